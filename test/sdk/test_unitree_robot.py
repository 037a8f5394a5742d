"""UnitreeRobot against the SDK's real Server classes (a scripted robot in a subprocess): what arrives, how
failures surface, concurrency of the e-stop's damp, and the arm_sdk/lowcmd frames on the wire."""

from __future__ import annotations

import json
import math
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from g1_mode_manager.core.port import MotorCommand, RobotError, RobotPort, SportState
from g1_mode_manager.sdk import UnitreeRobot
from g1_mode_manager.sdk.lowcmd import LowCmdWriter
from g1_mode_manager.sdk.state_readers import LowStateReader
from support.mode_manager import wait_until
from support.processes import ManagedProcess
from support.scripted_robot import events, lowstate_q, start_scripted_robot, wait_event

Peer = Callable[..., ManagedProcess]
#: How long the scripted robot holds a SelectMode's answer while the test's damp must get through.
SELECT_HELD_S = 2.0


def show(config: pytest.Config, text: str) -> None:
    """Print a figure even when pytest captures output (no timing assertions: the machine is shared)."""
    capture = config.pluginmanager.get_plugin("capturemanager")
    with capture.global_and_fixture_disabled():
        print(f"\n{text}")


@pytest.fixture(scope="module")
def robot(sdk_channels: int, pytestconfig: pytest.Config) -> Iterator[UnitreeRobot]:
    """One connected UnitreeRobot for the module (connect creates DDS entities once, with the SDK's sleeps)."""
    peer = start_scripted_robot({"domain": sdk_channels})
    port = UnitreeRobot(sdk_channels, "lo", rpc_timeout_s=1.0, mode_timeout_s=5.0)
    try:
        port.connect()
        show(pytestconfig, f"connect: {port.connect_time_s:.2f} s (creating entities {port.create_time_s:.2f} s)")
    finally:
        peer.stop()
    yield port
    port.close()


@pytest.fixture
def peer(sdk_channels: int, robot: UnitreeRobot) -> Iterator[Peer]:
    """Start a scripted robot with a script; the robot port waits until both services answer."""
    started: list[ManagedProcess] = []

    def start(**script: Any) -> ManagedProcess:
        proc = start_scripted_robot({"domain": sdk_channels, **script})
        started.append(proc)
        robot.probe(5.0)
        return proc

    yield start
    for proc in started:
        proc.stop()


def requests(proc: ManagedProcess, **match: Any) -> list[tuple[int, Any]]:
    """(api id, decoded parameter) of each logged request but the readiness probes (api 1)."""
    return [(e["api_id"], json.loads(e["parameter"])) for e in events(proc, "request", **match) if e["api_id"] != 1]


def test_robot_implements_the_port_and_writes_frames_fast(robot: UnitreeRobot) -> None:
    assert isinstance(robot, RobotPort)
    assert robot._arm is not None and robot._arm._writer.fast
    assert robot._lowcmd is not None and robot._lowcmd._writer.fast
    assert robot._loco is not None and robot._loco._writer.fast  # requests as ready-made bytes (request_writer.py)
    assert robot._switcher is not None and robot._switcher._writer.fast
    assert robot._loco._replies.fast and robot._switcher._replies.fast  # replies decoded with struct


