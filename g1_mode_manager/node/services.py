"""The node's services: ~/set_mode, ~/loco_command, ~/clear_fault, who drives in HIGH_LEVEL:
~/hand_over_to_autonomy and ~/take_over, and the flight recorder's ~/snapshot (the e-stop has a side node of its
own). Each answer is also kept by the flight recorder.

set_mode may block for seconds (SelectMode on a robot), and a loco command holds a thread while it waits for
the robot to show its outcome: they are served on a side node with a thread pool of its own, so the command
streams keep their cheap single-threaded taker, and a busy transition refuses further requests at once
instead of queueing them.
"""

from __future__ import annotations

import time

from g1_mode_manager_msgs.srv import LocoCommand, SetMode
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import MultiThreadedExecutor
from rclpy.node import Node
from std_srvs.srv import Trigger

from g1_mode_manager.core.modes import Mode
from g1_mode_manager.node.parts import Parts
from g1_mode_manager.node.policy_endpoints import PolicyEndpoints
from g1_mode_manager.node.side_node import SideNode

#: Threads of the services' side node: a transition, loco commands waiting for their outcome, a clear_fault.
SERVICE_THREADS = 6


class Services:
    """Serves the main node's services from a side node's executor."""

    def __init__(self, main: Node, parts: Parts, default_policy: str) -> None:
        self._log = main.get_logger()
        self._parts = parts
        self._side = SideNode(main, "services", MultiThreadedExecutor(num_threads=SERVICE_THREADS,
                                                                      context=main.context))
        group = ReentrantCallbackGroup()
        for srv_type, name, callback in ((SetMode, "set_mode", self._on_set_mode),
                                         (LocoCommand, "loco_command", self._on_loco_command),
                                         (Trigger, "clear_fault", self._on_clear_fault),
                                         (Trigger, "hand_over_to_autonomy", self._on_hand_over),
                                         (Trigger, "take_over", self._on_take_over),
                                         (Trigger, "snapshot", self._on_snapshot)):
            self._side.node.create_service(srv_type, self._side.name_under_main(name), callback, callback_group=group)
        self.policy = PolicyEndpoints(main, self._side, group, parts.policy, default_policy, parts.log.worker_error)

    def start(self) -> None:
        self._side.start()
        self.policy.start()

    def shutdown(self) -> None:
        self.policy.stop()
        self._side.shutdown()

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
            self._parts.log.events.count("set_mode_invalid")
            self._log.warn(f"set_mode refused: {exc}")
            return self._fill_set_mode(request, response, False, str(exc))
        self._parts.lowstate_demand.update(target)  # LOW_LEVEL and IDLE judge the link by rt/lowstate: receive it now
        outcome = self._parts.machine.request(target)
        return self._fill_set_mode(request, response, outcome.success, outcome.message)

    def _fill_set_mode(self, request: SetMode.Request, response: SetMode.Response, success: bool,
                       message: str) -> SetMode.Response:
        self._parts.recorder.service_answer("set_mode", request.mode_name or str(request.mode), success, message)
        response.success = success
        response.message = message
        response.mode = int(self._parts.machine.mode)
        response.mode_name = self._parts.machine.mode.name
        return response

    def _on_loco_command(self, request: LocoCommand.Request, response: LocoCommand.Response) -> LocoCommand.Response:
        result = self._parts.loco.run(request.command, request.value)
        if result.success:
            self._log.info(f"loco_command: {result.message}")
        else:
            self._parts.log.events.count("loco_command_refused" if result.code == -1 else "loco_command_failed")
            self._log.warn(f"loco_command {request.command!r}: {result.message}")
        response.success, response.message, response.code = result.success, result.message, result.code
        response.outcome_s = result.outcome_s
        self._parts.recorder.service_answer("loco_command", f"{request.command} {request.value}", result.success,
                                            f"code {result.code}: {result.message}")
        return response

    def _on_clear_fault(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """FAULT -> IDLE, or the holds released, once every latched body check has been clear fault_clear_hold_s."""
        monitor = self._parts.body.monitor
        outcome = self._parts.machine.clear_fault(lambda: monitor.clearable(time.monotonic()), monitor.clear)
        response.success, response.message = outcome.success, outcome.message
        self._parts.recorder.service_answer("clear_fault", "", outcome.success, outcome.message)
        return response

    def _on_hand_over(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """The autonomy drives, if it can (HIGH_LEVEL, nothing held, fresh odometry...); else why not."""
        response.success, response.message = self._parts.cmd_vel.sources.hand_over()
        if not response.success:
            self._log.warn(f"hand_over_to_autonomy refused: {response.message}")
        self._parts.recorder.service_answer("hand_over_to_autonomy", "", response.success, response.message)
        return response

    def _on_take_over(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """The teleop drives (the autonomy's Moves stop; it needs a new hand-over)."""
        response.success, response.message = self._parts.cmd_vel.sources.take_over()
        self._parts.recorder.service_answer("take_over", "", response.success, response.message)
        return response

    def _on_snapshot(self, _request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        """The flight recorder's window up to now, written as an incident file; the message is its path (or why
        none was written)."""
        response.success, response.message = self._parts.recorder.snapshot()
        if not response.success:
            self._log.error(f"snapshot: {response.message}")
        return response
