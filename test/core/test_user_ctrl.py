"""LOW_LEVEL by user control against the fake robot's firmware: entry, exits, refusals, silence, e-stops and FAULT
inside each step, and the supervision's expectation of fsm 1000."""

from __future__ import annotations

import threading
import time

import pytest

from fakes.fake_clock import FakeClock
from fakes.fake_robot import RELEASED
from fakes.fake_user_ctrl import UserCtrlRobot
from fakes.machine_rig import damp_confirmed_within
from g1_mode_manager.core.joint_commands import DAMPING
from g1_mode_manager.core.machine import ModeMachine, Result, TransitionRecord
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.user_ctrl import UNSUPPORTED, LowLevelPath, UserCtrlConfig, roll_pitch, upright
from g1_mode_manager.protocol.fsm import USER_CTRL_FSM_ID, InternalCtrl

ID, HI, LO, EM, FA = Mode.IDLE, Mode.HIGH_LEVEL, Mode.LOW_LEVEL, Mode.EMERGENCY, Mode.FAULT


class Rig:
    def __init__(self, firmware: str = "either", *, real_time: bool = False) -> None:
        self.robot = UserCtrlRobot(firmware=firmware)
        self.clock = None if real_time else FakeClock()
        self.records: list[TransitionRecord] = []
        timing = {"clock": time.monotonic, "sleep": time.sleep} if self.clock is None else \
            {"clock": self.clock, "sleep": self.clock.sleep}
        self.machine = ModeMachine(self.robot, user_ctrl=UserCtrlConfig(), on_record=self.records.append,
                                   **timing)  # type: ignore[arg-type]
        self.link = self.machine.user_ctrl_link
        assert self.link is not None

    def to(self, mode: Mode) -> None:
        outcome = self.machine.request(mode)
        assert outcome.success, outcome
        assert self.machine.mode is mode

    def wait_damp_confirmed(self, timeout_s: float = 5.0) -> bool:
        return damp_confirmed_within(self.machine, timeout_s)


def test_path_is_user_ctrl_when_configured() -> None:
    assert Rig().machine.low_level_path is LowLevelPath.USER_CTRL


def test_entry_from_walking_holds_the_pose_switches_and_sees_1000_before_committing() -> None:
    rig = Rig()
    rig.robot.switch_polls = 3
    rig.to(HI)
    start = len(rig.robot.calls)
    outcome = rig.machine.request(LO)
    assert outcome.success and rig.machine.mode is LO, outcome
    assert "user control" in outcome.message and "[low_level_path: user_ctrl]" in outcome.message
    assert "500 -> 1000" in outcome.message
    names = rig.robot.names(start)
    switch = names.index("switch_to_user_ctrl")
    assert names[:switch] == ["check_mode", "get_fsm_id"], names
    assert names[switch + 1:] == ["get_fsm_id"] * 4, names  # polled until 1000 showed
    # the hand-over frame went out before the switch, holding the measured pose with the configured gains
    in_user_ctrl, frame = rig.robot.user_frames[0]
    assert not in_user_ctrl and frame[3].kp == UserCtrlConfig().hold_kp and frame[3].q == 0.0
    assert rig.robot.user_ctrl and rig.link.live and rig.link.filler.kp[0] == UserCtrlConfig().hold_kp
    assert "release_mode" not in names and "select_mode" not in names  # the robot was never limp


def test_entry_from_damp_in_idle() -> None:
    rig = Rig()
    rig.to(ID)
    rig.robot.damped = True
    rig.to(LO)
    assert rig.robot.user_ctrl and rig.robot.fsm_before == 1


def test_firmware_without_user_control_is_refused_with_nothing_changed() -> None:
    rig = Rig("none")
    rig.to(HI)
    start = len(rig.robot.calls)
    outcome = rig.machine.request(LO)
    assert not outcome.success and outcome.refused and outcome.message == UNSUPPORTED
    assert rig.machine.mode is HI and rig.machine.status().last_refusal == UNSUPPORTED
    assert rig.robot.names(start) == ["check_mode", "get_fsm_id", "switch_to_user_ctrl"]  # nothing after the 7110
    assert not rig.link.live
    assert rig.records[-1].outcome is Result.REFUSED


def test_a_robot_refusing_the_switch_in_its_state_is_refused() -> None:
    rig = Rig("from_walkrun")
    rig.to(ID)
    rig.robot.damped = True
    outcome = rig.machine.request(LO)
    assert outcome.refused and "refused SwitchToUserCtrl" in outcome.message and "fsm 1" in outcome.message
    assert rig.machine.mode is ID and not rig.link.live and not rig.robot.internal_ctrl_calls


