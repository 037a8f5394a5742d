"""The flight recorder in the real node over the fake port: an e-stop's steps in its incident and the incident named
on /diagnostics; an unwritable folder on /diagnostics and in ~/snapshot's answer, the e-stop unaffected."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from node.test_node_plumbing import Harness
from std_srvs.srv import Trigger

from fakes.fake_robot_port import FakeRobotPort
from g1_mode_manager.core.recorder.incidents import Cause, list_incidents
from support.mode_manager import wait_until

RECORDER = "g1_mode_manager: recorder"


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    return tmp_path / "incidents"


def _recorder_statuses(harness: Harness) -> list[DiagnosticStatus]:
    if not hasattr(harness, "diagnostics"):
        harness.diagnostics = []
        harness.client.create_subscription(DiagnosticArray, "/diagnostics", harness.diagnostics.append, 10)
    return [s for d in list(harness.diagnostics) for s in d.status if s.name == RECORDER]


def _calls(path: Path) -> list[dict]:
    with open(path, "rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        return [{"topic": channel.topic, **json.loads(decoded.data)}
                for _s, channel, _m, decoded in reader.iter_decoded_messages(log_time_order=True)
                if channel.topic in ("/recorder/estop", "/recorder/robot_calls", "/recorder/transitions")]


def test_an_estops_steps_are_in_its_incident_and_diagnostics_name_it(folder: Path) -> None:
    harness = Harness(FakeRobotPort(), recorder_dir=str(folder), recorder_after_s=0.2)
    try:
        _recorder_statuses(harness)
        assert harness.set_mode("idle").success
        reply = harness.call(Trigger, "/g1_mode_manager/estop", Trigger.Request())
        assert reply.success, reply.message
        assert wait_until(lambda: list_incidents(folder), 5.0)
        [incident] = list_incidents(folder)
        assert incident.cause is Cause.EMERGENCY
        assert wait_until(lambda: any(incident.path.name in s.message for s in _recorder_statuses(harness)), 5.0)
        # what the ring keeps, once its thread has pruned it: the e-stop's own events at least
        def kept() -> list[dict[str, str]]:
            return [{v.key: v.value for v in s.values} for s in _recorder_statuses(harness)]

        assert wait_until(lambda: any(int(k["kept_events"]) > 0 and int(k["kept_kb"]) > 0 for k in kept()), 5.0), \
            kept()[-1:]
    finally:
        harness.close()
    steps = [(e["topic"].rsplit("/", 1)[1], e.get("step") or e.get("verb") or e["to"], e.get("phase", ""))
             for e in _calls(incident.path)]
    start = steps.index(("estop", "request", ""))
    after = steps[start:]
    # the first packet went out before the request was noted (nothing in front of it); then the sequence and the answer
    assert steps[start - 1] == ("robot_calls", "DampNoReply", "no_reply")
    damp = after.index(("robot_calls", "Damp", "request"))
    assert after[damp + 1] == ("robot_calls", "Damp", "answer")
    assert ("robot_calls", "GetFsmId", "answer") in after[damp:]
    assert after[-2:] == [("transitions", "EMERGENCY", ""), ("estop", "answer", "")]


def test_an_unwritable_folder_is_reported_and_the_estop_goes_on(tmp_path: Path) -> None:
    (tmp_path / "a_file").write_text("")
    folder = tmp_path / "a_file" / "incidents"
    harness = Harness(FakeRobotPort(), recorder_dir=str(folder), recorder_after_s=0.0)
    try:
        assert wait_until(lambda: any(s.level == DiagnosticStatus.WARN and "cannot create" in s.message
                                      for s in _recorder_statuses(harness)), 5.0)
        snapshot = harness.call(Trigger, "/g1_mode_manager/snapshot", Trigger.Request())
        assert not snapshot.success and str(folder) in snapshot.message
        assert harness.set_mode("idle").success
        start = time.monotonic()
        reply = harness.call(Trigger, "/g1_mode_manager/estop", Trigger.Request())
        assert reply.success and harness.port.damped, reply.message
        print(f"e-stop with an unwritable recorder folder answered in {time.monotonic() - start:.3f} s")
        assert wait_until(lambda: harness.node.parts.recorder.report().pending == "", 5.0)
        assert "cannot create" in harness.node.parts.recorder.report().error
        assert harness.node.machine.mode.name == "EMERGENCY"
    finally:
        harness.close()
