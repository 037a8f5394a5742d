"""The incident folder as the console sees it: the newest incident file, read once per version of it (its name,
size and modification time), and which file a download may serve.

The folder is the one the mode manager writes (``recorder_dir``, the same rule: core/recorder/incidents.py). A file
still being written (``.part``) is never listed, so never read; a damaged one is reported with why, never raised.
Reading is blocking file work: the web server runs it off its event loop.
"""

from __future__ import annotations

import hashlib
import os
import stat
import threading
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from g1_mode_manager.console.incident_series import UnreadableIncidentError, read_incident
from g1_mode_manager.core.recorder.incidents import IncidentFile, list_incidents, parse_name


class BadIncidentNameError(ValueError):
    """Not the name of an incident file (a path, a traversal, another file of the folder)."""


@dataclass(frozen=True)
class Latest:
    """``etag``: changes whenever ``payload`` does (another folder, another file, the file rewritten)."""

    etag: str
    payload: dict[str, Any]  # folder, incident (None, or read_incident's content, or its name and error)


class LastIncident:
    def __init__(self, folder: Callable[[], Path]) -> None:
        self._folder = folder
        self._lock = threading.Lock()  # two pages asking at once read a new file once
        self._cached: tuple[tuple[str, str, int, int], Latest] | None = None

    def latest(self) -> Latest:
        """The newest incident of the folder (by when it began, as its name says)."""
        folder = self._folder()
        with self._lock:
            found = list_incidents(folder)
            if not found:
                return self._keep((str(folder), "", 0, 0), {"folder": str(folder), "incident": None})
            newest = found[-1]
            try:
                st = newest.path.stat()
            except OSError:  # rotated away since the listing: the next look finds what replaced it
                return self._keep((str(folder), "", 0, 0), {"folder": str(folder), "incident": None})
            key = (str(folder), newest.path.name, st.st_size, st.st_mtime_ns)
            if self._cached is not None and self._cached[0] == key:
                return self._cached[1]
            incident = IncidentFile(newest.path, newest.began, newest.cause, st.st_size)
            try:
                content = read_incident(incident)
            except UnreadableIncidentError as exc:
                content = {"name": incident.path.name, "size": incident.size, "began": incident.began,
                           "kind": incident.cause.value, "error": f"{incident.path.name} cannot be read: {exc}"}
            return self._keep(key, {"folder": str(folder), "incident": content})

    def _keep(self, key: tuple[str, str, int, int], payload: dict[str, Any]) -> Latest:
        etag = '"' + hashlib.sha256(repr(key).encode()).hexdigest()[:20] + '"'
        latest = Latest(etag, payload)
        self._cached = (key, latest)
        return latest

    def file(self, name: str) -> Path | None:
        """The incident file ``name`` of the folder (a regular file, not a link), None if there is none;
        BadIncidentNameError for anything that is not an incident file's bare name."""
        if parse_name(name) is None or os.path.basename(name) != name:
            raise BadIncidentNameError(f"not an incident file's name: {name!r}")
        path = self._folder() / name
        try:
            st = path.lstat()
        except OSError:
            return None
        return path if stat.S_ISREG(st.st_mode) else None
