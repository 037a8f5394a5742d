"""odom and /tf from the robot's rt/lf/odommodestate, through the real node over the fake port: each sample once,
nothing stale, the twist in the body frame, and /diagnostics saying why odometry stops."""

from __future__ import annotations

import math

import pytest
from diagnostic_msgs.msg import DiagnosticArray
from nav_msgs.msg import Odometry
from node.test_node_plumbing import Harness

from fakes.fake_robot_port import FakeRobotPort
from g1_mode_manager.core.port import OdomSample
from g1_mode_manager.node.odometry import POSE_VARIANCE, rotate_into_body
from g1_mode_manager.protocol.odom_fields import OdomFields
from support.mode_manager import wait_until

tf2_msgs = pytest.importorskip("tf2_msgs.msg")

YAW = math.pi / 2  # facing +y in the odometry frame
QUARTERNION = (math.cos(YAW / 2), 0.0, 0.0, math.sin(YAW / 2))


def sample(count: int, x: float, age_s: float = 0.01) -> OdomSample:
    fields = OdomFields(stamp_s=1.0, position=(x, 2.0, 0.75), velocity=(0.0, 0.5, 0.0), yaw_speed=0.1,
                        quaternion=QUARTERNION, gyroscope=(0.0, 0.0, 0.1), rpy=(0.0, 0.0, YAW), body_height=0.75)
    return OdomSample(fields, age_s, count)


def test_rotation_into_the_body_frame() -> None:
    assert rotate_into_body(QUARTERNION, (0.0, 0.5, 0.0)) == pytest.approx((0.5, 0.0, 0.0), abs=1e-12)
    assert rotate_into_body((1.0, 0.0, 0.0, 0.0), (1.0, 2.0, 3.0)) == pytest.approx((1.0, 2.0, 3.0))


def test_each_sample_is_published_once_with_the_tf_and_nothing_stale() -> None:
    port = FakeRobotPort()
    h = Harness(port, odom_rate_hz=50.0, odom_child_frame_id="pelvis")
    try:
        odoms: list[Odometry] = []
        tfs: list = []
        diagnostics: list[DiagnosticArray] = []
        h.client.create_subscription(Odometry, "/odom", odoms.append, 10)
        h.client.create_subscription(tf2_msgs.TFMessage, "/tf", tfs.append, 100)
        h.client.create_subscription(DiagnosticArray, "/diagnostics", diagnostics.append, 10)
        assert h.set_mode("high_level").success
        port.odom = sample(1, 1.0)
        assert wait_until(lambda: odoms and tfs, 5.0)
        port.odom = sample(2, 1.5)
        assert wait_until(lambda: len(odoms) >= 2, 5.0)
        assert wait_until(lambda: False, 0.3) is False  # several ticks at 50 Hz: still the same two samples
        assert [o.pose.pose.position.x for o in odoms] == [1.0, 1.5]
        o = odoms[-1]
        assert (o.header.frame_id, o.child_frame_id) == ("odom", "pelvis")
        assert (o.pose.pose.orientation.w, o.pose.pose.orientation.z) == pytest.approx(QUARTERNION[::3])
        assert (o.twist.twist.linear.x, o.twist.twist.linear.y) == pytest.approx((0.5, 0.0), abs=1e-6)  # forward
        assert o.twist.twist.angular.z == pytest.approx(0.1)
        assert o.pose.covariance[0] == pytest.approx(POSE_VARIANCE[0]) and o.pose.covariance[35] > 0.0
        t = tfs[-1].transforms[0]
        assert (t.header.frame_id, t.child_frame_id, t.transform.translation.x) == ("odom", "pelvis", 1.5)

        port.odom = sample(3, 9.9, age_s=2.0)  # a new sample, but stale
        assert wait_until(lambda: False, 0.3) is False
        assert len(odoms) == 2
        assert wait_until(lambda: any(_odom_status(d, "stale") for d in diagnostics[-2:]), 5.0)
    finally:
        h.close()


def test_low_level_stops_odometry_and_diagnostics_say_why() -> None:
    port = FakeRobotPort()
    h = Harness(port, odom_rate_hz=20.0)
    try:
        diagnostics: list[DiagnosticArray] = []
        h.client.create_subscription(DiagnosticArray, "/diagnostics", diagnostics.append, 10)
        assert h.set_mode("high_level").success
        assert wait_until(lambda: any(_odom_status(d, "firmware may not publish odometry") for d in diagnostics), 5.0)
        port.odom = sample(1, 1.0, age_s=1.0)
        assert h.set_mode("low_level").success
        assert wait_until(lambda: any(_odom_status(d, "LOW_LEVEL: the robot's high-level services are off")
                                      for d in diagnostics[-2:]), 5.0)
    finally:
        h.close()


def _odom_status(array: DiagnosticArray, needle: str) -> bool:
    return any(s.name == "g1_mode_manager: odometry" and needle in s.message for s in array.status)


def test_tf2_msgs_has_the_type_hash_of_every_ros_jazzy_install() -> None:
    """Where scripts/build_msgs.sh built tf2_msgs, a /tf subscriber of a full ROS install must still match it:
    the hash is `ros2 topic info -v /tf`'s on Jazzy (RIHS01 hashes the fields, not the package's origin)."""
    import json
    import sys
    from pathlib import Path

    share = Path(sys.prefix) / "share" / "tf2_msgs"  # the venv prefix, where the wheels' packages install
    if not share.exists():  # a full ROS install
        from ament_index_python.packages import get_package_share_directory

        share = Path(get_package_share_directory("tf2_msgs"))
    description = json.loads((share / "msg" / "TFMessage.json").read_text())
    hashes = {h["type_name"]: h["hash_string"] for h in description["type_hashes"]}
    assert hashes["tf2_msgs/msg/TFMessage"] == "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087"
