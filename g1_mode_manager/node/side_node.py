"""A helper node of the mode manager with an executor and thread of its own.

Blocking work (a transition that waits seconds for SelectMode) must not share threads with the command
streams or the e-stop: the services get a side node (services.py) in the main node's namespace whose
services carry the main node's names (`<main node>/set_mode`), so `ros2 service call` and namespace
remaps work as if the main node served them. (The e-stop has a node of its own too, taken by a thread
without an executor: estop.py.)
"""

from __future__ import annotations

import threading

import rclpy
from rclpy.executors import Executor, ExternalShutdownException
from rclpy.node import Node


class SideNode:
    def __init__(self, main: Node, suffix: str, executor: Executor) -> None:
        self.main = main
        self.node = rclpy.create_node(
            f"{main.get_name()}_{suffix}",
            namespace=main.get_namespace(),
            context=main.context,
            start_parameter_services=False,
        )
        self._executor = executor
        self._executor.add_node(self.node)
        self._thread = threading.Thread(target=self._spin, name=f"{suffix}_executor", daemon=True)

    def name_under_main(self, name: str) -> str:
        """`<main node's fully qualified name>/<name>`, i.e. what `~/<name>` means on the main node."""
        return f"{self.main.get_fully_qualified_name()}/{name}"

    def start(self) -> None:
        self._thread.start()

    def _spin(self) -> None:
        try:
            self._executor.spin()
        except ExternalShutdownException:
            pass
        except Exception:
            # SIGINT shuts the context down while this thread waits: rclpy then raises RCLError ("context is not
            # valid") instead of ExternalShutdownException. Only an error of a live context is a real one.
            if self.main.context.ok():
                raise

    def shutdown(self, timeout_s: float = 1.0) -> None:
        """Stop serving; a callback still blocked in a robot call (an e-stop sequence, a SelectMode) is not
        waited for beyond ``timeout_s``: the process is exiting and the robot side needs nothing more."""
        self._executor.shutdown(timeout_sec=timeout_s)
        self._thread.join(timeout_s)
        self.node.destroy_node()
