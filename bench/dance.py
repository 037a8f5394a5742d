"""A whole-body-tracking policy (holosoma's dance) played on the sim by the node, from HIGH_LEVEL standing: load,
shadow, engage by user control, then the clip until its end, a fall or a stop. Prints, twice a second, the policy's
phase and progress, its RMS joint error against the motion's own reference (the model's ``joint_pos`` output, as
``~/policy/status`` reports it), the pelvis height and the sim's real-time factor (the node's loop runs on the wall
clock, as on a robot: a sim slower than real time plays the clip faster than its physics); then one summary line.

    flock /tmp/g1_sim_cpu.lock .venv/bin/python -m bench.dance [--policy dance_fastsac] [--seconds 150]
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

from harness.domains import allocate_run_domains

_ROS_DOMAIN, SDK_DOMAIN = allocate_run_domains()
os.environ["ROS_DOMAIN_ID"] = str(_ROS_DOMAIN)
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"

from harness.mode_manager import RosClient, start_mode_manager  # noqa: E402
from harness.processes import restore_sigint  # noqa: E402
from harness.sim_bridge import shared_sim_status, start_sim_bridge  # noqa: E402

NODE = "/g1_mode_manager"
#: The robot counts as fallen below this pelvis height, m (standing: 0.76).
FALLEN_Z_M = 0.5
#: The states in which the clip has ended for good (the policy stopped, or the node left LOW_LEVEL).
OVER = ("loaded", "unloaded")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="bench.dance", description=__doc__.split("\n\n")[0])
    parser.add_argument("--policy", default="dance_fastsac")
    parser.add_argument("--seconds", type=float, default=150.0, help="the longest the clip is played, s")
    parser.add_argument("--param", action="append", default=[], help="a node parameter, name:=value (repeatable)")
    args = parser.parse_args(argv)
    restore_sigint()
    from g1_mode_manager.protocol.dds import init_channels

    init_channels(SDK_DOMAIN, "lo")
    sim = start_sim_bridge(SDK_DOMAIN, speed=1.0)
    status = shared_sim_status()
    status.wait_ready(15.0)
    ros = RosClient("bench_dance")
    node = start_mode_manager(SDK_DOMAIN, "low_level_path:=user_ctrl", *args.param)
    try:
        return _dance(ros, status, args.policy, args.seconds)
    finally:
        node.stop()
        ros.close()
        sim.stop()


def _dance(ros: RosClient, sim, policy: str, seconds: float) -> int:
    from g1_mode_manager_msgs.msg import PolicyStatus
    from g1_mode_manager_msgs.srv import LoadPolicy, LocoCommand, SetMode
    from std_srvs.srv import Trigger

    from g1_mode_manager.topic_qos import MODE_QOS

    statuses: list[PolicyStatus] = []
    ros.node.create_subscription(PolicyStatus, f"{NODE}/policy/status", statuses.append, MODE_QOS)
    ros.wait_node_answers()

    def ok(reply, what: str) -> None:
        if not reply.success:
            raise SystemExit(f"{what} refused: {reply.message}")

    ok(ros.call(SetMode, f"{NODE}/set_mode", SetMode.Request(mode_name="high_level"), 30.0), "high_level")
    ok(ros.call(LocoCommand, f"{NODE}/loco_command", LocoCommand.Request(command="start"), 30.0), "start")
    time.sleep(2.0)  # at rest: the user-control entry waits for it
    ok(ros.call(LoadPolicy, f"{NODE}/policy/load", LoadPolicy.Request(policy=policy), 60.0), "load")
    ok(ros.call(Trigger, f"{NODE}/policy/shadow", Trigger.Request(), 30.0), "shadow")
    time.sleep(1.0)
    ok(ros.call(Trigger, f"{NODE}/policy/engage", Trigger.Request(), 30.0), "engage")
    t0 = time.monotonic()
    errors: list[float] = []
    lowest = 9.0
    print(f"{'t s':>6} {'sim s':>7} {'rtf':>5} {'phase':>10} {'clip %':>7} {'rms err rad':>11} {'pelvis z m':>10}")
    while time.monotonic() - t0 < seconds:
        time.sleep(0.5)
        s = sim.get()
        last = statuses[-1] if statuses else None
        z = s["body"]["pelvis_z"]
        lowest = min(lowest, z)
        err = last.tracking_error_rad if last is not None else -1.0
        if last is not None and last.phase == "running" and err >= 0.0:
            errors.append(err)
        phase = last.phase if last is not None else "?"
        progress = 100.0 * last.progress if last is not None and last.progress >= 0.0 else float("nan")
        print(f"{time.monotonic() - t0:6.1f} {s['sim_time']:7.1f} {s['real_time_factor']:5.2f} {phase:>10} "
              f"{progress:7.1f} {err:11.3f} {z:10.3f}", flush=True)
        if phase in OVER or z < FALLEN_Z_M or (last is not None and last.progress >= 1.0):
            break
    last = statuses[-1] if statuses else None
    played = 100.0 * last.progress if last is not None and last.progress >= 0.0 else 0.0
    fault = last.last_fault if last is not None else ""
    median = statistics.median(errors) if errors else float("nan")
    print(f"DANCE policy={policy} played_pct={played:.1f} seconds={time.monotonic() - t0:.1f} "
          f"lowest_pelvis_z={lowest:.3f} fell={int(lowest < FALLEN_Z_M)} rms_err_median={median:.3f} "
          f"rms_err_max={max(errors, default=float('nan')):.3f} fault={fault!r}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
