"""The g1_mode_manager node: ROS plumbing around the mode machine, the relays and the robot port.

Its parts are built in parts.py and wiring.py; this module starts them in order and stops them in the order
that hands the robot back safely.
"""

from __future__ import annotations

from rclpy.node import Node

from g1_mode_manager.node.settings import declare_settings
from g1_mode_manager.node.wiring import PortFactory, unitree_port, wire


class ModeManagerNode(Node):
    """Serves ~/set_mode, ~/loco_command, ~/clear_fault and the e-stop (~/estop, /estop); takes /cmd_vel,
    ~/arm_cmd and ~/lowcmd; publishes ~/mode, /diagnostics, ~/sportmodestate, odom, joint_states and ~/imu.

    Its threads: this node's executor (run by the caller) serves only parameters. The services run on a
    side node's executor with a pool of threads (a transition blocks for seconds); the e-stop on a side
    node taken by a thread of its own, which fires the first packet, with a small pool for the rest. The
    command streams are taken by one thread (StreamTaker: cheap at 100 Hz) and handed to the cmd_vel
    sender's thread and the arm and lowcmd workers. The supervisor, the body watch, each publication and
    the head LED are plain worker threads (PeriodicWorker).
    """

    def __init__(self, *, port_factory: PortFactory = unitree_port, node_name: str = "g1_mode_manager",
                 **kwargs) -> None:
        super().__init__(node_name, **kwargs)
        self.settings = s = declare_settings(self)
        p, e = wire(self, s, port_factory(s))
        self.parts, self.endpoints, self.machine = p, e, p.machine
        p.recorder.start()  # first: it keeps what the others do from their start on
        for worker in (p.cmd_vel, p.arm_worker, p.lowcmd_worker, p.policy_worker):
            worker.start()
        e.estop.start()
        p.supervisor.start()
        p.body.start()
        if p.head_led_worker is not None:
            p.head_led_worker.start()
        e.services.start()
        e.streams.start()
        e.state.start()
        e.state.publish_mode()
        self.get_logger().info(
            f"ready in {self.machine.mode.name}; robot side: interface {s.network_interface!r}, DDS domain "
            f"{s.dds_domain}; e-stop: {e.estop.service_name} and /estop")

    def shutdown(self) -> None:
        """Hand the robot back safely (arms ramped out, StopMove), stop the streams, workers, services and
        e-stop endpoint, turn the head LED off, close the robot port, write an incident still waiting. Call before
        destroy_node()."""
        p, e = self.parts, self.endpoints
        e.streams.shutdown()
        e.state.stop()
        p.arm.ramp_out()  # bounded: the arm worker still runs and sends the ramp-out frames
        p.body.stop()
        if p.policy_keys is not None:
            p.policy_keys.stop()  # no press from here on; a verb under way ends before the robot is handed back
        p.supervisor.stop()
        p.policy_worker.stop()  # the policy's last frame stands; the relay's hold and hand-back take over
        p.lowcmd.at_exit()  # user_ctrl: the robot handed back to its own controller while the hold still goes out
        for worker in (p.cmd_vel, p.arm_worker, p.lowcmd_worker):
            worker.stop()  # the cmd_vel sender sends a StopMove if the robot may be walking
        e.services.shutdown()
        e.estop.shutdown()
        if p.head_led_worker is not None and p.head_led is not None:
            p.head_led_worker.stop()
            p.head_led.turn_off()
        p.port.close()
        p.recorder.stop()  # last: a stop's incident still waiting is written now, with the shutdown in it
