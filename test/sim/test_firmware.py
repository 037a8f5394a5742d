"""The simulated G1's built-in rules: the rule table (pure, fast) and SimG1's answers (no long stepping)."""

from __future__ import annotations

import numpy as np
import pytest

from g1_mode_manager.protocol.api_ids import (
    ERR_INVALID_FSM_ID,
    ERR_REFUSED_IN_STATE,
    ERR_SERVER_API_NOT_IMPL,
    ERR_SERVER_API_PARAMETER,
    OK,
)
from g1_mode_manager.protocol.fsm import STANDING_FSM_IDS, VALID_FSM_IDS, WALKING_FSM_IDS, FsmId, FsmMode
from g1_mode_manager.protocol.motors import NUM_JOINTS
from g1_sim.firmware import rules
from g1_sim.firmware.posture import Posture, posture_of

# --- rule table (no physics) ---------------------------------------------------------------------


@pytest.mark.parametrize("requested", [-1, 5, 199, 803, 1000])
def test_unknown_fsm_ids_are_invalid(requested: int) -> None:
    assert rules.set_fsm_verdict(FsmId.STAND_UP, requested, dynamic=False) == ERR_INVALID_FSM_ID


@pytest.mark.parametrize("current", sorted(VALID_FSM_IDS))
def test_damp_is_always_allowed_even_while_dynamic(current: int) -> None:
    assert rules.set_fsm_verdict(current, FsmId.DAMP, dynamic=True) == OK
    assert rules.set_fsm_verdict(current, FsmId.DAMP, dynamic=False) == OK


@pytest.mark.parametrize("requested", sorted(VALID_FSM_IDS - {FsmId.DAMP}))
def test_everything_but_damp_is_refused_while_dynamic(requested: int) -> None:
    assert rules.set_fsm_verdict(FsmId.START, requested, dynamic=True) == ERR_REFUSED_IN_STATE


def test_stand_up_needs_damp_first() -> None:
    assert rules.set_fsm_verdict(FsmId.ZERO_TORQUE, FsmId.STAND_UP, dynamic=False) == ERR_REFUSED_IN_STATE
    assert rules.set_fsm_verdict(FsmId.DAMP, FsmId.STAND_UP, dynamic=False) == OK


@pytest.mark.parametrize("walk", sorted(WALKING_FSM_IDS))
def test_walking_starts_only_from_a_stand(walk: int) -> None:
    for current in (FsmId.ZERO_TORQUE, FsmId.DAMP, FsmId.SQUAT, FsmId.SIT):
        assert rules.set_fsm_verdict(current, walk, dynamic=False) == ERR_REFUSED_IN_STATE
    for current in STANDING_FSM_IDS:
        assert rules.set_fsm_verdict(current, walk, dynamic=False) == OK


def test_802_is_accepted_wherever_801_is() -> None:
    for current in VALID_FSM_IDS:
        for dynamic in (False, True):
            assert rules.set_fsm_verdict(current, 802, dynamic=dynamic) == rules.set_fsm_verdict(
                current, FsmId.RUN, dynamic=dynamic)
    assert rules.set_velocity_verdict(802) == OK


def test_zero_torque_is_allowed_from_anywhere_static() -> None:
    for current in VALID_FSM_IDS:
        assert rules.set_fsm_verdict(current, FsmId.ZERO_TORQUE, dynamic=False) == OK


def test_velocity_only_when_walking() -> None:
    for fsm in VALID_FSM_IDS:
        expected = OK if fsm in WALKING_FSM_IDS else ERR_REFUSED_IN_STATE
        assert rules.set_velocity_verdict(fsm) == expected


def test_dynamic_when_walking_with_command_or_moving_fast() -> None:
    kw = {"speed_mps": 0.0, "yaw_rate": 0.0, "transition_running": False}
    assert rules.is_dynamic(FsmId.START, moving_command=True, **kw)
    assert not rules.is_dynamic(FsmId.START, moving_command=False, **kw)
    assert rules.is_dynamic(FsmId.START, moving_command=False, speed_mps=0.5, yaw_rate=0.0,
                            transition_running=False)
    assert not rules.is_dynamic(FsmId.STAND_UP, moving_command=False, speed_mps=0.5, yaw_rate=0.0,
                                transition_running=False)
    assert rules.is_dynamic(FsmId.STAND_UP, moving_command=False, **{**kw, "transition_running": True})


