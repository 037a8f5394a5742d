"""What each step of the node's three stream paths costs a message, in microseconds: the profile that chooses
what to make cheaper, and says where the rest of a stream's CPU goes.

``python -m bench.stream_steps [DOMAIN] [N]`` runs each step N times on the node's own code, on data as the node
sees it (a JointCommand, a Twist and a JointState serialised by rclpy; the frames written on an SDK domain of their
own on loopback, with no reader), and prints one line per step and a total per path. What it cannot take apart
in one process (rclpy's take, Fast DDS's and Cyclone's threads, the wake-ups) is ``make bench``'s floor rows:
a bare relay's take only, and take + one write. Pure figures, no goal: they vary with the machine.
"""

from __future__ import annotations

import json
import statistics
import sys
import time
from collections.abc import Callable

import numpy as np

from g1_mode_manager.core import modes
from g1_mode_manager.core.events import RelayEvents
from g1_mode_manager.core.joint_commands import validate_arm_targets, validate_lowcmd, validate_lowcmd_block
from g1_mode_manager.core.machine.gate import ForwardGate
from g1_mode_manager.core.machine.state import MachineState
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import MotorCommand
from g1_mode_manager.core.recorder.ring import FlightRing, caps_for
from g1_mode_manager.core.velocity import VelocityLimits, sanitize
from g1_mode_manager.protocol.crc import crc32_of_array
from g1_mode_manager.protocol.dds import init_channels
from g1_mode_manager.protocol.motors import ARM_SDK_JOINT_NAMES, JOINT_NAMES, NUM_JOINTS

Step = tuple[str, Callable[[], object]]


def per_call_us(fn: Callable[[], object], n: int) -> float:
    """Mean time of a call made back to back with itself: every cache warm."""
    for _ in range(min(n, 200)):  # warm up (caches, lru entries)
        fn()
    start = time.perf_counter()
    for _ in range(n):
        fn()
    return (time.perf_counter() - start) / n * 1e6


#: Enough memory to push a step's code and data out of this VM's caches between two calls, as the node's other
#: threads, Cyclone and Fast DDS do between two frames of a stream.
_FLUSH = np.ones(4 * 1024 * 1024, dtype=np.float64)


def cold_call_us(fn: Callable[[], object], n: int) -> float:
    """Median time of one call made after the caches were filled with something else: what a step costs in a
    running node, where a frame comes every 2 ms and everything else runs in between."""
    times = []
    for _ in range(n):
        _FLUSH.sum()
        start = time.perf_counter_ns()
        fn()
        times.append(time.perf_counter_ns() - start)
    return statistics.median(times) / 1000


def _state_in(mode: Mode) -> MachineState:
    state = MachineState(clock=time.monotonic, on_record=None, on_change=None, on_alarm=None, history_size=8)
    state.mode = mode
    return state


class _Unwritten:
    """A robot port whose write goes nowhere: the recorder's own share of a write, alone."""

    def write_lowcmd(self, _commands: object) -> None:
        pass


def lowcmd_steps() -> list[Step]:
    """~/lowcmd -> rt/lowcmd, in the order the node runs them."""
    from g1_mode_manager_msgs.msg import JointCommand
    from rclpy.serialization import serialize_message

    from g1_mode_manager.flight_recorder.recording_port import RecordingPort
    from g1_mode_manager.node.joint_command_cdr import JointCommandReader
    from g1_mode_manager.sdk.frames import FrameWriter, LowCmdFrame
    from g1_mode_manager.sdk.lowcmd import build_lowcmd_frame

    n = NUM_JOINTS
    data = serialize_message(JointCommand(name=list(JOINT_NAMES), q=[0.0] * n, dq=[0.0] * n, tau=[0.0] * n,
                                          kp=[40.0] * n, kd=[2.0] * n))
    reader = JointCommandReader()
    names, block = reader.block(data)
    checked = validate_lowcmd_block(names, block)
    gate = ForwardGate(_state_in(Mode.LOW_LEVEL))
    events = RelayEvents(lambda _level, _text: None)
    frame = LowCmdFrame()
    writer = FrameWriter("rt/bench_steps_lowcmd")
    build_lowcmd_frame(frame, checked, 5)
    ring = FlightRing(caps_for(33.0))
    recording = RecordingPort(_Unwritten(), ring.add, frame_period_s=0.1)  # type: ignore[arg-type]
    words = np.zeros(251, dtype="<u4")

    def gate_step() -> bool:
        with gate.forwarding(modes.allows_low_level_commands) as decision:
            return decision.allowed

    return [("decode (JointCommand bytes -> a 5 x n view)", lambda: reader.block(data)),
            ("validate (names, ranges, gains, torques)", lambda: validate_lowcmd_block(names, block)),
            ("gate (forward lock, mode predicate)", gate_step),
            ("counters (received, sent)", lambda: (events.count("lowcmd_received"), events.count("lowcmd_sent"))),
            ("encode (columns into the LowCmd_ struct)", lambda: build_lowcmd_frame(frame, checked, 5)),
            ("CRC (over the frame's 250 words)", lambda: crc32_of_array(words, 250)),
            ("CDR bytes (CRC included)", lambda: writer.serialize(frame)),
            ("write (Cyclone, no reader)", lambda: writer.write_bytes(writer.serialize(frame))),
            ("recorder port around the write (keeps 10 frames a s)",
             lambda: recording.write_lowcmd(checked))]


