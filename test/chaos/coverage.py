"""What a chaos batch covered: the cell each e-stop landed in, and the table ``make chaos`` prints.

A cell is (what ``~/mode`` showed when the e-stop went out) x (what the operators had in flight then). The
row is the mode, or ``->TARGET`` while a transition is in progress (``->IDLE`` from UNINITIALIZED is the
first connect). The columns are the operators' own outstanding requests, seen from their side: a mode call
sent and not yet answered, a loco command likewise, a stream being published, a learned policy at work in the
node's loop (shadowing, engaging, running, holding or disengaging, as its ``~/policy/status`` says), or nothing.
Several can be in flight at once; each counts. A transition is itself a mode call in flight, so ``->X`` x nothing
cannot happen and is not required; a policy runs in IDLE and HIGH_LEVEL (its shadow), while LOW_LEVEL is entered
for it and in LOW_LEVEL, and those four cells are required.

Who drives has cells of its own, each a scenario in which it happened on the robot's record or the node's
``~/mode`` (drivers.drive_cells): the planner handed the robot and its Moves on the record, a hand-over refused,
a teleop Move taking over from the planner's, ``~/take_over`` taking the robot back, the planner falling silent
after its Moves reached the robot, the autonomy suspended by its conditions, HIGH_LEVEL left for IDLE or LOW_LEVEL
and FAULT entered while the autonomy drove, and the e-stop going out while the planner's Moves drove the robot.
"""

from __future__ import annotations

import threading
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass, field

ROWS = ("UNINITIALIZED", "IDLE", "HIGH_LEVEL", "LOW_LEVEL", "FAULT", "->IDLE", "->HIGH_LEVEL", "->LOW_LEVEL")
COLUMNS = ("nothing", "mode call", "loco command", "stream", "policy")
#: The rows in which a policy can be at work: its shadow (IDLE, HIGH_LEVEL), its engage, its run.
POLICY_ROWS = ("IDLE", "HIGH_LEVEL", "->LOW_LEVEL", "LOW_LEVEL")
#: Every cell a batch must hit: all but a transition with nothing in flight, and a policy only where it can be at
#: work. An odd count, so that the seed's cell and its path (by parity) pair every cell with both paths.
REQUIRED = tuple((r, c) for r in ROWS for c in COLUMNS
                 if not (r.startswith("->") and c == "nothing") and (c != "policy" or r in POLICY_ROWS))
HAND_OVER = "hand-over, planner Moves"
HAND_OVER_REFUSED = "hand-over refused"
TAKEOVER_BY_TELEOP = "takeover by teleop"
TAKE_OVER_SERVICE = "take_over service"
AUTONOMY_SILENT = "planner silent"
AUTONOMY_SUSPENDED = "autonomy suspended"
LEFT_WHILE_AUTONOMY = "set_mode out of HIGH_LEVEL, autonomy driving"
FAULT_WHILE_AUTONOMY = "FAULT, autonomy driving"
ESTOP_WHILE_AUTONOMY = "e-stop, autonomy driving"
DRIVE_CELLS = (HAND_OVER, HAND_OVER_REFUSED, TAKEOVER_BY_TELEOP, TAKE_OVER_SERVICE, AUTONOMY_SILENT, AUTONOMY_SUSPENDED,
               LEFT_WHILE_AUTONOMY, FAULT_WHILE_AUTONOMY, ESTOP_WHILE_AUTONOMY)
#: Those a batch must hit (the autonomy's conditions suspend it, and a body check trips while it drives, only as
#: the robot happens to fail them).
DRIVE_REQUIRED = tuple(c for c in DRIVE_CELLS if c not in (AUTONOMY_SUSPENDED, FAULT_WHILE_AUTONOMY))
#: The share of e-stops that must land after the node's first connect, in a batch of 100 or more.
AFTER_CONNECT_GOAL = 0.7


def row_of(mode_name: str, transition_in_progress: bool, target_name: str) -> str:
    """The row of a ``~/mode`` message."""
    return f"->{target_name}" if transition_in_progress else mode_name


