"""make bench: e-stop latency, cmd_vel -> Move latency and node CPU against the simulated G1, each beside
the raw SDK's own figure from the same run.

Everything runs on loopback on domains of its own. "Received" is the sim's own record (``--record``:
every request stamped with CLOCK_MONOTONIC where the sim's Cyclone delivers it); that clock is shared by
all processes of the machine, so "sent" (here) and "received by the robot" (there) compare directly.
The goals' raw references are taken right before each sample they judge (interleaved), so that both
see the same moments of the machine.
Node CPU is the node process's own utime + stime from /proc (robust to other load on the machine).
Prints a table and, last, one ``SUMMARY key=value ...`` line; not part of the test pass/fail.
"""

from __future__ import annotations

import argparse
import bisect
import json
import os
import platform
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from itertools import pairwise
from pathlib import Path

from harness.domains import allocate_run_domains

REPO = Path(__file__).resolve().parents[1]

# Domains held by file locks like the tests' (a bench beside a test run must not share its robot).
_ROS_DOMAIN, SDK_DOMAIN = allocate_run_domains()
os.environ["ROS_DOMAIN_ID"] = str(_ROS_DOMAIN)
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"

from g1_mode_manager.protocol import api_ids  # noqa: E402
from g1_mode_manager.protocol.motors import ARM_SDK_JOINT_NAMES, JOINT_NAMES  # noqa: E402
from harness.mode_manager import RosClient, start_mode_manager, wait_until  # noqa: E402
from harness.processes import restore_sigint  # noqa: E402
from harness.rate import run_at_rate  # noqa: E402
from harness.sim_bridge import shared_sim_status, start_sim_bridge  # noqa: E402
from harness.sim_record import is_damp, requests, velocity_of  # noqa: E402

NODE = "/g1_mode_manager"
#: The bench's nodes write their incidents (every e-stop sample makes one) into a folder of the run's own, never
#: into the user's.
INCIDENTS = Path(tempfile.mkdtemp(prefix="g1_bench_incidents_"))
RECORDER_OFF = "recorder_enabled:=false"


def pct(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q * (len(ordered) - 1)))]


class Stats:
    """Latencies in ms."""

    def __init__(self, values_s: list[float]) -> None:
        self.ms = [v * 1000 for v in values_s]

    @property
    def n(self) -> int:
        return len(self.ms)

    def median(self) -> float:
        return statistics.median(self.ms) if self.ms else float("nan")

    def p99(self) -> float:
        return pct(self.ms, 0.99) if self.ms else float("nan")

    def text(self) -> str:
        if not self.ms:
            return "no samples"
        return f"median {self.median():7.2f}   p99 {self.p99():7.2f}   max {max(self.ms):7.2f} ms   (n={self.n})"


class Sim:
    """A sim bridge with its record, and what the bench reads from it."""

    def __init__(self, faults: dict | None = None, *, gantry: bool = False) -> None:
        """``gantry``: the robot hangs in the sim's gantry, so a limp LOW_LEVEL robot does not fall (and fault)."""
        self.path = Path(tempfile.mkdtemp(prefix="g1_bench_")) / "record.jsonl"
        self.proc = start_sim_bridge(SDK_DOMAIN, speed=1.0, faults=faults,
                                     extra_args=["--record", str(self.path), *(["--gantry"] if gantry else [])])
        self._events: list[dict] = []
        self._stamps: list[float] = []  # the highest stamp up to each event: sorted, for the search
        self._offset = 0
        shared_sim_status().wait_ready(15.0)

    def events(self, since: float) -> list[dict]:
        """Record events at or after ``since``, read incrementally (the file grows by every frame).

        The search starts at the first event whose running highest stamp reaches ``since`` (no event before it can
        be as late), not at the run's first event: the bench polls this every few ms, and scanning minutes of record
        each time took a core from the very node and sim it measures."""
        if self.path.exists():
            with self.path.open() as f:
                f.seek(self._offset)
                for line in f:
                    if not line.endswith("\n"):
                        break  # a line still being written
                    self._offset += len(line.encode())
                    event = json.loads(line)
                    self._events.append(event)
                    self._stamps.append(max(event["t"], self._stamps[-1] if self._stamps else event["t"]))
        start = bisect.bisect_left(self._stamps, since)
        return [e for e in self._events[start:] if e["t"] >= since]

    def reset(self) -> None:
        """Back to the boot state (standing, service "ai"), e.g. after an e-stop dropped the robot."""
        shared_sim_status().reset()

    def first_request(self, api_id: int, t0: float, timeout_s: float,
                      match: Callable[[dict], bool] = lambda _e: True) -> float | None:
        """Receive time of the first request of ``api_id`` at or after t0 that matches, or None."""
        deadline = time.monotonic() + timeout_s
        while True:
            hits = [e["t"] for e in requests(self.events(t0), api_id) if match(e)]
            if hits:
                return min(hits)
            if time.monotonic() > deadline:
                return None
            time.sleep(0.005)

    def count(self, api_id: int, t0: float, t1: float) -> int:
        return sum(1 for e in requests(self.events(t0), api_id) if e["t"] <= t1)

    def stop(self) -> None:
        self.proc.stop()