def test_every_loco_call_arrives_with_its_api_id_and_json(robot: UnitreeRobot, peer: Peer) -> None:
    proc = peer(fsm_id=500, fsm_mode=0)
    loco = robot.loco
    assert robot.get_fsm_id() == 500
    assert robot.get_fsm_mode() == 0
    assert loco.get_balance_mode() == 0
    assert loco.get_stand_height() == pytest.approx(0.75)
    assert loco.get_swing_height() == pytest.approx(0.09)
    robot.set_fsm_id(4)
    assert robot.get_fsm_id() == 4
    robot.set_balance_mode(1)
    loco.set_stand_height(0.7)
    loco.set_swing_height(0.1)
    robot.set_velocity(0.3, -0.1, 0.2, 2.0)
    robot.set_speed_mode(2)
    robot.damp()
    loco.zero_torque()
    loco.squat()
    loco.sit()
    loco.stand_up()
    loco.start()
    loco.balance_stand()
    loco.continuous_gait(True)
    loco.continuous_gait(False)
    loco.move(0.5, 0.0, 0.0)
    loco.move(0.5, 0.1, -0.2, continuous=True)
    loco.stop_move()
    expected = [
        (7001, {}), (7002, {}), (7003, {}), (7005, {}), (7004, {}),
        (7101, {"data": 4}), (7001, {}), (7102, {"data": 1}), (7104, {"data": 0.7}), (7103, {"data": 0.1}),
        (7105, {"velocity": [0.3, -0.1, 0.2], "duration": 2.0}), (7107, {"data": 2}),
        (7101, {"data": 1}), (7101, {"data": 0}), (7101, {"data": 2}), (7101, {"data": 3}), (7101, {"data": 4}),
        (7101, {"data": 500}), (7102, {"data": 0}), (7102, {"data": 1}), (7102, {"data": 0}),
        (7105, {"velocity": [0.5, 0.0, 0.0], "duration": 1.0}),
        (7105, {"velocity": [0.5, 0.1, -0.2], "duration": 864000.0}),
        (7105, {"velocity": [0.0, 0.0, 0.0], "duration": 1.0}),
    ]
    assert requests(proc, service="sport") == expected
    assert all(not e["noreply"] for e in events(proc, "request"))


def test_getters_accept_object_and_bare_replies_and_reject_garbage(robot: UnitreeRobot, peer: Peer) -> None:
    peer(replies={"7001": "500", "7002": '{"data": 1}', "7005": "0.8", "7003": "not json", "7004": '{"x": 1}'})
    assert robot.get_fsm_id() == 500
    assert robot.get_fsm_mode() == 1
    assert robot.loco.get_stand_height() == pytest.approx(0.8)
    for call in (robot.loco.get_balance_mode, robot.loco.get_swing_height):
        with pytest.raises(RobotError) as info:
            call()
        assert info.value.code == 3106


def test_error_codes_raise_robot_error_with_the_code(robot: UnitreeRobot, peer: Peer) -> None:
    peer(codes={"7101": 7302, "7105": 7301, "1002": 3204})
    with pytest.raises(RobotError) as info:
        robot.set_fsm_id(999)
    assert (info.value.call, info.value.code) == ("SetFsmId", 7302)
    with pytest.raises(RobotError) as info:
        robot.set_velocity(0.2, 0.0, 0.0, 1.0)
    assert info.value.code == 7301
    with pytest.raises(RobotError) as info:
        robot.select_mode("bogus")
    assert (info.value.call, info.value.code) == ("SelectMode", 3204)


def test_released_sport_service_and_mode_switching(robot: UnitreeRobot, peer: Peer) -> None:
    proc = peer(mode="ai", form="0")
    assert robot.check_mode() == "ai"
    assert robot.motion_switcher.check_mode_info().form == "0"
    robot.release_mode()
    assert robot.check_mode() == ""
    with pytest.raises(RobotError) as info:
        robot.damp()
    assert info.value.code == 3203
    robot.select_mode("ai")
    assert robot.check_mode() == "ai"
    robot.damp()
    robot.motion_switcher.set_silent(True)
    assert robot.motion_switcher.get_silent() is True
    assert requests(proc, service="motion_switcher") == [
        (1001, {}), (1001, {}), (1003, {}), (1001, {}), (1002, {"name": "ai"}), (1001, {}),
        (1004, {"silent": True}), (1005, {}),
    ]


def test_timeout_raises_3104_within_the_per_call_timeout(robot: UnitreeRobot, peer: Peer,
                                                          pytestconfig: pytest.Config) -> None:
    peer(delays={"7002": 1.5})
    start = time.monotonic()
    with pytest.raises(RobotError) as info:
        robot.loco.get_fsm_mode(timeout_s=0.3)
    elapsed = time.monotonic() - start
    show(pytestconfig, f"timeout of 0.3 s raised after {elapsed:.2f} s")
    assert (info.value.call, info.value.code) == ("GetFsmMode", 3104)


def test_damp_no_reply_arrives_flagged_no_reply(robot: UnitreeRobot, peer: Peer) -> None:
    proc = peer()
    robot.damp_no_reply()
    (event,) = wait_event(proc, "request", api_id=7101)
    assert event["noreply"] is True
    assert json.loads(event["parameter"]) == {"data": 1}


