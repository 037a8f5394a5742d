"""The command streams the node takes: cmd_vel and the autonomy's (Twist or TwistStamped), ~/arm_cmd, ~/lowcmd.

They are taken by a thread of their own from a wait set of just them (see stream_taker.py): rclpy's executor
rebuilds its wait set in Python for every /cmd_vel. cmd_vel and the autonomy's topic are relative (a namespace
gives each robot its own);
~/arm_cmd and ~/lowcmd carry the main node's name. Each message is handed to its relay, which decides under
the forward gate whether it passes.
"""

from __future__ import annotations

import rclpy
from g1_mode_manager_msgs.msg import JointCommand
from geometry_msgs.msg import Twist, TwistStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState

from g1_mode_manager.node.joint_command_cdr import JointCommandReader
from g1_mode_manager.node.parts import Parts
from g1_mode_manager.node.settings import Settings
from g1_mode_manager.node.stream_taker import StreamTaker
from g1_mode_manager.node.twist_cdr import twist_velocity
from g1_mode_manager.relay.stamps import stamp_age_s


class CommandStreams:
    """Subscribes on a node of its own; ``start`` starts the taker thread, ``shutdown`` stops it."""

    def __init__(self, main: Node, settings: Settings, parts: Parts) -> None:
        self._clock = main.get_clock()
        self._cmd_vel_timeout_s = settings.cmd_vel_timeout_s
        self._autonomy_timeout_s = settings.autonomy_timeout_s
        self._parts = parts
        self._node = rclpy.create_node(f"{main.get_name()}_streams", namespace=main.get_namespace(),
                                       context=main.context, start_parameter_services=False)
        self._taker = StreamTaker(self._node, "streams", parts.log.worker_error)
        under_main = main.get_fully_qualified_name()
        if settings.cmd_vel_stamped:
            self._taker.subscribe(TwistStamped, "cmd_vel", self._on_cmd_vel_stamped)
        else:
            self._taker.subscribe(Twist, "cmd_vel", self._on_cmd_vel, raw=True)  # decoded by twist_cdr
        if settings.autonomy_topic and settings.autonomy_stamped:
            self._taker.subscribe(TwistStamped, settings.autonomy_topic, self._on_autonomy_stamped)
        elif settings.autonomy_topic:
            self._taker.subscribe(Twist, settings.autonomy_topic, self._on_autonomy, raw=True)
        self._taker.subscribe(JointState, f"{under_main}/arm_cmd", self._on_arm_cmd)
        self._lowcmd_reader = JointCommandReader()
        self._taker.subscribe(JointCommand, f"{under_main}/lowcmd", self._on_lowcmd, raw=True)  # joint_command_cdr

    def start(self) -> None:
        self._taker.start()

    def shutdown(self) -> None:
        self._taker.shutdown()
        self._node.destroy_node()

    def _on_cmd_vel(self, data: bytes) -> None:
        self._velocity(*twist_velocity(data))

    def _on_cmd_vel_stamped(self, msg: TwistStamped) -> None:
        if self._fresh(msg, "cmd_vel", self._cmd_vel_timeout_s):
            t = msg.twist
            self._velocity(t.linear.x, t.linear.y, t.angular.z)

    def _velocity(self, vx: float, vy: float, wz: float) -> None:
        """The teleop's velocity: to the policy while one drives the robot in LOW_LEVEL, else to LocoClient."""
        policy = self._parts.policy
        if policy.takes_velocity():
            policy.offer_velocity(vx, vy, wz)
        else:
            self._parts.cmd_vel.submit(vx, vy, wz)

    def _on_autonomy(self, data: bytes) -> None:
        sources = self._parts.cmd_vel.sources
        sources.offer(sources.autonomy, *twist_velocity(data))

    def _on_autonomy_stamped(self, msg: TwistStamped) -> None:
        if self._fresh(msg, "autonomy", self._autonomy_timeout_s):
            t, sources = msg.twist, self._parts.cmd_vel.sources
            sources.offer(sources.autonomy, t.linear.x, t.linear.y, t.angular.z)

    def _fresh(self, msg: TwistStamped, key: str, timeout_s: float) -> bool:
        """A command older than its source's timeout is dropped and counted (it would restart a robot the
        watchdog already stopped)."""
        age_s = stamp_age_s(self._clock.now().nanoseconds, msg.header.stamp.sec, msg.header.stamp.nanosec)
        if age_s <= timeout_s:
            return True
        events = self._parts.log.events
        events.count(f"{key}_stale_dropped")
        events.log("warn", f"{key}_stale", f"{key} dropped: stamp {age_s:.3f} s old (timeout {timeout_s:.3f} s)")
        return False

    def _on_arm_cmd(self, msg: JointState) -> None:
        self._parts.arm.submit(list(msg.name), list(msg.position))
        self._parts.lowstate_demand.update()  # the ramp starts from the measured pose
        self._parts.arm_worker.wake()

    def _on_lowcmd(self, data: bytes) -> None:
        if self._parts.policy.owns_low_level():  # two writers would interleave their frames on the robot
            events = self._parts.log.events
            events.count("lowcmd_refused_policy")
            events.log("warn", "lowcmd_policy", "~/lowcmd refused: a policy runs in LOW_LEVEL (~/policy/disengage)")
            return
        block = self._lowcmd_reader.block(data)
        if block is not None:
            self._parts.lowcmd.submit_block(*block)
        else:
            self._parts.lowcmd.submit(*self._lowcmd_reader.fields(data))
