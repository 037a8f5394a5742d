"""make bench: e-stop latency, cmd_vel -> Move latency and node CPU, against the simulated G1.

Everything runs on loopback on domains of its own. The sim bridge stamps every RPC request with
CLOCK_MONOTONIC when its server thread takes it; that clock is shared by all processes of the
machine, so "request sent" (here) and "received by the robot" (there) are directly comparable.
Prints a table; not part of the test pass/fail.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "test"))  # test/support: process management and the sim status client

os.environ.setdefault("ROS_DOMAIN_ID", str(90 + os.getpid() % 10))
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
SDK_DOMAIN = 200 + os.getpid() % 20

from g1_mode_manager.protocol import api_ids  # noqa: E402
from support.mode_manager import RosClient, start_mode_manager, wait_until  # noqa: E402
from support.sim_bridge import SimStatus, shared_sim_status, start_sim_bridge  # noqa: E402

SPORT, SWITCHER = api_ids.LOCO_SERVICE, api_ids.MOTION_SWITCHER_SERVICE


def pct(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


def summary(values_s: list[float]) -> str:
    ms = [v * 1000 for v in values_s]
    return f"median {statistics.median(ms):7.2f} ms   p99 {pct(ms, 0.99):7.2f} ms   max {max(ms):7.2f} ms   (n={len(ms)})"


class Bench:
    def __init__(self, sim: SimStatus, ros: RosClient) -> None:
        self.sim = sim
        self.ros = ros

    def recent_requests(self, service: str, api_id: int) -> list[dict]:
        return self.sim.get().get("recent_requests", {}).get(service, {}).get(str(api_id), [])

    def wait_request_after(self, service: str, api_id: int, t0: float, timeout_s: float,
                           match: Callable[[dict], bool] = lambda _r: True) -> float | None:
        """Monotonic receive time of the first request of api_id at or after t0, or None."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            hits = [r["t"] for r in self.recent_requests(service, api_id) if r["t"] >= t0 and match(r)]
            if hits:
                return min(hits)
            time.sleep(0.002)
        return None

    def set_mode(self, name: str):
        from g1_mode_manager_msgs.srv import SetMode

        return self.ros.call(SetMode, "/g1_mode_manager/set_mode", SetMode.Request(mode_name=name))

    def estop_client(self):
        """A ready ~/estop client, so that the timed call does not include discovery."""
        from std_srvs.srv import Trigger

        client = self.ros.node.create_client(Trigger, "/g1_mode_manager/estop")
        assert client.wait_for_service(timeout_sec=10.0)
        time.sleep(0.2)  # let the response reader match too
        return client

    def estop(self, client):
        from std_srvs.srv import Trigger

        future = client.call_async(Trigger.Request())
        done = threading.Event()
        future.add_done_callback(lambda _f: done.set())
        assert done.wait(30.0), "estop did not answer"
        return future.result()


def estop_latency(bench: Bench, samples: int, slow_select: bool) -> tuple[list[float], list[float]]:
    """Per sample: a fresh node (EMERGENCY is final); HIGH_LEVEL (or a SelectMode held by the sim); e-stop."""
    to_robot, to_reply = [], []
    for _ in range(samples):
        node = start_mode_manager(SDK_DOMAIN)
        bench.ros.wait_node_answers()
        client = None
        try:
            if slow_select:
                assert bench.set_mode("low_level").success
                selects_before = time.monotonic()
                worker = threading.Thread(target=bench.set_mode, args=("high_level",), daemon=True)
                worker.start()
                assert bench.wait_request_after(SWITCHER, api_ids.MS_SELECT_MODE, selects_before, 5.0)
            else:
                assert bench.set_mode("high_level").success
            client = bench.estop_client()
            t0 = time.monotonic()
            reply = bench.estop(client)
            t_reply = time.monotonic()
            t_damp = bench.wait_request_after(SPORT, api_ids.LOCO_SET_FSM_ID, t0, 5.0)
            assert t_damp is not None and reply.success, reply.message
            to_robot.append(t_damp - t0)
            to_reply.append(t_reply - t0)
        except BaseException:
            print(f"mode_manager output:\n{node.output()[-3000:]}", file=sys.stderr)
            raise
        finally:
            node.stop()
            bench.ros.wait_service_gone("/g1_mode_manager/set_mode")
            if client is not None:
                bench.ros.node.destroy_client(client)
    return to_robot, to_reply


def cmd_vel_latency(bench: Bench, samples: int) -> list[float]:
    """Publish a new vx; time until the sim receives a SetVelocity carrying it (20 Hz relay + RPC)."""
    from geometry_msgs.msg import Twist

    pub = bench.ros.node.create_publisher(Twist, "/cmd_vel", 10)
    assert wait_until(lambda: pub.get_subscription_count() > 0, 10.0)
    out = []
    for i in range(samples):
        vx = round(0.20 + 0.01 * (i % 2), 2)  # alternate: each value differs from the last, within one ramp step
        msg = Twist()
        msg.linear.x = vx
        t0 = time.monotonic()
        pub.publish(msg)
        t = bench.wait_request_after(SPORT, api_ids.LOCO_SET_VELOCITY, t0, 2.0,
                                     lambda r, vx=vx: abs(json.loads(r["parameter"])["velocity"][0] - vx) < 1e-6)
        if t is not None:
            out.append(t - t0)
        for _ in range(3):  # keep the watchdog fed while waiting a little between samples
            pub.publish(msg)
            time.sleep(0.03)
    return out


