"""The flight recorder on the real node against the real sim, its files read with the mcap library's reader and
mcap_ros2's decoder alone (support/incidents.py): a push while walking ends in FAULT and an incident that holds the
tilt rising past the limit, the node's Damp and its answer, and the Moves before, in order and with the robot's
latencies; ~/snapshot, called with the stock ros2 CLI, writes a file that ``g1ctl incidents`` lists.

The same push is judged by the robot too (the sim's record): a walking robot pushed over is damped, and a smaller
push it walks on through is no fault. One robot for all (the module's stack): the snapshot first, from IDLE, then the
walk and its two pushes (one fixture), the robot's side of them, then their incident (its after-window over by then).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import pytest
from g1_mode_manager_msgs.msg import Mode as ModeMsg

from g1_mode_manager.core.recorder.incidents import Cause, list_incidents
from g1_mode_manager.protocol import api_ids
from support.incidents import ROBOT_CALLS, answered, json_of, messages, metadata, wait_for_incident
from support.mode_manager import wait_until
from support.sim_record import confirming_damp, damped, is_damp, of_kind, requests, states, velocity_of
from support.timing import (
    HIGH_LEVEL_DAMP_S,
    INCIDENT_AFTER_S,
    INCIDENT_WRITE_S,
    RECORD_WAIT_S,
    ROUND_TRIP_S,
    check_latency,
)

pytestmark = [pytest.mark.e2e, pytest.mark.sim]

TILT_LIMIT_RAD = 1.0  # the node's default tilt_limit_rad
#: The stock ros2 CLI (ros2cli has no PyPI wheel; docs/recorder.md says how it was run): G1_ROS2_CLI or `ros2` on
#: PATH. Without it the snapshot is called by an rclpy client of the same service, as `ros2 service call` is.
ROS2_CLI = os.environ.get("G1_ROS2_CLI") or shutil.which("ros2")


@pytest.fixture(scope="module")
def stack(module_stack_factory, tmp_path_factory):
    folder = tmp_path_factory.mktemp("incidents")
    stack = module_stack_factory(node_params=(f"recorder_dir:={folder}", f"recorder_after_s:={INCIDENT_AFTER_S}"))
    stack.incidents = folder
    return stack


def _snapshot(stack) -> tuple[bool, str, str]:
    """(success, message, how it was called)."""
    name = stack.name("snapshot")
    if ROS2_CLI is None:
        from std_srvs.srv import Trigger

        reply = stack.ros.call(Trigger, name, Trigger.Request(), timeout_s=ROUND_TRIP_S + 10.0)
        return reply.success, reply.message, "rclpy client (no ros2 CLI here)"
    done = subprocess.run([ROS2_CLI, "service", "call", name, "std_srvs/srv/Trigger"], capture_output=True, text=True,
                          timeout=60.0, env=os.environ)
    assert done.returncode == 0, done.stdout + done.stderr
    match = re.search(r"success=(True|False), message='([^']*)'", done.stdout)
    assert match, done.stdout
    return match.group(1) == "True", match.group(2), ROS2_CLI


def test_a_snapshot_called_by_the_ros2_cli_is_listed_by_g1ctl(stack) -> None:
    assert stack.set_mode("idle").success
    success, message, how = _snapshot(stack)
    print(f"~/snapshot called by {how}: {message}")
    assert success, message
    path = Path(message)
    assert path.parent == stack.incidents and path in [f.path for f in list_incidents(stack.incidents)]
    assert list_incidents(stack.incidents)[-1].cause is Cause.SNAPSHOT
    listed = subprocess.run([sys.executable, "-m", "g1_mode_manager.cli.main", "incidents"], capture_output=True,
                            text=True, timeout=60.0, env=os.environ)
    assert listed.returncode == 0, listed.stderr
    line = next((line for line in listed.stdout.splitlines() if str(path) in line), None)
    assert line is not None, listed.stdout
    assert "IDLE" in line and "~/snapshot" in line, line


@dataclass(frozen=True)
class Pushes:
    """A walk on cmd_vel and its two pushes, as the test saw them."""

    t_walking: float  # UNIX time (the file's): Moves were reaching the robot
    t_small: float  # monotonic (the record's): the small push asked for
    walk_modes: list[str]  # ~/mode names from HIGH_LEVEL's entry to the end of the small push's watch
    t_push: float  # UNIX time: the big push asked for
    t0: float  # monotonic: the same moment, on the record's clock
    fault: ModeMsg | None  # the first ~/mode FAULT after the big push


@pytest.fixture(scope="module")
def pushes(stack) -> Pushes:
    """The robot walks on cmd_vel (0.3 m/s) and is pushed twice: 150 N, which it walks on through, then 600 N, which
    fells it. Asserted by the tests that read it: the robot's side and the incident's."""
    stack.modes()
    assert stack.set_mode("high_level").success
    assert stack.loco("start").success
    driving = threading.Event()
    driver = threading.Thread(target=lambda: [stack.drive(0.3, 0.2) for _ in iter(driving.is_set, True)], daemon=True)
    driver.start()
    try:
        assert wait_until(lambda: any(any(velocity_of(e) or []) for e in requests(stack.record.events(),
                                                                                 api_ids.LOCO_SET_VELOCITY)), 10.0)
        t_walking = time.time()
        t_small = time.monotonic()
        stack.set_faults({"push": {"force": 150, "direction": [1, 0], "duration": 0.2}})  # it walks on
        # watched 1.5 s: the sway this push causes peaks (~0.16 rad) 0.6 s in and is over within 1 s of sim time,
        # and a push that fells the robot has it past 1 rad ~0.5 s in (the 600 N push below); the rest is slack for a
        # sim running below real time on a loaded machine
        time.sleep(1.5)
        # from HIGH_LEVEL on: the subscription began with the mode the snapshot's test left (~/mode is latched)
        modes = stack.modes()
        entered = next((i for i, m in enumerate(modes) if m.mode == ModeMsg.HIGH_LEVEL), len(modes))
        walk_modes = [m.name for m in modes[entered:]]
        t_push, t0 = time.time(), time.monotonic()
        stack.set_faults({"push": {"force": 600, "direction": [1, 0], "duration": 0.3}})
        wait_until(lambda: stack.modes()[-1].mode == ModeMsg.FAULT, RECORD_WAIT_S)
    finally:
        driving.set()
        driver.join(5.0)
    fault = next((m for m in stack.modes() if m.mode == ModeMsg.FAULT), None)
    return Pushes(t_walking, t_small, walk_modes, t_push, t0, fault)


def test_a_walking_robot_pushed_over_is_damped(stack, pushes: Pushes) -> None:
    """Judged by the robot (the sim's record): the small push left it walking, upright; the big one felled it, and
    the node's Damp followed the tilt past the limit; no Move after the damping sequence's Damp; damped."""
    assert pushes.walk_modes and set(pushes.walk_modes) == {"HIGH_LEVEL"}, pushes.walk_modes
    assert all(e["tilt"] < TILT_LIMIT_RAD for e in of_kind(stack.record.events(pushes.t_small), "body")
               if e["t"] < pushes.t0)
    assert wait_until(lambda: stack.modes()[-1].mode == ModeMsg.FAULT and stack.modes()[-1].damp_confirmed, 10.0), \
        [(m.name, list(m.faults)) for m in stack.modes()[-3:]]
    fault = stack.modes()[-1]
    assert any(f.split(":")[0] in ("tilt", "spin") for f in fault.faults), list(fault.faults)

    def over() -> list[dict]:
        return [e for e in of_kind(stack.record.events(pushes.t0), "body") if e["tilt"] > TILT_LIMIT_RAD]

    assert wait_until(lambda: bool(over()), RECORD_WAIT_S), "the sim never showed the tilt past the limit"
    t_damp = next(e["t"] for e in requests(stack.record.events(pushes.t0)) if is_damp(e))
    check_latency("pushed over in HIGH_LEVEL: the node's Damp", over()[0]["t"], t_damp, HIGH_LEVEL_DAMP_S)
    # a Move written before the FAULT closed the gate may still land after its DampNoReply; none after the
    # sequence's Damp
    t_cut = confirming_damp(stack.record.events(pushes.t0))["t"]
    moves = [e for e in requests(stack.record.events(t_cut), api_ids.LOCO_SET_VELOCITY) if any(velocity_of(e) or [])]
    assert moves == [], moves[:3]
    assert wait_until(lambda: any(damped(s) for s in states(stack.record.events(pushes.t0))), 10.0)
    sport = stack.sim.get()["sport"]
    assert sport["fsm_id"] == 1 and sport["mode"] == "ai", sport
    print(f"~/mode: {fault.name}, faults {list(fault.faults)}")


def test_a_push_while_walking_leaves_the_fall_the_damp_and_the_moves_in_an_incident(stack, pushes: Pushes) -> None:
    assert pushes.fault is not None, [(m.name, list(m.faults)) for m in stack.modes()[-3:]]
    faults = list(pushes.fault.faults)
    path = wait_for_incident(stack.incidents, "fault", INCIDENT_AFTER_S + INCIDENT_WRITE_S)
    assert path in [f.path for f in list_incidents(stack.incidents) if f.cause is Cause.FAULT]
    info = metadata(path)
    assert info["cause"].startswith("FAULT from HIGH_LEVEL: ") and info["mode"] == "FAULT", info
    got = messages(path)

    statuses = [(m.t, s) for m, s in json_of(got, "/recorder/status")]
    t_fault = next(t for t, s in statuses if s["mode"] == "FAULT")
    assert any(s["mode"] == "HIGH_LEVEL" for t, s in statuses if t < t_fault)

    tilts = [(m.t, m.data.data) for m in got if m.topic == "/recorder/body/tilt_rad"]
    upright = [tilt for t, tilt in tilts if pushes.t_walking <= t < pushes.t_push]
    assert len(upright) >= 3 and max(upright) < 0.5, upright[-5:]  # walking upright before the push
    t_over = next(t for t, tilt in tilts if tilt > TILT_LIMIT_RAD)
    assert pushes.t_push < t_over
    if any(f.startswith("tilt") for f in faults):  # the tilt tripped it (a spin may trip first)
        assert t_over <= t_fault

    calls = json_of(got, ROBOT_CALLS)
    moves = [(m, c) for m, c in calls if c["verb"] == "SetVelocity" and c["phase"] == "request"
             and c["parameter"]["vx"] > 0.0]
    before = [(m, c) for m, c in moves if m.t < t_fault]
    # each answered (a loaded machine may time one out: its answer then says 3104)
    replies = [answered(got, move)[1] for move in before]
    acknowledged = [a for a in replies if a["code"] == 0]
    assert len(acknowledged) >= 3 and all(a["latency_ms"] > 0.0 for a in acknowledged), calls[:10]
    assert [m.t for m, _c in moves if m.t > t_fault] == []  # the gate closed at the FAULT
    assert any(m.data.linear.x > 0.0 for m in got if m.topic == "/recorder/moves/teleop" and m.t < t_fault)

    damp_shot = next(m.t for m, c in calls if c["verb"] == "DampNoReply" and m.t >= t_fault)
    damp = next((m, c) for m, c in calls if c["verb"] == "Damp" and c["phase"] == "request" and m.t >= t_fault)
    reply, answer = answered(got, damp)
    assert before[-1][0].t < t_fault <= damp_shot <= damp[0].t < reply.t
    assert answer["code"] == 0 and answer["latency_ms"] > 0.0, answer
    latencies = [a["latency_ms"] for a in acknowledged]
    print(f"incident {path.name}: {len(got)} messages, {path.stat().st_size / 1024:.0f} KiB; {len(before)} Moves "
          f"before the FAULT (acknowledged in {min(latencies):.1f}-{max(latencies):.1f} ms), tilt past "
          f"{TILT_LIMIT_RAD} rad {1000 * (t_over - t_fault):+.0f} ms from the FAULT ({', '.join(faults)}), the Damp "
          f"answered in {answer['latency_ms']:.1f} ms")
