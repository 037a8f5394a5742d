"""The flight recorder: a stop entered writes the window around it once, ~/snapshot writes at once, the folder is
rotated, an unwritable folder is reported and never raised, and no hook ever waits for a file."""

from __future__ import annotations

import os
import threading
import time
from pathlib import Path

from mcap.reader import make_reader

from g1_mode_manager.core.body.readings import BodyReadings
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.recorder.events import Kind
from g1_mode_manager.core.recorder.incidents import Cause, list_incidents
from g1_mode_manager.core.records import MachineStatus
from g1_mode_manager.flight_recorder.flight_recorder import PRUNE_PERIOD_S, FlightRecorder, RecorderConfig
from support.mode_manager import wait_until

VERDICTS = ("ok",) * 10


def _status(mode: Mode, version: int, faults: tuple[str, ...] = ()) -> MachineStatus:
    return MachineStatus(mode, False, None, True, True, False, "", "", version=version, faults=faults)


def _recorder(folder: Path, logs: list, **config) -> FlightRecorder:
    config = {"enabled": True, "window_s": 5.0, "after_s": 0.3, "max_files": 50, "max_bytes": 1 << 30, "frame_rate_hz": 10.0,
              "body_rate_hz": 100.0, "node": "/g1_mode_manager", **config}
    recorder = FlightRecorder(RecorderConfig(folder, **config), log=lambda level, text: logs.append((level, text)))
    recorder.start()
    return recorder


def _metadata(path: Path) -> dict[str, str]:
    with open(path, "rb") as stream:
        return next(m.metadata for m in make_reader(stream).iter_metadata() if m.name == "incident")


