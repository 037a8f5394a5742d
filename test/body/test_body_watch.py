"""The body watch against the fake port and the real mode machine: a fall faults, a held remote
combination e-stops once per press, the dead-man follows its key, an idle HIGH_LEVEL runs slow, and the
posture is read from each sample with the controller's state."""

from __future__ import annotations

from fakes.fake_robot_port import FakeRobotPort
from fakes.lowstate_bytes import lowstate_bytes
from fakes.machine_rig import Rig
from fakes.posture_poses import POSES
from g1_mode_manager.core.body.monitor import BodyMonitor
from g1_mode_manager.core.events import RelayEvents
from g1_mode_manager.core.machine import ModeMachine
from g1_mode_manager.core.modes import Mode
from g1_mode_manager.core.port import SportState
from g1_mode_manager.core.posture import NO_READING, Posture
from g1_mode_manager.protocol.remote import key_mask
from g1_mode_manager.relay.body_watch import BodyWatch
from support.mode_manager import wait_until

L2_B = key_mask(("L2", "B"))
R2 = key_mask(("R2",))


state = lowstate_bytes


class Clock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def _watch(mode: Mode, **kw) -> tuple[BodyWatch, ModeMachine, FakeRobotPort, Clock, list[tuple[str, str]]]:
    port = FakeRobotPort()
    machine = ModeMachine(port)
    Rig(port, machine, None).bring_to(mode)
    logs: list[tuple[str, str]] = []
    clock = Clock()
    watch = BodyWatch(port, machine, BodyMonitor(clear_hold_s=1.0), RelayEvents(lambda lv, t: logs.append((lv, t)),
                      throttle_s=0.0), estop_keys=kw.pop("estop_keys", L2_B), deadman_keys=kw.pop("deadman_keys", 0),
                      fast_period_s=0.01, slow_period_s=0.05, clock=clock, **kw)
    port.state = state()
    return watch, machine, port, clock, logs


def _steps(watch: BodyWatch, clock: Clock, n: int, dt: float = 0.01) -> None:
    for _ in range(n):
        clock.t += dt
        watch.step()


def test_a_fall_in_high_level_enters_fault_with_the_reason() -> None:
    watch, machine, port, clock, logs = _watch(Mode.HIGH_LEVEL)
    port.sport = SportState(fsm_id=500, fsm_mode=1, task_id=0, task_time=0.0, age_s=0.01)  # walking
    _steps(watch, clock, 3)
    assert machine.mode is Mode.HIGH_LEVEL
    port.state = state(tilt=1.3)
    _steps(watch, clock, 3)
    assert machine.mode is Mode.FAULT
    assert machine.status().faults[0].startswith("tilt: 1.30 rad > 1")
    assert any("protective stop" in text for _, text in logs)


def test_a_robot_lying_damped_in_high_level_is_not_fallen() -> None:
    watch, machine, port, clock, _ = _watch(Mode.HIGH_LEVEL)
    port.sport = SportState(fsm_id=1, fsm_mode=0, task_id=0, task_time=0.0, age_s=0.01)  # damped
    port.state = state(tilt=1.5)
    _steps(watch, clock, 5)
    assert machine.mode is Mode.HIGH_LEVEL


def test_overheat_in_high_level_holds_motion() -> None:
    watch, machine, port, clock, _ = _watch(Mode.HIGH_LEVEL)
    port.state = state(winding=125)
    _steps(watch, clock, 5)
    assert machine.mode is Mode.HIGH_LEVEL and machine.holding_motion() and not machine.allows_cmd_vel()


def test_checks_off_still_leaves_the_remote_estop() -> None:
    watch, machine, port, clock, _ = _watch(Mode.HIGH_LEVEL, enabled=False)
    port.state = state(winding=140, tilt=1.4)
    _steps(watch, clock, 5)
    assert machine.mode is Mode.HIGH_LEVEL
    port.state = state(keys=("L2", "B"))
    _steps(watch, clock, 1)
    assert machine.mode is Mode.EMERGENCY


