"""The policy row of `make bench`: the node running holosoma's locomotion policy in LOW_LEVEL (user control, the
robot standing under the policy) beside the same model run by a minimal standalone loop on Unitree's Python SDK
(bench/policy_standalone.py): each one's CPU, the inference time, and the frames' timing at the robot (|gap -
20 ms| between consecutive rt/user_lowcmd frames on the sim's record)."""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from itertools import pairwise
from pathlib import Path

POLICY = "loco_ppo"
MODEL = Path(sys.prefix, "share", "g1_mode_manager", "sim_assets", "policy", "ppo_g1_29dof.onnx")
PERIOD_S = 0.02


def to_applied(events: list[dict], since: float, until: float) -> list[float]:
    """Each policy frame's write (its DDS source timestamp) to the robot's applying it, s, from the sim's record."""
    return [e["ap"] - e["src"] for e in events
            if e.get("k") == "frame" and e.get("topic") == "user_lowcmd" and since <= e["t"] <= until
            and e.get("kp_max", 0.0) > 90.0 and e.get("src") is not None]


def frame_gaps(events: list[dict], since: float, until: float) -> list[float]:
    """|gap - 20 ms| between consecutive rt/user_lowcmd frames at the robot in [since, until] (accepted or not:
    the standalone loop's frames are ignored by a robot not in user control, their arrival still counts)."""
    arrivals = sorted(e["t"] for e in events
                      if e.get("k") == "frame" and e.get("topic") == "user_lowcmd" and since <= e["t"] <= until
                      and e.get("kp_max", 0.0) > 90.0)  # the policy's frames (kp 99 at the knees), not holds
    return [abs((b - a) - PERIOD_S) for a, b in pairwise(arrivals)]


def policy_rows(bench, sim, start_node: Callable, stop_node: Callable, cpu_percent: Callable, stats: Callable,
                domain: int, seconds: float, repo: Path) -> tuple[list[tuple[str, str]], dict[str, float]]:
    from g1_mode_manager_msgs.msg import PolicyStatus
    from g1_mode_manager_msgs.srv import LoadPolicy
    from std_srvs.srv import Trigger

    from g1_mode_manager.topic_qos import MODE_QOS

    rows: list[tuple[str, str]] = []
    summary: dict[str, float] = {}
    node = start_node(domain, "low_level_path:=user_ctrl")
    statuses: list = []
    bench.ros.node.create_subscription(PolicyStatus, "/g1_mode_manager/policy/status", statuses.append, MODE_QOS)
    try:
        bench.ros.wait_node_answers()
        # every client made now, discovered while the robot comes to rest
        for verb in ("shadow", "engage", "disengage"):
            bench.ros.client(Trigger, f"/g1_mode_manager/policy/{verb}")
        for mode in ("high_level",):
            assert bench.set_mode(mode).success
        bench.loco("start")
        time.sleep(3.0)  # at rest: the user-control entry waits for it
        for call in ((LoadPolicy, "policy/load", LoadPolicy.Request(policy=POLICY)),
                     (Trigger, "policy/shadow", Trigger.Request())):
            r = bench.ros.call(call[0], f"/g1_mode_manager/{call[1]}", call[2])
            assert r.success, r.message
        time.sleep(2.0)
        r = bench.ros.call(Trigger, "/g1_mode_manager/policy/engage", Trigger.Request(), 30.0)
        assert r.success, r.message
        time.sleep(3.0)  # the blend, then the policy alone
        t0 = time.monotonic()
        node_cpu = cpu_percent(node.proc.pid, seconds)
        t1 = time.monotonic()
        gaps = stats(frame_gaps(sim.events(t0), t0, t1))
        applied = stats(to_applied(sim.events(t0), t0, t1))
        running = [s for s in statuses if s.phase == "running"]
        assert running, f"the policy is {statuses[-1].phase if statuses else 'unknown'}: {statuses[-1].last_fault}"
        status = running[-1]
        r = bench.ros.call(Trigger, "/g1_mode_manager/policy/disengage", Trigger.Request(), 30.0)
        assert r.success, r.message
    finally:
        stop_node(bench, node)
    out = Path(tempfile.mkdtemp(prefix="g1_policy_")) / "standalone.json"
    t0 = time.monotonic()
    subprocess.run([sys.executable, "-m", "bench.policy_standalone", "--domain", str(domain), "--seconds",
                    str(seconds), "--model", str(MODEL), "--out", str(out)], cwd=repo, check=True, timeout=seconds + 30)
    raw = json.loads(out.read_text())
    raw_gaps = stats(frame_gaps(sim.events(t0), t0, time.monotonic()))
    raw_inference = stats(raw["inference_s"])
    rows += [(f"node CPU, LOW_LEVEL, {POLICY} at 50 Hz in the node's loop (robot standing)", f"{node_cpu:5.1f} % of one core"),
             ("  standalone loop on Unitree's SDK, same model (its own process)", f"{raw['cpu_pct']:5.1f} % of one core"),
             (f"{POLICY} in the node: inference p99 / tick p99 (its status, last 500 ticks)",
              f"{status.inference_p99_ms:.2f} / {status.tick_p99_ms:.2f} ms, {status.rate_hz:.1f} Hz, "
              f"{status.overruns} overruns"),
             ("  standalone loop: inference (observation + run)", raw_inference.text()),
             (f"{POLICY} in the node: the state's publication -> its frame written, p50 / p99 / max (status, last "
              "500 ticks)", f"{status.state_to_frame_p50_ms:.2f} / {status.state_to_frame_p99_ms:.2f} / "
              f"{status.state_to_frame_max_ms:.2f} ms"),
             (f"{POLICY} in the node: frame written -> applied by the robot (its record)", applied.text()),
             (f"{POLICY} in the node: |gap - 20 ms| between frames at the robot", gaps.text()),
             ("  standalone loop: |gap - 20 ms| between frames at the robot", raw_gaps.text())]
    summary.update(policy_50hz_pct=node_cpu, raw_policy_50hz_pct=raw["cpu_pct"],
                   policy_inference_p99_ms=status.inference_p99_ms, raw_policy_inference_p99_ms=raw_inference.p99(),
                   policy_jitter_p99_ms=gaps.p99(), raw_policy_jitter_p99_ms=raw_gaps.p99(),
                   policy_state_to_frame_p99_ms=status.state_to_frame_p99_ms,
                   policy_state_to_frame_max_ms=status.state_to_frame_max_ms,
                   policy_to_applied_p99_ms=applied.p99())
    return rows, summary
