"""What acts on the robot from outside its software: the keys held on the operator's remote (read at 50 Hz by
firmware.loop), the gantry's band and pushes on the pelvis (physics.pelvis_forces), and a motor that runs away.
"""

from __future__ import annotations

from g1_sim.firmware.core import FirmwareCore


class Outside(FirmwareCore):
    """The remote, the gantry, pushes and runaway motors."""

    def set_remote_keys(self, keys: frozenset[str]) -> None:
        """The keys held on the operator's remote from now on (the firmware looks at 50 Hz)."""
        with self._lock:
            self._remote = frozenset(keys)

    def set_gantry(self, on: bool) -> None:
        """Hang the pelvis from the gantry's band (anchored above where it is now), or unhook it."""
        with self._lock:
            self._forces.set_gantry(on, self._data)

    @property
    def gantry(self) -> bool:
        with self._lock:
            return self._forces.gantry

    def push(self, force_xy: tuple[float, float], duration_s: float) -> None:
        """Push the pelvis horizontally (N, world frame) for ``duration_s`` of sim time from now."""
        with self._lock:
            self.counters["pushes"] += 1
            self._forces.push(force_xy, duration_s, self.time)

    def run_away(self, motor: int, direction: int, duration_s: float) -> None:
        """Motor ``motor`` puts out its full effort limit in ``direction`` for ``duration_s`` of sim time from now,
        whatever it is commanded (firmware.loop)."""
        with self._lock:
            self.counters["runaways"] += 1
            self._runaway = (motor, float(direction), self.time + duration_s)