def test_a_released_service_is_refused_without_a_robot_call_that_changes_it() -> None:
    rig = Rig()
    rig.to(ID)
    rig.robot.set_service(RELEASED)
    outcome = rig.machine.request(LO)
    assert outcome.refused and "released" in outcome.message
    assert "switch_to_user_ctrl" not in rig.robot.names()


def test_1000_never_seen_hands_back_with_last_and_says_what_the_robot_showed() -> None:
    rig = Rig()
    rig.to(HI)
    rig.robot.switch_never_shows = True
    outcome = rig.machine.request(LO)
    assert outcome.refused and rig.machine.mode is HI
    assert "showed fsm 500, not 1000" in outcome.message and "SwitchToInternalCtrl(LAST)" in outcome.message
    assert rig.robot.internal_ctrl_calls == [InternalCtrl.LAST]
    assert rig.clock is not None and rig.clock.slept >= UserCtrlConfig().switch_timeout_s


def test_exit_to_high_level_hands_back_to_walkrun_and_sees_it_standing() -> None:
    rig = Rig()
    rig.to(HI)
    rig.to(LO)
    outcome = rig.machine.request(HI)
    assert outcome.success and "walk-run" in outcome.message and "fsm 500 seen" in outcome.message, outcome
    assert rig.robot.internal_ctrl_calls == [InternalCtrl.WALKRUN] and not rig.robot.user_ctrl
    assert not rig.link.live
    assert "select_mode" not in rig.robot.names()  # never limp: no SelectMode on this path


def test_exit_to_idle_hands_back_to_the_last_controller() -> None:
    rig = Rig()
    rig.to(ID)
    rig.robot.damped = True
    rig.to(LO)
    outcome = rig.machine.request(ID)
    assert outcome.success and rig.robot.internal_ctrl_calls == [InternalCtrl.LAST]
    assert rig.robot.damped and not rig.robot.user_ctrl and not rig.link.live


def test_exit_tilted_goes_passive_and_fault() -> None:
    rig = Rig()
    rig.to(HI)
    rig.to(LO)
    rig.robot.roll_pitch = (0.1, 0.9)
    outcome = rig.machine.request(HI)
    assert not outcome.success and "not upright" in outcome.message and "FAULT" in outcome.message
    assert rig.machine.mode is FA
    assert rig.wait_damp_confirmed()
    assert InternalCtrl.WALKRUN not in rig.robot.internal_ctrl_calls
    assert rig.robot.internal_ctrl_calls[0] is InternalCtrl.PASSIVE and rig.robot.damped and not rig.link.live
    assert any("user_ctrl hand-back" in f for f in rig.machine.status().faults)


def test_silence_hands_back_to_walkrun_into_idle() -> None:
    rig = Rig()
    rig.to(HI)
    rig.to(LO)
    outcome = rig.machine.hand_back_on_silence()
    assert outcome.success and rig.machine.mode is ID and "silent" in outcome.message
    assert "silent" in rig.machine.status().last_error  # ~/mode says why LOW_LEVEL was left
    assert rig.robot.internal_ctrl_calls == [InternalCtrl.WALKRUN] and not rig.robot.damped


def test_silence_on_a_tilted_robot_is_passive_and_fault() -> None:
    rig = Rig()
    rig.to(HI)
    rig.to(LO)
    rig.robot.roll_pitch = (1.3, 0.0)  # past the template's roll limit
    rig.machine.hand_back_on_silence()
    assert rig.machine.mode is FA and rig.wait_damp_confirmed()
    assert rig.robot.internal_ctrl_calls == [InternalCtrl.PASSIVE]


def test_silence_with_the_attitude_unknown_waits_for_it_then_counts_it_not_upright() -> None:
    rig = Rig()
    rig.to(HI)
    rig.to(LO)
    assert rig.clock is not None
    slept = rig.clock.slept
    rig.robot.roll_pitch = None  # no fresh rt/lowstate: looked for, then judged blind
    rig.machine.hand_back_on_silence()
    assert rig.machine.mode is FA and rig.wait_damp_confirmed()
    assert rig.robot.internal_ctrl_calls == [InternalCtrl.PASSIVE]
    assert rig.clock.slept - slept >= UserCtrlConfig().switch_timeout_s