class InFlight:
    """The operators' outstanding requests by column, counted as they are sent and answered (thread-safe)."""

    def __init__(self) -> None:
        self._changed = threading.Condition()
        self._counts: Counter[str] = Counter()

    def begin(self, column: str) -> None:
        with self._changed:
            self._counts[column] += 1
            self._changed.notify_all()

    def end(self, column: str) -> None:
        with self._changed:
            self._counts[column] -= 1
            self._changed.notify_all()

    def columns(self) -> tuple[str, ...]:
        """What is in flight now; ("nothing",) when nothing is."""
        with self._changed:
            now = tuple(c for c in COLUMNS if self._counts[c] > 0)
        return now or ("nothing",)

    def wait(self, timeout_s: float) -> None:
        """Until something begins or ends, or ``timeout_s``."""
        with self._changed:
            self._changed.wait(timeout_s)


@dataclass
class Landing:
    """Where one e-stop landed."""

    row: str
    columns: tuple[str, ...]
    connected: bool  # the node had finished a first connect (shown a mode other than UNINITIALIZED)
    path: str = "release"  # the node's low_level_path

    def cells(self) -> list[tuple[str, str]]:
        return [(self.row, c) for c in self.columns]


@dataclass
class Coverage:
    """The landings of a batch, and the scenario features it exercised."""

    landings: list[Landing] = field(default_factory=list)
    features: Counter[str] = field(default_factory=Counter)

    def add(self, landing: Landing, features: Iterable[str] = ()) -> None:
        self.landings.append(landing)
        self.features.update(features)

    def counts(self, path: str | None = None) -> Counter[tuple[str, str]]:
        """Landings by cell, of every path or of one."""
        return Counter(cell for landing in self.landings if path in (None, landing.path) for cell in landing.cells())

    def missing(self, path: str | None = None) -> list[tuple[str, str]]:
        counts = self.counts(path)
        return [cell for cell in REQUIRED if counts[cell] == 0]

    def after_connect(self) -> float:
        return sum(landing.connected for landing in self.landings) / max(1, len(self.landings))

    def shortfalls(self) -> list[str]:
        """Why this batch (100 scenarios or more) does not cover what it must; [] if it does."""
        why = []
        if self.missing():
            why.append(f"cells never hit: {self.missing()}")
        if missed := [c for c in DRIVE_REQUIRED if self.features[c] == 0]:
            why.append(f"drive cells never hit: {missed}")
        if self.after_connect() < AFTER_CONNECT_GOAL:
            why.append(f"only {100 * self.after_connect():.0f} % of e-stops after the first connect")
        return why

    def table(self) -> str:
        counts = self.counts()
        width = max(len(r) for r in ROWS) + 2
        lines = ["chaos coverage: e-stops by what ~/mode showed (rows) x what the operators had in flight (columns)",
                 "".ljust(width) + "".join(c.rjust(14) for c in COLUMNS)]
        for r in ROWS:
            cells = ["n/a" if (r, c) not in REQUIRED else str(counts[(r, c)]) for c in COLUMNS]
            lines.append(r.ljust(width) + "".join(v.rjust(14) for v in cells))
        n = len(self.landings)
        hit = len(REQUIRED) - len(self.missing())
        after = sum(landing.connected for landing in self.landings)
        lines.append(f"chaos coverage: {hit} of {len(REQUIRED)} cells hit; e-stops after the first connect: {after} of "
                     f"{n} ({100 * after / max(1, n):.0f} %)")
        for path in sorted({landing.path for landing in self.landings}):
            runs = sum(landing.path == path for landing in self.landings)
            lines.append(f"chaos coverage: {path} path: {runs} scenarios, {len(REQUIRED) - len(self.missing(path))} of "
                         f"{len(REQUIRED)} cells hit; missed {self.missing(path)}")
        lines.append("chaos coverage: who drives, scenarios in which it happened:")
        label = max(len(cell) for cell in DRIVE_CELLS) + 2
        lines += [f"  {cell.ljust(label)}{self.features[cell]:>6}" for cell in DRIVE_CELLS]
        if others := sorted((k, v) for k, v in self.features.items() if k not in DRIVE_CELLS):
            lines.append("chaos coverage: " + ", ".join(f"{k} {v}" for k, v in others))
        return "\n".join(lines)