def _tilts(path: Path) -> list[float]:
    from mcap_ros2.decoder import DecoderFactory

    with open(path, "rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        return [m.data for *_, m in reader.iter_decoded_messages(topics=["/recorder/body/tilt_rad"])]


def test_a_stop_writes_the_window_before_it_and_the_after_window(tmp_path: Path) -> None:
    logs: list = []
    recorder = _recorder(tmp_path, logs)
    try:
        recorder.on_status(_status(Mode.HIGH_LEVEL, 1))
        recorder.body_step(BodyReadings(tilt_rad=0.1), VERDICTS)
        recorder.on_status(_status(Mode.FAULT, 2, ("tilt: 1.20 rad > 1.00",)))
        assert recorder.report().pending.startswith("FAULT from HIGH_LEVEL")
        time.sleep(0.1)
        recorder.body_step(BodyReadings(tilt_rad=1.3), VERDICTS)  # inside the after-window
        recorder.on_status(_status(Mode.EMERGENCY, 3))  # a second stop joins the first one's incident
        assert wait_until(lambda: list_incidents(tmp_path), 5.0)
    finally:
        recorder.stop()
    [incident] = list_incidents(tmp_path)
    assert incident.cause is Cause.FAULT
    meta = _metadata(incident.path)
    assert meta["cause"] == "FAULT from HIGH_LEVEL: tilt: 1.20 rad > 1.00; then EMERGENCY from FAULT"
    assert meta["mode"] == "EMERGENCY" and meta["window_s"] == "5" and meta["node"] == "/g1_mode_manager"
    assert float(meta["after_s"]) >= 0.3
    assert _tilts(incident.path) == [0.1, 1.3]
    report = recorder.report()
    assert report.last_file == str(incident.path) and report.pending == "" and report.error == ""
    assert recorder.warnings() == ()
    assert any("incident written" in text for _level, text in logs)


def test_the_window_is_read_in_the_writing_child_not_in_the_node(tmp_path: Path) -> None:
    """What a window's copy and sort allocate must never land in the node's heap: the ring is read where the file
    is written."""
    recorder = _recorder(tmp_path / "incidents", [])
    read_by = tmp_path / "read_by"
    entries = recorder.ring.entries

    def entries_noting_the_reader(start: float, end: float):
        read_by.write_text(str(os.getpid()))
        return entries(start, end)

    recorder.ring.entries = entries_noting_the_reader  # type: ignore[method-assign]
    try:
        recorder.on_status(_status(Mode.IDLE, 1))
        recorder.body_step(BodyReadings(tilt_rad=0.2), VERDICTS)
        ok, path = recorder.snapshot()
    finally:
        recorder.stop()
    assert ok, path
    assert int(read_by.read_text()) != os.getpid()
    assert _tilts(Path(path)) == [0.2]  # the child's copy of the ring held what the node had added


def test_a_snapshot_is_written_at_once_and_the_folder_rotated(tmp_path: Path) -> None:
    recorder = _recorder(tmp_path, [], max_files=2)
    try:
        recorder.on_status(_status(Mode.IDLE, 1))
        paths = []
        for _ in range(3):
            ok, path = recorder.snapshot()
            assert ok, path
            paths.append(path)
    finally:
        recorder.stop()
    assert [str(f.path) for f in list_incidents(tmp_path)] == paths[1:]
    assert _metadata(Path(paths[-1]))["mode"] == "IDLE"


def test_a_recorder_turned_off_keeps_nothing_writes_nothing_and_refuses_a_snapshot(tmp_path: Path) -> None:
    recorder = _recorder(tmp_path, [], enabled=False, after_s=0.0)
    try:
        recorder.on_status(_status(Mode.HIGH_LEVEL, 1))
        recorder.service_answer("set_mode", "high_level", True, "ok")
        recorder.estop_step("request", "/g1_mode_manager/estop")
        recorder.on_status(_status(Mode.EMERGENCY, 2))
        ok, message = recorder.snapshot()
        time.sleep(0.2)  # an enabled recorder writes the stop's incident within this (its after-window is 0 s)
    finally:
        recorder.stop()
    assert not ok and "recorder_enabled false" in message
    assert list_incidents(tmp_path) == [] and not any(tmp_path.iterdir())
    assert not any(recorder.ring.counts().values())
    assert recorder.report().enabled is False


def test_the_recorder_keeps_a_window_and_no_more_however_large_its_caps(tmp_path: Path) -> None:
    """The caps are sized for each kind's busiest rate: a slow load would fill them for minutes. The recorder's
    thread drops what no incident can hold any more, within a period of it."""
    now = [1000.0]
    recorder = FlightRecorder(RecorderConfig(tmp_path, enabled=True, window_s=5.0, after_s=0.3, max_files=50,
                                             max_bytes=1 << 30, frame_rate_hz=10.0, body_rate_hz=100.0,
                                             node="/g1_mode_manager"),
                              log=lambda level, text: None, clock=lambda: now[0])
    recorder.start()
    try:
        recorder.on_status(_status(Mode.HIGH_LEVEL, 1))
        for i in range(20):
            recorder.note("info", f"old {i}")
        now[0] += 5.0 + 2.0 * PRUNE_PERIOD_S + 1.0  # older than a window and the slack
        recorder.note("info", "new")
        assert wait_until(lambda: recorder.ring.counts()[Kind.NOTE] == 1, 3.0 * PRUNE_PERIOD_S + 2.0)
        assert recorder.ring.counts()[Kind.STATUS] == 1  # the mode the window begins in stays
        # what /diagnostics says it keeps: the pruned ring (a note and the status), by the ring's own count
        assert wait_until(lambda: recorder.report().kept_events == 2, 3.0 * PRUNE_PERIOD_S + 2.0), recorder.report()
        assert recorder.report().kept_bytes == recorder.ring.approx_bytes() > 0
        ok, path = recorder.snapshot()
    finally:
        recorder.stop()
    assert ok, path
    assert _metadata(Path(path))["mode"] == "HIGH_LEVEL"


def test_an_unwritable_folder_is_reported_and_nothing_raises(tmp_path: Path) -> None:
    (tmp_path / "a_file").write_text("")
    folder = tmp_path / "a_file" / "incidents"
    logs: list = []
    recorder = _recorder(folder, logs, after_s=0.05)
    try:
        assert wait_until(lambda: recorder.report().error != "", 5.0)
        assert "cannot create" in recorder.report().error
        assert recorder.warnings() == (f"recorder: no incident can be written: cannot create {folder}: Not a directory",)
        ok, why = recorder.snapshot()
        assert not ok and why == f"no incident written: cannot create {folder}: Not a directory"
        recorder.on_status(_status(Mode.FAULT, 1, ("tilt",)))
        assert wait_until(lambda: recorder.report().pending == "", 5.0)
        assert recorder.report().error == f"cannot create {folder}: Not a directory"
    finally:
        recorder.stop()
    errors = [text for level, text in logs if level == "error"]
    assert len(errors) == 1, errors  # logged once, however often it is found


def test_no_hook_waits_for_a_file_being_written(tmp_path: Path) -> None:
    recorder = _recorder(tmp_path, [])
    writing, release = threading.Event(), threading.Event()
    write = recorder._folder.write

    def slow_write(*args, **kwargs):
        writing.set()
        release.wait(10.0)
        return write(*args, **kwargs)

    recorder._folder.write = slow_write  # type: ignore[method-assign]
    try:
        threading.Thread(target=recorder.snapshot, daemon=True).start()
        assert writing.wait(5.0)
        start = time.monotonic()
        for version in range(2, 200):
            recorder.on_status(_status(Mode.FAULT if version % 2 else Mode.HIGH_LEVEL, version))
            recorder.body_step(BodyReadings(tilt_rad=0.1), VERDICTS)
        took = time.monotonic() - start
        assert recorder.report().pending  # the stops were taken while the file was being written
        assert took < 0.5, f"the hooks waited {took:.3f} s"
    finally:
        release.set()
        recorder.stop()


def test_stopping_writes_a_pending_stop_at_once(tmp_path: Path) -> None:
    recorder = _recorder(tmp_path, [], after_s=60.0)
    recorder.on_status(_status(Mode.EMERGENCY, 1))
    start = time.monotonic()
    recorder.stop()
    assert time.monotonic() - start < 2.0
    [incident] = list_incidents(tmp_path)
    assert incident.cause is Cause.EMERGENCY and _metadata(incident.path)["cause"] == "EMERGENCY from UNINITIALIZED"