def test_the_remote_combination_estops_once_per_press() -> None:
    watch, machine, port, clock, logs = _watch(Mode.LOW_LEVEL)
    port.state = state(keys=("L2",))
    _steps(watch, clock, 3)
    assert machine.mode is Mode.LOW_LEVEL
    port.state = state(keys=("L2", "B", "up"))
    calls = len(port.calls)
    _steps(watch, clock, 5)
    assert machine.mode is Mode.EMERGENCY
    assert wait_until(lambda: machine.status().damp_confirmed, 5.0), "the e-stop's sequence did not finish"
    names = [c.name for c in port.calls[calls:]]
    # one e-stop from LOW_LEVEL: one sequence (one SelectMode), its first shot and its Damp at SelectMode's answer
    assert names.count("select_mode") == 1 and names.count("damp_no_reply") == 2, names
    assert sum("E-STOP from the robot's remote" in text for _, text in logs) == 1


def test_a_stale_remote_frame_presses_nothing() -> None:
    watch, machine, port, clock, _ = _watch(Mode.LOW_LEVEL)
    port.state, port.state_age = state(keys=("L2", "B")), 0.5
    _steps(watch, clock, 3)
    assert machine.mode is Mode.LOW_LEVEL


def test_the_deadman_follows_its_key() -> None:
    watch, _machine, port, clock, _ = _watch(Mode.LOW_LEVEL, deadman_keys=R2)
    _steps(watch, clock, 1)
    assert not watch.deadman_held()
    port.state = state(keys=("R2",))
    _steps(watch, clock, 1)
    assert watch.deadman_held()
    clock.t += 0.5  # no fresh frame since: the key counts as released
    assert not watch.deadman_held()


def test_no_deadman_set_always_passes() -> None:
    watch, *_ = _watch(Mode.LOW_LEVEL)
    assert watch.deadman_held()


def test_the_watch_runs_fast_on_rt_lowstate_and_slow_without_it() -> None:
    watch, _machine, port, _clock, _ = _watch(Mode.HIGH_LEVEL)
    port.lowstate_wanted = True
    assert watch.period_s() == 0.01
    port.lowstate_wanted = False
    assert watch.period_s() == 0.05


def test_the_remotes_keys_are_known_only_from_a_fresh_frame() -> None:
    watch, _machine, port, clock, _ = _watch(Mode.LOW_LEVEL)
    assert watch.fresh_keys() is None  # no frame yet
    port.state = state(keys=("R1", "X"))
    _steps(watch, clock, 1)
    assert watch.fresh_keys() == key_mask(("R1", "X"))
    clock.t += 0.5
    assert watch.fresh_keys() is None and not watch.keys_held(key_mask(("R1",)))


def _fsm(port: FakeRobotPort, fsm_id: int) -> None:
    port.sport = SportState(fsm_id=fsm_id, fsm_mode=0, task_id=0, task_time=0.0, age_s=0.01)


def test_the_posture_is_read_from_each_sample_with_the_controllers_state() -> None:
    watch, _machine, port, clock, _ = _watch(Mode.HIGH_LEVEL)
    assert watch.posture == NO_READING  # before the first step
    for q, fsm, posture in ((POSES["standing"].q, 4, Posture.STANDING),
                            (POSES["squatting_damped"].q, 1, Posture.SQUATTING),  # limp, and folded: it squats
                            (POSES["standing"].q, 1, Posture.UNKNOWN),  # limp on bent legs: falling, or held up
                            ((0.0,) * 29, 0, Posture.HANGING),  # limp on straight legs, upright: held from above
                            ((0.0,) * 29, 4, Posture.UNKNOWN)):
        port.state = state(q=q)
        _fsm(port, fsm)
        _steps(watch, clock, 1)
        assert watch.posture.posture is posture, (fsm, watch.posture)
    port.state = state(tilt=1.8, q=POSES["lying_back"].q)
    _fsm(port, 1)
    _steps(watch, clock, 1)
    assert watch.posture.posture is Posture.LYING_FRONT, watch.posture  # this sample pitches forward
    assert watch.posture.tilt_rad is not None and abs(watch.posture.tilt_rad - 1.8) < 1e-6, watch.posture


def test_no_sample_or_a_stale_one_reads_no_posture() -> None:
    watch, _machine, port, clock, _ = _watch(Mode.HIGH_LEVEL)
    port.state = state(q=POSES["standing"].q)
    _steps(watch, clock, 1)
    assert watch.posture.posture is Posture.STANDING
    port.state_age = 0.6
    _steps(watch, clock, 1)
    assert watch.posture == NO_READING
    port.state = None
    _steps(watch, clock, 1)
    assert watch.posture == NO_READING
