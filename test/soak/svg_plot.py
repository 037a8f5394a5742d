"""A small SVG of the samples (no plotting library in the venv, and none needed for four panels of lines)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from html import escape

from soak.growth import Row, group_lifetimes

#: (title, [(label, value of a row, colour)]) per panel.
Series = tuple[str, Callable[[Row], float], str]
PANELS: list[tuple[str, list[Series]]] = [
    ("node memory, MB", [("VmRSS", lambda r: r["rss_kb"] / 1024, "#1f77b4"),
                         ("RssAnon", lambda r: r["rss_anon_kb"] / 1024, "#6baed6"),
                         ("RssAnon less the ring's most", lambda r: r["anon_net_kb"] / 1024, "#aec7e8")]),
    ("node threads and open fds", [("threads", lambda r: r["threads"], "#d62728"),
                                   ("fds", lambda r: r["fds"], "#ff9896")]),
    ("node ROS endpoints (graph)", [("publishers", lambda r: r["ros_pubs"], "#2ca02c"),
                                    ("subscriptions", lambda r: r["ros_subs"], "#98df8a"),
                                    ("services + clients", lambda r: r["ros_services"] + r["ros_clients"], "#006d2c")]),
    ("node SDK (Cyclone) entities", [("writers", lambda r: r["sdk_node_writers"], "#9467bd"),
                                     ("readers", lambda r: r["sdk_node_readers"], "#c5b0d5"),
                                     ("sim's matched readers", lambda r: r["sim_matched_readers"], "#8c564b")]),
]
W, H = 380, 200  # one panel
PAD_L, PAD_R, PAD_T, PAD_B = 46, 10, 24, 40


def write_svg(rows: Sequence[Row], path: str, title: str) -> None:
    """Two by two panels against the run's minutes, one polyline per node lifetime (a gap at each restart)."""
    parts = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{2 * W}" height="{2 * H + 24}" '
             f'font-family="sans-serif" font-size="10">', '<rect width="100%" height="100%" fill="white"/>',
             f'<text x="{W}" y="15" text-anchor="middle" font-size="12">{escape(title)}</text>']
    if rows:
        for k, (name, series) in enumerate(PANELS):
            parts += _panel(rows, name, series, (k % 2) * W, 24 + (k // 2) * H)
    parts.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(parts) + "\n")


def _panel(rows: Sequence[Row], name: str, series: list[Series], x0: float, y0: float) -> list[str]:
    t_max = max(r["run_s"] for r in rows) / 60 or 1.0
    values = [f(r) for _, f, _ in series for r in rows]
    lo, hi = _range(min(values), max(values))
    pw, ph = W - PAD_L - PAD_R, H - PAD_T - PAD_B

    def xy(r: Row, f: Callable[[Row], float]) -> str:
        return f"{x0 + PAD_L + pw * (r['run_s'] / 60) / t_max:.1f},{y0 + PAD_T + ph * (1 - (f(r) - lo) / (hi - lo)):.1f}"

    out = [f'<text x="{x0 + PAD_L}" y="{y0 + PAD_T - 6}" font-size="11">{escape(name)}</text>',
           f'<rect x="{x0 + PAD_L}" y="{y0 + PAD_T}" width="{pw}" height="{ph}" fill="none" stroke="#999"/>']
    for value in (lo, (lo + hi) / 2, hi):
        y = y0 + PAD_T + ph * (1 - (value - lo) / (hi - lo))
        out.append(f'<text x="{x0 + PAD_L - 4}" y="{y + 3:.1f}" text-anchor="end">{value:.4g}</text>')
    for minute in _ticks(t_max):
        x = x0 + PAD_L + pw * minute / t_max
        out.append(f'<text x="{x:.1f}" y="{y0 + PAD_T + ph + 12}" text-anchor="middle">{minute:g}</text>')
    out.append(f'<text x="{x0 + PAD_L + pw}" y="{y0 + PAD_T + ph + 24}" text-anchor="end">run, min</text>')
    for lifetime in group_lifetimes(rows)[1:]:  # a restart: a dashed line at the new node's first sample
        x = x0 + PAD_L + pw * (lifetime[0]["run_s"] / 60) / t_max
        out.append(f'<line x1="{x:.1f}" y1="{y0 + PAD_T}" x2="{x:.1f}" y2="{y0 + PAD_T + ph}" stroke="#ccc" '
                   'stroke-dasharray="3,3"/>')
    for i, (label, f, colour) in enumerate(series):
        for lifetime in group_lifetimes(rows):
            points = " ".join(xy(r, f) for r in lifetime)
            out.append(f'<polyline points="{points}" fill="none" stroke="{colour}" stroke-width="1.5"/>')
        out.append(f'<text x="{x0 + PAD_L + 4 + 105 * i}" y="{y0 + PAD_T + ph + 36}" fill="{colour}">'
                   f"{escape(label)}</text>")
    return out


def _range(lo: float, hi: float) -> tuple[float, float]:
    """The y range: the data with a margin, never flat (a constant count shows as a line in the middle)."""
    span = hi - lo
    if span < 1e-9:
        return lo - 1, hi + 1
    return lo - 0.1 * span, hi + 0.1 * span


def _ticks(t_max: float) -> list[float]:
    step = next((s for s in (0.5, 1, 2, 5, 10, 15, 30, 60) if t_max / s <= 8), t_max / 8)
    return [k * step for k in range(int(t_max / step) + 1)]
