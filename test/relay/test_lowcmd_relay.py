"""The lowcmd relay against the fake robot port: LOW_LEVEL only, damping on silence, link loss and exit."""

from __future__ import annotations

import pytest
from relay_fakes import Gate

from fakes.fake_robot_port import FakeRobotPort
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import SportState
from g1_mode_manager.protocol.motors import DAMPING_KD, JOINT_INDEX
from g1_mode_manager.relay.link_health import LinkHealth
from g1_mode_manager.relay.lowcmd import EXIT_BURST, LowCmdRelay

KNEE = ["left_knee_joint"], [0.5], [], [], [100.0], [1.0]


def _relay(port, gate, events, clock, service: list[bool] | None = None, deadman: list[bool] | None = None) -> LowCmdRelay:
    """``service[0]``: the high-level service is known active; ``deadman[0]``: the dead-man key is held."""
    service = [False] if service is None else service
    return LowCmdRelay(port, gate, LinkHealth(port, gate, 0.5), events, silence_timeout_s=0.1,
                       exit_damping_s=0.2, service_active=lambda: service[0], clock=clock,
                       **({} if deadman is None else {"deadman": lambda: deadman[0]}))


def _is_damping(frame) -> bool:
    return all(c.kp == 0.0 and c.kd == DAMPING_KD and c.tau == 0.0 for c in frame)


def _frames(port) -> list:
    return [s.args[0] for s in port.stream("write_lowcmd")]


def test_only_in_low_level_and_damps_on_silence(events, clock) -> None:
    port = FakeRobotPort()
    gate = Gate(Mode.HIGH_LEVEL)
    relay = _relay(port, gate, events, clock)
    assert relay.submit(*KNEE) == "mode is HIGH_LEVEL"
    relay.tick(0.02)
    assert _frames(port) == []
    gate.mode = Mode.LOW_LEVEL
    assert relay.submit(*KNEE) is None
    assert _frames(port)[-1][JOINT_INDEX["left_knee_joint"]].kp == 100.0
    relay.tick(0.02)  # fresh: no damping frame
    assert len(_frames(port)) == 1
    clock.advance(1.0)
    relay.tick(0.02)
    assert _is_damping(_frames(port)[-1])
    assert "gains" in relay.submit(["left_knee_joint"], [0.5], [], [], [-1.0], [1.0])


def test_a_block_is_checked_and_forwarded_as_its_columns_are(events, clock) -> None:
    """The 500 Hz path hands the five columns as one array: the same gate, checks, refusal and frame."""
    import numpy as np

    port = FakeRobotPort()
    gate = Gate(Mode.HIGH_LEVEL)
    relay = _relay(port, gate, events, clock)
    knee = np.array([[0.5], [0.0], [0.0], [100.0], [1.0]])
    assert relay.submit_block(["left_knee_joint"], knee) == "mode is HIGH_LEVEL"
    gate.mode = Mode.LOW_LEVEL
    assert relay.submit_block(["left_knee_joint"], knee) is None
    sent = _frames(port)[-1][JOINT_INDEX["left_knee_joint"]]
    assert (sent.q, sent.kp, sent.kd) == (0.5, 100.0, 1.0)
    bad = knee.copy()
    bad[3, 0] = -1.0
    assert "gains" in relay.submit_block(["left_knee_joint"], bad)
    assert len(_frames(port)) == 1 and events.counts()["lowcmd_rejected"] == 1
    assert events.counts()["lowcmd_received"] == 3


def test_link_loss_in_low_level_sends_damping_frames(events, clock) -> None:
    port = FakeRobotPort()
    relay = _relay(port, Gate(Mode.LOW_LEVEL), events, clock)
    assert relay.submit(*KNEE) is None
    port.lowstate_age = 5.0
    port.sport = SportState(0, 0, 0, 0.0, age_s=5.0)
    relay.tick(0.02)  # the stream is fresh, but the robot cannot be watched: damp
    assert _is_damping(_frames(port)[-1])
    assert relay.submit(*KNEE) == "robot link lost"


def test_leaving_low_level_damps_before_the_next_mode_and_idle_keeps_damping_a_while(events, clock) -> None:
    port = FakeRobotPort()
    gate = Gate(Mode.LOW_LEVEL)
    relay = _relay(port, gate, events, clock)
    gate.add_leave_listener(relay.on_leave)
    relay.submit(*KNEE)
    gate.leave(Mode.IDLE)
    frames = _frames(port)
    assert len(frames) == 1 + EXIT_BURST and all(_is_damping(f) for f in frames[1:])
    relay.tick(0.02)
    assert len(_frames(port)) == 2 + EXIT_BURST and _is_damping(_frames(port)[-1])
    clock.advance(0.3)
    relay.tick(0.02)
    assert len(_frames(port)) == 2 + EXIT_BURST  # then the robot holds the damping frame
    assert relay.submit(*KNEE) == "mode is IDLE"


