"""Entry point of the `mode_manager` executable."""

from __future__ import annotations

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor

from g1_mode_manager.node.mode_manager import ModeManagerNode


def main(args: list[str] | None = None) -> None:
    rclpy.init(args=args)
    node = None
    executor = SingleThreadedExecutor()  # blocking services run on their own side node
    try:
        node = ModeManagerNode()
        executor.add_node(node)
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        executor.shutdown()
        if node is not None:
            node.shutdown()
            node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
