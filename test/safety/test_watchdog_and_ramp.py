"""The cmd_vel watchdog and the arm_sdk weight ramp, on a fake clock."""

import pytest

from g1_mode_manager.core.arm_ramp import ArmWeightRamp
from g1_mode_manager.core.watchdog import Watchdog


class Clock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def test_watchdog_starts_expired_and_expires_after_timeout() -> None:
    clock = Clock()
    dog = Watchdog(0.5, clock)
    assert dog.expired() and dog.age_s() is None
    dog.feed()
    clock.t += 0.49
    assert not dog.expired()
    clock.t += 0.02
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
