"""The user_ctrl path's lowcmd relay against the fake robot port: rt/user_lowcmd only, the robot never without a
command while it may be under user control, silence handed back (or damped), stops damped."""

from __future__ import annotations

import time

from relay_fakes import Gate

from fakes.fake_robot_port import FakeRobotPort
from g1_mode_manager.core.joint_commands import DAMPING
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.records import Outcome
from g1_mode_manager.core.user_ctrl import SilenceReaction, UserCtrlLink, hold_frame
from g1_mode_manager.protocol.motors import JOINT_INDEX
from g1_mode_manager.relay.link_health import LinkHealth
from g1_mode_manager.relay.user_lowcmd import UserLowCmdRelay

KNEE = ["left_knee_joint"], [0.5], [], [], [100.0], [1.0]
FIRST_FRAME_S = 1.0


class Rig:
    def __init__(self, events, clock, silence: SilenceReaction = SilenceReaction.HAND_BACK) -> None:
        self.port = FakeRobotPort()
        self.gate = Gate(Mode.HIGH_LEVEL)
        self.link = UserCtrlLink(clock)
        self.hand_backs: list[float] = []
        self.relay = UserLowCmdRelay(self.port, self.gate, LinkHealth(self.port, self.gate, 0.5), events,
                                     silence_timeout_s=0.1, exit_damping_s=0.2, service_active=lambda: True,
                                     clock=clock, user_ctrl=self.link, silence=silence, hand_back=self._hand_back,
                                     hold_kp=80.0, hold_kd=2.0, first_frame_s=FIRST_FRAME_S)

    def _hand_back(self) -> Outcome:
        self.hand_backs.append(1.0)
        return Outcome(True, Mode.IDLE, "handed back", 0.0, refused=False)

    def frames(self) -> list:
        return [s.args[0] for s in self.port.stream("write_user_lowcmd")]

    def enter(self) -> None:
        """What the entry step does: the hand-over frame, then fsm 1000 seen, then LOW_LEVEL."""
        self.link.begin(hold_frame(self.port.positions, 80.0, 2.0), lambda: False)
        self.link.entered()
        self.gate.mode = Mode.LOW_LEVEL


def test_user_frames_go_to_user_lowcmd_never_to_lowcmd(events, clock) -> None:
    rig = Rig(events, clock)
    rig.enter()
    assert rig.relay.submit(*KNEE) is None
    assert rig.frames()[-1][JOINT_INDEX["left_knee_joint"]].kp == 100.0
    assert rig.port.stream("write_lowcmd") == []


def test_the_hand_over_frame_repeats_until_the_first_user_frame(events, clock) -> None:
    rig = Rig(events, clock)
    rig.gate.in_transition = True  # the entry is under way
    rig.link.begin(hold_frame(rig.port.positions, 80.0, 2.0), lambda: False)
    assert rig.relay.busy()
    rig.relay.tick(0.02)
    assert rig.frames()[-1][3].kp == 80.0 and rig.frames()[-1][3].q == rig.port.positions[3]
    rig.gate.in_transition = False
    rig.link.entered()
    rig.gate.mode = Mode.LOW_LEVEL
    rig.relay.tick(0.02)  # entered, no user frame yet, within lowcmd_timeout_s: still the hold
    assert rig.frames()[-1][3].kp == 80.0 and not rig.hand_backs


def _wait_hand_back(rig: Rig) -> None:
    for _ in range(100):
        if rig.hand_backs:
            return
        time.sleep(0.01)


def test_a_first_frame_late_by_a_fresh_publishers_delay_keeps_low_level(events, clock) -> None:
    rig = Rig(events, clock)
    rig.enter()
    for _ in range(20):  # 0.4 s of the hand-over frame, past lowcmd_timeout_s (0.1 s) but within the grace
        clock.advance(0.02)
        rig.relay.tick(0.02)
    _wait_hand_back(rig)
    assert not rig.hand_backs and rig.frames()[-1][3].kp == 80.0
    assert rig.relay.submit(*KNEE) is None  # the user's first frame, 0.4 s after the entry, goes out
    assert rig.frames()[-1][JOINT_INDEX["left_knee_joint"]].kp == 100.0


