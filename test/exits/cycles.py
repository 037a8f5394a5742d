"""Start the node, operate it into one of several states, SIGINT it; N times. Every exit must be clean.

A clean exit is exit code 0 within CLEAN_EXIT_S of the SIGINT (the shutdown ramps the arms out and stops
the robot first, bounded well below that). The states at SIGINT cover what a user leaves a node in: just
started, connected and idle, HIGH_LEVEL with /cmd_vel and arm commands streaming, LOW_LEVEL with joint
commands streaming, a transition in flight (CheckMode held by the sim), and EMERGENCY after an e-stop.
One sim serves every cycle (reset in between); the next node starts while the current one runs. An unclean
exit's output (with the faulthandler's stacks of every thread) is kept in ``--keep``.

The last line is ``exits: N cycles, U unclean``; the exit status is 1 when U > 0.
"""

from __future__ import annotations

import argparse
import random
import threading
import time
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from e2e.conftest import Stack
from g1_mode_manager.protocol import api_ids
from support.mode_manager import RosClient, start_mode_manager
from support.processes import ManagedProcess
from support.sim_bridge import shared_sim_status, start_sim_bridge

STATES = ("uninitialized", "idle", "high_level_streaming", "low_level_streaming", "in_transition", "emergency")
CLEAN_EXIT_S = 5.0
NAMESPACES = 3
#: CheckMode held this long by the sim while a transition is in flight at SIGINT, s.
HELD_CHECK_MODE_S = 2.0


def main(sdk_domain: int, argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="make exits", description=__doc__.splitlines()[0])
    ap.add_argument("--cycles", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--keep", type=Path, default=Path(".venv/exits_unclean"), help="unclean exits' output")
    args = ap.parse_args(argv)
    from g1_mode_manager.protocol.dds import init_channels

    init_channels(sdk_domain, "lo")
    bridge = start_sim_bridge(sdk_domain, extra_args=("--gantry",))  # hung: a limp robot cannot fall (FAULT)
    ros = RosClient("exits_client")
    sim = shared_sim_status()
    sim.wait_ready(15.0)
    rng = random.Random(args.seed)
    unclean: list[str] = []
    states: Counter[str] = Counter()
    stop_s: list[float] = []
    started = time.monotonic()

    def start(k: int) -> tuple[str, ManagedProcess]:
        ns = f"/exits{k % NAMESPACES}"
        return ns, start_mode_manager(sdk_domain, remaps=(f"__ns:={ns}", f"/estop:={ns}/estop",
                                                          f"/cmd_vel:={ns}/cmd_vel"))

    try:
        with ThreadPoolExecutor(1) as starter:
            upcoming = starter.submit(start, 0)
            for k in range(args.cycles):
                ns, node = upcoming.result(60.0)
                if k + 1 < args.cycles:
                    upcoming = starter.submit(start, k + 1)
                state = rng.choice(STATES)
                states[state] += 1
                stack = Stack(bridge, node, ros, sim, None, ns)  # type: ignore[arg-type]
                code, took = _cycle(stack, state, rng)
                stop_s.append(took)
                if code != 0 or took > CLEAN_EXIT_S:
                    unclean.append(f"cycle {k} ({state}): exit {code} after {took:.1f} s")
                    args.keep.mkdir(parents=True, exist_ok=True)
                    (args.keep / f"cycle{k}_{state}.log").write_text(node.output())
                    print(f"exits: cycle {k} ({state}) exited with {code} after {took:.1f} s:\n{node.output()[-3000:]}",
                          flush=True)
                if (k + 1) % 100 == 0:
                    print(f"exits: {k + 1} cycles so far, {len(unclean)} unclean", flush=True)
    finally:
        ros.close()
        bridge.stop()
    stop_s.sort()
    n = len(stop_s)
    if n:
        print(f"exits: SIGINT -> exit: median {stop_s[n // 2]:.2f} s, max {stop_s[-1]:.2f} s; "
              f"{(time.monotonic() - started) / n:.1f} s per cycle; states at SIGINT: {dict(states)}")
    for line in unclean:
        print(line)
    print(f"exits: {n} cycles, {len(unclean)} unclean" + (f" (output kept in {args.keep})" if unclean else ""))
    return 1 if unclean else 0


def _cycle(stack: Stack, state: str, rng: random.Random) -> tuple[int | None, float]:
    """Operate the node into ``state``, SIGINT it there; (exit code, s from SIGINT to exit)."""
    stack.sim.reset()
    stop = threading.Event()
    background: list[threading.Thread] = []
    try:
        if state == "idle":
            stack.set_mode("idle")
        elif state == "high_level_streaming":
            stack.set_mode("high_level")
            background = [_streaming(stack, "cmd_vel", stop), _streaming(stack, "arm_cmd", stop)]
        elif state == "low_level_streaming":
            stack.set_mode("low_level")
            background = [_streaming(stack, "lowcmd", stop)]
        elif state == "in_transition":
            stack.set_faults({"delay_s": {str(api_ids.MS_CHECK_MODE): HELD_CHECK_MODE_S}})
            background = [_thread(lambda: _quietly(stack.set_mode, "high_level", 10.0))]
        elif state == "emergency":
            stack.set_mode("high_level")
            stack.estop()
        time.sleep(rng.uniform(0.05, 0.8))
        t = time.monotonic()
        code = stack.node.stop(timeout_s=10.0)
        return code, time.monotonic() - t
    finally:
        stop.set()
        for th in background:
            th.join(12.0)
        if state == "in_transition":
            stack.set_faults({})


def _thread(target: Any) -> threading.Thread:
    th = threading.Thread(target=target, daemon=True)
    th.start()
    return th


def _quietly(call: Any, *args: Any) -> None:
    try:
        call(*args)
    except (TimeoutError, RuntimeError):
        pass  # the node went away under it: that is the point


_PUBLISHERS: dict[str, Any] = {}


def _streaming(stack: Stack, what: str, stop: threading.Event) -> threading.Thread:
    topic, msg, rate_hz = _message(stack, what)
    if topic not in _PUBLISHERS:
        _PUBLISHERS[topic] = stack.ros.node.create_publisher(type(msg), topic, 10)
    pub = _PUBLISHERS[topic]

    def run() -> None:
        while not stop.wait(1.0 / rate_hz):
            pub.publish(msg)

    return _thread(run)


def _message(stack: Stack, what: str) -> tuple[str, Any, float]:
    if what == "cmd_vel":
        from geometry_msgs.msg import Twist

        msg = Twist()
        msg.angular.z = 0.2
        return f"{stack.ns}/cmd_vel", msg, 50.0
    if what == "arm_cmd":
        from sensor_msgs.msg import JointState

        return stack.name("arm_cmd"), JointState(name=["left_shoulder_roll_joint"], position=[0.4]), 50.0
    from g1_mode_manager_msgs.msg import JointCommand

    return stack.name("lowcmd"), JointCommand(name=["left_elbow_joint"], q=[0.8], dq=[0.0], tau=[0.0], kp=[30.0],
                                              kd=[1.5]), 500.0
