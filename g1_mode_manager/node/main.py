"""Entry point of the `mode_manager` executable.

SIGINT and SIGTERM ask for an orderly stop: the node hands the robot back (arms ramped out, StopMove)
and stops its threads while the ROS context is still valid, and only then is the context shut down.
(rclpy's own handler shuts the context down first, under threads that still wait on it: that crashed
the node at exit.)
"""

from __future__ import annotations

import signal
import threading

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.signals import SignalHandlerOptions

from g1_mode_manager.node.mode_manager import ModeManagerNode


def _spin(executor: SingleThreadedExecutor) -> None:
    try:
        executor.spin()
    except ExternalShutdownException:
        pass


def main(args: list[str] | None = None) -> None:
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    node = None
    executor = SingleThreadedExecutor()  # blocking services run on their own side node
    spin = threading.Thread(target=_spin, args=(executor,), name="main_executor", daemon=True)
    try:
        node = ModeManagerNode()
        executor.add_node(node)
        spin.start()
        while not stop.wait(0.5) and spin.is_alive():
            pass
    finally:
        if node is not None:
            node.shutdown()
        executor.shutdown(timeout_sec=1.0)
        if spin.is_alive():
            spin.join(2.0)
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
