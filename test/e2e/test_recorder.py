"""The flight recorder on the real node against the real sim, its files read with the mcap library's reader and
mcap_ros2's decoder alone: a push while walking ends in FAULT and an incident that holds the tilt rising past the
limit, the node's Damp and its answer, and the Moves before, in order and with the robot's latencies; ~/snapshot,
called with the stock ros2 CLI, writes a file that ``g1ctl incidents`` lists.

One robot for both (the module's stack): the snapshot first, from IDLE, then the push.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from g1_mode_manager_msgs.msg import Mode as ModeMsg
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from g1_mode_manager.core.recorder.incidents import Cause, list_incidents
from g1_mode_manager.protocol import api_ids
from support.mode_manager import wait_until
from support.sim_record import requests, velocity_of
from support.timing import INCIDENT_AFTER_S, INCIDENT_WRITE_S, RECORD_WAIT_S, ROUND_TRIP_S

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


def _messages(path: Path) -> list[tuple[str, float, object]]:
    """(topic, log time in s, decoded message) of every message, in log time order."""
    with open(path, "rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        return [(channel.topic, message.log_time / 1e9, decoded)
                for _schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=True)]


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


def test_a_push_while_walking_leaves_the_fall_the_damp_and_the_moves_in_an_incident(stack) -> None:
    stack.modes()
    assert stack.set_mode("high_level").success
    assert stack.loco("start").success
    driving = threading.Event()
    driver = threading.Thread(target=lambda: [stack.drive(0.3, 0.2) for _ in iter(driving.is_set, True)], daemon=True)
    driver.start()
    try:
        assert wait_until(lambda: any(any(velocity_of(e) or []) for e in requests(stack.record.events(),
                                                                                 api_ids.LOCO_SET_VELOCITY)), 10.0)
        t_walking = time.time()  # the file's times are UNIX times
        time.sleep(0.5)  # a few Moves and body readings while it walks upright
        t_push = time.time()
        stack.set_faults({"push": {"force": 600, "direction": [1, 0], "duration": 0.3}})
        assert wait_until(lambda: stack.modes()[-1].mode == ModeMsg.FAULT, RECORD_WAIT_S), \
            [(m.name, list(m.faults)) for m in stack.modes()[-3:]]
    finally:
        driving.set()
        driver.join(5.0)
    faults = list(stack.modes()[-1].faults)
    assert wait_until(lambda: any(f.cause is Cause.FAULT for f in list_incidents(stack.incidents)),
                      INCIDENT_AFTER_S + INCIDENT_WRITE_S)
    incident = next(f for f in list_incidents(stack.incidents) if f.cause is Cause.FAULT)
    got = _messages(incident.path)

    statuses = [(t, json.loads(m.data)) for topic, t, m in got if topic == "/recorder/status"]
    t_fault = next(t for t, s in statuses if s["mode"] == "FAULT")
    assert any(s["mode"] == "HIGH_LEVEL" for t, s in statuses if t < t_fault)

    tilts = [(t, m.data) for topic, t, m in got if topic == "/recorder/body/tilt_rad"]
    upright = [tilt for t, tilt in tilts if t_walking <= t < t_push]
    assert len(upright) >= 3 and max(upright) < 0.5, upright[-5:]  # walking upright before the push
    t_over = next(t for t, tilt in tilts if tilt > TILT_LIMIT_RAD)
    assert t_push < t_over
    if any(f.startswith("tilt") for f in faults):  # the tilt tripped it (a spin may trip first)
        assert t_over <= t_fault

    calls = [(t, json.loads(m.data)) for topic, t, m in got if topic == "/recorder/robot_calls"]
    answers = {c["id"]: (t, c) for t, c in calls if c["phase"] == "answer"}
    moves = [(t, c) for t, c in calls if c["verb"] == "SetVelocity" and c["phase"] == "request"
             and c["parameter"]["vx"] > 0.0]
    before = [(t, c) for t, c in moves if t < t_fault]
    for t, move in before:  # each answered (a loaded machine may time one out: its answer then says 3104)
        t_answer, answer = answers[move["id"]]
        assert t <= t_answer and answer["latency_ms"] is not None, answer
    acknowledged = [answers[c["id"]][1] for _t, c in before if answers[c["id"]][1]["code"] == 0]
    assert len(acknowledged) >= 3 and all(a["latency_ms"] > 0.0 for a in acknowledged), calls[:10]
    assert [t for t, _m in moves if t > t_fault] == []  # the gate closed at the FAULT
    assert any(m.linear.x > 0.0 for topic, t, m in got if topic == "/recorder/moves/teleop" and t < t_fault)

    damp_shot = next(t for t, c in calls if c["verb"] == "DampNoReply" and t >= t_fault)
    t_damp, damp = next((t, c) for t, c in calls if c["verb"] == "Damp" and c["phase"] == "request" and t >= t_fault)
    t_answer, answer = answers[damp["id"]]
    assert before[-1][0] < t_fault <= damp_shot <= t_damp < t_answer
    assert answer["code"] == 0 and answer["latency_ms"] > 0.0, answer
    latencies = [a["latency_ms"] for a in acknowledged]
    print(f"incident {incident.path.name}: {len(got)} messages, {incident.size / 1024:.0f} KiB; {len(before)} Moves "
          f"before the FAULT (acknowledged in {min(latencies):.1f}-{max(latencies):.1f} ms), tilt past "
          f"{TILT_LIMIT_RAD} rad {1000 * (t_over - t_fault):+.0f} ms from the FAULT ({', '.join(faults)}), the Damp "
          f"answered in {answer['latency_ms']:.1f} ms")
