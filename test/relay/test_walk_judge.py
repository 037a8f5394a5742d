"""The walk judge: acknowledged Moves against the robot's odometry, without ROS."""

from __future__ import annotations

import math

from g1_mode_manager.core.port import OdomSample
from g1_mode_manager.protocol.odom_fields import OdomFields
from g1_mode_manager.relay.walk_judge import WARNING, WalkJudge


def odom(x: float = 0.0, y: float = 0.0, yaw: float = 0.0, age_s: float = 0.02) -> OdomSample:
    fields = OdomFields(stamp_s=0.0, position=(x, y, 0.75), velocity=(0.0, 0.0, 0.0), yaw_speed=0.0,
                        quaternion=(math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)), gyroscope=(0.0, 0.0, 0.0),
                        rpy=(0.0, 0.0, math.atan2(math.sin(yaw), math.cos(yaw))), body_height=0.75)
    return OdomSample(fields, age_s, 1)


def feed(judge: WalkJudge, seconds: float, command: tuple[float, float, float], moves: tuple[float, float, float],
         start: float = 0.0, *, sway: float = 0.0, odometry: bool = True, age_s: float = 0.02) -> float:
    """Moves acknowledged at 10 Hz for ``seconds`` while the robot goes at ``moves`` (vx m/s, vy m/s, wz rad/s)
    from the origin, swaying ``sway`` m to and fro; returns the time of the last one."""
    t = start
    while t <= start + seconds + 1e-9:
        s = sway * math.sin(2 * math.pi * 1.5 * t)
        sample = odom(moves[0] * t + s, moves[1] * t, moves[2] * t, age_s) if odometry else None
        judge.acknowledged(*command, t, sample)
        t += 0.1
    return t - 0.1


def test_a_robot_that_acknowledges_moves_but_stands_still_is_reported_after_a_window() -> None:
    judge = WalkJudge(after_s=2.0)
    last = feed(judge, 1.5, (0.4, 0.0, 0.0), (0.01, 0.0, 0.0))
    assert judge.report(last).warning is None  # not a whole window yet
    last = feed(judge, 1.0, (0.4, 0.0, 0.0), (0.01, 0.0, 0.0), start=last + 0.1)
    warning = judge.report(last).warning
    assert warning is not None and warning.startswith(WARNING)
    assert "commanded 0.40 m/s" in warning and "odometry shows 0.01 m/s" in warning


def test_a_body_swaying_in_place_is_not_walking() -> None:
    judge = WalkJudge(after_s=1.0)
    last = feed(judge, 3.0, (0.5, 0.0, 0.0), (0.0, 0.0, 0.0), sway=0.05)  # 0.05 m at 1.5 Hz: up to 0.47 m/s
    assert judge.report(last).warning is not None


def test_a_walking_robot_is_not_reported() -> None:
    judge = WalkJudge(after_s=1.0)
    last = feed(judge, 3.0, (0.4, 0.0, 0.0), (0.35, 0.0, 0.0), sway=0.02)
    report = judge.report(last)
    assert report.warning is None and report.judged and report.measured[0] > 0.3


def test_turning_in_place_counts_as_walking_also_across_the_half_turn() -> None:
    judge = WalkJudge(after_s=1.0)
    last = feed(judge, 6.0, (0.0, 0.0, 0.8), (0.0, 0.0, 0.7))  # 4.2 rad: yaw wraps past pi
    report = judge.report(last)
    assert report.warning is None and 0.6 < report.measured[1] < 0.8


def test_the_warning_lapses_once_moves_stop_and_clears_once_the_robot_walks() -> None:
    judge = WalkJudge(after_s=1.0)
    last = feed(judge, 2.0, (0.4, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert judge.report(last).warning is not None
    assert judge.report(last + 1.5).warning is None  # no Move acknowledged for 1.5 s
    last = feed(judge, 2.0, (0.4, 0.0, 0.0), (0.0, 0.0, 0.0), start=last + 2.0)
    assert judge.report(last).warning is not None
    last = feed(judge, 1.5, (0.4, 0.0, 0.0), (0.4, 0.0, 0.0), start=last + 0.1)
    assert judge.report(last).warning is None


def test_small_commands_and_missing_or_stale_odometry_are_not_judged() -> None:
    judge = WalkJudge(after_s=0.5)
    last = feed(judge, 2.0, (0.05, 0.0, 0.1), (0.0, 0.0, 0.0))  # below what is worth walking for
    assert judge.report(last).warning is None
    for kwargs in ({"odometry": False}, {"age_s": 2.0}):
        judge = WalkJudge(after_s=0.5)
        last = feed(judge, 2.0, (0.4, 0.0, 0.0), (0.0, 0.0, 0.0), **kwargs)
        report = judge.report(last)
        assert report.warning is None and not report.judged