def raw_move_round_trip(samples: int) -> list[float]:
    from g1_mode_manager.sdk.loco_client import LocoClient

    client = _RAW_CLIENTS.setdefault("loco", LocoClient(1.0))  # SDK clients must never be collected
    client.wait_ready(5.0)
    out = []
    for _ in range(samples):
        t0 = time.monotonic()
        client.set_velocity(0.2, 0.0, 0.0, 1.0)
        out.append(time.monotonic() - t0)
        time.sleep(0.01)
    client.stop_move()
    return out


_RAW_CLIENTS: dict = {}


def cpu_percent(pid: int, seconds: float, during: Callable[[], None] | None = None) -> float:
    def ticks() -> int:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return int(fields[11]) + int(fields[12])  # utime + stime

    hz = os.sysconf("SC_CLK_TCK")
    start_ticks, start = ticks(), time.monotonic()
    if during is None:
        time.sleep(seconds)
    else:
        end = start + seconds
        while time.monotonic() < end:
            during()
    return 100.0 * (ticks() - start_ticks) / hz / (time.monotonic() - start)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="bench", description=__doc__.split("\n\n")[0])
    parser.add_argument("--samples", type=int, default=20, help="e-stop samples per case (each starts a node)")
    args = parser.parse_args(argv)
    from g1_mode_manager.protocol.dds import init_channels

    init_channels(SDK_DOMAIN, "lo")
    rows: list[tuple[str, str]] = []
    bridge = start_sim_bridge(SDK_DOMAIN, speed=1.0)
    ros = RosClient("bench")
    try:
        sim = shared_sim_status()
        sim.wait_ready(15.0)
        bench = Bench(sim, ros)
        if "recent_requests" not in sim.get():
            print("the sim bridge does not report request times (recent_requests): cannot measure", file=sys.stderr)
            return 2
        robot, reply = estop_latency(bench, args.samples, slow_select=False)
        rows += [("e-stop: ~/estop call -> Damp received by the robot", summary(robot)),
                 ("e-stop: ~/estop call -> service reply (Damp acknowledged)", summary(reply))]
        bridge.stop()
        bridge = start_sim_bridge(SDK_DOMAIN, speed=1.0, faults={"delay_s": {str(api_ids.MS_SELECT_MODE): 2.0}})
        sim = shared_sim_status()
        sim.wait_ready(15.0)
        bench = Bench(sim, ros)
        robot, reply = estop_latency(bench, max(3, args.samples // 4), slow_select=True)
        rows += [("e-stop during a SelectMode held 2 s: -> Damp received", summary(robot)),
                 ("e-stop during a SelectMode held 2 s: -> reply (after re-select)", summary(reply))]
        bridge.stop()
        bridge = start_sim_bridge(SDK_DOMAIN, speed=1.0)
        sim = shared_sim_status()
        sim.wait_ready(15.0)
        bench = Bench(sim, ros)
        node = start_mode_manager(SDK_DOMAIN)
        bench.ros.wait_node_answers()
        try:
            assert bench.set_mode("high_level").success
            from g1_mode_manager_msgs.srv import LocoCommand

            start = ros.call(LocoCommand, "/g1_mode_manager/loco_command", LocoCommand.Request(command="start"))
            assert start.success, start.message
            time.sleep(2.0)
            idle_cpu = cpu_percent(node.proc.pid, 10.0)
            rows.append(("node CPU, HIGH_LEVEL, no cmd_vel", f"{idle_cpu:5.1f} % of one core"))
            rows.append(("cmd_vel publish -> Move received (relay at 20 Hz)", summary(cmd_vel_latency(bench, 100))))
            time.sleep(1.0)  # the node's watchdog stops the robot; the robot stays in walk mode (fsm 500)
            rows.append(("raw SDK Move (SetVelocity) round trip, same run", summary(raw_move_round_trip(200))))
            from geometry_msgs.msg import Twist

            pub = ros.node.create_publisher(Twist, "/cmd_vel", 10)
            wait_until(lambda: pub.get_subscription_count() > 0, 10.0)
            msg = Twist()
            msg.linear.x = 0.3

            def publish_100hz() -> None:
                pub.publish(msg)
                time.sleep(0.01)

            busy_cpu = cpu_percent(node.proc.pid, 10.0, publish_100hz)
            rows.append(("node CPU, HIGH_LEVEL, cmd_vel at 100 Hz", f"{busy_cpu:5.1f} % of one core"))
        finally:
            node.stop()
    finally:
        ros.close()
        bridge.stop()
    cpu = subprocess.run(["sh", "-c", "grep -m1 'model name' /proc/cpuinfo | cut -d: -f2"],
                         capture_output=True, text=True).stdout.strip()
    print(f"\nmachine: {platform.node()} | {cpu} | {os.cpu_count()} cores | Python {platform.python_version()}")
    width = max(len(r[0]) for r in rows)
    for name, value in rows:
        print(f"{name:<{width}}  {value}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
