"""Entry point of the ``console`` executable: the g1_console node and its web server, in a process of its own.

    console --ros-args -p port:=8080 [-p host:=0.0.0.0 -p token_file:=/etc/g1/console_token] [-r __ns:=/g1_a]

It runs on the product's RMW (Fast DDS), as the launch files run the mode manager, whatever the shell exports:
the console is tested only on that one. It prints ``g1_console ready: <url>`` once it serves. SIGINT and SIGTERM
stop it in order (web server, publisher, executor, node); a crash or a kill leaves the mode manager untouched,
and its watchdog stops a robot this console was driving.
"""

from __future__ import annotations

import asyncio
import os
import signal
import sys
import threading
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from g1_mode_manager.help_flag import wants_help

if TYPE_CHECKING:  # rclpy is imported only once the RMW is set (see _environment)
    from collections.abc import Callable

    from rclpy.node import Node

    from g1_mode_manager.console.access import Access
    from g1_mode_manager.console.messages import MessageRules
    from g1_mode_manager.console.robot_view import RobotView
    from g1_mode_manager.console.settings import ConsoleSettings
    from g1_mode_manager.console.teleop import Teleop

#: The product's RMW (the mode manager's launch files set it for the node the same way).
PRODUCT_RMW = "rmw_fastrtps_cpp"
#: Exit status of a refused start (a configuration error, not a crash).
REFUSED = 2


def _environment() -> None:
    rmw = os.environ.get("RMW_IMPLEMENTATION")
    if rmw and rmw != PRODUCT_RMW:
        print(f"[g1_console] RMW_IMPLEMENTATION={rmw} in the environment: running on {PRODUCT_RMW}, the product's",
              file=sys.stderr, flush=True)
    os.environ["RMW_IMPLEMENTATION"] = PRODUCT_RMW
    # like g1ctl: stay on this machine unless the user chose otherwise
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")


def main(args: list[str] | None = None) -> None:
    if wants_help(args):
        print(__doc__)
        return
    _environment()
    import rclpy
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
    from rclpy.node import Node
    from rclpy.signals import SignalHandlerOptions

    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    node = Node("g1_console")
    executor = SingleThreadedExecutor()
    executor.add_node(node)

    def spin() -> None:
        try:
            executor.spin()
        except ExternalShutdownException:
            pass

    spinner = threading.Thread(target=spin, name="ros_executor", daemon=True)
    code = 0
    try:
        app = _build(node)
        if app is None:
            code = REFUSED
        else:
            spinner.start()
            code = asyncio.run(_serve(*app))
    finally:
        executor.shutdown(timeout_sec=1.0)
        if spinner.is_alive():
            spinner.join(2.0)
        node.destroy_node()
        rclpy.try_shutdown()
    if code:
        raise SystemExit(code)


def _build(node: Node) -> tuple | None:
    """Settings, access and the parts; None (logged) for a configuration that must not start."""
    from g1_mode_manager.console.access import Access, load_token
    from g1_mode_manager.console.messages import MessageRules
    from g1_mode_manager.console.policy_card import VERBS as POLICY_VERBS
    from g1_mode_manager.console.robot_view import RobotView
    from g1_mode_manager.console.settings import ConsoleSettings
    from g1_mode_manager.console.teleop import Limits, Teleop
    from g1_mode_manager.core.loco_verbs import LOCO_VERBS
    from g1_mode_manager.core.modes import Mode
    from g1_mode_manager.core.recovery import STEPS
    from g1_mode_manager.policy.builtin import builtin_configs
    from g1_mode_manager.protocol.motors import JOINT_NAMES

    try:
        settings = ConsoleSettings.declare(node)
        access = Access(settings.host, load_token(settings.token, settings.token_file))
    except (ValueError, OSError) as exc:
        node.get_logger().fatal(f"refusing to start: {exc}")
        return None
    modes = [m.name.lower() for m in Mode if m is not Mode.UNINITIALIZED]
    verbs = {name: verb.values for name, verb in LOCO_VERBS.items()}
    rules = MessageRules(modes, verbs, settings.max_message_bytes, policy_verbs=POLICY_VERBS)
    teleop = Teleop(settings.heartbeat_deadline_s, settings.driver_release_s,
                    Limits(settings.max_vx, settings.max_vy, settings.max_wz))
    hello = {"modes": modes, "verbs": {n: None if v is None else [v.start, v.stop - 1] for n, v in verbs.items()},
             "limits": {"max_vx": settings.max_vx, "max_vy": settings.max_vy, "max_wz": settings.max_wz},
             "recover_steps": list(STEPS), "policy_verbs": list(POLICY_VERBS),
             "policies": sorted(builtin_configs()), "joints": list(JOINT_NAMES)}
    manager = settings.manager_name(node.get_namespace())
    return node, settings, access, rules, teleop, RobotView(), manager, hello


