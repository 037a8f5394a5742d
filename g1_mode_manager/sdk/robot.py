"""UnitreeRobot: the RobotPort over Unitree SDK2 DDS (no ROS here).

``connect()`` creates every DDS entity once: the SDK sleeps 0.5 s in each RPC client's constructor,
so connect takes about 1.1 s plus the motion switcher's readiness probe; no call after it creates
anything (the frame writers are ours and do not sleep). Calls are safe from several threads at once: the e-stop thread's
``damp`` goes through the loco client while another thread waits in ``select_mode`` on the motion
switcher client (a separate client with its own, longer timeout), and each call has its own deadline.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Sequence
from typing import TypeVar

from g1_mode_manager.core.port import MotorCommand, OdomSample, PendingReply, RobotError, SportState, StateSample
from g1_mode_manager.core.user_ctrl import roll_pitch
from g1_mode_manager.protocol import topics
from g1_mode_manager.protocol.api_ids import ERR_CLIENT_SEND
from g1_mode_manager.protocol.dds import init_channels
from g1_mode_manager.protocol.fsm import InternalCtrl
from g1_mode_manager.protocol.idl import SportModeState_
from g1_mode_manager.protocol.lowstate_fields import decode_body_fields
from g1_mode_manager.protocol.side_by_side import side_by_side
from g1_mode_manager.sdk.arm_sdk import ArmSdkWriter
from g1_mode_manager.sdk.battery_reader import BatteryReader
from g1_mode_manager.sdk.loco_client import LocoClient
from g1_mode_manager.sdk.lowcmd import LowCmdWriter
from g1_mode_manager.sdk.motion_switcher import MotionSwitcherClient
from g1_mode_manager.sdk.odom_reader import OdomReader
from g1_mode_manager.sdk.state_readers import LowStateReader, SportStateReader
from g1_mode_manager.sdk.voice_client import VoiceClient

_log = logging.getLogger(__name__)
P = TypeVar("P")
#: A rt/lowstate sample younger than this makes reading rt/lf/lowstate (20 Hz) pointless for the body checks, s.
FRESH_STATE_S = 0.01
#: The joints' speeds that decide whether the robot is at rest for the user-control entry come from a sample no older
#: than this, s.
REST_FRESH_S = 0.1


class UnitreeRobot:
    """The G1 over Unitree SDK2: implements ``core.port.RobotPort``.

    ``rpc_timeout_s`` bounds each loco call; motion switcher calls get ``mode_timeout_s`` (SelectMode
    can take seconds); the mode calls also take their own ``timeout_s``.
    """

    def __init__(self, domain: int, interface: str, rpc_timeout_s: float = 1.0, *, mode_timeout_s: float = 5.0,
                 ready_budget_s: float = 3.0, user_ctrl: bool = False) -> None:
        if not rpc_timeout_s > 0 or not mode_timeout_s > 0:
            raise ValueError("timeouts must be > 0")
        self.domain = int(domain)
        self.interface = interface
        self.rpc_timeout_s = float(rpc_timeout_s)
        self.mode_timeout_s = float(mode_timeout_s)
        self.ready_budget_s = float(ready_budget_s)
        self._sport_listener: Callable[[SportState], None] | None = None
        self._connect_lock = threading.Lock()
        self._loco: LocoClient | None = None
        self._switcher: MotionSwitcherClient | None = None
        self._arm: ArmSdkWriter | None = None
        self._lowcmd: LowCmdWriter | None = None
        #: rt/user_lowcmd (low_level_path user_ctrl): created at connect, so the sim or robot has matched it before
        #: the first hand-over frame, which must not be lost to discovery.
        self._user_ctrl = bool(user_ctrl)
        self._user_lowcmd: LowCmdWriter | None = None
        self._lowstate: LowStateReader | None = None
        self._lf_lowstate: LowStateReader | None = None  # always received: the body checks' cheap stream
        self._battery: BatteryReader | None = None
        self._odom: OdomReader | None = None
        self._lowstate_wanted = True
        self._sport: SportStateReader | None = None
        self._ready = False
        self._closed = False
        self._voice: VoiceClient | None = None
        self._voice_lock = threading.Lock()
        #: Seconds the last connect() took (entity creation, then probe).
        self.connect_time_s: float | None = None
        self.create_time_s: float | None = None

    # --- connection -------------------------------------------------------------------------------
    def connect(self) -> None:
        """Create the DDS domain, clients, readers and writers once, then wait until the motion switcher
        answers (bounded by ``ready_budget_s``). Idempotent; after a failed probe, calling it again
        only probes again. Raises RobotError if the motion switcher never answered."""
        with self._connect_lock:
            if self._closed:
                raise RobotError("connect", ERR_CLIENT_SEND, "robot port was closed")
            if self._ready:
                return
            start = time.monotonic()
            if self._loco is None:
                init_channels(self.domain, self.interface)  # robot type compat applied before any topic
                self._lowstate = LowStateReader()
                self._lowstate.set_receiving(self._lowstate_wanted)
                self._lf_lowstate = LowStateReader(topics.LF_LOWSTATE)
                self._battery = BatteryReader()
                self._odom = OdomReader()
                self._sport = SportStateReader()
                if self._sport_listener is not None:
                    self._sport.set_listener(self._relay_sport_state)
                # the two RPC clients' SDK sleeps (0.7 s each) overlap: the first transition waits for one of them
                user_lowcmd = (lambda: LowCmdWriter(self._lowstate_mode_machine, topics.USER_LOWCMD)) \
                    if self._user_ctrl else (lambda: None)
                self._switcher, self._arm, self._lowcmd, self._user_lowcmd, self._loco = side_by_side(
                    lambda: MotionSwitcherClient(self.mode_timeout_s), ArmSdkWriter,
                    lambda: LowCmdWriter(self._lowstate_mode_machine), user_lowcmd,
                    lambda: LocoClient(self.rpc_timeout_s))
                self.create_time_s = time.monotonic() - start
            try:
                self._switcher.wait_ready(self.ready_budget_s)
            except RobotError as error:
                raise RobotError("connect", error.code, f"motion_switcher did not answer within "
                                 f"{self.ready_budget_s:.1f} s (domain {self.domain}, "
                                 f"interface {self.interface!r})") from error
            finally:
                self.connect_time_s = time.monotonic() - start
            self._ready = True
            _log.info("connected in %.2f s (entities %.2f s)", self.connect_time_s, self.create_time_s or 0.0)

    def probe(self, budget_s: float | None = None) -> dict[str, str]:
        """Wait (bounded) until both services answer; returns their api versions. Raises RobotError."""
        budget = self.ready_budget_s if budget_s is None else budget_s
        return {client.service: client.wait_ready(budget) for client in (self.motion_switcher, self.loco)}

    @property
    def loco(self) -> LocoClient:
        """The full loco API (stand/swing height, gait helpers...) beyond RobotPort."""
        return self._need(self._loco, "loco")

    @property
    def motion_switcher(self) -> MotionSwitcherClient:
        return self._need(self._switcher, "motion_switcher")

    def voice(self, timeout_s: float = 0.5) -> VoiceClient | None:
        """The voice service (head LED, TTS), or None until connect() succeeded or after close().

        Created on first use, by the caller's thread (the head LED worker): its client costs the SDK's
        0.5 s sleep, which must not lengthen connect(), i.e. the first transition.
        """
        if not self._ready or self._closed:
            return None
        with self._voice_lock:
            if self._voice is None:
                self._voice = VoiceClient(timeout_s)
            return self._voice

    def _need(self, part: P | None, call: str) -> P:
        if part is None or self._closed:
            raise RobotError(call, ERR_CLIENT_SEND, "not connected: call connect() first")
        return part

    def _lowstate_mode_machine(self) -> int | None:
        return None if self._lowstate is None else self._lowstate.mode_machine

    # --- mode services ----------------------------------------------------------------------------
    def check_mode(self, timeout_s: float | None = None) -> str:
        return self.motion_switcher.check_mode(timeout_s=timeout_s)

    def select_mode(self, name: str, timeout_s: float | None = None) -> None:
        self.motion_switcher.select_mode(name, timeout_s=timeout_s)

    def release_mode(self, timeout_s: float | None = None) -> None:
        self.motion_switcher.release_mode(timeout_s=timeout_s)

    def damp(self, timeout_s: float | None = None) -> None:
        self.loco.damp(timeout_s=timeout_s)

    def damp_no_reply(self) -> None:
        self.loco.damp_no_reply()

    # --- loco -------------------------------------------------------------------------------------
    def set_fsm_id(self, fsm_id: int) -> None:
        self.loco.set_fsm_id(fsm_id)

    def get_fsm_id(self, timeout_s: float | None = None) -> int:
        return self.loco.get_fsm_id(timeout_s=timeout_s)

    def get_fsm_mode(self) -> int:
        return self.loco.get_fsm_mode()

    def get_balance_mode(self, timeout_s: float | None = None) -> int:
        return self.loco.get_balance_mode(timeout_s=timeout_s)

    def get_stand_height(self, timeout_s: float | None = None) -> float:
        return self.loco.get_stand_height(timeout_s=timeout_s)

    def set_balance_mode(self, mode: int) -> None:
        self.loco.set_balance_mode(mode)

    def set_speed_mode(self, mode: int) -> None:
        self.loco.set_speed_mode(mode)

    def high_stand(self) -> None:
        self.loco.high_stand()

    def low_stand(self) -> None:
        self.loco.low_stand()

    def set_arm_task(self, task_id: int) -> None:
        self.loco.set_arm_task(task_id)

    # --- user control (core.user_ctrl.UserCtrlPort) ---------------------------------------------------
    def switch_to_user_ctrl(self, timeout_s: float | None = None) -> None:
        self.loco.switch_to_user_ctrl(timeout_s=timeout_s)

    def switch_to_internal_ctrl(self, target: InternalCtrl, timeout_s: float | None = None) -> None:
        self.loco.switch_to_internal_ctrl(target, timeout_s=timeout_s)

    def write_user_lowcmd(self, commands: Sequence[MotorCommand]) -> None:
        self._need(self._user_lowcmd, "user_lowcmd").write(commands)

    def attitude(self, max_age_s: float) -> tuple[float, float] | None:
        """(roll, pitch) from the newest state sample no older than ``max_age_s``; None without one."""
        sample = self.state_sample()
        if sample is None or sample.age_s > max_age_s:
            return None
        return roll_pitch(*sample.fields.quaternion)

    def joint_speed_max(self) -> float | None:
        """The largest |dq| of the newest state sample no older than REST_FRESH_S; None without one."""
        sample = self.state_sample()
        if sample is None or sample.age_s > REST_FRESH_S:
            return None
        return max(map(abs, sample.fields.dq))

    def set_velocity(self, vx: float, vy: float, wz: float, duration_s: float) -> None:
        self.loco.set_velocity(vx, vy, wz, duration_s)

    def send_velocity(self, vx: float, vy: float, wz: float, duration_s: float) -> PendingReply:
        return self.loco.send_velocity(vx, vy, wz, duration_s)

    # --- streams ----------------------------------------------------------------------------------
    def write_arm_sdk(self, targets: Sequence[MotorCommand], weight: float) -> None:
        self._need(self._arm, "arm_sdk").write(targets, weight)

    def write_lowcmd(self, commands: Sequence[MotorCommand]) -> None:
        self._need(self._lowcmd, "lowcmd").write(commands)

    def sport_state(self) -> SportState | None:
        return None if self._sport is None else self._sport.state()

    def set_sport_state_listener(self, listener: Callable[[SportState], None] | None) -> None:
        """Call ``listener`` with every rt/sportmodestate sample (age 0), in the DDS listener thread:
        keep it short. None removes it. May be set before or after connect(). Costs a Python call per
        sample while set (without one, the reader costs nothing per sample)."""
        self._sport_listener = listener
        if self._sport is not None:
            self._sport.set_listener(None if listener is None else self._relay_sport_state)

    def _relay_sport_state(self, sample: SportModeState_) -> None:
        listener = self._sport_listener
        if listener is not None:
            listener(SportState(fsm_id=int(sample.fsm_id), fsm_mode=int(sample.fsm_mode), task_id=int(sample.task_id),
                                task_time=float(sample.task_time), age_s=0.0))

    def lowstate_age_s(self) -> float | None:
        return None if self._lowstate is None else self._lowstate.age_s()

    def joint_positions(self) -> Sequence[float] | None:
        return None if self._lowstate is None else self._lowstate.joint_positions()

    def lowstate_data(self) -> tuple[bytes, int] | None:
        """The serialised latest rt/lowstate and how many arrived so far (None before the first): the
        joint state publisher decodes it only when it publishes."""
        if self._lowstate is None:
            return None
        snapshot, _stamp, count = self._lowstate.latest()
        return None if snapshot is None else (snapshot.data, count)

    def state_sample(self) -> StateSample | None:
        best: tuple[bytes, float, bool, float] | None = None  # the freshest sample's data, age, stream, publication
        now = time.monotonic()
        for reader, low_rate in ((self._lowstate, False), (self._lf_lowstate, True)):
            if reader is None or (best is not None and best[1] < FRESH_STATE_S):
                continue  # a sample of the 500 Hz stream this fresh: the 20 Hz one cannot be newer
            snapshot, stamp, published = reader.latest_published()
            if snapshot is not None and (best is None or now - stamp < best[1]):
                best = (snapshot.data, now - stamp, low_rate, published)
        return None if best is None else StateSample(decode_body_fields(best[0]), best[1], best[2], best[3])

    def battery_soc(self) -> tuple[float, float] | None:
        return None if self._battery is None else self._battery.soc()

    def odometry(self) -> OdomSample | None:
        return None if self._odom is None else self._odom.sample()

    def lowstate_restarts(self) -> int:
        return 0 if self._lowstate is None else self._lowstate.restarts

    def set_lowstate_wanted(self, wanted: bool) -> None:
        """Subscribe to rt/lowstate or not (receiving its 500 Hz costs CPU in Cyclone even with no Python)."""
        self._lowstate_wanted = bool(wanted)
        reader = self._lowstate
        if reader is not None:
            reader.set_receiving(self._lowstate_wanted)

    def lowstate_receiving(self) -> bool:
        reader = self._lowstate
        return reader is not None and reader.receiving

    def mode_machine(self) -> int | None:
        """mode_machine of the last rt/lowstate (copied into every LowCmd_), None before the first."""
        return self._lowstate_mode_machine()

    def close(self) -> None:
        """Stop readers, writers and the RPC clients' reply readers; later calls raise RobotError.

        The RPC clients first, without the connect lock: a call still waiting for its reply (a transition's
        SelectMode at exit) then ends now, not at its timeout, and nothing holds the process's exit up."""
        for client in (self._loco, self._switcher):
            if client is not None:
                client.close()
        with self._connect_lock:
            if self._closed:
                return
            self._closed = True
            with self._voice_lock:
                voice = self._voice
            for part in (self._sport, self._lowstate, self._lf_lowstate, self._battery, self._odom, self._arm, self._lowcmd,
                         self._user_lowcmd, self._loco, self._switcher, voice):
                if part is not None:
                    try:
                        part.close()
                    except Exception:  # closing is best effort; the process may be exiting
                        _log.exception("closing %s failed", type(part).__name__)
