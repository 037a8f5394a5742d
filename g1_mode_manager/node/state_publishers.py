"""What the node publishes: ~/mode, /diagnostics, the ~/sportmodestate mirror, odom, joint_states and ~/imu.

Each runs on a plain thread (a PeriodicWorker), not an executor timer: rclpy's executor costs Python per
wake-up. ~/mode is published at every change of the machine and of the driver as it happens, at every other
change of what it carries (holds, warnings, the autonomy's state, the link) within 1 / mode_change_check_hz,
and besides at mode_publish_rate_hz; it never goes back in time.
"""

from __future__ import annotations

import re
import threading
import time
from collections.abc import Callable

from diagnostic_msgs.msg import DiagnosticArray
from g1_mode_manager_msgs.msg import Mode as ModeMsg
from g1_mode_manager_msgs.msg import SportModeState
from rclpy.duration import Duration
from rclpy.node import Node

from g1_mode_manager.core.records import MachineStatus
from g1_mode_manager.node.diagnostics import build_diagnostics, drive_status, policy_status, recorder_status, walk_status
from g1_mode_manager.node.odometry import OdometryPublisher
from g1_mode_manager.node.parts import Parts
from g1_mode_manager.node.settings import Settings
from g1_mode_manager.relay.drive_sources import Driving
from g1_mode_manager.relay.periodic import PeriodicWorker
from g1_mode_manager.topic_qos import MODE_QOS


