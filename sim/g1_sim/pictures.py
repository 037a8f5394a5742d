"""Headless pictures of the simulated G1: a PNG snapshot, or the scripted tour as an animated GIF.

Rendering is software OpenGL through EGL (Mesa; Debian packages ``libegl1 libegl-mesa0
libgl1-mesa-dri``), about 0.25 s for a 320x240 frame on one core. ``MUJOCO_GL`` is set to ``egl``
before MuJoCo is imported when this module runs first; if MuJoCo was already imported with another
backend (e.g. in a test process), the EGL context is swapped in for our renderer only.

    python -m g1_sim.pictures --snapshot out.png
    python -m g1_sim.pictures --tour out.gif
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import mujoco
import numpy as np
from PIL import Image, ImageDraw

from g1_sim.firmware.robot import SimG1

WIDTH = 640
HEIGHT = 480


def _headless_context() -> None:
    """Make ``mujoco.Renderer`` use EGL if MuJoCo was imported without a headless backend."""
    from mujoco.rendering.classic import gl_context

    if gl_context._MUJOCO_GL in ("egl", "osmesa") or os.environ.get("DISPLAY"):
        return
    from mujoco.egl import GLContext

    gl_context.GLContext = GLContext


class Camera:
    """A renderer with a camera that follows the pelvis from the front-left, slightly above."""

    def __init__(self, sim: SimG1, width: int = WIDTH, height: int = HEIGHT, distance: float = 2.6) -> None:
        _headless_context()
        self.sim = sim
        self.renderer = mujoco.Renderer(sim.model, height, width)
        self.camera = mujoco.MjvCamera()
        self.camera.type = mujoco.mjtCamera.mjCAMERA_TRACKING
        self.camera.trackbodyid = sim.model.body("pelvis").id
        self.camera.distance = distance
        self.camera.azimuth = 140.0
        self.camera.elevation = -15.0

    def frame(self) -> np.ndarray:
        """An RGB image (height, width, 3) of the current state."""
        with self.sim.lock:
            self.renderer.update_scene(self.sim.data, camera=self.camera)
        return self.renderer.render()

    def close(self) -> None:
        self.renderer.close()


def caption(image: np.ndarray, text: str) -> Image.Image:
    """The frame as a Pillow image with a caption in the top-left corner."""
    img = Image.fromarray(image)
    draw = ImageDraw.Draw(img)
    draw.rectangle((0, 0, 8 + 7 * len(text), 18), fill=(0, 0, 0))
    draw.text((4, 3), text, fill=(255, 255, 255))
    return img


def snapshot(sim: SimG1, path: str | Path, width: int = WIDTH, height: int = HEIGHT) -> np.ndarray:
    """Write a PNG of the sim's current state; return the pixels."""
    cam = Camera(sim, width, height)
    try:
        image = cam.frame()
    finally:
        cam.close()
    Image.fromarray(image).save(path)
    return image


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m g1_sim.pictures", description=__doc__.splitlines()[0])
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--snapshot", metavar="PNG", help="picture of the robot standing after 1 s")
    group.add_argument("--tour", metavar="GIF", help="stand, walk, wave via arm_sdk, e-stop (damp)")
    parser.add_argument("--assets", help="simulation assets folder (default: installed)")
    args = parser.parse_args(argv)
    if args.snapshot:
        sim = SimG1(args.assets)
        sim.step(int(1.0 / sim.dt))
        snapshot(sim, args.snapshot)
        print(f"wrote {args.snapshot}")
    else:
        from g1_sim.tour import write_tour_gif

        frames = write_tour_gif(args.tour, assets=args.assets)
        print(f"wrote {args.tour} ({frames} frames)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