def lowcmd_column_steps() -> list[Step]:
    """The same message read as columns of Python floats (a message of another layout; the node's path before the
    5 x n view), for comparison."""
    from g1_mode_manager_msgs.msg import JointCommand
    from rclpy.serialization import serialize_message

    from g1_mode_manager.node.joint_command_cdr import JointCommandReader
    from g1_mode_manager.sdk.frames import LowCmdFrame
    from g1_mode_manager.sdk.lowcmd import build_lowcmd_frame

    n = NUM_JOINTS
    data = serialize_message(JointCommand(name=list(JOINT_NAMES), q=[0.0] * n, dq=[0.0] * n, tau=[0.0] * n,
                                          kp=[40.0] * n, kd=[2.0] * n))
    reader = JointCommandReader()
    fields = reader.fields(data)
    checked = validate_lowcmd(*fields)
    frame = LowCmdFrame()
    return [("decode (JointCommand bytes -> tuples)", lambda: reader.fields(data)),
            ("validate (tuples)", lambda: validate_lowcmd(*fields)),
            ("encode (tuples into the struct)", lambda: build_lowcmd_frame(frame, checked, 5))]


def cmd_vel_steps() -> list[Step]:
    """/cmd_vel -> Move."""
    from geometry_msgs.msg import Twist
    from rclpy.serialization import serialize_message

    from g1_mode_manager.node.twist_cdr import twist_velocity
    from g1_mode_manager.sdk.request_writer import encode

    msg = Twist()
    msg.linear.x = 0.3
    data = serialize_message(msg)
    gate = ForwardGate(_state_in(Mode.HIGH_LEVEL))
    limits = VelocityLimits(0.5, 0.3, 1.0, 1.0, 1.0, 2.0)

    def gate_step() -> bool:
        with gate.forwarding(modes.allows_cmd_vel) as decision:
            return decision.allowed

    return [("decode (Twist bytes -> vx, vy, wz)", lambda: twist_velocity(data)),
            ("sanitise (finite, clamped)", lambda: sanitize(0.3, 0.0, 0.1, limits)),
            ("gate (forward lock, mode predicate)", gate_step),
            ("Move parameter (JSON, as the RPC client makes it)",
             lambda: json.dumps({"velocity": [0.3, 0.0, 0.1], "duration": 1.0})),
            ("Move request bytes", lambda: encode(b"\x00\x01\x00\x00", 12345, 7105, '{"velocity": [0.3, 0.0, 0.1], '
                                                  '"duration": 1.0}', False))]


def arm_steps() -> list[Step]:
    """~/arm_cmd -> rt/arm_sdk."""
    from rclpy.serialization import deserialize_message, serialize_message
    from sensor_msgs.msg import JointState

    from g1_mode_manager.sdk.arm_sdk import build_arm_sdk_frame
    from g1_mode_manager.sdk.frames import FrameWriter, LowCmdFrame

    msg = JointState(name=list(ARM_SDK_JOINT_NAMES[3:5]), position=[0.3, 0.2])
    data = serialize_message(msg)
    targets = [MotorCommand(q=0.1, kp=60.0, kd=1.5)] * len(ARM_SDK_JOINT_NAMES)
    frame = LowCmdFrame()
    writer = FrameWriter("rt/bench_steps_arm_sdk")
    return [("decode (rclpy's JointState message)", lambda: deserialize_message(data, JointState)),
            ("validate (names, finite)", lambda: validate_arm_targets(list(msg.name), list(msg.position))),
            ("encode (17 targets + weight into the struct)", lambda: build_arm_sdk_frame(frame, targets, 0.5)),
            ("CDR bytes (CRC included) + write (no reader)", lambda: writer.write(frame))]


def main(argv: list[str]) -> int:
    domain = int(argv[0]) if argv else 96
    n = int(argv[1]) if len(argv) > 1 else 5000
    init_channels(domain, "lo")
    print(f"{'':<64} {'warm':>7}    {'cold':>7}")
    for path, steps in (("~/lowcmd -> rt/lowcmd", lowcmd_steps()),
                        ("  the same as tuples (other layouts)", lowcmd_column_steps()),
                        ("/cmd_vel -> Move", cmd_vel_steps()),
                        ("~/arm_cmd -> rt/arm_sdk", arm_steps())):
        print(path)
        warm_total = cold_total = 0.0
        for name, fn in steps:
            warm, cold = per_call_us(fn, n), cold_call_us(fn, max(1, n // 10))
            warm_total += warm
            cold_total += cold
            print(f"  {name:<62} {warm:7.2f} us {cold:7.2f} us")
        print(f"  {'sum':<62} {warm_total:7.2f} us {cold_total:7.2f} us")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
