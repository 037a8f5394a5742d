"""The e-stop endpoints, on a node and thread of their own so that they always get through, at once.

The services' threads may all be busy (a slow SelectMode, a flood of service calls); the
e-stop service and topic are taken by a thread of their own from a wait set of just them
(``StreamTaker``), which fires the e-stop's first packet (the mode machine's DampNoReply) right where it
took the request: no executor dispatch, no pool hand-off, no log line in front of it. The rest (EMERGENCY
registered under the forward gate, the damping sequence, the answer) runs in a pool thread, which calls
the machine's estop() and answers from there. Several requests at once each fire their own DampNoReply
and then join the one damping sequence that runs (the machine coalesces them), so none queues behind
another's sequence.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

import rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import Bool
from std_srvs.srv import Trigger

from g1_mode_manager.core.records import Outcome
from g1_mode_manager.node.stream_taker import Respond, StreamTaker

_log = logging.getLogger(__name__)

#: /estop: a BEST_EFFORT subscription matches RELIABLE and BEST_EFFORT publishers alike (hardware
#: buttons and micro-ROS bridges usually publish best effort; a RELIABLE one would never hear them).
ESTOP_TOPIC_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
#: Requests whose sequence runs at once; more wait for a thread (each has fired its DampNoReply already,
#: and each holds a thread only while it waits for the one running sequence).
ESTOP_THREADS = 4

EstopShot = Callable[[], list[str]]
EstopCall = Callable[..., Outcome]
#: (step: request or answer, the service or topic it came by, detail): e.g. the flight recorder's estop_step.
EstopSteps = Callable[[str, str, str], None]


class EstopEndpoint:
    """Serves `<main node>/estop` (std_srvs/Trigger) and listens to `/estop` (std_msgs/Bool, true = stop).

    ``shot()`` sends the first packet and returns its notes; ``estop(wait=..., fired=notes)`` does the rest.
    ``steps`` hears of each request after its first packet left, and of each answer.
    """

    def __init__(self, main: Node, shot: EstopShot, estop: EstopCall,
                 steps: EstopSteps = lambda _step, _via, _detail: None) -> None:
        self._shot = shot
        self._estop = estop
        self._steps = steps
        self._log = main.get_logger()
        self.service_name = f"{main.get_fully_qualified_name()}/estop"
        self._node = rclpy.create_node(f"{main.get_name()}_estop", namespace=main.get_namespace(),
                                       context=main.context, start_parameter_services=False)
        self._pool = ThreadPoolExecutor(max_workers=ESTOP_THREADS, thread_name_prefix="estop")
        self._taker = StreamTaker(self._node, "estop_taker", self._error)
        self._taker.serve(Trigger, self.service_name, self._on_trigger)
        self._taker.subscribe(Bool, "/estop", self._on_topic, ESTOP_TOPIC_QOS)

    def start(self) -> None:
        self._taker.start()

    def shutdown(self, timeout_s: float = 1.0) -> None:
        """Stop taking requests; a sequence still running is not waited for (the process is exiting)."""
        self._taker.shutdown(timeout_s)
        self._pool.shutdown(wait=False, cancel_futures=True)
        self._node.destroy_node()

    def _on_trigger(self, _request: Trigger.Request, respond: Respond) -> None:
        notes = self._shot()  # the DampNoReply first, in the thread that took the request
        self._steps("request", self.service_name, "; ".join(notes))
        self._pool.submit(self._finish_trigger, notes, respond)

    def _finish_trigger(self, notes: list[str], respond: Respond) -> None:
        try:
            outcome = self._estop(fired=notes)
        except Exception as exc:  # never leave a caller without an answer (the machine's estop does not raise)
            self._error(exc)
            respond(Trigger.Response(success=False, message=f"e-stop failed in the node: {exc}"))
            return
        self._report(self.service_name, outcome)
        respond(Trigger.Response(success=outcome.success, message=outcome.message))
        self._steps("answer", self.service_name, f"success={outcome.success}: {outcome.message}")

    def _on_topic(self, msg: Bool) -> None:
        if msg.data:
            notes = self._shot()
            self._steps("request", "/estop", "; ".join(notes))
            self._pool.submit(self._finish_topic, notes)

    def _finish_topic(self, notes: list[str]) -> None:
        # a topic has nobody to answer: register at once, the sequence runs in the machine's thread
        try:
            outcome = self._estop(wait=False, fired=notes)
        except Exception as exc:
            self._error(exc)
            return
        self._log.warn(f"E-STOP requested via /estop topic: {outcome.message}")
        self._steps("answer", "/estop", outcome.message)

    def _error(self, exc: BaseException) -> None:
        _log.error("e-stop endpoint: %s", exc, exc_info=exc)
        self._log.error(f"e-stop endpoint error: {exc!r}")

    def _report(self, source: str, outcome: Outcome) -> None:
        if outcome.success:
            self._log.warn(f"E-STOP via {source} done in {outcome.duration_s * 1000:.0f} ms: {outcome.message}")
        else:
            self._log.error(f"E-STOP via {source} incomplete after {outcome.duration_s * 1000:.0f} ms: {outcome.message}")
