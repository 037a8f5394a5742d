"""Sim bridge logic without MuJoCo or DDS: faults, RPC handlers, frame checks, lowstate packing, pacing."""

from __future__ import annotations

import json
import re
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from unitree_sdk2py.idl.default import unitree_hg_msg_dds__LowCmd_
from unitree_sdk2py.utils.crc import CRC

from g1_mode_manager.protocol import api_ids as api
from g1_mode_manager.protocol.dds import apply_robot_type_compat
from g1_mode_manager.protocol.idl import LowCmd_, LowState_
from g1_sim.bridge import commands
from g1_sim.bridge.clock import Pacer, RateMeter
from g1_sim.bridge.faults import FaultConfigError, Faults, parse_faults
from g1_sim.bridge.lowstate_codec import LowStatePacker, self_check
from g1_sim.bridge.rpc_services import SimServer, arm_action_handlers, motion_switcher_handlers, sport_handlers
from g1_sim.firmware.state import BodySnapshot
from g1_sim.physics.battery import reading_at


@dataclass
class StandIn:
    """Records calls; answers like a robot standing in fsm 4 with service "ai" selected."""

    fsm_id: int = 4
    active: bool = True
    user_ctrl_active: bool = False  # fsm 1000 in force (sport 7110)
    calls: list[tuple[str, Any]] = field(default_factory=list)

    def sport_active(self) -> bool:
        return self.active

    def sport_state(self) -> tuple[int, int]:
        return (self.fsm_id, 0)

    def arm_task(self) -> tuple[int, float]:
        return (0, 0.0)

    @property
    def standing_balanced(self) -> bool:
        return self.fsm_id in (4, 500)

    def set_fsm_id(self, i: int) -> int:
        self.calls.append(("set_fsm_id", i))
        return api.OK

    def get_fsm_id(self) -> tuple[int, int]:
        return (api.OK, self.fsm_id)

    def get_fsm_mode(self) -> tuple[int, int]:
        return (api.OK, 0)

    def set_balance_mode(self, m: int) -> int:
        self.calls.append(("set_balance_mode", m))
        return api.OK

    def get_balance_mode(self) -> tuple[int, int]:
        return (api.OK, 0)

    def set_velocity(self, vx: float, vy: float, wz: float, d: float) -> int:
        self.calls.append(("set_velocity", (vx, vy, wz, d)))
        return api.OK

    def set_speed_mode(self, m: int) -> int:
        return api.OK

    def set_stand_height(self, h: float) -> int:
        return api.OK

    def get_stand_height(self) -> tuple[int, float]:
        return (api.OK, 0.75)

    def set_swing_height(self, h: float) -> int:
        return api.OK

    def get_swing_height(self) -> tuple[int, float]:
        return (api.OK, 0.08)

    def check_mode(self) -> tuple[str, str]:
        return ("0", "ai" if self.active else "")

    def select_mode(self, name: str) -> int:
        self.calls.append(("select_mode", name))
        self.active = True
        return api.OK

    def release_mode(self) -> int:
        self.active = False
        return api.OK

    def get_silent(self) -> tuple[int, bool]:
        return (api.OK, False)

    def set_silent(self, b: bool) -> int:
        return api.OK

    def apply_arm_sdk(self, q, dq, tau, kp, kd, weight) -> None:  # type: ignore[no-untyped-def]
        self.calls.append(("arm_sdk", (np.array(q), weight)))

    def apply_lowcmd(self, q, dq, tau, kp, kd, enabled) -> None:  # type: ignore[no-untyped-def]
        self.calls.append(("lowcmd", (np.array(q), np.array(enabled))))

    def apply_user_lowcmd(self, q, dq, tau, kp, kd, enabled) -> bool:  # type: ignore[no-untyped-def]
        if self.user_ctrl_active:
            self.calls.append(("user_lowcmd", (np.array(q), np.array(enabled))))
        return self.user_ctrl_active

    def switch_to_user_ctrl(self) -> int:
        self.calls.append(("switch_to_user_ctrl", None))
        return api.OK

    def switch_to_internal_ctrl(self, target: int) -> int:
        self.calls.append(("switch_to_internal_ctrl", target))
        return api.OK


# --- faults ------------------------------------------------------------------------------------


def test_faults_parse_all_keys() -> None:
    c = parse_faults('{"delay_s": {"1002": 5.0}, "drop": [7101], "error": {"7101": 3104}, '
                     '"pause_state": true, "damp_fails": 2}')
    assert c.delay_s == {1002: (5.0, 5.0)}
    assert c.drop == {7101}
    assert c.error == {7101: 3104}
    assert c.pause_state and c.damp_fails == 2
    assert parse_faults("") == parse_faults("{}")