class StatePublishers:
    """The publishers and their workers; ``publish_mode(status)`` is the machine's change listener."""

    def __init__(self, node: Node, settings: Settings, parts: Parts) -> None:
        s, port, machine = settings, parts.port, parts.machine
        self._node = node
        self._parts = parts
        self._publish_lock = threading.Lock()
        self._published_version = -1
        self._published_content: tuple[object, ...] | None = None  # what the last ~/mode said (see _publish)
        self._mirrored_stamp = 0.0  # monotonic receive time of the last rt/sportmodestate mirrored
        self._mode_pub = node.create_publisher(ModeMsg, "~/mode", MODE_QOS)
        self._sport_pub = node.create_publisher(SportModeState, "~/sportmodestate", 10)
        self._diag_pub = node.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self._odom = OdometryPublisher(node, port, lambda: machine.mode, frame_id=s.odom_frame_id,
                                       child_frame_id=s.odom_child_frame_id, publish_tf=s.odom_publish_tf,
                                       enabled=s.odom_rate_hz > 0)
        self._workers = [self._worker("mode_publisher", s.mode_publish_rate_hz, self.publish_mode),
                         self._worker("mode_changes", s.mode_change_check_hz, self._publish_mode_if_changed),
                         self._worker("diagnostics", s.diagnostics_rate_hz, self._publish_diagnostics)]
        if s.odom_rate_hz > 0:
            self._workers.append(self._worker("odometry", s.odom_rate_hz, self._odom.tick))
        if s.sportmodestate_rate_hz > 0:
            self._workers.append(self._worker("sportmodestate_mirror", s.sportmodestate_rate_hz,
                                              self._mirror_sport_state))
        if s.joint_state_rate_hz > 0:  # joint_states and ~/imu from rt/lowstate, decoded only when published
            from g1_mode_manager.node.joint_states import LowStatePublisher

            self._workers.append(self._worker("joint_states", s.joint_state_rate_hz,
                                              LowStatePublisher(node, port).publish))

    def start(self) -> None:
        for worker in self._workers:
            worker.start()

    def stop(self) -> None:
        for worker in self._workers:
            worker.stop()

    def _worker(self, name: str, rate_hz: float, publish: Callable[[], None]) -> PeriodicWorker:
        """A worker that publishes unless the context is shutting down (SIGINT comes before shutdown())."""

        def step(_dt_s: float) -> None:
            if self._node.context.ok():
                publish()

        return PeriodicWorker(name, rate_hz, step, self._parts.log.worker_error)

    # --- ~/mode ----------------------------------------------------------------------------------
    def publish_mode(self, status: MachineStatus | None = None) -> None:
        """Publish a status unless a newer one was published already: ~/mode never goes back in time."""
        self._publish(status, only_if_changed=False)

    def _publish_mode_if_changed(self) -> None:
        self._publish(None, only_if_changed=True)

    def _publish(self, status: MachineStatus | None, *, only_if_changed: bool) -> None:
        with self._publish_lock:
            status = status or self._parts.machine.status()
            if status.version < self._published_version:
                return
            link_ok = self._parts.link.link_ok(status.mode)
            driving = self._parts.cmd_vel.sources.driving(status.mode)
            warnings = [*self._parts.body.monitor.warnings(), *self._walk_warning(), *self._parts.recorder.warnings()]
            posture = self._parts.body.watch.posture.posture
            # what counts as a change: a figure inside a text (an age, a measured speed) does not
            content = (status, link_ok, driving.driver, _shape(driving.autonomy_suspended), tuple(map(_shape, warnings)),
                       posture)
            if only_if_changed and content == self._published_content:
                return
            self._published_version, self._published_content = status.version, content
            msg = self._mode_message(status, link_ok, driving, warnings, posture.value)
            msg.stamp = self._node.get_clock().now().to_msg()
            self._mode_pub.publish(msg)

    def _mode_message(self, status: MachineStatus, link_ok: bool, driving: Driving, warnings: list[str],
                      posture: str) -> ModeMsg:
        return ModeMsg(
            mode=int(status.mode),
            name=status.mode.name,
            transition_in_progress=status.transition_in_progress,
            transition_target=int(status.transition_target if status.transition_target is not None else status.mode),
            high_level_service_known=status.service_known,
            high_level_service_active=status.service_active,
            damp_confirmed=status.damp_confirmed,
            link_ok=link_ok,
            low_level_path=self._parts.machine.low_level_path.value,
            driver=driving.driver.value,
            autonomy_suspended=driving.autonomy_suspended,
            last_refusal=status.last_refusal,
            last_error=status.last_error,
            robot_mismatch=status.robot_mismatch,
            reasserts=status.reasserts,
            faults=list(status.faults),
            holds=list(status.holds),
            warnings=warnings,
            posture=posture,
        )

    def _walk_warning(self) -> list[str]:
        warning = self._parts.walk.report(time.monotonic()).warning
        return [warning] if warning else []

    # --- /diagnostics and ~/sportmodestate ---------------------------------------------------------
    def _publish_diagnostics(self) -> None:
        p = self._parts
        status, name = p.machine.status(), self._node.get_fully_qualified_name()
        array = build_diagnostics(self._node.get_clock().now().to_msg(), name, status, p.link.report(),
                                  p.log.events.counts())
        array.status.extend(p.body.diagnostics(name, status.mode))
        array.status.append(self._odom.status(name))
        array.status.append(walk_status(p.walk.report(time.monotonic()), name))
        array.status.append(drive_status(p.cmd_vel.sources.driving(status.mode), name))
        array.status.append(policy_status(p.policy, name))
        array.status.append(recorder_status(p.recorder.report(), name))
        self._diag_pub.publish(array)

    def _mirror_sport_state(self) -> None:
        """Publish the newest rt/sportmodestate once (stamped with its receive time); a timer, not a
        callback per sample: the robot may publish it at 500 Hz. Nobody subscribed: nothing read or sent."""
        if self._sport_pub.get_subscription_count() == 0:
            return
        state = self._parts.port.sport_state()
        if state is None:
            return
        stamp = time.monotonic() - state.age_s
        if abs(stamp - self._mirrored_stamp) < 1e-4:  # already mirrored
            return
        self._mirrored_stamp = stamp
        received = self._node.get_clock().now() - Duration(nanoseconds=int(state.age_s * 1e9))
        self._sport_pub.publish(SportModeState(stamp=received.to_msg(), fsm_id=state.fsm_id, fsm_mode=state.fsm_mode,
                                               task_id=state.task_id, task_time=state.task_time))


def _shape(text: str) -> str:
    """A text with its figures blanked: "battery_low: 18 % < 20" and "battery_low: 17 % < 20" are one warning."""
    return re.sub(r"\d+(\.\d+)?", "#", text)
