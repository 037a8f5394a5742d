"""The body watch: reads the robot's state, runs the body checks and the remote, and acts through the
mode machine. ROS-free; the node runs ``step`` on a thread of its own and reads what it found.

- Every step takes the freshest state sample (rt/lowstate while it is received, at ``fast_period_s``;
  otherwise rt/lf/lowstate at ``slow_period_s``, so an idle HIGH_LEVEL never needs the 500 Hz stream),
  takes the few fields the checks read (the port decoded them) and evaluates them (``BodyMonitor``).
- A FAULT reaction enters FAULT (the machine's protective stop never waits for the robot); a HOLD holds
  motion in the mode; WARN is only reported.
- The remote: a held e-stop combination (default L2+B) e-stops in every mode, once per press; the optional
  dead-man key is what the lowcmd relay asks before it forwards a user frame.
- The posture (core/posture.py) from the same sample, for ~/mode and the posture verbs of ~/loco_command.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Protocol

from g1_mode_manager.core.body.checks import Reaction, holds_upright
from g1_mode_manager.core.body.monitor import BodyMonitor
from g1_mode_manager.core.body.motion_allowance import MotionRecord, allowance
from g1_mode_manager.core.body.readings import BodyReadings, readings_of
from g1_mode_manager.core.events import RelayEvents
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import RobotPort, StateSample
from g1_mode_manager.core.posture import NO_READING, PostureReading, read_posture
from g1_mode_manager.core.records import MachineStatus, Outcome
from g1_mode_manager.protocol.fsm import FsmId

#: A remote frame older than this says nothing about the keys held now (rt/lowstate: 2 ms; lf: 50 ms), s.
REMOTE_FRESH_S = 0.2
#: rt/sportmodestate older than this says nothing about the controller's state, s.
SPORT_FRESH_S = 0.5
#: A state sample older than this says nothing about the posture now (rt/lf/lowstate: 50 ms), s.
POSTURE_FRESH_S = 0.5


class BodyMachine(Protocol):
    """What the body watch asks of the mode machine."""

    def status(self) -> MachineStatus: ...
    def fault(self, faults: tuple[str, ...]) -> bool: ...
    def hold(self, holds: tuple[str, ...]) -> None: ...
    def estop_shot(self) -> list[str]: ...
    def estop(self, *, wait: bool = True, fired: list[str] | None = None) -> Outcome: ...


class BodyWatch:
    def __init__(self, port: RobotPort, machine: BodyMachine, monitor: BodyMonitor, events: RelayEvents, *,
                 estop_keys: int, deadman_keys: int, fast_period_s: float, slow_period_s: float,
                 enabled: bool = True, motion: MotionRecord | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        """``motion``: what a tracking policy's motion asks for, so that its own speeds are not judged a flail."""
        self._port = port
        self._machine = machine
        self.monitor = monitor
        self._events = events
        self._estop_keys = estop_keys
        self._deadman_keys = deadman_keys
        self._fast_period_s = fast_period_s
        self._slow_period_s = slow_period_s
        self._enabled = enabled
        self._clock = clock
        self._motion = motion
        #: what the speed checks allow while no motion plays: nothing beyond the bases, and no joint past its limit
        self._still = allowance(monitor.threshold("joint_speed"), monitor.threshold("spin"), None)
        self._lock = threading.Lock()
        self._keys = 0  # the remote's key field, as of _keys_at
        self._keys_at = float("-inf")
        self._estop_pressed = False  # the combination was held at the last look (one e-stop per press)
        self.readings = BodyReadings()
        self.posture: PostureReading = NO_READING

    def period_s(self) -> float:
        """How long until the next step: short while rt/lowstate is received, long on rt/lf/lowstate alone."""
        return self._fast_period_s if self._port.lowstate_receiving() else self._slow_period_s

    def step(self) -> None:
        status = self._machine.status()
        if status.mode is Mode.UNINITIALIZED:
            return
        now = self._clock()
        sample = self._port.state_sample()
        battery = self._port.battery_soc()
        soc = None if battery is None else battery[0]
        if sample is None:
            readings = BodyReadings(soc_pct=soc)
        else:
            fields = sample.fields
            allowed = None if self._motion is None else self._motion.current()
            readings = readings_of(fields, state_age_s=sample.age_s, soc_pct=soc,
                                   allowance=self._still if allowed is None else allowed,
                                   joint_base_rad_s=self.monitor.threshold("joint_speed"))
            if sample.age_s <= REMOTE_FRESH_S:
                with self._lock:
                    self._keys = int.from_bytes(fields.remote[2:4], "little")
                    self._keys_at = now - sample.age_s
        self.readings = readings
        self.posture = self._posture(sample, status)
        self._remote_estop(status, now)
        if not self._enabled:
            return
        trips = self.monitor.evaluate(readings, status.mode, self._upright_expected(status), now)
        faults = tuple(t.text for t in trips if t.reaction is Reaction.FAULT)
        holds = tuple(t.text for t in trips if t.reaction is Reaction.HOLD)
        if faults:
            self._events.log("error", "body_fault", f"body check tripped in {status.mode.name}: {', '.join(faults)}: "
                             "protective stop (FAULT)")
            self._machine.fault(faults)
        if holds:
            self._events.log("error", "body_hold", f"body check tripped in {status.mode.name}: {', '.join(holds)}: "
                             "no new motion until ~/clear_fault")
            self._machine.hold(holds)

    def _posture(self, sample: StateSample | None, status: MachineStatus) -> PostureReading:
        if sample is None or sample.age_s > POSTURE_FRESH_S:
            return NO_READING
        return read_posture(sample.fields.q, sample.fields.quaternion, limp=self._limp(status))

    def _limp(self, status: MachineStatus) -> bool | None:
        """No controller holds the joints: the built-in one damps or lets go (None: not known; released, the
        user's frames hold them or nothing does)."""
        if status.service_known and not status.service_active:
            return None
        sport = self._port.sport_state()
        if sport is None or sport.age_s > SPORT_FRESH_S:
            return None
        return sport.fsm_id in (FsmId.DAMP, FsmId.ZERO_TORQUE)

    def _upright_expected(self, status: MachineStatus) -> bool:
        """Something is meant to hold the robot upright: the user's controller in LOW_LEVEL; in IDLE and
        HIGH_LEVEL the built-in controller in a state that stands or walks. Not during a transition (it
        changes who holds the robot: LOW_LEVEL's entry leaves it limp), nor in EMERGENCY and FAULT."""
        if status.transition_in_progress:
            return False
        if status.mode is Mode.LOW_LEVEL:
            return True
        if status.mode not in (Mode.IDLE, Mode.HIGH_LEVEL) or (status.service_known and not status.service_active):
            return False
        sport = self._port.sport_state()
        return sport is not None and sport.age_s <= SPORT_FRESH_S and holds_upright(sport.fsm_id, sport.fsm_mode)

    def _remote_estop(self, status: MachineStatus, now: float) -> None:
        if not self._estop_keys:
            return
        pressed = self.keys_held(self._estop_keys, now)
        first, self._estop_pressed = pressed and not self._estop_pressed, pressed
        if not first or status.mode is Mode.EMERGENCY:
            return
        notes = self._machine.estop_shot()
        self._events.log("error", "remote_estop", f"E-STOP from the robot's remote (keys held) in {status.mode.name}")
        self._machine.estop(wait=False, fired=notes)

    def keys_held(self, mask: int, now: float | None = None) -> bool:
        """The remote's keys in ``mask`` are all held, as of a frame no older than REMOTE_FRESH_S."""
        keys = self.fresh_keys(now)
        return keys is not None and keys & mask == mask

    def fresh_keys(self, now: float | None = None) -> int | None:
        """The remote's key field as of a frame no older than REMOTE_FRESH_S (None: no such frame, the keys held now
        are not known)."""
        with self._lock:
            keys, at = self._keys, self._keys_at
        return keys if (self._clock() if now is None else now) - at <= REMOTE_FRESH_S else None

    def deadman_held(self) -> bool:
        """The LOW_LEVEL dead-man: True while its key is held (always True when no dead-man is set)."""
        return not self._deadman_keys or self.keys_held(self._deadman_keys)