def test_every_fault_key_is_in_the_docs_fault_table() -> None:
    from g1_sim.bridge import faults

    table = (Path(__file__).parents[2] / "docs" / "sim.md").read_text().split("## Faults", 1)[1]
    documented = set(re.findall(r"^\| `(\w+)` \|", table, re.MULTILINE))
    assert documented >= faults._KEYS, f"fault keys missing from docs/sim.md's table: {sorted(faults._KEYS - documented)}"

@pytest.mark.parametrize(
    "text",
    ["{", "[]", '{"dely_s": {}}', '{"delay_s": {"x": 1}}', '{"delay_s": {"1002": -1}}', '{"drop": 7101}',
     '{"error": {"7101": 0}}', '{"error": {"7101": 1.5}}', '{"pause_state": 1}', '{"damp_fails": -1}',
     '{"damp_fails": true}', '{"drop": [true]}', '{"delay_s": {"1003": [2, 1]}}', '{"delay_s": {"1003": [1]}}',
     '{"seed": "x"}'],
)
def test_faults_invalid_is_refused_and_previous_kept(text: str) -> None:
    faults = Faults(parse_faults('{"drop": [1001]}'))
    with pytest.raises(FaultConfigError):
        faults.set_json(text)
    assert faults.drops(1001)


def test_faults_parse_the_body_injections() -> None:
    c = parse_faults(json.dumps({"motor_temperature": {"3": [90, 130.5], "28": [20, 21]}, "battery_soc": 15,
                                 "remote_keys": ["L2", "B"], "push": {"force": 150, "direction": [0, 2], "duration": 0.3},
                                 "freeze_lowstate": True, "runaway_motor": {"motor": 18, "duration": 0.2}}))
    assert c.motor_temperature == {3: (90.0, 130.5), 28: (20.0, 21.0)}
    assert c.runaway_motor is not None and (c.runaway_motor.motor, c.runaway_motor.direction) == (18, 1)
    assert c.battery_soc == 15.0 and c.remote_keys == {"L2", "B"} and c.freeze_lowstate
    assert c.push is not None and c.push.force_xy == pytest.approx((0.0, 150.0)) and c.push.duration_s == 0.3
    angled = parse_faults('{"push": {"force": 100, "direction": 3.141592653589793, "duration": 1}}').push
    assert angled is not None and angled.force_xy == pytest.approx((-100.0, 0.0))
    assert parse_faults(json.dumps(c.to_json())) == c  # the status shows what parses back
    none = parse_faults("")
    assert none.battery_soc is None and none.push is None and not none.remote_keys and not none.freeze_lowstate


@pytest.mark.parametrize(
    ("text", "why"),
    [('{"motor_temperature": {"29": [1, 2]}}', "motor index must be 0..28"),
     ('{"motor_temperature": {"x": [1, 2]}}', "motor index"),
     ('{"motor_temperature": {"3": [90]}}', "[casing, winding]"),
     ('{"motor_temperature": {"3": [90, 999]}}', "within -40..200"),
     ('{"motor_temperature": [90, 130]}', "must be an object"),
     ('{"battery_soc": 101}', "0..100"), ('{"battery_soc": "15"}', "expected a number"),
     ('{"remote_keys": ["L2", "b"]}', "unknown remote key 'b'"), ('{"remote_keys": "L2"}', "list of key names"),
     ('{"push": {"force": 100, "direction": [0, 0], "duration": 0.2}}', "must not be zero"),
     ('{"push": {"force": 0, "direction": [1, 0], "duration": 0.2}}', "push.force"),
     ('{"push": {"force": 100, "direction": [1, 0], "duration": 9}}', "push.duration"),
     ('{"push": {"force": 100, "direction": [1, 0, 0], "duration": 1}}', "push.direction"),
     ('{"push": {"force": 100, "duration": 1}}', "push must be an object"),
     ('{"freeze_lowstate": 1}', "freeze_lowstate must be true or false"),
     ('{"runaway_motor": {"motor": 29, "duration": 0.2}}', "runaway_motor.motor"),
     ('{"runaway_motor": {"motor": 3, "direction": 0, "duration": 0.2}}', "runaway_motor.direction"),
     ('{"runaway_motor": {"motor": 3, "duration": 5}}', "runaway_motor.duration"),
     ('{"runaway_motor": {"motor": 3}}', "runaway_motor must be an object")],
)
def test_faults_body_injections_refused_with_a_reason(text: str, why: str) -> None:
    faults = Faults(parse_faults('{"battery_soc": 50}'))
    with pytest.raises(FaultConfigError, match=re.escape(why)):
        faults.set_json(text)
    assert faults.config.battery_soc == 50