class Bench:
    def __init__(self, ros: RosClient) -> None:
        self.ros = ros
        self._pubs: dict[tuple[str, int], object] = {}

    def set_mode(self, name: str):
        from g1_mode_manager_msgs.srv import SetMode

        return self.ros.call(SetMode, f"{NODE}/set_mode", SetMode.Request(mode_name=name))

    def set_mode_in_background(self, name: str) -> None:
        """A transition left in flight (the sim holds its SelectMode); its outcome does not matter."""

        def run() -> None:
            try:
                self.set_mode(name)
            except (TimeoutError, RuntimeError):
                pass  # the node was stopped under it

        threading.Thread(target=run, daemon=True).start()

    def loco(self, command: str) -> None:
        from g1_mode_manager_msgs.srv import LocoCommand

        result = self.ros.call(LocoCommand, f"{NODE}/loco_command", LocoCommand.Request(command=command))
        assert result.success, result.message

    def publisher(self, msg_type, topic: str, k: int = 0):
        """Publishers are kept for the whole run (never collected while DDS may call into them)."""
        key = (topic, k)
        if key not in self._pubs:
            self._pubs[key] = self.ros.node.create_publisher(msg_type, topic, 10)
        pub = self._pubs[key]
        assert wait_until(lambda: pub.get_subscription_count() > 0, 10.0), f"nobody subscribes to {topic}"
        return pub

    def estop_client(self):
        """A ready ~/estop client, so that the timed call does not include discovery."""
        from std_srvs.srv import Trigger

        client = self.ros.node.create_client(Trigger, f"{NODE}/estop")
        assert client.wait_for_service(timeout_sec=10.0)
        time.sleep(0.2)  # let the response reader match too
        return client

    @staticmethod
    def estop(client):
        from std_srvs.srv import Trigger

        future = client.call_async(Trigger.Request())
        done = threading.Event()
        future.add_done_callback(lambda _f: done.set())
        assert done.wait(30.0), "estop did not answer"
        return future.result()


class Flood:
    """/cmd_vel from two publishers at ``rate_hz`` each (a thread each), value settable while running."""

    def __init__(self, bench: Bench, rate_hz: float, vx: float) -> None:
        from geometry_msgs.msg import Twist

        self.vx = vx
        self.sent = 0
        self._stop = threading.Event()
        self._pubs = [bench.publisher(Twist, "/cmd_vel", k) for k in (1, 2)]
        self._rate_hz = rate_hz
        self._threads = [threading.Thread(target=self._run, args=(p,), daemon=True) for p in self._pubs]
        self._msg_type = Twist

    def _run(self, pub) -> None:
        msg = self._msg_type()

        def publish() -> None:
            msg.linear.x = self.vx
            pub.publish(msg)
            self.sent += 1

        run_at_rate(self._rate_hz, publish, self._stop)

    def __enter__(self) -> Flood:
        self.started = time.monotonic()
        for t in self._threads:
            t.start()
        return self

    def __exit__(self, *_exc: object) -> None:
        self._stop.set()
        for t in self._threads:
            t.join(2.0)
        self.rate_hz = self.sent / 2 / (time.monotonic() - self.started)


def fresh_node(bench: Bench, mode: str = "high_level", walk: bool = False, params: tuple[str, ...] = ()):
    node = start_mode_manager(SDK_DOMAIN, f"recorder_dir:={INCIDENTS}", *params)
    try:
        bench.ros.wait_node_answers()
        result = bench.set_mode(mode)
        assert result.success, result.message
        if walk:
            bench.loco("start")
    except BaseException:  # never leave a node running behind a failed bench
        print(f"mode_manager output:\n{node.output()[-3000:]}", file=sys.stderr)
        node.stop()
        raise
    return node


def stop_node(bench: Bench, node) -> None:
    node.stop()
    bench.ros.wait_service_gone(f"{NODE}/set_mode")