@pytest.mark.parametrize("stop", [Mode.EMERGENCY, Mode.FAULT], ids=lambda m: m.name)
def test_a_stop_from_low_level_damps_at_once_and_until_the_service_is_active(events, clock, stop: Mode) -> None:
    port = FakeRobotPort()
    gate = Gate(Mode.LOW_LEVEL)
    service = [False]
    relay = _relay(port, gate, events, clock, service)
    gate.add_leave_listener(relay.on_leave)
    relay.submit(*KNEE)
    gate.leave(stop)
    assert len(_frames(port)) == 1 + EXIT_BURST
    clock.advance(1.0)  # SelectMode takes seconds on a robot: nothing else holds it meanwhile
    assert relay.busy()
    relay.tick(0.02)
    frames = _frames(port)
    assert len(frames) == 2 + EXIT_BURST and _is_damping(frames[-1])
    service[0] = True  # the service answers: its Damp holds the robot now
    assert not relay.busy()
    relay.tick(0.02)
    assert len(_frames(port)) == 2 + EXIT_BURST


@pytest.mark.parametrize("source", [Mode.UNINITIALIZED, Mode.IDLE, Mode.HIGH_LEVEL], ids=lambda m: m.name)
def test_a_stop_from_any_other_mode_writes_no_lowcmd(events, clock, source: Mode) -> None:
    """The high-level service holds the robot there (or will): a lowcmd frame would compete with it."""
    port = FakeRobotPort()
    gate = Gate(source)
    relay = _relay(port, gate, events, clock)  # the service is not (yet) known active
    gate.add_leave_listener(relay.on_leave)
    gate.leave(Mode.EMERGENCY)
    assert not relay.busy()
    relay.tick(0.02)
    assert _frames(port) == []


def test_a_hold_in_low_level_replaces_the_user_stream_with_damping(events, clock) -> None:
    port = FakeRobotPort()
    gate = Gate(Mode.LOW_LEVEL)
    relay = _relay(port, gate, events, clock)
    assert relay.submit(*KNEE) is None
    gate.holds = True
    assert relay.submit(*KNEE) == "mode is LOW_LEVEL"
    assert relay.busy()
    relay.tick(0.02)
    frames = _frames(port)
    assert len(frames) == 2 and _is_damping(frames[-1])


def test_the_deadman_passes_user_frames_only_while_its_key_is_held(events, clock) -> None:
    port = FakeRobotPort()
    held = [True]
    relay = _relay(port, Gate(Mode.LOW_LEVEL), events, clock, deadman=held)
    assert relay.submit(*KNEE) is None
    assert not _is_damping(_frames(port)[-1])
    held[0] = False
    assert "dead-man" in relay.submit(*KNEE)
    assert _is_damping(_frames(port)[-1])
    relay.tick(0.02)
    assert len(_frames(port)) == 3 and _is_damping(_frames(port)[-1])
    held[0] = True
    assert relay.submit(*KNEE) is None and not _is_damping(_frames(port)[-1])


def test_a_closed_forward_gate_writes_no_user_frame(events, clock) -> None:
    port = FakeRobotPort()
    gate = Gate(Mode.LOW_LEVEL)
    relay = _relay(port, gate, events, clock)
    gate.forward_refuses = True  # an e-stop began between the check and the write
    assert relay.submit(*KNEE) == "mode is LOW_LEVEL"
    assert _frames(port) == []


def test_before_lowstate_is_refused_not_crashing(events, clock) -> None:
    port = FakeRobotPort()
    port.lowstate_age = None
    relay = _relay(port, Gate(Mode.LOW_LEVEL), events, clock)
    assert relay.submit(*KNEE) == "robot link lost"
    relay.tick(0.02)  # damping cannot be written without mode_machine: counted, no crash
    assert _frames(port) == [] and events.counts()["lowcmd_write_failures"] == 1


def test_link_health_needs_sportmodestate_in_high_level() -> None:
    port = FakeRobotPort()
    gate = Gate(Mode.HIGH_LEVEL)
    link = LinkHealth(port, gate, 0.5)
    assert link.link_ok(Mode.HIGH_LEVEL)
    port.sport = SportState(4, 0, 0, 0.0, age_s=2.0)
    assert not link.link_ok(Mode.HIGH_LEVEL) and "sportmodestate" in link.report().reason
    gate.mode = Mode.LOW_LEVEL
    assert link.link_ok(Mode.LOW_LEVEL)
    gate.mode = Mode.UNINITIALIZED
    assert not link.report().connected
