"""End-to-end fixtures: the real sim bridge and the real mode_manager node, each in a subprocess."""

from __future__ import annotations

import json
import math
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from g1_mode_manager_msgs.srv import LocoCommand, SetMode
from geometry_msgs.msg import Twist

from support.mode_manager import RosClient, start_mode_manager
from support.processes import ManagedProcess
from support.sim_bridge import SimStatus, shared_sim_status, start_sim_bridge
from support.sim_record import SimRecord


def _yaw(quat_wxyz: Sequence[float]) -> float:
    w, x, y, z = quat_wxyz
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


@dataclass
class Stack:
    """The simulated G1, the node under test, a ROS client and the sim's status service."""

    bridge: ManagedProcess
    node: ManagedProcess
    ros: RosClient
    sim: SimStatus
    record: SimRecord  # the robot's own record: every request, frame and state change, with receive times
    ns: str = ""  # the node's namespace ("" = the root), e.g. "/robot_a"
    #: the bridge's status when this stack began (a bridge shared by a file's tests counts on)
    baseline: dict = field(default_factory=dict)

    def name(self, relative: str) -> str:
        """A name of the node under test: ``name("set_mode")`` -> ``<ns>/g1_mode_manager/set_mode``."""
        return f"{self.ns}/g1_mode_manager/{relative}"

    def set_mode(self, name: str, timeout_s: float = 30.0) -> SetMode.Response:
        return self.ros.call(SetMode, self.name("set_mode"), SetMode.Request(mode_name=name), timeout_s)

    def loco(self, command: str, value: int = 0) -> LocoCommand.Response:
        return self.ros.call(LocoCommand, self.name("loco_command"),
                             LocoCommand.Request(command=command, value=value))

    def estop(self, timeout_s: float = 30.0):
        from std_srvs.srv import Trigger

        return self.ros.call(Trigger, self.name("estop"), Trigger.Request(), timeout_s)

    def match_estop(self, timeout_s: float = 15.0) -> None:
        """Make the e-stop client and wait for its server now, so a test that times an e-stop does not time
        this client's discovery (long on a loaded machine) as the node's latency."""
        from std_srvs.srv import Trigger

        assert self.ros.client(Trigger, self.name("estop")).wait_for_service(timeout_sec=timeout_s), "no ~/estop server"

    def position(self) -> tuple[float, float, float]:
        return tuple(self.sim.get()["base"]["position"])

    def requests(self, service: str, api_id: int) -> int:
        """Requests the robot received since this stack began."""
        now = int(self.sim.get()["requests"].get(service, {}).get(str(api_id), 0))
        return now - int(self.baseline.get("requests", {}).get(service, {}).get(str(api_id), 0))

    def frames(self, topic: str) -> dict[str, int]:
        """The robot's frame counts of ``topic`` (lowcmd, arm_sdk: accepted, bad_crc...) since this stack began."""
        now, base = self.sim.get()["frames"][topic], self.baseline.get("frames", {}).get(topic, {})
        return {key: count - base.get(key, 0) for key, count in now.items()}

    def drive(self, vx: float, seconds: float, *, vy: float = 0.0, wz: float = 0.0, rate_hz: float = 20.0) -> None:
        pub = self.cmd_vel_publisher()
        msg = Twist()
        msg.linear.x, msg.linear.y, msg.angular.z = vx, vy, wz
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            pub.publish(msg)
            time.sleep(1.0 / rate_hz)

    def drive_sim_time(self, vx: float, sim_seconds: float, *, wz: float = 0.0, rate_hz: float = 20.0) -> None:
        """As ``drive``, for ``sim_seconds`` of the sim's time: a loaded machine runs the sim below real time, and
        a walk's length follows the robot's time, not the test's."""
        pub = self.cmd_vel_publisher()
        msg = Twist()
        msg.linear.x, msg.angular.z = vx, wz
        end = self.sim.get()["sim_time"] + sim_seconds
        next_look = 0.0
        while True:
            if time.monotonic() >= next_look:
                if self.sim.get()["sim_time"] >= end:
                    return
                next_look = time.monotonic() + 0.2
            pub.publish(msg)
            time.sleep(1.0 / rate_hz)

    def walk_forward(self, vx: float, metres: float, within_sim_s: float | None = None) -> float:
        """Drive forward at ``vx`` on cmd_vel (20 Hz) until the robot is ``metres`` from where it stood (the sim's
        base position), for at most ``within_sim_s`` (WALK_SIM_S unless given) of sim time; returns how far it
        walked. A teleop stalled on a loaded machine stops the walk (the node's watchdog) for a while: a fixed drive
        time would then fall short."""
        from support.timing import WALK_SIM_S

        within_sim_s = WALK_SIM_S if within_sim_s is None else within_sim_s
        pub = self.cmd_vel_publisher()
        msg = Twist()
        msg.linear.x = vx
        status = self.sim.get()
        x0, y0, _ = status["base"]["position"]
        t0 = status["sim_time"]
        next_look = 0.0
        while True:
            if time.monotonic() >= next_look:  # the sim's status every 0.2 s, as drive_sim_time reads it
                status = self.sim.get()
                x, y, _ = status["base"]["position"]
                walked = math.hypot(x - x0, y - y0)
                took = status["sim_time"] - t0
                if walked >= metres or took >= within_sim_s:
                    print(f"walk_forward: {walked:.2f} of {metres} m in {took:.1f} s of sim time "
                          f"(at most {within_sim_s:.1f})")
                    return walked
                next_look = time.monotonic() + 0.2
            pub.publish(msg)
            time.sleep(0.05)

    def turn_by(self, wz: float, degrees: float) -> float:
        """Turn on the spot at ``wz`` on cmd_vel (20 Hz) until the robot's heading (the sim's base) has turned
        ``degrees`` the way ``wz`` asks, for at most TURN_SIM_S of sim time; returns how far it turned, degrees (the
        heading's steps summed, so a turn past 180 degrees reads as one). Bounded by the robot's time, as
        walk_forward: a teleop stalled on a loaded machine stops the turn for a while, not the test."""
        from support.timing import TURN_SIM_S

        pub = self.cmd_vel_publisher()
        msg = Twist()
        msg.angular.z = wz
        status = self.sim.get()
        heading, turned = _yaw(status["base"]["quaternion"]), 0.0
        end = status["sim_time"] + TURN_SIM_S
        next_look = 0.0
        while True:
            if time.monotonic() >= next_look:
                status = self.sim.get()
                now = _yaw(status["base"]["quaternion"])
                turned += math.copysign(1.0, wz) * math.remainder(now - heading, 2 * math.pi)
                heading = now
                if math.degrees(turned) >= degrees or status["sim_time"] >= end:
                    return math.degrees(turned)
                next_look = time.monotonic() + 0.2
            pub.publish(msg)
            time.sleep(0.05)

    def cmd_vel_publisher(self):
        if not hasattr(self, "_cmd_vel"):
            self._cmd_vel = self.ros.node.create_publisher(Twist, f"{self.ns}/cmd_vel", 10)
            deadline = time.monotonic() + 10.0
            while self._cmd_vel.get_subscription_count() == 0 and time.monotonic() < deadline:
                time.sleep(0.05)
        return self._cmd_vel

    def set_faults(self, faults: dict) -> None:
        """Replace the sim's faults at run time (its `faults` parameter)."""
        from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
        from rcl_interfaces.srv import SetParameters

        value = ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=json.dumps(faults))
        r = self.ros.call(SetParameters, "/g1_sim_bridge/set_parameters",
                          SetParameters.Request(parameters=[Parameter(name="faults", value=value)]))
        assert r.results[0].successful, r.results[0].reason

    def set_gantry(self, on: bool) -> None:
        """Hang the robot in the sim's gantry, or unhook it (the bridge's `gantry` parameter)."""
        from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
        from rcl_interfaces.srv import SetParameters

        value = ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=on)
        r = self.ros.call(SetParameters, "/g1_sim_bridge/set_parameters",
                          SetParameters.Request(parameters=[Parameter(name="gantry", value=value)]))
        assert r.results[0].successful, r.results[0].reason

    def modes(self) -> list:
        """Every ~/mode message since the first call (a subscription of the test's client)."""
        if not hasattr(self, "_modes"):
            from g1_mode_manager_msgs.msg import Mode

            from g1_mode_manager.topic_qos import MODE_QOS

            self._modes: list = []
            self.ros.node.create_subscription(Mode, self.name("mode"), self._modes.append, MODE_QOS)
        return self._modes

    def clear_fault(self):
        from std_srvs.srv import Trigger

        return self.ros.call(Trigger, self.name("clear_fault"), Trigger.Request())

    def horizontal_speed(self) -> float:
        v = self.sim.get()["base"]["linear_velocity"]
        return math.hypot(v[0], v[1])


