"""cmd_vel sanitising and acceleration limiting."""

import math
from dataclasses import replace

import pytest
from hypothesis import given
from hypothesis import strategies as st

from g1_mode_manager.core.velocity import (
    MAX_MOVE_DURATION_S,
    AccelerationLimiter,
    Velocity,
    VelocityLimits,
    check_move_duration,
    in_dead_band,
    sanitize,
)

LIMITS = VelocityLimits(max_vx=0.8, max_vy=0.4, max_wz=1.0, max_ax=1.0, max_ay=1.0, max_awz=2.0)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize("axis", [0, 1, 2])
def test_non_finite_is_rejected_as_zero(bad: float, axis: int) -> None:
    values = [0.3, 0.1, 0.2]
    values[axis] = bad
    result = sanitize(*values, LIMITS)
    assert result.rejected and result.velocity == Velocity()
    assert "non-finite" in result.reason


def test_each_axis_clamped() -> None:
    result = sanitize(5.0, -3.0, 1e9, LIMITS)
    assert result.clamped and not result.rejected
    assert result.velocity == Velocity(0.8, -0.4, 1.0)


def test_within_limits_passes_unchanged() -> None:
    result = sanitize(0.5, -0.2, 0.3, LIMITS)
    assert result.velocity == Velocity(0.5, -0.2, 0.3) and not result.clamped and not result.rejected


@given(st.floats(allow_nan=True, allow_infinity=True), st.floats(allow_nan=True, allow_infinity=True),
       st.floats(allow_nan=True, allow_infinity=True))
def test_sanitized_output_is_always_finite_and_bounded(vx: float, vy: float, wz: float) -> None:
    v = sanitize(vx, vy, wz, LIMITS).velocity
    assert abs(v.vx) <= LIMITS.max_vx and abs(v.vy) <= LIMITS.max_vy and abs(v.wz) <= LIMITS.max_wz
    assert all(math.isfinite(x) for x in (v.vx, v.vy, v.wz))


def test_acceleration_limiter_ramps_at_the_acceleration_limit() -> None:
    limiter = AccelerationLimiter(LIMITS)
    steps = [limiter.step(Velocity(0.8, 0.0, -1.0), 0.1) for _ in range(10)]
    assert (steps[0].vx, steps[0].vy, steps[0].wz) == pytest.approx((0.1, 0.0, -0.2))
    assert (steps[4].vx, steps[4].wz) == pytest.approx((0.5, -1.0))
    assert steps[-1].vx == pytest.approx(0.8)
    limiter.reset()
    assert limiter.current == Velocity()


@given(st.lists(st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-2, 2)), min_size=1, max_size=50))
def test_acceleration_limiter_never_jumps_more_than_allowed(targets) -> None:
    limiter = AccelerationLimiter(LIMITS)
    dt = 0.05
    prev = limiter.current
    for vx, vy, wz in targets:
        cur = limiter.step(Velocity(vx, vy, wz), dt)
        assert abs(cur.vx - prev.vx) <= LIMITS.max_ax * dt + 1e-12
        assert abs(cur.vy - prev.vy) <= LIMITS.max_ay * dt + 1e-12
        assert abs(cur.wz - prev.wz) <= LIMITS.max_awz * dt + 1e-12
        prev = cur


def test_limits_must_be_positive() -> None:
    with pytest.raises(ValueError, match="max_vx"):
        replace(LIMITS, max_vx=0.0)
    with pytest.raises(ValueError, match="max_awz"):
        replace(LIMITS, max_awz=math.nan)


def test_limiter_dt_is_clamped_and_propose_does_not_advance() -> None:
    limiter = AccelerationLimiter(LIMITS, max_dt_s=0.05)
    assert limiter.propose(Velocity(0.8, 0.0, 0.0), 0.5).vx == pytest.approx(0.05)  # a stall: one nominal step
    assert limiter.current == Velocity()  # nothing committed: a refused Move leaves the ramp where it was
    limiter.commit(Velocity(0.05, 0.0, 0.0))
    assert limiter.propose(Velocity(0.8, 0.0, 0.0), 0.05).vx == pytest.approx(0.10)


def test_dead_band_is_every_axis_below_the_robot_threshold() -> None:
    assert in_dead_band(Velocity(0.09, -0.09, 0.05))
    assert not in_dead_band(Velocity(0.1, 0.0, 0.0)) and not in_dead_band(Velocity(0.0, 0.0, -0.2))


@pytest.mark.parametrize("bad", [0.0, -1.0, 2.01, 864000.0, 1e6, math.nan, math.inf])
def test_move_lease_is_bounded_so_a_dead_node_lets_the_robot_stop(bad: float) -> None:
    with pytest.raises(ValueError, match="stops by itself"):
        check_move_duration(bad)
    assert check_move_duration(MAX_MOVE_DURATION_S) == MAX_MOVE_DURATION_S