def test_faults_tell_a_listener_every_change() -> None:
    faults = Faults()
    seen: list[tuple[Any, Any]] = []
    faults.on_change = lambda old, new: seen.append((old, new))
    faults.set_json('{"remote_keys": ["L2", "B"]}')
    faults.set_json("")
    assert [(o.remote_keys, n.remote_keys) for o, n in seen] == [(set(), {"L2", "B"}), ({"L2", "B"}, set())]


def test_delay_ranges_draw_a_delay_per_request_replayably() -> None:
    text = '{"delay_s": {"1003": [0.5, 3.0], "1002": 2.0}, "seed": 11}'
    first, second = Faults(parse_faults(text)), Faults(parse_faults(text))
    draws = [first.delay_s(1003) for _ in range(50)]
    assert all(0.5 <= d <= 3.0 for d in draws) and len(set(draws)) > 40  # differs per request
    assert draws == [second.delay_s(1003) for _ in range(50)]  # the same seed replays the same delays
    assert first.delay_s(1002) == 2.0 and first.delay_s(7101) == 0.0
    assert parse_faults(text).to_json()["delay_s"] == {"1003": [0.5, 3.0], "1002": 2.0}


@pytest.mark.parametrize(
    ("text", "why"),
    [('{"ignore_fsm_ids": 500}', "ignore_fsm_ids must be a list of fsm ids"),
     ('{"ignore_fsm_ids": ["500"]}', "an fsm id must be an integer >= 0, got '500'"),
     ('{"ignore_fsm_ids": [-1]}', "got -1"), ('{"ignore_fsm_ids": [true]}', "got True"),
     ('{"ignore_fsm_ids": [500.0]}', "got 500.0")],
)
def test_ignore_fsm_ids_refused_with_a_reason(text: str, why: str) -> None:
    faults = Faults(parse_faults('{"ignore_fsm_ids": [501]}'))
    with pytest.raises(FaultConfigError, match=re.escape(why)):
        faults.set_json(text)
    assert faults.ignores_fsm(501) and not faults.ignores_fsm(500)


def test_odometry_errors_have_non_zero_defaults_and_parse_partly() -> None:
    default = parse_faults("").odom
    assert default.xy_per_m > 0 and default.xy_mps > 0 and default.yaw_per_rad > 0 and default.noise_m > 0
    c = parse_faults('{"odom_drift": {"xy_per_m": 0.05, "yaw_per_rad": -0.01}, "odom_noise_m": 0}')
    assert (c.odom.xy_per_m, c.odom.yaw_per_rad, c.odom.noise_m) == (0.05, -0.01, 0.0)
    assert c.odom.xy_mps == default.xy_mps  # left out: its default
    assert parse_faults(json.dumps(c.to_json())) == c
    exact = parse_faults('{"odom_drift": {"xy_per_m": 0, "xy_mps": 0, "yaw_per_rad": 0}, "odom_noise_m": 0}').odom
    assert (exact.xy_per_m, exact.xy_mps, exact.yaw_per_rad, exact.noise_m) == (0, 0, 0, 0)


@pytest.mark.parametrize(
    ("text", "why"),
    [('{"odom_drift": 0.01}', "odom_drift must be an object"),
     ('{"odom_drift": {"xy": 0.01}}', "odom_drift: unknown keys ['xy']"),
     ('{"odom_drift": {"xy_mps": -0.1}}', "odom_drift.xy_mps must be within 0..1"),
     ('{"odom_drift": {"xy_per_m": 2}}', "odom_drift.xy_per_m must be within -1..1"),
     ('{"odom_drift": {"yaw_per_rad": "0.1"}}', "odom_drift.yaw_per_rad: expected a number"),
     ('{"odom_noise_m": -0.001}', "odom_noise_m must be within 0..1 m"), ('{"odom_noise_m": true}', "odom_noise_m")],
)
def test_odometry_errors_refused_with_a_reason(text: str, why: str) -> None:
    faults = Faults(parse_faults('{"odom_noise_m": 0.5}'))
    with pytest.raises(FaultConfigError, match=re.escape(why)):
        faults.set_json(text)
    assert faults.config.odom.noise_m == 0.5


