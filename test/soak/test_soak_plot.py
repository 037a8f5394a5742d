"""The soak's SVG (soak.svg_plot) is well-formed and draws one line per lifetime and series."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

from soak.svg_plot import PANELS, write_svg

FIELDS = ("rss_kb", "anon_net_kb", "rss_anon_kb", "threads", "fds", "ros_pubs", "ros_subs", "ros_services", "ros_clients",
          "sdk_node_writers", "sdk_node_readers", "sim_matched_readers")


def test_one_polyline_per_lifetime_and_series(tmp_path: Path) -> None:
    rows = [{"lifetime": k, "age_s": a, "run_s": 320.0 * k + a, **dict.fromkeys(FIELDS, 7 + k)}
            for k in range(3) for a in (0.0, 30.0, 60.0)]
    path = tmp_path / "soak.svg"
    write_svg(rows, str(path), "soak <seed 1>")
    root = ET.parse(path).getroot()
    lines = root.findall("{http://www.w3.org/2000/svg}polyline")
    assert len(lines) == 3 * sum(len(series) for _, series in PANELS)
    assert all(len(line.get("points", "").split()) == 3 for line in lines)


def test_no_samples_still_writes_an_svg(tmp_path: Path) -> None:
    path = tmp_path / "empty.svg"
    write_svg([], str(path), "nothing")
    assert ET.parse(path).getroot().tag == "{http://www.w3.org/2000/svg}svg"
