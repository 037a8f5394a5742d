"""``make run`` (g1_demo) stopped by SIGTERM, as a service manager, ``docker stop`` or ``timeout`` stop it: it stops
the sim, the node and the console it started, exits 0 and prints no traceback, as on Ctrl-C."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from harness.domains import allocate_run_domains
from support.mode_manager import wait_until

pytestmark = [pytest.mark.e2e, pytest.mark.sim]

BIN = Path(sys.executable).parent
RUNNING = "The simulated G1 and the mode manager are running"


def _children(pid: int) -> list[int]:
    """The processes whose parent is ``pid`` (/proc)."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                found.append(int(entry.name))
    return found


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def test_sigterm_stops_everything_the_demo_started_and_exits_cleanly(tmp_path: Path) -> None:
    ros_domain, sdk_domain = allocate_run_domains()  # its own robot: no other test's sim on its domain
    log = (tmp_path / "demo.log").open("w+")
    demo = subprocess.Popen([str(BIN / "g1_demo"), "--no-tour", "--console-port", "0", "--dds-domain", str(sdk_domain)],
                            stdout=log, stderr=subprocess.STDOUT, start_new_session=True,
                            env={**os.environ, "ROS_DOMAIN_ID": str(ros_domain)})
    started: list[int] = []
    try:
        assert wait_until(lambda: RUNNING in Path(log.name).read_text() or demo.poll() is not None, 120.0)
        assert demo.poll() is None, Path(log.name).read_text()[-3000:]
        started = _children(demo.pid)
        assert len(started) == 3, f"the sim, the node and the console: {started}"
        demo.send_signal(signal.SIGTERM)  # to the demo alone, as a service manager's stop does
        code = demo.wait(40.0)
        out = Path(log.name).read_text()
        assert code == 0, out[-3000:]
        assert "Traceback" not in out, out[-3000:]
        assert wait_until(lambda: not any(_alive(p) for p in started), 10.0), \
            f"left running: {[p for p in started if _alive(p)]}"
    finally:
        for pid in [demo.pid, *started]:
            if _alive(pid):
                try:
                    os.killpg(pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
        time.sleep(0.1)
        log.close()
