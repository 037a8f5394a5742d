"""The flight recorder's files over the soak: every node lifetime writes into one incident folder (so rotation works
across lifetimes), and after each lifetime, with its node stopped, the folder is judged against docs/recorder.md:

- at most ``recorder_max_files`` complete files, together at most ``recorder_max_total_mb``, except that the newest
  stays even when it alone is larger (flight_recorder/incident_folder.py, ``to_remove``: the oldest go while more than one is
  left and either limit is exceeded);
- the oldest went first: every file written after the oldest one kept is still there, the newest written included;
- no more went than the limits asked for: the newest file removed would not have fitted beside those kept (judged
  where its size was seen);
- no ``.part`` file is left behind;
- every file opens with the ``mcap`` library's reader and its messages read to the end (CRCs checked);
- the lifetime's e-stop made a file whose cause is EMERGENCY.

Rotation itself is judged by this module's own reading of the rule, not by the product's function that does it.
"""

from __future__ import annotations

import re
import statistics
import threading
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from g1_mode_manager.core.recorder.incidents import PARTIAL, SUFFIX, IncidentFile, list_incidents, parse_name
from g1_mode_manager.node.settings import BYTES_PER_MB

#: The node's log line for each file it writes (flight_recorder/flight_recorder.py): how files that were written and rotated
#: away between two looks at the folder are still counted.
_WRITTEN = re.compile(r"incident written to [^\n]*?(incident_[^/\s]+" + re.escape(SUFFIX) + r") \(")
#: The e-stop's file begins at EMERGENCY's entry, a moment after the request; a stop entered up to the after-window
#: before it (a FAULT) holds both in one file that begins then. Margin for the two clocks' reading, s.
_CLOCK_SLACK_S = 1.0


@dataclass(frozen=True)
class Limits:
    max_files: int
    max_total_mb: float

    @property
    def max_bytes(self) -> int:
        return int(self.max_total_mb * BYTES_PER_MB)  # as the node converts its parameter


@dataclass(frozen=True)
class FileCheck:
    """One complete incident file read back: its message count and the cause in its metadata, or why not."""

    messages: int = 0
    cause: str = ""
    error: str = ""


@dataclass(frozen=True)
class Verdict:
    violations: list[str]
    kept: list[IncidentFile]
    total_bytes: int
    estop_file: str = ""  # the name of the lifetime's e-stop's file ("" when there was none)


def read_incident(path: Path) -> FileCheck:
    """Open ``path`` as anyone without this package would (docs/recorder.md, "The file") and read every message."""
    from mcap.reader import make_reader

    try:
        with open(path, "rb") as stream:
            reader = make_reader(stream, validate_crcs=True)
            count = sum(1 for _ in reader.iter_messages())
            causes = [m.metadata.get("cause", "") for m in reader.iter_metadata() if m.name == "incident"]
    except Exception as e:  # a torn or truncated file: whatever the reader raises is the finding
        return FileCheck(error=f"{type(e).__name__}: {e}")
    if len(causes) != 1:
        return FileCheck(count, error=f"{len(causes)} 'incident' metadata records")
    return FileCheck(count, causes[0])


def written_in_log(output: str) -> list[str]:
    """The names of the files a node's output says it wrote, in order."""
    return [m.group(1) for m in _WRITTEN.finditer(output)]


def _order(name: str) -> tuple[float, str]:
    parsed = parse_name(name)
    return (parsed[0] if parsed else 0.0), name  # the rotation's order: when the incident began, then the name