def test_ignored_fsm_ids_answer_ok_and_leave_the_robot_alone() -> None:
    robot = StandIn()
    faults = Faults(parse_faults('{"ignore_fsm_ids": [500, 0]}'))
    assert faults.config.to_json()["ignore_fsm_ids"] == [0, 500]
    assert parse_faults(json.dumps(faults.config.to_json())) == faults.config
    s = _server(robot, faults)
    assert s.handle_for_test(api.LOCO_SET_FSM_ID, '{"data": 500}') == (api.OK, "")
    assert s.handle_for_test(api.LOCO_SET_FSM_ID, '{"data": 0}') == (api.OK, "")
    assert robot.calls == []
    assert s.handle_for_test(api.LOCO_SET_FSM_ID, '{"data": 501}') == (api.OK, "")
    assert robot.calls == [("set_fsm_id", 501)]
    robot.active = False  # debug mode: the sport service answers nothing but 3203, ignored ids included
    assert s.handle_for_test(api.LOCO_SET_FSM_ID, '{"data": 500}')[0] == api.ERR_SERVER_API_NOT_IMPL


def test_damp_fails_budget_is_used_up_and_restarts_on_set() -> None:
    faults = Faults(parse_faults('{"damp_fails": 2}'))
    assert [faults.take_damp_failure() for _ in range(3)] == [True, True, False]
    faults.set_json('{"damp_fails": 1}')
    assert faults.take_damp_failure() and not faults.take_damp_failure()


def test_damp_fails_budget_is_not_restarted_by_other_faults_or_the_same_configuration() -> None:
    faults = Faults(parse_faults('{"damp_fails": 2}'))
    assert faults.take_damp_failure()
    faults.set_json('{"damp_fails": 2, "motor_temperature": {"16": [70, 140]}}')  # a body injection
    faults.set_json('{"damp_fails": 2}')  # and the plan's configuration re-sent
    assert faults.take_damp_failure() and not faults.take_damp_failure()
    faults.set_json("{}")
    faults.set_json('{"damp_fails": 2}')  # set anew: a new budget
    assert [faults.take_damp_failure() for _ in range(3)] == [True, True, False]


# --- RPC handlers --------------------------------------------------------------------------------


def _server(robot: StandIn, faults: Faults | None = None) -> SimServer:
    return SimServer(api.LOCO_SERVICE, api.LOCO_API_VERSION, sport_handlers(robot, faults or Faults()), faults=faults)


def test_sport_getters_reply_data_json() -> None:
    s = _server(StandIn(fsm_id=500))
    assert s.handle_for_test(api.LOCO_GET_FSM_ID, "") == (0, '{"data": 500}')
    code, data = s.handle_for_test(api.LOCO_GET_STAND_HEIGHT, "{}")
    assert code == 0 and json.loads(data) == {"data": 0.75}


def test_sport_setters_parse_parameters() -> None:
    robot = StandIn()
    s = _server(robot)
    assert s.handle_for_test(api.LOCO_SET_FSM_ID, '{"data": 500}') == (0, "")
    assert s.handle_for_test(api.LOCO_SET_VELOCITY, '{"velocity": [0.5, 0, 0.1], "duration": 864000.0}')[0] == 0
    assert robot.calls == [("set_fsm_id", 500), ("set_velocity", (0.5, 0.0, 0.1, 864000.0))]


@pytest.mark.parametrize(
    ("api_id", "parameter"),
    [(api.LOCO_SET_FSM_ID, "{not json"), (api.LOCO_SET_FSM_ID, '{"data": "1"}'), (api.LOCO_SET_FSM_ID, "[1]"),
     (api.LOCO_SET_FSM_ID, '{"data": 1.5}'), (api.LOCO_SET_VELOCITY, '{"velocity": [1, 2]}'),
     (api.LOCO_SET_VELOCITY, '{"velocity": [1, 2, NaN]}'), (api.LOCO_SET_BALANCE_MODE, "{}")],
)
def test_malformed_parameter_answers_3204_and_does_nothing(api_id: int, parameter: str) -> None:
    robot = StandIn()
    assert _server(robot).handle_for_test(api_id, parameter) == (api.ERR_SERVER_API_PARAMETER, "")
    assert robot.calls == []


def test_sport_answers_3203_while_released() -> None:
    robot = StandIn(active=False)
    s = _server(robot)
    assert s.handle_for_test(api.LOCO_SET_FSM_ID, '{"data": 1}') == (api.ERR_SERVER_API_NOT_IMPL, "")
    assert s.handle_for_test(api.LOCO_GET_FSM_ID, "{}") == (api.ERR_SERVER_API_NOT_IMPL, "")
    assert robot.calls == []


