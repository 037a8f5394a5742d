"""holosoma's dances (whole-body tracking policies) in the node's loop on the sim, every parameter at its default
(user control), judged on the sim's truth and record:

- a stretch of each clip that holds what stopped the node before (targets past the knee's and the ankles' stops, joints
  faster than 10 rad/s, the body turning at 7 rad/s about the vertical at 27 s) plays without a stop or a fall, and no
  target past its joint's range + margin reaches the robot;
- a motor running away mid-dance (the sim's fault injection) is still a flail: the joint-speed check's FAULT damps the
  robot;
- an e-stop mid-dance damps the robot at once and ends the policy's frames.

The whole clips: ``python -m bench.dance`` (docs/figures.md), longer than any suite can carry.
"""

from __future__ import annotations

import re
import time

import pytest
from g1_mode_manager_msgs.msg import Mode as ModeMsg

from e2e.test_policy import engage, policy_call, statuses
from e2e.user_ctrl_session import (
    STANDING_Z_M,
    USER_CTRL,
    damped_on_the_record,
    frames_on,
    fsm_states,
    no_user_frame_before_1000,
)
from g1_mode_manager.core.body.checks import BY_NAME
from g1_mode_manager.core.joint_commands import RANGE_MARGIN_RAD
from g1_mode_manager.policy.deploy_config import read_config
from g1_mode_manager.protocol.fsm import STANDING_FSM_IDS
from harness.clip import clip_seconds, lowest_reference_m, policy_kp_max
from support.mode_manager import wait_until
from support.sim_record import of_kind
from support.timing import ESTOP_FRAME_S, LOW_LEVEL_REACTION_S, RECORD_WAIT_S, check_latency

pytestmark = [pytest.mark.e2e, pytest.mark.latency_only]

#: The clip's stretch played, s after its start: past the fast turn both dances make at 27 s.
STRETCH_S = 30.0
#: A fall judged on the sim's truth: the pelvis below the clip's own lowest reference by more than this, m, or the
#: body tilted past the vendor's limit.
CROUCH_MARGIN_M = 0.2
FALLEN_TILT_RAD = BY_NAME["tilt"].threshold
#: The left elbow: a light joint that the dances move slowly at the stretch's start.
ELBOW = 18


def _policy_frames(stack, policy: str, since: float) -> list[dict]:
    kp = policy_kp_max(policy)
    return [e for _, e in frames_on(stack.record.events(since), "user_lowcmd") if abs(e["kp_max"] - kp) < 1e-3]


def _clip_at(stack, seconds: float, timeout_s: float) -> None:
    """Until the clip has played ``seconds`` (its progress on ~/policy/status), failing if the policy stops."""
    seen = statuses(stack)
    policy = seen[-1].policy
    length = clip_seconds(policy)
    assert wait_until(lambda: seen[-1].phase != "running" or seen[-1].progress * length >= seconds, timeout_s), \
        f"{policy}: {seen[-1].progress * length:.1f} s of the clip after {timeout_s:.0f} s"
    if seen[-1].phase != "running":
        modes = stack.modes()
        raise AssertionError(f"{policy}: the policy is {seen[-1].phase} ({seen[-1].last_fault!r}) at "
                             f"{seen[-1].progress * length:.1f} s of the clip; the node in "
                             f"{modes[-1].name if modes else '?'} {list(modes[-1].faults) if modes else []}")


@pytest.mark.parametrize("policy", ["dance_ppo", "dance_fastsac"])
def test_a_stretch_of_each_dance_plays_through_its_stops_and_turns_without_a_stop_or_a_fall(shared_stack_factory,
                                                                                             policy: str) -> None:
    floor = lowest_reference_m(policy) - CROUCH_MARGIN_M
    stack = shared_stack_factory(node_params=(USER_CTRL,))
    stack.modes()  # subscribed from the start
    seen = statuses(stack)
    engaged = engage(stack, policy=policy, shadow_s=1.0)
    hold = read_config(policy)[1]["start_hold_s"]
    _clip_at(stack, STRETCH_S, timeout_s=(hold + STRETCH_S) * 3 + 10)
    status = seen[-1]
    body = of_kind(stack.record.events(engaged), "body")
    lowest, tilt = min(e["z"] for e in body), max(e["tilt"] for e in body)
    frames = _policy_frames(stack, policy, engaged)
    past = max((e["past"] for e in frames if e.get("past") is not None), default=0.0)
    clamped = {i: n for i, n in enumerate(status.clamps) if n}
    print(f"{policy}: {STRETCH_S:g} s of the clip, RMS joint error {status.tracking_error_rad:.3f} rad (latest); "
          f"pelvis lowest {lowest:.3f} m (floor {floor:.3f}), tilt at most {tilt:.2f} rad; {len(frames)} policy frames, "
          f"the furthest target {past:.3f} rad past its joint's range; clamped ticks by motor {clamped}; "
          f"state -> frame p50/p99/max {status.state_to_frame_p50_ms:.2f}/{status.state_to_frame_p99_ms:.2f}/"
          f"{status.state_to_frame_max_ms:.2f} ms, jitter p99 {status.frame_jitter_p99_ms:.2f} ms")
    assert stack.modes()[-1].mode == ModeMsg.LOW_LEVEL, list(stack.modes()[-1].faults)
    assert lowest > floor and tilt < FALLEN_TILT_RAD, "the robot fell"
    assert frames and all(e["ok"] for e in frames), "a policy frame the robot did not take"
    assert past <= RANGE_MARGIN_RAD + 1e-3, f"a target {past:.3f} rad past its joint's range reached the robot"
    r = policy_call(stack, "disengage")
    assert r.success, r.message
    assert wait_until(lambda: fsm_states(stack.record.events())[-1][1] in STANDING_FSM_IDS, RECORD_WAIT_S)
    assert stack.sim.get()["body"]["pelvis_z"] > STANDING_Z_M, "not standing after the hand-back"


