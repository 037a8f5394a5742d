"""The real node with no robot on the other side: clear errors, nothing left half done, e-stop still EMERGENCY."""

from __future__ import annotations

import pytest
from g1_mode_manager_msgs.msg import Mode
from g1_mode_manager_msgs.srv import SetMode
from std_srvs.srv import Trigger

from support.mode_manager import RosClient, start_mode_manager

pytestmark = pytest.mark.e2e


def test_no_robot_answers(sdk_domain: int) -> None:
    # No sim bridge on this domain: nothing answers. The e-stop retries until estop_timeout_s (10 s by default) and
    # only then says it is incomplete; a 2 s budget gives the same verdict (each try waits the SDK's fixed 3 s
    # connect budget, so the answer comes after one failed try) without the test waiting out 10 s of retries.
    node = start_mode_manager(sdk_domain, "estop_timeout_s:=2.0")
    ros = RosClient("no_robot_client")
    try:
        ros.wait_node_answers()
        r = ros.call(SetMode, "/g1_mode_manager/set_mode", SetMode.Request(mode_name="high_level"))
        assert not r.success and r.mode == Mode.UNINITIALIZED
        assert "motion_switcher did not answer" in r.message, r.message
        e = ros.call(Trigger, "/g1_mode_manager/estop", Trigger.Request(), timeout_s=60.0)
        assert not e.success and "e-stop incomplete" in e.message, e.message
        r = ros.call(SetMode, "/g1_mode_manager/set_mode", SetMode.Request(mode_name="idle"))
        assert not r.success and r.mode == Mode.EMERGENCY  # EMERGENCY even though the robot never answered
        assert node.alive()
    finally:
        ros.close()
        assert node.stop() == 0, node.output()[-3000:]
