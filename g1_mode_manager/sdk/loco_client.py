"""The G1's full loco API ("sport" service) over the SDK's RPC client, raising RobotError on every failure.

The SDK's Python ``LocoClient`` drops error codes, lacks several calls and starts walking with fsm 200
(older firmware); this one registers every api id, sends Start as 500, and returns data or raises.
"""

from __future__ import annotations

import json
import math

from g1_mode_manager.protocol import api_ids as api
from g1_mode_manager.protocol.fsm import SPEED_MODE_MAX_SPEED, BalanceMode, FsmId, InternalCtrl
from g1_mode_manager.sdk.rpc_client import PendingCall, RpcClient, parse_number

#: The e-stop's first packet's parameter, encoded once.
_DAMP_TEXT = json.dumps({"data": int(FsmId.DAMP)})


def _finite(name: str, **values: float) -> None:
    for key, value in values.items():
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
            raise ValueError(f"{name}: {key} must be a finite number, got {value!r}")


def _velocity(vx: float, vy: float, wz: float, duration: float) -> dict[str, object]:
    _finite("SetVelocity", vx=vx, vy=vy, wz=wz, duration=duration)
    if duration < 0:
        raise ValueError(f"SetVelocity: duration must be >= 0, got {duration!r}")
    return {"velocity": [float(vx), float(vy), float(wz)], "duration": float(duration)}


