"""The soak run (``make soak MINUTES=30``): the real node and sim under a steady random load for a long time,
its resources sampled and judged for growth, every node lifetime judged by the chaos invariants and its flight
recorder's incident folder by the recorder's limits.

Only the ``test_*.py`` files here are collected by pytest (fast unit tests of the pure parts: the load's
schedule, the growth rule, the report, the incident folder's judge); the run itself is ``python -m soak`` with
``test/`` on the path. See docs/soak.md.
"""
