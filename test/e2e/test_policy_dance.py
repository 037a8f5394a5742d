"""holosoma's dance (a whole-body tracking policy) in the node's loop on the sim: an e-stop while the clip plays
damps the robot at once and ends the policy's frames, judged on the sim's record. The whole clip is
``python -m bench.dance`` (docs/figures.md): longer than the suite can carry."""

from __future__ import annotations

import time

import pytest

from e2e.test_policy import POLICY_KP_MAX, STEADY_POLICY, engage, statuses
from e2e.user_ctrl_session import damped_on_the_record, frames_on, no_user_frame_before_1000
from g1_mode_manager.policy.deploy_config import read_config
from support.mode_manager import wait_until
from support.timing import ESTOP_FRAME_S, RECORD_WAIT_S, check_latency

pytestmark = [pytest.mark.e2e, pytest.mark.latency_only]

POLICY = "dance_fastsac"


def test_an_estop_mid_dance_damps_the_robot_and_ends_the_policys_frames(shared_stack_factory) -> None:
    stack = shared_stack_factory(node_params=STEADY_POLICY)
    seen = statuses(stack)
    engage(stack, policy=POLICY, shadow_s=1.0)
    # the blend ran under the ready gains; the policy's own frames begin with its start hold (the clip's first time
    # step), and the clip plays start_hold_s after that
    def policy_frames() -> list[float]:
        return [e["t"] for _, e in frames_on(stack.record.events(), "user_lowcmd")
                if abs(e["kp_max"] - POLICY_KP_MAX) < 1e-3]

    assert wait_until(lambda: bool(policy_frames()), RECORD_WAIT_S), "no frame of the policy's on the record"
    # just into the clip (the record's clock is this process's monotonic clock): in the sim the robot falls within a
    # second of the clip's start (docs/robot_compat.md), and the e-stop is judged while the policy drives it
    time.sleep(max(0.0, policy_frames()[0] + read_config(POLICY)[1]["start_hold_s"] + 0.1 - time.monotonic()))
    assert seen[-1].phase == "running", (seen[-1].phase, seen[-1].last_fault)
    stack.match_estop()
    t0 = time.monotonic()
    r = stack.estop()
    answered = time.monotonic()
    assert r.success, r.message

    first_damping = damped_on_the_record(stack, t0)[0]
    ev = stack.record.events()
    check_latency("e-stop mid-dance -> first damping frame", t0, first_damping["t"], ESTOP_FRAME_S)
    no_user_frame_before_1000(ev, user_kp=POLICY_KP_MAX)
    policy = [e for _, e in frames_on(ev, "user_lowcmd") if abs(e["kp_max"] - POLICY_KP_MAX) < 1e-3]
    assert [e for e in policy if e["t"] < t0], "no policy frame reached the robot before the e-stop"
    after = [e for e in policy if e["t"] > answered]
    assert not after, f"{len(after)} policy frames after the e-stop's answer"
    assert stack.sim.get()["sport"]["fsm_id"] == 1 and not stack.sim.get()["user_ctrl"]
    assert wait_until(lambda: seen[-1].phase == "loaded", 5.0), seen[-1].phase
    played = max(s.progress for s in seen)
    print(f"e-stopped {played * 100:.2f} % into the clip (its status at 2 Hz), RMS joint error against the motion's "
          f"reference {max(s.tracking_error_rad for s in seen):.3f} rad at most")
    assert played > 0.0, "the clip never started"
