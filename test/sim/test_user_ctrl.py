"""User control (sport 7110 / 7111, rt/user_lowcmd; newer firmware): the rules (pure), SimG1's answers and
physics (no DDS), and the bridge seen through the SDK's own clients, judged on the sim's status and record.

Bridge tests run the bridge in a subprocess (run pytest under ``flock /tmp/g1-sim.lock``).
"""

from __future__ import annotations

import functools
import json
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest
from unitree_sdk2py.idl.default import unitree_hg_msg_dds__LowCmd_

from g1_mode_manager.protocol import api_ids as api
from g1_mode_manager.protocol.crc import lowcmd_crc
from g1_mode_manager.protocol.fsm import STANDING_FSM_IDS, USER_CTRL_FSM_ID, VALID_FSM_IDS, FsmId, InternalCtrl
from g1_mode_manager.protocol.idl import LowCmd_
from g1_mode_manager.protocol.motors import NUM_JOINTS
from g1_sim.bridge import commands
from g1_sim.bridge.faults import FaultConfigError, parse_faults
from g1_sim.firmware.user_ctrl import (
    DEFAULT_DELAY_S,
    REFUSAL_CODE,
    WALKRUN_FSM,
    Phase,
    UserCtrlOption,
    internal_target,
    switch_in_verdict,
)
from harness.rate import run_at_rate
from support.mode_manager import wait_until
from support.sdk_calls import call, initialised
from support.sim_bridge import SimStatus, shared_sim_status, sim_bridge_factory  # noqa: F401  (fixture)
from support.sim_record import SimRecord, of_kind, requests, states
from support.timing import RECORD_WAIT_S

#: Gains of a user's stiff hold of the standing pose (N m/rad, N m s/rad): enough for the G1's legs.
HOLD_KP, HOLD_KD = 300.0, 8.0
#: A standing pelvis is ~0.75 m high; below this it is falling.
STANDING_Z_M = 0.6
#: Physics steps in a second of sim time (2 ms steps) and between two frames at 500 Hz.
STEPS_PER_S = 500
#: Sim seconds the bridge test watches the robot held by user frames, and then by the built-in controller. A
#: robot nobody holds is below STANDING_Z_M ~0.5 s after it is let go (SimG1: 0.23 s under user control with
#: no frames, 0.53 s damped): 2 s is four times that, and leaves ~1000 frames at 500 Hz for the >= 300 judged.
WATCH_S = 2.0
ALL = np.ones(NUM_JOINTS, dtype=bool)


# --- the rules (no physics) ----------------------------------------------------------------------------------


@pytest.mark.parametrize("fsm", sorted(VALID_FSM_IDS))
def test_switch_in_is_accepted_where_each_firmware_option_says(fsm: int) -> None:
    damp, walkrun = fsm == FsmId.DAMP, fsm in STANDING_FSM_IDS
    expected = {UserCtrlOption.NONE: api.ERR_SERVER_API_NOT_IMPL,
                UserCtrlOption.FROM_DAMP: api.OK if damp else REFUSAL_CODE,
                UserCtrlOption.FROM_WALKRUN: api.OK if walkrun else REFUSAL_CODE,
                UserCtrlOption.EITHER: api.OK if damp or walkrun else REFUSAL_CODE}
    for option, code in expected.items():
        assert switch_in_verdict(option, fsm, balanced=True, phase=Phase.INTERNAL) == code, option


def test_switch_in_is_refused_during_a_stand_up_and_while_a_switch_is_pending_or_in_force() -> None:
    assert switch_in_verdict(UserCtrlOption.EITHER, FsmId.STAND_UP, balanced=False, phase=Phase.INTERNAL) == REFUSAL_CODE
    for phase in (Phase.SWITCHING, Phase.USER):
        assert switch_in_verdict(UserCtrlOption.EITHER, FsmId.DAMP, balanced=True, phase=phase) == REFUSAL_CODE
    assert REFUSAL_CODE != api.OK


