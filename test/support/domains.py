"""Pick DDS domain ids that no other live test run on this machine holds."""

from __future__ import annotations

import fcntl
import os
import tempfile

# ROS 2 domains 1..101 are safe with Fast DDS port mapping; Cyclone accepts 0..230.
_ROS_RANGE = range(11, 101)
_SDK_RANGE = range(120, 230)
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
