"""Subprocess management (``harness.processes``, shared with the benchmarks), under the name the tests import."""

from harness.processes import ManagedProcess, python_module

__all__ = ["ManagedProcess", "python_module"]
