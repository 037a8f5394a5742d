"""The sim started the way the vendor's power-on flows begin: folded in a squat, or lying on its back, damped
(``start_posture``, the bridge's ``--boot-posture``, kept by a reset). From there the flows of Unitree's remote
guide work: squat -> damp -> 706 stands the robot up, lying -> damp -> 702 gets it up. Runs MuJoCo (and one
bridge): run under the sim CPU lock."""

from __future__ import annotations

import functools

import pytest
from unitree_sdk2py.g1.loco.g1_loco_client import LocoClient

from g1_mode_manager.protocol.api_ids import OK
from g1_mode_manager.protocol.fsm import FsmId, FsmMode
from g1_sim.firmware import SimG1
from g1_sim.firmware.posture import Posture
from g1_sim.firmware.state import tilt_rad
from support.sdk_calls import initialised
from support.sim_bridge import shared_sim_status, sim_bridge_factory  # noqa: F401  (fixture)

pytestmark = pytest.mark.sim

#: Standing again: the pelvis above this (lock stand 0.76).
STANDING_ABOVE_M = 0.7


def run(sim: SimG1, seconds: float) -> None:
    sim.step(round(seconds / sim.dt))


def test_booted_folded_in_a_squat_the_robot_is_damped_on_its_feet_and_706_stands_it_up() -> None:
    sim = SimG1(start_posture="squat")
    assert sim.get_fsm_id() == (OK, FsmId.DAMP) and sim.get_fsm_mode() == (OK, FsmMode.STATIC)
    for _ in range(50):  # 5 s: folded on its feet all along
        run(sim, 0.1)
        pose = sim.base_pose()
        assert 0.15 < pose.position[2] < 0.3 and tilt_rad(pose.quaternion) < 0.8, pose
        assert sim.posture is Posture.UPRIGHT and not sim.fallen
    assert sim.set_fsm_id(FsmId.DAMP) == OK  # the flow's L2+B: already damped, nothing changes
    assert sim.set_fsm_id(FsmId.SQUAT_TO_STAND) == OK  # L2+A
    run(sim, 4.0)
    assert sim.get_fsm_id() == (OK, FsmId.SQUAT_TO_STAND) and sim.get_fsm_mode() == (OK, FsmMode.STATIC)
    assert sim.standing_balanced and sim.base_pose().position[2] > STANDING_ABOVE_M


def test_booted_lying_the_robot_is_damped_on_its_back_and_702_gets_it_up() -> None:
    sim = SimG1(start_posture="lying")
    assert sim.get_fsm_id() == (OK, FsmId.DAMP)
    run(sim, 1.0)
    assert sim.posture is Posture.ON_BACK and sim.base_pose().position[2] < 0.2
    assert sim.counters["falls"] == 0  # booted on the floor: no fall
    assert sim.set_fsm_id(FsmId.SQUAT_TO_STAND) == OK  # a squat-to-stand does not lift a lying robot
    run(sim, 2.0)
    assert sim.get_fsm_id() == (OK, FsmId.DAMP) and sim.posture is Posture.ON_BACK
    assert sim.set_fsm_id(FsmId.LIE_TO_STAND) == OK  # L2+X
    run(sim, 8.0)
    assert sim.get_fsm_id() == (OK, FsmId.LIE_TO_STAND) and sim.get_fsm_mode() == (OK, FsmMode.STATIC)
    assert sim.standing_balanced and sim.base_pose().position[2] > STANDING_ABOVE_M


def test_a_robot_booted_off_its_feet_is_limp_or_damped() -> None:
    assert SimG1(start_posture="lying", start_fsm=FsmId.ZERO_TORQUE).get_fsm_id() == (OK, FsmId.ZERO_TORQUE)
    with pytest.raises(ValueError, match="fsm 0 or 1"):
        SimG1(start_posture="squat", start_fsm=FsmId.STAND_UP)
    with pytest.raises(ValueError):
        SimG1(start_posture="kneeling")


def test_cli_boot_posture() -> None:
    from g1_sim.bridge.main import parse_cli

    assert parse_cli([]).boot_posture == "standing"
    assert parse_cli(["--boot-posture", "lying"]).boot_posture == "lying"
    with pytest.raises(SystemExit):
        parse_cli(["--boot-posture", "kneeling"])


@functools.cache
def _loco() -> LocoClient:
    """One for the session: SDK entities must outlive every bridge (harness/sim_bridge.py: pitfall)."""
    return initialised(LocoClient())


def test_bridge_booted_folded_reports_it_keeps_it_through_a_reset_and_stands_up_by_the_vendors_flow(
        sdk_channels: int, sim_bridge_factory) -> None:  # noqa: F811
    sim_bridge_factory(speed=1.0, extra_args=("--boot-posture", "squat", "--no-ros-publish"))
    status = shared_sim_status()
    first = status.wait_ready()
    assert first["boot_posture"] == "squat" and first["sport"]["fsm_id"] == FsmId.DAMP, first["sport"]
    assert first["body"]["posture"] == "upright" and first["body"]["pelvis_z"] < 0.3, first["body"]
    again = status.reset()  # folded again, sim time from 0
    assert again["sim_time"] < 1.0 and again["sport"]["fsm_id"] == FsmId.DAMP, again["sport"]
    assert again["body"]["posture"] == "upright" and again["body"]["pelvis_z"] < 0.3, again["body"]
    loco = _loco()
    # Damp and Squat2StandUp, as the SDK's LocoClient sends them (its methods drop the answer): L2+B, L2+A
    assert loco.SetFsmId(FsmId.DAMP) == OK and loco.SetFsmId(FsmId.SQUAT_TO_STAND) == OK
    up = status.wait_sim_time(status.get()["sim_time"] + 4.0)  # the stand-up takes ~3 s of sim time
    assert (up["sport"]["fsm_id"], up["sport"]["fsm_mode"]) == (FsmId.SQUAT_TO_STAND, FsmMode.STATIC), up["sport"]
    assert up["body"]["pelvis_z"] > STANDING_ABOVE_M, up["body"]