def test_unknown_api_is_not_implemented() -> None:
    assert _server(StandIn()).handle_for_test(api.LOCO_GET_PHASE, "{}")[0] == api.ERR_SERVER_API_NOT_IMPL


def test_damp_fails_and_error_faults() -> None:
    robot = StandIn()
    faults = Faults(parse_faults('{"damp_fails": 1, "error": {"7105": 3104}}'))
    s = _server(robot, faults)
    assert s.handle_for_test(api.LOCO_SET_FSM_ID, '{"data": 1}')[0] == api.ERR_CLIENT_API_TIMEOUT
    assert s.handle_for_test(api.LOCO_SET_FSM_ID, '{"data": 1}')[0] == api.OK
    assert s.handle_for_test(api.LOCO_SET_VELOCITY, '{"velocity": [0, 0, 0], "duration": 1}')[0] == 3104
    assert robot.calls == [("set_fsm_id", 1)]


def test_motion_switcher_handlers() -> None:
    robot = StandIn()
    s = SimServer(api.MOTION_SWITCHER_SERVICE, api.MOTION_SWITCHER_API_VERSION, motion_switcher_handlers(robot))
    assert json.loads(s.handle_for_test(api.MS_CHECK_MODE, "{}")[1]) == {"form": "0", "name": "ai"}
    assert s.handle_for_test(api.MS_RELEASE_MODE, "{}")[0] == 0
    assert json.loads(s.handle_for_test(api.MS_CHECK_MODE, "{}")[1])["name"] == ""
    assert s.handle_for_test(api.MS_SELECT_MODE, '{"name": 3}')[0] == api.ERR_SERVER_API_PARAMETER
    assert s.handle_for_test(api.MS_SELECT_MODE, '{"name": "ai"}')[0] == 0
    assert json.loads(s.handle_for_test(api.MS_GET_SILENT, "{}")[1]) == {"silent": False}


@dataclass
class ArmStandIn:
    executed: list[int] = field(default_factory=list)

    def execute_arm_action(self, action_id: int) -> int:
        self.executed.append(action_id)
        return api.OK

    def arm_action_list(self) -> dict[int, str]:
        return {99: "release arm"}


def test_arm_service_takes_both_sdks_parameters_and_has_no_custom_actions() -> None:
    robot = ArmStandIn()
    s = SimServer(api.ARM_SERVICE, api.ARM_API_VERSION, arm_action_handlers(robot))
    assert s.handle_for_test(api.ARM_EXECUTE_ACTION, '{"data": 26}') == (api.OK, "")  # Python SDK
    assert s.handle_for_test(api.ARM_EXECUTE_ACTION, '{"action_id":99}') == (api.OK, "")  # C++ SDK
    assert s.handle_for_test(api.ARM_EXECUTE_ACTION, "{}")[0] == api.ERR_SERVER_API_PARAMETER
    assert robot.executed == [26, 99]
    assert s.handle_for_test(api.ARM_EXECUTE_CUSTOM_ACTION, '{"action_name":"wave"}')[0] == api.ARM_ERR_INVALID_ACTION_ID
    assert s.handle_for_test(api.ARM_EXECUTE_CUSTOM_ACTION, "{}")[0] == api.ERR_SERVER_API_PARAMETER
    assert s.handle_for_test(api.ARM_STOP_CUSTOM_ACTION, "") == (api.OK, "")


# --- rt/lowcmd and rt/arm_sdk frames ---------------------------------------------------------------


def _frame(mode_machine: int = 5, *, mode: int = 1, good_crc: bool = True, weight: float = 1.0,
           crc: int | None = None) -> LowCmd_:
    """A frame with a good CRC, a wrong one (``good_crc=False``) or the given crc field (0: none, as Unitree's C++
    arm_sdk example sends)."""
    msg = unitree_hg_msg_dds__LowCmd_()
    msg.mode_machine = mode_machine
    for i in range(29):
        msg.motor_cmd[i].mode = mode
        msg.motor_cmd[i].q = 0.01 * i
        msg.motor_cmd[i].kp = 40.0
    msg.motor_cmd[29].q = weight
    msg.crc = CRC().Crc(msg) ^ (0 if good_crc else 1) if crc is None else crc
    return msg


