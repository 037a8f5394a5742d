"""The robot port: the only way the core reaches the robot.

The state machine needs only :class:`ModePort`. :class:`RobotPort` adds what the node relays
(loco commands, arm_sdk and lowcmd frames, robot state). Implementations: the Unitree SDK2 adapter
(``g1_mode_manager.sdk``) and a fake for unit tests. Every call blocks until the robot answered or
its timeout passed, and raises :class:`RobotError` on failure; none returns a silent error code.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

from g1_mode_manager.protocol.api_ids import (
    ERR_CLIENT_API_TIMEOUT,
    ERR_CLIENT_SEND,
    ERR_REFUSED_IN_STATE,
    describe_code,
)
from g1_mode_manager.protocol.body_fields import BodyFields
from g1_mode_manager.protocol.odom_fields import OdomFields


class RobotError(Exception):
    """A robot call failed: the call's name, the robot's return code, and why.

    Callers ask the error what the failure means for the robot (:attr:`maybe_delivered`,
    :attr:`not_sent`, :attr:`transport`) instead of knowing the SDK's return codes.
    """

    def __init__(self, call: str, code: int, detail: str = "") -> None:
        self.call = call
        self.code = code
        self.detail = detail
        text = f"{call} failed: {describe_code(code)}"
        super().__init__(f"{text}: {detail}" if detail else text)

    @property
    def not_sent(self) -> bool:
        """The request never left this process (no server matched): the robot cannot be acting on it."""
        return self.code == ERR_CLIENT_SEND

    @property
    def maybe_delivered(self) -> bool:
        """The request went out but its answer was lost (timeout): the robot may be acting on it."""
        return self.code == ERR_CLIENT_API_TIMEOUT

    @property
    def transport(self) -> bool:
        """Lost on the way (not sent, or the answer lost), not refused by the robot: sending again may work."""
        return self.not_sent or self.maybe_delivered

    @property
    def refused_in_state(self) -> bool:
        """The robot took the call and refused it in its current state (e.g. a Move to a damped robot)."""
        return self.code == ERR_REFUSED_IN_STATE


@runtime_checkable
class ModePort(Protocol):
    """Mode services and damping: what the mode state machine needs.

    ``timeout_s`` bounds one call (None: the port's default for that call); the e-stop passes short
    ones of its own so that a dead link cannot hold it for the length of a SelectMode.
    """

    def connect(self) -> None:
        """Initialise the SDK connection (DDS domain, clients). Idempotent."""

    def check_mode(self, timeout_s: float | None = None) -> str:
        """MotionSwitcher CheckMode: the active service's name, '' when released (debug mode)."""

    def select_mode(self, name: str, timeout_s: float | None = None) -> None:
        """MotionSwitcher SelectMode(name), e.g. 'ai'."""

    def release_mode(self, timeout_s: float | None = None) -> None:
        """MotionSwitcher ReleaseMode: the robot enters debug mode and goes limp."""

    def damp(self, timeout_s: float | None = None) -> None:
        """Loco SetFsmId(1), waiting for the robot's answer."""

    def damp_no_reply(self) -> None:
        """Loco SetFsmId(1) sent without waiting for an answer: the e-stop's first, fastest shot.

        Raises RobotError only if the request could not be sent at all.
        """

    def get_fsm_id(self, timeout_s: float | None = None) -> int:
        """Loco GetFsmId: the built-in controller's state (1 = damping); how an e-stop verifies itself."""


@dataclass(frozen=True)
class SportState:
    """The last rt/sportmodestate, with its age."""

    fsm_id: int
    fsm_mode: int
    task_id: int
    task_time: float
    age_s: float


@dataclass(frozen=True)
class MotorCommand:
    """One motor's command: tau + kp * (q - q_measured) + kd * (dq - dq_measured)."""

    q: float = 0.0
    dq: float = 0.0
    tau: float = 0.0
    kp: float = 0.0
    kd: float = 0.0


class PendingReply(Protocol):
    """A request already written; its reply still to come."""

    def wait(self) -> None:
        """Block until the robot answered or the call's timeout passed; raises RobotError on failure."""


class VoicePort(Protocol):
    """The part of the robot's voice service the head LED needs (sdk.voice_client.VoiceClient)."""

    def set_led(self, r: int, g: int, b: int) -> None: ...
    def tts(self, text: str) -> None: ...


@dataclass(frozen=True)
class StateSample:
    """The newest robot state sample: what the body checks read of its LowState_, and how old it is."""

    fields: BodyFields
    age_s: float
    low_rate: bool  # from rt/lf/lowstate (about 20 Hz), not rt/lowstate
    #: when the robot published it, this process's monotonic s (from its DDS source timestamp: exact where both
    #: share a clock, as on the sim; a robot's clock offset from this machine's adds to it); NaN: not known
    published_s: float = float("nan")


@dataclass(frozen=True)
class OdomSample:
    """The newest rt/lf/odommodestate (the robot's state estimate), its age and how many arrived so far."""

    fields: OdomFields
    age_s: float
    count: int


@runtime_checkable
class RobotPort(ModePort, Protocol):
    """Everything the node sends to or reads from the robot."""

    # --- loco service (sport) --------------------------------------------------------------
    def set_fsm_id(self, fsm_id: int) -> None: ...
    def get_fsm_mode(self) -> int: ...
    def get_balance_mode(self, timeout_s: float | None = None) -> int: ...
    def get_stand_height(self, timeout_s: float | None = None) -> float: ...
    def set_balance_mode(self, mode: int) -> None: ...
    def set_speed_mode(self, mode: int) -> None: ...
    def set_velocity(self, vx: float, vy: float, wz: float, duration_s: float) -> None: ...
    def send_velocity(self, vx: float, vy: float, wz: float, duration_s: float) -> PendingReply:
        """Write a SetVelocity request now and return without waiting for its reply (so a forward gate
        held around the write is never held for a round trip). Never waits for a server to match:
        with none matched it raises RobotError (3102, not sent) at once."""
    def high_stand(self) -> None: ...
    def low_stand(self) -> None: ...
    def set_arm_task(self, task_id: int) -> None: ...

    # --- streams ---------------------------------------------------------------------------
    def write_arm_sdk(self, targets: Sequence[MotorCommand], weight: float) -> None:
        """One rt/arm_sdk frame: 17 targets for motors 12..28 and the blend weight 0..1."""

    def write_lowcmd(self, commands: Sequence[MotorCommand]) -> None:
        """One rt/lowcmd frame: 29 commands in motor order, mode_machine from rt/lowstate.

        Raises RobotError if no rt/lowstate was seen yet (mode_machine unknown).
        """

    def sport_state(self) -> SportState | None:
        """The last rt/sportmodestate, or None if none arrived yet."""

    def set_sport_state_listener(self, listener: Callable[[SportState], None] | None) -> None:
        """Call `listener` (from a DDS thread) with every rt/sportmodestate sample; None removes it."""

    def lowstate_age_s(self) -> float | None:
        """Seconds since the last rt/lowstate, or None if none arrived yet."""

    def joint_positions(self) -> Sequence[float] | None:
        """The 29 measured joint positions in motor order while current (rt/lowstate received, fresh), else None."""

    def state_sample(self) -> StateSample | None:
        """The freshest of rt/lowstate (while received) and rt/lf/lowstate; None before either arrived."""

    def battery_soc(self) -> tuple[float, float] | None:
        """(state of charge %, age s) of the newest rt/lf/bmsstate; None before one arrived."""

    def odometry(self) -> OdomSample | None:
        """The newest rt/lf/odommodestate; None before one arrived (old firmware, or never in high-level mode)."""

    def lowstate_restarts(self) -> int:
        """How often rt/lowstate's tick went back (the robot rebooted) since connect."""

    def set_lowstate_wanted(self, wanted: bool) -> None:
        """Receive rt/lowstate or not (while not: lowstate_age_s grows, joint_positions is None)."""

    def lowstate_receiving(self) -> bool:
        """True while rt/lowstate is subscribed (connected and wanted)."""

    def lowstate_data(self) -> tuple[bytes, int] | None:
        """The serialised latest rt/lowstate and how many arrived so far; None before the first (or on a
        port without the raw stream). Decoded (protocol.lowstate_fields) only by whoever publishes it."""

    # --- signalling ------------------------------------------------------------------------
    def voice(self, timeout_s: float = 0.5) -> VoicePort | None:
        """The voice service (head LED, TTS) with calls of ``timeout_s``; None while there is none (not
        connected yet, closed, or a port without one)."""

    def close(self) -> None:
        """Stop readers and writers."""
