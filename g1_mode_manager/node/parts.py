"""The node's robot-side parts, each built once and named: the mode machine and what reads it or goes through
its forward gate (relays and their workers, loco commands, the supervisor, the body watch, the policy's remote
keys, the head LED).

Each is built from parts built before it, so none has to ask whether another exists yet; the node's ROS side
(what it publishes, serves and takes) is built after them, in wiring.py.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from g1_mode_manager.core.body.motion_allowance import MotionRecord
from g1_mode_manager.core.controller.interface import Controller
from g1_mode_manager.core.drive import Driver
from g1_mode_manager.core.events import RelayEvents
from g1_mode_manager.core.machine import ModeMachine
from g1_mode_manager.core.port import RobotPort
from g1_mode_manager.core.records import MachineStatus
from g1_mode_manager.display.head_led import HeadLed, LedLook, parse_looks
from g1_mode_manager.flight_recorder.flight_recorder import FlightRecorder
from g1_mode_manager.node.body_supervision import BodySupervision
from g1_mode_manager.node.node_log import NodeLog
from g1_mode_manager.node.settings import Settings, parse_keys
from g1_mode_manager.node.supervisor import RobotSupervisor
from g1_mode_manager.policy_loop.policy_keys import KeyCombo, PolicyKeys
from g1_mode_manager.policy_loop.policy_runner import PolicyRunner
from g1_mode_manager.relay.arm import ArmRelay
from g1_mode_manager.relay.autonomy_conditions import AutonomyConditions
from g1_mode_manager.relay.cmd_vel import AutonomyInput, CmdVelRelay
from g1_mode_manager.relay.link_health import LinkHealth
from g1_mode_manager.relay.loco_command import LocoCommands
from g1_mode_manager.relay.lowcmd import LowCmdRelay
from g1_mode_manager.relay.lowstate_demand import LowStateDemand
from g1_mode_manager.relay.periodic import PeriodicWorker
from g1_mode_manager.relay.user_lowcmd import UserLowCmdRelay
from g1_mode_manager.relay.walk_judge import WalkJudge


@dataclass(frozen=True)
class Parts:
    """Each part by name; the ROS side reads what it needs from here."""

    port: RobotPort
    log: NodeLog
    machine: ModeMachine
    link: LinkHealth
    walk: WalkJudge
    cmd_vel: CmdVelRelay  # with its own sender thread: sends on arrival, keeps Moves alive at cmd_vel_rate_hz
    arm: ArmRelay
    arm_worker: PeriodicWorker  # the arm and lowcmd workers sleep while their stream cannot pass
    lowcmd: LowCmdRelay
    lowcmd_worker: PeriodicWorker
    policy: PolicyRunner  # a controller in the node's own loop, its frames through the lowcmd relay
    policy_worker: PeriodicWorker
    policy_keys: PolicyKeys | None  # the remote's keys for the policy on the body watch's thread, or None (both off)
    loco: LocoCommands
    lowstate_demand: LowStateDemand
    supervisor: PeriodicWorker
    body: BodySupervision
    head_led: HeadLed | None  # with its worker, or neither (head_led_enabled false)
    head_led_worker: PeriodicWorker | None
    recorder: FlightRecorder  # the node's own past, on every robot call (``port`` records) and the parts' hooks

    def wake_relay_workers(self, *_change: object) -> None:
        """A mode change may give a sleeping relay worker something to do (LOW_LEVEL damping, exit damping)."""
        self.arm_worker.wake()
        self.lowcmd_worker.wake()
        self.policy_worker.wake()


def build_parts(settings: Settings, port: RobotPort, log: NodeLog, on_change: Callable[[MachineStatus], None],
                recorder: FlightRecorder) -> Parts:
    """Build the parts (nothing started yet); ``on_change`` is the machine's change listener."""
    s = settings
    events, on_error = log.events, log.worker_error
    machine = ModeMachine(port, release_timeout_s=s.release_timeout_s, select_timeout_s=s.select_timeout_s,
                          estop_timing=s.estop_timing(), on_record=log.record, on_change=on_change, on_alarm=log.alarm,
                          user_ctrl=s.user_ctrl_config())  # None: low_level_path release
    link = LinkHealth(port, machine, s.link_timeout_s)
    walk = WalkJudge(s.not_walking_after_s)
    autonomy = None if not s.autonomy_topic else AutonomyInput(s.autonomy_topic, s.autonomy_limits(),
                                                                s.autonomy_timeout_s)
    cmd_vel = CmdVelRelay(port, machine, link, events, limits=s.velocity_limits(), timeout_s=s.cmd_vel_timeout_s,
                          move_duration_s=s.move_duration_s, rate_hz=s.cmd_vel_rate_hz,
                          max_rate_hz=s.cmd_vel_max_rate_hz, on_error=on_error,
                          on_acknowledged=lambda v, sent_at: walk.acknowledged(v.vx, v.vy, v.wz, sent_at,
                                                                               port.odometry()),
                          autonomy=autonomy,
                          autonomy_blocked=AutonomyConditions(port, lambda: machine.status().holds, walk,
                                                              odom_timeout_s=s.autonomy_odom_timeout_s))
    arm = ArmRelay(port, machine, link, events, ramp_time_s=s.arm_ramp_time_s, silence_timeout_s=s.arm_cmd_timeout_s,
                   kp=s.arm_kp, kd=s.arm_kd, period_s=1.0 / s.arm_rate_hz)
    # what a tracking policy's motion asks for, noted by its ticks and read by the body checks
    thresholds = s.body_thresholds()
    motion = MotionRecord(thresholds["joint_speed"], thresholds["spin"])
    body = BodySupervision(port, machine, events, s, on_error, motion)
    lowcmd = _lowcmd_relay(s, port, machine, link, events, deadman=body.watch.deadman_held)
    policy = PolicyRunner(port, machine, lowcmd, events, loader=lambda name: _load_policy(name, s),
                          limits=s.policy_limits(), velocity_limits=s.velocity_limits(),
                          cmd_vel_timeout_s=s.cmd_vel_timeout_s, hold_gains=(s.user_ctrl_hold_kp, s.user_ctrl_hold_kd),
                          motion=motion)
    policy_keys = _policy_keys(s, policy, body, log)
    loco = LocoCommands(port, machine, outcome_timeout_s=s.loco_outcome_timeout_s,
                        motion_timeout_s=s.loco_motion_timeout_s, get_up_timeout_s=s.loco_get_up_timeout_s,
                        posture=lambda: body.watch.posture)
    # lowcmd first: its damping frames are the urgent ones; loco last: it only wakes waiting answers
    for relay in (lowcmd, policy, arm, cmd_vel, loco):
        machine.add_leave_listener(relay.on_leave)
    # a policy reads rt/lowstate from its shadow on, as the arms' ramp does
    lowstate_demand = LowStateDemand(port, machine, lambda: arm.busy() or policy.ticking(), link.link_ok,
                                     always=s.joint_state_rate_hz > 0)
    # The head LED's own worker *reads* the mode (no leave listener, no machine lock held while it talks to the
    # robot), so a slow voice service never delays an e-stop.
    head_led = head_led_worker = None
    if s.head_led_enabled:
        head_led = HeadLed(lambda: machine.mode, lambda: port.voice(s.voice_timeout_s), parse_looks(s.led_looks()),
                           events, announce=s.announce_modes, autonomy_look=LedLook.parse(s.head_led_autonomy),
                           autonomy_drives=lambda: cmd_vel.sources.driving(machine.mode).driver is Driver.AUTONOMY)
        head_led_worker = PeriodicWorker("head_led", s.head_led_rate_hz, head_led.tick, on_error)
    parts = Parts(
        port=port, log=log, machine=machine, link=link, walk=walk, cmd_vel=cmd_vel, arm=arm,
        arm_worker=PeriodicWorker("arm_relay", s.arm_rate_hz, arm.tick, on_error, busy=arm.busy),
        lowcmd=lowcmd,
        lowcmd_worker=PeriodicWorker("lowcmd_relay", s.lowcmd_damping_rate_hz, lowcmd.tick, on_error,
                                     busy=lowcmd.busy),
        policy=policy, policy_keys=policy_keys,
        policy_worker=PeriodicWorker("policy_loop", 50.0, policy.tick, on_error, busy=policy.ticking,
                                     period_s=policy.period_s),
        loco=loco, lowstate_demand=lowstate_demand,
        supervisor=PeriodicWorker("supervisor", s.supervise_rate_hz,
                                  RobotSupervisor(port, machine, lowstate_demand).step, on_error),
        body=body, head_led=head_led, head_led_worker=head_led_worker, recorder=recorder,
    )
    machine.add_leave_listener(parts.wake_relay_workers)  # after the relays': exit damping is due now
    policy.wake = parts.policy_worker.wake
    if machine.user_ctrl_link is not None:  # the hand-over frames start while the lowcmd worker may sleep
        machine.user_ctrl_link.wake = parts.lowcmd_worker.wake
    return parts


