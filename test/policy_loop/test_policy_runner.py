"""The policy loop against fakes of the robot port, the machine and the lowcmd relay: a fault inside the loop (an
exception, a non-finite or out-of-range target, overruns, a stale sample) stops the policy, sends no bad frame and
ends the stream at once; engage is refused on a shadow far from the measured pose."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import pytest

from g1_mode_manager.core.body.motion_allowance import MotionRecord
from g1_mode_manager.core.controller.interface import Command, JointTargets, RobotState
from g1_mode_manager.core.controller.phases import Phase
from g1_mode_manager.core.events import RelayEvents
from g1_mode_manager.core.joint_commands import RANGE_MARGIN_RAD
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import StateSample
from g1_mode_manager.core.records import Outcome
from g1_mode_manager.core.velocity import VelocityLimits
from g1_mode_manager.policy_loop.policy_runner import PolicyLimits, PolicyRunner
from g1_mode_manager.protocol.body_fields import BodyFields
from g1_mode_manager.protocol.motors import JOINT_NAMES, JOINT_RANGE_RAD, NUM_JOINTS

POSE = np.full(NUM_JOINTS, 0.1)
LIMITS = VelocityLimits(0.8, 0.4, 1.0, 1.5, 1.0, 3.0)
NO_BLEND = PolicyLimits(blend_s=0.0)


class Port:
    def __init__(self) -> None:
        self.age_s = 0.002

    def state_sample(self) -> StateSample:
        fields = BodyFields((1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0,) * NUM_JOINTS, (30,) * NUM_JOINTS,
                            (30,) * NUM_JOINTS, bytes(40), tuple(POSE))
        return StateSample(fields, self.age_s, False)


@dataclass
class Machine:
    requested: list[Mode] = field(default_factory=list)

    def request(self, target: Mode) -> Outcome:
        self.requested.append(target)
        return Outcome(True, target, "ok", 0.1, False)


@dataclass
class Relay:
    frames: list = field(default_factory=list)
    ended: int = 0

    def submit_frame(self, frame) -> None:
        self.frames.append(frame)

    def end_stream(self) -> None:
        self.ended += 1


class Controller:
    name, rate_hz, action_scale_rule = "fake", 50.0, "flat 1 (a fake)"

    def __init__(self, q: float | None = 0.1, raises: bool = False) -> None:
        self.q, self.raises = q, raises
        self.speeds: tuple[np.ndarray, np.ndarray] | None = None

    def activate(self, state: RobotState | None) -> None: ...
    def deactivate(self) -> None: ...
    def progress(self) -> None: ...
    def ready(self) -> None: ...
    def reference(self) -> None: ...

    def reference_speeds(self) -> tuple[np.ndarray, np.ndarray] | None:
        return self.speeds

    def step(self, state: RobotState, command: Command) -> JointTargets:
        if self.raises:
            raise RuntimeError("a policy bug")
        z = np.zeros(NUM_JOINTS)
        return JointTargets(np.full(NUM_JOINTS, self.q), z, z, np.full(NUM_JOINTS, 40.0), np.full(NUM_JOINTS, 1.0))


def running(controller: Controller, limits: PolicyLimits = NO_BLEND, clock=time.monotonic, motion=None,
            logged: list | None = None):
    port, machine, relay = Port(), Machine(), Relay()
    log = (lambda level, text: logged.append((level, text))) if logged is not None else (lambda *_: None)
    runner = PolicyRunner(port, machine, relay, RelayEvents(log), loader=lambda _: controller,
                          limits=limits, velocity_limits=LIMITS, cmd_vel_timeout_s=0.5,
                          hold_gains=(300.0, 8.0), motion=motion, clock=clock)
    assert runner.load("fake")[0] and runner.start_shadow()[0]
    runner.tick(0.02)
    ok, why = runner.engage()
    assert ok, why
    runner.tick(0.02)
    assert runner.phase is Phase.RUNNING and len(relay.frames) == 1
    return runner, port, relay


@pytest.mark.parametrize(("make_bad", "why"), [
    (lambda c: setattr(c, "raises", True), "RuntimeError: a policy bug"),
    (lambda c: setattr(c, "q", float("nan")), "non-finite"),
])
def test_a_bad_tick_stops_the_policy_sends_nothing_and_ends_the_stream(make_bad, why):
    controller = Controller()
    runner, _, relay = running(controller)
    make_bad(controller)
    runner.tick(0.02)
    assert runner.phase is Phase.LOADED and why in runner.last_fault
    assert len(relay.frames) == 1 and relay.ended == 1


def test_a_stale_sample_while_sending_is_a_fault_and_in_the_shadow_only_skipped():
    runner, port, relay = running(Controller())
    port.age_s = 0.2
    runner.tick(0.02)
    assert runner.phase is Phase.LOADED and "ms old" in runner.last_fault and relay.ended == 1
    assert runner.start_shadow()[0]
    runner.tick(0.02)
    assert runner.phase is Phase.SHADOW and runner.stats.skipped == 1


def test_overruns_in_a_row_stop_the_policy():
    runner, _, relay = running(Controller(), PolicyLimits(blend_s=0.0, overrun_s=1e-9, max_overruns=3))
    runner.tick(0.02)
    assert runner.phase is Phase.LOADED and "ticks in a row" in runner.last_fault
    # the shadow's tick, the first engaged one and this one overran: the third stops the policy after its frame (a
    # checked one: an overrun is late, not wrong)
    assert len(relay.frames) == 2 and relay.ended == 1 and runner.stats.overruns == 3


def test_engage_is_refused_while_the_shadow_is_far_from_the_measured_pose():
    controller = Controller(q=1.0)
    runner = PolicyRunner(Port(), Machine(), Relay(), RelayEvents(lambda *_: None), loader=lambda _: controller,
                          limits=PolicyLimits(), velocity_limits=LIMITS, cmd_vel_timeout_s=0.5,
                          hold_gains=(300.0, 8.0))
    runner.load("fake")
    runner.start_shadow()
    runner.tick(0.02)
    ok, why = runner.engage()
    assert not ok and "from the measured pose" in why and runner.phase is Phase.SHADOW


def test_a_target_past_its_joints_range_is_clamped_into_range_and_margin_counted_and_logged():
    controller = Controller()
    logged: list = []
    runner, _, relay = running(controller, logged=logged)
    controller.q = 100.0
    runner.tick(0.02)
    assert runner.phase is Phase.RUNNING
    knee = JOINT_NAMES.index("left_knee_joint")
    assert relay.frames[-1][knee].q == pytest.approx(JOINT_RANGE_RAD[knee][1] + RANGE_MARGIN_RAD)
    assert runner.clamp.clamped()["left_knee_joint"] == 1
    assert any(level == "warn" and "left_knee_joint clamped: 100.000 rad" in text for level, text in logged)
    controller.q = 0.1
    runner.tick(0.02)
    assert relay.frames[-1][knee].q == pytest.approx(0.1) and runner.clamp.clamped()["left_knee_joint"] == 1


def test_a_target_held_past_its_range_longer_than_the_bound_stops_the_policy():
    now = [100.0]
    controller = Controller()
    runner, _, relay = running(controller, limits=PolicyLimits(blend_s=0.0, clamp_max_s=0.5), clock=lambda: now[0])
    controller.q = -5.0
    for _ in range(25):  # 0.48 s of clamped ticks at 50 Hz: still a press against the stop
        runner.tick(0.02)
        now[0] += 0.02
    assert runner.phase is Phase.RUNNING, runner.last_fault
    sent = len(relay.frames)
    runner.tick(0.02)  # 0.5 s
    now[0] += 0.02
    runner.tick(0.02)  # 0.52 s: held too long
    assert runner.phase is Phase.LOADED and "past its range + 0.5 rad for 0.52 s" in runner.last_fault
    assert len(relay.frames) == sent + 1 and relay.ended == 1  # the faulting tick sent nothing


def test_a_motions_speeds_are_noted_while_the_policy_steps():
    controller = Controller()
    motion = MotionRecord(10.0, 6.0)
    controller.speeds = (np.full(NUM_JOINTS, 3.0), np.array([0.0, 0.0, 2.0]))
    runner, _, _ = running(controller, motion=motion)
    runner.tick(0.02)
    recent = motion.recent()
    assert recent is not None and recent.body_rates[2] == 2.0 and np.all(recent.joints == 3.0)
