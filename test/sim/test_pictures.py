"""Headless rendering works here: a snapshot PNG is written and shows something (not a blank frame)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

pytestmark = pytest.mark.sim


def test_snapshot_png_is_not_blank(tmp_path: Path) -> None:
    from g1_sim.firmware import SimG1
    from g1_sim.pictures import snapshot

    sim = SimG1()
    sim.step(50)
    out = tmp_path / "g1.png"
    pixels = snapshot(sim, out, width=320, height=240)
    assert out.stat().st_size > 1000
    saved = np.asarray(Image.open(out).convert("RGB"), dtype=float)
    assert saved.shape == (240, 320, 3)
    assert np.array_equal(saved, pixels)
    assert saved.std() > 10.0  # sky, floor and robot, not one colour