def test_no_first_frame_within_the_grace_hands_back(events, clock) -> None:
    rig = Rig(events, clock)
    rig.enter()
    clock.advance(FIRST_FRAME_S + 0.05)
    rig.relay.tick(0.02)
    _wait_hand_back(rig)
    assert rig.hand_backs == [1.0]


def test_silence_hands_back_and_holds_meanwhile(events, clock) -> None:
    rig = Rig(events, clock)
    rig.enter()
    assert rig.relay.submit(*KNEE) is None
    clock.advance(0.2)
    rig.relay.tick(0.02)
    for _ in range(100):
        if rig.hand_backs:
            break
        time.sleep(0.01)
    assert rig.hand_backs == [1.0]
    assert rig.frames()[-1][0].kp == 80.0  # a hold, not damping, while the robot is handed back


def test_silence_damps_when_configured(events, clock) -> None:
    rig = Rig(events, clock, SilenceReaction.DAMP)
    rig.enter()
    assert rig.relay.submit(*KNEE) is None
    clock.advance(0.2)
    rig.relay.tick(0.02)
    assert rig.frames()[-1] == tuple(DAMPING) and not rig.hand_backs


def test_leaving_for_a_stop_damps_until_the_robot_is_out_of_user_control(events, clock) -> None:
    rig = Rig(events, clock)
    rig.enter()
    rig.gate.mode = Mode.EMERGENCY
    rig.relay.on_leave(Mode.LOW_LEVEL, Mode.EMERGENCY)
    assert rig.frames()[-3:] == [tuple(DAMPING)] * 3
    rig.relay.tick(0.02)
    assert rig.frames()[-1] == tuple(DAMPING) and rig.relay.busy()
    rig.link.left()
    n = len(rig.frames())
    rig.relay.tick(0.02)
    assert len(rig.frames()) == n and not rig.relay.busy()


def test_leaving_for_high_level_holds_where_the_robot_is(events, clock) -> None:
    rig = Rig(events, clock)
    rig.enter()
    rig.port.positions = [0.3] * 29
    rig.gate.mode, rig.gate.in_transition = Mode.LOW_LEVEL, True
    rig.relay.on_leave(Mode.LOW_LEVEL, Mode.HIGH_LEVEL)
    assert all(f[5].q == 0.3 and f[5].kp == 80.0 for f in rig.frames()[-3:])
    rig.relay.tick(0.02)
    assert rig.frames()[-1][5].q == 0.3


def test_a_hold_during_the_entry_repeats_damping_not_the_hand_over_frame(events, clock) -> None:
    rig = Rig(events, clock)
    rig.gate.in_transition = True  # the entry is under way, SwitchToUserCtrl in flight
    rig.link.begin(hold_frame(rig.port.positions, 80.0, 2.0), lambda: False)
    rig.relay.tick(0.02)
    assert rig.frames()[-1][3].kp == 80.0
    rig.gate.holds = True  # a body check holds motion: a stiff hold is motion
    rig.relay.tick(0.02)
    assert rig.frames()[-1] == tuple(DAMPING)


def test_leaving_under_a_hold_damps_instead_of_holding(events, clock) -> None:
    rig = Rig(events, clock)
    rig.enter()
    rig.gate.holds = True
    rig.gate.in_transition = True
    rig.relay.on_leave(Mode.LOW_LEVEL, Mode.HIGH_LEVEL)
    assert rig.frames()[-3:] == [tuple(DAMPING)] * 3
    rig.gate.mode = Mode.HIGH_LEVEL
    rig.relay.tick(0.02)
    assert rig.frames()[-1] == tuple(DAMPING) and rig.relay.busy()
