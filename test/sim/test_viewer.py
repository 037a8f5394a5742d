"""sim_bridge --viewer: a real window under Xvfb showing the robot and its LED; headless machines get a warning."""

from __future__ import annotations

import numpy as np
import pytest

from g1_sim.bridge.viewer import display_available, led_rgba
from support.mode_manager import wait_until
from support.sim_bridge import sim_bridge_factory  # noqa: F401  (pytest fixture)
from support.xvfb import xvfb


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


@pytest.mark.sim
def test_viewer_window_draws_the_robot_and_its_led_under_xvfb(monkeypatch, sdk_channels, sim_bridge_factory,  # noqa: F811
                                                               tmp_path) -> None:
    """The real window on a virtual display: the robot in the middle of it, the LED's colour above its head."""
    from PIL import ImageGrab

    from g1_mode_manager.sdk.voice_client import VoiceClient

    with xvfb() as display:
        monkeypatch.setenv("DISPLAY", display)
        monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
        bridge = sim_bridge_factory(extra_args=("--viewer", "--no-ros-publish"))
        voice = VoiceClient(1.0)
        assert wait_until(lambda: _try(lambda: voice.set_led(*MAGENTA)), 15.0), "the sim's voice service never answered"

        def shot() -> np.ndarray:
            return np.asarray(ImageGrab.grab(xdisplay=display).convert("RGB")).astype(int)

        if not wait_until(lambda: _led_pixels(shot()).sum() > 0, 30.0, period_s=0.5):
            ImageGrab.grab(xdisplay=display).save(tmp_path / "viewer.png")
            raise AssertionError(f"no LED drawn in the window; screenshot {tmp_path / 'viewer.png'}:\n"
                                 f"{bridge.output()[-2000:]}")
        image = shot()
        ImageGrab.grab(xdisplay=display).save(tmp_path / "viewer.png")
        assert bridge.alive() and "viewer failed" not in bridge.output()
        assert bridge.stop() == 0, bridge.output()[-2000:]  # the window closes with the bridge, before X goes

    window = image.any(axis=2)  # the window on Xvfb's black root
    rows, cols = np.nonzero(window)
    top, bottom, left, right = rows.min(), rows.max(), cols.min(), cols.max()
    assert (bottom - top) > 200 and (right - left) > 200, f"window {right - left}x{bottom - top}"
    body = _robot_pixels(image)
    body_rows, body_cols = np.nonzero(body)
    width = right - left
    centre = (body_cols > left + width / 3) & (body_cols < right - width / 3)
    print(f"window {width}x{bottom - top}: {body.sum()} robot pixels ({centre.mean():.0%} in the middle third), "
          f"{_led_pixels(image).sum()} LED pixels; screenshot {tmp_path / 'viewer.png'}")
    assert body.sum() > 1000, "the robot is not drawn (too few of its grey/white pixels)"
    assert centre.mean() > 0.9, "the camera does not follow the robot (it is not in the middle)"
    led_rows, led_cols = np.nonzero(_led_pixels(image))
    assert led_rows.mean() < np.percentile(body_rows, 10), "the LED is not above the robot's head"
    assert abs(led_cols.mean() - body_cols.mean()) < width / 8


MAGENTA = (255, 0, 255)  # nothing else in the scene has it


def _led_pixels(image: np.ndarray) -> np.ndarray:
    r, g, b = image[..., 0], image[..., 1], image[..., 2]
    return (r > 150) & (b > 150) & (g < 90)


def _robot_pixels(image: np.ndarray) -> np.ndarray:
    """The G1's silver and white shells: bright and grey; the floor and sky of the scene are blue."""
    brightest, darkest = image.max(axis=2), image.min(axis=2)
    return (darkest > 120) & (brightest - darkest < 30)


def _try(call) -> bool:
    try:
        call()
    except Exception:
        return False
    return True
