"""The soak's report: each lifetime's figures at its start, after the warm-up and at its end; the noise each
metric showed beside its threshold; and the last line, ``soak: M minutes, V violations, growth: ...``."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

from soak.growth import THRESHOLDS, Growth, Row, group_lifetimes, noise


def _at(rows: Sequence[Row], warmup_s: float) -> tuple[Row, Row, Row]:
    """(first sample, first sample after the warm-up, last sample) of one lifetime."""
    ordered = sorted(rows, key=lambda r: r["age_s"])
    warm = next((r for r in ordered if r["age_s"] >= warmup_s), ordered[-1])
    return ordered[0], warm, ordered[-1]


#: The table's figure columns: (heading, the cell of one sample).
CELLS: list[tuple[str, Callable[[Row], str]]] = [
    ("RSS MB", lambda r: f"{r['rss_kb'] / 1024:.1f}"),
    ("ring MB (most so far)", lambda r: f"{r['ring_kb'] / 1024:.1f} ({r['ring_peak_kb'] / 1024:.1f})"),
    ("private (RssAnon) MB", lambda r: f"{r['rss_anon_kb'] / 1024:.1f}"),
    ("private less the ring's most, MB", lambda r: f"{r['anon_net_kb'] / 1024:.1f}"),
    ("threads", lambda r: str(r["threads"])),
    ("fds", lambda r: str(r["fds"])),
    ("ROS pubs/subs/services/clients", lambda r: f"{r['ros_pubs']}/{r['ros_subs']}/{r['ros_services']}/{r['ros_clients']}"),
    ("SDK writers/readers", lambda r: f"{r['sdk_node_writers']}/{r['sdk_node_readers']}"),
    ("sim's matched readers", lambda r: str(r["sim_matched_readers"])),
    ("SDK participants", lambda r: str(r["sdk_participants"])),
]


def figures_table(rows: Sequence[Row], warmup_s: float, violations: Mapping[int, int]) -> list[str]:
    """A Markdown table, one line per lifetime: each figure at age 0 → after the warm-up → at the last sample."""
    headings = ["lifetime", "samples (last age)", *(h for h, _ in CELLS), "violations"]
    lines = ["| " + " | ".join(headings) + " |", "|" + " --- |" * len(headings)]
    for rows_k in group_lifetimes(rows):
        three = _at(rows_k, warmup_s)
        k = int(rows_k[0]["lifetime"])
        cells = [str(k), f"{len(rows_k)} ({three[2]['age_s']:g} s)"]
        cells += [" → ".join(cell(r) for r in three) for _, cell in CELLS]
        lines.append("| " + " | ".join([*cells, str(violations.get(k, 0))]) + " |")
    return lines


def noise_lines(rows: Sequence[Row], warmup_s: float, thresholds: Mapping[str, float] = THRESHOLDS) -> list[str]:
    """Per metric, the largest late-minus-early this run showed (either view) beside its threshold."""
    out = []
    for metric, limit in thresholds.items():
        seen = noise(rows, metric, warmup_s)
        unit = " kB" if metric.endswith("_kb") else ""
        out.append(f"  {metric:20s} largest |late - early| {seen:g}{unit}, threshold {limit:g}{unit}")
    return out


def last_line(minutes: float, violations: int, growth: Sequence[Growth]) -> str:
    grew = "; ".join(g.text() for g in growth) if growth else "none"
    return f"soak: {minutes:.1f} minutes, {violations} violations, growth: {grew}"