def test_damp_returns_while_select_mode_is_held_by_the_server(robot: UnitreeRobot, peer: Peer,
                                                              pytestconfig: pytest.Config) -> None:
    """The e-stop thread's damp must not wait behind a slow SelectMode in another thread."""
    # The damp answers within the port's 1 s rpc timeout or raises (failing the test), so a hold of 2 s leaves a
    # second beyond it; a damp queued behind the SelectMode would return only after its answer, the thread done.
    proc = peer(delays={"1002": SELECT_HELD_S})
    outcome: dict[str, Any] = {}

    def select() -> None:
        try:
            robot.select_mode("ai", timeout_s=6.0)
            outcome["select"] = "ok"
        except Exception as error:
            outcome["select"] = error

    thread = threading.Thread(target=select)
    thread.start()
    wait_event(proc, "request", api_id=1002)
    start = time.monotonic()
    robot.damp()
    damp_s = time.monotonic() - start
    select_still_waiting = thread.is_alive()
    thread.join(8.0)
    show(pytestconfig, f"damp during a SelectMode held {SELECT_HELD_S} s by the server returned in {damp_s * 1e3:.1f} ms")
    assert select_still_waiting
    assert outcome["select"] == "ok"
    order = [e["api_id"] for e in events(proc, "request") if e["api_id"] != 1]
    assert order == [1002, 7101]


def test_closing_the_port_ends_a_call_still_waiting_for_its_reply(sdk_channels: int) -> None:
    """At shutdown a transition's SelectMode may still wait for a robot that answers in seconds: close() ends
    it at once (and every later call), so nothing holds the process's exit up for the call's timeout."""
    proc = start_scripted_robot({"domain": sdk_channels, "delays": {"1002": 30.0}})
    port = UnitreeRobot(sdk_channels, "lo", rpc_timeout_s=1.0, mode_timeout_s=20.0)
    outcome: dict[str, Any] = {}

    def select() -> None:
        try:
            port.select_mode("ai", timeout_s=20.0)
            outcome["select"] = "answered"
        except RobotError as error:
            outcome["select"] = error

    try:
        port.connect()
        thread = threading.Thread(target=select)
        thread.start()
        wait_event(proc, "request", api_id=1002)
        start = time.monotonic()
        port.close()
        thread.join(20.0)
        ended_s = time.monotonic() - start
        assert isinstance(outcome["select"], RobotError) and outcome["select"].code == 3102, outcome
        assert "closed" in str(outcome["select"])
        assert ended_s < 5.0, f"the call ended {ended_s:.1f} s after close(), at its timeout"
        with pytest.raises(RobotError):
            port.get_fsm_id(timeout_s=5.0)
    finally:
        port.close()
        proc.stop()


def test_lowstate_can_be_unsubscribed_and_resubscribed(robot: UnitreeRobot, peer: Peer) -> None:
    """Off: no sample reaches the port and no pose is handed out (it would be stale); mode_machine stays
    known. Back on: samples flow again within moments."""
    peer(lowstate_hz=200, mode_machine=5)
    assert wait_until(lambda: robot.joint_positions() is not None, 5.0)
    try:
        robot.set_lowstate_wanted(False)
        assert not robot.lowstate_receiving()
        time.sleep(0.05)  # a sample already in flight may still land
        _data, count = robot.lowstate_data()
        time.sleep(0.3)
        assert robot.lowstate_data()[1] == count, "rt/lowstate still received while unsubscribed"
        assert robot.joint_positions() is None and robot.mode_machine() == 5
        assert robot.lowstate_age_s() > 0.25
        robot.set_lowstate_wanted(True)
        assert robot.lowstate_receiving()
        assert wait_until(lambda: robot.lowstate_data()[1] > count + 10, 5.0), "rt/lowstate did not come back"
        assert robot.joint_positions() == pytest.approx([lowstate_q(i) for i in range(29)], abs=1e-6)
    finally:
        robot.set_lowstate_wanted(True)


