"""The cmd_vel watchdog and the arm_sdk weight ramp, on a fake clock."""

import pytest

from fakes.fake_clock import FakeClock
from g1_mode_manager.core.arm_ramp import ArmWeightRamp, robot_accepts_arm_sdk
from g1_mode_manager.core.watchdog import Watchdog


def test_watchdog_starts_expired_and_expires_after_timeout() -> None:
    clock = FakeClock()
    dog = Watchdog(0.5, clock)
    assert dog.expired() and dog.age_s() is None
    dog.feed()
    clock.advance(0.49)
    assert not dog.expired()
    clock.advance(0.02)
    assert dog.expired()
    dog.feed()
    assert not dog.expired()
    dog.reset()
    assert dog.expired()


def test_watchdog_rejects_bad_timeout() -> None:
    with pytest.raises(ValueError):
        Watchdog(0.0)


def test_ramp_goes_in_and_out_linearly_without_jumps() -> None:
    ramp = ArmWeightRamp(2.0)
    weights = [ramp.step(True, 0.02) for _ in range(120)]
    assert weights[0] == pytest.approx(0.01)
    assert weights[49] == pytest.approx(0.5)
    assert weights[-1] == 1.0
    assert max(b - a for a, b in zip([0.0, *weights], weights, strict=False)) <= 0.01 + 1e-12
    down = [ramp.step(False, 0.02) for _ in range(120)]
    assert down[-1] == 0.0 and not ramp.active()
    assert max(a - b for a, b in zip([1.0, *down], down, strict=False)) <= 0.01 + 1e-12
    assert ramp.step(True, -1.0) == 0.0  # a negative dt never moves it


def test_ramp_rejects_bad_time() -> None:
    with pytest.raises(ValueError):
        ArmWeightRamp(0.0)


def test_ramp_step_is_bounded_by_the_nominal_period_whatever_the_stall() -> None:
    ramp = ArmWeightRamp(2.0, period_s=0.02)
    assert ramp.step(True, 0.5) == pytest.approx(0.01)  # a 0.5 s stall: one nominal step, not 0.25


def test_ramp_propose_changes_nothing_until_committed() -> None:
    ramp = ArmWeightRamp(1.0, period_s=0.02)
    assert ramp.propose(True, 0.02) == pytest.approx(0.02) and ramp.weight == 0.0
    ramp.commit(0.02)
    ramp.restart()
    assert ramp.weight == 0.0


@pytest.mark.parametrize(("fsm_id", "fsm_mode", "accepts"), [
    (4, 0, True), (4, 1, False), (706, 1, False), (702, 0, True), (500, 0, True), (500, 1, True),
    (801, 1, True), (0, 0, False), (1, 0, False), (2, 0, False), (3, 0, False),
])
def test_robot_accepts_arm_sdk_only_standing_or_walking(fsm_id, fsm_mode, accepts) -> None:
    assert robot_accepts_arm_sdk(fsm_id, fsm_mode) is accepts
