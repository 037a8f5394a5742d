"""The chaos suite: the real node against the real sim bridge under random fault schedules, judged by the robot.

One bridge serves the whole batch (reset to its boot state between scenarios); every scenario starts a
fresh node (EMERGENCY is latched), injects random per-request delays on CheckMode / SelectMode /
ReleaseMode / SetFsmId (0-3 s, so in-flight calls land in every order), failing Damps, random mode
requests, loco commands and /cmd_vel from two clients, and an e-stop at a random instant through the
service or the topic (reliable or best effort). See scenario.judge for the invariants.

CI runs a fixed-seed batch (G1_CHAOS_N, default 10); `make chaos N=500 SEED=...` a longer one. The
last line of a batch is `chaos: N scenarios, V violations`, with each failing seed above it.
"""

from __future__ import annotations

import os
import threading
import time
from pathlib import Path

import pytest
from g1_mode_manager_msgs.msg import Mode
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import Bool
from std_srvs.srv import Trigger

from chaos.scenario import Claims, judge, plan, run_actions
from e2e.conftest import Stack
from g1_mode_manager.node.mode_manager import MODE_QOS
from support.mode_manager import RosClient, start_mode_manager, wait_until
from support.sim_bridge import shared_sim_status, start_sim_bridge
from support.sim_record import SimRecord

pytestmark = [pytest.mark.e2e, pytest.mark.sim]

N = int(os.environ.get("G1_CHAOS_N", "10"))
SEED = int(os.environ.get("G1_CHAOS_SEED", "7000"))
SUMMARY = os.environ.get("G1_CHAOS_SUMMARY", "")
#: Node call timeouts longer than the longest injected delay: every in-flight call's reply comes back.
NODE_PARAMS = ("rpc_timeout_s:=4.0", "select_timeout_s:=10.0", "release_timeout_s:=8.0")
SETTLE_S = 12.0  # after the faults clear, supervision must get the robot damped within this


def test_chaos_batch(sdk_channels: int, tmp_path: Path) -> None:
    record_path = tmp_path / "chaos_record.jsonl"
    bridge = start_sim_bridge(sdk_channels, speed=1.0, extra_args=("--record", str(record_path)))
    ros = RosClient("chaos_client")
    current: list[Claims] = [Claims()]

    def on_mode(msg: Mode) -> None:
        claims = current[0]
        with claims.lock:
            claims.modes.append((time.monotonic(), msg))

    ros.node.create_subscription(Mode, "/g1_mode_manager/mode", on_mode, MODE_QOS)
    estop_pubs = {
        "topic_reliable": ros.node.create_publisher(Bool, "/estop", 10),
        "topic_best_effort": ros.node.create_publisher(Bool, "/estop",
                                                       QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT)),
    }
    sim = shared_sim_status()
    sim.wait_ready(15.0)
    record = SimRecord(record_path)
    failures: list[str] = []
    latencies: list[float] = []
    try:
        for i in range(N):
            seed = SEED + i
            claims = Claims()
            current[0] = claims
            bad = _scenario(seed, bridge, ros, sim, record, claims, estop_pubs, latencies)
            if bad:
                failures.append(f"seed {seed}: " + "; ".join(bad))
                print(f"chaos: VIOLATION seed {seed}: {bad}", flush=True)
    finally:
        ros.close()
        bridge.stop()
    latencies.sort()
    if latencies:
        median = latencies[len(latencies) // 2] * 1000
        print(f"chaos: e-stop request -> first Damp received by the robot: median {median:.2f} ms, "
              f"max {latencies[-1] * 1000:.2f} ms (n={len(latencies)})")
    line = f"chaos: {N} scenarios, {len(failures)} violations"
    print("\n".join([*failures, line]), flush=True)
    if SUMMARY:
        Path(SUMMARY).write_text("\n".join([*failures, line]) + "\n")
    assert not failures, "\n".join(failures)


def _scenario(seed, bridge, ros, sim, record, claims, estop_pubs, latencies) -> list[str]:
    p = plan(seed)
    sim.reset()
    node = start_mode_manager(int(os.environ["G1_TEST_SDK_DOMAIN"]), *NODE_PARAMS)
    try:
        ros.wait_node_answers()
        stack = Stack(bridge, node, ros, sim, record)
        estop_client = ros.node.create_client(Trigger, "/g1_mode_manager/estop")  # discovered before the instant
        assert estop_client.wait_for_service(timeout_sec=10.0)
        stack.set_faults(p.faults)
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
            estop_pubs[p.estop_via].publish(Bool(data=True))
            wait_until(lambda: any(m.mode == Mode.EMERGENCY for _, m in claims.modes), 5.0)
        actions.join(40.0)
        stop.set()
        stack.set_faults({})
        wait_until(lambda: sim.get()["sport"]["fsm_id"] == 1 and sim.get()["sport"]["mode"] != "", SETTLE_S, 0.1)
        time.sleep(0.5)
        end_state = sim.get()
        events = record.after_last_reset()
        first_damp = next((e["t"] for e in events if e["k"] == "req" and e["t"] >= claims.t_estop
                           and e.get("api") == 7101 and e.get("p") == '{"data": 1}'), None)
        before = [m for t, m in claims.modes if t < claims.t_estop]
        connected = bool(before) and before[-1].mode != Mode.UNINITIALIZED
        if first_damp is not None and connected:  # from UNINITIALIZED the e-stop first connects (~1.5 s)
            latencies.append(first_damp - claims.t_estop)
        return judge(events, claims, end_state)
    finally:
        if "estop_client" in locals():
            ros.node.destroy_client(estop_client)
        code = node.stop()
        ros.wait_service_gone("/g1_mode_manager/set_mode")
        if code not in (0, None):
            print(f"chaos seed {seed}: node exited with {code}:\n{node.output()[-3000:]}")


def _call(client, timeout_s: float):
    done = threading.Event()
    future = client.call_async(Trigger.Request())
    future.add_done_callback(lambda _f: done.set())
    if not done.wait(timeout_s):
        raise TimeoutError(f"~/estop did not answer within {timeout_s} s")
    return future.result()