def test_lie_to_stand_only_from_damp() -> None:
    assert rules.set_fsm_verdict(FsmId.DAMP, FsmId.LIE_TO_STAND, dynamic=False) == OK
    for current in (FsmId.ZERO_TORQUE, FsmId.SQUAT, FsmId.SIT, *STANDING_FSM_IDS - {FsmId.LIE_TO_STAND}):
        assert rules.set_fsm_verdict(current, FsmId.LIE_TO_STAND, dynamic=False) == ERR_REFUSED_IN_STATE, current


@pytest.mark.parametrize("posture", list(Posture))
def test_only_702_moves_a_lying_robot_and_702_moves_only_a_lying_one(posture: Posture) -> None:
    assert rules.stays_as_it_is(FsmId.STAND_UP, posture) == posture.lying
    assert rules.stays_as_it_is(FsmId.SQUAT_TO_STAND, posture) == posture.lying
    assert rules.stays_as_it_is(FsmId.LIE_TO_STAND, posture) == (not posture.lying)
    assert not rules.stays_as_it_is(FsmId.DAMP, posture)


def test_706_squats_from_a_stand_and_stands_from_damp_squat_or_sit() -> None:
    for current in STANDING_FSM_IDS:
        assert rules.squats_down(current, FsmId.SQUAT_TO_STAND)
    for current in (FsmId.DAMP, FsmId.SQUAT, FsmId.SIT):
        assert not rules.squats_down(current, FsmId.SQUAT_TO_STAND)
    assert not rules.squats_down(FsmId.STAND_UP, FsmId.STAND_UP)


def test_a_706_squat_takes_only_damping_and_zero_torque() -> None:
    # 706 again included: the way back up from that squat goes through damping (the vendor's remote guide)
    for requested in VALID_FSM_IDS - {FsmId.DAMP, FsmId.ZERO_TORQUE}:
        assert rules.set_fsm_verdict(FsmId.SQUAT_TO_STAND, requested, dynamic=False,
                                     squatting=True) == ERR_REFUSED_IN_STATE, requested
    for requested in (FsmId.DAMP, FsmId.ZERO_TORQUE):
        assert rules.set_fsm_verdict(FsmId.SQUAT_TO_STAND, requested, dynamic=False, squatting=True) == OK


def _quat_about_y(angle: float) -> np.ndarray:
    return np.array([np.cos(angle / 2), 0.0, np.sin(angle / 2), 0.0])


def test_posture_from_pelvis_height_and_tilt() -> None:
    assert posture_of(0.75, _quat_about_y(0.0)) is Posture.UPRIGHT
    assert posture_of(0.30, _quat_about_y(0.5)) is Posture.UPRIGHT  # sagging or squatting, on its feet
    assert posture_of(0.60, _quat_about_y(1.5)) is Posture.UPRIGHT  # tipping, still high: not on the floor yet
    assert posture_of(0.08, _quat_about_y(-1.6)) is Posture.ON_BACK  # pitched back: forward points up
    assert posture_of(0.10, _quat_about_y(1.6)) is Posture.ON_FRONT
    assert Posture.ON_BACK.lying and Posture.ON_FRONT.lying and not Posture.UPRIGHT.lying


# --- SimG1 answers -------------------------------------------------------------------------------

@pytest.fixture
def sim():
    from g1_sim.firmware import SimG1

    return SimG1()


@pytest.mark.sim
def test_boots_standing_in_lock_stand_with_ai_selected(sim) -> None:
    assert sim.check_mode() == ("0", "ai")
    assert sim.sport_active()
    assert sim.get_fsm_id() == (OK, FsmId.STAND_UP)
    assert sim.get_fsm_mode() == (OK, FsmMode.STATIC)
    assert sim.base_pose().position[2] > 0.7


@pytest.mark.sim
def test_sim_answers_invalid_ids_and_velocity_outside_walking(sim) -> None:
    assert sim.set_fsm_id(803) == ERR_INVALID_FSM_ID
    assert sim.set_velocity(0.5, 0.0, 0.0, 1.0) == ERR_REFUSED_IN_STATE
    assert sim.get_fsm_id() == (OK, FsmId.STAND_UP)


