"""``sim_bridge --viewer``: MuJoCo's passive viewer on the running sim, with the head LED drawn above the head.

Only where a display exists (DISPLAY or WAYLAND_DISPLAY); elsewhere the bridge says so and runs headless,
so a launch file with ``viewer:=true`` never breaks a headless machine. The viewer thread copies nothing:
it syncs the live MjData under the robot's lock at ~30 Hz, and follows a reset (a fresh robot) by reopening.
The window opens on the robot alone (MuJoCo's left and right panels hidden: Tab and Shift+Tab show them).
"""

from __future__ import annotations

import logging
import os
import threading
import time
from collections.abc import Callable, Mapping
from typing import Any

log = logging.getLogger("g1_sim.viewer")
FPS = 30.0
#: The LED marker: a small sphere this far above the torso origin, m (the G1's head is ~0.45 m above it).
LED_HEIGHT_M = 0.55
LED_RADIUS_M = 0.03
HEAD_BODY = "torso_link"


def display_available(env: Mapping[str, str] = os.environ) -> bool:
    return bool(env.get("DISPLAY") or env.get("WAYLAND_DISPLAY"))


def led_rgba(rgb: list[int]) -> list[float]:
    """The LED colour as a marker colour; off is shown dark grey, not invisible (you see it is off)."""
    if not any(rgb):
        return [0.15, 0.15, 0.15, 1.0]
    return [c / 255.0 for c in rgb] + [1.0]


class Viewer:
    """Runs the passive viewer in a thread of its own until ``stop()`` or the window is closed."""

    def __init__(self, robot: Any, led: Callable[[], list[int]]) -> None:
        self._robot = robot  # the bridge's RobotSlot: ``current`` changes on reset
        self._led = led
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="viewer", daemon=True)

    def start(self) -> bool:
        """False (and a warning) when there is no display: the bridge runs on without a window."""
        if not display_available():
            log.warning("--viewer: no display (DISPLAY / WAYLAND_DISPLAY unset): running headless")
            return False
        self._thread.start()
        return True

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(15.0)  # a window still opening (llvmpipe: seconds) is closed once it is open

    def _run(self) -> None:
        import mujoco
        import mujoco.viewer

        try:
            while not self._stop.is_set():
                robot = self._robot.current
                # launch_passive runs mj_forward on the data and its render thread copies it while loading:
                # under the robot's lock, or that races the sim's mj_step ("mjData while stack is in use",
                # and the window never opened). The sim waits for the window once (~0.5 s with llvmpipe).
                with robot.lock:
                    # the robot fills the window; MuJoCo's panels come back with Tab / Shift+Tab
                    handle = mujoco.viewer.launch_passive(robot.model, robot.data, show_left_ui=False,
                                                          show_right_ui=False)
                with handle as viewer:
                    head = robot.model.body(HEAD_BODY).id
                    self._frame(viewer, robot.model)
                    while viewer.is_running() and not self._stop.is_set() and self._robot.current is robot:
                        with robot.lock:
                            self._draw_led(viewer, robot.data.xpos[head])
                            viewer.sync()
                        self._stop.wait(1.0 / FPS)
                    if not viewer.is_running():
                        return  # the user closed the window: the sim goes on headless
                _wait_closed(viewer)
        except Exception:
            log.exception("viewer failed; the sim goes on headless")

    @staticmethod
    def _frame(viewer: Any, model: Any) -> None:
        """Follow the pelvis from 3 m, so the whole robot (and the LED above its head) is in view."""
        import mujoco

        with viewer.lock():
            viewer.cam.type = mujoco.mjtCamera.mjCAMERA_TRACKING
            viewer.cam.trackbodyid = model.body("pelvis").id
            viewer.cam.distance, viewer.cam.elevation, viewer.cam.azimuth = 3.0, -15.0, 135.0

    def _draw_led(self, viewer: Any, head_xyz: Any) -> None:
        import mujoco

        scene = viewer.user_scn
        scene.ngeom = 0
        pos = [float(head_xyz[0]), float(head_xyz[1]), float(head_xyz[2]) + LED_HEIGHT_M]
        mujoco.mjv_initGeom(scene.geoms[0], mujoco.mjtGeom.mjGEOM_SPHERE, [LED_RADIUS_M, 0, 0], pos,
                            [1, 0, 0, 0, 1, 0, 0, 0, 1], led_rgba(self._led()))
        scene.ngeom = 1


def _wait_closed(viewer: Any, timeout_s: float = 5.0) -> None:
    """Closing the handle only asks MuJoCo's render thread to end; it draws the robot's MjData until it has,
    and at interpreter exit glfw.terminate under a running render loop is a SIGSEGV (1 exit in 2 before
    this). Join that thread (Python names it after its target, MuJoCo's ``_launch_internal``)."""
    viewer.close()
    deadline = time.monotonic() + timeout_s
    for thread in threading.enumerate():
        if thread is not threading.current_thread() and thread.name.endswith("(_launch_internal)"):
            thread.join(max(0.0, deadline - time.monotonic()))
