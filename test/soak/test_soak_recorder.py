"""The soak's judge of the flight recorder's folder (soak.recorder), on real incident files written by the product's
own writer: the limits with the newest always kept, the oldest going first and no more than needed, no ``.part``
left, every file read to its end, the e-stop's file there."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from g1_mode_manager.core.recorder.events import Note
from g1_mode_manager.core.recorder.incidents import Cause, list_incidents
from g1_mode_manager.core.recorder.ring import FlightRing, caps_for
from g1_mode_manager.flight_recorder.incident_folder import IncidentFolder
from soak.recorder import Limits, RecorderLedger, judge_folder, read_incident, written_in_log
from support.incident_files import estop_incident

T0 = 1_795_000_000.0  # UNIX time of the first file
MB = 1_000_000  # the parameter is in MB (node/settings.py BYTES_PER_MB)


def _incident(folder: Path, began: float, cause: Cause, text: str, notes: int = 5) -> Path:
    """A file as the flight recorder writes it (through the incident folder), of ``notes`` incompressible notes."""
    ring = FlightRing(caps_for(10.0), clock=lambda: 0.0)
    for _ in range(notes):
        ring.add(Note("info", os.urandom(300).hex()), 0.0)
    metadata = {"cause": text, "mode": "IDLE", "began": f"{began:.3f}", "window_s": "10", "after_s": "0",
                "node": "/g1_mode_manager"}
    path, _count = IncidentFolder(folder, max_files=10**6, max_bytes=10**12).write(
        began, cause, lambda: ring.entries(-1.0, 1.0), metadata, to_unix=lambda t: t + began)
    return path


def _snapshot(folder: Path, began: float, notes: int = 5) -> Path:
    return _incident(folder, began, Cause.SNAPSHOT, "~/snapshot", notes)


def _estop(folder: Path, began: float) -> Path:
    return estop_incident(folder, began=began)


def _written(folder: Path) -> dict[str, int | None]:
    return {f.path.name: f.size for f in list_incidents(folder)}


def _judge(folder: Path, limits: Limits, written: dict[str, int | None] | None = None,
           estop_wall: float = T0 + 100.0) -> list[str]:
    return judge_folder(folder, limits, _written(folder) if written is None else written, estop_wall=estop_wall,
                        after_s=1.0).violations


def test_a_folder_within_its_limits_with_the_estop_s_file_passes(tmp_path: Path) -> None:
    _snapshot(tmp_path, T0 + 10.0)
    _incident(tmp_path, T0 + 20.0, Cause.FAULT, "FAULT from LOW_LEVEL: state_lost")
    estop = _estop(tmp_path, T0 + 100.2)
    verdict = judge_folder(tmp_path, Limits(3, 1.0), _written(tmp_path), estop_wall=T0 + 100.0, after_s=1.0)
    assert verdict.violations == []
    assert verdict.estop_file == estop.name and len(verdict.kept) == 3
    check = read_incident(estop)
    assert check.messages > 0 and check.cause.startswith("EMERGENCY from HIGH_LEVEL") and not check.error


def test_more_files_than_max_files_is_a_violation(tmp_path: Path) -> None:
    for k in range(3):
        _snapshot(tmp_path, T0 + k)
    _estop(tmp_path, T0 + 100.0)
    assert _judge(tmp_path, Limits(4, 1.0)) == []
    [bad] = _judge(tmp_path, Limits(3, 1.0))
    assert "4 incident files kept, recorder_max_files 3" in bad


def test_the_size_limit_holds_unless_the_newest_alone_exceeds_it(tmp_path: Path) -> None:
    _snapshot(tmp_path, T0, notes=40)
    _estop(tmp_path, T0 + 100.0)
    total = sum(f.size for f in list_incidents(tmp_path))
    assert _judge(tmp_path, Limits(10, total / MB)) == []
    [bad] = _judge(tmp_path, Limits(10, (total - 1) / MB))
    assert f"take {total} bytes" in bad
    (tmp_path / list_incidents(tmp_path)[0].path.name).unlink()  # the newest alone, larger than the limit: kept
    assert _judge(tmp_path, Limits(10, 1 / MB), written={}) == []


def test_a_part_file_left_behind_is_a_violation(tmp_path: Path) -> None:
    _estop(tmp_path, T0 + 100.0)
    (tmp_path / "incident_20261129T000000.000Z_fault.mcap.part").write_bytes(b"half")
    [bad] = _judge(tmp_path, Limits(5, 1.0))
    assert "half-written" in bad and ".part" in bad


@pytest.mark.parametrize("keep", [0.5, 0.98])
def test_a_file_that_does_not_read_to_its_end_is_a_violation(tmp_path: Path, keep: float) -> None:
    snapshot = _snapshot(tmp_path, T0, notes=20)
    _estop(tmp_path, T0 + 100.0)
    data = snapshot.read_bytes()
    snapshot.write_bytes(data[: int(len(data) * keep)])  # a torn write: its index or its footer missing
    [bad] = _judge(tmp_path, Limits(5, 1.0))
    assert snapshot.name in bad and "does not read to its end" in bad


def test_no_file_of_the_estop_is_a_violation(tmp_path: Path) -> None:
    _estop(tmp_path, T0)  # an EMERGENCY of an earlier lifetime
    _snapshot(tmp_path, T0 + 99.5)  # and a file of this one, but no EMERGENCY in it
    [bad] = _judge(tmp_path, Limits(5, 1.0), estop_wall=T0 + 100.0)
    assert "the e-stop made no incident file with cause EMERGENCY" in bad


def test_an_estop_joined_to_a_fault_just_before_counts_as_the_estop_s_file(tmp_path: Path) -> None:
    joined = _incident(tmp_path, T0 + 99.4, Cause.FAULT,
                       "FAULT from LOW_LEVEL: state_lost; then EMERGENCY from FAULT (/g1_mode_manager/estop)")
    verdict = judge_folder(tmp_path, Limits(5, 1.0), _written(tmp_path), estop_wall=T0 + 100.0, after_s=1.0)
    assert verdict.violations == [] and verdict.estop_file == joined.name


def test_a_newer_file_removed_while_an_older_one_stays_is_a_violation(tmp_path: Path) -> None:
    old = _snapshot(tmp_path, T0)
    gone = _snapshot(tmp_path, T0 + 1.0)
    _estop(tmp_path, T0 + 100.0)
    written = _written(tmp_path)
    gone.unlink()
    [bad] = _judge(tmp_path, Limits(5, 1.0), written)
    assert f"{gone.name} removed while the older {old.name} was kept" in bad


def test_the_newest_written_must_stay(tmp_path: Path) -> None:
    _estop(tmp_path, T0 + 100.0)
    newest = _snapshot(tmp_path, T0 + 101.0)
    written = _written(tmp_path)
    newest.unlink()
    [bad] = _judge(tmp_path, Limits(5, 1.0), written)
    assert f"{newest.name} removed while the older" in bad


def test_removing_more_than_the_limits_ask_is_a_violation(tmp_path: Path) -> None:
    first = _snapshot(tmp_path, T0)
    _snapshot(tmp_path, T0 + 1.0)
    _estop(tmp_path, T0 + 100.0)
    written = _written(tmp_path)
    first.unlink()
    [bad] = _judge(tmp_path, Limits(3, 1.0), written)  # three fit: the first should have stayed
    assert f"{first.name} ({written[first.name]} bytes) removed though it fitted" in bad
    assert _judge(tmp_path, Limits(2, 1.0), written) == []  # by count
    kept = sum(f.size for f in list_incidents(tmp_path))
    assert _judge(tmp_path, Limits(3, (kept + written[first.name] - 1) / MB), written) == []  # by size
    assert _judge(tmp_path, Limits(3, 1.0), {**written, first.name: None}) == []  # its size never seen: not judged


def test_the_node_s_log_names_the_files_it_wrote() -> None:
    output = ("[INFO] [1795000000.1] [g1_mode_manager]: flight recorder: incident written to /tmp/x y/"
              "incident_20261129T025953.245Z_snapshot.mcap (~/snapshot; 812 messages)\n"
              "[INFO] [1795000001.2] [g1_mode_manager]: flight recorder: incident written to "
              "/tmp/i/incident_20261129T025955.302Z_emergency.mcap (EMERGENCY from IDLE (/estop); 3 messages)\n"
              "[INFO] [g1_mode_manager]: mode IDLE\n")
    assert written_in_log(output) == ["incident_20261129T025953.245Z_snapshot.mcap",
                                      "incident_20261129T025955.302Z_emergency.mcap"]


def test_the_ledger_counts_every_file_written_and_reports_one_line(tmp_path: Path) -> None:
    folder = tmp_path / "incidents"
    ledger = RecorderLedger(folder, Limits(2, 1.0), after_s=1.0)
    assert ledger.node_params() == (f"recorder_dir:={folder}", "recorder_max_files:=2",
                                    "recorder_max_total_mb:=1.0", "recorder_after_s:=1.0")
    ledger.lifetime_starts()
    first = _snapshot(folder, T0)
    ledger.snapshot_answered(str(first))
    second = _snapshot(tmp_path, T0 + 1.0)  # written and rotated away unseen: only the node's log names it
    _estop(folder, T0 + 100.0)
    shutil.move(second, folder / second.name)
    first.unlink()  # the rotation at two files
    log = f"flight recorder: incident written to {folder / second.name} (~/snapshot; 5 messages)\n"
    assert ledger.estop_file_there(T0 + 100.0)
    assert ledger.judge(0, log, estop_wall=T0 + 100.0, estop_before_stop=True) == []
    [lifetime] = ledger.lifetimes
    assert (lifetime.written, lifetime.removed, lifetime.limit, lifetime.kept) == (3, 1, "count", 2)
    assert lifetime.estop_before_stop
    assert ledger.largest_total == lifetime.total_bytes > 0
    line = ledger.summary()
    assert line.startswith("recorder: 3 incident files written (1 emergency, 2 snapshot), 2 kept at the end (")
    assert "1 rotated away (at the count limit after 1 lifetimes, the size limit after 0)" in line
    assert line.endswith("limits 2 files, 1 MB (976.6 KiB)") and "\n" not in line
    assert ledger.sizes_line().startswith("Incident sizes seen: emergency 1: ")
    assert len(ledger.table()) == 3

    ledger.lifetime_starts()  # the next lifetime: one more file, and the size limit takes two of the three
    ledger.snapshot_answered(str(_snapshot(folder, T0 + 200.0, notes=400)))
    big = _estop(folder, T0 + 300.0)
    for old in list_incidents(folder)[:-1]:
        old.path.unlink()
    ledger.limits = Limits(2, (big.stat().st_size + 1) / MB)
    assert ledger.judge(1, "", estop_wall=T0 + 300.0, estop_before_stop=False) == []
    assert (ledger.lifetimes[1].written, ledger.lifetimes[1].removed, ledger.lifetimes[1].limit) == (2, 3, "size")
