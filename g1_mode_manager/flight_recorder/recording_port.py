"""The robot port with every call and frame also put on the flight ring: the one place all robot traffic passes.

A call is recorded as its request before it is written and as its answer (code, value, latency) when it returns,
so a call still waiting when an incident is written shows as a request without an answer. DampNoReply, the
e-stop's first packet, is recorded after it left, never in front of it. Frames are recorded at most once per
``frame_period_s`` per topic, after they were written, packed into an array. Each odometry sample (the robot's
estimate of its velocity) is recorded once, when a part of the node first reads it: the odom publisher at
odom_rate_hz, the walk judge at each acknowledged Move, the autonomy's conditions.
Everything else passes through unchanged.
"""

from __future__ import annotations

import itertools
import threading
import time
from collections.abc import Callable, Sequence
from typing import Final, TypeVar

from g1_mode_manager.core.port import (
    MotorCommand,
    OdomSample,
    PendingReply,
    RobotError,
    RobotPort,
    SportState,
    StateSample,
    VoicePort,
)
from g1_mode_manager.core.recorder.events import Event, FrameSent, OdometrySeen, Phase, RobotCall, Verb
from g1_mode_manager.core.user_ctrl import UserCtrlPort
from g1_mode_manager.protocol import api_ids as api
from g1_mode_manager.protocol.fsm import InternalCtrl

R = TypeVar("R")

CONNECT: Final = Verb("Connect", 0)
CHECK_MODE: Final = Verb("CheckMode", api.MS_CHECK_MODE)
SELECT_MODE: Final = Verb("SelectMode", api.MS_SELECT_MODE, ("name",))
RELEASE_MODE: Final = Verb("ReleaseMode", api.MS_RELEASE_MODE)
DAMP: Final = Verb("Damp", api.LOCO_SET_FSM_ID)
DAMP_NO_REPLY: Final = Verb("DampNoReply", api.LOCO_SET_FSM_ID)
SET_FSM_ID: Final = Verb("SetFsmId", api.LOCO_SET_FSM_ID, ("fsm_id",))
GET_FSM_ID: Final = Verb("GetFsmId", api.LOCO_GET_FSM_ID)
GET_FSM_MODE: Final = Verb("GetFsmMode", api.LOCO_GET_FSM_MODE)
GET_BALANCE_MODE: Final = Verb("GetBalanceMode", api.LOCO_GET_BALANCE_MODE)
GET_STAND_HEIGHT: Final = Verb("GetStandHeight", api.LOCO_GET_STAND_HEIGHT)
SET_BALANCE_MODE: Final = Verb("SetBalanceMode", api.LOCO_SET_BALANCE_MODE, ("mode",))
SET_SPEED_MODE: Final = Verb("SetSpeedMode", api.LOCO_SET_SPEED_MODE, ("mode",))
#: A Move; all zero, a StopMove.
SET_VELOCITY: Final = Verb("SetVelocity", api.LOCO_SET_VELOCITY, ("vx", "vy", "wz", "duration_s"))
HIGH_STAND: Final = Verb("HighStand", api.LOCO_SET_STAND_HEIGHT)
LOW_STAND: Final = Verb("LowStand", api.LOCO_SET_STAND_HEIGHT)
SET_ARM_TASK: Final = Verb("SetArmTask", api.LOCO_SET_ARM_TASK, ("task_id",))
SWITCH_TO_USER_CTRL: Final = Verb("SwitchToUserCtrl", api.LOCO_SWITCH_TO_USER_CTRL)
SWITCH_TO_INTERNAL_CTRL: Final = Verb("SwitchToInternalCtrl", api.LOCO_SWITCH_TO_INTERNAL_CTRL, ("target",))


