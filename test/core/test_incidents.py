"""Incident files: their names say when and why, the folder's default, listing and rotation."""

from __future__ import annotations

from pathlib import Path

from g1_mode_manager.core.recorder.incidents import (
    Cause,
    IncidentFile,
    default_folder,
    file_name,
    folder_for,
    list_incidents,
    parse_name,
    to_remove,
)


def test_a_name_says_when_the_incident_began_and_why() -> None:
    began = 1795000000.123  # 2026-11-18T...
    name = file_name(began, Cause.FAULT)
    assert name.startswith("incident_2026") and name.endswith("_fault.mcap")
    parsed = parse_name(name)
    assert parsed is not None
    assert abs(parsed[0] - began) < 0.001 and parsed[1] is Cause.FAULT
    assert parse_name(name + ".part") is None
    assert parse_name("incident_20261128T101502.123Z_other.mcap") is None
    assert parse_name("notes.txt") is None


def test_the_default_folder_is_the_users_state_folder() -> None:
    assert default_folder({"XDG_STATE_HOME": "/s", "HOME": "/h"}) == Path("/s/g1_mode_manager/incidents")
    assert default_folder({"HOME": "/h"}) == Path("/h/.local/state/g1_mode_manager/incidents")


def test_a_recorder_dir_names_its_folder_and_empty_names_the_default() -> None:
    """The one rule the node (where it writes) and the console (where it reads) share."""
    assert folder_for("", {"XDG_STATE_HOME": "/s"}) == Path("/s/g1_mode_manager/incidents")
    assert folder_for("/data/incidents", {"XDG_STATE_HOME": "/s"}) == Path("/data/incidents")
    assert folder_for("~/incidents") == Path.home() / "incidents"


def test_the_listing_shows_complete_incidents_oldest_first(tmp_path: Path) -> None:
    for began, cause in ((200.0, Cause.SNAPSHOT), (100.0, Cause.FAULT)):
        (tmp_path / file_name(began, cause)).write_bytes(b"x" * int(began))
    (tmp_path / (file_name(300.0, Cause.EMERGENCY) + ".part")).write_bytes(b"half")
    (tmp_path / "other.mcap").write_bytes(b"")
    found = list_incidents(tmp_path)
    assert [(f.cause, f.size) for f in found] == [(Cause.FAULT, 100), (Cause.SNAPSHOT, 200)]
    assert list_incidents(tmp_path / "missing") == []


def test_rotation_removes_the_oldest_by_count_and_by_size_but_never_the_newest() -> None:
    files = [IncidentFile(Path(f"{i}"), float(i), Cause.FAULT, 10) for i in range(5)]
    assert [f.began for f in to_remove(files, max_files=3, max_bytes=1000)] == [0.0, 1.0]
    assert [f.began for f in to_remove(files, max_files=10, max_bytes=25)] == [0.0, 1.0, 2.0]
    huge = [*files, IncidentFile(Path("5"), 5.0, Cause.FAULT, 10_000)]
    assert [f.path.name for f in to_remove(huge, max_files=10, max_bytes=100)] == ["0", "1", "2", "3", "4"]
