"""Snapshots the firmware hands to the DDS bridge (copies, safe to use outside the sim's lock)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from g1_sim.physics.battery import BatteryReading


@dataclass(frozen=True)
class LowStateSnapshot:
    """What rt/lowstate carries: joints in motor order and the pelvis IMU."""

    q: np.ndarray  # 29, rad
    dq: np.ndarray  # 29, rad/s
    tau_est: np.ndarray  # 29, N m (the torque the motors applied)
    imu_quaternion: np.ndarray  # w x y z
    imu_gyroscope: np.ndarray  # rad/s, body frame
    imu_accelerometer: np.ndarray  # m/s^2, body frame (specific force: +9.81 z when at rest)
    imu_rpy: np.ndarray  # roll, pitch, yaw in rad
    tick: int  # ms of sim time since boot
    mode_machine: int
    motor_mode: np.ndarray  # 29, uint8: 1 = the motor is enabled (servo on), 0 = disabled (no torque)


class ImuSnapshot(NamedTuple):
    """What an IMU reports (unitree_hg IMUState_): orientation, rates and specific force in its own frame.
    (Plain floats in a named tuple: made 500 times a second of sim time, published as they are.)"""

    quaternion: tuple[float, ...]  # w x y z
    gyroscope: tuple[float, ...]  # rad/s
    accelerometer: tuple[float, ...]  # m/s^2 (specific force: +9.81 z when at rest upright)
    rpy: tuple[float, ...]  # roll, pitch, yaw in rad


@dataclass(frozen=True)
class BasePose:
    """Pelvis pose and twist in the world frame (for odometry and tests)."""

    position: np.ndarray  # x y z, m
    quaternion: np.ndarray  # w x y z
    linear_velocity: np.ndarray  # m/s, world
    angular_velocity: np.ndarray  # rad/s, world


def rpy_of(w: float, x: float, y: float, z: float) -> tuple[float, float, float]:
    """Roll, pitch, yaw (ZYX) of a w x y z quaternion, on floats (numpy's calls per element would cost more
    than the arithmetic, at 1000 calls a second of sim time)."""
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


def quat_to_rpy(q: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw (ZYX) of a w x y z quaternion."""
    return np.array(rpy_of(*np.asarray(q, dtype=float).tolist()))


@dataclass(frozen=True)
class BodySnapshot:
    """What the robot's body reports besides joints and IMU: motor temperatures, battery, the remote."""

    casing_c: np.ndarray  # 29, deg C
    winding_c: np.ndarray  # 29, deg C
    battery: BatteryReading
    remote_keys: frozenset[str]  # keys held on the operator's remote


def tilt_rad(q_wxyz: np.ndarray) -> float:
    """Angle between the body's z axis and vertical, as Unitree's terminations.hpp computes it from the IMU
    quaternion (acos of minus the z of gravity in the body frame)."""
    _, x, y, _ = q_wxyz
    return float(np.arccos(np.clip(1.0 - 2.0 * (x * x + y * y), -1.0, 1.0)))
