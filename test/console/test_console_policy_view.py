"""The Policy card's picture: the loop's status as the page shows it, and the policy's targets against the measured
joints, matched by name into the motor order, plotted only while both are fresh."""

from __future__ import annotations

import math
from types import SimpleNamespace

from fakes.fake_clock import FakeClock
from g1_mode_manager.console.policy_view import PolicyView, in_motor_order, status_fields
from g1_mode_manager.console.robot_view import FAST_STALE_S
from g1_mode_manager.protocol.motors import JOINT_NAMES


def status_msg(**overrides) -> SimpleNamespace:
    fields = dict(policy="loco_ppo", phase="shadow", rate_hz=49.96, inference_p99_ms=1.234, tick_p99_ms=2.345,
                  ticks=120, overruns=1, skipped=2, blend=0.0, progress=-1.0, max_target_error_rad=0.12345,
                  tracking_error_rad=-1.0, last_fault="", action_scale="flat 0.25", state_to_frame_p99_ms=2.5,
                  frame_jitter_p99_ms=0.8, clamps=[])
    fields.update(overrides)
    return SimpleNamespace(**fields)


def test_the_status_is_shown_with_minus_one_as_none_and_nothing_json_cannot_carry() -> None:
    fields = status_fields(status_msg())
    assert fields["phase"] == "shadow" and fields["rate_hz"] == 50.0 and fields["inference_p99_ms"] == 1.23
    assert fields["progress"] is None and fields["tracking_error_rad"] is None  # a walker: no clip, no reference
    assert fields["max_target_error_rad"] == 0.1235 and fields["overruns"] == 1
    dance = status_fields(status_msg(policy="dance_ppo", progress=0.4567, tracking_error_rad=0.05, tick_p99_ms=math.nan))
    assert dance["progress"] == 0.457 and dance["tracking_error_rad"] == 0.05
    assert dance["tick_p99_ms"] is None  # NaN would make the page's JSON.parse throw
    clamped = status_fields(status_msg(clamps=[0, 0, 0, 0, 7] + [0] * 24))
    assert clamped["clamped"] == {"left_ankle_pitch_joint": 7} and fields["clamped"] == {}
    assert fields["action_scale"] == "flat 0.25" and fields["state_to_frame_p99_ms"] == 2.5


def test_before_any_status_the_card_says_unloaded_and_knows_no_joints() -> None:
    clock, view = FakeClock(), PolicyView()
    snap = view.snapshot(clock())
    assert snap["status"]["phase"] == "unloaded" and snap["status"]["no_status"]
    assert snap["joints"] is None and snap["default"] is None and snap["engage_limit_rad"] is None
    assert view.sample(clock(), 0.0)["err"] is None  # a gap, not a zero
    view.set_params("loco_ppo", 0.5)
    view.on_status(status_fields(status_msg(phase="loaded")))
    snap = view.snapshot(clock())
    assert snap["status"]["phase"] == "loaded" and "no_status" not in snap["status"]
    assert snap["default"] == "loco_ppo" and snap["engage_limit_rad"] == 0.5


def test_targets_against_measured_joints_match_by_name_and_plot_the_largest_difference() -> None:
    clock, view = FakeClock(), PolicyView(history_len=2)
    targets = [0.01 * i for i in range(len(JOINT_NAMES))]
    view.on_targets(JOINT_NAMES, targets, clock())
    assert view.sample(clock(), 0.0)["err"] is None  # no measured joints yet
    measured = dict(zip(JOINT_NAMES, targets, strict=True))
    measured["left_knee_joint"] += 0.3
    measured["right_wrist_yaw_joint"] -= 0.1
    names = [*reversed(measured), "a_hand_joint"]  # another order, and a joint that is not the G1's 29
    view.on_joints(names, [*(measured[n] for n in reversed(measured)), 9.9], clock())
    assert view.sample(clock(), 0.1)["err"] == 0.3
    joints = view.snapshot(clock())["joints"]
    assert joints["target"][JOINT_NAMES.index("left_knee_joint")] == 0.03
    assert joints["measured"][JOINT_NAMES.index("left_knee_joint")] == 0.33
    clock.advance(FAST_STALE_S + 0.1)  # the loop stopped ticking: its targets went stale
    view.on_joints(names, [*(measured[n] for n in reversed(measured)), 9.9], clock())
    assert view.sample(clock(), 0.7)["err"] is None and view.snapshot(clock())["joints"] is None
    assert [p["t"] for p in view.history()] == [0.1, 0.7]  # bounded


def test_a_message_missing_a_joint_or_carrying_a_non_finite_one_is_not_plotted() -> None:
    values = [0.0] * len(JOINT_NAMES)
    assert in_motor_order(JOINT_NAMES, values) == values
    assert in_motor_order(JOINT_NAMES[1:], values[1:]) is None
    assert in_motor_order(JOINT_NAMES, [math.nan, *values[1:]]) is None
