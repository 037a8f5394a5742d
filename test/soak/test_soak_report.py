"""The soak's report (soak.report): its last line, the contract `make soak` ends with, and the figures table."""

from __future__ import annotations

from soak.growth import Growth
from soak.report import figures_table, last_line

FIGURES = {"rss_kb": 88_000, "ring_kb": 1_500.0, "ring_peak_kb": 2_000.0, "anon_net_kb": 46_000,
           "rss_anon_kb": 48_000, "threads": 38, "fds": 24, "ros_pubs": 11, "ros_subs": 4,
           "ros_services": 14, "ros_clients": 0, "sdk_node_writers": 5, "sdk_node_readers": 11,
           "sim_matched_readers": 5, "sdk_participants": 3}


def test_the_last_line_says_minutes_violations_and_what_grew() -> None:
    assert last_line(30.04, 0, []) == "soak: 30.0 minutes, 0 violations, growth: none"
    grew = [Growth("rss_kb", "in lifetime 2", 2048, 600), Growth("fds", "across lifetimes", 3, 1)]
    assert last_line(31.5, 2, grew) == ("soak: 31.5 minutes, 2 violations, "
                                        "growth: rss_kb +2.0 MB in lifetime 2; fds +3 across lifetimes")


def test_the_table_has_a_line_per_lifetime_with_start_warm_and_end() -> None:
    rows = [{"lifetime": k, "age_s": a, **FIGURES, "threads": 28 if a == 0 else 38}
            for k in (0, 1) for a in (0.0, 30.0, 60.0, 90.0)]
    table = figures_table(rows, 60.0, {1: 2})
    assert len(table) == 4
    assert table[2].startswith("| 0 | 4 (90 s) | 85.9 → 85.9 → 85.9 | 1.5 (2.0) → 1.5 (2.0) → 1.5 (2.0) | "
                               "46.9 → 46.9 → 46.9 | 44.9 → 44.9 → 44.9 | 28 → 38 → 38 |") and table[2].endswith("| 0 |")
    assert table[3].endswith("| 2 |")
