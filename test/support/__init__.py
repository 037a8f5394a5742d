"""Test support: fixtures, scripted robots and clients. The process harness it shares with the benchmarks is
``harness/`` (re-exported here under the names the tests import)."""