def _lowcmd_relay(s: Settings, port: RobotPort, machine: ModeMachine, link: LinkHealth, events: RelayEvents, *,
                  deadman: Callable[[], bool]) -> LowCmdRelay:
    """~/lowcmd -> rt/lowcmd (low_level_path release) or rt/user_lowcmd (user_ctrl)."""
    kwargs = dict(silence_timeout_s=s.lowcmd_timeout_s, exit_damping_s=s.lowcmd_exit_damping_s,
                  service_active=lambda: machine.status().service_active, deadman=deadman)
    config, user_ctrl = s.user_ctrl_config(), machine.user_ctrl_link
    if config is None or user_ctrl is None:
        return LowCmdRelay(port, machine, link, events, **kwargs)
    return UserLowCmdRelay(port, machine, link, events, user_ctrl=user_ctrl, silence=config.silence,
                           hand_back=machine.hand_back_on_silence, hold_kp=config.hold_kp, hold_kd=config.hold_kd,
                           first_frame_s=config.first_frame_s, **kwargs)


def _policy_keys(s: Settings, policy: PolicyRunner, body: BodySupervision, log: NodeLog) -> PolicyKeys | None:
    """The policy's remote keys, looked at after each body watch step (a phase read while no policy is loaded), or
    None when both are off. Logged unthrottled: every press and its answer are the operator's to read."""
    engage, disengage = (KeyCombo(text, parse_keys(text)) for text in (s.policy_engage_keys, s.policy_disengage_keys))
    if not engage.mask and not disengage.mask:
        return None
    keys = PolicyKeys(policy, body.watch.fresh_keys, log.relay, engage=engage, disengage=disengage,
                      estop=KeyCombo(s.remote_estop_keys, parse_keys(s.remote_estop_keys)))
    body.on_step = keys.look
    return keys


def _load_policy(name: str, s: Settings) -> Controller:
    """onnxruntime is imported with the first policy loaded, not with every node."""
    from g1_mode_manager.policy.loader import load_policy

    return load_policy(name, s.policy_models())
