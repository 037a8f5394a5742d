"""The policy's ROS side: ~/policy/load (LoadPolicy), ~/policy/shadow, ~/policy/engage, ~/policy/disengage,
~/policy/hold and ~/policy/unload (std_srvs/Trigger) on the services' side node; ~/policy/status (PolicyStatus) at
every change of phase and at 2 Hz while the loop ticks, and ~/policy/targets (sensor_msgs/JointState: the targets
of the latest tick, beside the measured joints of joint_states) while the loop ticks."""

from __future__ import annotations

import traceback
from collections import deque

from g1_mode_manager_msgs.msg import PolicyStatus
from g1_mode_manager_msgs.srv import LoadPolicy
from rclpy.callback_groups import CallbackGroup
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger

from g1_mode_manager.node.side_node import SideNode
from g1_mode_manager.policy_loop.policy_runner import DisengageTo, PolicyRunner
from g1_mode_manager.protocol.motors import JOINT_NAMES
from g1_mode_manager.relay.periodic import PeriodicWorker
from g1_mode_manager.topic_qos import MODE_QOS

#: ~/policy/targets and the status' change check, Hz (the policy ticks at 50: every second tick is shown).
PUBLISH_RATE_HZ = 25.0
#: ~/policy/status at least this often while the loop ticks, s.
STATUS_PERIOD_S = 0.5


class PolicyEndpoints:
    def __init__(self, main: Node, side: SideNode, group: CallbackGroup, runner: PolicyRunner, default: str,
                 on_error: object) -> None:
        self._log = main.get_logger()
        self._runner = runner
        self._default = default
        self._clock = main.get_clock()
        node = side.node
        node.create_service(LoadPolicy, side.name_under_main("policy/load"), self._on_load, callback_group=group)
        for name, verb in (("shadow", runner.start_shadow), ("engage", runner.engage),
                           ("disengage", runner.disengage), ("hold", lambda: runner.disengage(DisengageTo.HOLD)),
                           ("unload", runner.unload)):
            node.create_service(Trigger, side.name_under_main(f"policy/{name}"), self._trigger(name, verb),
                                callback_group=group)
        self._status_pub = main.create_publisher(PolicyStatus, "~/policy/status", MODE_QOS)  # latched, as ~/mode
        self._targets_pub = main.create_publisher(JointState, "~/policy/targets", 10)
        self._published: tuple[str, str] | None = None
        self._status_at = float("-inf")
        self._targets_at = float("-inf")
        # asleep while the loop does not tick (every node has one; few run a policy): a verb's answer and a change
        # of phase wake it
        self._worker = PeriodicWorker("policy_publisher", PUBLISH_RATE_HZ, self._publish, on_error,  # type: ignore[arg-type]
                                      busy=self._due)
        runner.on_phase_change = self._worker.wake

    def start(self) -> None:
        self._worker.start()

    def stop(self) -> None:
        self._worker.stop()

    def _on_load(self, request: LoadPolicy.Request, response: LoadPolicy.Response) -> LoadPolicy.Response:
        policy = request.policy.strip() or self._default
        response.success, response.message = self._runner.load(policy)
        self._answered("load", response.success, response.message)
        return response

    def _trigger(self, name: str, verb: object):
        def callback(_request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
            self._log.info(f"policy/{name} requested")
            try:
                response.success, response.message = verb()  # type: ignore[operator]
            except Exception as exc:  # an answer, always: a callback that raises leaves its caller waiting forever
                self._log.error(f"policy/{name} failed: {type(exc).__name__}: {exc}\n{traceback.format_exc()}")
                response.success, response.message = False, f"policy/{name} failed: {type(exc).__name__}: {exc}"
            self._answered(name, response.success, response.message)
            return response
        return callback

    def _answered(self, verb: str, success: bool, message: str) -> None:
        # one call site per severity: rclpy raises when a call site's severity changes, and a raising service
        # callback never answers its caller
        if success:
            self._log.info(f"policy/{verb}: {message}")
        else:
            self._log.warning(f"policy/{verb}: {message}")
        self._publish()
        self._worker.wake()  # the loop may tick now: its status and targets are due

    def _due(self) -> bool:
        controller = self._runner.controller
        return self._runner.ticking() or self._published != ("" if controller is None else controller.name,
                                                             self._runner.phase.value)

    def _publish(self, _dt_s: float = 0.0) -> None:
        r = self._runner
        controller = r.controller
        now_ns = self._clock.now().nanoseconds
        key = ("" if controller is None else controller.name, r.phase.value)
        now = now_ns * 1e-9
        if key != self._published or (r.ticking() and now - self._status_at >= STATUS_PERIOD_S):
            self._published, self._status_at = key, now
            self._status_pub.publish(self._status(key, now_ns))
        shadow = r.shadow
        if r.ticking() and shadow.at > self._targets_at:
            self._targets_at = shadow.at
            msg = JointState(name=list(JOINT_NAMES), position=shadow.targets.tolist())
            msg.header.stamp = self._clock.now().to_msg()
            self._targets_pub.publish(msg)

    def _status(self, key: tuple[str, str], now_ns: int) -> PolicyStatus:
        r, stats = self._runner, self._runner.stats
        msg = PolicyStatus(policy=key[0], phase=key[1], ticks=stats.ticks, overruns=stats.overruns,
                           skipped=stats.skipped, last_fault=r.last_fault)
        msg.stamp.sec, msg.stamp.nanosec = divmod(now_ns, 1_000_000_000)
        ticking = r.ticking()
        msg.rate_hz = stats.rate_hz() if ticking else 0.0
        msg.inference_p99_ms = stats.p99(stats.inference_s) * 1e3
        msg.tick_p99_ms = stats.p99(stats.tick_s) * 1e3
        msg.blend = r.blend_progress()
        progress = None if r.controller is None else r.controller.progress()
        msg.progress = -1.0 if progress is None else progress
        shadow = r.shadow
        msg.max_target_error_rad = float(abs(shadow.targets - shadow.measured).max()) if ticking else 0.0
        msg.tracking_error_rad = -1.0 if shadow.tracking_error_rad is None else shadow.tracking_error_rad
        msg.action_scale = "" if r.controller is None else r.controller.action_scale_rule
        ages = stats.percentiles(stats.state_to_frame_s, 50, 99, 100)
        msg.state_to_frame_p50_ms, msg.state_to_frame_p99_ms, msg.state_to_frame_max_ms = (a * 1e3 for a in ages)
        period = 1.0 / r.controller.rate_hz if r.controller is not None else 0.02
        msg.frame_period_p50_ms = stats.percentiles(stats.frame_gaps_s, 50)[0] * 1e3
        jitter = deque(abs(g - period) for g in stats.frame_gaps_s)
        msg.frame_jitter_p99_ms, msg.frame_jitter_max_ms = (j * 1e3 for j in stats.percentiles(jitter, 99, 100))
        msg.clamps = r.clamp.counts.tolist() if r.clamp.counts.any() else []
        return msg