def test_streams_frames_and_state(robot: UnitreeRobot, peer: Peer) -> None:
    received: list[SportState] = []
    robot.set_sport_state_listener(received.append)
    proc = peer(record_frames=True, lowstate_hz=50, mode_machine=7, sportmodestate_hz=20, fsm_id=500, fsm_mode=1)
    deadline = time.monotonic() + 5.0
    while (robot.lowstate_age_s() is None or not received) and time.monotonic() < deadline:
        time.sleep(0.02)
    robot.set_sport_state_listener(None)
    assert robot.mode_machine() == 7
    assert robot.joint_positions() == pytest.approx([lowstate_q(i) for i in range(29)], abs=1e-6)
    state = robot.sport_state()
    assert state is not None and (state.fsm_id, state.fsm_mode) == (500, 1)
    assert received and (received[0].fsm_id, received[0].fsm_mode) == (500, 1)

    commands = [MotorCommand(q=0.01 * i, dq=0.1, tau=0.5, kp=40.0 + i, kd=1.0) for i in range(29)]
    robot.write_lowcmd(commands)
    (frame,) = wait_event(proc, "frame", topic="rt/lowcmd")
    assert frame["crc_ok"] and frame["mode_pr"] == 0 and frame["mode_machine"] == 7
    assert frame["mode"] == [1] * 29 + [0] * 6
    assert frame["q"][:29] == pytest.approx([0.01 * i for i in range(29)], abs=1e-6)
    assert frame["kp"][:29] == pytest.approx([40.0 + i for i in range(29)])
    assert frame["tau"][:29] == pytest.approx([0.5] * 29)

    targets = [MotorCommand(q=-0.02 * k, kp=60.0, kd=1.5) for k in range(17)]
    for n, weight in enumerate((1.7, -0.5, 0.25), start=1):
        robot.write_arm_sdk(targets, weight)
        wait_event(proc, "frame", topic="rt/arm_sdk", count=n)
    arm = events(proc, "frame", topic="rt/arm_sdk")
    assert [f["q"][29] for f in arm] == pytest.approx([1.0, 0.0, 0.25])
    for f in arm:
        assert f["crc_ok"]
        assert f["mode"] == [0] * 12 + [1] * 17 + [0] * 6
        assert f["q"][12:29] == pytest.approx([-0.02 * k for k in range(17)], abs=1e-6)
        assert f["kp"][12:29] == pytest.approx([60.0] * 17)


def test_concurrent_calls_from_many_threads_all_get_their_own_reply(robot: UnitreeRobot, peer: Peer) -> None:
    proc = peer()
    errors: list[BaseException] = []

    def worker(k: int) -> None:
        try:
            for j in range(5):
                robot.set_fsm_id(100 * k + j)
        except BaseException as error:
            errors.append(error)

    threads = [threading.Thread(target=worker, args=(k,)) for k in range(8)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(10.0)
    assert not errors
    got = sorted(p["data"] for api_id, p in requests(proc, service="sport") if api_id == 7101)
    assert got == sorted(100 * k + j for k in range(8) for j in range(5))
    ids = [e["id"] for e in events(proc, "request", api_id=7101)]
    assert len(set(ids)) == len(ids)


def test_lowcmd_before_any_lowstate_raises() -> None:
    reader = LowStateReader()  # no lowstate publisher is running
    writer = LowCmdWriter(lambda: reader.mode_machine)
    try:
        with pytest.raises(RobotError, match="lowstate"):
            writer.write([MotorCommand()] * 29)
    finally:
        writer.close()
        reader.close()


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda r: r.write_lowcmd([MotorCommand()] * 28), "expected 29"),
        (lambda r: r.write_lowcmd([MotorCommand(q=math.nan)] * 29), "non-finite"),
        (lambda r: r.write_lowcmd([MotorCommand(kp=-1.0)] * 29), "negative gain"),
        (lambda r: r.write_arm_sdk([MotorCommand()] * 29, 0.5), "expected 17"),
        (lambda r: r.write_arm_sdk([MotorCommand(tau=math.inf)] * 17, 0.5), "non-finite"),
        (lambda r: r.write_arm_sdk([MotorCommand()] * 17, math.nan), "weight"),
        (lambda r: r.set_velocity(math.nan, 0.0, 0.0, 1.0), "finite"),
        (lambda r: r.set_speed_mode(7), "SetSpeedMode"),
    ],
)
def test_bad_frames_and_values_raise_value_error(robot: UnitreeRobot, call: Callable, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        call(robot)