def test_lowcmd_checks_crc_mode_machine_and_debug_mode() -> None:
    robot = StandIn(active=False)
    seen: list[tuple[Any, ...]] = []
    intake = commands.CommandIntake(robot, on_frame=lambda *a: seen.append(a))
    assert intake.on_lowcmd(_frame(good_crc=False)) == commands.BAD_CRC
    assert intake.on_lowcmd(_frame(mode_machine=4)) == commands.BAD_MODE_MACHINE
    assert intake.on_lowcmd(_frame()) is None
    assert intake.on_lowcmd(_frame(mode=0)) is None
    assert intake.on_lowcmd(_frame(crc=0)) == commands.BAD_CRC  # rt/lowcmd has no "no CRC"
    robot.active = True
    assert intake.on_lowcmd(_frame()) == commands.NOT_DEBUG_MODE
    applied = [c for c in robot.calls if c[0] == "lowcmd"]
    assert len(applied) == 2 and applied[0][1][1].all() and not applied[1][1][1].any()
    assert np.allclose(applied[0][1][0], 0.01 * np.arange(29), atol=1e-6)
    assert intake.counts()["lowcmd"] == {"received": 6, "accepted": 2, "bad_crc": 2, "bad_mode_machine": 1,
                                         "motors_disabled": 1, "not_debug_mode": 1}
    assert [a[4] for a in seen] == ["wrong", "ok", "ok", "ok", "none", "ok"]


def test_arm_sdk_takes_any_crc_and_checks_standing_not_mode_machine() -> None:
    robot = StandIn()
    seen: list[tuple[Any, ...]] = []
    intake = commands.CommandIntake(robot, on_frame=lambda *a: seen.append(a))
    assert intake.on_arm_sdk(_frame(crc=0)) is None  # Unitree's C++ example: no CRC at all
    assert intake.on_arm_sdk(_frame(good_crc=False)) is None  # the field is not looked at
    assert intake.on_arm_sdk(_frame(mode_machine=0, mode=0, weight=1.7)) is None
    robot.fsm_id = 1
    assert intake.on_arm_sdk(_frame(crc=0)) == commands.NOT_STANDING
    calls = [c for c in robot.calls if c[0] == "arm_sdk"]
    assert len(calls) == 3
    q, weight = calls[2][1]
    assert weight == 1.0 and q.shape == (17,) and q[0] == pytest.approx(0.12)
    counts = intake.counts()["arm_sdk"]
    assert counts == {"received": 4, "accepted": 3, "crc0": 2, "crc_wrong": 1, "mode_machine_not_5": 1,
                      "not_standing": 1}
    assert [(a[1], a[4]) for a in seen] == [(None, "none"), (None, "wrong"), (None, "ok"), ("not_standing", "none")]


def test_non_finite_frames_are_ignored() -> None:
    robot = StandIn()
    intake = commands.CommandIntake(robot)
    assert intake.on_arm_sdk(_frame(weight=float("nan"))) == commands.NON_FINITE
    assert robot.calls == []


# --- rt/lowstate packing -------------------------------------------------------------------------


def test_lowstate_packing_matches_cyclonedds_and_sdk_crc() -> None:
    apply_robot_type_compat()
    packer = LowStatePacker()
    self_check(packer)
    q = np.linspace(-1, 1, 29)
    packer.pack(q, q * 2, q * 3, np.array([1, 0, 0, 0]), np.ones(3), np.ones(3) * 9.8, np.zeros(3), 42)
    decoded = LowState_.deserialize(packer.frame_bytes())
    assert decoded.mode_machine == 5 and decoded.tick == 42
    assert decoded.motor_state[28].q == pytest.approx(1.0) and decoded.motor_state[28].tau_est == pytest.approx(3.0)
    assert decoded.crc == CRC().Crc(decoded)
    # motor mode and supply voltage: given once, kept until they change; the spare slots 29..34 stay zero
    mode = np.ones(29, dtype=np.uint8)
    mode[[0, 7]] = 0
    packer.pack(q, q, q, np.array([1, 0, 0, 0]), np.ones(3), np.ones(3), np.zeros(3), 43, motor_mode=mode, vol=52.5)
    packer.pack(q, q, q, np.array([1, 0, 0, 0]), np.ones(3), np.ones(3), np.zeros(3), 44)
    decoded = LowState_.deserialize(packer.frame_bytes())
    assert [m.mode for m in decoded.motor_state] == [0, 1, 1, 1, 1, 1, 1, 0] + [1] * 21 + [0] * 6
    assert [m.vol for m in decoded.motor_state] == [52.5] * 29 + [0.0] * 6
    assert decoded.crc == CRC().Crc(decoded)


# --- pacing --------------------------------------------------------------------------------------


class FakeWall:
    def __init__(self) -> None:
        self.now = 0.0
        self.slept: list[float] = []

    def clock(self) -> float:
        return self.now

    def sleep(self, s: float) -> None:
        self.slept.append(s)
        self.now += s