def estop_latency(bench: Bench, sim: Sim, samples: int, case: str, raw_per_sample: int = 0,
                  params: tuple[str, ...] = ()) -> tuple[Stats, Stats, Stats]:
    """Per sample a fresh node (EMERGENCY is final), then the e-stop under ``case``:
    'plain' (HIGH_LEVEL), 'select' (a SelectMode held by the sim in flight) or 'flood' (walking, /cmd_vel
    at 1 kHz from two publishers). With ``raw_per_sample``, that many raw SDK RPC round trips (GetFsmId,
    Unitree's stock client) right before each e-stop: the reference measured at the same moments of the
    machine (a fresh node beside the sim, the robot in the same state), returned third."""
    to_robot, to_reply, raw = [], [], []
    for _ in range(samples):
        if case == "flood":
            sim.reset()  # the last sample's e-stop dropped the robot; walking starts from standing
        node = fresh_node(bench, "low_level" if case == "select" else "high_level", walk=case == "flood",
                          params=params)
        client = None
        flood = None
        try:
            if case == "select":
                before = time.monotonic()
                bench.set_mode_in_background("high_level")
                assert sim.first_request(api_ids.MS_SELECT_MODE, before, 5.0) is not None
            client = bench.estop_client()
            raw += stock_rpc_round_trips(raw_per_sample)
            if case == "flood":
                flood = Flood(bench, 1000.0, 0.3).__enter__()
                time.sleep(0.5)
            t0 = time.monotonic()
            reply = Bench.estop(client)
            t_reply = time.monotonic()
            t_damp = sim.first_request(api_ids.LOCO_SET_FSM_ID, t0, 5.0, is_damp)
            assert t_damp is not None and reply.success, reply.message
            to_robot.append(t_damp - t0)
            to_reply.append(t_reply - t0)
        except BaseException:
            print(f"mode_manager output:\n{node.output()[-3000:]}", file=sys.stderr)
            raise
        finally:
            if flood is not None:
                flood.__exit__()
            stop_node(bench, node)
            if client is not None:
                bench.ros.node.destroy_client(client)
    return Stats(to_robot), Stats(to_reply), Stats(raw)


def cmd_vel_latency(bench: Bench, sim: Sim, samples: int, flood: Flood | None = None,
                    raw_per_sample: int = 0) -> tuple[Stats, Stats]:
    """Publish a new vx; time until the robot receives a SetVelocity carrying it. With a flood running,
    the flood itself switches to the new value at t0 (two publishers at 1 kHz, latest wins). With
    ``raw_per_sample``, that many raw Move round trips (the stock client's SetVelocity, at a vx the node
    never sends) right before each sample: the reference at the same moments, returned second."""
    from geometry_msgs.msg import Twist

    pub = bench.publisher(Twist, "/cmd_vel")
    out: list[float] = []
    raw: list[float] = []
    if flood is None:  # walking at the samples' speed first: each sample is then within one ramp step
        warm = Twist()
        warm.linear.x = 0.21
        t0 = time.monotonic()
        while time.monotonic() - t0 < 5.0 and not any(
                abs(velocity_of(e)[0] - 0.21) < 1e-6 for e in requests(sim.events(t0), api_ids.LOCO_SET_VELOCITY)):
            pub.publish(warm)
            time.sleep(0.03)
    for i in range(samples):
        raw += stock_move_round_trips(raw_per_sample)
        vx = round(0.20 + 0.01 * (i % 2), 2)  # alternate: each value differs from the last, within one ramp step
        msg = Twist()
        msg.linear.x = vx
        t0 = time.monotonic()
        if flood is None:
            pub.publish(msg)
        else:
            flood.vx = vx
        t = sim.first_request(api_ids.LOCO_SET_VELOCITY, t0, 2.0,
                              lambda e, vx=vx: abs(velocity_of(e)[0] - vx) < 1e-6)
        if t is not None:
            out.append(t - t0)
        for _ in range(3):  # keep the watchdog fed while waiting a little between samples
            if flood is None:
                pub.publish(msg)
            time.sleep(0.03)
    return Stats(out), Stats(raw)


_RAW: dict = {}  # SDK clients must never be collected
#: Raw round trips right before each e-stop / cmd_vel sample: the goals' references are measured at the
#: same moments of the machine as what they judge (on a shared VM, host steal comes and goes by the
#: second; a reference taken a minute apart compares two different machines).
RAW_PER_ESTOP = 10
RAW_PER_CMD_VEL = 2


def stock_client():
    """Unitree's stock G1 LocoClient, made once."""
    from unitree_sdk2py.g1.loco.g1_loco_client import LocoClient as StockLocoClient

    stock = _RAW.get("stock")
    if stock is None:
        stock = _RAW["stock"] = StockLocoClient()
        stock.SetTimeout(1.0)
        stock.Init()
        # discovery: the first calls of a new client can be lost before its readers match
        assert wait_until(lambda: stock._Call(api_ids.LOCO_GET_FSM_ID, "{}")[0] == 0, 10.0), "stock client: no answer"
    return stock


def _timed_calls(name: str, call: Callable[[], int], samples: int) -> list[float]:
    """Round trips of ``call`` (returns the SDK's code), 5 ms apart, in seconds; a call that fails is
    reported, not counted (a 1 s timeout would inflate the reference)."""
    out = []
    for _ in range(samples):
        t0 = time.monotonic()
        code = call()
        if code == 0:
            out.append(time.monotonic() - t0)
        else:
            print(f"raw {name} failed: code {code}", file=sys.stderr)
        time.sleep(0.005)
    return out