def judge_folder(folder: Path, limits: Limits, written: Mapping[str, int | None], *, estop_wall: float,
                 after_s: float, checks: dict[str, FileCheck] | None = None) -> Verdict:
    """The folder after a lifetime whose e-stop was requested at UNIX time ``estop_wall``. ``written``: every file
    name the run knows was written (seen in the folder, answered by ~/snapshot, logged by a node), with its size
    where it was seen. ``checks`` caches each file's reading across lifetimes (a file never changes once named)."""
    checks = {} if checks is None else checks
    kept = list_incidents(folder)
    total = sum(f.size for f in kept)
    bad: list[str] = []
    if len(kept) > limits.max_files:
        bad.append(f"recorder: {len(kept)} incident files kept, recorder_max_files {limits.max_files}")
    if total > limits.max_bytes and len(kept) > 1:
        bad.append(f"recorder: {len(kept)} incident files kept take {total} bytes, recorder_max_total_mb "
                   f"{limits.max_total_mb:g} ({limits.max_bytes} bytes); only the newest alone may exceed it")
    parts = sorted(p.name for p in folder.glob(f"*{PARTIAL}"))
    if parts:
        bad.append(f"recorder: a half-written file left behind: {', '.join(parts)}")
    bad += _rotation(kept, limits, written)
    for f in kept:
        key = f"{f.path.name}:{f.size}"
        if key not in checks:
            checks[key] = read_incident(f.path)
        if checks[key].error:
            bad.append(f"recorder: {f.path.name} ({f.size} bytes) does not read to its end: {checks[key].error}")
    since = estop_wall - after_s - _CLOCK_SLACK_S
    estop = [f for f in kept if f.began >= since and "EMERGENCY" in checks[f"{f.path.name}:{f.size}"].cause]
    if not estop:
        bad.append(f"recorder: the e-stop made no incident file with cause EMERGENCY (files begun since the e-stop: "
                   f"{[f.path.name for f in kept if f.began >= since]})")
    return Verdict(bad, kept, total, estop[-1].path.name if estop else "")


def _rotation(kept: Sequence[IncidentFile], limits: Limits, written: Mapping[str, int | None]) -> list[str]:
    """The oldest went first, and no more than the limits asked for."""
    names = {f.path.name for f in kept}
    every = sorted({*written, *names}, key=_order)
    if not kept:
        return [f"recorder: no incident file kept; written: {every[-3:]}"] if every else []
    oldest_kept = _order(kept[0].path.name)
    gone_newer = [n for n in every if n not in names and _order(n) > oldest_kept]
    if gone_newer:
        return [f"recorder: {', '.join(gone_newer)} removed while the older {kept[0].path.name} was kept"]
    removed = [n for n in every if n not in names]
    if removed and (size := written.get(removed[-1])) is not None:
        total = sum(f.size for f in kept)
        if len(kept) + 1 <= limits.max_files and total + size <= limits.max_bytes:
            return [f"recorder: {removed[-1]} ({size} bytes) removed though it fitted beside the {len(kept)} files "
                    f"kept ({total} bytes)"]
    return []


@dataclass
class LifetimeFiles:
    """One lifetime's part of the folder's story, for the report."""

    index: int
    written: int  # files first known in this lifetime
    kept: int
    total_bytes: int
    removed: int  # files rotated away in this lifetime
    limit: str  # which limit the folder stood at after a removal: "count", "size" or "" (nothing removed)
    estop_file: str
    estop_before_stop: bool  # already in the folder when the node was sent SIGINT (else written at its shutdown)


