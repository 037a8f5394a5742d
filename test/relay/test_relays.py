"""The command relays against the fake robot port: gates, watchdog, ramps, bad input."""

from __future__ import annotations

import itertools
import math

import pytest

from fakes.fake_robot_port import FakeRobotPort
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import SportState
from g1_mode_manager.core.velocity import VelocityLimits
from g1_mode_manager.node.link import LinkHealth
from g1_mode_manager.protocol import api_ids
from g1_mode_manager.protocol.motors import DAMPING_KD, JOINT_INDEX
from g1_mode_manager.relay.arm import ArmRelay
from g1_mode_manager.relay.cmd_vel import CmdVelRelay
from g1_mode_manager.relay.events import RelayEvents
from g1_mode_manager.relay.lowcmd import LowCmdRelay


class Gate:
    """Stands in for the mode machine's predicates."""

    def __init__(self, mode: Mode) -> None:
        self.mode = mode
        self.in_transition = False

    def _is(self, mode: Mode) -> bool:
        return self.mode is mode and not self.in_transition

    def allows_cmd_vel(self) -> bool:
        return self._is(Mode.HIGH_LEVEL)

    def allows_arm_commands(self) -> bool:
        return self._is(Mode.HIGH_LEVEL)

    def allows_low_level_commands(self) -> bool:
        return self._is(Mode.LOW_LEVEL)


@pytest.fixture
def logs() -> list[tuple[str, str]]:
    return []


@pytest.fixture
def events(logs) -> RelayEvents:
    return RelayEvents(lambda level, text: logs.append((level, text)), throttle_s=1000.0)


LIMITS = VelocityLimits(max_vx=0.8, max_vy=0.4, max_wz=1.0, max_ax=1.0, max_ay=1.0, max_aw=2.0)


def _cmd_vel(port, gate, events, timeout_s=0.3) -> CmdVelRelay:
    return CmdVelRelay(port, gate, LinkHealth(port, gate, 0.5), events, limits=LIMITS, timeout_s=timeout_s,
                       move_duration_s=1.0)


def test_cmd_vel_dropped_outside_high_level_with_warning_naming_the_mode(events, logs) -> None:
    port = FakeRobotPort()
    for mode in (Mode.UNINITIALIZED, Mode.IDLE, Mode.LOW_LEVEL, Mode.EMERGENCY):
        relay = _cmd_vel(port, Gate(mode), events)
        assert relay.submit(0.5, 0.0, 0.0) is None
        relay.tick(0.05)
    assert port.stream("set_velocity") == []
    assert events.counts()["cmd_vel_dropped"] == 4
    assert [t for _, t in logs if "dropped" in t] == [  # throttled: one warning per key and period
        "cmd_vel dropped: mode is UNINITIALIZED, velocity commands pass only in HIGH_LEVEL"
    ]


def test_cmd_vel_rate_limited_latest_wins_and_one_stop_move_on_silence(events) -> None:
    port = FakeRobotPort()
    gate = Gate(Mode.HIGH_LEVEL)
    relay = _cmd_vel(port, gate, events, timeout_s=0.3)
    relay.submit(0.2, 0.0, 0.0)
    relay.submit(0.8, 0.0, 0.0)  # latest wins: the 0.2 is never sent
    relay.tick(0.1)
    relay.tick(0.1)
    sent = [s.args for s in port.stream("set_velocity")]
    assert sent[0][0] == pytest.approx(0.1) and sent[1][0] == pytest.approx(0.2)  # 1 m/s^2 * 0.1 s per tick
    assert all(args[3] == 1.0 for args in sent)
    relay._watchdog._last -= 1.0
    for _ in range(5):
        relay.tick(0.1)
    stops = [s.args for s in port.stream("set_velocity")][2:]
    assert stops == [(0.0, 0.0, 0.0, 1.0)]  # exactly one StopMove
    assert events.counts()["stop_moves_sent"] == 1


def test_cmd_vel_nan_sends_zero_and_huge_is_clamped(events, logs) -> None:
    port = FakeRobotPort()
    relay = _cmd_vel(port, Gate(Mode.HIGH_LEVEL), events)
    assert relay.submit(math.nan, 0.0, 0.0).rejected
    relay.tick(0.1)
    assert port.stream("set_velocity")[-1].args[:3] == (0.0, 0.0, 0.0)
    assert relay.submit(1e9, -1e9, math.inf).rejected
    assert relay.submit(1e9, -1e9, 5.0).clamped
    for _ in range(30):
        relay.tick(0.1)
    assert port.stream("set_velocity")[-1].args[:3] == pytest.approx((0.8, -0.4, 1.0))
    counts = events.counts()
    assert counts["cmd_vel_rejected"] == 2 and counts["cmd_vel_clamped"] == 1
    assert any("non-finite" in text for _, text in logs)


def test_cmd_vel_stops_when_mode_leaves_high_level_or_link_is_lost(events) -> None:
    port = FakeRobotPort()
    gate = Gate(Mode.HIGH_LEVEL)
    relay = _cmd_vel(port, gate, events)
    relay.submit(0.5, 0.0, 0.0)
    relay.tick(0.1)
    gate.in_transition = True  # a transition away has started
    relay.tick(0.1)
    relay.tick(0.1)
    assert [s.args for s in port.stream("set_velocity")][-1] == (0.0, 0.0, 0.0, 1.0)
    assert len(port.stream("set_velocity")) == 2
    gate.in_transition = False
    relay.submit(0.5, 0.0, 0.0)
    relay.tick(0.1)
    port.lowstate_age = 5.0  # link lost
    relay.tick(0.1)
    assert [s.args for s in port.stream("set_velocity")][-1] == (0.0, 0.0, 0.0, 1.0)


