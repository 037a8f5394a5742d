"""DDS domains of a run (``harness.domains``, shared with the benchmarks), under the name the tests import."""

from harness.domains import allocate_run_domains, allocate_sdk_domain

__all__ = ["allocate_run_domains", "allocate_sdk_domain"]
