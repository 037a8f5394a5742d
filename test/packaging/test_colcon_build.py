"""The package builds the ordinary ROS way: colcon in a workspace, both packages, ROS layout installed."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
VENV = Path(sys.prefix)


def _tracked_files() -> list[str]:
    out = subprocess.run(["git", "ls-files", "-co", "--exclude-standard"], cwd=REPO, check=True,
                         capture_output=True, text=True)
    return [f for f in out.stdout.splitlines() if (REPO / f).is_file()]


@pytest.mark.ros_build
@pytest.mark.skipif(shutil.which("colcon", path=str(VENV / "bin")) is None, reason="colcon not in the venv")
def test_colcon_builds_both_packages(tmp_path: Path) -> None:
    src = tmp_path / "src" / "g1_mode_manager"
    for rel in _tracked_files():
        (src / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(REPO / rel, src / rel)
    env = {**os.environ, "PATH": f"{VENV / 'bin'}:{os.environ['PATH']}", "AMENT_PREFIX_PATH": str(VENV),
           "CMAKE_PREFIX_PATH": str(VENV)}
    result = subprocess.run(
        [str(VENV / "bin" / "colcon"), "build", "--paths", "src/g1_mode_manager", "src/g1_mode_manager/msg_defs",
         "--cmake-args", "-DBUILD_TESTING=OFF", f"-DPython3_EXECUTABLE={VENV / 'bin' / 'python'}"],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300,
    )
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-3000:]
    assert "2 packages finished" in result.stdout
    install = tmp_path / "install"
    for exe in ("mode_manager", "sim_bridge", "g1ctl", "console"):
        assert (install / "g1_mode_manager" / "lib" / "g1_mode_manager" / exe).exists(), exe
    # the console's page is package data: a build without it would serve nothing
    site = next((install / "g1_mode_manager" / "lib").glob("python3*/site-packages"))
    for page_file in ("index.html", "console.css", "plot.js", "teleop.js", "console.js"):
        assert (site / "g1_mode_manager" / "console" / "static" / page_file).exists(), page_file
    assert (install / "g1_mode_manager" / "share" / "g1_mode_manager" / "config" / "mode_manager.yaml").exists()
    for launch_file in ("sim.launch.py", "robot.launch.py"):
        assert (install / "g1_mode_manager" / "share" / "g1_mode_manager" / "launch" / launch_file).exists(), launch_file
    assert (install / "g1_mode_manager" / "share" / "ament_index" / "resource_index" / "packages" / "g1_mode_manager").exists()
    msgs_py = next((install / "g1_mode_manager_msgs" / "lib").glob("python3*/site-packages"))
    check = subprocess.run(
        [sys.executable, "-c", "import g1_mode_manager_msgs.srv as s, g1_mode_manager_msgs.msg as m; "
         "print(m.__file__, m.Mode.EMERGENCY, m.JointCommand().name)"],
        env={**env, "PYTHONPATH": str(msgs_py),
             "LD_LIBRARY_PATH": f"{install / 'g1_mode_manager_msgs' / 'lib'}:{VENV / 'lib'}"},
        capture_output=True, text=True, timeout=60,
    )
    assert check.returncode == 0, check.stderr
    module_file, emergency, _ = check.stdout.split()
    assert module_file.startswith(str(install)) and emergency == "4"  # the workspace's build, not the venv's
