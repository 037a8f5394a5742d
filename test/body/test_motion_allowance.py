"""What a playing motion allows the speed checks, without a robot: nothing when none plays (the vendor's thresholds
as they were), the motion's own speeds plus a margin while one plays, never past a joint's velocity limit; and a flail
far beyond the motion still trips, with the joint named."""

from __future__ import annotations

import numpy as np
import pytest

from g1_mode_manager.core.body.checks import BY_NAME
from g1_mode_manager.core.body.monitor import BodyMonitor
from g1_mode_manager.core.body.motion_allowance import (
    JOINT_MARGIN,
    REFERENCE_WINDOW_S,
    SPIN_MARGIN_RAD_S,
    SPIN_SHARE,
    MotionRecord,
    MotionSpeeds,
    allowance,
)
from g1_mode_manager.core.body.readings import readings_of
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.protocol.body_fields import BodyFields
from g1_mode_manager.protocol.motors import JOINT_NAMES, NUM_JOINTS, VELOCITY_LIMIT_RAD_S

JOINT_BASE, SPIN_BASE = BY_NAME["joint_speed"].threshold, BY_NAME["spin"].threshold
KNEE, WRIST = JOINT_NAMES.index("left_knee_joint"), JOINT_NAMES.index("left_wrist_roll_joint")


def _fields(dq: dict[int, float] | None = None, gyro: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> BodyFields:
    speeds = [0.0] * NUM_JOINTS
    for i, v in (dq or {}).items():
        speeds[i] = v
    return BodyFields((1.0, 0.0, 0.0, 0.0), gyro, tuple(speeds), (30,) * NUM_JOINTS, (30,) * NUM_JOINTS,
                      bytes(40), (0.0,) * NUM_JOINTS)


def _motion(joint: float = 0.0, yaw: float = 0.0, **at: float) -> MotionSpeeds:
    speeds = np.full(NUM_JOINTS, joint)
    for name, v in at.items():
        speeds[JOINT_NAMES.index(name)] = v
    return MotionSpeeds(speeds, np.array([0.0, 0.0, yaw]))


def _judge(fields: BodyFields, motion: MotionSpeeds | None):
    readings = readings_of(fields, state_age_s=0.002, soc_pct=90.0,
                           allowance=allowance(JOINT_BASE, SPIN_BASE, motion), joint_base_rad_s=JOINT_BASE)
    monitor = BodyMonitor(clear_hold_s=1.0)
    monitor.evaluate(readings, Mode.LOW_LEVEL, True, 10.0)
    return readings, monitor.evaluate(readings, Mode.LOW_LEVEL, True, 10.02)


def test_with_no_motion_the_checks_judge_the_raw_speeds_against_the_vendors_thresholds() -> None:
    readings, trips = _judge(_fields({WRIST: 11.92}), None)
    assert readings.joint_speed_judged == pytest.approx(11.92) and readings.joint_speed_max == pytest.approx(11.92)
    assert [t.text for t in trips] == ["joint_speed: 11.92 rad/s > 10"]
    _, trips = _judge(_fields(gyro=(0.0, 0.0, -6.5)), None)
    assert [t.text for t in trips] == ["spin: 6.50 rad/s > 6"]


def test_a_motions_own_joint_speed_is_no_flail_and_a_speed_far_beyond_it_is() -> None:
    dancing = _motion(right_shoulder_yaw_joint=21.0)
    shoulder = JOINT_NAMES.index("right_shoulder_yaw_joint")
    _, trips = _judge(_fields({shoulder: 24.0}), dancing)
    assert trips == []
    limit = VELOCITY_LIMIT_RAD_S[WRIST]
    # the same dance asks the wrist for 1 rad/s: the wrist may move 1 + JOINT_MARGIN of its limit, no faster
    bound = 1.0 + JOINT_MARGIN * limit
    _, trips = _judge(_fields({WRIST: bound - 0.5}), _motion(1.0))
    assert trips == []
    _, trips = _judge(_fields({WRIST: bound + 0.5}), _motion(1.0))
    assert [t.check for t in trips] == ["joint_speed"]
    assert f"left_wrist_roll_joint at {bound + 0.5:.2f} rad/s, its bound {bound:.2f}" in trips[0].text


def test_no_motion_allows_a_joint_past_its_velocity_limit_nor_does_a_base_set_above_it() -> None:
    knee_limit = VELOCITY_LIMIT_RAD_S[KNEE]
    _, trips = _judge(_fields({KNEE: knee_limit + 0.5}), _motion(left_knee_joint=knee_limit))
    assert [t.check for t in trips] == ["joint_speed"]
    raised = allowance(40.0, SPIN_BASE, None)
    assert raised.joints[KNEE] == pytest.approx(knee_limit - 40.0)  # judged = speed + 20: trips above the limit


def test_a_motions_turn_is_no_spin_and_a_turn_far_beyond_it_or_about_another_axis_is() -> None:
    turning = _motion(yaw=7.0)  # a dance's pirouette about the vertical
    bound = (1.0 + SPIN_SHARE) * 7.0 + SPIN_MARGIN_RAD_S
    _, trips = _judge(_fields(gyro=(0.0, 0.0, bound - 0.2)), turning)
    assert trips == []
    _, trips = _judge(_fields(gyro=(0.0, 0.0, bound + 0.2)), turning)
    assert [t.check for t in trips] == ["spin"]
    _, trips = _judge(_fields(gyro=(6.5, 0.0, 7.0)), turning)  # tipping over (pitch) while it spins
    assert [t.check for t in trips] == ["spin"]


def test_the_motions_speeds_count_for_the_window_before_its_newest_tick_until_that_is_a_window_old() -> None:
    now = [5.0]
    record = MotionRecord(JOINT_BASE, SPIN_BASE, clock=lambda: now[0])
    assert record.recent() is None and record.current() is None
    record.note(np.full(NUM_JOINTS, -4.0), np.array([-2.0, 0.0, 1.0]))  # directions do not matter
    now[0] += 0.02
    record.note(np.full(NUM_JOINTS, 1.0), np.array([0.5, 0.0, 3.0]))
    recent = record.recent()
    assert recent is not None and np.all(recent.joints == 4.0) and list(recent.body_rates) == [2.0, 0.0, 3.0]
    assert record.current() == allowance(JOINT_BASE, SPIN_BASE, recent)
    now[0] = 5.0 + REFERENCE_WINDOW_S + 0.01
    record.note(np.full(NUM_JOINTS, 1.0), np.zeros(3))
    assert np.all(record.recent().joints == 1.0)  # the first tick left the window
    now[0] += REFERENCE_WINDOW_S + 0.01
    assert record.recent() is None and record.current() is None  # the policy stopped: nothing beyond the bases
