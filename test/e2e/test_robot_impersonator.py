"""The real node against a G1 impersonated on the robot's Cyclone DDS 0.10.2 (the closest check of real-robot
compatibility this project can run: see docs/robot_compat.md).

The impersonator (``support/robot_impersonator.py``) runs in ``.venv-cyclone010`` with the SDK's own
``Server`` and publishers, initialised the SDK's way and without any type fix; the node runs as shipped
(cyclonedds 11 + the type fix, unicast-only loopback). Judged from what the impersonator received.
"""

from __future__ import annotations

import json
import time

from g1_mode_manager_msgs.srv import LocoCommand, SetMode
from geometry_msgs.msg import Twist
from std_srvs.srv import Trigger

from support.cyclone010 import side_python
from support.mode_manager import RosClient, start_mode_manager, wait_until
from support.processes import ManagedProcess
from support.scripted_robot import events

IMPERSONATOR = str(__import__("pathlib").Path(__file__).resolve().parents[1] / "support" / "robot_impersonator.py")


def test_node_drives_a_robot_on_cyclone_0_10(sdk_domain: int) -> None:
    robot = ManagedProcess([side_python(), "-u", IMPERSONATOR, str(sdk_domain)], name="impersonator")
    node = ros = None
    try:
        robot.wait_for_line(lambda line: '"event": "ready"' in line, 30.0)
        node = start_mode_manager(sdk_domain)
        ros = RosClient("impersonator_client")
        ros.wait_node_answers()

        r = ros.call(SetMode, "/g1_mode_manager/set_mode", SetMode.Request(mode_name="high_level"))
        assert r.success, r.message
        assert events(robot, "request", svc="motion_switcher", api=1001), "CheckMode never reached the robot"

        r = ros.call(LocoCommand, "/g1_mode_manager/loco_command", LocoCommand.Request(command="start"))
        assert r.success, r.message
        assert events(robot, "state", fsm=500)

        pub = ros.node.create_publisher(Twist, "/cmd_vel", 10)
        assert wait_until(lambda: pub.get_subscription_count() > 0, 10.0)
        msg = Twist()
        msg.linear.x = 0.4
        end = time.monotonic() + 1.5
        while time.monotonic() < end:
            pub.publish(msg)
            time.sleep(0.05)
        moves = [json.loads(e["p"])["velocity"] for e in events(robot, "request", svc="sport", api=7105)]
        assert any(v[0] > 0.1 for v in moves), f"no forward Move reached the robot: {moves[-5:]}"

        r = ros.call(Trigger, "/g1_mode_manager/estop", Trigger.Request(), timeout_s=20.0)
        assert r.success, r.message
        states = events(robot, "state")
        assert (states[-1]["fsm"], states[-1]["svc"]) == (1, "ai"), states[-3:]
        damps = [e for e in events(robot, "request", svc="sport", api=7101) if json.loads(e["p"]) == {"data": 1}]
        assert damps, "no Damp reached the robot"
    finally:
        if ros is not None:
            ros.close()
        if node is not None:
            node.stop()
        robot.stop()
