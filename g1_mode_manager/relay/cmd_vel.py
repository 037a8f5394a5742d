"""/cmd_vel (and the autonomy's cmd_vel_nav) -> LocoClient Move, in HIGH_LEVEL only: sanitised, clamped,
rate-limited, latest-wins, watchdog.

Two sources feed one Move stream: the teleop and, once an operator handed it the robot, the autonomy, each
with its own limits and watchdog (velocity_source.py); who drives is core/drive.py's. One sender writes every
Move, so no Move of the previous driver can follow the new driver's first: after a change of driver the ramp
starts again from standstill. The autonomy drives only while its conditions hold (``autonomy_blocked``:
fresh odometry, no hold, a robot that walks when told to); otherwise it is suspended: a StopMove, and the
reason in ``driving()``.

A command is sent as soon as it arrives, by a sender thread of its own (the /cmd_vel callback only
stores it and wakes the thread: a blocking RPC there would stall the node's executor). While the
acceleration limiter still ramps toward the command the sender steps every RAMP_PERIOD_S; a steady Move
is repeated at the keep-alive rate (``rate_hz``); the watchdog wakes the sender at its own deadline.
Moves never exceed ``max_rate_hz`` (a token bucket of MOVE_BURST: a new command right after a keep-alive
or a ramp step goes out at once instead of waiting out a minimum interval).
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

from g1_mode_manager.core import modes
from g1_mode_manager.core.drive import Driver
from g1_mode_manager.core.events import RelayEvents
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import PendingReply, RobotError, RobotPort
from g1_mode_manager.core.velocity import Sanitized, Velocity, VelocityLimits, check_move_duration, in_dead_band
from g1_mode_manager.relay.drive_sources import DriveSources
from g1_mode_manager.relay.gate import LinkMonitor, ModeGate
from g1_mode_manager.relay.velocity_source import VelocitySource

#: While the command is still ramping, the sender steps this often (and this is the limiter's largest dt).
RAMP_PERIOD_S = 0.05
#: Moves that may go out back to back; over any longer stretch they stay within max_rate_hz. Two, so that
#: a new command arriving just after a keep-alive or ramp step is not held back (with a plain minimum
#: interval it would wait up to 1 / max_rate_hz).
MOVE_BURST = 2
#: A StopMove that got no answer is sent again up to this many times in all; after that the robot
#: stops by itself when the last Move's lease (move_duration_s) runs out.
STOP_ATTEMPTS = 5
#: A transition out of HIGH_LEVEL waits at most this long for the StopMove before its first robot call (s).
STOP_WAIT_S = 3.0
#: A keep-alive this close to its period counts as due: a wake is never exactly on time, and a step that judged one
#: a hair early would put it off a whole period (s).
KEEP_ALIVE_SLACK_S = 0.002


@dataclass(frozen=True)
class AutonomyInput:
    """The autonomy's source: its topic (for messages), limits and silence timeout."""

    topic: str
    limits: VelocityLimits
    timeout_s: float


