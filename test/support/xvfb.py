"""A virtual X display (Debian's Xvfb) for a test: the display number is Xvfb's own pick of a free one."""

from __future__ import annotations

import os
import shutil
import subprocess
import time
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def xvfb(size: str = "960x720x24", timeout_s: float = 10.0) -> Iterator[str]:
    """Start Xvfb (no TCP listener) and yield its DISPLAY (":N"); it is stopped afterwards."""
    binary = shutil.which("Xvfb")
    if binary is None:
        raise RuntimeError("Xvfb is missing: `make setup` installs it (scripts/check_system.sh, Debian xvfb)")
    read_fd, write_fd = os.pipe()
    proc = subprocess.Popen([binary, "-displayfd", str(write_fd), "-screen", "0", size, "-nolisten", "tcp"],
                            pass_fds=(write_fd,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    os.close(write_fd)
    try:
        number = _read_display_number(read_fd, timeout_s)
        yield f":{number}"
    finally:
        os.close(read_fd)
        proc.terminate()
        try:
            proc.wait(5.0)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5.0)


def _read_display_number(fd: int, timeout_s: float) -> int:
    """Xvfb writes the display number and a newline to ``-displayfd`` once it accepts connections."""
    os.set_blocking(fd, False)
    deadline, text = time.monotonic() + timeout_s, b""
    while time.monotonic() < deadline:
        try:
            chunk = os.read(fd, 16)
        except BlockingIOError:
            chunk = None
        if chunk == b"":
            break  # Xvfb exited
        if chunk:
            text += chunk
            if text.endswith(b"\n"):
                return int(text)
        time.sleep(0.05)
    raise RuntimeError(f"Xvfb did not report a display within {timeout_s} s")
