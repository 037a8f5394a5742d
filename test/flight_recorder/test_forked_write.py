"""A write done by a forked child: its answer comes back, its memory and its failures stay in the child."""

from __future__ import annotations

import os
import signal
import time

import pytest

from g1_mode_manager.flight_recorder.forked_write import ChildWriteError, in_child


def _rss_kb() -> int:
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith("VmRSS"))


def test_the_write_runs_in_another_process_and_its_count_comes_back(tmp_path) -> None:
    seen: list[int] = []

    def write() -> int:
        seen.append(os.getpid())  # the child's copy of the list
        (tmp_path / "out").write_text(str(os.getpid()))
        return 1234

    assert in_child(write, 10.0) == 1234
    child = int((tmp_path / "out").read_text())
    assert child != os.getpid()
    assert seen == []  # nothing the child did touched this process's objects


def test_what_the_child_allocates_never_lands_in_this_process() -> None:
    before = _rss_kb()

    def write() -> int:
        big = [float(i) for i in range(2_000_000)]  # about 64 MB of Python objects, alive until the child exits
        return len(big)

    assert in_child(write, 30.0) == 2_000_000
    assert _rss_kb() - before < 8_000  # kB


def test_an_exception_in_the_child_is_raised_here_with_its_type_and_text() -> None:
    def write() -> int:
        raise OSError(28, "No space left on device")

    with pytest.raises(ChildWriteError, match=r"OSError: \[Errno 28\] No space left on device"):
        in_child(write, 10.0)


def test_a_child_that_does_not_answer_in_time_is_killed(tmp_path) -> None:
    def write() -> int:
        (tmp_path / "pid").write_text(str(os.getpid()))
        time.sleep(60.0)
        return 0

    started = time.monotonic()
    with pytest.raises(TimeoutError, match=r"did not end within 0\.5 s"):
        in_child(write, 0.5)
    assert time.monotonic() - started < 10.0
    with pytest.raises(ProcessLookupError):  # killed and reaped
        os.kill(int((tmp_path / "pid").read_text()), 0)


def test_a_child_that_dies_without_answering_is_an_error_with_its_exit() -> None:
    def write() -> int:
        os.kill(os.getpid(), signal.SIGKILL)
        return 0

    with pytest.raises(ChildWriteError, match=r"without an answer \(exit -9\)"):
        in_child(write, 10.0)


def test_where_no_child_can_be_made_the_write_runs_here(monkeypatch) -> None:
    def refuse() -> int:
        raise BlockingIOError(11, "Resource temporarily unavailable")

    monkeypatch.setattr(os, "fork", refuse)
    assert in_child(os.getpid, 10.0) == os.getpid()
