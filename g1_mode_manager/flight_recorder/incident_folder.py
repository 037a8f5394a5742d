"""The incident folder: whether it can be written, one incident written into it whole, the oldest removed.

Synchronous, and only ever called from the flight recorder's own thread; the file itself is written by a forked
child (forked_write: the conversion's memory never lands in the node). A file goes out under a ``.part`` name and
is renamed once synced, by the child, so a listing (``g1ctl incidents``) never shows half a file and a node that
stops meanwhile still leaves the whole one; after each write the oldest incidents go until at most ``max_files``
remain, together at most ``max_bytes``.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Final

from g1_mode_manager.core.recorder.incidents import PARTIAL, SUFFIX, Cause, file_name, list_incidents, to_remove
from g1_mode_manager.core.recorder.ring import Entry
from g1_mode_manager.flight_recorder.forked_write import in_child
from g1_mode_manager.flight_recorder.incident_writer import write_incident

#: The longest an incident's child may take to write it (a full window takes about a second), s.
WRITE_TIMEOUT_S: Final = 30.0


class IncidentFolder:
    def __init__(self, folder: Path, *, max_files: int, max_bytes: int) -> None:
        self.folder = folder
        self._max_files = max_files
        self._max_bytes = max_bytes

    def check(self) -> str:
        """'' if incidents can be written here (the folder made if missing; a file left half written by a process
        that died is removed), else why not."""
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            return f"cannot create {self.folder}: {exc.strerror or exc}"
        if not os.access(self.folder, os.W_OK | os.X_OK):
            return f"{self.folder} is not writable"
        for stale in self.folder.glob(f"incident_*{SUFFIX}{PARTIAL}"):
            stale.unlink(missing_ok=True)
        return ""

    def write(self, began: float, cause: Cause, window: Callable[[], Sequence[Entry]], metadata: Mapping[str, str],
              *, to_unix: Callable[[float], float]) -> tuple[Path, int]:
        """Write one incident (``began``: UNIX time, for its name) of the entries ``window`` gives; returns its path
        and message count. Raises OSError when the folder cannot take it (nothing is left behind then).

        ``window`` is called in the child, on its copy of the ring: the copies, the filtering and the sort of a
        window's entries are tens of thousands of objects and a few lists of pointers, and made in the node, they
        would raise its allocators' high-water mark at every incident (the node's RSS stepping up by about a
        hundred kB each, docs/soak.md)."""
        self.folder.mkdir(parents=True, exist_ok=True)
        path = self.folder / file_name(began, cause)
        while path.exists():  # two incidents in one millisecond
            began += 0.001
            path = self.folder / file_name(began, cause)
        part = path.with_name(path.name + PARTIAL)

        def write() -> int:
            count = write_incident(part, window(), metadata, to_unix=to_unix)
            os.replace(part, path)
            return count

        try:
            count = in_child(write, WRITE_TIMEOUT_S)
        except BaseException:
            part.unlink(missing_ok=True)
            raise
        self._rotate()
        return path, count

    def _rotate(self) -> None:
        for old in to_remove(list_incidents(self.folder), max_files=self._max_files, max_bytes=self._max_bytes):
            old.path.unlink(missing_ok=True)