class LocoClient(RpcClient):
    """Loco calls of the G1. Each takes an optional ``timeout_s`` (default: the client's)."""

    def __init__(self, timeout_s: float = 1.0) -> None:
        super().__init__(api.LOCO_SERVICE, api.LOCO_API_VERSION, api.LOCO_GET_APIS + api.LOCO_SET_APIS, timeout_s)

    # --- getters --------------------------------------------------------------------------------
    def get_fsm_id(self, *, timeout_s: float | None = None) -> int:
        return parse_number("GetFsmId", self.call("GetFsmId", api.LOCO_GET_FSM_ID, timeout_s=timeout_s), int)

    def get_fsm_mode(self, *, timeout_s: float | None = None) -> int:
        return parse_number("GetFsmMode", self.call("GetFsmMode", api.LOCO_GET_FSM_MODE, timeout_s=timeout_s), int)

    def get_balance_mode(self, *, timeout_s: float | None = None) -> int:
        data = self.call("GetBalanceMode", api.LOCO_GET_BALANCE_MODE, timeout_s=timeout_s)
        return parse_number("GetBalanceMode", data, int)

    def get_stand_height(self, *, timeout_s: float | None = None) -> float:
        data = self.call("GetStandHeight", api.LOCO_GET_STAND_HEIGHT, timeout_s=timeout_s)
        return parse_number("GetStandHeight", data, float)

    def get_swing_height(self, *, timeout_s: float | None = None) -> float:
        data = self.call("GetSwingHeight", api.LOCO_GET_SWING_HEIGHT, timeout_s=timeout_s)
        return parse_number("GetSwingHeight", data, float)

    # --- setters --------------------------------------------------------------------------------
    def set_fsm_id(self, fsm_id: int, *, timeout_s: float | None = None) -> None:
        self.call("SetFsmId", api.LOCO_SET_FSM_ID, {"data": int(fsm_id)}, timeout_s=timeout_s)

    def set_balance_mode(self, mode: int, *, timeout_s: float | None = None) -> None:
        self.call("SetBalanceMode", api.LOCO_SET_BALANCE_MODE, {"data": int(mode)}, timeout_s=timeout_s)

    def set_stand_height(self, height: float, *, timeout_s: float | None = None) -> None:
        _finite("SetStandHeight", height=height)
        self.call("SetStandHeight", api.LOCO_SET_STAND_HEIGHT, {"data": float(height)}, timeout_s=timeout_s)

    def set_swing_height(self, height: float, *, timeout_s: float | None = None) -> None:
        _finite("SetSwingHeight", height=height)
        self.call("SetSwingHeight", api.LOCO_SET_SWING_HEIGHT, {"data": float(height)}, timeout_s=timeout_s)

    def set_velocity(self, vx: float, vy: float, wz: float, duration: float = api.MOVE_DURATION_S, *,
                     timeout_s: float | None = None) -> None:
        """SetVelocity: body velocity (m/s, m/s, rad/s) held for ``duration`` s. NaN/inf raise ValueError."""
        self.call("SetVelocity", api.LOCO_SET_VELOCITY, _velocity(vx, vy, wz, duration), timeout_s=timeout_s)

    def send_velocity(self, vx: float, vy: float, wz: float, duration: float = api.MOVE_DURATION_S, *,
                      timeout_s: float | None = None) -> PendingCall:
        """SetVelocity written at once, its reply awaited by the returned call's ``wait()``; raises
        RobotError (3102) at once if no server is matched (nothing waits for one)."""
        return self.send("SetVelocity", api.LOCO_SET_VELOCITY, _velocity(vx, vy, wz, duration), timeout_s=timeout_s)

    def set_arm_task(self, task_id: int, *, timeout_s: float | None = None) -> None:
        """SetArmTask: a built-in arm motion (``api.ARM_TASK_*``: wave, wave and turn, shake hand stages)."""
        self.call("SetArmTask", api.LOCO_SET_ARM_TASK, {"data": int(task_id)}, timeout_s=timeout_s)

    def set_speed_mode(self, mode: int, *, timeout_s: float | None = None) -> None:
        if int(mode) not in SPEED_MODE_MAX_SPEED:
            raise ValueError(f"SetSpeedMode: mode must be one of {sorted(SPEED_MODE_MAX_SPEED)}, got {mode!r}")
        self.call("SetSpeedMode", api.LOCO_SET_SPEED_MODE, {"data": int(mode)}, timeout_s=timeout_s)

    def switch_to_user_ctrl(self, *, timeout_s: float | None = None) -> None:
        """SwitchToUserCtrl (7110, newer firmware): the joints then follow rt/user_lowcmd. Raises RobotError with
        the robot's code (3203 where the firmware lacks it)."""
        self.call("SwitchToUserCtrl", api.LOCO_SWITCH_TO_USER_CTRL, {"data": False}, timeout_s=timeout_s)

    def switch_to_internal_ctrl(self, target: InternalCtrl, *, timeout_s: float | None = None) -> None:
        """SwitchToInternalCtrl (7111): LAST, PASSIVE (damping) or WALKRUN takes the robot back."""
        self.call("SwitchToInternalCtrl", api.LOCO_SWITCH_TO_INTERNAL_CTRL, {"data": int(InternalCtrl(target))},
                  timeout_s=timeout_s)

    # --- high-level helpers, as the SDK's LocoClient names them --------------------------------------
    def damp(self, *, timeout_s: float | None = None) -> None:
        self.set_fsm_id(FsmId.DAMP, timeout_s=timeout_s)

    def damp_no_reply(self) -> None:
        """SetFsmId(1) flagged no-reply: sent at once, nothing awaited (the e-stop's first shot)."""
        self.call_no_reply("SetFsmId", api.LOCO_SET_FSM_ID, text=_DAMP_TEXT)  # made once: no json.dumps on the e-stop's path

    def zero_torque(self, *, timeout_s: float | None = None) -> None:
        self.set_fsm_id(FsmId.ZERO_TORQUE, timeout_s=timeout_s)

    def squat(self, *, timeout_s: float | None = None) -> None:
        self.set_fsm_id(FsmId.SQUAT, timeout_s=timeout_s)

    def sit(self, *, timeout_s: float | None = None) -> None:
        self.set_fsm_id(FsmId.SIT, timeout_s=timeout_s)

    def stand_up(self, *, timeout_s: float | None = None) -> None:
        """Lock standing (fsm 4); the robot needs a Damp first."""
        self.set_fsm_id(FsmId.STAND_UP, timeout_s=timeout_s)

    def start(self, *, timeout_s: float | None = None) -> None:
        """Walk mode, fsm 500 (current firmware; the SDK fork sends 200)."""
        self.set_fsm_id(FsmId.START, timeout_s=timeout_s)

    def balance_stand(self, *, timeout_s: float | None = None) -> None:
        self.set_balance_mode(BalanceMode.BALANCE_STAND, timeout_s=timeout_s)

    def continuous_gait(self, flag: bool, *, timeout_s: float | None = None) -> None:
        mode = BalanceMode.CONTINUOUS_GAIT if flag else BalanceMode.BALANCE_STAND
        self.set_balance_mode(mode, timeout_s=timeout_s)

    def move(self, vx: float, vy: float, wz: float, continuous: bool = False, *,
             timeout_s: float | None = None) -> None:
        """SetVelocity for 1 s, or for 10 days when ``continuous`` (until the next command)."""
        duration = api.MOVE_CONTINUOUS_DURATION_S if continuous else api.MOVE_DURATION_S
        self.set_velocity(vx, vy, wz, duration, timeout_s=timeout_s)

    def stop_move(self, *, timeout_s: float | None = None) -> None:
        self.set_velocity(0.0, 0.0, 0.0, timeout_s=timeout_s)

    def high_stand(self, *, timeout_s: float | None = None) -> None:
        """SetStandHeight(0xFFFFFFFF), sent as the integer the SDK sends: the highest stand."""
        self.call("SetStandHeight", api.LOCO_SET_STAND_HEIGHT, {"data": api.STAND_HEIGHT_HIGH}, timeout_s=timeout_s)

    def low_stand(self, *, timeout_s: float | None = None) -> None:
        """SetStandHeight(0): the lowest stand."""
        self.call("SetStandHeight", api.LOCO_SET_STAND_HEIGHT, {"data": api.STAND_HEIGHT_LOW}, timeout_s=timeout_s)

    def wave_hand(self, turn: bool = False, *, timeout_s: float | None = None) -> None:
        self.set_arm_task(api.ARM_TASK_WAVE_AND_TURN if turn else api.ARM_TASK_WAVE, timeout_s=timeout_s)

    def shake_hand(self, stage: int, *, timeout_s: float | None = None) -> None:
        """Stage 0 holds the hand out (task 2), stage 1 withdraws it (task 3); the SDK's toggling form
        (no stage) keeps state in the client, which a restart would lose, so the stage is explicit."""
        stages = api.ARM_TASK_SHAKE_HAND_STAGES
        if stage not in range(len(stages)):
            raise ValueError(f"ShakeHand: stage must be 0 or 1, got {stage!r}")
        self.set_arm_task(stages[stage], timeout_s=timeout_s)
