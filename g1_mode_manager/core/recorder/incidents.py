"""Incident files: their folder, their names, how they are found and which go when the folder is full.

The name holds when the incident began and what began it (``incident_20261128T101502.123Z_fault.mcap``), so the
folder can be listed and rotated without opening a file; the cause's text and the mode are in the file's
``incident`` metadata. A file is written under a ``.part`` name and renamed when complete: a listing never
shows half a file.
"""

from __future__ import annotations

import calendar
import os
import re
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import Final

SUFFIX: Final = ".mcap"
PARTIAL: Final = ".part"
#: The MCAP metadata record that says what the file is: METADATA_KEYS, each a text.
METADATA_NAME: Final = "incident"
METADATA_KEYS: Final = ("cause", "mode", "began", "window_s", "after_s", "node")

_NAME = re.compile(r"^incident_(\d{8}T\d{6})\.(\d{3})Z_([a-z]+)" + re.escape(SUFFIX) + "$")


class Cause(StrEnum):
    FAULT = "fault"  # a body check's protective stop
    EMERGENCY = "emergency"  # an e-stop
    SNAPSHOT = "snapshot"  # ~/snapshot


@dataclass(frozen=True)
class IncidentFile:
    path: Path
    began: float  # UNIX time the incident began (from the name), s
    cause: Cause
    size: int  # bytes


def default_folder(env: Mapping[str, str] = os.environ) -> Path:
    """``$XDG_STATE_HOME/g1_mode_manager/incidents`` (``~/.local/state/...`` without it): kept across reboots,
    unlike /tmp, and the XDG place for a program's history and logs."""
    state = env.get("XDG_STATE_HOME") or str(Path(env.get("HOME") or Path.home()) / ".local" / "state")
    return Path(state) / "g1_mode_manager" / "incidents"


def folder_for(recorder_dir: str, env: Mapping[str, str] = os.environ) -> Path:
    """The folder a ``recorder_dir`` setting names: itself (``~`` expanded), or the default folder for ''. The node
    writes there and the console reads there, by the same rule."""
    return Path(recorder_dir).expanduser() if recorder_dir else default_folder(env)


def file_name(began: float, cause: Cause) -> str:
    whole = int(began)
    millis = int((began - whole) * 1000.0)
    return f"incident_{time.strftime('%Y%m%dT%H%M%S', time.gmtime(whole))}.{millis:03d}Z_{cause.value}{SUFFIX}"


def parse_name(name: str) -> tuple[float, Cause] | None:
    """(when it began, its cause) from an incident file's name; None for any other name."""
    match = _NAME.match(name)
    if match is None or match.group(3) not in Cause.__members__.values():
        return None
    began = calendar.timegm(time.strptime(match.group(1), "%Y%m%dT%H%M%S"))
    return began + int(match.group(2)) / 1000.0, Cause(match.group(3))


def list_incidents(folder: Path) -> list[IncidentFile]:
    """The complete incident files in ``folder``, oldest first; [] if there is no such folder."""
    found = []
    try:
        entries = list(os.scandir(folder))
    except (FileNotFoundError, NotADirectoryError):
        return []
    for entry in entries:
        parsed = parse_name(entry.name)
        if parsed is None or not entry.is_file():
            continue
        try:
            size = entry.stat().st_size
        except OSError:  # removed since the scan
            continue
        found.append(IncidentFile(Path(entry.path), parsed[0], parsed[1], size))
    found.sort(key=lambda f: (f.began, f.path.name))
    return found


def to_remove(files: Sequence[IncidentFile], *, max_files: int, max_bytes: int) -> list[IncidentFile]:
    """The oldest files to delete so that at most ``max_files`` remain, together at most ``max_bytes``; the newest
    stays even when it alone is larger."""
    keep = sorted(files, key=lambda f: (f.began, f.path.name))
    drop: list[IncidentFile] = []
    total = sum(f.size for f in keep)
    while len(keep) > 1 and (len(keep) > max_files or total > max_bytes):
        oldest = keep.pop(0)
        total -= oldest.size
        drop.append(oldest)
    return drop
