"""The sim thread: step the robot one physics step at a time and publish on the robot's schedule.

rt/lowstate goes out at 500 Hz of sim time, rt/lf/lowstate (the same frames) at 20 Hz, rt/secondary_imu
with every rt/lowstate frame, rt/sportmodestate and the ROS topics at 50 Hz, rt/lf/bmsstate at
BMSSTATE_RATE_HZ, all from this thread right after the step they describe (packing is cheap, see
lowstate_codec and imu_codec).

rt/secondary_imu's rate on the robot is not documented. 500 Hz, the rate of the pelvis IMU in rt/lowstate:
Unitree's ankle example subscribes both for one 2 ms control loop, and a slower torso IMU would be a
surprise to it. It goes on when rt/lowstate alone is frozen (another topic), and stops with ``pause_state``.

rt/odommodestate (500 Hz) and rt/lf/odommodestate (every 25th of its samples: 20 Hz) carry the robot's
state estimate (firmware.odometry) while a high-level service is active only, as the robot does; each
rt/lf/odommodestate sample is handed to ``on_odom`` (the bridge's record) with the truth beside it, before it is
published. A torso IMU or odometry sample, or an rt/lowstate frame, that no reader has matched and nothing
records is not computed (streams.StatePublishers).

rt/sportmodestate's (fsm_id, fsm_mode) is read through ``sport_state`` when one is given: the bridge's one
records the robot's state in the same hold of the robot's lock, so the record shows a state before any frame that
shows it leaves the sim (a client answered on that frame must find the state already on the record).

The loop keeps the robot's 2 ms cycle on the wall clock, step by step, while anyone reads a 500 Hz stream or
sends frames; otherwise it sleeps once every IDLE_BATCH_STEPS steps (the steps and what they publish are the
same, in sim time).

Every BODY_PERIOD_S of sim time the body's report (temperatures, battery, remote, with injected readings
laid over: body_report) is taken afresh and handed to ``on_body`` (the bridge's record) before anything of that
step is published, so the record shows a condition before any frame that shows it.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import Any, Protocol

from g1_mode_manager.protocol.topics import (
    LF_LOWSTATE_RATE_HZ,
    LF_ODOMMODESTATE_RATE_HZ,
    LOWSTATE_RATE_HZ,
    ODOMMODESTATE_RATE_HZ,
    SPORTMODESTATE_RATE_HZ,
)
from g1_sim.bridge.body_report import BodyReport, body_report
from g1_sim.bridge.clock import Pacer, RateMeter, StampClock
from g1_sim.bridge.faults import Faults
from g1_sim.bridge.ros_face import BridgeNode
from g1_sim.bridge.streams import StatePublishers

log = logging.getLogger(__name__)

ROS_RATE_HZ = 50.0
#: rt/lf/bmsstate: the robot's rate is not documented; a battery changes slowly, and 5 Hz lets a test see
#: an injected soc within 0.2 s of sim time.
BMSSTATE_RATE_HZ = 5.0
#: The body's report (and the record's ``body`` event) is renewed this often, s of sim time.
BODY_PERIOD_S = 0.01
#: While nobody reads a 500 Hz stream (rt/lowstate, rt/secondary_imu, rt/odommodestate) or sends frames, the loop
#: sleeps once every this many steps (10 ms of sim time: half a period of rt/sportmodestate, the fastest stream
#: left) instead of after every step. The sleep and its wake-up cost more than the step itself; the robot's
#: behaviour in sim time is the same, and what leaves the sim leaves at most that much ahead of the wall clock.
IDLE_BATCH_STEPS = 5
#: A frame this recent (wall s) counts as a stream still being sent: its next frame is due within it.
FRAME_STREAM_GAP_S = 0.1


class SteppableRobot(Protocol):
    dt: float
    time: float

    def step(self, n: int = 1) -> None: ...
    def lowstate(self) -> Any: ...
    def torso_imu(self) -> Any: ...
    def sport_active(self) -> bool: ...
    def odometry(self) -> Any: ...
    def sport_state(self) -> tuple[int, int]: ...
    def arm_task(self) -> tuple[int, float]: ...
    def base_pose(self) -> Any: ...
    def body(self) -> Any: ...


#: ``on_body(sim_time, lowstate, report)`` every BODY_PERIOD_S (lowstate: the snapshot of that step).
BodyHook = Callable[[float, Any, BodyReport], None]
#: ``on_odom(sim_time, estimate)`` for every rt/lf/odommodestate sample (estimate: firmware.odometry's).
OdomHook = Callable[[float, Any], None]
#: ``sport_state()`` -> (fsm_id, fsm_mode) for the next rt/sportmodestate frame.
SportRead = Callable[[], tuple[int, int]]


def _every(rate_hz: float, dt: float) -> int:
    return max(1, round(1.0 / (rate_hz * dt)))


class SimLoop:
    """Runs in its own thread until ``stop()``; an exception ends the loop and is kept in ``error``."""

    def __init__(self, robot: SteppableRobot, publishers: StatePublishers, faults: Faults, pacer: Pacer,
                 *, node: BridgeNode | None = None, stamps: StampClock | None = None,
                 on_body: BodyHook | None = None, on_odom: OdomHook | None = None,
                 sport_state: SportRead | None = None, frames_within: Callable[[float], bool] | None = None) -> None:
        """``frames_within(s)``: a joint frame came in the last s (wall); the loop then paces every step."""
        self._robot = robot
        self._pub = publishers
        self._faults = faults
        self._pacer = pacer
        self._node = node
        self._stamps = stamps or StampClock()
        self._on_body = on_body
        self._on_odom = on_odom
        self._sport_state = sport_state or robot.sport_state
        self._frames_within = frames_within or (lambda _s: False)
        self.rate = RateMeter()
        self.error: BaseException | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="sim", daemon=True)
        dt = robot.dt
        self._low_every = _every(LOWSTATE_RATE_HZ, dt)
        self._sport_every = _every(SPORTMODESTATE_RATE_HZ, dt)
        self._ros_every = _every(ROS_RATE_HZ, dt)
        self._lf_every = _every(LF_LOWSTATE_RATE_HZ, dt)
        self._bms_every = _every(BMSSTATE_RATE_HZ, dt)
        self._body_every = _every(1.0 / BODY_PERIOD_S, dt)
        self._odom_every = _every(ODOMMODESTATE_RATE_HZ, dt)
        self._lf_odom_every = _every(LF_ODOMMODESTATE_RATE_HZ, dt)
        if self._lf_every % self._low_every:
            raise ValueError("rt/lf/lowstate must fall on rt/lowstate frames")
        if self._lf_odom_every % self._odom_every:
            raise ValueError("rt/lf/odommodestate must fall on rt/odommodestate samples")
        self.body = body_report(robot.body(), faults.config)  # the latest report (read by the status service)

    def start(self) -> None:
        self._thread.start()

    def stop(self, timeout_s: float = 5.0) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout_s)

    @property
    def running(self) -> bool:
        return self._thread.is_alive()

    def _run(self) -> None:
        try:
            self._loop()
        except BaseException as e:  # reported by main, which then shuts down
            self.error = e
            log.exception("sim loop failed")

    def _loop(self) -> None:
        robot, pub, faults, node, on_body = self._robot, self._pub, self._faults, self._node, self._on_body
        k = 0
        while not self._stop.is_set():
            robot.step(1)
            k += 1
            t = robot.time
            with faults.held():  # a fault set now applies from the next step on, never within this one
                paused = faults.state_paused
                body_due = k % self._body_every == 0
                if body_due:
                    self.body = body_report(robot.body(), faults.config)
                s = None
                if on_body is not None and body_due:
                    # on the record before any frame that shows this step leaves the sim: a node that reacts to the
                    # frame must find the condition already recorded, however long this thread is preempted here
                    s = robot.lowstate()
                    on_body(t, s, self.body)
                if k % self._low_every == 0 and not (paused or faults.lowstate_frozen):
                    lf = k % self._lf_every == 0
                    if pub.wants_lowstate(also_lf=lf):
                        if s is None:
                            s = robot.lowstate()
                        pub.publish_lowstate(s, self.body, also_lf=lf)
                    else:
                        pub.count_unread("lowstate", also_lf=lf)
                if k % self._low_every == 0 and not paused:
                    if pub.wants_secondary_imu():
                        pub.publish_secondary_imu(robot.torso_imu())
                    else:
                        pub.count_unread("secondary_imu")
                if k % self._odom_every == 0 and not (paused or faults.odom_frozen) and robot.sport_active():
                    lf = k % self._lf_odom_every == 0
                    recorded = lf and self._on_odom is not None
                    # the estimate integrates between samples whatever their rate (firmware.odometry): a sample
                    # nobody reads or records need not be computed
                    if recorded or pub.wants_odom(also_lf=lf):
                        odom = robot.odometry()
                        if recorded:  # on the record before the sample leaves the sim, as the body's
                            self._on_odom(t, odom)
                        pub.publish_odom(t, odom, also_lf=lf)
                    else:
                        pub.count_unread("odommodestate", also_lf=lf)
                if k % self._sport_every == 0 and not paused:
                    pub.publish_sportmodestate(*self._sport_state(), *robot.arm_task())
                if k % self._bms_every == 0 and not paused:
                    pub.publish_bmsstate(self.body)
                if node is not None and k % self._ros_every == 0 and node.publish_ros:
                    self._publish_ros(t, robot.lowstate() if s is None else s)
            self.rate.update(t)
            if k % IDLE_BATCH_STEPS == 0 or self._streaming():
                self._pacer.pace(t)

    def _streaming(self) -> bool:
        """Someone reads a 500 Hz stream or sends frames: the loop keeps the robot's 2 ms cycle step by step."""
        pub = self._pub
        return (pub.wants_lowstate() or pub.wants_secondary_imu() or pub.wants_odom()
                or self._frames_within(FRAME_STREAM_GAP_S))

    def _publish_ros(self, t: float, s: Any) -> None:
        assert self._node is not None
        b = self._robot.base_pose()
        self._node.publish_state(self._stamps.stamp_ns(t), s.q, s.dq, s.tau_est, b.position, b.quaternion,
                                 b.linear_velocity, b.angular_velocity)
