"""The scripted tour of the simulated G1: stand, walk, wave an arm through arm_sdk, e-stop (damp, sink).

Drives :class:`SimG1` through its public API only, as a client of the real robot would, and films it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Final

import numpy as np
from PIL import Image

from g1_mode_manager.protocol.fsm import FsmId
from g1_mode_manager.protocol.motors import ARM_SDK_JOINTS
from g1_sim.firmware.robot import SimG1
from g1_sim.physics.model import DEFAULT_POSE
from g1_sim.pictures import Camera, caption

#: arm_sdk gains for motors 12..28: waist stiff (it carries the torso), arms moderate, wrists soft.
ARM_SDK_KP: Final = np.array([150.0, 150.0, 150.0] + ([40.0] * 4 + [10.0] * 3) * 2)
ARM_SDK_KD: Final = np.array([4.0, 4.0, 4.0] + ([1.5] * 4 + [0.5] * 3) * 2)
ARM_SDK_HOME: Final = DEFAULT_POSE[list(ARM_SDK_JOINTS)]
#: Index of a motor within the 17 arm_sdk slots.
R_SHOULDER_PITCH: Final = 22 - ARM_SDK_JOINTS[0]
R_SHOULDER_ROLL: Final = 23 - ARM_SDK_JOINTS[0]
R_ELBOW: Final = 25 - ARM_SDK_JOINTS[0]

FRAME_PERIOD_S: Final = 0.25
GIF_SIZE: Final = (288, 216)
GIF_COLORS: Final = 64


def send_arm_sdk(sim: SimG1, targets: np.ndarray, weight: float) -> None:
    """One arm_sdk frame with the tour's gains and zero feed-forward."""
    zeros = np.zeros(len(ARM_SDK_JOINTS))
    sim.apply_arm_sdk(targets, zeros, zeros, ARM_SDK_KP, ARM_SDK_KD, weight)


def wave_targets(t: float) -> np.ndarray:
    """Right arm up and out, elbow swinging at 1 Hz."""
    q = ARM_SDK_HOME.copy()
    q[R_SHOULDER_PITCH] = -0.6
    q[R_SHOULDER_ROLL] = -1.3
    q[R_ELBOW] = 0.4 + 0.5 * math.sin(2 * math.pi * t)
    return q


def run_tour(sim: SimG1, on_frame: Callable[[str], None], frame_period_s: float = FRAME_PERIOD_S) -> None:
    """Play the tour on ``sim`` (booted standing), calling ``on_frame(caption)`` every frame period."""
    steps_per_frame = round(frame_period_s / sim.dt)
    arm_steps = round(0.02 / sim.dt)  # arm_sdk is streamed at 50 Hz

    def play(seconds: float, label: str, arm: Callable[[float], tuple[np.ndarray, float]] | None = None) -> None:
        t0 = sim.time
        for i in range(round(seconds / sim.dt)):
            if arm is not None and i % arm_steps == 0:
                send_arm_sdk(sim, *arm(sim.time - t0))
            if i % steps_per_frame == 0:
                on_frame(label)
            sim.step()

    play(1.0, "lock stand (fsm 4)")
    sim.set_fsm_id(FsmId.START)
    sim.set_velocity(0.5, 0.0, 0.0, 2.5)
    play(3.0, "walk: SetVelocity(0.5, 0, 0)")
    sim.set_velocity(0.0, 0.0, 0.6, 2.0)
    play(2.5, "turn: SetVelocity(0, 0, 0.6)")
    play(1.0, "arm_sdk weight 0 -> 1", lambda t: (wave_targets(t), min(t / 1.0, 1.0)))
    play(2.0, "arm_sdk: wave", lambda t: (wave_targets(t + 1.0), 1.0))
    play(1.5, "arm_sdk weight 1 -> 0", lambda t: (wave_targets(t + 3.0), max(1.0 - t / 1.5, 0.0)))
    sim.set_fsm_id(FsmId.DAMP)
    play(3.0, "e-stop: Damp (fsm 1), robot sinks")


def write_tour_gif(path: str | Path, *, assets: str | Path | None = None, size: tuple[int, int] = GIF_SIZE) -> int:
    """Film the tour into an animated GIF; return the number of frames."""
    sim = SimG1(assets)
    cam = Camera(sim, *size)
    frames: list[Image.Image] = []
    try:
        run_tour(sim, lambda label: frames.append(caption(cam.frame(), label).quantize(colors=GIF_COLORS)))
    finally:
        cam.close()
    frames[0].save(path, save_all=True, append_images=frames[1:], duration=int(FRAME_PERIOD_S * 1000), loop=0,
                   optimize=True)
    return len(frames)