class _Stacks:
    """Starts stacks and stops everything it started."""

    def __init__(self, sdk_channels: int, records: Path) -> None:
        self._sdk = sdk_channels
        self._records = records
        self._started: list[ManagedProcess] = []
        self._clients: list[RosClient] = []

    def start(self, faults: dict | None = None, node_params: Sequence[str] = (),
              bridge_args: Sequence[str] = ()) -> Stack:
        record = self._records / f"sim_record_{len(self._started)}.jsonl"
        bridge = start_sim_bridge(self._sdk, speed=1.0, faults=faults,
                                  extra_args=("--record", str(record), *bridge_args))
        self._started.append(bridge)
        ros = RosClient()  # first: it is discovered while the node starts, not after
        self._clients.append(ros)
        node = start_mode_manager(self._sdk, *node_params)
        self._started.append(node)
        ros.wait_node_answers()
        sim = shared_sim_status()  # SDK clients must live for the whole process (see harness.sim_bridge)
        sim.wait_ready(15.0)
        stack = Stack(bridge, node, ros, sim, SimRecord(record))
        stack.match_estop()
        return stack

    def stop(self) -> None:
        for ros in self._clients:
            ros.close()
        for proc in reversed(self._started):
            code = proc.stop()
            if code not in (0, None):
                print(f"{proc.name} exited with {code}; output:\n{proc.output()[-4000:]}")


