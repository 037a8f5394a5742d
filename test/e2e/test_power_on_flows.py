"""The vendor's power-on flows, judged on the sim's record: a G1 powered on folded in a squat, or lying on its back
(damped either way), is brought up by one `g1ctl recover` and walks after `start`, with exactly the vendor's get-up on
the request topic (Unitree's remote-control guide, as quoted in phanthymotus-driver PR #215: folded, damp then
squat-to-stand 706; lying, damp then lie-to-stand 702) and the balance stand after it."""

from __future__ import annotations

import subprocess

import pytest
from g1_mode_manager_msgs.msg import Mode as ModeMsg

from g1_mode_manager.protocol import api_ids
from g1_mode_manager.protocol.fsm import FsmId
from support.mode_manager import wait_until
from support.processes import python_module
from support.sim_record import fsm_of, requests

pytestmark = [pytest.mark.e2e, pytest.mark.sim]

#: How far the robot must walk after getting up: the walk the vendor's flows are for, not a step.
WALKS_M = 1.0


@pytest.mark.parametrize(("boot", "posture", "get_up"), [
    ("squat", "squatting", FsmId.SQUAT_TO_STAND),
    ("lying", "lying_back", FsmId.LIE_TO_STAND),
])
def test_a_robot_powered_on_folded_or_lying_walks_after_recover_and_start(stack_factory, boot: str, posture: str,
                                                                          get_up: FsmId) -> None:
    stack = stack_factory(bridge_args=("--boot-posture", boot))
    # the node just started (UNINITIALIZED: it reads nothing of the robot yet); recover takes it to HIGH_LEVEL
    assert wait_until(lambda: stack.modes(), 10.0) and stack.modes()[-1].name == "UNINITIALIZED"
    t0 = stack.record.events()[0]["t"]

    recover = subprocess.run(python_module("g1_mode_manager.cli.main", "recover"), capture_output=True, text=True,
                             timeout=90)
    print(recover.stdout)
    assert recover.returncode == 0, recover.stdout + recover.stderr
    assert recover.stdout.strip().endswith("recover: the robot stands"), recover.stdout
    assert f"({posture})" in recover.stdout, "the get-up was not chosen by the posture the node read"
    fsm_asked = [fsm_of(e) for e in requests(stack.record.events(t0), api_ids.LOCO_SET_FSM_ID)]
    assert fsm_asked == [FsmId.DAMP, get_up], fsm_asked
    balance = requests(stack.record.events(t0), api_ids.LOCO_SET_BALANCE_MODE)
    assert len(balance) == 1 and balance[0]["t"] > requests(stack.record.events(t0), api_ids.LOCO_SET_FSM_ID)[-1]["t"]
    assert stack.sim.get()["body"]["pelvis_z"] > 0.7

    assert stack.loco("start").success
    walked = stack.walk_forward(0.5, WALKS_M)
    print(f"powered on {boot}: recover, start, walked {walked:.2f} m")
    assert walked >= WALKS_M, f"walked only {walked:.2f} m"
    assert stack.modes()[-1].mode == ModeMsg.HIGH_LEVEL, [list(m.faults) for m in stack.modes()[-3:]]
