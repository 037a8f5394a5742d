"""The robot's state estimate (firmware.odometry): the truth plus the drift and noise it is configured with."""

from __future__ import annotations

import math

import pytest

from g1_sim.firmware.odometry import OdomErrors, Odometer

EXACT = OdomErrors(xy_per_m=0.0, xy_mps=0.0, yaw_per_rad=0.0, noise_m=0.0)


def _quat_yaw(yaw: float) -> tuple[float, float, float, float]:
    return (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))


def _walk(odo: Odometer, *, rate_hz: float, seconds: float, speed: float = 0.5, turn: float = 0.0,
          t0: float = 0.0, start: tuple[float, float, float] = (0.0, 0.0, 0.0)):
    """Drive a pelvis (0.75 m high) forward at ``speed`` m/s while turning at ``turn`` rad/s (the path stepped at
    500 Hz), asking the odometer at ``rate_hz``; the last estimate and the true (x, y, yaw)."""
    x, y, yaw = start
    dt, every = 0.002, round(500 / rate_hz)
    est = None
    for k in range(round(seconds / dt) + 1):
        if k:
            x, y, yaw = x + speed * math.cos(yaw) * dt, y + speed * math.sin(yaw) * dt, yaw + turn * dt
        if k % every == 0:
            velocity = (speed * math.cos(yaw), speed * math.sin(yaw), 0.0)
            est = odo.update(t0 + k * dt, (x, y, 0.75), _quat_yaw(yaw), velocity, (0.0, 0.0, turn))
    assert est is not None
    return est, (x, y, yaw)


def test_without_errors_the_estimate_is_the_truth() -> None:
    est, (x, y, yaw) = _walk(Odometer(EXACT), rate_hz=500, seconds=4.0, turn=0.3)
    assert est.position == pytest.approx((x, y, 0.75), abs=1e-9)
    assert est.rpy[2] == pytest.approx(math.remainder(yaw, 2 * math.pi), abs=1e-9)
    assert est.velocity == pytest.approx((0.5 * math.cos(yaw), 0.5 * math.sin(yaw), 0.0), abs=1e-9)
    assert est.yaw_speed == pytest.approx(0.3) and est.gyroscope == (0.0, 0.0, 0.3)
    assert est.quaternion == pytest.approx(_quat_yaw(math.remainder(yaw, 2 * math.pi)), abs=1e-9)
    assert est.body_height == 0.75 and est.true_position == (x, y, 0.75)


def test_position_drifts_by_its_scale_error_per_metre_walked() -> None:
    odo = Odometer(OdomErrors(xy_per_m=0.01, xy_mps=0.0, yaw_per_rad=0.0, noise_m=0.0))
    est, (x, y, _) = _walk(odo, rate_hz=500, seconds=20.0)  # 10 m along x
    assert x == pytest.approx(10.0)
    assert est.position[0] - x == pytest.approx(0.1, rel=1e-6) and est.position[1] == pytest.approx(y)
    assert est.velocity[0] == pytest.approx(0.505)


def test_heading_drifts_by_its_scale_error_per_radian_turned_and_bends_the_path() -> None:
    odo = Odometer(OdomErrors(xy_per_m=0.0, xy_mps=0.0, yaw_per_rad=0.01, noise_m=0.0))
    est, (_, _, yaw) = _walk(odo, rate_hz=500, seconds=math.pi / 2 / 0.5, speed=0.0, turn=0.5)  # a quarter turn
    assert yaw == pytest.approx(math.pi / 2, abs=1e-3)
    assert est.rpy[2] - est.true_yaw == pytest.approx(0.01 * yaw, rel=1e-6)
    assert est.yaw_speed == pytest.approx(0.505)
    est, (x, y, _) = _walk(odo, rate_hz=500, seconds=2.0, t0=10.0, start=(0.0, 0.0, yaw))  # then 1 m along +y
    heading_error = 0.01 * yaw
    assert est.position[0] - x == pytest.approx(-math.sin(heading_error), rel=1e-3)
    assert est.position[1] == pytest.approx(y, abs=1e-3)


def test_a_standing_robot_creeps_at_its_drift_speed_in_a_seeded_direction() -> None:
    errors = OdomErrors(xy_per_m=0.0, xy_mps=0.001, yaw_per_rad=0.0, noise_m=0.0)
    a, _ = _walk(Odometer(errors, seed=3), rate_hz=20, seconds=100.0, speed=0.0)
    b, _ = _walk(Odometer(errors, seed=3), rate_hz=20, seconds=100.0, speed=0.0)
    c, _ = _walk(Odometer(errors, seed=4), rate_hz=20, seconds=100.0, speed=0.0)
    assert math.hypot(a.position[0], a.position[1]) == pytest.approx(0.1)
    assert math.hypot(a.velocity[0], a.velocity[1]) == pytest.approx(0.001)
    assert a.position == b.position and a.position != c.position


def test_the_drift_does_not_depend_on_how_often_it_is_asked() -> None:
    errors = OdomErrors(xy_per_m=0.02, xy_mps=0.0005, yaw_per_rad=0.01, noise_m=0.0)
    fast, truth = _walk(Odometer(errors), rate_hz=500, seconds=6.0, turn=0.4)
    slow, _ = _walk(Odometer(errors), rate_hz=20, seconds=6.0, turn=0.4)
    assert fast.position == pytest.approx(slow.position, abs=1e-3) and fast.rpy[2] == pytest.approx(slow.rpy[2])
    assert math.dist(fast.position[:2], truth[:2]) > 0.02  # and it is there


def test_noise_is_white_of_its_size_and_replays_with_the_seed() -> None:
    errors = OdomErrors(xy_per_m=0.0, xy_mps=0.0, yaw_per_rad=0.0, noise_m=0.002)
    odo, again = Odometer(errors, seed=9), Odometer(errors, seed=9)
    xs = [odo.update(k * 0.002, (1.0, 2.0, 0.75), (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)).position[0]
          for k in range(2000)]
    replay = [again.update(k * 0.002, (1.0, 2.0, 0.75), (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)).position[0]
              for k in range(2000)]
    mean = sum(xs) / len(xs)
    std = math.sqrt(sum((v - mean) ** 2 for v in xs) / len(xs))
    assert mean == pytest.approx(1.0, abs=3e-4) and std == pytest.approx(0.002, rel=0.1)
    assert xs == replay


def test_roll_and_pitch_are_the_truths_the_yaw_the_estimates() -> None:
    odo = Odometer(OdomErrors(xy_per_m=0.0, xy_mps=0.0, yaw_per_rad=0.1, noise_m=0.0))
    odo.update(0.0, (0.0, 0.0, 0.7), (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    # pitched 0.2 rad about y after turning 1 rad about z
    cy, sy, cp, sp = math.cos(0.5), math.sin(0.5), math.cos(0.1), math.sin(0.1)
    q = (cy * cp, -sy * sp, cy * sp, sy * cp)
    est = odo.update(1.0, (0.0, 0.0, 0.7), q, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert est.true_yaw == pytest.approx(1.0)
    assert est.rpy == pytest.approx((0.0, 0.2, 1.1), abs=1e-9)
    w, x, y, z = est.quaternion
    assert w * w + x * x + y * y + z * z == pytest.approx(1.0)
    assert math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)) == pytest.approx(1.1)