class RecordingPort:
    """A RobotPort around ``port``; ``add`` puts an event on the flight ring (FlightRing.add)."""

    def __init__(self, port: RobotPort, add: Callable[[Event], None], *, frame_period_s: float,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.inner = port
        self._add = add
        self._frame_period_s = frame_period_s
        self._clock = clock
        self._ids = itertools.count(1)
        self._last_frame: dict[str, float] = {}  # topic -> when its last recorded frame was written
        self._odom_lock = threading.Lock()  # several threads read the odometry: a sample is recorded once
        self._odom_count = 0  # the last odometry sample recorded (OdomSample.count)

    # --- recording ---------------------------------------------------------------------------------
    def _call(self, verb: Verb, args: tuple[object, ...], call: Callable[[], R]) -> R:
        call_id = next(self._ids)
        self._add(RobotCall(call_id, verb, args, Phase.REQUEST))
        start = self._clock()
        try:
            value = call()
        except RobotError as exc:
            self._answer(call_id, verb, args, start, code=exc.code, error=str(exc))
            raise
        except Exception as exc:
            self._answer(call_id, verb, args, start, code=-1, error=f"{type(exc).__name__}: {exc}")
            raise
        self._answer(call_id, verb, args, start, answer=value)
        return value

    def _answer(self, call_id: int, verb: Verb, args: tuple[object, ...], start: float, *, code: int = api.OK,
                answer: object = None, error: str = "") -> None:
        self._add(RobotCall(call_id, verb, args, Phase.ANSWER, code, answer, self._clock() - start, error))

    def _frame(self, topic: str, commands: Sequence[MotorCommand], weight: float | None = None) -> None:
        now = self._clock()
        if now - self._last_frame.get(topic, float("-inf")) < self._frame_period_s:
            return
        self._last_frame[topic] = now
        self._add(FrameSent.of(topic, commands, weight))

    # --- mode services -----------------------------------------------------------------------------
    def connect(self) -> None:
        self._call(CONNECT, (), self.inner.connect)

    def check_mode(self, timeout_s: float | None = None) -> str:
        return self._call(CHECK_MODE, (), lambda: self.inner.check_mode(timeout_s))

    def select_mode(self, name: str, timeout_s: float | None = None) -> None:
        self._call(SELECT_MODE, (name,), lambda: self.inner.select_mode(name, timeout_s))

    def release_mode(self, timeout_s: float | None = None) -> None:
        self._call(RELEASE_MODE, (), lambda: self.inner.release_mode(timeout_s))

    def damp(self, timeout_s: float | None = None) -> None:
        self._call(DAMP, (), lambda: self.inner.damp(timeout_s))

    def damp_no_reply(self) -> None:
        try:
            self.inner.damp_no_reply()
        except RobotError as exc:
            self._add(RobotCall(next(self._ids), DAMP_NO_REPLY, (), Phase.NO_REPLY, exc.code, error=str(exc)))
            raise
        self._add(RobotCall(next(self._ids), DAMP_NO_REPLY, (), Phase.NO_REPLY))

    def get_fsm_id(self, timeout_s: float | None = None) -> int:
        return self._call(GET_FSM_ID, (), lambda: self.inner.get_fsm_id(timeout_s))

    # --- loco ----------------------------------------------------------------------------------------
    def set_fsm_id(self, fsm_id: int) -> None:
        self._call(SET_FSM_ID, (fsm_id,), lambda: self.inner.set_fsm_id(fsm_id))

    def get_fsm_mode(self) -> int:
        return self._call(GET_FSM_MODE, (), self.inner.get_fsm_mode)

    def get_balance_mode(self, timeout_s: float | None = None) -> int:
        return self._call(GET_BALANCE_MODE, (), lambda: self.inner.get_balance_mode(timeout_s))

    def get_stand_height(self, timeout_s: float | None = None) -> float:
        return self._call(GET_STAND_HEIGHT, (), lambda: self.inner.get_stand_height(timeout_s))

    def set_balance_mode(self, mode: int) -> None:
        self._call(SET_BALANCE_MODE, (mode,), lambda: self.inner.set_balance_mode(mode))

    def set_speed_mode(self, mode: int) -> None:
        self._call(SET_SPEED_MODE, (mode,), lambda: self.inner.set_speed_mode(mode))

    def set_velocity(self, vx: float, vy: float, wz: float, duration_s: float) -> None:
        self._call(SET_VELOCITY, (vx, vy, wz, duration_s), lambda: self.inner.set_velocity(vx, vy, wz, duration_s))

    def send_velocity(self, vx: float, vy: float, wz: float, duration_s: float) -> PendingReply:
        """The request now, its answer when the caller's ``wait()`` returns (outside the forward gate)."""
        args = (vx, vy, wz, duration_s)
        call_id = next(self._ids)
        self._add(RobotCall(call_id, SET_VELOCITY, args, Phase.REQUEST))
        start = self._clock()
        try:
            reply = self.inner.send_velocity(vx, vy, wz, duration_s)
        except RobotError as exc:
            self._answer(call_id, SET_VELOCITY, args, start, code=exc.code, error=str(exc))
            raise
        return _RecordedReply(reply, lambda **answer: self._answer(call_id, SET_VELOCITY, args, start, **answer))

    def high_stand(self) -> None:
        self._call(HIGH_STAND, (), self.inner.high_stand)

    def low_stand(self) -> None:
        self._call(LOW_STAND, (), self.inner.low_stand)

    def set_arm_task(self, task_id: int) -> None:
        self._call(SET_ARM_TASK, (task_id,), lambda: self.inner.set_arm_task(task_id))

    # --- streams -------------------------------------------------------------------------------------
    def write_arm_sdk(self, targets: Sequence[MotorCommand], weight: float) -> None:
        self.inner.write_arm_sdk(targets, weight)
        self._frame("arm_sdk", targets, weight)

    def write_lowcmd(self, commands: Sequence[MotorCommand]) -> None:
        self.inner.write_lowcmd(commands)
        self._frame("lowcmd", commands)

    def sport_state(self) -> SportState | None:
        return self.inner.sport_state()

    def set_sport_state_listener(self, listener: Callable[[SportState], None] | None) -> None:
        self.inner.set_sport_state_listener(listener)

    def lowstate_age_s(self) -> float | None:
        return self.inner.lowstate_age_s()

    def joint_positions(self) -> Sequence[float] | None:
        return self.inner.joint_positions()

    def state_sample(self) -> StateSample | None:
        return self.inner.state_sample()

    def battery_soc(self) -> tuple[float, float] | None:
        return self.inner.battery_soc()

    def odometry(self) -> OdomSample | None:
        sample = self.inner.odometry()
        if sample is not None and sample.count > self._odom_count:
            with self._odom_lock:  # counts only grow: a sample read late by a slower reader is not kept again
                new = sample.count > self._odom_count
                self._odom_count = max(sample.count, self._odom_count)
            if new:
                f = sample.fields
                self._add(OdometrySeen(f.velocity, f.yaw_speed, f.quaternion))
        return sample

    def lowstate_restarts(self) -> int:
        return self.inner.lowstate_restarts()

    def set_lowstate_wanted(self, wanted: bool) -> None:
        self.inner.set_lowstate_wanted(wanted)

    def lowstate_receiving(self) -> bool:
        return self.inner.lowstate_receiving()

    def lowstate_data(self) -> tuple[bytes, int] | None:
        return self.inner.lowstate_data()

    # --- signalling ----------------------------------------------------------------------------------
    def voice(self, timeout_s: float = 0.5) -> VoicePort | None:
        return self.inner.voice(timeout_s)

    def close(self) -> None:
        self.inner.close()


class RecordingUserCtrlPort(RecordingPort):
    """The same around a port with the user_ctrl path's calls (core.user_ctrl.UserCtrlPort)."""

    inner: UserCtrlPort  # type: ignore[assignment]

    def switch_to_user_ctrl(self, timeout_s: float | None = None) -> None:
        self._call(SWITCH_TO_USER_CTRL, (), lambda: self.inner.switch_to_user_ctrl(timeout_s))

    def switch_to_internal_ctrl(self, target: InternalCtrl, timeout_s: float | None = None) -> None:
        self._call(SWITCH_TO_INTERNAL_CTRL, (int(target),),
                   lambda: self.inner.switch_to_internal_ctrl(target, timeout_s))

    def write_user_lowcmd(self, commands: Sequence[MotorCommand]) -> None:
        self.inner.write_user_lowcmd(commands)
        self._frame("user_lowcmd", commands)

    def attitude(self, max_age_s: float) -> tuple[float, float] | None:
        return self.inner.attitude(max_age_s)

    def joint_speed_max(self) -> float | None:
        return self.inner.joint_speed_max()


def recording_port(port: RobotPort, add: Callable[[Event], None], *, frame_period_s: float,
                   clock: Callable[[], float] = time.monotonic) -> RecordingPort:
    """``port`` recorded; with the user_ctrl path's calls exactly when ``port`` has them, so the mode machine's
    check that the port can take that path still holds."""
    kind = RecordingUserCtrlPort if isinstance(port, UserCtrlPort) else RecordingPort
    return kind(port, add, frame_period_s=frame_period_s, clock=clock)


class _RecordedReply:
    """A Move's pending reply whose ``wait`` also records the answer."""

    __slots__ = ("_answer", "_reply")

    def __init__(self, reply: PendingReply, answer: Callable[..., None]) -> None:
        self._reply = reply
        self._answer = answer

    def wait(self) -> None:
        try:
            self._reply.wait()
        except RobotError as exc:
            self._answer(code=exc.code, error=str(exc))
            raise
        self._answer()
