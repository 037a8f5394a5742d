"""A whole-body-tracking policy (holosoma's dances) played to its end by the node on the sim, judged on the sim's
truth and record, beside the same clip in a zero-latency playback of the same controller (``bench.dance_playback``).

Each run: a fresh sim (recording) and node; HIGH_LEVEL, the robot's own walker standing, then load, shadow 1 s,
engage by user control; the clip plays to its end (or a fall, or the node stops it); the policy is disengaged
(WALKRUN) and the robot must stand 3 s later. Twice a second a progress line: the policy's phase and progress, its
RMS joint error against the motion's own reference (``~/policy/status``), the pelvis height and torso tilt (the
sim's), the sim's real-time factor. Per run, ``DANCE ...`` (the verdict), ``LOOP ...`` (timing: the node's state ->
frame written, from its status; the frames' period and jitter on arrival, the wire and the time to applied, from the
sim's record: the jitter of the frames as the node wrote them, as the sim's DDS delivered them and as it applied them)
and ``PLAYBACK ...`` (the zero-latency run, after the sim stopped). The node's state -> frame comes from
its ``~/policy/status`` every half second, each over its last 500 ticks: the median of their p50s, the largest of their
p99s and maxima.

Fallen is the sim's truth: the torso's tilt past 1.0 rad (terminations.hpp) or the pelvis lower than the clip's own
lowest reference (the model's ``ref_pos_xyz``) less ``CROUCH_MARGIN_M``.

    flock /tmp/g1_sim_cpu.lock .venv/bin/python -m bench.dance [--policy dance_ppo] [--runs 3] [--seconds 150]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from harness.domains import allocate_run_domains

_ROS_DOMAIN, SDK_DOMAIN = allocate_run_domains()
os.environ["ROS_DOMAIN_ID"] = str(_ROS_DOMAIN)
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"

from bench.dance_playback import play  # noqa: E402
from harness.clip import lowest_reference_m  # noqa: E402
from harness.mode_manager import RosClient, start_mode_manager  # noqa: E402
from harness.processes import restore_sigint  # noqa: E402
from harness.sim_bridge import shared_sim_status, start_sim_bridge  # noqa: E402
from harness.sim_record import SimRecord, of_kind  # noqa: E402

NODE = "/g1_mode_manager"
#: Fallen: below the clip's lowest reference height by more than this, m (or tilted past FALLEN_TILT_RAD).
CROUCH_MARGIN_M = 0.2
FALLEN_TILT_RAD = 1.0
#: After the disengage the robot must stand: pelvis above this, m, this long after.
STANDING_Z_M = 0.6
HANDED_BACK_S = 3.0
#: The policy's phases after which it no longer drives.
OVER = ("loaded", "unloaded")


@dataclass
class Run:
    policy: str
    played: float = 0.0
    fell: bool = False
    lowest_z: float = 9.0
    worst_tilt: float = 0.0
    errors: list[float] = field(default_factory=list)
    state_to_frame: list[tuple[float, float, float]] = field(default_factory=list)  # each status' p50, p99, max
    fault: str = ""
    standing_after: bool = False
    mode: str = ""


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="bench.dance", description=__doc__.split("\n\n")[0])
    parser.add_argument("--policy", action="append", default=[], help="a tracking policy (repeatable; default both "
                        "shipped dances)")
    parser.add_argument("--runs", type=int, default=1)
    parser.add_argument("--seconds", type=float, default=150.0, help="the longest a clip is played, s")
    parser.add_argument("--param", action="append", default=[], help="a node parameter, name:=value (repeatable)")
    parser.add_argument("--no-playback", action="store_true", help="leave out the zero-latency playback")
    args = parser.parse_args(argv)
    restore_sigint()
    from g1_mode_manager.protocol.dds import init_channels

    init_channels(SDK_DOMAIN, "lo")
    ros = RosClient("bench_dance")
    failed = 0
    try:
        for policy in args.policy or ["dance_ppo", "dance_fastsac"]:
            floor = lowest_reference_m(policy) - CROUCH_MARGIN_M
            for run in range(args.runs):
                result = _one_run(ros, policy, args.seconds, args.param, floor)
                failed += result.fell or result.played < 1.0 or not result.standing_after
                if not args.no_playback:
                    zero = play(policy, seed=run)
                    print(zero.line(), flush=True)
                    median = statistics.median(result.errors) if result.errors else float("nan")
                    zero_median = statistics.median(zero.errors) if zero.errors else float("nan")
                    print(f"COMPARE policy={policy} run={run} node_rms_err_median={median:.3f} "
                          f"playback_rms_err_median={zero_median:.3f} difference={median - zero_median:+.3f}",
                          flush=True)
    finally:
        ros.close()
    return 1 if failed else 0


def _one_run(ros: RosClient, policy: str, seconds: float, params: list[str], floor_z: float) -> Run:
    record_path = Path(tempfile.mkdtemp(prefix="g1_dance_")) / "robot.jsonl"
    sim = start_sim_bridge(SDK_DOMAIN, speed=1.0, extra_args=("--record", str(record_path)))
    status = shared_sim_status()
    node = None
    try:
        status.wait_ready(15.0)
        node = start_mode_manager(SDK_DOMAIN, "low_level_path:=user_ctrl", *params)
        result = _dance(ros, status, policy, seconds, floor_z)
        _report(result, SimRecord(record_path), floor_z)
        return result
    finally:
        if node is not None:
            node.stop()
            for line in node.lines:  # why the node stopped the dance, if it did
                if ("WARN" in line or "ERROR" in line) and "clamped" not in line:
                    print(f"node: {line}")
        sim.stop()


def _dance(ros: RosClient, sim, policy: str, seconds: float, floor_z: float) -> Run:
    from g1_mode_manager_msgs.msg import Mode, PolicyStatus
    from g1_mode_manager_msgs.srv import LoadPolicy, LocoCommand, SetMode
    from std_srvs.srv import Trigger

    from g1_mode_manager.topic_qos import MODE_QOS

    statuses: list[PolicyStatus] = []
    modes: list[Mode] = []
    subs = [ros.node.create_subscription(PolicyStatus, f"{NODE}/policy/status", statuses.append, MODE_QOS),
            ros.node.create_subscription(Mode, f"{NODE}/mode", modes.append, MODE_QOS)]
    ros.wait_node_answers()
    out = Run(policy)

    def ok(reply, what: str) -> None:
        if not reply.success:
            raise SystemExit(f"{what} refused: {reply.message}")

    try:
        ok(ros.call(SetMode, f"{NODE}/set_mode", SetMode.Request(mode_name="high_level"), 30.0), "high_level")
        ok(ros.call(LocoCommand, f"{NODE}/loco_command", LocoCommand.Request(command="start"), 30.0), "start")
        time.sleep(2.0)  # at rest: the user-control entry waits for it
        reply = ros.call(LoadPolicy, f"{NODE}/policy/load", LoadPolicy.Request(policy=policy), 60.0)
        ok(reply, "load")
        print(f"load: {reply.message}")
        ok(ros.call(Trigger, f"{NODE}/policy/shadow", Trigger.Request(), 30.0), "shadow")
        time.sleep(1.0)
        ok(ros.call(Trigger, f"{NODE}/policy/engage", Trigger.Request(), 30.0), "engage")
        t0 = time.monotonic()
        ended_at = None
        print(f"{'t s':>6} {'rtf':>5} {'phase':>10} {'clip %':>7} {'rms err rad':>11} {'pelvis z m':>10} {'tilt':>5}")
        while time.monotonic() - t0 < seconds:
            time.sleep(0.5)
            s = sim.get()
            last = statuses[-1] if statuses else None
            z, tilt = s["body"]["pelvis_z"], s["body"]["tilt"]
            out.lowest_z, out.worst_tilt = min(out.lowest_z, z), max(out.worst_tilt, tilt)
            out.fell = out.fell or z < floor_z or tilt > FALLEN_TILT_RAD
            phase = last.phase if last is not None else "?"
            if last is not None and phase == "running":
                if last.tracking_error_rad >= 0.0 and last.progress > 0.0:
                    out.errors.append(last.tracking_error_rad)
                if last.state_to_frame_max_ms > 0.0:
                    out.state_to_frame.append((last.state_to_frame_p50_ms, last.state_to_frame_p99_ms,
                                               last.state_to_frame_max_ms))
                out.played = max(out.played, last.progress)
            print(f"{time.monotonic() - t0:6.1f} {s['real_time_factor']:5.2f} {phase:>10} {100 * out.played:7.1f} "
                  f"{(last.tracking_error_rad if last else -1):11.3f} {z:10.3f} {tilt:5.2f}", flush=True)
            if out.fell or phase in OVER:
                break
            if out.played >= 1.0:
                ended_at = ended_at or time.monotonic()
                if time.monotonic() - ended_at >= 1.0:  # on the clip's last frame for a second
                    break
        last = statuses[-1] if statuses else None
        # the loop's own stop (its status) or a body check's FAULT (the mode: the loop only sees its phase end)
        faults = [f for m in modes for f in m.faults]
        out.fault = "; ".join(filter(None, (last.last_fault if last is not None else "", *dict.fromkeys(faults))))
        if last is not None and last.phase not in OVER:
            reply = ros.call(Trigger, f"{NODE}/policy/disengage", Trigger.Request(), 30.0)
            print(f"disengage: {reply.success} {reply.message}")
        time.sleep(HANDED_BACK_S)
        s = sim.get()
        out.standing_after = s["body"]["pelvis_z"] > STANDING_Z_M and s["body"]["tilt"] < FALLEN_TILT_RAD
        out.mode = modes[-1].mode if modes else "?"
        return out
    finally:
        for sub in subs:
            ros.node.destroy_subscription(sub)


def _report(run: Run, record: SimRecord, floor_z: float) -> None:
    events = record.events()
    bodies = of_kind(events, "body")
    if bodies:  # the record's own body samples (every 10 ms of sim time) over the whole run
        run.lowest_z = min(run.lowest_z, min(e["z"] for e in bodies))
        run.worst_tilt = max(run.worst_tilt, max(e["tilt"] for e in bodies))
        run.fell = run.fell or run.lowest_z < floor_z or run.worst_tilt > FALLEN_TILT_RAD
    frames = [e for e in of_kind(events, "frame") if e["topic"] == "user_lowcmd" and e["ok"]]
    past = max((e.get("past") or 0.0 for e in frames), default=0.0)
    median = statistics.median(run.errors) if run.errors else float("nan")
    print(f"DANCE policy={run.policy} played_pct={100 * run.played:.1f} fell={int(run.fell)} "
          f"lowest_pelvis_z={run.lowest_z:.3f} (floor {floor_z:.3f}) max_tilt={run.worst_tilt:.2f} "
          f"rms_err_median={median:.3f} rms_err_max={max(run.errors, default=float('nan')):.3f} "
          f"standing_after={int(run.standing_after)} most_past_range_on_record={past:.3f} fault={run.fault!r}",
          flush=True)
    # the policy's frames while it ran: the ones after the engage's blend (its ready gains) at its own stiffness
    kp = statistics.mode([e["kp_max"] for e in frames]) if frames else 0.0
    policy = [e for e in frames if e["kp_max"] == kp]
    def jitter_of(key: str) -> np.ndarray:
        gaps = np.diff([e[key] for e in policy if e.get(key) is not None]) * 1e3
        return np.abs(gaps[gaps < 40.0] - 20.0)  # a pause of the loop's (a hold) is not a period

    gaps = np.diff([e["t"] for e in policy]) * 1e3
    gaps = gaps[gaps < 40.0]
    jitter, written, applied_jitter = jitter_of("t"), jitter_of("src"), jitter_of("ap")
    wire = np.array([(e["t"] - e["src"]) * 1e3 for e in policy if e.get("src") is not None])
    applied = np.array([(e["ap"] - e["src"]) * 1e3 for e in policy if e.get("src") is not None])
    s2f = np.array(run.state_to_frame) if run.state_to_frame else np.zeros((1, 3))

    def q(values: np.ndarray, p: float) -> float:
        return float(np.percentile(values, p)) if len(values) else float("nan")

    print(f"LOOP policy={run.policy} frames={len(policy)} state_to_frame_p50_ms={np.median(s2f[:, 0]):.2f} "
          f"state_to_frame_p99_ms={s2f[:, 1].max():.2f} state_to_frame_max_ms={s2f[:, 2].max():.2f} "
          f"period_p50_ms={q(gaps, 50):.2f} jitter_p99_ms={q(jitter, 99):.2f} jitter_max_ms={q(jitter, 100):.2f} "
          f"written_jitter_p99_ms={q(written, 99):.2f} applied_jitter_p99_ms={q(applied_jitter, 99):.2f} "
          f"wire_p99_ms={q(wire, 99):.2f} to_applied_p99_ms={q(applied, 99):.2f} to_applied_max_ms={q(applied, 100):.2f}",
          flush=True)


if __name__ == "__main__":
    sys.exit(main())
