"""The fake G1 extended to the full RobotPort: loco calls, arm_sdk / lowcmd frames, robot state.

For unit tests of the relays and the node's plumbing only; end-to-end tests use the real sim bridge.
"""

from __future__ import annotations

import dataclasses
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from fakes.fake_user_ctrl import UserCtrlRobot
from g1_mode_manager.core.port import MotorCommand, OdomSample, RobotError, SportState, StateSample, VoicePort
from g1_mode_manager.protocol import api_ids
from g1_mode_manager.protocol.lowstate_fields import decode_body_fields
from g1_mode_manager.protocol.motors import NUM_JOINTS


@dataclass(frozen=True)
class Sent:
    name: str
    args: tuple
    at: float


class FakeReply:
    """A Move's reply: waits for its hold event, if any, then raises the injected code, if any."""

    def __init__(self, name: str, code: int | None, hold: threading.Event | None) -> None:
        self._name = name
        self._code = code
        self._hold = hold

    def wait(self) -> None:
        if self._hold is not None:
            self._hold.wait(10.0)
        if self._code is not None:
            raise RobotError(self._name, self._code, "injected")


class FakeRobotPort(UserCtrlRobot):
    """Records every stream call with its time; state (ages, fsm) is set by the test."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self._stream_lock = threading.Lock()
        self.sent: list[Sent] = []
        self.lowstate_age: float | None = 0.01
        self.sport: SportState | None = SportState(fsm_id=4, fsm_mode=0, task_id=0, task_time=0.0, age_s=0.01)
        self.positions: list[float] | None = [0.1 * i for i in range(NUM_JOINTS)]
        self.fail_stream: dict[str, int] = {}  # name -> error code for every call
        self.listener: Callable[[SportState], None] | None = None
        self.restarts = 0
        self.lowstate_wanted = True
        self.state: bytes | None = None  # a serialised LowState_ for the body checks
        self.state_age = 0.002
        self.soc: float | None = None
        #: An event: Move replies written while it is in place wait until it is set (at most 10 s).
        self.move_reply_hold: threading.Event | None = None
        self.lowstate_sample: tuple[bytes, int] | None = None  # raw rt/lowstate: none unless a test sets it
        self.voice_port: VoicePort | None = None  # no voice service unless a test sets one
        # What the loco calls change, so that their outcomes can be read back (as on the robot):
        self.ignored_fsm_ids: set[int] = set()  # SetFsmId of these answers 0 and does nothing (firmware quirk)
        self.balance_mode = 0
        self.stand_height = 0.75
        self.outcomes = True  # False: every loco call answers 0 and changes nothing
        self.odom: OdomSample | None = None  # rt/lf/odommodestate: none unless a test sets it

    def _record(self, name: str, *args: object) -> None:
        code = self.fail_stream.get(name)
        with self._stream_lock:
            self.sent.append(Sent(name, args, time.monotonic()))
        if code is not None:
            raise RobotError(name, code, "injected")

    def stream(self, name: str) -> list[Sent]:
        with self._stream_lock:
            return [s for s in self.sent if s.name == name]

    def set_fsm_id(self, fsm_id: int) -> None:
        self._record("set_fsm_id", fsm_id)
        if self.outcomes and fsm_id not in self.ignored_fsm_ids and self.sport is not None:
            self.sport = dataclasses.replace(self.sport, fsm_id=fsm_id, fsm_mode=0, task_id=0, task_time=0.0)

    def get_balance_mode(self, timeout_s: float | None = None) -> int:
        return self.balance_mode

    def get_stand_height(self, timeout_s: float | None = None) -> float:
        return self.stand_height


    def get_fsm_mode(self) -> int:
        return self.sport.fsm_mode if self.sport else 0

    def set_balance_mode(self, mode: int) -> None:
        self._record("set_balance_mode", mode)
        if self.outcomes:
            self.balance_mode = mode

    def set_speed_mode(self, mode: int) -> None:
        self._record("set_speed_mode", mode)

    def high_stand(self) -> None:
        self._record("high_stand")
        if self.outcomes:
            self.stand_height = 0.78

    def low_stand(self) -> None:
        self._record("low_stand")
        if self.outcomes:
            self.stand_height = 0.6

    def set_arm_task(self, task_id: int) -> None:
        self._record("set_arm_task", task_id)
        if self.outcomes and self.sport is not None:  # the motion has just begun
            self.sport = dataclasses.replace(self.sport, task_id=task_id, task_time=0.001)

    def set_velocity(self, vx: float, vy: float, wz: float, duration_s: float) -> None:
        self._record("set_velocity", vx, vy, wz, duration_s)

    def send_velocity(self, vx: float, vy: float, wz: float, duration_s: float) -> FakeReply:
        """Recorded as set_velocity when written; an injected failure and ``move_reply_hold`` come with the reply."""
        code = self.fail_stream.get("set_velocity")
        with self._stream_lock:
            self.sent.append(Sent("set_velocity", (vx, vy, wz, duration_s), time.monotonic()))
        return FakeReply("set_velocity", code, self.move_reply_hold)

    def write_arm_sdk(self, targets: Sequence[MotorCommand], weight: float) -> None:
        assert len(targets) == 17
        self._record("write_arm_sdk", tuple(targets), weight)

    def write_lowcmd(self, commands: Sequence[MotorCommand]) -> None:
        assert len(commands) == NUM_JOINTS
        if self.lowstate_age is None:
            raise RobotError("write_lowcmd", api_ids.ERR_UNKNOWN, "no rt/lowstate yet: mode_machine unknown")
        self._record("write_lowcmd", tuple(commands))

    def write_user_lowcmd(self, commands: Sequence[MotorCommand]) -> None:
        assert len(commands) == NUM_JOINTS
        if self.lowstate_age is None:
            raise RobotError("write_user_lowcmd", api_ids.ERR_UNKNOWN, "no rt/lowstate yet: mode_machine unknown")
        self._record("write_user_lowcmd", tuple(commands))
        super().write_user_lowcmd(commands)

    def sport_state(self) -> SportState | None:
        """The state the test set, except that a damping robot reports fsm 1 (as rt/sportmodestate does)."""
        if self.sport is not None and self.damped and self.service:
            return dataclasses.replace(self.sport, fsm_id=1, fsm_mode=0)
        return self.sport

    def set_sport_state_listener(self, listener: Callable[[SportState], None] | None) -> None:
        self.listener = listener

    def lowstate_age_s(self) -> float | None:
        return self.lowstate_age

    def joint_positions(self) -> Sequence[float] | None:
        return self.positions

    def close(self) -> None:
        self._record("close")

    def state_sample(self) -> StateSample | None:
        """The LowState_ a test set (``state``), aged ``state_age``; None unless a test sets one."""
        return None if self.state is None else StateSample(decode_body_fields(self.state), self.state_age, low_rate=False)

    def battery_soc(self) -> tuple[float, float] | None:
        return None if self.soc is None else (self.soc, 0.1)

    def odometry(self) -> OdomSample | None:
        return self.odom

    def lowstate_restarts(self) -> int:
        return self.restarts

    def set_lowstate_wanted(self, wanted: bool) -> None:
        self.lowstate_wanted = wanted

    def lowstate_receiving(self) -> bool:
        return self.lowstate_wanted

    def lowstate_data(self) -> tuple[bytes, int] | None:
        return self.lowstate_sample

    def voice(self, timeout_s: float = 0.5) -> VoicePort | None:
        return self.voice_port