class _SharedBridge:
    """One bridge for a file's tests, each test with a fresh robot (the sim's reset: boot state, no faults,
    nothing delayed in flight), its own node and its own view of the record. Saves the bridge's start (MuJoCo
    model and policy, ~5 s) per test; the node, whose state a test may leave final (EMERGENCY), is new."""

    def __init__(self, sdk_channels: int, records: Path) -> None:
        self._sdk = sdk_channels
        self._record = records / "sim_record.jsonl"
        self._bridge: ManagedProcess | None = None

    def start(self, node_params: Sequence[str]) -> tuple[ManagedProcess, ManagedProcess, SimStatus, SimRecord, dict]:
        """(bridge, node, status, record view, the bridge's status right after the reset)."""
        if self._bridge is None or not self._bridge.alive():
            self._bridge = start_sim_bridge(self._sdk, speed=1.0, extra_args=("--record", str(self._record)))
        sim = shared_sim_status()
        sim.wait_ready(15.0)
        record = SimRecord(self._record, from_now=True)  # from just before the reset: it holds the boot state
        baseline = sim.reset()
        return self._bridge, start_mode_manager(self._sdk, *node_params), sim, record, baseline

    def stop(self) -> None:
        if self._bridge is not None:
            code = self._bridge.stop()
            if code not in (0, None):
                print(f"sim_bridge exited with {code}; output:\n{self._bridge.output()[-4000:]}")


@pytest.fixture(scope="module")
def _shared_bridge(sdk_channels: int, tmp_path_factory: pytest.TempPathFactory) -> Iterator[_SharedBridge]:
    shared = _SharedBridge(sdk_channels, tmp_path_factory.mktemp("shared_bridge"))
    yield shared
    shared.stop()


@pytest.fixture
def shared_stack_factory(_shared_bridge: _SharedBridge) -> Iterator:
    """Like stack_factory, on the file's one bridge (see _SharedBridge): faults and the gantry are set at run
    time after the reset; the node, the client and the record view are the test's own."""
    nodes: list[ManagedProcess] = []
    clients: list[RosClient] = []

    def factory(faults: dict | None = None, node_params: Sequence[str] = (), bridge_args: Sequence[str] = ()) -> Stack:
        unknown = set(bridge_args) - {"--gantry"}
        assert not unknown, f"a shared bridge cannot take {unknown} (start-time arguments): use stack_factory"
        ros = RosClient()  # first: it is discovered while the node starts, not after
        clients.append(ros)
        bridge, node, sim, record, baseline = _shared_bridge.start(node_params)
        nodes.append(node)
        ros.wait_node_answers()
        stack = Stack(bridge, node, ros, sim, record, baseline=baseline)
        stack.match_estop()
        # the reset cleared the robot's faults (and its parameter) and kept the gantry as it was: each is set only
        # where the test needs it otherwise, since a call to the bridge's parameter service waits for this new
        # client to discover it
        if faults:
            stack.set_faults(faults)
        if baseline["body"]["gantry"] != ("--gantry" in bridge_args):
            stack.set_gantry("--gantry" in bridge_args)
        return stack

    yield factory
    for ros in clients:
        ros.close()
    for node in reversed(nodes):
        code = node.stop()
        if code not in (0, None):
            print(f"mode_manager exited with {code}; output:\n{node.output()[-4000:]}")


@pytest.fixture
def stack_factory(sdk_channels: int, tmp_path: Path) -> Iterator:
    """factory(faults=None, node_params=(), bridge_args=()) -> Stack; everything it started is stopped after
    the test. ``bridge_args`` go to sim_bridge (e.g. --no-ros-publish: the sim's own /joint_states off)."""
    stacks = _Stacks(sdk_channels, tmp_path)
    yield stacks.start
    stacks.stop()


@pytest.fixture(scope="module")
def module_stack_factory(sdk_channels: int, tmp_path_factory: pytest.TempPathFactory) -> Iterator:
    """The same, stopped after the module: for a file whose tests can share one robot (each test leaves it
    as the next expects; a file stays in one worker, its tests in file order)."""
    stacks = _Stacks(sdk_channels, tmp_path_factory.mktemp("stacks"))
    yield stacks.start
    stacks.stop()
