"""The soak's growth rule (soak.growth): late minus early by medians, within a lifetime after its warm-up and
across lifetimes at the same age."""

from __future__ import annotations

import pytest

from soak.growth import THRESHOLDS, Growth, across_lifetimes, judge_growth, late_minus_early, within_lifetime

AGES = [30.0 * k for k in range(11)]  # 0..300 s


def lifetime(k: int, value, metric: str = "rss_kb") -> list[dict]:
    """Rows of lifetime ``k``: ``value(age)`` for the metric, every other judged metric constant."""
    return [{"lifetime": k, "age_s": a, metric: value(a), "threads": 40} for a in AGES]


def start_up(age: float) -> float:
    """A node that grows while it starts and then stays put."""
    return 80_000.0 if age < 60 else 90_000.0


def test_late_minus_early_takes_medians_of_the_thirds() -> None:
    assert late_minus_early([5, 5, 5, 5, 5, 5]) == 0
    assert late_minus_early([1, 1, 1, 5, 5, 5]) == 4
    assert late_minus_early([0, 0, 0, 0, 100, 0, 0, 0, 0]) == 0  # a spike in the middle
    assert late_minus_early([0, 0, 0, 0, 0, 0, 0, 0, 100]) == 0  # a spike at the end: one of the last three
    assert late_minus_early([3]) == 0 and late_minus_early([]) == 0
    assert late_minus_early([1, 4]) == 3


def test_within_a_lifetime_the_warm_up_is_not_judged() -> None:
    assert within_lifetime(lifetime(0, start_up), "rss_kb", warmup_s=60) == 0
    assert within_lifetime(lifetime(0, start_up), "rss_kb", warmup_s=0) == 10_000


def test_within_a_lifetime_a_steady_leak_shows() -> None:
    leak = within_lifetime(lifetime(0, lambda a: 90_000 + 10 * a), "rss_kb", warmup_s=60)
    assert leak == pytest.approx(10 * (270 - 90))  # medians of the thirds of 60..300 s: 90 s and 270 s


def test_within_a_lifetime_needs_two_samples_after_the_warm_up() -> None:
    assert within_lifetime(lifetime(0, start_up)[:3], "rss_kb", warmup_s=60) is None


def test_across_lifetimes_compares_the_same_ages() -> None:
    same = [lifetime(k, start_up) for k in range(6)]
    assert across_lifetimes(same, "rss_kb") == 0  # each start-up is like the others: no growth
    creeping = [lifetime(k, lambda a, k=k: start_up(a) + 500 * k) for k in range(6)]
    assert across_lifetimes(creeping, "rss_kb") == 500 * 4  # the last two lifetimes' against the first two's


def test_across_lifetimes_uses_only_ages_every_lifetime_has() -> None:
    short = [r for r in lifetime(2, lambda a: 1e9 if a > 120 else start_up(a)) if r["age_s"] <= 120]
    rows = [lifetime(0, start_up), lifetime(1, start_up), short]
    assert across_lifetimes(rows, "rss_kb") == 0  # 1e9 at ages the others do not reach is not compared
    assert across_lifetimes(rows[:1], "rss_kb") is None


def test_judge_names_what_grew_where() -> None:
    rows = [r for k in range(3) for r in lifetime(k, start_up)]
    assert judge_growth(rows, {"rss_kb": 1024, "threads": 0}, warmup_s=60) == []
    rows += lifetime(3, lambda a: start_up(a) + 20 * a)
    grew = judge_growth(rows, {"rss_kb": 1024, "threads": 0}, warmup_s=60)
    # at the same ages the leaking lifetime is above the first one too (by 20 kB/s x 150 s, the median age)
    assert [(g.metric, g.where, g.amount) for g in grew] == [("rss_kb", "in lifetime 3", 3600),
                                                             ("rss_kb", "across lifetimes", 3000)]
    assert grew[0].text() == "rss_kb +3.5 MB in lifetime 3"


def test_a_count_that_outlives_its_node_grows_across_lifetimes() -> None:
    rows = [r for k in range(6) for r in lifetime(k, lambda a, k=k: 5 + k, metric="sim_matched_readers")]
    grew = judge_growth(rows, {"sim_matched_readers": 0}, warmup_s=60)
    assert grew == [Growth("sim_matched_readers", "across lifetimes", 4, 0)]
    assert grew[0].text() == "sim_matched_readers +4 across lifetimes"


def _memory_row(age: float, *, ring_peak: float = 1_500.0, leak_kb_s: float = 0.0, file_kb: float = 40_000.0) -> dict:
    anon = 50_000 + ring_peak + leak_kb_s * age
    return {"lifetime": 0, "age_s": age, "rss_kb": anon + file_kb, "rss_anon_kb": anon, "ring_peak_kb": ring_peak,
            "anon_net_kb": anon - ring_peak}


MEMORY = {"anon_net_kb": THRESHOLDS["anon_net_kb"]}


def test_memory_is_judged_less_the_most_the_ring_has_held() -> None:
    """A busier window late in a lifetime raises the RSS by what the ring then holds: not growth. A leak beside it
    still is."""
    busier = [_memory_row(a, ring_peak=1_500.0 if a < 200 else 2_500.0) for a in AGES]  # a busier window at 200 s
    assert judge_growth(busier, MEMORY, warmup_s=60) == []
    assert within_lifetime(busier, "rss_kb", warmup_s=60) == 1_000  # the raw RSS would have read as growth
    leaking = [_memory_row(a, ring_peak=1_500.0 if a < 200 else 2_500.0, leak_kb_s=5.0) for a in AGES]
    assert [(g.metric, g.where) for g in judge_growth(leaking, MEMORY, warmup_s=60)] == [("anon_net_kb", "in lifetime 0")]


def test_a_library_read_in_is_not_growth_and_a_leak_beside_it_is() -> None:
    """Pages of a mapped file (a library's code, read in the first time it runs) raise VmRSS, not the private
    memory the node holds."""
    paged_in = [_memory_row(a, file_kb=40_000.0 if a < 150 else 41_000.0) for a in AGES]
    assert judge_growth(paged_in, MEMORY, warmup_s=60) == []
    assert within_lifetime(paged_in, "rss_kb", warmup_s=60) == 1_000
    leaking = [_memory_row(a, file_kb=40_000.0 if a < 150 else 41_000.0, leak_kb_s=5.0) for a in AGES]
    assert [(g.metric, g.where) for g in judge_growth(leaking, MEMORY, warmup_s=60)] == [("anon_net_kb", "in lifetime 0")]
