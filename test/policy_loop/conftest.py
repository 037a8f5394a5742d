"""Fixtures of the policy loop's tests (shared with the relay tests)."""

from fakes.worker_fixtures import clock, logs  # noqa: F401  (pytest finds fixtures by name)