def test_pacer_holds_speed_and_does_not_sprint_after_lag() -> None:
    wall = FakeWall()
    pacer = Pacer(2.0, clock=wall.clock, sleep=wall.sleep)
    pacer.pace(0.0)
    pacer.pace(1.0)  # 1 s of sim at 2x: 0.5 s of wall
    assert wall.now == pytest.approx(0.5)
    wall.now += 10.0  # the sim stalled
    pacer.pace(1.002)
    pacer.pace(1.2)
    assert wall.now == pytest.approx(10.5 + 0.099)
    fast = Pacer(0.0, clock=wall.clock, sleep=wall.sleep)
    fast.pace(0.0)
    fast.pace(100.0)
    assert wall.now == pytest.approx(10.599)


def test_rate_meter() -> None:
    wall = FakeWall()
    meter = RateMeter(1.0, clock=wall.clock)
    for k in range(5):
        meter.update(3.0 * k)
        wall.now += 1.0
    assert meter.real_time_factor == pytest.approx(3.0) and meter.mean_real_time_factor == pytest.approx(3.0)


# --- ROS parameters ------------------------------------------------------------------------------


def test_bridge_node_parameters_validate_and_forward() -> None:
    import rclpy
    from rclpy.parameter import Parameter

    from g1_sim.bridge.ros_face import BridgeNode

    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        node = BridgeNode(overrides={"speed": 3.0, "dds_domain": 7}, context=context)
        p = node.params()
        assert (p.network_interface, p.dds_domain, p.speed, p.faults, p.publish_ros) == ("lo", 7, 3.0, "", True)
        faults = Faults()
        speeds: list[float] = []
        node.on_faults = faults.set_json
        node.on_speed = speeds.append
        assert node.set_parameters([Parameter("faults", value='{"drop": [7101]}')])[0].successful
        bad = node.set_parameters([Parameter("faults", value='{"drop": 7101}')])[0]
        assert not bad.successful and "drop must be a list" in bad.reason
        assert faults.drops(7101) and node.get_parameter("faults").value == '{"drop": [7101]}'
        assert not node.set_parameters([Parameter("speed", value=-1.0)])[0].successful
        assert node.set_parameters([Parameter("speed", value=0.0)])[0].successful and speeds == [0.0]
        assert not node.set_parameters([Parameter("dds_domain", value=3)])[0].successful  # read-only
        assert node.set_parameters([Parameter("publish_ros", value=False)])[0].successful and not node.publish_ros
        node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)


def test_cli_gantry_and_soc_reach_the_bridge() -> None:
    from g1_sim.bridge.main import _overrides, parse_cli

    args = parse_cli(["--gantry", "--soc", "35"])
    assert _overrides(args)["gantry"] is True and args.soc == 35.0
    assert "gantry" not in _overrides(parse_cli([])) and parse_cli([]).soc == 90.0
    with pytest.raises(SystemExit):
        parse_cli(["--soc", "120"])


class _SteppingRobot:
    """Changes its fsm_mode inside ``step``, as a get-up standing still or a fall does in the sim's loop."""

    dt = 0.002

    def __init__(self) -> None:
        self.lock = threading.RLock()
        self.time = 0.0
        self.fsm_id = 702
        self._mode = 1
        self._steps = 0

    def step(self, n: int = 1) -> None:
        with self.lock:
            self._steps += n
            self.time += n * self.dt
            if self._steps % 7 == 0:  # not a multiple of any publishing period: changes land between frames
                self._mode ^= 1

    def sport_state(self) -> tuple[int, int]:
        with self.lock:
            return (self.fsm_id, self._mode)

    def check_mode(self) -> tuple[str, str]:
        return ("normal", "ai")

    def lowstate(self) -> None: ...
    def torso_imu(self) -> None: ...
    def sport_active(self) -> bool:
        return False
    def odometry(self) -> None: ...
    def arm_task(self) -> tuple[int, float]:
        return (0, 0.0)
    def base_pose(self) -> None: ...
    def body(self) -> BodySnapshot:
        return BodySnapshot(np.full(29, 30.0), np.full(29, 30.0), reading_at(90.0, 100.0), frozenset())


