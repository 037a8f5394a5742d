"""The e-stop endpoints, on their own node and executor so that they always get through.

The main node's executor threads may all be busy (a slow SelectMode, a flood of service calls); the
e-stop service and topic are served by a separate executor with threads of its own and call the mode
machine's estop(), which fires its DampNoReply before anything else and never waits for a transition
in flight. Several requests at once each fire their own DampNoReply and then join the one damping
sequence that runs (the machine coalesces them), so none queues behind another's sequence.
"""

from __future__ import annotations

from collections.abc import Callable

from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import Bool
from std_srvs.srv import Trigger

from g1_mode_manager.core.records import Outcome
from g1_mode_manager.node.side_node import SideNode

#: /estop: a BEST_EFFORT subscription matches RELIABLE and BEST_EFFORT publishers alike (hardware
#: buttons and micro-ROS bridges usually publish best effort; a RELIABLE one would never hear them).
ESTOP_TOPIC_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
#: Service requests handled at once; more wait for a thread (each holds one only while its sequence runs).
ESTOP_THREADS = 4

EstopCall = Callable[..., Outcome]


class EstopEndpoint:
    """Serves `<main node>/estop` (std_srvs/Trigger) and listens to `/estop` (std_msgs/Bool, true = stop)."""

    def __init__(self, main: Node, estop: EstopCall) -> None:
        self._estop = estop
        self._log = main.get_logger()
        self._side = SideNode(main, "estop", MultiThreadedExecutor(num_threads=ESTOP_THREADS, context=main.context))
        group = ReentrantCallbackGroup()
        self.service_name = self._side.name_under_main("estop")
        self._side.node.create_service(Trigger, self.service_name, self._on_trigger, callback_group=group)
        self._side.node.create_subscription(Bool, "/estop", self._on_topic, ESTOP_TOPIC_QOS, callback_group=group)

    def start(self) -> None:
        self._side.start()

    def shutdown(self) -> None:
        self._side.shutdown()

    def _on_trigger(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        outcome = self._estop()  # the DampNoReply is out before anything is logged
        self._report(self.service_name, outcome)
        response.success = outcome.success
        response.message = outcome.message
        return response

    def _on_topic(self, msg: Bool) -> None:
        if msg.data:
            # a topic has nobody to answer: register at once, the sequence runs in the machine's thread
            outcome = self._estop(wait=False)
            self._log.warn(f"E-STOP requested via /estop topic: {outcome.message}")

    def _report(self, source: str, outcome: Outcome) -> None:
        if outcome.success:
            self._log.warn(f"E-STOP via {source} done in {outcome.duration_s * 1000:.0f} ms: {outcome.message}")
        else:
            self._log.error(f"E-STOP via {source} incomplete after {outcome.duration_s * 1000:.0f} ms: {outcome.message}")
