"""The e-stop endpoints, on their own node and executor thread so that they always get through.

The main node's executor threads may all be busy (a slow SelectMode, a flood of service calls);
the e-stop service and topic are served by a separate single-threaded executor and call the mode
machine's estop(), which never waits for a transition in flight.
"""

from __future__ import annotations

from collections.abc import Callable

from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import Bool
from std_srvs.srv import Trigger

from g1_mode_manager.core.records import Outcome
from g1_mode_manager.node.side_node import SideNode


class EstopEndpoint:
    """Serves `<main node>/estop` (std_srvs/Trigger) and listens to `/estop` (std_msgs/Bool, true = stop)."""

    def __init__(self, main: Node, estop: Callable[[], Outcome], retries: int = 2) -> None:
        self._estop = estop
        self._retries = retries
        self._log = main.get_logger()
        self._side = SideNode(main, "estop", SingleThreadedExecutor(context=main.context))
        self.service_name = self._side.name_under_main("estop")
        self._side.node.create_service(Trigger, self.service_name, self._on_trigger)
        self._side.node.create_subscription(Bool, "/estop", self._on_topic,
                                            QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE))

    def start(self) -> None:
        self._side.start()

    def shutdown(self) -> None:
        self._side.shutdown()

    def _run(self, source: str) -> Outcome:
        self._log.warn(f"E-STOP requested via {source}")
        outcome = self._estop()
        for attempt in range(self._retries):
            # A repeated e-stop retries the whole sequence (e.g. a CheckMode that lagged behind a
            # ReleaseMode made the first Damp go to a released service); do it for the caller.
            if outcome.success:
                break
            self._log.error(f"E-STOP attempt {attempt + 1} incomplete ({outcome.message}); retrying")
            outcome = self._estop()
        if outcome.success:
            self._log.warn(f"E-STOP done in {outcome.duration_s * 1000:.0f} ms: {outcome.message}")
        else:
            self._log.error(f"E-STOP incomplete after {outcome.duration_s * 1000:.0f} ms: {outcome.message}")
        return outcome

    def _on_trigger(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        outcome = self._run(self.service_name)
        response.success = outcome.success
        response.message = outcome.message
        return response

    def _on_topic(self, msg: Bool) -> None:
        if msg.data:
            self._run("/estop topic")
