"""The g1_mode_manager node: ROS plumbing around the mode machine, the relays and the robot port."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from g1_mode_manager_msgs.msg import JointCommand, SportModeState
from g1_mode_manager_msgs.msg import Mode as ModeMsg
from g1_mode_manager_msgs.srv import LocoCommand, SetMode
from geometry_msgs.msg import Twist, TwistStamped
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.duration import Duration
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from sensor_msgs.msg import JointState

from g1_mode_manager.core.machine import ModeMachine
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import RobotPort, VoicePort
from g1_mode_manager.core.records import MachineStatus, Result, TransitionRecord
from g1_mode_manager.core.velocity import Velocity
from g1_mode_manager.display.head_led import HeadLed, parse_looks
from g1_mode_manager.node.body_supervision import BodySupervision
from g1_mode_manager.node.diagnostics import build_diagnostics, walk_status
from g1_mode_manager.node.estop import EstopEndpoint
from g1_mode_manager.node.joint_command_cdr import JointCommandReader
from g1_mode_manager.node.odometry import OdometryPublisher
from g1_mode_manager.node.settings import Settings, declare_settings
from g1_mode_manager.node.side_node import SideNode
from g1_mode_manager.node.stream_taker import StreamTaker
from g1_mode_manager.node.twist_cdr import twist_velocity
from g1_mode_manager.relay.arm import ArmRelay
from g1_mode_manager.relay.cmd_vel import CmdVelRelay
from g1_mode_manager.relay.events import RelayEvents
from g1_mode_manager.relay.link_health import LinkHealth
from g1_mode_manager.relay.loco_command import LocoCommands
from g1_mode_manager.relay.lowcmd import LowCmdRelay
from g1_mode_manager.relay.lowstate_demand import LowStateDemand
from g1_mode_manager.relay.periodic import PeriodicWorker
from g1_mode_manager.relay.stamps import stamp_age_s
from g1_mode_manager.relay.user_lowcmd import UserLowCmdRelay
from g1_mode_manager.relay.walk_judge import WalkJudge
from g1_mode_manager.topic_qos import MODE_QOS

PortFactory = Callable[[Settings], RobotPort]


def unitree_port(settings: Settings) -> RobotPort:
    """The real robot port: Unitree SDK2 over Cyclone DDS (connects on the first transition)."""
    from g1_mode_manager.sdk.robot import UnitreeRobot

    return UnitreeRobot(settings.dds_domain, settings.network_interface, rpc_timeout_s=settings.rpc_timeout_s,
                        mode_timeout_s=settings.select_timeout_s, user_ctrl=settings.user_ctrl_config() is not None)


class ModeManagerNode(Node):
    """Serves ~/set_mode, ~/loco_command, ~/estop; relays /cmd_vel, ~/arm_cmd, ~/lowcmd; publishes state.

    Three executors: this node's (parameters only), the services side node's (a thread pool for
    blocking transitions) and the e-stop side node's. The command streams are taken by a thread of
    their own (StreamTaker: cheap at 100 Hz); periodic publications run on plain threads.
    """

    def __init__(self, *, port_factory: PortFactory = unitree_port, node_name: str = "g1_mode_manager",
                 **kwargs) -> None:
        super().__init__(node_name, **kwargs)
        self.settings = s = declare_settings(self)
        self._port = port_factory(s)
        self._mirrored_stamp = 0.0  # monotonic receive time of the last rt/sportmodestate mirrored
        self._events = RelayEvents(self._relay_log)
        self.machine = ModeMachine(
            self._port,
            release_timeout_s=s.release_timeout_s,
            select_timeout_s=s.select_timeout_s,
            estop_timing=s.estop_timing(),
            on_record=self._on_record,
            on_change=self._on_change,
            on_alarm=self._on_alarm,
            user_ctrl=s.user_ctrl_config(),  # None: low_level_path release
        )
        self._publish_lock = threading.Lock()
        self._published_version = -1
        self._restarts_seen = 0
        self._link = LinkHealth(self._port, self.machine, s.link_timeout_s)

        self._mode_pub = self.create_publisher(ModeMsg, "~/mode", MODE_QOS)
        self._sport_pub = self.create_publisher(SportModeState, "~/sportmodestate", 10)
        self._diag_pub = self.create_publisher(DiagnosticArray, "/diagnostics", 10)

        # set_mode may block for seconds (SelectMode on a robot): served on a side node with a thread pool
        # of its own, so the command streams keep their cheap single-threaded executor, and a busy
        # transition refuses further requests at once instead of queueing them.
        # loco commands hold a thread while they wait for the robot to show their outcome (seconds at most)
        self._service_side = SideNode(self, "services", MultiThreadedExecutor(num_threads=6, context=self.context))
        services = ReentrantCallbackGroup()
        self._service_side.node.create_service(SetMode, self._service_side.name_under_main("set_mode"), self._on_set_mode,
                                           callback_group=services)
        self._service_side.node.create_service(LocoCommand, self._service_side.name_under_main("loco_command"),
                                           self._on_loco_command, callback_group=services)

        self._walk = WalkJudge(s.not_walking_after_s)
        self._cmd_vel = CmdVelRelay(self._port, self.machine, self._link, self._events, limits=s.velocity_limits(),
                                    timeout_s=s.cmd_vel_timeout_s, move_duration_s=s.move_duration_s,
                                    rate_hz=s.cmd_vel_rate_hz, max_rate_hz=s.cmd_vel_max_rate_hz,
                                    on_error=self._worker_error, on_acknowledged=self._judge_walk)
        self._odom = OdometryPublisher(self, self._port, lambda: self.machine.mode, frame_id=s.odom_frame_id,
                                       child_frame_id=s.odom_child_frame_id, publish_tf=s.odom_publish_tf,
                                       enabled=s.odom_rate_hz > 0)
        self._arm = ArmRelay(self._port, self.machine, self._link, self._events, ramp_time_s=s.arm_ramp_time_s,
                             silence_timeout_s=s.arm_cmd_timeout_s, kp=s.arm_kp, kd=s.arm_kd,
                             period_s=1.0 / s.arm_rate_hz)
        self._body = BodySupervision(self._port, self.machine, self._events, s, self._worker_error)
        self._body.serve(self._service_side, services)
        self._lowcmd = self._lowcmd_relay(s)
        self._loco = LocoCommands(self._port, self.machine, outcome_timeout_s=s.loco_outcome_timeout_s,
                                  motion_timeout_s=s.loco_motion_timeout_s)
        # lowcmd first: its damping frames are the urgent ones; loco last: it only wakes waiting answers
        for relay in (self._lowcmd, self._arm, self._cmd_vel, self._loco):
            self.machine.add_leave_listener(relay.on_leave)
        # --- cmd_vel relative (a namespace gives each robot its own), Twist or TwistStamped ---
        # The command streams are taken by a thread of their own from a wait set of just them (see
        # stream_taker.py): rclpy's executor rebuilds its wait set in Python for every /cmd_vel.
        self._streams_node = rclpy.create_node(f"{self.get_name()}_streams", namespace=self.get_namespace(),
                                               context=self.context, start_parameter_services=False)
        self._streams = StreamTaker(self._streams_node, "streams", self._worker_error)
        under_main = self.get_fully_qualified_name()
        if s.cmd_vel_stamped:
            self._streams.subscribe(TwistStamped, "cmd_vel", self._on_cmd_vel_stamped)
        else:
            self._streams.subscribe(Twist, "cmd_vel", self._on_cmd_vel, raw=True)  # decoded by twist_cdr
        self._streams.subscribe(JointState, f"{under_main}/arm_cmd", self._on_arm_cmd)
        self._lowcmd_reader = JointCommandReader()
        self._streams.subscribe(JointCommand, f"{under_main}/lowcmd", self._on_lowcmd, raw=True)  # joint_command_cdr

        # Periodic publications run on plain threads, not executor timers (same cost reason as above).
        self._state_out = [PeriodicWorker("mode_publisher", s.mode_publish_rate_hz, self._while_ok(self._publish_mode),
                                          self._worker_error),
                           PeriodicWorker("diagnostics", s.diagnostics_rate_hz, self._while_ok(self._publish_diagnostics),
                                          self._worker_error)]
        if s.odom_rate_hz > 0:
            self._state_out.append(PeriodicWorker("odometry", s.odom_rate_hz, self._while_ok(self._odom.tick),
                                                  self._worker_error))
        if s.sportmodestate_rate_hz > 0:
            self._state_out.append(PeriodicWorker("sportmodestate_mirror", s.sportmodestate_rate_hz,
                                                  self._while_ok(self._mirror_sport_state), self._worker_error))

        self._workers = [
            self._cmd_vel,  # its own sender thread: sends on arrival, keeps Moves alive at cmd_vel_rate_hz
            # both sleep while their stream cannot pass; a command or a mode change wakes them
            PeriodicWorker("arm_relay", s.arm_rate_hz, self._arm.tick, self._worker_error, busy=self._arm.busy),
            PeriodicWorker("lowcmd_relay", s.lowcmd_damping_rate_hz, self._lowcmd.tick, self._worker_error,
                           busy=self._lowcmd.busy),
        ]
        self._arm_worker, self._lowcmd_worker = self._workers[1], self._workers[2]
        if self.machine.user_ctrl_link is not None:  # the hand-over frames start while the worker may sleep
            self.machine.user_ctrl_link.wake = self._lowcmd_worker.wake
        self._lowstate_demand = LowStateDemand(self._port, self.machine, self._arm.busy, self._link.link_ok,
                                               always=s.joint_state_rate_hz > 0)
        self.machine.add_leave_listener(self._wake_workers)  # after the relays': exit damping is due now
        for worker in self._workers:
            worker.start()
        self._estop = EstopEndpoint(self, self.machine.estop_shot, self.machine.estop)
        self._estop.start()
        self._supervisor = PeriodicWorker("supervisor", s.supervise_rate_hz, self._supervise, self._worker_error)
        self._supervisor.start()
        self._body.start()

        # --- the head LED shows the mode. Its own worker *reads* the mode (no leave listener, no
        # machine lock held while it talks to the robot), so a slow voice service never delays an e-stop.
        self._head_led: HeadLed | None = None
        self._head_led_worker: PeriodicWorker | None = None
        if s.head_led_enabled:
            self._head_led = HeadLed(lambda: self.machine.mode, self._voice_port, parse_looks(s.led_looks()),
                                     self._events, announce=s.announce_modes)
            self._head_led_worker = PeriodicWorker("head_led", s.head_led_rate_hz, self._head_led.tick,
                                                   self._worker_error)
            self._head_led_worker.start()

        # --- joint_states and ~/imu from rt/lowstate, decoded only when published ---
        if s.joint_state_rate_hz > 0:
            from g1_mode_manager.node.joint_states import LowStatePublisher

            self._lowstate_pub = LowStatePublisher(self, self._port)
            self._state_out.append(PeriodicWorker("joint_states", s.joint_state_rate_hz,
                                                  self._while_ok(self._lowstate_pub.publish), self._worker_error))
        self._service_side.start()
        self._streams.start()
        for publisher in self._state_out:
            publisher.start()
        self._publish_mode()
        self.get_logger().info(
            f"ready in {self.machine.mode.name}; robot side: interface {s.network_interface!r}, DDS domain "
            f"{s.dds_domain}; e-stop: {self._estop.service_name} and /estop")

    def _lowcmd_relay(self, s: Settings) -> LowCmdRelay:
        """~/lowcmd -> rt/lowcmd (low_level_path release) or rt/user_lowcmd (user_ctrl)."""
        kwargs = dict(silence_timeout_s=s.lowcmd_timeout_s, exit_damping_s=s.lowcmd_exit_damping_s,
                      service_active=lambda: self.machine.status().service_active, deadman=self._body.watch.deadman_held)
        config, link = s.user_ctrl_config(), self.machine.user_ctrl_link
        if config is None or link is None:
            return LowCmdRelay(self._port, self.machine, self._link, self._events, **kwargs)
        return UserLowCmdRelay(self._port, self.machine, self._link, self._events, user_ctrl=link,
                               silence=config.silence, hand_back=self.machine.hand_back_on_silence,
                               hold_kp=config.hold_kp, hold_kd=config.hold_kd, **kwargs)

    def _path_note(self, status: MachineStatus) -> list[str]:
        """~/mode says which path LOW_LEVEL takes while it is, or is about to be, in it (the Mode message has no
        field of its own for it; warnings is the list every client already shows)."""
        target = status.transition_target if status.transition_in_progress else status.mode
        if Mode.LOW_LEVEL not in (status.mode, target):
            return []
        return [f"low_level_path: {self.machine.low_level_path.value}"]

    # --- lifecycle -----------------------------------------------------------------------------
    def shutdown(self) -> None:
        """Hand the robot back safely (arms ramped out, StopMove), stop relays and the e-stop executor, close
        the robot port. Call before destroy_node()."""
        self._streams.shutdown()
        self._streams_node.destroy_node()
        for publisher in self._state_out:
            publisher.stop()
        self._arm.ramp_out()  # bounded: the arm worker still runs and sends the ramp-out frames
        self._body.stop()
        self._supervisor.stop()
        self._lowcmd.at_exit()  # user_ctrl: the robot handed back to its own controller while the hold still goes out
        for worker in self._workers:
            worker.stop()  # the cmd_vel sender sends a StopMove if the robot may be walking
        self._service_side.shutdown()
        self._estop.shutdown()
        if self._head_led_worker is not None and self._head_led is not None:
            self._head_led_worker.stop()
            self._head_led.turn_off()
        self._port.close()

    # --- services ------------------------------------------------------------------------------
    def _on_set_mode(self, request: SetMode.Request, response: SetMode.Response) -> SetMode.Response:
        try:
            if request.mode_name.strip():
                target = Mode.parse(request.mode_name)
            elif request.mode == Mode.UNINITIALIZED:
                raise ValueError("no mode given: set mode_name (e.g. 'high_level') or mode (1 IDLE, 2 HIGH_LEVEL, "
                                 "3 LOW_LEVEL, 4 EMERGENCY); UNINITIALIZED cannot be requested")
            else:
                target = Mode.from_value(request.mode)
        except ValueError as exc:
            self._events.count("set_mode_invalid")
            self.get_logger().warn(f"set_mode refused: {exc}")
            return self._fill_set_mode(response, False, str(exc))
        self._lowstate_demand.update(target)  # LOW_LEVEL and IDLE judge the link by rt/lowstate: receive it now
        outcome = self.machine.request(target)
        return self._fill_set_mode(response, outcome.success, outcome.message)

    def _fill_set_mode(self, response: SetMode.Response, success: bool, message: str) -> SetMode.Response:
        response.success = success
        response.message = message
        response.mode = int(self.machine.mode)
        response.mode_name = self.machine.mode.name
        return response

    def _on_loco_command(self, request: LocoCommand.Request, response: LocoCommand.Response) -> LocoCommand.Response:
        result = self._loco.run(request.command, request.value)
        if result.success:
            self.get_logger().info(f"loco_command: {result.message}")
        else:
            self._events.count("loco_command_refused" if result.code == -1 else "loco_command_failed")
            self.get_logger().warn(f"loco_command {request.command!r}: {result.message}")
        response.success, response.message, response.code = result.success, result.message, result.code
        response.outcome_s = result.outcome_s
        return response

    # --- command streams -------------------------------------------------------------------------
    def _on_cmd_vel(self, data: bytes) -> None:
        self._cmd_vel.submit(*twist_velocity(data))

    def _on_cmd_vel_stamped(self, msg: TwistStamped) -> None:
        """A command older than cmd_vel_timeout_s is dropped and counted (it would restart a robot the
        watchdog already stopped)."""
        age_s = stamp_age_s(self.get_clock().now().nanoseconds, msg.header.stamp.sec, msg.header.stamp.nanosec)
        if age_s > self.settings.cmd_vel_timeout_s:
            self._events.count("cmd_vel_stale_dropped")
            self._events.log("warn", "cmd_vel_stale", f"cmd_vel dropped: stamp {age_s:.3f} s old (cmd_vel_timeout_s "
                             f"{self.settings.cmd_vel_timeout_s:.3f} s)")
            return
        t = msg.twist
        self._cmd_vel.submit(t.linear.x, t.linear.y, t.angular.z)

    def _voice_port(self) -> VoicePort | None:
        """The robot's voice service once the port is connected (ports without one: None)."""
        return self._port.voice(self.settings.voice_timeout_s)

    def _on_arm_cmd(self, msg: JointState) -> None:
        self._arm.submit(list(msg.name), list(msg.position))
        self._lowstate_demand.update()  # the ramp starts from the measured pose
        self._arm_worker.wake()

    def _on_lowcmd(self, data: bytes) -> None:
        self._lowcmd.submit(*self._lowcmd_reader.fields(data))

    # --- state out -------------------------------------------------------------------------------
    def _while_ok(self, publish: Callable[[], None]) -> Callable[[float], None]:
        """A worker step that publishes unless the context is shutting down (SIGINT comes before shutdown())."""

        def step(_dt_s: float) -> None:
            if self.context.ok():
                publish()

        return step

    def _mirror_sport_state(self) -> None:
        """Publish the newest rt/sportmodestate once (stamped with its receive time); a timer, not a
        callback per sample: the robot may publish it at 500 Hz. Nobody subscribed: nothing read or sent."""
        if self._sport_pub.get_subscription_count() == 0:
            return
        state = self._port.sport_state()
        if state is None:
            return
        stamp = time.monotonic() - state.age_s
        if abs(stamp - self._mirrored_stamp) < 1e-4:  # already mirrored
            return
        self._mirrored_stamp = stamp
        received = self.get_clock().now() - Duration(nanoseconds=int(state.age_s * 1e9))
        self._sport_pub.publish(SportModeState(stamp=received.to_msg(), fsm_id=state.fsm_id, fsm_mode=state.fsm_mode,
                                               task_id=state.task_id, task_time=state.task_time))

    def _on_change(self, status: MachineStatus) -> None:
        self._wake_workers()
        self._publish_mode(status)

    def _wake_workers(self, *_leave: object) -> None:
        """A mode change may give a sleeping relay worker something to do (LOW_LEVEL damping, exit damping)."""
        for name in ("_arm_worker", "_lowcmd_worker"):
            worker = getattr(self, name, None)  # None while __init__ runs
            if worker is not None:
                worker.wake()

    def _publish_mode(self, status: MachineStatus | None = None) -> None:
        """Publish a status unless a newer one was published already: ~/mode never goes back in time."""
        with self._publish_lock:
            status = status or self.machine.status()
            if status.version < self._published_version:
                return
            self._published_version = status.version
            self._publish_mode_locked(status)

    def _publish_mode_locked(self, status: MachineStatus) -> None:
        self._mode_pub.publish(ModeMsg(
            stamp=self.get_clock().now().to_msg(),
            mode=int(status.mode),
            name=status.mode.name,
            transition_in_progress=status.transition_in_progress,
            transition_target=int(status.transition_target if status.transition_target is not None else status.mode),
            high_level_service_known=status.service_known,
            high_level_service_active=status.service_active,
            damp_confirmed=status.damp_confirmed,
            link_ok=self._link.link_ok(),
            last_refusal=status.last_refusal,
            last_error=status.last_error,
            robot_mismatch=status.robot_mismatch,
            reasserts=status.reasserts,
            faults=list(status.faults),
            holds=list(status.holds),
            warnings=[*self._body.monitor.warnings(), *self._walk_warning(), *self._path_note(status)],
        ))

    def _judge_walk(self, v: Velocity, sent_at: float) -> None:
        self._walk.acknowledged(v.vx, v.vy, v.wz, sent_at, self._port.odometry())

    def _walk_warning(self) -> list[str]:
        warning = self._walk.report(time.monotonic()).warning
        return [warning] if warning else []

    def _publish_diagnostics(self) -> None:
        status, name = self.machine.status(), self.get_fully_qualified_name()
        array = build_diagnostics(self.get_clock().now().to_msg(), name, status, self._link.report(),
                                  self._events.counts())
        array.status.extend(self._body.diagnostics(name, status.mode))
        array.status.append(self._odom.status(name))
        array.status.append(walk_status(self._walk.report(time.monotonic()), name))
        self._diag_pub.publish(array)

    # --- logging ---------------------------------------------------------------------------------
    def _on_record(self, record: TransitionRecord) -> None:
        text = (f"transition {record.source.name} -> {record.target.name}: {record.outcome.value} in "
                f"{record.duration_s * 1000:.0f} ms: {record.message}")
        if record.outcome is Result.OK:
            self.get_logger().info(text)
        elif record.outcome in (Result.REFUSED, Result.REGISTERED):
            self.get_logger().warn(text)
        else:
            self.get_logger().error(text)

    def _on_alarm(self, text: str) -> None:
        self._events.count("supervision_alarms")
        self.get_logger().error(text)

    def _supervise(self, _dt_s: float) -> None:
        """Check the robot against the mode: EMERGENCY re-damped if seen out of damping, a mismatch
        (another program, a reboot seen in rt/lowstate's tick) stops forwarding. Then rt/lowstate is
        subscribed or not as needed (LowStateDemand)."""
        restarts = self._port.lowstate_restarts()
        if restarts > self._restarts_seen:
            self._restarts_seen = restarts
            self.machine.report_mismatch("the robot restarted (rt/lowstate tick went back)")
        state = self._port.sport_state()
        if state is None:
            self.machine.supervise()
        else:
            self.machine.supervise(state.fsm_id, state.age_s)
        self._lowstate_demand.update()

    def _relay_log(self, level: str, text: str) -> None:
        logger = self.get_logger()
        # one call site per severity: rclpy refuses a second severity from the same line
        if level == "info":
            logger.info(text)
        elif level == "warn":
            logger.warn(text)
        else:
            logger.error(text)

    def _worker_error(self, exc: BaseException) -> None:
        self._events.count("relay_errors")
        self.get_logger().error(f"relay error (relay keeps running): {exc!r}")