def test_estop_in_user_control_damps_by_frame_then_passive_and_verifies() -> None:
    rig = Rig()
    rig.to(HI)
    rig.to(LO)
    frames = len(rig.robot.user_frames)
    start = len(rig.robot.calls)
    outcome = rig.machine.estop()
    assert outcome.success and rig.machine.status().damp_confirmed, outcome
    # the first thing out is a damping frame on rt/user_lowcmd (the fake logs frames apart from calls)
    assert rig.robot.user_frames[frames][1] == tuple(DAMPING)
    names = rig.robot.names(start)
    assert names[0] == "damp_no_reply" and "switch_to_internal_ctrl" in names
    assert names.index("switch_to_internal_ctrl") < names.index("damp")
    assert rig.robot.internal_ctrl_calls == [InternalCtrl.PASSIVE]
    assert rig.robot.damped and not rig.robot.user_ctrl and not rig.link.live


@pytest.mark.parametrize("step", ["switch_to_user_ctrl", "get_fsm_id"])
def test_estop_inside_the_entry_preempts_it_and_damps_the_robot(step: str) -> None:
    rig = Rig(real_time=True)
    rig.to(HI)
    rig.robot.switch_polls = 2
    hold = rig.robot.hold(step) if step == "switch_to_user_ctrl" else None
    outcomes = []
    entry = threading.Thread(target=lambda: outcomes.append(rig.machine.request(LO)))
    if step == "get_fsm_id":
        hold_after = threading.Event()
        original = rig.robot.switch_to_user_ctrl

        def switched(timeout_s: float | None = None) -> None:
            original(timeout_s)
            hold_after.set()

        rig.robot.switch_to_user_ctrl = switched  # type: ignore[method-assign]
        entry.start()
        assert hold_after.wait(5.0)
    else:
        entry.start()
        assert hold is not None and hold.wait_entered()
    estop: list = []
    stopper = threading.Thread(target=lambda: estop.append(rig.machine.estop()))
    stopper.start()
    time.sleep(0.05)
    if hold is not None:
        hold.release()
    entry.join(5.0)
    stopper.join(10.0)
    assert outcomes and outcomes[0].message.endswith("preempted by e-stop"), outcomes
    assert estop and estop[0].success, estop
    assert rig.machine.mode is EM and rig.robot.damped and not rig.robot.user_ctrl
    assert rig.robot.get_fsm_id() == 1


def test_fault_in_user_control_is_passive_and_verified() -> None:
    rig = Rig()
    rig.to(HI)
    rig.to(LO)
    assert rig.machine.fault(("tilt: 1.2 rad > 1",))
    assert rig.wait_damp_confirmed()
    assert rig.robot.internal_ctrl_calls == [InternalCtrl.PASSIVE] and rig.robot.damped


def test_supervision_expects_1000_in_low_level() -> None:
    rig = Rig()
    rig.to(HI)
    rig.to(LO)
    assert rig.clock is not None
    rig.clock.advance(2.0)
    rig.machine.supervise()
    assert not rig.machine.status().robot_mismatch
    rig.robot.user_ctrl = False  # another program handed the robot back
    rig.clock.advance(2.0)
    rig.machine.supervise()
    assert "not 1000" in rig.machine.status().robot_mismatch
    assert not rig.machine.allows_low_level_commands()


def test_estop_seeing_a_late_switch_marks_the_robot_live_again() -> None:
    rig = Rig()
    rig.to(HI)
    rig.to(LO)
    rig.to(HI)
    assert not rig.link.live
    rig.robot.user_ctrl = True  # a switch that landed late
    rig.machine.estop()
    assert rig.robot.damped and not rig.robot.user_ctrl


def test_roll_pitch_and_upright_limits() -> None:
    assert roll_pitch(1.0, 0.0, 0.0, 0.0) == (0.0, 0.0)
    r, p = roll_pitch(0.8776, 0.0, 0.4794, 0.0)  # 1.0 rad about y
    assert abs(p - 1.0) < 1e-3 and abs(r) < 1e-6
    assert upright((1.0, 0.8)) and not upright((1.01, 0.0)) and not upright((0.0, -0.81)) and not upright(None)
    assert USER_CTRL_FSM_ID == 1000


def test_a_switch_landing_after_the_entry_gave_up_is_a_fault_damped_with_passive() -> None:
    rig = Rig()
    rig.to(HI)
    rig.robot.switch_never_shows = True
    assert rig.machine.request(LO).refused
    assert not rig.link.live
    rig.robot.user_ctrl = True  # the firmware did not cancel the accepted switch: it lands now
    rig.machine.supervise(USER_CTRL_FSM_ID, 0.01)  # right after the hand-back was verified: no evidence yet
    assert rig.machine.mode is HI
    assert rig.clock is not None
    rig.clock.advance(1.0)
    rig.machine.supervise(USER_CTRL_FSM_ID, 0.01)
    assert rig.machine.mode is FA and rig.wait_damp_confirmed()
    assert rig.robot.internal_ctrl_calls[-1] is InternalCtrl.PASSIVE and rig.robot.damped
    assert any("fsm 1000" in f for f in rig.machine.status().faults)


