"""Fixtures of the display tests (shared with the relay tests)."""

from fakes.worker_fixtures import clock, events, logs  # noqa: F401  (pytest finds fixtures by name)
