"""The built-in upper-body motions: sport SetArmTask (wave, wave and turn, shake hand) and the ``arm``
service's actions, as scripted trajectories that the lock stand holds as its own upper-body targets
(``StanceController.upper``), as a built-in controller would, rather than through the rt/arm_sdk torque
blend: blended torques at arm_sdk's gains tipped the stance over in quick motions.

Not the robot's recorded motions: a few keyframes per motion (targets of named joints, cosine-eased;
joints not named hold the pose they had when the motion began), enough for a client to see the arm move
and the robot report it. The waist holds its start pose.
A motion ramps in over ``RAMP_S``, plays, returns to the pose the arms had before it (``{}`` keys) and
ramps out; the first shake-hand stage holds its last key (hand held out) until the second stage or
another motion takes over from there.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Final

import numpy as np

from g1_mode_manager.protocol.motors import ARM_SDK_JOINTS, JOINT_INDEX

RAMP_S: Final = 1.0

Key = tuple[float, dict[str, float]]  # (time s from start, target q of named joints, rad)


@dataclass(frozen=True)
class ArmMotion:
    name: str
    keys: tuple[Key, ...]  # the first key is where the motion begins; the last key's time is its length
    hold: bool = False  # keep the last key until replaced (no return, no ramp-out)

    @property
    def duration_s(self) -> float:
        return self.keys[-1][0]


def _wave(cycles: int, name: str) -> ArmMotion:
    up = {"right_shoulder_roll_joint": -1.2, "right_shoulder_pitch_joint": -0.3, "right_elbow_joint": 0.5}
    keys: list[Key] = [(0.0, {}), (1.5, up)]
    for k in range(cycles):
        keys += [(2.1 + 1.2 * k, {**up, "right_elbow_joint": 1.0}), (2.7 + 1.2 * k, up)]
    return ArmMotion(name, (*keys, (keys[-1][0] + 1.5, {})))


_HAND_OUT = {"right_shoulder_pitch_joint": -0.8, "right_shoulder_roll_joint": -0.15, "right_elbow_joint": 0.5}
#: sport SetArmTask 7106 {"data": id} (the SDK's WaveHand(turn) = 0/1, ShakeHand stages = 2, 3).
SPORT_TASKS: Final[dict[int, ArmMotion]] = {
    0: _wave(3, "wave hand"),
    1: _wave(4, "wave hand and turn"),  # the robot also turns on the spot; the sim only waves
    2: ArmMotion("shake hand: hold out", ((0.0, {}), (1.0, _HAND_OUT)), hold=True),
    3: ArmMotion("shake hand: withdraw", ((0.0, {}), (1.0, {}))),
}

#: arm service ExecuteAction 7106 {"data": id}: of the robot's actions (ids and names as the SDK's
#: action_map) only those the sim's lock stand survives; 99 "release arm" ends any action. A quick
#: out-and-back swing (shake hand 27, hands up 15) tipped it over: its centre-of-mass servo's lean stays
#: where it was when the motion ends.
RELEASE_ARM: Final = 99
ARM_ACTIONS: Final[dict[int, ArmMotion]] = {
    26: _wave(3, "high wave"),
}
RELEASE_MOTION: Final = ArmMotion("release arm", ((0.0, {}), (1.0, {})))
ARM_ACTION_NAMES: Final = {RELEASE_ARM: "release arm", **{i: m.name for i, m in ARM_ACTIONS.items()}}


def _ease(x: float) -> float:
    return 0.5 - 0.5 * float(np.cos(np.pi * min(max(x, 0.0), 1.0)))


class ArmTaskPlayer:
    """Plays one motion at a time; ``update`` at 50 Hz sets :attr:`command` (targets of motors 12..28 and
    their weight 0..1, or None when no motion plays)."""

    def __init__(self) -> None:
        self.command: tuple[np.ndarray, float] | None = None
        self._motion: ArmMotion | None = None
        self._task_id = 0
        self._t0 = 0.0
        self._from = np.zeros(len(ARM_SDK_JOINTS))  # targets where the motion begins
        self._home = np.zeros(len(ARM_SDK_JOINTS))  # the pose before the first motion: {} keys go back here
        self._weight0 = 0.0  # the weight when taking over from a held motion (no ramp-in)

    @property
    def active(self) -> bool:
        return self._motion is not None

    def start(self, task_id: int, motion: ArmMotion, now: float, q_upper: np.ndarray) -> None:
        """Begin ``motion`` from the measured upper-body pose, or from the running motion's targets."""
        if self._motion is not None and self.command is not None:
            self._from, self._weight0 = self.command[0].copy(), self.command[1]
        else:
            self._from, self._weight0 = np.array(q_upper, dtype=float), 0.0
            self._home = self._from.copy()
        self._motion, self._task_id, self._t0 = motion, int(task_id), now

    def stop(self) -> None:
        """End at once (the controller changed state): the built-in controller takes the arms back."""
        self._motion = None
        self.command = None

    def report(self, now: float) -> tuple[int, float]:
        """(task_id, task_time) for rt/sportmodestate: the running motion's id (SetArmTask's task id, or
        the arm service's action id) and seconds since it began; (0, 0.0) while none runs (so a wave,
        id 0, shows as task_time > 0). What the robot reports for arm-service actions is not documented."""
        return (self._task_id, now - self._t0) if self._motion is not None else (0, 0.0)

    def _targets(self, t: float) -> np.ndarray:
        assert self._motion is not None
        keys = self._motion.keys
        prev = self._from
        for (t_a, _), (t_b, b) in itertools.pairwise(keys):
            nxt = self._key_q(b)
            if t <= t_b:
                return prev + (nxt - prev) * _ease((t - t_a) / max(t_b - t_a, 1e-6))
            prev = nxt
        return prev

    def _key_q(self, targets: dict[str, float]) -> np.ndarray:
        q = self._home.copy()
        for name, value in targets.items():
            q[JOINT_INDEX[name] - ARM_SDK_JOINTS[0]] = value
        return q

    def update(self, now: float) -> None:
        m = self._motion
        if m is None:
            return
        t = now - self._t0
        if t >= m.duration_s and not m.hold:
            self.stop()
            return
        ramp_in = max(self._weight0, _ease(t / RAMP_S))
        ramp_out = 1.0 if m.hold else _ease((m.duration_s - t) / RAMP_S)
        self.command = (self._targets(t), min(ramp_in, ramp_out))
