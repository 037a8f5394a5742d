"""The robot's state estimator as the sim models it: the true pelvis motion plus a slow drift and noise.

A real G1 estimates its pose from the IMU and leg kinematics (rt/odommodestate); the estimate drifts from the
truth, and a client that fuses or checks odometry must be tested against an estimate, not the truth. The
model, with the errors of :class:`OdomErrors`:

* heading: a gyro scale error, ``yaw_per_rad`` rad of error per rad turned (signed: turning back undoes it);
* position: the true horizontal displacement, scaled by ``1 + xy_per_m`` (``xy_per_m`` m of error per m
  travelled straight) and rotated by the heading error so far, plus a creep of ``xy_mps`` m/s in a direction
  drawn from the seed (what foot slip does to a standing robot's estimate);
* ``noise_m``: white noise on the reported position (x, y, z), not integrated.

The estimate starts equal to the truth (the odometry frame is the world frame at the start) and integrates
displacements between calls, so it goes on through periods nobody asks for it (debug mode) and is the same
whatever the call rate, but for the noise. Deterministic given the seed and the calls' sim times.
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass
from typing import Final, NamedTuple

#: Defaults: small enough to look like a good estimator, large enough that a test tells the estimate from the
#: truth within a few seconds (1 cm per m walked, 1 cm of creep a minute standing, 0.2 % of the turns, 1 mm noise).
DEFAULT_XY_PER_M: Final = 0.01
DEFAULT_XY_MPS: Final = 0.0002
DEFAULT_YAW_PER_RAD: Final = 0.002
DEFAULT_NOISE_M: Final = 0.001


@dataclass(frozen=True)
class OdomErrors:
    """How the estimate departs from the truth (module docstring); all zero: the truth itself."""

    xy_per_m: float = DEFAULT_XY_PER_M
    xy_mps: float = DEFAULT_XY_MPS
    yaw_per_rad: float = DEFAULT_YAW_PER_RAD
    noise_m: float = DEFAULT_NOISE_M


Vec3 = tuple[float, float, float]


class OdomEstimate(NamedTuple):
    """What rt/odommodestate carries (odometry frame: the world frame at the start), and the truth beside it.
    (A named tuple: made 500 times a second of sim time, it costs a fraction of a frozen dataclass.)"""

    position: Vec3  # x y z, m (noise included)
    velocity: Vec3  # m/s, odometry frame
    yaw_speed: float  # rad/s
    quaternion: tuple[float, float, float, float]  # w x y z: the true roll and pitch, the estimated yaw
    rpy: Vec3  # roll, pitch, yaw (estimated) in rad
    gyroscope: Vec3  # rad/s, body frame
    body_height: float  # m, the pelvis above the floor
    true_position: Vec3  # x y z, m
    true_yaw: float  # rad


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def _quat_from_rpy(roll: float, pitch: float, yaw: float) -> tuple[float, float, float, float]:
    """w x y z of the ZYX Euler angles (yaw, then pitch, then roll)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy)


class Odometer:
    """The estimate of one robot; ``update`` at the moments the robot publishes it.

    Plain floats, no numpy: it runs 500 times a second of sim time on a handful of numbers.
    """

    def __init__(self, errors: OdomErrors | None = None, seed: int = 0) -> None:
        self.errors = errors or OdomErrors()
        self._rng = random.Random(seed)
        angle = self._rng.uniform(0.0, 2.0 * math.pi)
        self._creep = (self.errors.xy_mps * math.cos(angle), self.errors.xy_mps * math.sin(angle))
        self._t: float | None = None
        self._true_xy = (0.0, 0.0)
        self._true_yaw = 0.0
        self._x = self._y = 0.0
        self._yaw_error = 0.0

    def update(self, t: float, position: Vec3, q_wxyz: tuple[float, float, float, float], velocity: Vec3,
               gyroscope: Vec3) -> OdomEstimate:
        """The estimate at sim time ``t`` of a pelvis at ``position`` with orientation ``q_wxyz`` moving at
        ``velocity`` (world frame) and turning at ``gyroscope`` (body frame)."""
        e = self.errors
        w, qx, qy, qz = q_wxyz
        # the rotation matrix's entries this needs (body to world)
        r00, r10 = 1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy + w * qz)
        r20, r21, r22 = 2 * (qx * qz - w * qy), 2 * (qy * qz + w * qx), 1 - 2 * (qx * qx + qy * qy)
        true_yaw = math.atan2(r10, r00)
        x, y, z = position
        if self._t is None:  # the odometry frame is the world frame at the first call
            self._t, self._true_xy, self._true_yaw, self._x, self._y = t, (x, y), true_yaw, x, y
        self._yaw_error += e.yaw_per_rad * _wrap(true_yaw - self._true_yaw)
        k = 1.0 + e.xy_per_m
        c, s = k * math.cos(self._yaw_error), k * math.sin(self._yaw_error)
        dx, dy, dt = x - self._true_xy[0], y - self._true_xy[1], t - self._t
        self._x += c * dx - s * dy + self._creep[0] * dt
        self._y += s * dx + c * dy + self._creep[1] * dt
        self._t, self._true_xy, self._true_yaw = t, (x, y), true_yaw
        nx, ny, nz = (self._rng.gauss(0.0, e.noise_m) for _ in range(3)) if e.noise_m > 0 else (0.0, 0.0, 0.0)
        roll = math.atan2(r21, r22)
        pitch = math.asin(max(-1.0, min(1.0, -r20)))
        yaw = _wrap(true_yaw + self._yaw_error)
        vx, vy, vz = velocity
        gx, gy, gz = gyroscope
        yaw_rate = r20 * gx + r21 * gy + r22 * gz  # the world z component of the body rate
        return OdomEstimate(
            position=(self._x + nx, self._y + ny, z + nz),
            velocity=(c * vx - s * vy + self._creep[0], s * vx + c * vy + self._creep[1], vz),
            yaw_speed=(1.0 + e.yaw_per_rad) * yaw_rate, quaternion=_quat_from_rpy(roll, pitch, yaw),
            rpy=(roll, pitch, yaw), gyroscope=(gx, gy, gz), body_height=z + nz, true_position=(x, y, z),
            true_yaw=true_yaw)
