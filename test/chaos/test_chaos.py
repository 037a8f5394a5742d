"""The chaos suite: the real node against the real sim bridge under random fault schedules, judged by the robot.

One bridge serves the whole batch (reset to its boot state between scenarios); every scenario starts a
fresh node (EMERGENCY is latched), injects random per-request delays on CheckMode / SelectMode /
ReleaseMode / SetFsmId (0-3 s, so in-flight calls land in every order), failing Damps, random mode
requests, loco commands and /cmd_vel from two clients, body faults made true in the sim (pushes,
overheated motors, a drained battery, L2+B on the remote, a frozen state stream; the robot hung in the
gantry or not, per scenario) and clear_fault calls, and an e-stop at a random instant through the
service or the topic (reliable or best effort). See scenario.judge for the invariants.

CI runs a fixed-seed batch (G1_CHAOS_N, default 40) in G1_CHAOS_PARTS parts (default 2: seeds split in
consecutive ranges, each part with its own bridge); `make chaos N=500 SEED=...`
runs one part. The last line of a part is `chaos: N scenarios, V violations`, each failing seed above it.
"""

from __future__ import annotations

import contextlib
import itertools
import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from g1_mode_manager_msgs.msg import Mode
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import Bool
from std_srvs.srv import Trigger

from chaos.scenario import Claims, judge, plan, run_actions
from e2e.conftest import Stack
from g1_mode_manager.topic_qos import MODE_QOS
from support.mode_manager import RosClient, start_mode_manager, wait_until
from support.sim_bridge import shared_sim_status, start_sim_bridge
from support.sim_record import SimRecord

pytestmark = [pytest.mark.e2e, pytest.mark.sim]

N = int(os.environ.get("G1_CHAOS_N", "40"))
SEED = int(os.environ.get("G1_CHAOS_SEED", "7000"))
SUMMARY = os.environ.get("G1_CHAOS_SUMMARY", "")
PARTS = min(2, max(1, int(os.environ.get("G1_CHAOS_PARTS", "2"))))
#: Node call timeouts longer than the longest injected delay: every in-flight call's reply comes back.
NODE_PARAMS = ("rpc_timeout_s:=4.0", "select_timeout_s:=10.0", "release_timeout_s:=8.0")
SETTLE_S = 12.0  # after the faults clear, supervision must get the robot damped within this


#: Namespaces the scenarios' nodes cycle through: the next node starts while the current one runs and the
#: previous one may still be leaving the graph. The test's ROS entities are made once per namespace:
#: destroying them while the client's executor waits on them kills its spin thread (rclpy InvalidHandle).
NAMESPACES = 3


class Endpoints:
    """The test's subscription, client and publishers for one namespace, made once and reused."""

    def __init__(self, ros: RosClient, ns: str) -> None:
        self.claims = Claims()
        self.mode_sub = ros.node.create_subscription(Mode, f"{ns}/g1_mode_manager/mode", self._on_mode, MODE_QOS)
        self.estop_client = ros.node.create_client(Trigger, f"{ns}/g1_mode_manager/estop")
        self.estop_pubs = {
            "topic_reliable": ros.node.create_publisher(Bool, f"{ns}/estop", QoSProfile(depth=10)),
            "topic_best_effort": ros.node.create_publisher(
                Bool, f"{ns}/estop", QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)),
        }

    def _on_mode(self, msg: Mode) -> None:
        claims = self.claims
        with claims.lock:
            claims.modes.append((time.monotonic(), msg))


def _start_node(k: int):
    """The node of scenario k, in a namespace of its own with its own /estop and /cmd_vel, so it can start
    (UNINITIALIZED: it touches nothing on the robot) while scenario k-1 still runs."""
    ns = f"/chaos{k % NAMESPACES}"
    node = start_mode_manager(int(os.environ["G1_TEST_SDK_DOMAIN"]), *NODE_PARAMS,
                              remaps=(f"__ns:={ns}", f"/estop:={ns}/estop", f"/cmd_vel:={ns}/cmd_vel"))
    return ns, node


