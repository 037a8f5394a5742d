"""sim_bridge --viewer: headless machines get a warning and a working sim; the LED marker's colours."""

from __future__ import annotations

import pytest

from g1_sim.bridge.viewer import display_available, led_rgba
from support.sim_bridge import sim_bridge_factory  # noqa: F401  (pytest fixture)


def test_display_detection_and_led_colours() -> None:
    assert not display_available({})
    assert display_available({"DISPLAY": ":0"}) and display_available({"WAYLAND_DISPLAY": "wayland-0"})
    assert led_rgba([255, 0, 0]) == [1.0, 0.0, 0.0, 1.0]
    assert led_rgba([0, 0, 0])[:3] != [0.0, 0.0, 0.0]  # off stays visible as dark grey


@pytest.mark.sim
def test_viewer_without_a_display_warns_and_the_sim_runs(monkeypatch, sdk_channels, sim_bridge_factory) -> None:  # noqa: F811
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    bridge = sim_bridge_factory(extra_args=("--viewer", "--no-ros-publish"))
    assert "no display" in bridge.output() and bridge.alive()
