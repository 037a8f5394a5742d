"""The soak's load, planned from a seed: node lifetimes, each ending in an e-stop, and within each the
operators' commands and streams at planned instants. Pure: no ROS, no clock; the same seed gives the same
plan, so a lifetime that broke an invariant is replayed with the same seed."""

from __future__ import annotations

import random
from dataclasses import dataclass
from typing import Any

#: What an operator asks for, with weights by repetition: mode requests, loco commands, a lost link (the sim's
#: pause_state: every state topic silent), a clear_fault (a lost link in LOW_LEVEL is a FAULT).
COMMAND_KINDS = ("mode", "mode", "mode", "loco", "loco", "link_loss", "clear")
#: Streams to the node: /cmd_vel, ~/arm_cmd (HIGH_LEVEL passes them), ~/lowcmd (LOW_LEVEL passes it).
STREAM_KINDS = ("drive", "drive", "arm", "lowcmd")
MODES = ("idle", "high_level", "low_level")
LOCO = ("stand_up", "start", "zero_torque", "squat", "balance_stand")
ESTOP_VIA = ("service", "service", "topic_reliable", "topic_best_effort")
COMMAND_GAP_S = (2.0, 8.0)
STREAM_S = (1.0, 6.0)
STREAM_GAP_S = (0.5, 4.0)
LINK_LOSS_S = (1.0, 2.0)
#: ~/snapshot (an incident file written at once): the first within a shortest lifetime, then now and then.
FIRST_SNAPSHOT_S = (1.0, 58.0)
SNAPSHOT_GAP_S = (120.0, 300.0)
#: A lifetime's length is drawn in [1 - JITTER, 1 + JITTER] x the mean, so restarts do not fall on a beat.
JITTER = 0.2
#: Wall time a restart costs besides the lifetimes (e-stop settle, node stop, sim reset, node start), s:
#: planned for, so a run lasts about the minutes asked for.
RESTART_S = 15.0
#: A shorter last lifetime is merged into the one before it.
MIN_LIFETIME_S = 60.0


@dataclass(frozen=True)
class Action:
    at_s: float  # since the node's ready line
    kind: str
    arg: Any = None  # mode name, loco verb, (vx, vy, wz), arm positions, an elbow angle
    seconds: float = 0.0  # how long a stream or a lost link lasts


@dataclass(frozen=True)
class Lifetime:
    index: int
    length_s: float  # from the node's ready line to its e-stop
    estop_via: str  # "service", "topic_reliable", "topic_best_effort"
    commands: tuple[Action, ...]  # one operator, in order
    streams: tuple[Action, ...]  # another, in order, overlapping the commands
    snapshots: tuple[Action, ...]  # ~/snapshot calls, a third caller


def plan_soak(seed: int, minutes: float, lifetime_s: float = 300.0) -> list[Lifetime]:
    """The lifetimes of a run of ``minutes``: lengths around ``lifetime_s``, each with its load."""
    rng = random.Random(seed)
    budget = minutes * 60.0
    lengths: list[float] = []
    while True:
        length = round(rng.uniform(1.0 - JITTER, 1.0 + JITTER) * lifetime_s, 1)
        left = budget - sum(lengths) - RESTART_S * (len(lengths) + 1)
        if left < MIN_LIFETIME_S and lengths:
            lengths[-1] += max(0.0, left + RESTART_S)
            break
        if length >= left:
            lengths.append(round(max(left, MIN_LIFETIME_S), 1))
            break
        lengths.append(length)
    return [lifetime(seed, k, length) for k, length in enumerate(lengths)]


def lifetime(seed: int, index: int, length_s: float) -> Lifetime:
    """Lifetime ``index`` of the run ``seed``. The e-stop's way, the commands, the streams and the snapshots each draw
    from a random stream of their own, so a lifetime cut shorter (a run's last) plays a prefix of the same load."""
    rng = random.Random(f"{seed}/{index}/commands")
    commands = [Action(0.5, "mode", rng.choice(MODES))]  # connect at once: the node's first call touches the robot
    t = 0.5
    while (t := t + rng.uniform(*COMMAND_GAP_S)) < length_s - 1.0:
        commands.append(_command(rng, round(t, 2)))
    rng = random.Random(f"{seed}/{index}/streams")
    streams = []
    t = rng.uniform(*STREAM_GAP_S)
    while t < length_s - 1.0:
        seconds = round(rng.uniform(*STREAM_S), 2)
        streams.append(_stream(rng, round(t, 2), seconds))
        t += seconds + rng.uniform(*STREAM_GAP_S)
    via = random.Random(f"{seed}/{index}/estop").choice(ESTOP_VIA)
    rng = random.Random(f"{seed}/{index}/snapshots")
    snapshots = []
    t = rng.uniform(*FIRST_SNAPSHOT_S)
    while t < length_s - 1.0:
        snapshots.append(Action(round(t, 2), "snapshot"))
        t += rng.uniform(*SNAPSHOT_GAP_S)
    return Lifetime(index, length_s, via, tuple(commands), tuple(streams), tuple(snapshots))


def _command(rng: random.Random, at: float) -> Action:
    kind = rng.choice(COMMAND_KINDS)
    if kind == "mode":
        return Action(at, kind, rng.choice(MODES))
    if kind == "loco":
        return Action(at, kind, rng.choice(LOCO))
    if kind == "link_loss":
        return Action(at, kind, seconds=round(rng.uniform(*LINK_LOSS_S), 2))
    return Action(at, kind)


def _stream(rng: random.Random, at: float, seconds: float) -> Action:
    kind = rng.choice(STREAM_KINDS)
    if kind == "drive":  # within the node's clamps (max_vx 0.8, max_vy 0.4, max_wz 1.0): the ramp still acts
        arg: Any = (round(rng.uniform(-0.3, 0.6), 2), round(rng.uniform(-0.2, 0.2), 2), round(rng.uniform(-0.6, 0.6), 2))
    elif kind == "arm":  # shoulder rolls, outwards
        arg = (round(rng.uniform(0.0, 0.8), 3), round(rng.uniform(-0.8, 0.0), 3))
    else:  # left elbow angle, rad
        arg = round(rng.uniform(0.2, 1.2), 3)
    return Action(at, kind, arg, seconds)
