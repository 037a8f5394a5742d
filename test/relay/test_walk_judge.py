"""The walk judge: acknowledged Moves against the robot's odometry, without ROS."""

from __future__ import annotations

from g1_mode_manager.core.port import OdomSample
from g1_mode_manager.protocol.odom_fields import OdomFields
from g1_mode_manager.relay.walk_judge import WARNING, WalkJudge


def odom(vx: float = 0.0, vy: float = 0.0, wz: float = 0.0, age_s: float = 0.02) -> OdomSample:
    fields = OdomFields(stamp_s=0.0, position=(0.0, 0.0, 0.75), velocity=(vx, vy, 0.0), yaw_speed=wz,
                        quaternion=(1.0, 0.0, 0.0, 0.0), gyroscope=(0.0, 0.0, wz), rpy=(0.0, 0.0, 0.0),
                        body_height=0.75)  # fmt: skip
    return OdomSample(fields, age_s, 1)


def feed(judge: WalkJudge, seconds: float, command: tuple[float, float, float], measured: OdomSample | None,
         start: float = 0.0) -> float:  # fmt: skip
    """Moves acknowledged at 10 Hz for ``seconds``; returns the time of the last one."""
    t = start
    while t <= start + seconds:
        judge.acknowledged(*command, t, measured)
        t += 0.1
    return t - 0.1


def test_a_robot_that_acknowledges_moves_but_stands_still_is_reported_after_the_limit() -> None:
    judge = WalkJudge(after_s=2.0)
    last = feed(judge, 1.5, (0.4, 0.0, 0.0), odom(0.01))
    assert judge.report(last).warning is None  # not yet: 1.5 s < 2 s
    last = feed(judge, 1.0, (0.4, 0.0, 0.0), odom(0.01), start=last + 0.1)
    warning = judge.report(last).warning
    assert warning is not None and warning.startswith(WARNING)
    assert "commanded 0.40 m/s" in warning and "odometry shows 0.01 m/s" in warning


def test_a_walking_robot_is_not_reported() -> None:
    judge = WalkJudge(after_s=1.0)
    last = feed(judge, 3.0, (0.4, 0.0, 0.0), odom(0.35))
    report = judge.report(last)
    assert report.warning is None and report.judged


def test_turning_in_place_counts_as_walking() -> None:
    judge = WalkJudge(after_s=1.0)
    last = feed(judge, 3.0, (0.0, 0.0, 0.8), odom(wz=0.7))
    assert judge.report(last).warning is None


def test_the_warning_lapses_once_moves_stop_and_clears_once_the_robot_walks() -> None:
    judge = WalkJudge(after_s=1.0)
    last = feed(judge, 2.0, (0.4, 0.0, 0.0), odom(0.0))
    assert judge.report(last).warning is not None
    assert judge.report(last + 1.5).warning is None  # no Move acknowledged for 1.5 s
    last = feed(judge, 2.0, (0.4, 0.0, 0.0), odom(0.0), start=last + 2.0)
    assert judge.report(last).warning is not None
    judge.acknowledged(0.4, 0.0, 0.0, last + 0.1, odom(0.3))
    assert judge.report(last + 0.1).warning is None


def test_small_commands_and_missing_or_stale_odometry_are_not_judged() -> None:
    judge = WalkJudge(after_s=0.5)
    last = feed(judge, 2.0, (0.05, 0.0, 0.1), odom(0.0))  # below what is worth walking for
    assert judge.report(last).warning is None
    for measured in (None, odom(0.0, age_s=2.0)):
        judge = WalkJudge(after_s=0.5)
        last = feed(judge, 2.0, (0.4, 0.0, 0.0), measured)
        report = judge.report(last)
        assert report.warning is None and not report.judged
