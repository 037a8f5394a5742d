"""The body checks through the real node over the fake port: FAULT on ~/mode with its reason,
~/clear_fault refused then accepted, one /diagnostics status per check, and bad key parameters."""

from __future__ import annotations

import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from g1_mode_manager_msgs.msg import Mode
from node.test_node_plumbing import Harness
from rclpy.parameter import Parameter
from std_srvs.srv import Trigger

from fakes.fake_robot_port import FakeRobotPort
from fakes.lowstate_bytes import lowstate_bytes as state
from g1_mode_manager.core.port import SportState
from g1_mode_manager.node.mode_manager import ModeManagerNode
from g1_mode_manager.topic_qos import MODE_QOS
from support.mode_manager import wait_until

WALKING = SportState(fsm_id=500, fsm_mode=0, task_id=0, task_time=0.0, age_s=0.01)


@pytest.fixture
def harness():
    # long enough that the refused clear below lands inside it even when a loaded machine slows the calls
    h = Harness(FakeRobotPort(), fault_clear_hold_s=5.0)
    yield h
    h.close()


def test_a_fall_shows_fault_with_its_reason_and_clear_fault_waits_for_the_hold_time(harness) -> None:
    modes: list[Mode] = []
    harness.client.create_subscription(Mode, "/g1_mode_manager/mode", modes.append, MODE_QOS)
    diagnostics: list[DiagnosticArray] = []
    harness.client.create_subscription(DiagnosticArray, "/diagnostics", diagnostics.append, 10)
    port = harness.port
    port.state, port.sport = state(), WALKING
    assert harness.set_mode("high_level").success
    port.state = state(tilt=1.4)  # pushed over while walking
    assert wait_until(lambda: any(m.mode == Mode.FAULT for m in modes), 5.0)
    fault = next(m for m in modes if m.mode == Mode.FAULT)
    assert fault.name == "FAULT" and fault.faults and fault.faults[0].startswith("tilt: 1.40 rad > 1")
    assert wait_until(lambda: port.damped, 5.0)

    # damped, the robot is no longer held up: the fall's tilt stops counting (at the body check's next look,
    # up to 10 ms after FAULT), and the hold time starts
    def clear() -> Trigger.Response:
        return harness.call(Trigger, "/g1_mode_manager/clear_fault", Trigger.Request())

    assert wait_until(lambda: "still active" not in clear().message, 3.0)
    refused = clear()
    assert not refused.success and "tilt clear for only" in refused.message, refused.message
    set_mode = harness.set_mode("high_level")
    assert not set_mode.success and "clear_fault" in set_mode.message and "tilt" in set_mode.message

    assert wait_until(lambda: clear().success, 10.0)
    assert harness.node.machine.mode.name == "IDLE" and port.damped
    assert wait_until(lambda: any(m.mode == Mode.IDLE and not m.faults for m in modes[-3:]), 5.0)
    assert wait_until(lambda: any(any(s.name == "g1_mode_manager: body tilt" for s in d.status) for d in diagnostics), 5.0)
    body = [s for s in diagnostics[-1].status if s.name.startswith("g1_mode_manager: body ")]
    assert len(body) == 10 and all({kv.key for kv in s.values} >= {"value", "threshold", "state"} for s in body)


@pytest.mark.parametrize("name", ["remote_estop_keys", "lowcmd_deadman_key", "policy_engage_keys",
                                  "policy_disengage_keys"])
def test_an_unknown_remote_key_fails_at_start_naming_its_parameter(name: str) -> None:
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        with pytest.raises(ValueError, match=f"parameter {name}: unknown remote key 'Q'"):
            ModeManagerNode(port_factory=lambda _s: FakeRobotPort(), context=context,
                            parameter_overrides=[Parameter(name, value="L2+Q")])
    finally:
        rclpy.try_shutdown(context=context)