def test_internal_targets() -> None:
    assert internal_target(InternalCtrl.LAST, FsmId.DAMP) == FsmId.DAMP
    assert internal_target(InternalCtrl.LAST, FsmId.START) == FsmId.START
    assert internal_target(InternalCtrl.PASSIVE, FsmId.START) == FsmId.DAMP
    assert internal_target(InternalCtrl.WALKRUN, FsmId.DAMP) == WALKRUN_FSM == FsmId.RUN


def test_fault_keys_parse_and_refuse_with_a_reason() -> None:
    c = parse_faults('{"user_ctrl": "from_damp", "user_ctrl_delay_s": 0.3}')
    assert (c.user_ctrl, c.user_ctrl_delay_s) == ("from_damp", 0.3)
    none = parse_faults("")
    assert (none.user_ctrl, none.user_ctrl_delay_s) == (None, DEFAULT_DELAY_S)
    assert none.to_json()["user_ctrl"] is None
    refused = (('{"user_ctrl": "always"}', "from_walkrun"), ('{"user_ctrl": 1}', "user_ctrl"),
               ('{"user_ctrl_delay_s": -1}', "user_ctrl_delay_s"), ('{"user_ctrl_delay_s": true}', "seconds"))
    for text, why in refused:
        with pytest.raises(FaultConfigError, match=why):
            parse_faults(text)


# --- SimG1 (physics, no DDS) ---------------------------------------------------------------------------------


def _sim(**kw: Any) -> Any:
    from g1_sim.firmware import SimG1

    return SimG1(**kw)


def _settle_user_ctrl(sim: Any) -> None:
    """Step past the switch's delay."""
    sim.step(round(sim.user_ctrl_status()["delay_s"] * STEPS_PER_S) + 2)


def _hold(sim: Any, q: np.ndarray, seconds: float) -> float:
    """Frames holding ``q`` at 500 Hz for ``seconds``; returns the lowest pelvis height seen."""
    lowest = float("inf")
    kp, kd = np.full(NUM_JOINTS, HOLD_KP), np.full(NUM_JOINTS, HOLD_KD)
    for _ in range(round(seconds * STEPS_PER_S)):
        sim.apply_user_lowcmd(q, 0.0, 0.0, kp, kd, ALL)
        sim.step(1)
        lowest = min(lowest, float(sim.base_pose().position[2]))
    return lowest