class CmdVelRelay:
    """Keeps only the latest command; each `step` sends at most one Move (or StopMove).

    The acceleration limiter advances only on Moves the robot acknowledged, with dt clamped to the
    tick period; a refused or unanswered Move restarts it from zero. A Move whose answer was lost
    counts as "maybe moving". Silence, the gate closing, a sub-dead-band command or shutdown while
    (maybe) moving sends a StopMove, repeated until acknowledged (bounded).
    """

    def __init__(self, port: RobotPort, gate: ModeGate, link: LinkMonitor, events: RelayEvents, *,
                 limits: VelocityLimits, timeout_s: float, move_duration_s: float, rate_hz: float,
                 max_rate_hz: float, on_error: Callable[[BaseException], None] | None = None,
                 on_acknowledged: Callable[[Velocity, float], None] | None = None,
                 autonomy: AutonomyInput | None = None, autonomy_blocked: Callable[[], str | None] = lambda: None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        if not (rate_hz > 0.0 and max_rate_hz > 0.0):
            raise ValueError(f"cmd_vel rates must be > 0 Hz, got {rate_hz} and {max_rate_hz}")
        self._port = port
        self._gate = gate
        self._link = link
        self._events = events
        self._period_s = 1.0 / rate_hz
        self._ramp_s = min(self._period_s, RAMP_PERIOD_S)
        self._max_rate_hz = max_rate_hz
        self._wake = threading.Event()
        #: who drives (the teleop, or the autonomy once handed the robot) and their latest commands
        self.sources = DriveSources(
            gate, events, VelocitySource(Driver.TELEOP, "cmd_vel", limits, timeout_s, self._ramp_s, clock),
            None if autonomy is None else VelocitySource(Driver.AUTONOMY, autonomy.topic, autonomy.limits,
                                                         autonomy.timeout_s, self._ramp_s, clock),
            blocked=autonomy_blocked, wake=self._wake.set)
        self._move_duration_s = check_move_duration(move_duration_s)
        self._on_error = on_error
        self._on_acknowledged = on_acknowledged  # (the Move, when it was sent): e.g. a walk judge
        #: called with each Move written and who drove it (after the forward gate), e.g. by the flight recorder
        self.on_move: Callable[[Driver, Velocity], None] = lambda _driver, _v: None
        self._clock = clock
        self._stopped = threading.Event()
        self._settled = threading.Condition()  # the sender notifies after every step; _stops under it
        self._stops = 0  # stops (EMERGENCY, FAULT) begun: each ends a transition's wait for a StopMove
        self._thread = threading.Thread(target=self._run, name="cmd_vel_sender", daemon=True)
        # sender thread only:
        self._source = self.sources.teleop  # the driving source at the last step
        self._maybe_moving = False  # a non-zero Move may be running on the robot
        self._move_in_flight = False  # a Move was written and its answer is awaited
        self._stop_reason: str | None = None  # a StopMove is owed
        self._stop_attempts = 0
        #: forwarding stopped by a stop (EMERGENCY, FAULT) that damps the robot: a StopMove still goes out, since it
        #: stops a walking robot whose Damp failed, and the damped robot's refusal of it is expected
        self._after_stop = False
        self._last_ack: float | None = None  # when the robot acknowledged the last Move
        self._last_send = -math.inf
        self._tokens = float(MOVE_BURST)  # the Move budget (token bucket, refilled at max_rate_hz)
        self._tokens_at = clock()

    # --- what the node calls -------------------------------------------------------------------
    def submit(self, vx: float, vy: float, wz: float) -> Sanitized:
        """Take a new command from /cmd_vel, the teleop (never blocks); see DriveSources.offer."""
        return self.sources.offer(self.sources.teleop, vx, vy, wz)

    def on_leave(self, source: Mode, target: Mode) -> None:
        """Leave listener: leaving HIGH_LEVEL wakes the sender, which stops a running Move.

        HIGH_LEVEL -> LOW_LEVEL also waits, at most STOP_WAIT_S, until that StopMove is settled (acknowledged,
        refused or given up), so that ReleaseMode never reaches the robot before it: the released robot would
        otherwise answer it 3203 and keep the last Move's velocity for the moment it still walks. Going to
        IDLE never waits (nothing follows that the StopMove could be overtaken by), nor does a stop
        (EMERGENCY, FAULT), which also ends such a wait."""
        if source is not Mode.HIGH_LEVEL:
            return
        self.sources.left_high_level(target)
        if target in (Mode.EMERGENCY, Mode.FAULT):
            with self._settled:
                self._stops += 1
                self._settled.notify_all()
            self._wake.set()
            return
        self._wake.set()
        if target is Mode.LOW_LEVEL:
            self._wait_stop_settled(target)

    def _stop_owed(self) -> bool:
        return self._maybe_moving or self._stop_reason is not None or self._move_in_flight

    def _wait_stop_settled(self, target: Mode) -> None:
        deadline = self._clock() + STOP_WAIT_S
        with self._settled:
            stops = self._stops
            while self._stop_owed() and self._stops == stops and not self._stopped.is_set():
                left = deadline - self._clock()
                if left <= 0.0:
                    self._events.log("error", "stop_move_unsettled",
                                     f"leaving HIGH_LEVEL for {target.name}: StopMove not settled within "
                                     f"{STOP_WAIT_S:g} s; going on (the robot stops by itself within "
                                     f"{self._move_duration_s} s of the last Move)")
                    return
                self._settled.wait(left)

    def start(self) -> None:
        self._thread.start()

    def stop(self, timeout_s: float = 3.0) -> None:
        """Stop the sender; then a StopMove if the robot may be walking (bounded: two attempts)."""
        self._stopped.set()
        self._wake.set()
        with self._settled:
            self._settled.notify_all()
        if self._thread.is_alive():
            self._thread.join(timeout_s)
        if self._maybe_moving or self._stop_reason is not None:
            for _ in range(2):
                if self._stop_move("node shutting down"):
                    break

    # --- the sender ----------------------------------------------------------------------------
    def _run(self) -> None:
        last_step = self._clock()
        while not self._stopped.is_set():
            # idle (no Move may be running, none owed, no fresh command): sleep until submit/on_leave/stop
            self._wake.wait(self._next_step_in(last_step))
            self._wake.clear()
            if self._stopped.wait(self._budget_wait()):
                break
            last_step = self._clock()
            try:
                self.step()
            except Exception as exc:  # a relay bug must not end the sender silently
                if self._on_error is not None:
                    self._on_error(exc)
            with self._settled:  # a transition may wait for a StopMove (on_leave)
                self._settled.notify_all()

    def _refill(self) -> None:
        now = self._clock()
        self._tokens = min(float(MOVE_BURST), self._tokens + (now - self._tokens_at) * self._max_rate_hz)
        self._tokens_at = now

    def _budget_wait(self) -> float:
        """Seconds until the Move budget allows a send (0 if it does now)."""
        self._refill()
        return max(0.0, (1.0 - self._tokens) / self._max_rate_hz)

    def _spend(self) -> None:
        """A Move or StopMove goes out now."""
        self._refill()
        self._tokens -= 1.0
        self._last_send = self._tokens_at

    def _idle(self) -> bool:
        return not self._maybe_moving and self._stop_reason is None and self._source.watchdog.expired()

    def _next_step_in(self, last_step: float) -> float | None:
        """Seconds until the next step: the ramp's tick while ramping, else the keep-alive, or the watchdog's
        deadline if that comes first; None when idle (only a wake starts a step)."""
        if self._idle():
            return None
        source = self._source
        ramping = source.target != source.limiter.current  # a racy read: at worst one step early or late
        now = self._clock()
        # the keep-alive counts from the last write, not from the last step's start: a step that began a period
        # after the previous one comes a little less than a period after its write, and would skip a period
        due = last_step + self._ramp_s if ramping else max(last_step, self._last_send) + self._period_s
        deadline = source.watchdog.deadline()
        if deadline is not None and now < deadline < due:
            due = deadline + 0.001  # just past it: the step sees the watchdog expired
        return max(0.0, due - now)

    def step(self) -> None:
        """One decision with the driver's latest command: at most one Move or StopMove.

        What to send is planned first without asking the mode; the forward gate then decides, once, and its
        decision (the mode it judged) is what the link check and a drop's reason take."""
        pick = self.sources.pick()
        source, target, untaken = pick.source, pick.target, pick.untaken
        if pick.new_driver:  # no Move after this carries the previous driver's velocity
            source.limiter.reset()
            self._last_ack = None
        self._source = source
        now = self._clock()
        blocked = self.sources.blocked() if source.driver is Driver.AUTONOMY else None
        if blocked is not None:
            v, rest_why = None, f"autonomy suspended: {blocked}"
        else:
            v, rest_why = self._plan(source, target, now)
        reply = None
        with self._gate.forwarding(modes.allows_cmd_vel) as decision:
            forward = decision.allowed and self._link.link_ok(decision.mode)
            if forward and v is not None:
                reply = self._write_move(v)  # only the write under the gate: an e-stop never waits for a reply
                self._move_in_flight = reply is not None
        self._after_stop = decision.mode in (Mode.EMERGENCY, Mode.FAULT)
        if reply is not None and v is not None:
            self.on_move(source.driver, v)
        if not forward:
            self.sources.forget_all()
            if not decision.allowed and untaken:
                self._events.count("cmd_vel_dropped", untaken)
                self._events.log("warn", "cmd_vel_dropped", f"cmd_vel dropped: mode is {decision.mode.name}, "
                                 "velocity commands pass only in HIGH_LEVEL")
            self._rest("forwarding stopped")
            return
        if rest_why is not None:
            self._rest(rest_why)
        elif reply is not None:
            try:
                self._settle_move(reply, v, now)
            finally:
                self._move_in_flight = False

    def _plan(self, source: VelocitySource, target: Velocity, now: float) -> tuple[Velocity | None, str | None]:
        """(the Move to write, None) or (None, why to rest instead); (None, None): nothing due, the robot runs
        exactly this already and only the keep-alive repeats it (a 100 Hz stream of one value costs
        cmd_vel_rate_hz Moves a second, not max_rate_hz)."""
        if source.watchdog.expired():
            return None, f"no {source.topic} for {source.watchdog.timeout_s} s"
        dt = self._ramp_s if self._last_ack is None else now - self._last_ack
        v = source.limiter.propose(target, dt)
        if in_dead_band(v) and in_dead_band(target):
            return None, "command below the robot's dead band (0.1)"
        if (self._last_ack is not None and v == source.limiter.current
                and now - self._last_send < self._period_s - KEEP_ALIVE_SLACK_S):
            return None, None
        return v, None

    def _rest(self, why: str) -> None:
        """Nothing to send: a StopMove if one is owed, and the limiter starts again from standstill."""
        self._source.limiter.reset()
        self._last_ack = None
        if self._maybe_moving or self._stop_reason is not None:
            self._stop_move(why)

    def _write_move(self, v: Velocity) -> PendingReply | None:
        """Write one Move; None if it was not sent (counted and logged, the ramp restarts)."""
        self._spend()
        try:
            return self._port.send_velocity(v.vx, v.vy, v.wz, self._move_duration_s)
        except RobotError as exc:
            self._move_failed(exc, v)
            return None

    def _settle_move(self, reply: PendingReply, v: Velocity, now: float) -> None:
        """The Move's reply: the limiter advances only on an acknowledged Move."""
        try:
            reply.wait()
        except RobotError as exc:
            self._move_failed(exc, v)
            return
        self._source.limiter.commit(v)
        self._last_ack = now
        self._maybe_moving = not v.is_zero()
        self._stop_reason = None
        self._stop_attempts = 0
        self._events.count("moves_sent")
        if self._on_acknowledged is not None:
            self._on_acknowledged(v, now)

    def _move_failed(self, exc: RobotError, v: Velocity) -> None:
        lost = exc.maybe_delivered  # sent, answer lost: it may be running
        self._maybe_moving = self._maybe_moving or (lost and not v.is_zero())
        self._source.limiter.reset()
        self._last_ack = None
        self._events.count("rpc_failures")
        self._events.log("error", "move_failed", f"Move failed: {exc}; the ramp restarts from zero")

    def _stop_move(self, why: str) -> bool:
        """Send StopMove (SetVelocity 0, 0, 0); True once it is settled (acknowledged, refused or given up)."""
        if self._stop_reason is None:
            self._stop_reason = why
            self._stop_attempts = 0
        self._stop_attempts += 1
        self._spend()
        try:
            self._port.set_velocity(0.0, 0.0, 0.0, self._move_duration_s)
        except RobotError as exc:
            if exc.refused_in_state and self._after_stop:
                self._events.log("info", "stop_move_after_stop", f"StopMove ({self._stop_reason}) refused by the "
                                 f"robot in its stop's damping ({exc.code}), as expected: the stop damps it")
                self._maybe_moving = False
                self._stop_reason = None
                self._stop_attempts = 0
                return True
            self._events.count("rpc_failures")
            if exc.transport and self._stop_attempts < STOP_ATTEMPTS:
                self._events.log("error", "stop_move_failed",
                                 f"StopMove ({self._stop_reason}) failed: {exc}; sending it again")
                return False
            self._events.log("error", "stop_move_settled",
                             f"StopMove ({self._stop_reason}) not acknowledged: {exc}; the robot stops by itself "
                             f"within {self._move_duration_s} s of the last Move")
        else:
            self._events.count("stop_moves_sent")
            self._events.log("info", "stop_move", f"StopMove acknowledged: {self._stop_reason}")
        self._maybe_moving = False
        self._stop_reason = None
        self._stop_attempts = 0
        return True
