"""The node wired: its robot-side parts (parts.py), the flight recorder's hooks in them, and its ROS side, what it
publishes, serves and takes.

The mode machine tells of a change through ``on_change``, which it is handed before the parts that listen
exist: a :class:`ChangeListeners` to which each listener is added once built, before any thread that could
change the mode starts (mode_manager.py starts them).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from rclpy.node import Node

from g1_mode_manager.core.port import RobotPort
from g1_mode_manager.core.records import MachineStatus
from g1_mode_manager.flight_recorder.flight_recorder import FlightRecorder
from g1_mode_manager.flight_recorder.recording_port import recording_port
from g1_mode_manager.node.command_streams import CommandStreams
from g1_mode_manager.node.estop import EstopEndpoint
from g1_mode_manager.node.node_log import NodeLog, log_to
from g1_mode_manager.node.parts import Parts, build_parts
from g1_mode_manager.node.services import Services
from g1_mode_manager.node.settings import Settings
from g1_mode_manager.node.state_publishers import StatePublishers

PortFactory = Callable[[Settings], RobotPort]


def unitree_port(settings: Settings) -> RobotPort:
    """The real robot port: Unitree SDK2 over Cyclone DDS (connects on the first transition)."""
    from g1_mode_manager.sdk.robot import UnitreeRobot

    return UnitreeRobot(settings.dds_domain, settings.network_interface, rpc_timeout_s=settings.rpc_timeout_s,
                        mode_timeout_s=settings.select_timeout_s, user_ctrl=settings.user_ctrl_config() is not None)


class ChangeListeners:
    """The machine's ``on_change``: calls each listener added so far, in the order they were added."""

    def __init__(self) -> None:
        self._listeners: list[Callable[[MachineStatus], None]] = []

    def add(self, listener: Callable[[MachineStatus], None]) -> None:
        self._listeners.append(listener)

    def __call__(self, status: MachineStatus) -> None:
        for listener in tuple(self._listeners):
            listener(status)


@dataclass(frozen=True)
class Endpoints:
    """The node's ROS side, each on threads of its own (see ModeManagerNode)."""

    state: StatePublishers  # ~/mode, /diagnostics, ~/sportmodestate, odom, joint_states, ~/imu
    services: Services  # ~/set_mode, ~/loco_command, ~/clear_fault, ~/hand_over_to_autonomy, ~/take_over
    streams: CommandStreams  # cmd_vel, the autonomy's topic, ~/arm_cmd, ~/lowcmd
    estop: EstopEndpoint  # ~/estop, /estop


def wire(node: Node, settings: Settings, port: RobotPort) -> tuple[Parts, Endpoints]:
    """Build everything ``node`` is made of; nothing is started."""
    changes = ChangeListeners()
    logger = node.get_logger()
    recorder = FlightRecorder(settings.recorder_config(node.get_fully_qualified_name()), log=log_to(logger))
    on = recorder.config.enabled
    if on:
        port = recording_port(port, recorder.add, frame_period_s=recorder.frame_period_s)
    parts = build_parts(settings, port, NodeLog(logger, recorder if on else None), changes, recorder)
    state = StatePublishers(node, settings, parts)
    changes.add(parts.wake_relay_workers)
    if on:
        _tap(parts, changes)
    changes.add(state.publish_mode)
    parts.cmd_vel.sources.on_driver_change = state.publish_mode  # a takeover is on ~/mode at once
    services = Services(node, parts, settings.policy)
    return parts, Endpoints(state=state, services=services, streams=CommandStreams(node, settings, parts),
                            estop=EstopEndpoint(node, parts.machine.estop_shot, parts.machine.estop,
                                                recorder.estop_step))


def _tap(parts: Parts, changes: ChangeListeners) -> None:
    """The flight recorder's hooks in the parts (the robot port and the log record by themselves); among the
    machine's change listeners after the relay workers' wake, which may have damping to send."""
    recorder = parts.recorder
    changes.add(recorder.on_status)
    parts.body.on_reading = recorder.body_step
    parts.cmd_vel.sources.on_input = recorder.drive_input
    parts.cmd_vel.on_move = recorder.move_sent