def stock_rpc_round_trips(samples: int) -> list[float]:
    """GetFsmId round trips through the stock client."""
    stock = stock_client()
    return _timed_calls("GetFsmId", lambda: stock._Call(api_ids.LOCO_GET_FSM_ID, "{}")[0], samples)


RAW_MOVE_VX = 0.25  # never one of the node's values in cmd_vel_latency (0.20, 0.21)


def stock_move_round_trips(samples: int) -> list[float]:
    """SetVelocity round trips through the stock client."""
    stock = stock_client()
    return _timed_calls("SetVelocity", lambda: stock.SetVelocity(RAW_MOVE_VX, 0.0, 0.0, 1.0), samples)


def raw_round_trips(samples: int) -> dict[str, tuple[Stats, Stats]]:
    """GetFsmId (an RPC) and SetVelocity (a Move) round trips from this process, without the node: through
    Unitree's stock SDK client (``unitree_sdk2py.g1.loco.g1_loco_client.LocoClient``: the SDK's own
    latency, the goals' reference) and through this project's client (``sdk/loco_client.py``: ready-made
    request bytes, per-call deadlines), interleaved so that both see the same moments of the machine."""
    from g1_mode_manager.sdk.loco_client import LocoClient

    ours = _RAW.setdefault("loco", LocoClient(1.0))
    ours.wait_ready(5.0)
    stock = stock_client()
    calls = {
        "stock": (lambda: stock._Call(api_ids.LOCO_GET_FSM_ID, "{}"), lambda: stock.SetVelocity(0.2, 0.0, 0.0, 1.0)),
        "ours": (ours.get_fsm_id, lambda: ours.set_velocity(0.2, 0.0, 0.0, 1.0)),
    }
    times: dict[str, tuple[list[float], list[float]]] = {k: ([], []) for k in calls}
    for _ in range(samples):
        for key, (rpc, move) in calls.items():
            for call, out in ((rpc, times[key][0]), (move, times[key][1])):
                t0 = time.monotonic()
                call()
                out.append(time.monotonic() - t0)
                time.sleep(0.005)
    ours.stop_move()
    return {k: (Stats(rpc), Stats(move)) for k, (rpc, move) in times.items()}


def cpu_times() -> list[int]:
    """The machine's CPU time counters (/proc/stat "cpu" line: user nice system idle iowait irq softirq
    steal ...), in ticks."""
    return [int(v) for v in Path("/proc/stat").read_text().splitlines()[0].split()[1:]]


def steal_percent(start: list[int], end: list[int]) -> float:
    """Share of the machine's CPU time the hypervisor gave to others between two ``cpu_times()``."""
    delta = [b - a for a, b in zip(start, end, strict=True)]
    return 100.0 * delta[7] / max(1, sum(delta[:8]))


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


def paced(publish: Callable[[], None], rate_hz: float) -> Callable[[], None]:
    """A step for cpu_percent that publishes at rate_hz on an absolute schedule."""
    state = {"next": time.monotonic()}

    def step() -> None:
        publish()
        state["next"] += 1.0 / rate_hz
        delay = state["next"] - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        else:
            state["next"] = time.monotonic()

    return step


def raw_stream(topic: str, rate_hz: float, seconds: float) -> dict:
    """Unitree's own SDK publisher streaming ``topic`` from a process of its own (bench/raw_stream.py)."""
    out = Path(tempfile.mkdtemp(prefix="g1_raw_")) / "raw.json"
    subprocess.run([sys.executable, "-m", "bench.raw_stream", "--domain", str(SDK_DOMAIN), "--topic", topic,
                    "--rate", str(rate_hz), "--seconds", str(seconds), "--out", str(out)],
                   cwd=REPO, check=True, timeout=seconds + 30)
    return json.loads(out.read_text())