def call_in_loop(loop: asyncio.AbstractEventLoop, callback: Callable[[], object]) -> None:
    """``callback`` in ``loop``, from the ROS executor's thread. The executor outlives the loop by up to its shutdown:
    an answer that lands then (the mode manager's parameters, read at start, answered as a SIGTERM came) has no page
    left to tell, and must not raise in the executor's thread."""
    try:
        loop.call_soon_threadsafe(callback)
    except RuntimeError:  # the loop is closed
        pass


async def _serve(node: Node, settings: ConsoleSettings, access: Access, rules: MessageRules, teleop: Teleop,
                 view: RobotView, manager: str, hello: dict[str, Any]) -> int:
    """Serve until SIGINT or SIGTERM; the exit status (REFUSED if the address cannot be bound)."""
    from g1_mode_manager.console.bridge import RosBridge
    from g1_mode_manager.console.cmd_vel_publisher import CmdVelPublisher
    from g1_mode_manager.console.incident_routes import IncidentRoutes
    from g1_mode_manager.console.last_incident import LastIncident
    from g1_mode_manager.console.policy_view import PolicyView
    from g1_mode_manager.console.server import ConsoleServer
    from g1_mode_manager.core.recorder.incidents import folder_for

    loop = asyncio.get_running_loop()
    stop = asyncio.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    server_ref: list = []
    policy = PolicyView()
    bridge = RosBridge(node, manager, view, policy, lambda: server_ref and call_in_loop(loop, server_ref[0].changed))

    def blocked(now: float) -> str | None:
        return bridge.ready_to_drive() or view.drive_block(now)

    def incident_folder() -> Path:
        """The console's recorder_dir, else the mode manager's (once read), else the default both share."""
        return folder_for(settings.recorder_dir or bridge.node_recorder_dir or "")

    publisher = CmdVelPublisher(teleop, settings.publish_rate_hz, blocked, bridge.publish)
    server = ConsoleServer(settings, access, rules, teleop, view, policy, bridge, publisher, blocked, hello,
                           IncidentRoutes(LastIncident(incident_folder)))
    server_ref.append(server)
    started = time.monotonic()
    try:
        host, port = await server.start()
    except OSError as exc:  # the port is taken, the address is not this machine's
        node.get_logger().fatal(f"refusing to start: cannot serve on {settings.host}:{settings.port}: {exc}")
        await server.stop()
        return REFUSED
    publisher.start()
    shown = f"[{host}]" if ":" in host else host
    token = " (add ?token=<the token> to open it)" if access.needs_token else ""
    print(f"g1_console ready: http://{shown}:{port}/{token}  (mode manager {manager}, cmd_vel {bridge.cmd_vel_topic}, "
          f"{(time.monotonic() - started) * 1000:.0f} ms)", flush=True)
    try:
        await stop.wait()
    finally:
        publisher.stop()
        await server.stop()
    return 0


if __name__ == "__main__":
    main()
