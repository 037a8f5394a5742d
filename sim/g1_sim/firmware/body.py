"""The body the firmware reports on: motor temperatures and the battery, advanced together from the torques.

Both depend on the same thing, the motors' work: copper loss heats the windings and is drawn from the
battery along with the mechanical power. The firmware advances them at its 50 Hz from the torques and
joint velocities of that instant (their time constants are tens of seconds and more, so sampling at
50 Hz costs nothing in accuracy and nothing per physics step).
"""

from __future__ import annotations

import numpy as np

from g1_sim.firmware.state import BodySnapshot
from g1_sim.physics.battery import START_SOC, Battery
from g1_sim.physics.model import EFFORT_LIMIT
from g1_sim.physics.thermal import MotorThermal


class Body:
    """Motor temperatures (MotorThermal) and battery (Battery) of one robot."""

    def __init__(self, soc: float = START_SOC) -> None:
        self.thermal = MotorThermal(EFFORT_LIMIT)
        self.battery = Battery(soc)

    def update(self, tau: np.ndarray, dq: np.ndarray, dt: float) -> None:
        """Advance ``dt`` seconds at these motor torques (N m) and joint velocities (rad/s)."""
        loss_w = self.thermal.copper_loss_w(tau)
        self.thermal.update(loss_w, dt)
        self.battery.drain(float(np.abs(tau * dq).sum() + loss_w.sum()), dt)

    def snapshot(self, remote_keys: frozenset[str]) -> BodySnapshot:
        return BodySnapshot(casing_c=self.thermal.casing.copy(), winding_c=self.thermal.winding.copy(),
                            battery=self.battery.reading(), remote_keys=remote_keys)
