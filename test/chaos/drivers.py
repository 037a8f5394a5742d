"""Who drives, judged on the robot's record: the teleop (cmd_vel) and the planner (the autonomy's cmd_vel_nav).

A chaos scenario's two sources are told apart by the shape of their Moves, which the node's clamps and ramps
keep: the teleop walks straight ahead (vx > 0 only, at most TELEOP_VX); the planner walks ahead, to the left and
turns right at once (vx > 0, vy > 0, wz < 0: the ramp moves every axis at each step, so even its first Move has
all three). A Move of neither shape is a source the judge does not know of, or a mix of the two.

The rules, from the record and the operators' own calls (``DriveLog``):

- the planner's Moves come only after a hand-over that succeeded was requested, and none after a takeover until
  the next such hand-over: a takeover is a teleop Move on the record, an answered ``~/take_over``, the node's
  leaving HIGH_LEVEL (its ``~/mode``), or the node killed;
- every planner Move is within the autonomy's limits and within what the planner asked;
- each source's acknowledged Moves step at most by its own acceleration limits over one ramp period, from the
  last Move or from standstill (the node starts its ramp again after a change of driver);
- a planner that fell silent moves the robot no more once its timeout has passed (with a margin for a starved node).

Without a planner (``DriveLog.planner_command`` None: the soak's teleop commands of every shape), every Move is the
teleop's and only the ramp rule applies.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from typing import Any

from chaos.coverage import (
    AUTONOMY_SILENT,
    AUTONOMY_SUSPENDED,
    ESTOP_WHILE_AUTONOMY,
    FAULT_WHILE_AUTONOMY,
    HAND_OVER,
    HAND_OVER_REFUSED,
    LEFT_WHILE_AUTONOMY,
    TAKE_OVER_SERVICE,
    TAKEOVER_BY_TELEOP,
)
from g1_mode_manager.core.velocity import VelocityLimits
from g1_mode_manager.node.settings import Settings
from g1_mode_manager.protocol import api_ids
from g1_mode_manager.relay.cmd_vel import RAMP_PERIOD_S
from support.sim_record import Event, requests, sent_at, velocity_of
from support.timing import SILENT_PLANNER_STOP_S

#: The node's limits (its parameters' defaults, which the chaos nodes run with).
TELEOP_LIMITS: VelocityLimits = Settings().velocity_limits()
AUTONOMY_LIMITS: VelocityLimits = Settings().autonomy_limits()
AUTONOMY_TIMEOUT_S = Settings().autonomy_timeout_s
#: The chaos teleop's command: straight ahead, m/s.
TELEOP_VX = 0.3
TELEOP, PLANNER, STOP = "teleop", "planner", "stop"
#: A Move's values may differ from the node's by the record's float formatting.
EPS = 1e-6
IDLE, HIGH_LEVEL, LOW_LEVEL, FAULT = 1, 2, 3, 5
#: How long before the e-stop a planner Move shows the autonomy driving when the e-stop went out, s: the Move's
#: lease (move_duration_s), within which the robot still walks by it.
DRIVING_WITHIN_S = Settings().move_duration_s


@dataclass
class Call:
    """A ``~/hand_over_to_autonomy`` or ``~/take_over`` call, in the test's monotonic time; ``answered`` None if
    no answer came (a killed node, the scenario's end)."""

    sent: float
    answered: float | None = None
    success: bool | None = None
    message: str = ""


@dataclass
class DriveLog:
    """The operators' side of who drives: their calls and the planner's streams."""

    planner_command: tuple[float, float, float] | None = None  # None: no planner in this run
    hand_overs: list[Call] = field(default_factory=list)
    take_overs: list[Call] = field(default_factory=list)
    #: [first, last] message of each planner stream, the last kept up to date while it publishes
    planner_streams: list[list[float]] = field(default_factory=list)


@dataclass(frozen=True)
class Takeover:
    """Something that ends the autonomy's drive. A hand-over answered before ``after`` was surely done before it;
    a Move sent after ``before`` surely came after it."""

    after: float
    before: float
    what: str


def source_of(v: list[float], planner: bool = True) -> str | None:
    """TELEOP, PLANNER, or None for a Move of neither shape; ``planner`` False: every Move is the teleop's."""
    vx, vy, wz = v
    if not planner:
        return TELEOP
    if 0.0 < vx <= TELEOP_VX + EPS and vy == 0.0 and wz == 0.0:
        return TELEOP
    if vx > 0.0 and vy > 0.0 and wz < 0.0:
        return PLANNER
    return None


def _moves(events: list[Event]) -> list[tuple[float, list[float]]]:
    """(send time, velocity) of every non-zero Move the robot received. Who may drive is the node's decision when
    it sends: a Move it sent before a takeover and the robot received after it, because the robot's receiving side
    was starved meanwhile, was in flight, not sent by a source that no longer drives (the request's own stamp,
    ``sent_at``, tells the two apart where its receive time cannot)."""
    return [(sent_at(e), v) for e in requests(events, api_ids.LOCO_SET_VELOCITY) if (v := velocity_of(e)) and any(v)]


def judge_drivers(events: list[Event], modes: list[tuple[float, Any]], log: DriveLog,
                  restarts: list[tuple[float, float]], grace_s: float) -> list[str]:
    """Violations of who may drive, on the record; [] if none (and always [] without a planner)."""
    command = log.planner_command
    if command is None:
        return []
    bad: list[str] = []
    moves = _moves(events)
    if odd := [(t, v) for t, v in moves if source_of(v) is None]:
        bad.append(f"a Move {odd[0][1]} at {odd[0][0]:.3f} of neither the teleop's shape nor the planner's")
    planner = [(t, v) for t, v in moves if source_of(v) == PLANNER]
    limits = (AUTONOMY_LIMITS.max_vx, AUTONOMY_LIMITS.max_vy, AUTONOMY_LIMITS.max_wz)
    if over := [(t, v) for t, v in planner if any(abs(a) > lim + EPS for a, lim in zip(v, limits, strict=True))]:
        bad.append(f"a planner Move {over[0][1]} at {over[0][0]:.3f} above the autonomy's limits {limits}")
    if more := [(t, v) for t, v in planner if any(abs(a) > abs(c) + EPS for a, c in zip(v, command, strict=True))]:
        bad.append(f"a planner Move {more[0][1]} at {more[0][0]:.3f} above what the planner asked, {command}")
    takeovers = _takeovers(moves, modes, log, restarts, grace_s)
    handed = [c for c in log.hand_overs if c.success]
    for t, v in planner:
        if why := _not_handed(t, handed, takeovers):
            bad.append(f"a planner Move {v} that reached the robot was sent at {t:.3f}: {why}")
            break
    bad += _judge_silence(planner, log.planner_streams)
    return bad


def _takeovers(moves: list[tuple[float, list[float]]], modes: list[tuple[float, Any]], log: DriveLog,
               restarts: list[tuple[float, float]], grace_s: float) -> list[Takeover]:
    """Every end of the autonomy's drive the judge knows of. Times on the record and the test's receive times of
    answers and ``~/mode`` differ by what is in flight: ``grace_s`` either way."""
    ends = [Takeover(t - grace_s, t, f"the teleop's Move at {t:.3f}") for t, v in moves if source_of(v) == TELEOP]
    ends += [Takeover(c.sent, c.answered + grace_s, f"~/take_over answered at {c.answered:.3f}")
             for c in log.take_overs if c.answered is not None and c.success]
    ends += [Takeover(t - grace_s, t + grace_s, f"leaving HIGH_LEVEL ({m.name}) claimed at {t:.3f}")
             for (_, before), (t, m) in itertools.pairwise(modes) if _in_high_level(before) and not _in_high_level(m)]
    ends += [Takeover(t, t + grace_s, f"the node stopped at {t:.3f}") for t, _ in restarts]
    return ends


def _in_high_level(m: Any) -> bool:
    """HIGH_LEVEL, and not on the way out of it."""
    return m.mode == HIGH_LEVEL and not (m.transition_in_progress and m.transition_target != HIGH_LEVEL)


def _not_handed(t: float, handed: list[Call], takeovers: list[Takeover]) -> str:
    """Why a planner Move sent at ``t`` had no hand-over in force; "" if it had."""
    earlier = [h for h in handed if h.sent < t]
    if not earlier:
        return "no hand-over that succeeded was requested before it"
    ended = []
    for h in earlier:
        answered = h.answered if h.answered is not None else float("inf")
        ends = [e for e in takeovers if answered < e.after and e.before < t]
        if not ends:
            return ""
        ended.append(min(ends, key=lambda e: e.before))
    end = max(ended, key=lambda e: e.before)
    return f"{end.what} ended the autonomy's drive {t - end.before:.3f} s before, and no hand-over since"


def _judge_silence(planner: list[tuple[float, list[float]]], streams: list[list[float]]) -> list[str]:
    """No planner Move later than the planner's last message plus the autonomy's timeout and SILENT_PLANNER_STOP_S,
    until it publishes again."""
    merged: list[list[float]] = []  # the stretches in which some planner stream published
    for first, last in sorted(streams):
        if merged and first <= merged[-1][1]:
            merged[-1][1] = max(merged[-1][1], last)
        else:
            merged.append([first, last])
    for k, (_, last) in enumerate(merged):
        again = merged[k + 1][0] if k + 1 < len(merged) else float("inf")
        late = [(t, v) for t, v in planner if last + AUTONOMY_TIMEOUT_S + SILENT_PLANNER_STOP_S < t < again]
        if late:
            return [f"a planner Move {late[0][1]} was sent {late[0][0] - last:.3f} s after the planner fell "
                    f"silent (autonomy_timeout_s {AUTONOMY_TIMEOUT_S:g})"]
    return []


def judge_ramps(events: list[Event], log: DriveLog) -> list[str]:
    """Each source's acknowledged Moves step at most by its own acceleration limits over one ramp period from the
    last. A StopMove, or a ramp's first step from standstill, may come at any time: the node stops, or starts its
    ramp again, after a change of driver, a failed Move or a restart. Without a planner every Move is the teleop's."""
    planner = log.planner_command is not None
    steps = {TELEOP: _steps(TELEOP_LIMITS), PLANNER: _steps(AUTONOMY_LIMITS)}
    previous: tuple[float, ...] = (0.0, 0.0, 0.0)
    for e in events:
        if e.get("api") != api_ids.LOCO_SET_VELOCITY or e["k"] != "done" or e["code"] != 0:
            continue
        v = velocity_of(e) or [0.0, 0.0, 0.0]
        source = source_of(v, planner)
        if not any(v) or source is None:  # a StopMove; a Move of neither shape is judge_drivers' to report
            previous = (0.0, 0.0, 0.0)
            continue
        if not (_within(v, previous, steps[source]) or _within(v, (0.0, 0.0, 0.0), steps[source])):
            return [f"{source} Move {v} after {list(previous)}: above its acceleration limit"]
        previous = tuple(v)
    return []


def _within(v: list[float], previous: tuple[float, ...], steps: tuple[float, float, float]) -> bool:
    return all(abs(a - b) <= step + EPS for a, b, step in zip(v, previous, steps, strict=True))


def _steps(limits: VelocityLimits) -> tuple[float, float, float]:
    """The most one Move may change from the last: the acceleration limits over one ramp period."""
    return (limits.max_ax * RAMP_PERIOD_S, limits.max_ay * RAMP_PERIOD_S, limits.max_awz * RAMP_PERIOD_S)


def drive_cells(events: list[Event], modes: list[tuple[float, Any]], log: DriveLog, t_estop: float) -> list[str]:
    """The coverage cells of who drives that this scenario hit (coverage.DRIVE_CELLS)."""
    if log.planner_command is None:
        return []
    # every Move in order, StopMoves too: (receive time, TELEOP, PLANNER, STOP or None)
    labels = [(e["t"], source_of(v) if any(v) else STOP) for e in requests(events, api_ids.LOCO_SET_VELOCITY)
              if (v := velocity_of(e)) is not None]
    driving = [(t, s) for t, s in labels if s != STOP]
    cells = []
    if any(c.success for c in log.hand_overs) and any(s == PLANNER for _, s in driving):
        cells.append(HAND_OVER)
    if any(c.success is False for c in log.hand_overs):
        cells.append(HAND_OVER_REFUSED)
    services = [c.sent for c in log.take_overs]
    leaves = [t for (_, a), (t, b) in itertools.pairwise(modes) if _in_high_level(a) and not _in_high_level(b)]
    if any(a == PLANNER and b == TELEOP and not any(ta < x < tb for x in services + leaves)
           for (ta, a), (tb, b) in itertools.pairwise(driving)):
        cells.append(TAKEOVER_BY_TELEOP)
    if any(c.success and "already" not in c.message for c in log.take_overs):
        cells.append(TAKE_OVER_SERVICE)
    # the planner's Moves reached the robot under a hand-over, then it fell silent: not the moment after a hand-over,
    # before its first command reached the node
    handed = [c.sent for c in log.hand_overs if c.success]
    silent = [t for t, m in modes if m.autonomy_suspended.startswith("silent")]
    if any(s == PLANNER and max((h for h in handed if h < t_s), default=t_s) < t < t_s
           for t_s in silent for t, s in driving):
        cells.append(AUTONOMY_SILENT)
    if any(m.autonomy_suspended.startswith("suspended") for _, m in modes):
        cells.append(AUTONOMY_SUSPENDED)
    left = [_target(b) for (_, a), (_, b) in itertools.pairwise(modes)
            if a.driver == "autonomy" and _in_high_level(a) and not _in_high_level(b)]
    if IDLE in left or LOW_LEVEL in left:
        cells.append(LEFT_WHILE_AUTONOMY)
    if FAULT in left:
        cells.append(FAULT_WHILE_AUTONOMY)
    claimed = [m for t, m in modes if t < t_estop][-1:]
    last = [(t, s) for t, s in labels if t < t_estop][-1:]
    if claimed and _in_high_level(claimed[0]) and claimed[0].driver == "autonomy" and not claimed[0].autonomy_suspended \
            and last and last[0][1] == PLANNER and t_estop - last[0][0] < DRIVING_WITHIN_S:
        cells.append(ESTOP_WHILE_AUTONOMY)
    return cells


def _target(m: Any) -> int:
    """Where a ``~/mode`` is going: its transition's target, or its mode."""
    return m.transition_target if m.transition_in_progress else m.mode