def parts(half: int) -> list:
    """(first seed, count) of the CI batch's ``half`` (0 or 1; with G1_CHAOS_PARTS=1 the first has it all).
    The second half runs from a file of its own (test_chaos_second_half.py): xdist keeps a file on one
    worker, and the two halves run side by side on two."""
    bounds = [N * k // PARTS for k in range(PARTS + 1)]
    halves = [pytest.param(SEED + lo, hi - lo, id=f"seeds{SEED + lo}-{SEED + hi - 1}")
              for lo, hi in itertools.pairwise(bounds) if hi > lo]  # fmt: skip
    return halves[half::2]


@pytest.mark.parametrize(("first_seed", "count"), parts(0))
def test_chaos_batch(sdk_channels: int, tmp_path: Path, first_seed: int, count: int) -> None:
    os.environ["PYTHONFAULTHANDLER"] = "1"  # a node that crashes prints every thread's Python stack
    record_path = tmp_path / "chaos_record.jsonl"
    bridge = start_sim_bridge(sdk_channels, speed=1.0, extra_args=("--record", str(record_path)))
    ros = RosClient("chaos_client")
    sim = shared_sim_status()
    sim.wait_ready(15.0)
    record = SimRecord(record_path)
    endpoints = {f"/chaos{k}": Endpoints(ros, f"/chaos{k}") for k in range(NAMESPACES)}
    failures: list[str] = []
    latencies: list[float] = []
    unclean: list[str] = []  # nodes that did not exit 0 on SIGINT (not a safety violation; reported)
    body = {"body faults injected": 0, "FAULT entered": 0, "holds": 0, "hung in the gantry": 0}
    started = time.monotonic()
    with ThreadPoolExecutor(1) as starter:
        upcoming = starter.submit(_start_node, 0)
        try:
            for i in range(count):
                ns, node = upcoming.result(60.0)
                if i + 1 < count:
                    upcoming = starter.submit(_start_node, i + 1)
                seed = first_seed + i
                bad = _scenario(seed, Stack(bridge, node, ros, sim, record, ns), endpoints[ns], latencies, unclean, body)
                if bad:
                    failures.append(f"seed {seed}: " + "; ".join(bad))
                    print(f"chaos: VIOLATION seed {seed}: {bad}", flush=True)
                if (i + 1) % 50 == 0:
                    print(f"chaos: {i + 1} scenarios so far, {len(failures)} violations", flush=True)
        finally:
            if not upcoming.cancel():
                with contextlib.suppress(Exception):
                    upcoming.result(60.0)[1].stop()
            ros.close()
            bridge.stop()
    latencies.sort()
    if latencies:
        median = latencies[len(latencies) // 2] * 1000
        print(f"chaos: e-stop request -> first Damp received by the robot (node connected): median {median:.2f} ms, "
              f"max {latencies[-1] * 1000:.2f} ms (n={len(latencies)})")
    print("chaos: scenarios with " + ", ".join(f"{what} {n}" for what, n in body.items()))
    print(f"chaos: {(time.monotonic() - started) / max(count, 1):.1f} s per scenario; nodes that did not exit cleanly on "
          f"SIGINT: {len(unclean)} {unclean}")
    line = f"chaos: {count} scenarios, {len(failures)} violations"
    print("\n".join([*failures, line]), flush=True)
    if SUMMARY:
        Path(SUMMARY).write_text("\n".join([*failures, line]) + "\n")
    assert not failures, "\n".join(failures)


def _scenario(seed: int, stack: Stack, ends: Endpoints, latencies: list[float], unclean: list[str],
              body: dict[str, int]) -> list[str]:  # fmt: skip
    p = plan(seed)
    body["body faults injected"] += any(kind == "body" for _, _, kind, _ in p.actions)
    body["hung in the gantry"] += p.gantry
    ros, sim, node = stack.ros, stack.sim, stack.node
    claims = ends.claims = Claims()
    estop_client = ends.estop_client
    estop_pub = ends.estop_pubs.get(p.estop_via)
    try:
        sim.reset()
        ros.wait_node_answers(f"{stack.ns}/g1_mode_manager")
        assert estop_client.wait_for_service(timeout_sec=10.0)
        assert estop_pub is None or wait_until(lambda: estop_pub.get_subscription_count() >= 1, 10.0)
        stack.set_faults(p.faults)
        stack.set_gantry(p.gantry)
        stop = threading.Event()
        t0 = time.monotonic()
        actions = threading.Thread(target=run_actions, args=(stack, p, t0, stop), daemon=True)
        actions.start()
        time.sleep(max(0.0, t0 + p.estop_at - time.monotonic()))
        claims.t_estop = time.monotonic()
        if p.estop_via == "service":
            reply = _call(estop_client, 40.0)
            claims.t_answer, claims.estop_success = time.monotonic(), reply.success
        else:
            estop_pub.publish(Bool(data=True))
        actions.join(40.0)
        stop.set()
        stack.set_faults({})
        # the robot damped, and by the node's e-stop: the remote's L2+B damps it by itself (the built-in
        # controller), while an e-stop from UNINITIALIZED first connects (~1.5 s)
        wait_until(lambda: _damped(sim.get()) and _damp_since(stack.record, claims.t_estop), SETTLE_S, 0.1)
        time.sleep(0.3)
        end_state = sim.get()
        alive = node.alive()
        events = stack.record.after_last_reset()
        first_damp = next((e["t"] for e in events if e["k"] == "req" and e["t"] >= claims.t_estop
                           and e.get("api") == 7101 and e.get("p") == '{"data": 1}'), None)
        with claims.lock:
            before = [m for t, m in claims.modes if t < claims.t_estop]
            body["FAULT entered"] += any(m.mode == Mode.FAULT for _, m in claims.modes)
            body["holds"] += any(m.holds for _, m in claims.modes)
        connected = bool(before) and before[-1].mode != Mode.UNINITIALIZED
        if first_damp is not None and connected:  # from UNINITIALIZED the e-stop first connects (~1.5 s)
            latencies.append(first_damp - claims.t_estop)
        crashed = [] if alive else [f"the node died during the scenario (exit {node.proc.returncode}): "
                                    f"{node.output()[-1500:]}"]
        return crashed + judge(events, claims, end_state)
    finally:
        t_stop = time.monotonic()
        code = node.stop()  # before the next reset: its supervision would damp the fresh robot
        stop_s = time.monotonic() - t_stop
        if os.environ.get("G1_CHAOS_VERBOSE"):
            print(node.output())
        if code not in (0, None) or stop_s > 5.0:
            unclean.append(f"seed {seed}: exit {code} after {stop_s:.1f} s")
            print(f"chaos seed {seed}: node exited with {code} after {stop_s:.1f} s:\n{node.output()[-3000:]}")


def _damp_since(record: SimRecord, t: float) -> bool:
    return any(e["k"] == "req" and e.get("api") == 7101 and e.get("p") == '{"data": 1}' for e in record.events(t))


def _damped(status: dict) -> bool:
    return status["sport"]["fsm_id"] == 1 and status["sport"]["mode"] != ""


def _call(client, timeout_s: float):
    done = threading.Event()
    future = client.call_async(Trigger.Request())
    future.add_done_callback(lambda _f: done.set())
    if not done.wait(timeout_s):
        raise TimeoutError(f"~/estop did not answer within {timeout_s} s")
    return future.result()