def relay_floor(bench: Bench, write: bool, seconds: float, check: bool = False) -> float:
    """CPU of bench/relay_floor.py (what rclpy, Fast DDS and Cyclone alone cost a ~/lowcmd relay) while a
    JointCommand is published to it at 500 Hz, measured as the node's is."""
    topic = "/relay_floor/lowcmd"
    proc = subprocess.Popen([sys.executable, "-m", "bench.relay_floor", "--domain", str(SDK_DOMAIN), "--topic", topic,
                             *(["--write"] if write else []), *(["--check"] if check else [])],
                            cwd=REPO, stdout=subprocess.PIPE, text=True)
    try:
        if proc.stdout is None or proc.stdout.readline().strip() != "ready":
            raise RuntimeError("relay_floor did not start")
        from g1_mode_manager_msgs.msg import JointCommand

        pub = bench.publisher(JointCommand, topic, 1 + write + check)  # a publisher per floor process: no stale match
        time.sleep(0.5)
        message = _lowcmd_message(0)
        return cpu_percent(proc.pid, seconds, paced(lambda: pub.publish(message), 500))
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(10.0)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def stream_timing(sim: Sim, sends: list[tuple[float, float]], topic: str, period_s: float) -> tuple[Stats, Stats]:
    """(send -> received at the robot, |inter-arrival gap - period| at the robot) of a marked stream: each frame's
    marker (motor 0's kp) is its ``kp_max`` on the sim's record (``topic`` as the record names it: "lowcmd")."""
    since = min(t for _m, t in sends) - 0.01
    time.sleep(0.3)  # the last frames' record lines
    arrivals: dict[float, list[float]] = {}
    for e in sim.events(since):
        if e.get("k") == "frame" and e.get("topic") == topic and e.get("ok"):
            arrivals.setdefault(e["kp_max"], []).append(e["t"])
    latency, received = [], []
    for marker, sent in sends:
        later = [t for t in arrivals.get(marker, ()) if t >= sent]
        if later:
            latency.append(min(later) - sent)
            received.append(min(later))
    received.sort()
    gaps = [abs((b - a) - period_s) for a, b in pairwise(received)]
    return Stats(latency), Stats(gaps)


def _lowcmd_message(seq: int):
    from g1_mode_manager_msgs.msg import JointCommand

    from bench.raw_stream import marker

    n = len(JOINT_NAMES)
    kp = [0.0] * n
    kp[0] = marker(seq)
    return JointCommand(name=list(JOINT_NAMES), q=[0.0] * n, dq=[0.0] * n, tau=[0.0] * n, kp=kp, kd=[2.0] * n)


def lowcmd_500hz(low, node, sim: Sim, seconds: float) -> tuple[float, Stats, Stats]:
    """(the node's CPU, publish -> frame at the robot, |gap - 2 ms| at the robot) of ~/lowcmd at 500 Hz."""
    sends: list[tuple[float, float]] = []

    def publish() -> None:
        seq = len(sends)
        message = _lowcmd_message(seq)
        sends.append((message.kp[0], time.monotonic()))
        low.publish(message)

    pct_ = cpu_percent(node.proc.pid, seconds, paced(publish, 500))
    latency, jitter = stream_timing(sim, sends, "lowcmd", 0.002)
    return pct_, latency, jitter


