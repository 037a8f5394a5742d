"""g1ctl incidents: the flight recorder's incident files, oldest first, each with when it began, the mode and its
cause (the file's ``incident`` metadata), read from the folder itself: no node needs to run."""

from __future__ import annotations

from datetime import datetime
from pathlib import Path

from mcap.reader import make_reader

from g1_mode_manager.core.recorder.incidents import METADATA_NAME, IncidentFile, list_incidents


def describe(incident: IncidentFile) -> str:
    """One line: local time, mode, cause, size, path."""
    when = datetime.fromtimestamp(incident.began).astimezone().isoformat(sep=" ", timespec="milliseconds")
    try:
        with open(incident.path, "rb") as stream:
            meta = next((m.metadata for m in make_reader(stream).iter_metadata() if m.name == METADATA_NAME), {})
        mode, cause = meta.get("mode", "?"), meta.get("cause", incident.cause.value)
    except Exception as exc:  # a damaged file is listed, not fatal
        mode, cause = "?", f"unreadable: {type(exc).__name__}: {exc}"
    return f"{when}  {mode:<10} {cause}  ({incident.size / 1024:.0f} KiB) {incident.path}"


def print_incidents(folder: Path) -> int:
    found = list_incidents(folder)
    print(f"{len(found)} incident file(s) in {folder}")
    for incident in found:
        print(describe(incident))
    return 0
