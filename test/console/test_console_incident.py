"""The Last incident card's reading side, on real incident files written by the product's own writer (the flight
ring's events, the robot port's recording of calls and odometry, the incident folder's naming and renaming): the
summary, the plot series and the e-stop's steps in seconds from the stop; the newest complete file of a folder,
read once per version; a file still being written never read; a damaged file reported, not raised; only incident
files' bare names served."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from g1_mode_manager.console.incident_series import MAX_POINTS, UnreadableIncidentError, read_incident
from g1_mode_manager.console.last_incident import BadIncidentNameError, LastIncident
from g1_mode_manager.core.recorder.incidents import PARTIAL, Cause, file_name, list_incidents
from support.incident_files import AFTER_S, EPOCH, STOP, VIA, WINDOW_S, estop_incident


def _incident(folder: Path) -> dict:
    return read_incident(list_incidents(folder)[-1])


def test_an_estop_reads_as_its_summary_series_modes_and_steps_in_seconds_from_the_stop(tmp_path: Path) -> None:
    estop_incident(tmp_path)
    inc = _incident(tmp_path)
    assert inc["kind"] == "emergency" and inc["mode"] == "EMERGENCY" and inc["cause"] == f"EMERGENCY from HIGH_LEVEL ({VIA})"
    assert inc["began"] == pytest.approx(EPOCH + STOP) and (inc["start"], inc["end"]) == (-WINDOW_S, AFTER_S)
    s = inc["series"]
    # walking from -5 s to -1 s, a StopMove at -1 s
    assert s["cmd_vx"][0] == pytest.approx([-5.0, 0.3]) and s["cmd_vx"][-1] == pytest.approx([-1.0, 0.0])
    assert s["cmd_wz"][0] == pytest.approx([-5.0, 0.1]) and s["cmd_wz"][-1][1] == 0.0
    # the odometry's velocity along the frame's y is the body's forward speed, each sample once
    assert len(s["meas_vx"]) == 20 and all(v == pytest.approx(0.25) for _t, v in s["meas_vx"])
    assert all(v == pytest.approx(0.2) for _t, v in s["meas_wz"])
    assert s["tilt"][0] == pytest.approx([-5.0, 0.05]) and s["tilt"][-1] == pytest.approx([0.501, 0.4])
    assert inc["modes"] == [[-WINDOW_S, "HIGH_LEVEL"], [0.0, "EMERGENCY"]]
    steps = [(st["step"], st["t"]) for st in inc["steps"]]
    assert [name for name, _t in steps] == ["DampNoReply sent", "e-stop request", "EMERGENCY entered", "Damp request",
                                            "Damp answer", "damp_confirmed", "e-stop answer"], steps
    assert all(t == pytest.approx(0.0, abs=1e-6) for _n, t in steps[:3]) and steps[3][1] == pytest.approx(0.001)
    assert steps[-1][1] == pytest.approx(0.501)
    assert inc["steps"][0]["detail"] == "" and inc["steps"][1]["detail"] == VIA and inc["steps"][4]["detail"].startswith("code 0")
    assert inc["steps"][-1]["detail"] == "success=True: e-stop: robot damped"


def test_a_long_series_is_thinned_with_its_peak_kept(tmp_path: Path) -> None:
    estop_incident(tmp_path, tilts=3 * MAX_POINTS)
    tilt = _incident(tmp_path)["series"]["tilt"]
    assert len(tilt) <= MAX_POINTS + 2
    assert max(v for _t, v in tilt) == 1.5
    assert [t for t, _v in tilt] == sorted(t for t, _v in tilt)


def test_a_damaged_file_raises_with_why(tmp_path: Path) -> None:
    path = estop_incident(tmp_path)
    data = path.read_bytes()
    for damaged in (data[: len(data) // 2], b"not an mcap file at all", b""):
        path.write_bytes(damaged)
        with pytest.raises(UnreadableIncidentError) as caught:
            _incident(tmp_path)
        assert str(caught.value), damaged[:10]


def test_the_newest_complete_file_is_read_once_per_version_and_a_part_file_never(tmp_path: Path) -> None:
    folder = tmp_path / "incidents"
    last = LastIncident(lambda: folder)
    assert last.latest().payload == {"folder": str(folder), "incident": None}  # no folder yet
    older = estop_incident(folder, began=EPOCH + STOP)
    newer = estop_incident(folder, began=EPOCH + STOP + 60.0)
    first = last.latest()
    assert first.payload["incident"]["name"] == newer.name and first.payload["folder"] == str(folder)
    assert last.latest() is first  # the same version: not read again

    # a newer incident still being written: never read, the complete one stays the last
    (folder / (file_name(EPOCH + STOP + 120.0, Cause.EMERGENCY) + PARTIAL)).write_bytes(b"half an incident")
    assert last.latest() is first

    # the file rewritten (another size and time): read again, with a new etag
    shutil.copyfile(older, newer.with_suffix(".tmp"))
    os.replace(newer.with_suffix(".tmp"), newer)
    os.utime(newer, ns=(0, 10**18))
    again = last.latest()
    assert again is not first and again.etag != first.etag and again.payload["incident"]["name"] == newer.name


def test_a_damaged_newest_file_is_reported_on_the_card_not_raised(tmp_path: Path) -> None:
    good = estop_incident(tmp_path, began=EPOCH + STOP)
    bad = estop_incident(tmp_path, began=EPOCH + STOP + 60.0)
    bad.write_bytes(bad.read_bytes()[:1000])  # truncated: a disk that filled, a copy cut short
    incident = LastIncident(lambda: tmp_path).latest().payload["incident"]
    assert incident["name"] == bad.name and incident["size"] == 1000 and incident["kind"] == "emergency"
    assert incident["error"].startswith(f"{bad.name} cannot be read: "), incident
    assert "series" not in incident
    assert good.exists()


def test_only_an_incident_files_bare_name_is_served(tmp_path: Path) -> None:
    folder = tmp_path / "incidents"
    path = estop_incident(folder)
    outside = tmp_path / path.name  # the same name outside the folder
    outside.write_bytes(b"secret")
    last = LastIncident(lambda: folder)
    assert last.file(path.name) == path
    for bad in ("../" + path.name, f"{folder}/{path.name}", "..", "", "passwd", path.name + ".part",
                path.name.replace(".mcap", ".txt"), "incident_x.mcap", path.name + "/", "sub/" + path.name,
                path.name.replace("emergency", "EMERGENCY"), path.name + "\x00"):
        with pytest.raises(BadIncidentNameError):
            last.file(bad)
    absent = path.name.replace("emergency", "fault")
    assert last.file(absent) is None
    (folder / absent).symlink_to(outside)  # a link in the folder is not one of its files
    assert last.file(absent) is None
