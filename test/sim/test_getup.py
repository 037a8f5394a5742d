"""The simulated G1 gets up only the way a G1 can: damped on the floor (on its back or front), lie-to-stand
(702) raises it in a few seconds and leaves it balanced at fsm 702; a stand-up (4) or squat-to-stand (706) of
a lying robot answers 0 and nothing moves; 706 squats a standing robot down and stands a squatting one up.
Runs MuJoCo: run under the sim CPU lock."""

from __future__ import annotations

import pytest

from g1_mode_manager.protocol.api_ids import ERR_REFUSED_IN_STATE, OK
from g1_mode_manager.protocol.fsm import FsmId, FsmMode
from g1_sim.firmware import SimG1
from g1_sim.firmware.posture import Posture

pytestmark = pytest.mark.sim


def run(sim: SimG1, seconds: float) -> None:
    sim.step(round(seconds / sim.dt))


def lying(push: tuple[float, float] | None = None) -> SimG1:
    """Damped on the floor: damping alone tips the standing robot onto its back; a push forward first puts
    it on its front."""
    sim = SimG1()
    if push:
        sim.push(push, 0.3)
        run(sim, 2.5)
    assert sim.set_fsm_id(FsmId.DAMP) == OK
    run(sim, 2.0)
    return sim


@pytest.mark.parametrize("push, posture", [(None, Posture.ON_BACK), ((120.0, 0.0), Posture.ON_FRONT)])
def test_lie_to_stand_raises_a_damped_lying_robot_in_a_few_seconds(push, posture: Posture) -> None:
    sim = lying(push)
    assert sim.posture is posture
    assert sim.set_fsm_id(FsmId.LIE_TO_STAND) == OK
    run(sim, 0.1)
    assert sim.get_fsm_id() == (OK, FsmId.LIE_TO_STAND) and sim.get_fsm_mode() == (OK, FsmMode.DYNAMIC)
    t = 0.0
    while sim.get_fsm_mode() == (OK, FsmMode.DYNAMIC) and t < 10.0:
        run(sim, 0.1)
        t += 0.1
    print(f"702 from {posture.value}: static after {t + 0.1:.1f} s, pelvis {sim.base_pose().position[2]:.2f} m")
    assert 3.0 < t < 8.0
    assert sim.get_fsm_id() == (OK, FsmId.LIE_TO_STAND)  # the robot stays at 702 once up
    assert sim.standing_balanced and not sim.fallen and sim.posture is Posture.UPRIGHT
    assert sim.base_pose().position[2] > 0.7
    assert sim.set_fsm_id(FsmId.START) == OK  # and walks from there
    run(sim, 1.0)
    assert sim.get_fsm_id() == (OK, FsmId.START) and not sim.fallen


@pytest.mark.parametrize("fsm", [FsmId.STAND_UP, FsmId.SQUAT_TO_STAND])
def test_stand_up_and_squat_to_stand_leave_a_lying_robot_down(fsm: FsmId) -> None:
    sim = lying()
    assert sim.set_fsm_id(fsm) == OK  # answered 0 ...
    run(sim, 4.0)
    assert sim.get_fsm_id() == (OK, FsmId.DAMP)  # ... and nothing moved
    assert sim.posture is Posture.ON_BACK and sim.base_pose().position[2] < 0.2
    assert sim.counters["posture_ignored"] == 1


def test_lie_to_stand_needs_damp_and_a_lying_robot() -> None:
    sim = SimG1()  # standing in lock stand
    assert sim.set_fsm_id(FsmId.LIE_TO_STAND) == ERR_REFUSED_IN_STATE
    assert sim.set_fsm_id(FsmId.DAMP) == OK
    assert sim.set_fsm_id(FsmId.LIE_TO_STAND) == OK  # damped but still on its feet: 0, nothing
    assert sim.get_fsm_id() == (OK, FsmId.DAMP)


def test_706_squats_a_standing_robot_and_stands_a_squatting_one() -> None:
    sim = SimG1()
    assert sim.set_fsm_id(FsmId.SQUAT_TO_STAND) == OK  # StandUp2Squat
    run(sim, 3.0)
    assert sim.get_fsm_id() == (OK, FsmId.SQUAT_TO_STAND) and sim.get_fsm_mode() == (OK, FsmMode.STATIC)
    assert sim.base_pose().position[2] < 0.65 and not sim.fallen and sim.posture is Posture.UPRIGHT
    assert sim.set_fsm_id(FsmId.START) == ERR_REFUSED_IN_STATE  # no walking from the squat
    assert sim.set_fsm_id(FsmId.STAND_UP) == ERR_REFUSED_IN_STATE  # standing again goes through damping

    sim = SimG1()
    assert sim.set_fsm_id(FsmId.SQUAT) == OK
    run(sim, 3.0)
    assert sim.set_fsm_id(FsmId.SQUAT_TO_STAND) == OK  # Squat2StandUp
    run(sim, 4.0)
    assert sim.get_fsm_id() == (OK, FsmId.SQUAT_TO_STAND) and sim.standing_balanced
    assert sim.base_pose().position[2] > 0.7 and not sim.fallen
