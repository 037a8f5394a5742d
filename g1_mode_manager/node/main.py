"""Entry point of the `mode_manager` executable.

    mode_manager [--ros-args -p name:=value ... -r __ns:=/g1_a]

The G1 mode manager node (README.md). Its parameters, their defaults and ranges: config/mode_manager.yaml, or
`ros2 param describe /g1_mode_manager <name>` while it runs; e.g. `-p network_interface:=eth0` for a real G1,
`-p dds_domain:=N` for the sim's domain.

SIGINT and SIGTERM ask for an orderly stop: the node hands the robot back (arms ramped out, StopMove)
and stops its threads while the ROS context is still valid, and only then is the context shut down.
(rclpy's own handler shuts the context down first, under threads that still wait on it: that crashed
the node at exit.)
"""

from __future__ import annotations

import os
import signal
import sys
import threading

# Nothing of rclpy or the SDK before the RMW check: importing rclpy loads rcl, which loads the RMW named in
# the environment (and exits 102 if that one is not installed).
from g1_mode_manager.help_flag import wants_help
from g1_mode_manager.node.one_dds_stack import refusal_from_environment, second_dds_stack

#: How long a thread holding the GIL keeps it while another waits for it, s (Python's default: 0.005).
SWITCH_INTERVAL_S = 0.001

#: Exit status of a refused start (a configuration error, not a crash).
REFUSED = 2


def _spin(executor) -> None:
    from rclpy.executors import ExternalShutdownException

    try:
        executor.spin()
    except ExternalShutdownException:
        pass


def _refuse(why: str) -> None:
    print(f"[FATAL] [g1_mode_manager]: {why}", file=sys.stderr, flush=True)
    raise SystemExit(REFUSED)


def main(args: list[str] | None = None) -> None:
    if wants_help(args):
        print(__doc__)
        return
    refusal = refusal_from_environment(os.environ)
    if refusal:
        _refuse(refusal)
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.signals import SignalHandlerOptions
    from rclpy.utilities import get_rmw_implementation_identifier

    from g1_mode_manager.node.mode_manager import ModeManagerNode

    # A thread that wants the GIL back (the policy loop after onnxruntime's inference or a DDS write, each of which lets
    # it go) waits until the thread holding it is made to let go: 5 ms by default. Measured on the dances beside the
    # sim, the frames' jitter p99 went from 1.8-2.2 ms to 0.9-1.5 ms at 1 ms (docs/figures.md).
    sys.setswitchinterval(SWITCH_INTERVAL_S)
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    refusal = second_dds_stack(get_rmw_implementation_identifier())  # a default RMW other than Fast DDS
    if refusal:
        rclpy.try_shutdown()
        _refuse(refusal)
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