def cpu_rows(bench: Bench, sim: Sim, seconds: float) -> tuple[list[tuple[str, str]], dict[str, float]]:
    """The node's CPU in each mode and stream, and the streams' raw SDK references from the same run."""
    from g1_mode_manager_msgs.msg import JointCommand
    from geometry_msgs.msg import Twist
    from sensor_msgs.msg import JointState

    rows: list[tuple[str, str]] = []
    summary: dict[str, float] = {}

    def cpu(name: str, value: float) -> float:
        rows.append((name, f"{value:5.1f} % of one core"))
        return value

    node = fresh_node(bench, walk=True)
    try:
        time.sleep(4.0)  # settled: rt/lowstate unsubscribed 2 s after the last thing that needed it
        summary["cpu_idle_pct"] = cpu("node CPU, HIGH_LEVEL walking, no commands", cpu_percent(node.proc.pid, seconds))
        pub = bench.publisher(Twist, "/cmd_vel")
        msg = Twist()
        msg.linear.x = 0.3
        for rate in (10, 100, 1000):
            value = cpu(f"node CPU, /cmd_vel at {rate} Hz", cpu_percent(node.proc.pid, seconds,
                                                                         paced(lambda: pub.publish(msg), rate)))
            if rate == 100:
                summary["cpu_100hz_pct"] = value
            time.sleep(1.0)
        arm = bench.publisher(JointState, f"{NODE}/arm_cmd")
        arm_msg = JointState(name=list(ARM_SDK_JOINT_NAMES[3:5]), position=[0.3, 0.2])
        summary["arm_50hz_pct"] = cpu("node CPU, ~/arm_cmd at 50 Hz (arm_sdk frames at 50 Hz)",
                                      cpu_percent(node.proc.pid, seconds, paced(lambda: arm.publish(arm_msg), 50)))
        time.sleep(4.0)  # the arms ramp out
    finally:
        stop_node(bench, node)
    raw = raw_stream("rt/arm_sdk", 50.0, seconds)  # the robot stays in the sport service: arm_sdk frames count
    summary["raw_arm_50hz_pct"] = cpu("  raw SDK publisher CPU, rt/arm_sdk at 50 Hz (its own process)", raw["cpu_pct"])

    node = fresh_node(bench, "low_level")
    try:
        low = bench.publisher(JointCommand, f"{NODE}/lowcmd")
        time.sleep(1.0)
        summary["lowlevel_idle_pct"] = cpu("node CPU, LOW_LEVEL, no commands (damping frames at 50 Hz)",
                                           cpu_percent(node.proc.pid, seconds))
        summary["lowcmd_500hz_pct"], latency, jitter = lowcmd_500hz(low, node, sim, seconds)
        cpu("node CPU, LOW_LEVEL, ~/lowcmd at 500 Hz", summary["lowcmd_500hz_pct"])
    finally:
        stop_node(bench, node)
    node = fresh_node(bench, "low_level", params=(RECORDER_OFF,))
    try:
        low = bench.publisher(JointCommand, f"{NODE}/lowcmd")  # the same publisher, matched to this node
        time.sleep(1.0)
        off_pct, off_latency, _ = lowcmd_500hz(low, node, sim, seconds)
        summary["lowcmd_500hz_recorder_off_pct"] = cpu("  the same with the flight recorder off", off_pct)
        summary["lowcmd_p99_recorder_off_ms"] = off_latency.p99()
    finally:
        stop_node(bench, node)
    raw = raw_stream("rt/lowcmd", 500.0, seconds)  # the robot stays released: rt/lowcmd frames count
    for write, check, key, name in (
            (False, False, "floor_take_500hz_pct", "take only"),
            (True, False, "floor_relay_500hz_pct", "take + one constant rt/lowcmd write"),
            (True, True, "floor_checked_500hz_pct", "take + the node's decode, checks, build, CRC + write")):
        summary[key] = cpu(f"  floor, a bare rclpy relay at 500 Hz ({name}; its own process)",
                           relay_floor(bench, write, seconds, check))
    summary["raw_lowcmd_500hz_pct"] = cpu("  raw SDK publisher CPU, rt/lowcmd at 500 Hz (its own process)",
                                          raw["cpu_pct"])
    raw_latency, raw_jitter = stream_timing(sim, [tuple(p) for p in raw["sends"]], "lowcmd", 0.002)
    rows += [("~/lowcmd 500 Hz: publish -> rt/lowcmd frame received", latency.text()),
             ("  the same with the flight recorder off", f"p99 {summary['lowcmd_p99_recorder_off_ms']:7.2f} ms"),
             ("  raw SDK publisher: Write -> rt/lowcmd frame received", raw_latency.text()),
             ("~/lowcmd 500 Hz: |gap - 2 ms| between frames at the robot", jitter.text()),
             ("  raw SDK publisher: |gap - 2 ms| between frames at the robot", raw_jitter.text())]
    summary.update(lowcmd_p99_ms=latency.p99(), raw_lowcmd_p99_ms=raw_latency.p99(), lowcmd_jitter_p99_ms=jitter.p99(),
                   raw_lowcmd_jitter_p99_ms=raw_jitter.p99())
    return rows, summary


def cpu_only(seconds: float) -> int:
    """The CPU rows alone (with their raw references), printed as the full run prints them."""
    return rows_only(lambda bench, sim: cpu_rows(bench, sim, seconds), {"gantry": True}, "STREAMS", ())


def rows_only(rows_of: Callable, sim_options: dict, label: str, keys: tuple[str, ...],
              goals: Callable[[dict[str, float]], list[tuple[str, bool]]] | None = None) -> int:
    """One group of rows on a sim of its own, printed as the full run prints them, then ``label`` with its figures
    (``keys``, or all of them)."""
    from g1_mode_manager.protocol.dds import init_channels

    init_channels(SDK_DOMAIN, "lo")
    ros = RosClient("bench")
    sim = Sim(**sim_options)
    try:
        rows, summary = rows_of(Bench(ros), sim)
    finally:
        ros.close()
        sim.stop()
    width = max(len(r[0]) for r in rows)
    for name, value in rows:
        print(f"{name:<{width}}  {value}", flush=True)
    if goals is not None:
        print("goals: " + ", ".join(f"{name}: {'met' if ok else 'NOT met'}" for name, ok in goals(summary)))
    print(f"{label} " + " ".join(f"{k}={summary[k]:.2f}" for k in (keys or summary)))
    return 0


#: The flight recorder's cost: the e-stop and the 500 Hz relay with it on (the SUMMARY's figures) and off.
RECORDER_KEYS = ("estop_damp_p99_ms", "estop_damp_p99_recorder_off_ms", "lowcmd_500hz_pct", "lowcmd_500hz_recorder_off_pct",
                 "lowcmd_p99_ms", "lowcmd_p99_recorder_off_ms")
POLICY_KEYS = ("policy_50hz_pct", "raw_policy_50hz_pct", "policy_inference_p99_ms", "raw_policy_inference_p99_ms",
               "policy_jitter_p99_ms", "raw_policy_jitter_p99_ms", "policy_state_to_frame_p99_ms",
               "policy_state_to_frame_max_ms", "policy_to_applied_p99_ms")


