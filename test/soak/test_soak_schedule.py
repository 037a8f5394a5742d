"""The soak's load plan (soak.schedule): the same from the same seed, lifetimes filling the run's minutes, and
every action where and as long as the plan says."""

from __future__ import annotations

import itertools

import pytest

from soak.schedule import (
    FIRST_SNAPSHOT_S,
    JITTER,
    LINK_LOSS_S,
    MIN_LIFETIME_S,
    RESTART_S,
    SNAPSHOT_GAP_S,
    STREAM_S,
    lifetime,
    plan_soak,
)


def test_the_same_seed_plans_the_same_load() -> None:
    assert plan_soak(7, 30) == plan_soak(7, 30)
    assert plan_soak(7, 30) != plan_soak(8, 30)


@pytest.mark.parametrize(("minutes", "mean_s"), [(30, 300), (3, 60), (10, 120), (1, 300), (0.5, 300)])
def test_the_lifetimes_fill_the_run(minutes: float, mean_s: float) -> None:
    plan = plan_soak(3, minutes, mean_s)
    wall = sum(p.length_s for p in plan) + RESTART_S * len(plan)
    assert wall == pytest.approx(max(minutes * 60, MIN_LIFETIME_S + RESTART_S), abs=0.2)
    assert [p.index for p in plan] == list(range(len(plan)))
    for p in plan[:-1]:  # the last one takes what is left
        assert (1 - JITTER) * mean_s - 0.1 <= p.length_s <= (1 + JITTER) * mean_s + 0.1
    assert all(p.length_s >= min(MIN_LIFETIME_S, (1 - JITTER) * mean_s - 0.1) for p in plan)


def test_a_shorter_run_plans_the_same_first_lifetimes() -> None:
    long, short = plan_soak(11, 60), plan_soak(11, 30)
    assert [p.length_s for p in short[:-1]] == [p.length_s for p in long[: len(short) - 1]]
    assert short[0] == long[0]


def test_a_shorter_lifetime_plays_a_prefix_of_the_same_load() -> None:
    full, cut = lifetime(5, 2, 300.0), lifetime(5, 2, 120.0)
    assert cut.commands == full.commands[: len(cut.commands)]
    assert cut.streams == full.streams[: len(cut.streams)]
    assert cut.snapshots == full.snapshots[: len(cut.snapshots)]


def test_each_lifetime_connects_first_and_acts_within_its_length() -> None:
    for p in plan_soak(21, 30):
        assert p.commands[0].kind == "mode" and p.commands[0].at_s == 0.5
        for actions in (p.commands, p.streams):
            times = [a.at_s for a in actions]
            assert times == sorted(times) and times[0] > 0 and times[-1] < p.length_s - 1.0
        for a, b in zip(p.streams, p.streams[1:], strict=False):  # one stream at a time
            assert a.at_s + a.seconds < b.at_s
        assert p.estop_via in ("service", "topic_reliable", "topic_best_effort")


def test_the_load_mixes_every_kind_within_the_node_s_limits() -> None:
    plan = plan_soak(4, 30)
    commands = [a for p in plan for a in p.commands]
    streams = [a for p in plan for a in p.streams]
    assert {a.kind for a in commands} == {"mode", "loco", "link_loss", "clear"}
    assert {a.kind for a in streams} == {"drive", "arm", "lowcmd"}
    for a in commands:
        if a.kind == "link_loss":
            assert LINK_LOSS_S[0] <= a.seconds <= LINK_LOSS_S[1]
    for a in streams:
        assert STREAM_S[0] <= a.seconds <= STREAM_S[1]
        if a.kind == "drive":
            vx, vy, wz = a.arg
            assert abs(vx) <= 0.8 and abs(vy) <= 0.4 and abs(wz) <= 1.0  # the node's max_vx, max_vy, max_wz
    assert {p.estop_via for p in plan_soak(4, 120)} == {"service", "topic_reliable", "topic_best_effort"}


def test_every_lifetime_asks_for_a_snapshot_now_and_then() -> None:
    for p in [*plan_soak(9, 30), lifetime(9, 0, MIN_LIFETIME_S)]:
        times = [a.at_s for a in p.snapshots]
        assert times and {a.kind for a in p.snapshots} == {"snapshot"}
        assert FIRST_SNAPSHOT_S[0] <= times[0] <= FIRST_SNAPSHOT_S[1] and times[-1] < p.length_s - 1.0
        for a, b in itertools.pairwise(times):
            assert SNAPSHOT_GAP_S[0] - 0.01 <= b - a <= SNAPSHOT_GAP_S[1] + 0.01
    assert len(lifetime(9, 0, 300.0).snapshots) in (1, 2)