@pytest.mark.sim
def test_sim_refuses_switches_while_walking_but_not_damp(sim) -> None:
    assert sim.set_fsm_id(FsmId.START) == OK
    assert sim.set_velocity(0.5, 0.0, 0.0, 1.0) == OK
    assert sim.get_fsm_mode() == (OK, FsmMode.DYNAMIC)
    assert sim.set_fsm_id(FsmId.STAND_UP) == ERR_REFUSED_IN_STATE
    assert sim.set_fsm_id(FsmId.ZERO_TORQUE) == ERR_REFUSED_IN_STATE
    assert sim.set_fsm_id(FsmId.DAMP) == OK
    assert sim.get_fsm_id() == (OK, FsmId.DAMP)
    assert sim.counters["damp_requests"] == 1


@pytest.mark.sim
def test_sim_stand_up_needs_damp(sim) -> None:
    assert sim.set_fsm_id(FsmId.ZERO_TORQUE) == OK
    assert sim.set_fsm_id(FsmId.STAND_UP) == ERR_REFUSED_IN_STATE
    assert sim.set_fsm_id(FsmId.DAMP) == OK
    assert sim.set_fsm_id(FsmId.STAND_UP) == OK
    assert sim.get_fsm_mode() == (OK, FsmMode.DYNAMIC)  # the stand-up motion runs
    assert sim.set_fsm_id(FsmId.START) == ERR_REFUSED_IN_STATE


@pytest.mark.sim
def test_velocity_lapses_after_its_duration(sim) -> None:
    assert sim.set_fsm_id(FsmId.START) == OK
    assert sim.set_velocity(0.3, 0.0, 0.0, 0.1) == OK
    sim.step(round(0.2 / sim.dt))
    assert sim._loco.command.tolist() == [0.0, 0.0, 0.0]


@pytest.mark.sim
def test_parameters_are_checked_and_stored(sim) -> None:
    assert sim.set_speed_mode(7) == ERR_SERVER_API_PARAMETER
    assert sim.set_speed_mode(1) == OK
    assert sim.set_balance_mode(3) == ERR_SERVER_API_PARAMETER
    assert sim.set_balance_mode(1) == OK
    assert sim.get_balance_mode() == (OK, 1)
    assert sim.set_stand_height(0.7) == OK
    assert sim.get_stand_height() == (OK, 0.7)
    assert sim.set_swing_height(0.1) == OK
    assert sim.get_swing_height() == (OK, 0.1)
    assert sim.set_silent(True) == OK
    assert sim.get_silent() is True


@pytest.mark.sim
def test_release_silences_sport_and_select_comes_back_limp(sim) -> None:
    assert sim.release_mode() == OK
    assert sim.check_mode() == ("0", "")
    assert not sim.sport_active()
    assert sim.set_fsm_id(FsmId.DAMP) == ERR_SERVER_API_NOT_IMPL  # no damping in debug mode
    assert sim.get_fsm_id()[0] == ERR_SERVER_API_NOT_IMPL
    assert sim.set_velocity(0.1, 0.0, 0.0, 1.0) == ERR_SERVER_API_NOT_IMPL
    assert sim.select_mode("bogus") == ERR_SERVER_API_PARAMETER
    assert sim.select_mode("ai") == OK
    assert sim.sport_active()
    assert sim.get_fsm_id() == (OK, FsmId.ZERO_TORQUE)
    assert sim.select_mode("ai") == OK  # selecting again changes nothing
    assert sim.get_fsm_id() == (OK, FsmId.ZERO_TORQUE)


