"""The battery: a charge drained by the power the robot draws, and what its BMS reports about it.

A body supervisor stops the robot on a low state of charge (Unitree's terminations.hpp: soc < 20 %), so
the sim's soc must fall with use, faster when walking than standing. The G1's pack is about 9 Ah at about
54 V nominal (13 lithium cells in series). Power drawn = mechanical power of the motors (sum |tau dq|,
no credit for braking) + their copper loss (physics.thermal) + an idle draw for computers, sensors and
drivers (chosen, not measured on a G1).

Pack voltage follows the soc linearly from 3.5 V to 4.2 V a cell (a plain open-circuit curve) minus the
drop over the pack's internal resistance; the BMS reports a current in mA, negative while discharging
(the usual BMS sign; a G1 document stating it was not found).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final

CELLS: Final = 13
CAPACITY_AH: Final = 9.0
NOMINAL_V: Final = 54.0
CELL_EMPTY_V: Final = 3.5
CELL_FULL_V: Final = 4.2
INTERNAL_OHM: Final = 0.08
IDLE_W: Final = 100.0
START_SOC: Final = 90.0


@dataclass(frozen=True)
class BatteryReading:
    """What the BMS reports: soc %, pack and cell voltages, current (negative while discharging)."""

    soc: float
    pack_v: float
    cell_v: float
    current_a: float
    power_w: float


class Battery:
    """State of charge in % of CAPACITY_AH x NOMINAL_V, drained by :meth:`drain`."""

    def __init__(self, soc: float = START_SOC) -> None:
        if not 0.0 <= soc <= 100.0:
            raise ValueError(f"soc must be within 0..100 %, got {soc}")
        self.soc = float(soc)
        self.power_w = IDLE_W
        self._energy_j = CAPACITY_AH * 3600.0 * NOMINAL_V

    def drain(self, motor_power_w: float, dt: float) -> None:
        """Draw the motors' power plus the idle draw for ``dt`` seconds."""
        self.power_w = IDLE_W + motor_power_w
        self.soc = max(0.0, self.soc - 100.0 * self.power_w * dt / self._energy_j)

    def reading(self) -> BatteryReading:
        return reading_at(self.soc, self.power_w)


def reading_at(soc: float, power_w: float) -> BatteryReading:
    """The BMS's report at this charge and draw (an injected soc shows in the voltages too)."""
    open_circuit_v = CELLS * (CELL_EMPTY_V + (CELL_FULL_V - CELL_EMPTY_V) * soc / 100.0)
    current_a = power_w / open_circuit_v
    pack_v = open_circuit_v - INTERNAL_OHM * current_a
    return BatteryReading(soc=soc, pack_v=pack_v, cell_v=pack_v / CELLS, current_a=-current_a, power_w=power_w)
