"""What the tests and the benchmarks both use to run the product: DDS domains of their own, the node and
the sim bridge in subprocesses, the sim's record. Importable from the repository root (``python -m pytest``,
``python -m bench.run``); nothing here imports from ``test/``."""