@pytest.mark.sim
def test_streams_are_gated_by_state(sim) -> None:
    zeros17, zeros29 = np.zeros(17), np.zeros(NUM_JOINTS)
    sim.apply_lowcmd(zeros29, zeros29, zeros29, zeros29, zeros29, np.ones(NUM_JOINTS))
    assert sim.counters["lowcmd_ignored"] == 1  # not in debug mode
    sim.apply_arm_sdk(zeros17, zeros17, zeros17, zeros17, zeros17, 0.5)
    assert sim.arm_sdk_weight == 0.5  # standing: accepted
    assert sim.set_fsm_id(FsmId.DAMP) == OK
    assert sim.arm_sdk_weight == 0.0  # leaving the stand drops the blend
    sim.apply_arm_sdk(zeros17, zeros17, zeros17, zeros17, zeros17, 0.5)
    assert sim.arm_sdk_weight == 0.0
    assert sim.counters["arm_sdk_ignored"] == 1


@pytest.mark.sim
def test_lowstate_shapes_and_values(sim) -> None:
    sim.step(250)
    ls = sim.lowstate()
    assert ls.q.shape == ls.dq.shape == ls.tau_est.shape == (NUM_JOINTS,)
    assert ls.mode_machine == 5
    assert ls.tick == 500
    assert abs(np.linalg.norm(ls.imu_quaternion) - 1.0) < 1e-6
    assert 8.0 < ls.imu_accelerometer[2] < 11.5  # standing: specific force ~ +g
    assert sim.sport_state() == (FsmId.STAND_UP, FsmMode.STATIC)


@pytest.mark.sim
def test_motor_mode_is_enabled_under_the_built_in_controller_and_as_lowcmd_asks_in_debug_mode(sim) -> None:
    assert sim.lowstate().motor_mode.tolist() == [1] * NUM_JOINTS  # standing
    assert sim.set_fsm_id(FsmId.DAMP) == OK
    assert sim.lowstate().motor_mode.tolist() == [1] * NUM_JOINTS  # damping is a command, not a disabled motor
    assert sim.release_mode() == OK
    assert sim.lowstate().motor_mode.tolist() == [0] * NUM_JOINTS  # debug mode, no rt/lowcmd yet: disabled
    zeros29 = np.zeros(NUM_JOINTS)
    enabled = np.ones(NUM_JOINTS)
    enabled[[3, 9]] = 0
    sim.apply_lowcmd(zeros29, zeros29, zeros29, zeros29, zeros29, enabled)
    assert sim.lowstate().motor_mode.tolist() == enabled.astype(int).tolist()


@pytest.mark.sim
def test_remote_l2_b_damps_while_a_service_is_active_only(sim) -> None:
    sim.set_remote_keys(frozenset({"L2"}))
    sim.step(25)
    assert sim.get_fsm_id() == (OK, FsmId.STAND_UP)  # L2 alone does nothing
    sim.set_remote_keys(frozenset({"L2", "B", "up"}))
    sim.step(25)  # the firmware looks at 50 Hz
    assert sim.get_fsm_id() == (OK, FsmId.DAMP) and sim.counters["remote_damps"] == 1
    assert sim.set_fsm_id(FsmId.STAND_UP) == OK  # still held: pressed once, not re-damped while held
    sim.step(25)
    assert sim.get_fsm_id()[1] != FsmId.DAMP

    sim.set_remote_keys(frozenset())
    assert sim.release_mode() == OK
    sim.set_remote_keys(frozenset({"L2", "B"}))
    sim.step(25)
    assert sim.fsm_id == FsmId.ZERO_TORQUE and sim.counters["remote_damps"] == 1  # debug mode: ignored
    assert sim.body().remote_keys == {"L2", "B"}


def test_missing_assets_name_make_setup(tmp_path) -> None:
    from g1_sim.assets import AssetsMissingError, assets_dir

    with pytest.raises(AssetsMissingError, match="make setup"):
        assets_dir(tmp_path)


@pytest.mark.sim
def test_rpc_threads_and_the_loop_share_the_robot_safely(sim) -> None:
    import threading

    codes: list[int] = []
    stop = threading.Event()

    def rpc_client() -> None:
        while not stop.is_set():
            codes.append(sim.get_fsm_id()[0])
            codes.append(sim.set_fsm_id(FsmId.STAND_UP))
            sim.lowstate()

    client = threading.Thread(target=rpc_client)
    client.start()
    try:
        sim.step(500)
    finally:
        stop.set()
        client.join(timeout=5)
    assert codes and set(codes) == {OK}
    assert sim.base_pose().position[2] > 0.7