@dataclass
class RecorderLedger:
    """What the run saw of the incident folder: every name (with its size where seen), each lifetime's verdict."""

    folder: Path
    limits: Limits
    after_s: float
    written: dict[str, int | None] = field(default_factory=dict)
    checks: dict[str, FileCheck] = field(default_factory=dict)
    lifetimes: list[LifetimeFiles] = field(default_factory=list)
    largest_total: int = 0
    _known_before: int = 0  # names known when the current lifetime began
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    def node_params(self) -> tuple[str, ...]:
        """The node's parameters that point it at the folder with the run's limits."""
        return (f"recorder_dir:={self.folder}", f"recorder_max_files:={self.limits.max_files}",
                f"recorder_max_total_mb:={float(self.limits.max_total_mb)}",
                f"recorder_after_s:={float(self.after_s)}")

    def lifetime_starts(self) -> None:
        with self._lock:
            self._known_before = len(self.written)

    def saw(self, files: Iterable[IncidentFile]) -> None:
        with self._lock:
            for f in files:
                self.written[f.path.name] = f.size

    def saw_name(self, name: str) -> None:
        with self._lock:
            self.written.setdefault(name, None)

    def look(self) -> list[IncidentFile]:
        """The folder now, remembered."""
        files = list_incidents(self.folder)
        self.saw(files)
        return files

    def snapshot_answered(self, path: str) -> None:
        """~/snapshot's answer names its file: seen at once, before a later write can rotate it away."""
        p = Path(path)
        try:
            size: int | None = p.stat().st_size
        except OSError:
            size = None
        with self._lock:
            if size is not None or p.name not in self.written:
                self.written[p.name] = size

    def judge(self, index: int, node_output: str, *, estop_wall: float, estop_before_stop: bool) -> list[str]:
        """After lifetime ``index`` (its node stopped): the folder judged; its violations."""
        for name in written_in_log(node_output):
            self.saw_name(name)
        self.look()
        with self._lock:
            written = dict(self.written)
        v = judge_folder(self.folder, self.limits, written, estop_wall=estop_wall, after_s=self.after_s,
                         checks=self.checks)
        self.largest_total = max(self.largest_total, v.total_bytes)
        new = len(written) - self._known_before
        removed = (self.lifetimes[-1].kept if self.lifetimes else 0) + new - len(v.kept)
        # Full by count once max_files remain; fewer after a removal means the size limit made it.
        limit = "" if removed <= 0 else "count" if len(v.kept) >= self.limits.max_files else "size"
        self.lifetimes.append(LifetimeFiles(index, new, len(v.kept), v.total_bytes, removed, limit, v.estop_file,
                                            estop_before_stop))
        return v.violations

    def estop_file_there(self, estop_wall: float) -> bool:
        """Whether the folder already holds the e-stop's file (a file begun around it whose cause names EMERGENCY)."""
        since = estop_wall - self.after_s - _CLOCK_SLACK_S
        for f in self.look():
            key = f"{f.path.name}:{f.size}"
            if f.began >= since and key not in self.checks:
                self.checks[key] = read_incident(f.path)
            if f.began >= since and "EMERGENCY" in self.checks[key].cause:
                return True
        return False

    # --- the report ---------------------------------------------------------------------------------------------
    def summary(self) -> str:
        """One line: files written, kept at the end, the largest total a lifetime left, the limits."""
        kept = self.lifetimes[-1] if self.lifetimes else None
        removed = sum(lt.removed for lt in self.lifetimes)
        by_limit = [sum(lt.limit == k for lt in self.lifetimes) for k in ("count", "size")]
        by_cause: dict[str, int] = {}
        for name in self.written:
            parsed = parse_name(name)
            cause = parsed[1].value if parsed else "?"
            by_cause[cause] = by_cause.get(cause, 0) + 1
        causes = ", ".join(f"{n} {c}" for c, n in sorted(by_cause.items()))
        return (f"recorder: {len(self.written)} incident files written ({causes or 'none'}), "
                f"{kept.kept if kept else 0} kept at the end ({_kib(kept.total_bytes if kept else 0)}), largest "
                f"total after a lifetime {_kib(self.largest_total)}; {removed} rotated away (at the count limit after "
                f"{by_limit[0]} lifetimes, the size limit after {by_limit[1]}); limits {self.limits.max_files} files, "
                f"{self.limits.max_total_mb:g} MB ({_kib(self.limits.max_bytes)})")

    def sizes_line(self) -> str:
        """The sizes of the files seen, per cause: what the limits were chosen against."""
        parts = []
        for cause in ("emergency", "fault", "snapshot"):
            sizes = sorted(s for n, s in self.written.items() if s is not None and f"_{cause}{SUFFIX}" in n)
            if sizes:
                parts.append(f"{cause} {len(sizes)}: {_kib(sizes[0])} .. median {_kib(int(statistics.median(sizes)))}"
                             f" .. {_kib(sizes[-1])}")
        return "Incident sizes seen: " + ("; ".join(parts) or "none")

    def table(self) -> list[str]:
        lines = ["| lifetime | files written | rotated away (limit) | kept after it | total | the e-stop's file | "
                 "there before SIGINT |", "| --- | --- | --- | --- | --- | --- | --- |"]
        for lt in self.lifetimes:
            removed = f"{lt.removed} ({lt.limit})" if lt.limit else str(lt.removed)
            lines.append(f"| {lt.index} | {lt.written} | {removed} | {lt.kept} | {_kib(lt.total_bytes)} | "
                         f"{lt.estop_file or 'none'} | {'yes' if lt.estop_before_stop else 'no'} |")
        return lines


def _kib(n: int) -> str:
    return f"{n / 1024:.1f} KiB"