def test_the_entry_waits_for_rest_and_refuses_a_robot_that_keeps_moving() -> None:
    rig = Rig()
    rig.to(HI)
    rig.robot.joint_speed = 2.5  # stepping
    outcome = rig.machine.request(LO)
    assert outcome.refused and "not at rest" in outcome.message and "2.50 rad/s" in outcome.message, outcome
    assert "switch_to_user_ctrl" not in rig.robot.names() and not rig.robot.user_frames and not rig.link.live
    assert rig.clock is not None and rig.clock.slept >= UserCtrlConfig().rest_timeout_s


def test_an_estop_while_the_entry_measures_the_pose_leaves_no_stiff_hold_behind_it() -> None:
    """The e-stop lands after the entry's last robot call and before its hand-over frame: the entry must not begin
    the hold after the e-stop (the relay would repeat a kp 300 frame after the Damp until the robot was seen out
    of a user control it never entered)."""
    rig = Rig(real_time=True)
    rig.to(HI)
    measuring, go_on = threading.Event(), threading.Event()
    original = rig.robot.joint_positions

    def paused_pose():
        measuring.set()
        assert go_on.wait(10.0)
        return original()

    rig.robot.joint_positions = paused_pose  # type: ignore[method-assign]
    outcomes: list = []
    entry = threading.Thread(target=lambda: outcomes.append(rig.machine.request(LO)))
    entry.start()
    assert measuring.wait(5.0)
    frames_before = len(rig.robot.user_frames)
    estop = rig.machine.estop()
    go_on.set()
    entry.join(5.0)
    assert estop.success, estop
    assert outcomes and outcomes[0].message.endswith("preempted by e-stop"), outcomes
    stiff = [frame for _, frame in rig.robot.user_frames[frames_before:] if max(c.kp for c in frame) > 0]
    assert stiff == [], "a hand-over frame reached the robot after the e-stop"
    assert rig.link.filler == DAMPING and not rig.link.live
    assert rig.machine.mode is EM and rig.robot.damped and not rig.robot.user_ctrl


def test_low_level_is_refused_while_a_body_check_holds_motion_with_nothing_sent() -> None:
    """In LOW_LEVEL a hold damps the robot: entering it would hand a standing robot to damping."""
    rig = Rig()
    rig.to(HI)
    rig.machine.hold(("winding_overheat: 121.00 °C > 120",))
    start = len(rig.robot.calls)
    outcome = rig.machine.request(LO)
    assert outcome.refused and rig.machine.mode is HI, outcome
    assert "holds motion (winding_overheat: 121.00 °C > 120)" in outcome.message and "~/clear_fault" in outcome.message
    assert rig.robot.names(start) == [] and rig.robot.user_frames == [] and not rig.link.live
    assert rig.machine.clear_fault(lambda: "", lambda: None).success
    rig.to(LO)  # released: the entry runs


def test_estop_waits_for_a_switch_accepted_during_it_before_it_claims_the_robot_damped() -> None:
    """A damped robot (fsm 1) whose SwitchToUserCtrl, in flight at the e-stop, is accepted and takes effect later
    than switch_timeout_s: the Damp does nothing while it is pending and GetFsmId still shows 1, so a verification
    then would pass and the robot switch after it. The e-stop waits for the switch, then PASSIVE and Damp."""
    rig = Rig(real_time=True)
    rig.to(HI)
    rig.robot.damped = True  # the robot lies damped; the firmware takes the switch from damping
    rig.robot.switch_polls = 70  # 1000 shows 70 GetFsmId polls (about 1.4 s) after the switch is accepted
    hold = rig.robot.hold("switch_to_user_ctrl")
    outcomes: list = []
    entry = threading.Thread(target=lambda: outcomes.append(rig.machine.request(LO)))
    entry.start()
    assert hold.wait_entered()
    estop: list = []
    stopper = threading.Thread(target=lambda: estop.append(rig.machine.estop()))
    stopper.start()
    time.sleep(0.05)
    hold.release()
    entry.join(10.0)
    stopper.join(15.0)
    assert estop and estop[0].success, estop
    seen = [rig.robot.get_fsm_id() for _ in range(100)]  # longer than the switch took
    assert USER_CTRL_FSM_ID not in seen, "the robot switched to user control after the e-stop's success"
    assert rig.robot.damped and not rig.robot.user_ctrl
    assert InternalCtrl.PASSIVE in rig.robot.internal_ctrl_calls
