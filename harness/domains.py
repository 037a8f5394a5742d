"""Pick DDS domain ids that no other live test run on this machine holds."""

from __future__ import annotations

import fcntl
import os
import tempfile

# Both stacks map domain d to UDP ports from 7400 + 250 d. Above domain 100 those fall in Linux's
# ephemeral range (32768-60999), where any process's outgoing socket may already hold one: a sim then
# fails to start with "failed to bind to ANY:<port>: address in use" (seen with SDK domain 206). So both
# kinds share 11..100, split in two so that no ROS domain ever equals an SDK domain.
_ROS_RANGE = range(11, 56)
_SDK_RANGE = range(56, 101)
_held: list[int] = []  # open lock file descriptors, kept for the life of the process


def _lock(kind: str, candidates: range) -> int:
    start = os.getpid() % len(candidates)
    for k in range(len(candidates)):
        domain = candidates[(start + k) % len(candidates)]
        path = os.path.join(tempfile.gettempdir(), f"g1_mode_manager_test_{kind}_{domain}.lock")
        fd = os.open(path, os.O_CREAT | os.O_RDWR, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            continue
        _held.append(fd)
        return domain
    raise RuntimeError(f"no free {kind} DDS domain for this test run")


def allocate_run_domains() -> tuple[int, int]:
    """(ROS_DOMAIN_ID, Unitree SDK2 domain), each held by a file lock until this process exits."""
    return _lock("ros", _ROS_RANGE), _lock("sdk", _SDK_RANGE)


def allocate_sdk_domain() -> int:
    """One more Unitree SDK2 domain, held like the run's own (a second simulated robot on its own domain)."""
    return _lock("sdk", _SDK_RANGE)