class _SportFrames:
    """Publishes nothing; for every rt/sportmodestate frame, keeps what it shows and the record's last state then."""

    def __init__(self, record: Path) -> None:
        self.record = record
        self.seen: list[tuple[tuple[int, int], tuple[int, int] | None]] = []

    def publish_sportmodestate(self, fsm_id: int, fsm_mode: int, task_id: int = 0, task_time: float = 0.0) -> None:
        states = [json.loads(line) for line in self.record.read_text().splitlines()]
        last = [(e["fsm"], e["fsm_mode"]) for e in states if e["k"] == "state"][-1:]
        self.seen.append(((fsm_id, fsm_mode), last[0] if last else None))

    def wants_lowstate(self, **_: Any) -> bool:
        return True

    def wants_secondary_imu(self) -> bool:
        return True

    def wants_odom(self, **_: Any) -> bool:
        return True

    def count_unread(self, *_: Any, **__: Any) -> None: ...
    def publish_lowstate(self, *_: Any, **__: Any) -> None: ...
    def publish_secondary_imu(self, *_: Any) -> None: ...
    def publish_odom(self, *_: Any, **__: Any) -> None: ...
    def publish_bmsstate(self, *_: Any) -> None: ...


def test_a_state_is_on_the_record_before_the_sportmodestate_frame_that_shows_it(tmp_path: Path) -> None:
    """A client answered on a frame (a get-up answered once 702 shows standing) must find the state on the
    record: the frame's state is read and recorded in one hold of the robot's lock, before it is published."""
    from g1_sim.bridge.record import Recorder, record_state
    from g1_sim.bridge.sim_loop import SimLoop

    robot, path = _SteppingRobot(), tmp_path / "record.jsonl"
    recorder, frames = Recorder(str(path)), _SportFrames(path)
    loop = SimLoop(robot, frames, Faults(), Pacer(0.0),  # type: ignore[arg-type]
                   sport_state=lambda: record_state(recorder, robot))
    loop.start()
    try:
        deadline = time.monotonic() + 10.0
        while len(frames.seen) < 40 and time.monotonic() < deadline and loop.running:
            time.sleep(0.01)
    finally:
        loop.stop()
        recorder.close()
    assert loop.error is None, loop.error
    assert len(frames.seen) >= 40
    assert {shown[1] for shown, _ in frames.seen} == {0, 1}, "the robot's state never changed between frames"
    assert all(shown == recorded for shown, recorded in frames.seen), frames.seen


class _Readers:
    """Publishes nothing; 500 Hz readers matched or not, as the test sets them."""

    def __init__(self) -> None:
        self.fast = {"lowstate": False, "secondary_imu": False, "odom": False}

    def publish_sportmodestate(self, *_: Any, **__: Any) -> None: ...
    def count_unread(self, *_: Any, **__: Any) -> None: ...
    def publish_lowstate(self, *_: Any, **__: Any) -> None: ...
    def publish_secondary_imu(self, *_: Any) -> None: ...
    def publish_odom(self, *_: Any, **__: Any) -> None: ...
    def publish_bmsstate(self, *_: Any) -> None: ...

    def wants_lowstate(self, *, also_lf: bool = False) -> bool:
        return self.fast["lowstate"]

    def wants_secondary_imu(self) -> bool:
        return self.fast["secondary_imu"]

    def wants_odom(self, *, also_lf: bool = False) -> bool:
        return self.fast["odom"]


class _CountingPacer:
    """Notes the sim time of every pace() call; stops the loop after ``steps`` steps."""

    def __init__(self, stop_after: int, loop: list[Any]) -> None:
        self.paced: list[float] = []
        self._stop_after = stop_after
        self._loop = loop

    def pace(self, sim_time: float) -> None:
        self.paced.append(round(sim_time / 0.002))
        if self.paced[-1] >= self._stop_after:
            self._loop[0].stop()  # from inside the loop: it ends after this step


@pytest.mark.parametrize("why", ["nothing", "lowstate", "secondary_imu", "odom", "frames"])
def test_the_loop_keeps_the_2_ms_cycle_step_by_step_only_while_a_500_hz_stream_is_read_or_frames_come(
        why: str) -> None:
    from g1_sim.bridge.sim_loop import IDLE_BATCH_STEPS, SimLoop

    readers = _Readers()
    if why in readers.fast:
        readers.fast[why] = True
    holder: list[Any] = []
    pacer = _CountingPacer(50, holder)
    loop = SimLoop(_SteppingRobot(), readers, Faults(), pacer,  # type: ignore[arg-type]
                   frames_within=lambda _s: why == "frames")
    holder.append(loop)
    loop._loop()
    if why == "nothing":  # the steps all happen; the loop sleeps once per batch of them
        assert pacer.paced == list(range(IDLE_BATCH_STEPS, 51, IDLE_BATCH_STEPS))
    else:
        assert pacer.paced == list(range(1, 51))