def _lowest_for(sim: Any, seconds: float) -> float:
    lowest = float("inf")
    for _ in range(round(seconds * 50)):
        sim.step(STEPS_PER_S // 50)
        lowest = min(lowest, float(sim.base_pose().position[2]))
    return lowest


@pytest.mark.sim
def test_firmware_none_answers_3203_and_nothing_changes() -> None:
    sim = _sim(user_ctrl="none")
    assert sim.switch_to_user_ctrl() == api.ERR_SERVER_API_NOT_IMPL
    assert sim.switch_to_internal_ctrl(InternalCtrl.PASSIVE) == api.ERR_SERVER_API_NOT_IMPL
    sim.step(50)
    assert sim.get_fsm_id() == (api.OK, FsmId.STAND_UP)
    assert sim.user_ctrl_status() == {"user_ctrl": False, "switching": False, "option": "none", "delay_s": DEFAULT_DELAY_S}


@pytest.mark.sim
def test_from_damp_refuses_a_standing_robot_and_from_walkrun_a_damping_one() -> None:
    sim = _sim(user_ctrl="from_damp")
    assert sim.switch_to_user_ctrl() == REFUSAL_CODE
    assert sim.set_fsm_id(FsmId.START) == api.OK  # walking
    assert sim.switch_to_user_ctrl() == REFUSAL_CODE
    sim.step(50)
    assert sim.get_fsm_id() == (api.OK, FsmId.START) and not sim.user_ctrl_status()["switching"]
    assert sim.counters["user_ctrl_refused"] == 2
    sim.set_user_ctrl("from_walkrun", DEFAULT_DELAY_S)
    assert sim.set_fsm_id(FsmId.DAMP) == api.OK
    assert sim.switch_to_user_ctrl() == REFUSAL_CODE
    sim.set_user_ctrl("from_damp", DEFAULT_DELAY_S)
    assert sim.switch_to_user_ctrl() == api.OK
    assert sim.switch_to_user_ctrl() == REFUSAL_CODE  # pending: not twice


@pytest.mark.sim
def test_fsm_1000_and_user_frames_only_after_the_delay() -> None:
    sim = _sim(user_ctrl_delay_s=0.2)
    q = sim.lowstate().q
    assert sim.switch_to_user_ctrl() == api.OK
    sim.step(90)  # 0.18 s: still the built-in controller, the old fsm shown
    assert sim.get_fsm_id() == (api.OK, FsmId.STAND_UP) and sim.sport_state() == (FsmId.STAND_UP, 0)
    assert sim.user_ctrl_status()["switching"] and not sim.user_ctrl_active
    assert not sim.apply_user_lowcmd(q, 0.0, 0.0, np.full(NUM_JOINTS, 5.0), np.zeros(NUM_JOINTS), ALL)
    assert sim.counters["user_lowcmd_ignored"] == 1
    sim.step(12)
    assert sim.get_fsm_id() == (api.OK, USER_CTRL_FSM_ID) and sim.get_fsm_mode() == (api.OK, 0)
    assert sim.sport_state() == (USER_CTRL_FSM_ID, 0) and sim.user_ctrl_active
    # the frame sent before the switch was not kept: no command yet, every motor disabled (limp)
    assert not sim.lowstate().motor_mode.any()
    assert sim.apply_user_lowcmd(q, 0.0, 0.0, np.full(NUM_JOINTS, HOLD_KP), np.full(NUM_JOINTS, HOLD_KD), ALL)
    assert sim.lowstate().motor_mode.all()


@pytest.mark.sim
def test_in_user_control_setfsmid_and_move_do_nothing_lowcmd_and_arm_sdk_are_ignored() -> None:
    sim = _sim()
    assert sim.switch_to_user_ctrl() == api.OK
    assert sim.set_fsm_id(FsmId.DAMP) == api.OK  # during the delay already: 0 and nothing
    _settle_user_ctrl(sim)
    assert sim.set_fsm_id(FsmId.DAMP) == api.OK
    assert sim.set_fsm_id(FsmId.START) == api.OK
    assert sim.set_velocity(0.5, 0.0, 0.0, 1.0) == api.OK
    sim.step(25)
    assert sim.get_fsm_id() == (api.OK, USER_CTRL_FSM_ID)
    assert sim.counters["user_ctrl_ignored_calls"] == 4
    assert sim.check_mode() == ("0", "ai")
    z = np.zeros(NUM_JOINTS)
    sim.apply_lowcmd(z, z, z, z, z, ALL)
    assert sim.counters["lowcmd_ignored"] == 1 and sim.counters["lowcmd_frames"] == 0
    sim.apply_arm_sdk(np.zeros(17), 0, 0, np.full(17, 60.0), np.ones(17), 1.0)
    assert sim.counters["arm_sdk_ignored"] == 1 and sim.arm_sdk_weight == 0.0
    assert sim.switch_to_internal_ctrl(7) == api.ERR_SERVER_API_PARAMETER
    assert sim.get_fsm_id() == (api.OK, USER_CTRL_FSM_ID)


@pytest.mark.sim
def test_switch_to_internal_outside_user_control_answers_0_and_does_nothing() -> None:
    sim = _sim()
    for target in InternalCtrl:
        assert sim.switch_to_internal_ctrl(target) == api.OK
    sim.step(25)
    assert sim.get_fsm_id() == (api.OK, FsmId.STAND_UP) and sim.counters["internal_ctrl_switches"] == 0


@pytest.mark.sim
def test_release_mode_ends_user_control_limp() -> None:
    sim = _sim()
    assert sim.switch_to_user_ctrl() == api.OK
    _settle_user_ctrl(sim)
    assert sim.release_mode() == api.OK
    assert sim.check_mode() == ("0", "") and sim.fsm_id == FsmId.ZERO_TORQUE
    assert not sim.user_ctrl_active and not sim.lowstate().motor_mode.any()
    assert sim.get_fsm_id()[0] == api.ERR_SERVER_API_NOT_IMPL


@pytest.mark.sim
def test_last_returns_to_damp_from_damp_and_passive_damps() -> None:
    sim = _sim(start_fsm=FsmId.DAMP)
    assert sim.switch_to_user_ctrl() == api.OK
    _settle_user_ctrl(sim)
    assert sim.switch_to_internal_ctrl(InternalCtrl.LAST) == api.OK
    assert sim.get_fsm_id() == (api.OK, FsmId.DAMP) and not sim.user_ctrl_active
    sim2 = _sim()
    q = sim2.lowstate().q
    assert sim2.switch_to_user_ctrl() == api.OK
    assert _hold(sim2, q, 1.0) > STANDING_Z_M
    assert sim2.switch_to_internal_ctrl(InternalCtrl.PASSIVE) == api.OK
    assert sim2.get_fsm_id() == (api.OK, FsmId.DAMP) and sim2.lowstate().motor_mode.all()
    sim2.step(2 * STEPS_PER_S)
    assert sim2.base_pose().position[2] < 0.4  # damping holds nothing up: the robot sinks to the floor


@pytest.mark.sim
@pytest.mark.parametrize("target, fsm", [(InternalCtrl.WALKRUN, WALKRUN_FSM), (InternalCtrl.LAST, FsmId.STAND_UP)])
def test_a_standing_robot_held_by_user_frames_is_caught_by_the_built_in_controller(target: InternalCtrl, fsm: int) -> None:
    sim = _sim()
    q = sim.lowstate().q
    assert sim.switch_to_user_ctrl() == api.OK
    lowest = _hold(sim, q, 3.0)
    assert sim.get_fsm_id() == (api.OK, USER_CTRL_FSM_ID)
    assert lowest > STANDING_Z_M, f"fell under user frames: {lowest:.2f} m"
    assert sim.switch_to_internal_ctrl(target) == api.OK
    assert sim.get_fsm_id() == (api.OK, fsm)
    lowest = _lowest_for(sim, 3.0)
    assert lowest > STANDING_Z_M and not sim.fallen, f"not caught: {lowest:.2f} m"
    assert sim.standing_balanced


@pytest.mark.sim
def test_user_frames_are_checked_as_lowcmd_frames() -> None:
    sim = _sim()
    intake = commands.CommandIntake(sim)
    q = sim.lowstate().q
    assert intake.on_user_lowcmd(_frame(q)) == commands.NOT_USER_CTRL
    assert sim.switch_to_user_ctrl() == api.OK
    _settle_user_ctrl(sim)
    assert intake.on_user_lowcmd(_frame(q, crc_ok=False)) == commands.BAD_CRC
    assert intake.on_user_lowcmd(_frame(q, mode_machine=0)) == commands.BAD_MODE_MACHINE
    assert intake.on_user_lowcmd(_frame(q)) is None
    assert intake.on_lowcmd(_frame(q)) == commands.USER_CTRL_ACTIVE
    assert intake.counts()["user_lowcmd"] == {"received": 4, "accepted": 1, "bad_crc": 1, "bad_mode_machine": 1,
                                              "not_user_ctrl": 1}
    assert intake.counts()["lowcmd"] == {"received": 1, "user_ctrl_active": 1}


def _frame(q: np.ndarray, *, kp: float = HOLD_KP, kd: float = HOLD_KD, mode_machine: int = 5,
           crc_ok: bool = True) -> LowCmd_:
    msg = unitree_hg_msg_dds__LowCmd_()
    msg.mode_machine = mode_machine
    for i in range(NUM_JOINTS):
        m = msg.motor_cmd[i]
        m.mode, m.q, m.dq, m.tau, m.kp, m.kd = 1, float(q[i]), 0.0, 0.0, kp, kd
    msg.crc = lowcmd_crc(msg) ^ (0 if crc_ok else 0xFF)
    return msg


# --- through the bridge, with the SDK's own clients ------------------------------------------------------------


@dataclass
class Clients:
    """SDK clients of this process, alive for the whole session (support/sim_bridge.py: pitfall)."""

    sport: Any  # the SDK's generic Client on "sport", 7110/7111 registered (its LocoClient has neither)
    switcher: Any
    status: SimStatus
    user: Any  # rt/user_lowcmd
    low: Any  # rt/lowcmd
    lowstate: Any


@functools.cache
def _session_clients() -> Clients:
    from unitree_sdk2py.comm.motion_switcher.motion_switcher_client import MotionSwitcherClient
    from unitree_sdk2py.core.channel import ChannelPublisher, ChannelSubscriber
    from unitree_sdk2py.rpc.client import Client

    from g1_mode_manager.protocol import topics
    from g1_mode_manager.protocol.idl import LowState_

    sport = Client(api.LOCO_SERVICE, False)
    sport._SetApiVerson(api.LOCO_API_VERSION)
    for api_id in (api.LOCO_GET_FSM_ID, api.LOCO_SET_FSM_ID, api.LOCO_SET_VELOCITY, api.LOCO_SWITCH_TO_USER_CTRL,
                   api.LOCO_SWITCH_TO_INTERNAL_CTRL):
        sport._RegistApi(api_id, 0)
    switcher = initialised(MotionSwitcherClient())
    user = initialised(ChannelPublisher(topics.USER_LOWCMD, LowCmd_))
    low = initialised(ChannelPublisher(topics.LOWCMD, LowCmd_))
    lowstate = initialised(ChannelSubscriber(topics.LOWSTATE, LowState_))
    return Clients(sport, switcher, shared_sim_status(), user, low, lowstate)


@pytest.fixture
def clients(sdk_channels: int) -> Clients:
    c = _session_clients()
    for client in (c.sport, c.switcher):  # a test may have left a shorter one
        client.SetTimeout(3.0)
    return c


def _call(c: Clients, api_id: int, parameter: dict[str, Any] | None = None) -> tuple[int, Any]:
    return call(c.sport, api_id, parameter)


def _fsm(c: Clients) -> int:
    code, data = _call(c, api.LOCO_GET_FSM_ID)
    assert code == 0, code
    return int(data["data"])


def _refused_user_frames(c: Clients) -> int:
    """rt/user_lowcmd frames the robot ignored because it was not under user control."""
    return int(c.status.get()["frames"].get("user_lowcmd", {}).get("not_user_ctrl", 0))


def _ready(c: Clients) -> None:
    c.status.wait_ready()
    deadline = time.monotonic() + 15.0
    while c.sport.GetServerApiVersion()[0] != 0:  # a fresh client is not matched at once (3102)
        assert time.monotonic() < deadline, "sport service not answering"
        time.sleep(0.1)


def _wait_fsm(c: Clients, fsm: int, timeout_s: float = 5.0) -> None:
    deadline = time.monotonic() + timeout_s
    while (now := _fsm(c)) != fsm:
        assert time.monotonic() < deadline, f"fsm {now}, not {fsm}"
        time.sleep(0.01)


class FrameStream:
    """rt/user_lowcmd at 500 Hz from a thread, every frame holding one pose (a user's stiff hold)."""

    PERIOD_S = 0.002

    def __init__(self, publisher: Any, q: np.ndarray) -> None:
        self._publisher, self._msg = publisher, _frame(q)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self.sent = 0

    def _run(self) -> None:
        def write() -> None:
            self._publisher.Write(self._msg)
            self.sent += 1

        run_at_rate(1.0 / self.PERIOD_S, write, self._stop)

    def __enter__(self) -> FrameStream:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join(2.0)


def _standing_q(c: Clients) -> np.ndarray:
    c.lowstate.Read(0.05)
    msg = c.lowstate.Read(2.0)
    assert msg is not None, "no rt/lowstate"
    return np.array([m.q for m in msg.motor_state[:NUM_JOINTS]])


def _index(events: list[dict[str, Any]], pred: Any) -> int:
    return next(i for i, e in enumerate(events) if pred(e))


def _fsms(events: list[dict[str, Any]]) -> list[int]:
    """The fsm ids the record's state events went through (a change of fsm_mode alone repeats one)."""
    out: list[int] = []
    for s in states(events):
        if not out or out[-1] != s["fsm"]:
            out.append(s["fsm"])
    return out


@pytest.fixture
def record(tmp_path: Any) -> Iterator[Any]:
    yield tmp_path / "record.jsonl"


@pytest.mark.sim
def test_bridge_standing_switch_held_by_frames_and_caught_by_walkrun(clients: Clients, sim_bridge_factory,  # noqa: F811
                                                                      record: Any) -> None:
    from g1_sim.bridge.clock import MAX_LAG_S

    delay = 0.3
    sim_bridge_factory(faults={"user_ctrl_delay_s": delay}, extra_args=("--record", str(record)))
    c = clients
    _ready(c)
    assert _fsm(c) == FsmId.STAND_UP
    q = _standing_q(c)
    with FrameStream(c.user, q) as stream:
        time.sleep(0.2)  # frames before the switch: ignored
        assert _call(c, api.LOCO_SWITCH_TO_USER_CTRL, {"data": False})[0] == api.OK
        assert _fsm(c) == FsmId.STAND_UP  # the delay: still the old fsm
        _wait_fsm(c, USER_CTRL_FSM_ID)
        assert c.switcher.CheckMode() == (0, {"form": "0", "name": "ai"})
        assert c.sport._Call(api.LOCO_SET_FSM_ID, json.dumps({"data": 1}))[0] == api.OK  # Damp: 0 and nothing
        for _ in range(20):
            c.low.Write(_frame(np.zeros(NUM_JOINTS), kp=50.0))  # rt/lowcmd: ignored
            time.sleep(0.01)
        c.status.wait_sim_time(c.status.get()["sim_time"] + WATCH_S)
        st = c.status.get()
        assert st["user_ctrl"] and st["user_ctrl_option"] == "either" and st["sport"]["fsm_id"] == USER_CTRL_FSM_ID
        assert _call(c, api.LOCO_SWITCH_TO_INTERNAL_CTRL, {"data": int(InternalCtrl.WALKRUN)})[0] == api.OK
        assert _fsm(c) == WALKRUN_FSM
        # the stream goes on until the robot has judged frames after the switch (a starved stream thread may have
        # sent none yet)
        refused = _refused_user_frames(c)
        assert wait_until(lambda: _refused_user_frames(c) >= refused + 10, RECORD_WAIT_S)
    st = c.status.wait_sim_time(c.status.get()["sim_time"] + WATCH_S)  # no frames: the built-in controller holds it
    print(f"frames sent {stream.sent}; status frames {st['frames']}; firmware {st['firmware']}")
    assert not st["user_ctrl"] and st["sport"]["fsm_id"] == WALKRUN_FSM
    assert st["frames"]["lowcmd"].get("user_ctrl_active", 0) >= 10 and st["frames"]["lowcmd"].get("accepted", 0) == 0

    ev = SimRecord(record).events()
    done_in = requests(ev, api.LOCO_SWITCH_TO_USER_CTRL, kind="done")
    assert [e["code"] for e in done_in] == [api.OK]
    fsms = _fsms(ev)
    assert fsms == [FsmId.STAND_UP, USER_CTRL_FSM_ID, WALKRUN_FSM], fsms  # the Damp changed nothing
    i_in = _index(ev, lambda e: e["k"] == "state" and e["fsm"] == USER_CTRL_FSM_ID)
    i_out = _index(ev, lambda e: e["k"] == "state" and e["fsm"] == WALKRUN_FSM)
    assert ev[i_in]["t"] - done_in[0]["t"] >= delay - MAX_LAG_S, "fsm 1000 before the delay"
    user = [(i, e) for i, e in enumerate(ev) if e["k"] == "frame" and e["topic"] == "user_lowcmd"]
    before = [e for i, e in user if i < i_in]
    during = [e for i, e in user if i_in < i < i_out]
    after = [e for i, e in user if i > i_out]
    # A frame judged just before a switch may be written just after its state line: at most one at each edge.
    assert len(before) >= 50 and all(not e["ok"] and e["why"] == "not_user_ctrl" for e in before)
    assert len(during) >= 300 and all(e["ok"] for e in during[1:]), [e for e in during if not e["ok"]][:3]
    assert after and all(not e["ok"] for e in after[1:])
    low = [e for e in of_kind(ev, "frame") if e["topic"] == "lowcmd"]
    assert low and all(e["why"] == "user_ctrl_active" for e in low)
    damp = requests(ev, api.LOCO_SET_FSM_ID, kind="done")
    assert [e["code"] for e in damp] == [api.OK]
    body = [e for e in of_kind(ev, "body") if e["t"] >= done_in[0]["t"] - 0.2]
    lowest = min(e["z"] for e in body)
    print(f"lowest pelvis {lowest:.3f} m over {body[-1]['st'] - body[0]['st']:.1f} s of sim time")
    assert body[-1]["st"] - body[0]["st"] > 2 * WATCH_S and lowest > STANDING_Z_M


@pytest.mark.sim
def test_bridge_firmware_option_none_then_from_damp(clients: Clients, sim_bridge_factory, record: Any) -> None:  # noqa: F811
    """--user-ctrl from_damp, the fault key user_ctrl "none" over it; a reset drops the fault."""
    sim_bridge_factory(faults={"user_ctrl": "none"}, extra_args=("--user-ctrl", "from_damp", "--record", str(record)))
    c = clients
    _ready(c)
    st = c.status.get()
    assert (st["user_ctrl_option"], st["user_ctrl"], st["faults"]["user_ctrl"]) == ("none", False, "none")
    assert _call(c, api.LOCO_SWITCH_TO_USER_CTRL, {"data": False})[0] == api.ERR_SERVER_API_NOT_IMPL
    assert _call(c, api.LOCO_SWITCH_TO_INTERNAL_CTRL, {"data": 1})[0] == api.ERR_SERVER_API_NOT_IMPL
    assert _fsm(c) == FsmId.STAND_UP

    assert c.status.reset()["user_ctrl_option"] == "from_damp"
    assert _call(c, api.LOCO_SET_FSM_ID, {"data": int(FsmId.START)})[0] == api.OK  # walking
    assert _call(c, api.LOCO_SWITCH_TO_USER_CTRL, {"data": False})[0] == REFUSAL_CODE
    assert _fsm(c) == FsmId.START
    assert _call(c, api.LOCO_SET_FSM_ID, {"data": int(FsmId.DAMP)})[0] == api.OK
    assert _call(c, api.LOCO_SWITCH_TO_USER_CTRL, {"data": False})[0] == api.OK
    _wait_fsm(c, USER_CTRL_FSM_ID)
    assert _call(c, api.LOCO_SWITCH_TO_INTERNAL_CTRL, {"data": int(InternalCtrl.PASSIVE)})[0] == api.OK
    assert _fsm(c) == FsmId.DAMP
    assert not c.status.get()["user_ctrl"]
    ev = SimRecord(record).after_last_reset()
    assert _fsms(ev) == [FsmId.STAND_UP, FsmId.START, FsmId.DAMP, USER_CTRL_FSM_ID, FsmId.DAMP]
    assert [e["code"] for e in requests(ev, api.LOCO_SWITCH_TO_USER_CTRL, kind="done")] == [REFUSAL_CODE, api.OK]
