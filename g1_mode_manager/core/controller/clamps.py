"""A policy's targets past a joint's stops: clamped into the joint's range plus the frame check's margin, counted per
joint, and a stop only when one joint's target stays clamped longer than a bound.

Field policies press joints against their stops in normal motion (holosoma's dances ask for an ankle or a knee up
to 0.7 rad beyond range + margin, for at most five ticks in a row: docs/policies.md), and holosoma removed its own
target clipping. A target no joint can reach still never reaches the robot unclamped: at a clamped target the motor
presses the joint against its stop with at most kp x margin (docs/safety.md). A target that stays clamped is no
longer a press but a policy asking for what the joint cannot do, and the loop stops it. A non-finite target is not
clamped (NaN stays NaN): the frame check refuses it and the loop stops the policy, as before.

``~/lowcmd`` frames are not clamped: a user's controller sending q = 100 rad is a bug, refused as it was.
"""

from __future__ import annotations

import dataclasses
from typing import Final

import numpy as np

from g1_mode_manager.core.controller.interface import ControllerError, JointTargets
from g1_mode_manager.core.joint_commands import RANGE_MARGIN_RAD
from g1_mode_manager.protocol.motors import JOINT_NAMES, JOINT_RANGE_RAD, NUM_JOINTS

#: The lowest and highest target a policy may put on the wire, rad (motor order): what the frame check passes.
LOWEST: Final = np.array([low for low, _ in JOINT_RANGE_RAD]) - RANGE_MARGIN_RAD
HIGHEST: Final = np.array([high for _, high in JOINT_RANGE_RAD]) + RANGE_MARGIN_RAD


class TargetClamp:
    """``apply`` clamps one tick's targets and keeps count; raises ControllerError once a joint's target has been
    clamped on every tick for longer than ``max_held_s``."""

    def __init__(self, max_held_s: float) -> None:
        if not max_held_s > 0.0:
            raise ValueError(f"a clamp's longest hold must be > 0 s, got {max_held_s}")
        self.max_held_s = max_held_s
        self.counts = np.zeros(NUM_JOINTS, dtype=np.int64)  # ticks clamped, per joint, since the last reset
        self._since = np.full(NUM_JOINTS, np.nan)  # when each joint's current run of clamped ticks began
        self.started: tuple[int, ...] = ()  # the joints whose run began at the last apply

    def reset(self) -> None:
        self.counts[:] = 0
        self._since[:] = np.nan
        self.started = ()

    def apply(self, targets: JointTargets, now: float) -> JointTargets:
        q = targets.q
        past = (q < LOWEST) | (q > HIGHEST)  # False for NaN: the frame check refuses it after this
        if not past.any():
            self._since[:] = np.nan
            self.started = ()
            return targets
        self.counts += past
        fresh = past & np.isnan(self._since)
        self.started = tuple(int(i) for i in np.flatnonzero(fresh))
        self._since = np.where(past, np.where(fresh, now, self._since), np.nan)
        held = np.where(past, now - self._since, 0.0)
        worst = int(np.argmax(held))
        if held[worst] > self.max_held_s:
            raise ControllerError(f"target of {JOINT_NAMES[worst]} past its range + {RANGE_MARGIN_RAD:g} rad for "
                                  f"{held[worst]:.2f} s (policy_clamp_max_s {self.max_held_s:g}): {q[worst]:.3f} rad, "
                                  f"range {JOINT_RANGE_RAD[worst]}")
        return dataclasses.replace(targets, q=np.clip(q, LOWEST, HIGHEST))

    def clamped(self) -> dict[str, int]:
        """Ticks clamped per joint (only the joints ever clamped), since the last reset."""
        return {JOINT_NAMES[i]: int(n) for i, n in enumerate(self.counts) if n}
