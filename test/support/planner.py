"""A scripted planner: a process publishing the autonomy's velocity input as Nav2's controller server would,
at a fixed rate (20 Hz, Twist or TwistStamped), one constant command, until SIGINT.

``start_planner(topic, vx, vy, wz)`` starts it and waits until the node under test subscribes (or, to start it
while something else goes on, ``launch_planner`` and later ``planner_subscribed``); ``python
planner.py TOPIC VX VY WZ [RATE_HZ] [stamped]`` is the process.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from harness.processes import ManagedProcess

#: Nav2's controller server publishes at its controller_frequency, 20 Hz by default.
RATE_HZ = 20.0


def launch_planner(topic: str, vx: float, vy: float = 0.0, wz: float = 0.0, *, rate_hz: float = RATE_HZ,
                   stamped: bool = False) -> ManagedProcess:
    """The planner's process, started and not waited for: its start (an interpreter and rclpy, a second or two)
    can run while the test readies the robot; ``planner_subscribed`` then waits for it."""
    argv = [sys.executable, "-u", str(Path(__file__).resolve()), topic, str(vx), str(vy), str(wz), str(rate_hz),
            "stamped" if stamped else "plain"]
    return ManagedProcess(argv, name="planner")


def planner_subscribed(proc: ManagedProcess, timeout_s: float = 20.0) -> ManagedProcess:
    """Wait until the node under test subscribes to the launched planner (it publishes from then on); stops the
    planner if it does not."""
    try:
        proc.wait_for_line(lambda line: line.startswith("planner: subscribed"), timeout_s)
    except BaseException:
        proc.stop()
        raise
    return proc


def start_planner(topic: str, vx: float, vy: float = 0.0, wz: float = 0.0, *, rate_hz: float = RATE_HZ,
                  stamped: bool = False, timeout_s: float = 20.0) -> ManagedProcess:
    return planner_subscribed(launch_planner(topic, vx, vy, wz, rate_hz=rate_hz, stamped=stamped), timeout_s)


def _main(topic: str, vx: str, vy: str, wz: str, rate_hz: str = str(RATE_HZ), kind: str = "plain") -> None:
    import rclpy
    from geometry_msgs.msg import Twist, TwistStamped
    from rclpy.executors import ExternalShutdownException

    rclpy.init()
    node = rclpy.create_node("scripted_planner")
    stamped = kind == "stamped"
    pub = node.create_publisher(TwistStamped if stamped else Twist, topic, 10)
    twist = Twist()
    twist.linear.x, twist.linear.y, twist.angular.z = float(vx), float(vy), float(wz)
    while pub.get_subscription_count() == 0:
        time.sleep(0.02)
    print("planner: subscribed", flush=True)
    period = 1.0 / float(rate_hz)
    try:
        next_at = time.monotonic()
        while True:
            if stamped:
                msg = TwistStamped(twist=twist)
                msg.header.stamp = node.get_clock().now().to_msg()
                pub.publish(msg)
            else:
                pub.publish(twist)
            next_at += period
            time.sleep(max(0.0, next_at - time.monotonic()))
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    _main(*sys.argv[1:])
