"""The least any rclpy relay of ``~/lowcmd`` can cost in this stack: a process of its own that takes each
JointCommand as raw CDR bytes (the node's own ``StreamTaker``: a wait set of just that subscription, one take)
and, with ``--write``, writes one ready-made constant LowCmd_ frame to rt/lowcmd per message (the node's own
``FrameWriter``: pre-serialised bytes, one Cyclone write). No decoding, no check, no gate, no state read.

Run by bench/run.py, which measures this process's CPU while it publishes at 500 Hz, as it does for the node:
``python -m bench.relay_floor --domain D --topic /relay_floor/lowcmd [--write]``. It prints ``ready`` once
its subscription exists and runs until SIGINT/SIGTERM. Whatever the node costs above this figure is its own
work; this figure itself is rclpy's, Fast DDS's and Cyclone's.

``--check`` (with ``--write``) adds what every frame must go through, and nothing else: the node's own decode,
validation, frame build, CRC and write of each message's values (``joint_command_cdr``, ``validate_lowcmd_block``,
``build_lowcmd_frame``), in one flat function, without the node's gate, link check, counters or other threads: the
floor of a Python relay that checks every frame.
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading

from g1_mode_manager.protocol.dds import init_channels


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="relay_floor", description=__doc__.split("\n\n")[0])
    parser.add_argument("--domain", type=int, required=True, help="the SDK's DDS domain (the sim's)")
    parser.add_argument("--topic", required=True, help="the JointCommand topic to take")
    parser.add_argument("--write", action="store_true", help="write a constant rt/lowcmd frame per message")
    parser.add_argument("--check", action="store_true",
                        help="with --write: decode, check and build each message's own frame (the node's code)")
    args = parser.parse_args(argv)

    init_channels(args.domain, "lo")
    import rclpy
    from g1_mode_manager_msgs.msg import JointCommand
    from rclpy.node import Node

    from g1_mode_manager.node.stream_taker import StreamTaker
    from g1_mode_manager.protocol import topics
    from g1_mode_manager.sdk.frames import FrameWriter, LowCmdFrame

    rclpy.init()
    node = Node("relay_floor")
    taker = StreamTaker(node, name="floor_taker")
    count = [0]
    if args.write and args.check:
        from g1_mode_manager.core.joint_commands import validate_lowcmd_block
        from g1_mode_manager.node.joint_command_cdr import JointCommandReader
        from g1_mode_manager.sdk.lowcmd import build_lowcmd_frame

        writer = FrameWriter(topics.LOWCMD)
        reader, frame = JointCommandReader(), LowCmdFrame()

        def on_message(raw: bytes) -> None:
            count[0] += 1
            names, block = reader.block(raw)  # the bench's messages are the usual layout
            writer.write(build_lowcmd_frame(frame, validate_lowcmd_block(names, block), 5))
    elif args.write:
        writer = FrameWriter(topics.LOWCMD)
        frame = LowCmdFrame()
        # every motor disabled (mode 0, zero gains): nothing changes on a released robot, and the write
        # costs what any frame's does (same size, same path)
        frame.set_header(0, 5)
        data = writer.serialize(frame)

        def on_message(_raw: bytes) -> None:
            count[0] += 1
            writer.write_bytes(data)
    else:
        def on_message(_raw: bytes) -> None:
            count[0] += 1

    taker.subscribe(JointCommand, args.topic, on_message, 10, raw=True)  # the node's ~/lowcmd QoS
    taker.start()
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    print("ready", flush=True)
    stop.wait()
    taker.shutdown()
    node.destroy_node()
    rclpy.try_shutdown()
    print(f"taken {count[0]}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
