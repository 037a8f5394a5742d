"""Parameters of the g1_console node, declared up front with descriptions: the one home of their defaults."""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node

from g1_mode_manager.console.messages import MAX_MESSAGE_BYTES

DESCRIPTIONS = {
    "manager": "the mode manager node: relative to this node's namespace, or absolute (/g1_a/g1_mode_manager)",
    "host": "address the web server binds to; anything beyond loopback needs token or token_file",
    "port": "TCP port of the web server (0: any free port, printed in the ready line)",
    "token": "token every request must present (?token=... or Authorization: Bearer); empty: none on loopback",
    "token_file": "file whose first line is the token (instead of token)",
    "heartbeat_deadline_s": "a page whose last message is older than this stops driving (it sends one every 0.1 s)",
    "publish_rate_hz": "cmd_vel rate while a page drives",
    "state_rate_hz": "rate of the state sent to every page",
    "driver_release_s": "the driving page keeps the driver lock this long after it let go",
    "max_vx": "full stick or key forward, m/s (the mode manager clamps again with its max_vx)",
    "max_vy": "full stick or key sideways, m/s",
    "max_wz": "full stick or key turn, rad/s",
    "max_clients": "WebSocket connections served at once; more are refused (503)",
    "max_message_bytes": "longest message acted on; longer ones are refused and counted",
    "max_messages_per_s": "steady rate of messages per page; a flood beyond it (and its burst) is refused and counted",
    "recorder_dir": "the mode manager's incident folder, shown on the Last incident card; '' = the mode manager's own "
                    "recorder_dir (read from it), else $XDG_STATE_HOME/g1_mode_manager/incidents",
}


@dataclass(frozen=True)
class ConsoleSettings:
    manager: str = "g1_mode_manager"
    host: str = "127.0.0.1"
    port: int = 8080
    token: str = ""
    token_file: str = ""
    heartbeat_deadline_s: float = 0.3
    publish_rate_hz: float = 20.0
    state_rate_hz: float = 10.0
    driver_release_s: float = 2.0
    max_vx: float = 0.5
    max_vy: float = 0.3
    max_wz: float = 0.8
    max_clients: int = 8
    max_message_bytes: int = MAX_MESSAGE_BYTES
    max_messages_per_s: float = 50.0
    recorder_dir: str = ""

    def __post_init__(self) -> None:
        positive = ("heartbeat_deadline_s", "publish_rate_hz", "state_rate_hz", "max_clients", "max_message_bytes",
                    "max_messages_per_s")
        for name in positive:
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        for name in ("driver_release_s", "max_vx", "max_vy", "max_wz"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")
        if not 0 <= self.port <= 65535:
            raise ValueError(f"port must be 0..65535, got {self.port}")
        if self.heartbeat_deadline_s >= 1.0:
            raise ValueError("heartbeat_deadline_s must be < 1 s: a dead-man that waits longer is no dead-man")

    @classmethod
    def declare(cls, node: Node) -> ConsoleSettings:
        """Declare every parameter on ``node`` and read them; ValueError names a bad one."""
        values: dict[str, Any] = {}
        for f in fields(cls):
            default = f.default
            node.declare_parameter(f.name, default, ParameterDescriptor(description=DESCRIPTIONS[f.name]))
            values[f.name] = type(default)(node.get_parameter(f.name).value)
        return cls(**values)

    def manager_name(self, namespace: str) -> str:
        """The mode manager's fully qualified name, seen from a node in ``namespace``."""
        if self.manager.startswith("/"):
            return self.manager.rstrip("/")
        return f"{namespace.rstrip('/')}/{self.manager}"