def test_a_motor_running_away_mid_dance_is_a_flail_the_joint_speed_check_damps(shared_stack_factory) -> None:
    policy = "dance_ppo"
    stack = shared_stack_factory(node_params=(USER_CTRL,))
    stack.modes()  # subscribed from the start
    engage(stack, policy=policy, shadow_s=1.0)
    _clip_at(stack, 2.0, timeout_s=30.0)
    stack.set_faults({"runaway_motor": {"motor": ELBOW, "direction": -1, "duration": 0.3}})
    t_injected = next(e["t"] for e in of_kind(stack.record.events(time.monotonic() - 5.0), "inject")
                      if e["what"] == "runaway_motor")
    assert wait_until(lambda: stack.modes()[-1].mode == ModeMsg.FAULT, RECORD_WAIT_S), stack.modes()[-1]
    faults = list(stack.modes()[-1].faults)
    assert any(f.startswith("joint_speed:") and "left_elbow_joint" in f for f in faults), faults
    first_damping = damped_on_the_record(stack, t_injected)[0]
    # the condition: the elbow past the bound the dance allowed it (the fault names both), on the record's body
    # samples (their largest |dq|: the runaway elbow's, once it passes a bound no other joint is near)
    text = next(f for f in faults if f.startswith("joint_speed:"))
    bound = float(re.search(r"its bound ([0-9.]+)", text).group(1))
    body = of_kind(stack.record.events(t_injected - 1.0), "body")
    past = next(e for e in body if e["t"] >= t_injected and e["dq"] > bound)
    before = max(e["t"] for e in body if e["t"] < past["t"])
    print(f"runaway elbow mid-dance: {text}; the record's first sample past {bound:.2f} rad/s "
          f"{(past['t'] - t_injected) * 1e3:.0f} ms after the injection")
    # the node reads rt/lowstate between the record's samples: the condition may precede its first sample of it
    check_latency("runaway motor mid-dance -> first damping frame", before, first_damping["t"], LOW_LEVEL_REACTION_S)
    late = [e for e in _policy_frames(stack, policy, t_injected) if e["t"] > first_damping["t"]]
    assert not late, f"{len(late)} policy frames after the first damping frame"
    assert wait_until(lambda: stack.sim.get()["sport"]["fsm_id"] == 1, RECORD_WAIT_S), "the robot was not damped"


def test_an_estop_mid_dance_damps_the_robot_and_ends_the_policys_frames(shared_stack_factory) -> None:
    policy = "dance_fastsac"
    stack = shared_stack_factory(node_params=(USER_CTRL,))
    seen = statuses(stack)
    engage(stack, policy=policy, shadow_s=1.0)
    _clip_at(stack, 5.0, timeout_s=40.0)  # into the clip: the robot dances, upright
    stack.match_estop()
    t0 = time.monotonic()
    r = stack.estop()
    answered = time.monotonic()
    assert r.success, r.message
    first_damping = damped_on_the_record(stack, t0)[0]
    ev = stack.record.events()
    check_latency("e-stop mid-dance -> first damping frame", t0, first_damping["t"], ESTOP_FRAME_S)
    no_user_frame_before_1000(ev, user_kp=policy_kp_max(policy))
    frames = _policy_frames(stack, policy, 0.0)
    assert [e for e in frames if e["t"] < t0], "no policy frame reached the robot before the e-stop"
    after = [e for e in frames if e["t"] > answered]
    assert not after, f"{len(after)} policy frames after the e-stop's answer"
    assert stack.sim.get()["sport"]["fsm_id"] == 1 and not stack.sim.get()["user_ctrl"]
    assert wait_until(lambda: seen[-1].phase == "loaded", 5.0), seen[-1].phase
    print(f"e-stopped {max(s.progress for s in seen) * 100:.2f} % into the clip")