def _policy_rows(bench: Bench, sim: Sim, seconds: float) -> tuple[list[tuple[str, str]], dict[str, float]]:
    from bench.policy_rows import policy_rows

    return policy_rows(bench, sim, start_mode_manager, stop_node, cpu_percent, Stats, SDK_DOMAIN, seconds, REPO)


def policy_goals(summary: dict[str, float]) -> list[tuple[str, bool]]:
    return [("policy: node CPU <= the standalone loop's", summary["policy_50hz_pct"] <= summary["raw_policy_50hz_pct"]),
            ("policy: frame jitter p99 <= the standalone loop's",
             summary["policy_jitter_p99_ms"] <= summary["raw_policy_jitter_p99_ms"]),
            ("policy: frame jitter p99 <= 1 ms", summary["policy_jitter_p99_ms"] <= 1.0),
            ("policy: state -> frame written p99 <= 5 ms", summary["policy_state_to_frame_p99_ms"] <= 5.0)]


def policy_only(seconds: float) -> int:
    """The policy row alone, with its goals."""
    return rows_only(lambda bench, sim: _policy_rows(bench, sim, seconds), {}, "POLICY", POLICY_KEYS, policy_goals)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="bench", description=__doc__.split("\n\n")[0])
    parser.add_argument("--samples", type=int, default=100,
                        help="e-stop samples (each starts a node); the flood and SelectMode cases take 1/20 (>= 5)")
    parser.add_argument("--cpu-seconds", type=float, default=10.0, help="length of each CPU measurement")
    parser.add_argument("--cpu-only", action="store_true",
                        help="only the node's CPU rows (idle HIGH_LEVEL with the body checks on, the streams)")
    parser.add_argument("--policy-only", action="store_true",
                        help="only the policy row (the node's loop beside a standalone loop on Unitree's SDK)")
    args = parser.parse_args(argv)
    restore_sigint()  # the bench stops its sims and nodes with SIGINT, started in the background or not
    if args.cpu_only:
        return cpu_only(args.cpu_seconds)
    if args.policy_only:
        return policy_only(args.cpu_seconds)
    from g1_mode_manager.protocol.dds import init_channels

    init_channels(SDK_DOMAIN, "lo")
    rows: list[tuple[str, str]] = []
    summary: dict[str, float] = {}
    cpu_start = cpu_times()
    ros = RosClient("bench")
    bench = Bench(ros)
    sim = Sim()
    try:
        robot, reply, raw_rpc = estop_latency(bench, sim, args.samples, "plain", RAW_PER_ESTOP)
        rows += [("raw SDK RPC (GetFsmId) round trip, beside the e-stop samples", raw_rpc.text()),
                 ("~/estop call -> Damp received by the robot", robot.text()),
                 ("~/estop call -> service reply (robot verified damped)", reply.text())]
        summary.update(estop_damp_p99_ms=robot.p99(), raw_rpc_p99_ms=raw_rpc.p99())
        off, _, _ = estop_latency(bench, sim, max(5, args.samples // 2), "plain", params=(RECORDER_OFF,))
        rows.append(("  the same with the flight recorder off (half the samples)", off.text()))
        summary["estop_damp_p99_recorder_off_ms"] = off.p99()
        few = max(5, args.samples // 20)
        robot, _, _ = estop_latency(bench, sim, few, "flood")
        rows.append(("~/estop during /cmd_vel 2 x 1 kHz -> Damp received", robot.text()))

        sim.reset()
        node = fresh_node(bench, walk=True)
        try:
            plain, raw_move = cmd_vel_latency(bench, sim, 100, raw_per_sample=RAW_PER_CMD_VEL)
            rows += [("raw SDK Move (SetVelocity) round trip, beside the cmd_vel samples", raw_move.text()),
                     ("/cmd_vel publish -> Move received", plain.text())]
            summary.update(cmd_vel_median_ms=plain.median(), cmd_vel_p99_ms=plain.p99(),
                           raw_move_median_ms=raw_move.median(), raw_move_p99_ms=raw_move.p99())
            with Flood(bench, 1000.0, 0.2) as flood:
                flooded, _ = cmd_vel_latency(bench, sim, 50, flood)
            rows.append((f"/cmd_vel 2 x {flood.rate_hz:.0f} Hz -> new value's Move received", flooded.text()))
            time.sleep(1.0)  # the node's watchdog stops the robot; it stays in walk mode (fsm 500): Moves pass
            raw = raw_round_trips(200)
            rows += [("raw SDK RPC (GetFsmId), 200 in a row, robot walking", raw["stock"][0].text()),
                     ("raw SDK Move (SetVelocity), 200 in a row, robot walking", raw["stock"][1].text()),
                     ("  the same through this project's client: RPC", raw["ours"][0].text()),
                     ("  the same through this project's client: Move", raw["ours"][1].text())]
        finally:
            stop_node(bench, node)
        sim.stop()

        sim = Sim(faults={"delay_s": {str(api_ids.MS_SELECT_MODE): 2.0}}, gantry=True)
        robot, reply, _ = estop_latency(bench, sim, few, "select")
        rows += [("~/estop during a SelectMode held 2 s -> Damp received", robot.text()),
                 ("~/estop during a SelectMode held 2 s -> reply (after re-select)", reply.text())]
        node = fresh_node(bench, "low_level")
        try:  # a transition in flight forwards nothing: count the Moves that reach the robot meanwhile
            from geometry_msgs.msg import Twist

            t0 = time.monotonic()
            bench.set_mode_in_background("high_level")
            pub = bench.publisher(Twist, "/cmd_vel")
            msg = Twist()
            msg.linear.x = 0.3
            for _ in range(150):
                pub.publish(msg)
                time.sleep(0.01)
            moves = sim.count(api_ids.LOCO_SET_VELOCITY, t0, time.monotonic())
            rows.append(("/cmd_vel at 100 Hz during a SelectMode held 2 s", f"{moves} Moves received (none may pass "
                         "during a transition)"))
        finally:
            stop_node(bench, node)
        sim.stop()

        sim = Sim(gantry=True)
        stream_rows, stream_summary = cpu_rows(bench, sim, args.cpu_seconds)
        rows += stream_rows
        summary.update(stream_summary)
        sim.stop()

        sim = Sim()  # on its feet: the policy holds it
        stream_rows, stream_summary = _policy_rows(bench, sim, args.cpu_seconds)
        rows += stream_rows
        summary.update(stream_summary)
    finally:
        ros.close()
        sim.stop()
    cpu = subprocess.run(["sh", "-c", "grep -m1 'model name' /proc/cpuinfo | cut -d: -f2"],
                         capture_output=True, text=True).stdout.strip()
    load = os.getloadavg()[0]
    print(f"\nmachine: {platform.node()} | {cpu} | {os.cpu_count()} cores | Python {platform.python_version()} | "
          f"load average {load:.2f} at the end | hypervisor steal {steal_percent(cpu_start, cpu_times()):.1f} % of the "
          "CPU time during the run")
    width = max(len(r[0]) for r in rows)
    for name, value in rows:
        print(f"{name:<{width}}  {value}")
    goals = [("e-stop p99 <= 1.5 x raw RPC p99", summary["estop_damp_p99_ms"] <= 1.5 * summary["raw_rpc_p99_ms"]),
             ("cmd_vel median <= raw Move median + 0.5 ms",
              summary["cmd_vel_median_ms"] <= summary["raw_move_median_ms"] + 0.5),
             ("cmd_vel p99 <= raw Move p99 + 2 ms", summary["cmd_vel_p99_ms"] <= summary["raw_move_p99_ms"] + 2.0),
             ("idle CPU <= 2 %", summary["cpu_idle_pct"] <= 2.0), ("100 Hz CPU <= 6 %", summary["cpu_100hz_pct"] <= 6.0),
             ("~/lowcmd 500 Hz CPU <= the bare relay's take + one write + 3 points",
              summary["lowcmd_500hz_pct"] <= summary["floor_relay_500hz_pct"] + 3.0),
             ("~/arm_cmd 50 Hz CPU <= 1.5 x the raw arm_sdk publisher's",
              summary["arm_50hz_pct"] <= 1.5 * summary["raw_arm_50hz_pct"]),
             ("~/lowcmd p99 <= raw p99 + 1 ms", summary["lowcmd_p99_ms"] <= summary["raw_lowcmd_p99_ms"] + 1.0),
             *policy_goals(summary)]
    print("goals: " + ", ".join(f"{name}: {'met' if ok else 'NOT met'}" for name, ok in goals))
    keys = ("estop_damp_p99_ms", "raw_rpc_p99_ms", "cmd_vel_median_ms", "cmd_vel_p99_ms", "raw_move_median_ms",
            "raw_move_p99_ms", "cpu_idle_pct", "cpu_100hz_pct", "lowcmd_500hz_pct", "raw_lowcmd_500hz_pct",
            "lowcmd_p99_ms", "raw_lowcmd_p99_ms", "arm_50hz_pct", "raw_arm_50hz_pct", "lowlevel_idle_pct",
            "lowcmd_jitter_p99_ms", "raw_lowcmd_jitter_p99_ms", "floor_take_500hz_pct", "floor_relay_500hz_pct",
            *POLICY_KEYS)
    print("SUMMARY " + " ".join(f"{k}={summary[k]:.2f}" for k in keys))
    print("RECORDER " + " ".join(f"{k}={summary[k]:.2f}" for k in RECORDER_KEYS))
    return 0


if __name__ == "__main__":
    sys.exit(main())
