"""Fixtures of the relay tests (shared with the display tests)."""

from fakes.worker_fixtures import clock, events, logs  # noqa: F401  (pytest finds fixtures by name)
