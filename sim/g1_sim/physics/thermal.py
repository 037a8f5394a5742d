"""Motor temperatures: a two-node thermal model per motor (winding and casing), heated by its torque.

The G1 reports a casing and a winding temperature per motor, and a body supervisor stops the robot when
either runs hot (Unitree's terminations.hpp: winding > 120 C, casing > 85 C). The sim needs temperatures
that behave like a motor's: near ambient at rest, rising under load, the casing lagging the winding.

Per motor, with T_w the winding and T_c the casing temperature::

    C_w dT_w/dt = P - (T_w - T_c) / R_wc           P = copper loss = P_rated (tau / tau_cont)^2
    C_c dT_c/dt = (T_w - T_c) / R_wc - (T_c - T_amb) / R_ca

Copper loss grows with the current squared, and a motor's current with its torque. Rated continuous
torque is a quarter of the effort limit (peak torque is several times the continuous one on such
actuators); held there, a winding settles at 115 C and its casing at 79 C, just under the limits. The
figures are chosen, not measured on a G1: bigger motors get proportionally more loss, heat capacity and
cooling (``size`` = limit / largest limit), so every motor has the same time constants (about 45 s for
the winding, about 5 min for the casing) and the same temperature at the same fraction of its rating.
Standing takes a few per cent of rated loss, so a standing robot warms by a few degrees only.
"""

from __future__ import annotations

from typing import Final

import numpy as np
from numpy.typing import ArrayLike

AMBIENT_C: Final = 25.0
#: Loss of the largest motor at its continuous torque, W, and that torque as a fraction of the effort limit.
RATED_LOSS_W: Final = 120.0
CONTINUOUS_FRACTION: Final = 0.25
#: Of the largest motor: heat capacities (J/K) and thermal resistances (K/W) winding->casing, casing->air.
WINDING_J_PER_K: Final = 150.0
CASING_J_PER_K: Final = 600.0
WINDING_TO_CASING_K_PER_W: Final = 0.30
CASING_TO_AIR_K_PER_W: Final = 0.45


class MotorThermal:
    """Winding and casing temperatures (deg C) of every motor, advanced by :meth:`update`."""

    def __init__(self, effort_limit: ArrayLike, *, ambient_c: float = AMBIENT_C) -> None:
        limit = np.asarray(effort_limit, dtype=float)
        size = limit / limit.max()
        self.ambient_c = float(ambient_c)
        self._loss_per_tau2 = RATED_LOSS_W * size / (CONTINUOUS_FRACTION * limit) ** 2
        self._c_w = WINDING_J_PER_K * size
        self._c_c = CASING_J_PER_K * size
        self._g_wc = size / WINDING_TO_CASING_K_PER_W  # conductances, W/K
        self._g_ca = size / CASING_TO_AIR_K_PER_W
        self.winding = np.full(limit.shape, self.ambient_c)
        self.casing = np.full(limit.shape, self.ambient_c)

    def copper_loss_w(self, tau: np.ndarray) -> np.ndarray:
        """Heat each motor's winding makes at these torques, W (also drawn from the battery)."""
        return self._loss_per_tau2 * (tau * tau)

    def update(self, loss_w: np.ndarray, dt: float) -> None:
        """Advance ``dt`` seconds with these losses (explicit Euler: dt is far below the time constants)."""
        to_casing = self._g_wc * (self.winding - self.casing)
        to_air = self._g_ca * (self.casing - self.ambient_c)
        self.winding += dt * (loss_w - to_casing) / self._c_w
        self.casing += dt * (to_casing - to_air) / self._c_c