def test_cmd_vel_rpc_failure_is_counted_and_relay_keeps_going(events) -> None:
    port = FakeRobotPort()
    port.fail_stream["set_velocity"] = api_ids.ERR_CLIENT_API_TIMEOUT
    relay = _cmd_vel(port, Gate(Mode.HIGH_LEVEL), events)
    relay.submit(0.5, 0.0, 0.0)
    relay.tick(0.1)
    relay.tick(0.1)
    assert events.counts()["rpc_failures"] == 2


def _arm(port, gate, events) -> ArmRelay:
    return ArmRelay(port, gate, LinkHealth(port, gate, 0.5), events, ramp_time_s=1.0, silence_timeout_s=0.5,
                    kp=60.0, kd=1.5)


def test_arm_weight_ramps_in_holds_unnamed_joints_and_ramps_out_on_leaving(events) -> None:
    port = FakeRobotPort()
    gate = Gate(Mode.HIGH_LEVEL)
    relay = _arm(port, gate, events)
    assert relay.submit(["left_elbow_joint"], [1.0]) is None
    for _ in range(60):
        relay.submit(["left_elbow_joint"], [1.0])
        relay.tick(0.02)
    frames = port.stream("write_arm_sdk")
    weights = [f.args[1] for f in frames]
    assert weights[0] == pytest.approx(0.02) and weights[-1] == 1.0
    assert max(b - a for a, b in itertools.pairwise(weights)) <= 0.02 + 1e-9
    targets = frames[-1].args[0]
    elbow = JOINT_INDEX["left_elbow_joint"] - 12
    shoulder = JOINT_INDEX["right_shoulder_pitch_joint"] - 12
    assert targets[elbow].q == 1.0
    assert targets[shoulder].q == pytest.approx(port.positions[JOINT_INDEX["right_shoulder_pitch_joint"]])
    gate.mode = Mode.IDLE
    for _ in range(60):
        relay.tick(0.02)
    out = [f.args[1] for f in port.stream("write_arm_sdk")][len(weights):]
    assert out[-1] == 0.0 and max(a - b for a, b in itertools.pairwise(out)) <= 0.02 + 1e-9
    n = len(port.stream("write_arm_sdk"))
    relay.tick(0.02)
    assert len(port.stream("write_arm_sdk")) == n  # nothing more once back at zero


def test_arm_bad_input_refused_and_nothing_sent(events) -> None:
    port = FakeRobotPort()
    relay = _arm(port, Gate(Mode.HIGH_LEVEL), events)
    assert "not allowed" in relay.submit(["left_knee_joint"], [0.1])
    assert "entries" in relay.submit(["left_elbow_joint"], [0.1, 0.2])
    assert "non-finite" in relay.submit(["left_elbow_joint"], [math.nan])
    relay.tick(0.02)
    assert port.stream("write_arm_sdk") == []
    assert events.counts()["arm_cmd_rejected"] == 3
    assert _arm(port, Gate(Mode.LOW_LEVEL), events).submit(["left_elbow_joint"], [0.1]) == "mode is LOW_LEVEL"


def _low(port, gate, events) -> LowCmdRelay:
    return LowCmdRelay(port, gate, LinkHealth(port, gate, 0.5), events, silence_timeout_s=0.1)


def test_lowcmd_only_in_low_level_and_damps_on_silence(events) -> None:
    port = FakeRobotPort()
    gate = Gate(Mode.HIGH_LEVEL)
    relay = _low(port, gate, events)
    assert relay.submit(["left_knee_joint"], [0.5], [], [], [40.0], [1.0]) == "mode is HIGH_LEVEL"
    relay.tick(0.02)
    assert port.stream("write_lowcmd") == []
    gate.mode = Mode.LOW_LEVEL
    assert relay.submit(["left_knee_joint"], [0.5], [], [], [40.0], [1.0]) is None
    frame = port.stream("write_lowcmd")[-1].args[0]
    assert frame[JOINT_INDEX["left_knee_joint"]].kp == 40.0
    relay.tick(0.02)  # fresh: no damping frame
    assert len(port.stream("write_lowcmd")) == 1
    relay._watchdog._last -= 1.0
    relay.tick(0.02)
    damp = port.stream("write_lowcmd")[-1].args[0]
    assert all(c.kp == 0.0 and c.kd == DAMPING_KD for c in damp)
    assert "gains" in relay.submit(["left_knee_joint"], [0.5], [], [], [-1.0], [1.0])


def test_lowcmd_before_lowstate_is_refused_not_crashing(events) -> None:
    port = FakeRobotPort()
    port.lowstate_age = None
    relay = _low(port, Gate(Mode.LOW_LEVEL), events)
    assert relay.submit(["left_knee_joint"], [0.5], [], [], [40.0], [1.0]) == "robot link lost"
    assert port.stream("write_lowcmd") == []


def test_link_health_needs_sportmodestate_in_high_level() -> None:
    port = FakeRobotPort()
    gate = Gate(Mode.HIGH_LEVEL)
    link = LinkHealth(port, gate, 0.5)
    assert link.link_ok()
    port.sport = SportState(4, 0, 0, 0.0, age_s=2.0)
    assert not link.link_ok() and "sportmodestate" in link.report().reason
    gate.mode = Mode.LOW_LEVEL
    assert link.link_ok()
    gate.mode = Mode.UNINITIALIZED
    assert not link.report().connected
