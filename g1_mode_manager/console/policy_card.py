"""The Policy card's ROS side: a client of each of the mode manager's ``~/policy/*`` services (one per button), and
the topics the card shows (``~/policy/status``, ``~/policy/targets`` and ``joint_states`` beside them), handed to
the PolicyView.

``joint_states`` is taken only while the policy's loop ticks, as the status says at every change of phase: the card
needs the measured joints only beside the targets, and the sim publishes them only while someone subscribes. The
node's default policy and its engage bound are read once through its get_parameters service, apart from the
bridge's read: a node without policies answers none of them, and that must not keep the console from driving.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from g1_mode_manager_msgs.msg import PolicyStatus
from g1_mode_manager_msgs.srv import LoadPolicy
from rcl_interfaces.msg import ParameterType
from rcl_interfaces.srv import GetParameters
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger

from g1_mode_manager.console.policy_view import PolicyView, status_fields
from g1_mode_manager.core.controller.phases import TICKING
from g1_mode_manager.topic_qos import MODE_QOS

#: The card's buttons, in order; each calls ~/policy/<verb> (load: LoadPolicy, the others std_srvs/Trigger).
VERBS = ("load", "shadow", "engage", "disengage", "hold", "unload")
#: How long each verb's answer may take before the page is told it timed out (s): a load reads a model and probes
#: it; engage and disengage wait for the robot's switch, as set_mode does.
ANSWER_TIMEOUT_S = {"load": 30.0, "shadow": 5.0, "engage": 30.0, "disengage": 30.0, "hold": 5.0, "unload": 5.0}
#: The mode manager's parameters the card shows: what LOAD loads with no name, and the bound ENGAGE checks.
PARAMS = ("policy", "policy_engage_max_error_rad")


def service(verb: str) -> str:
    """The bridge's name for the verb's service."""
    return f"policy_{verb}"


def request(verb: str, policy: str = "") -> Any:
    """The verb's request; ``policy`` ("": the node's default) only for load."""
    return LoadPolicy.Request(policy=policy) if verb == "load" else Trigger.Request()


class PolicyFeed:
    def __init__(self, node: Node, manager: str, namespace: str, view: PolicyView,
                 on_change: Callable[[], None]) -> None:
        self._node = node
        self._view = view
        self._on_change = on_change
        self._joints_topic = f"{namespace}/joint_states"
        self._joints: Any = None  # the joint_states subscription while the loop ticks
        self._phase: str | None = None
        node.create_subscription(PolicyStatus, f"{manager}/policy/status", self._on_status, MODE_QOS)
        # best effort matches both reliable and best-effort publishers
        node.create_subscription(JointState, f"{manager}/policy/targets", self._on_targets, qos_profile_sensor_data)
        self.clients = {service(verb): node.create_client(LoadPolicy if verb == "load" else Trigger,
                                                          f"{manager}/policy/{verb}") for verb in VERBS}
        self._params_client = node.create_client(GetParameters, f"{manager}/get_parameters")
        self._params_pending = False
        self._params_timer = node.create_timer(0.25, self._read_params)  # until the node answers

    def _on_status(self, msg: PolicyStatus) -> None:
        self._view.on_status(status_fields(msg))
        ticking = msg.phase in TICKING
        if ticking and self._joints is None:
            self._joints = self._node.create_subscription(JointState, self._joints_topic, self._on_joints,
                                                          qos_profile_sensor_data)
        elif not ticking and self._joints is not None:
            self._node.destroy_subscription(self._joints)
            self._joints = None
        if msg.phase != self._phase:  # the 2 Hz repeats wait for the next state tick
            self._phase = msg.phase
            self._on_change()

    def _on_targets(self, msg: JointState) -> None:
        self._view.on_targets(msg.name, msg.position, time.monotonic())

    def _on_joints(self, msg: JointState) -> None:
        self._view.on_joints(msg.name, msg.position, time.monotonic())

    def _read_params(self) -> None:
        if self._params_pending or not self._params_client.service_is_ready():
            return
        self._params_pending = True
        self._params_client.call_async(GetParameters.Request(names=list(PARAMS))).add_done_callback(self._took_params)

    def _took_params(self, future: Any) -> None:
        self._params_pending = False
        result = future.result()
        if result is None:
            return
        self._params_timer.cancel()  # answered: a node without policies answers no values, and is not asked again
        values = {name: v for name, v in zip(PARAMS, result.values, strict=False)}
        default = values.get("policy")
        limit = values.get("policy_engage_max_error_rad")
        self._view.set_params(
            default.string_value if default is not None and default.type == ParameterType.PARAMETER_STRING else None,
            limit.double_value if limit is not None and limit.type == ParameterType.PARAMETER_DOUBLE else None)
        self._on_change()
