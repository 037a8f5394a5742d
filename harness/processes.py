"""Start the project's processes for a test and make sure every one of them is stopped."""

from __future__ import annotations

import fcntl
import os
import select
import signal
import struct
import subprocess
import sys
import termios
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path

#: The repository's root, on every child's PYTHONPATH: a script the harness starts by path (a scripted robot, a
#: test's helper process) imports harness/ from there however pytest or a benchmark was started.
_ROOT = str(Path(__file__).resolve().parents[1])


def child_env(env: dict[str, str] | None = None) -> dict[str, str]:
    """This process's environment with ``env`` over it and the repository's root first on PYTHONPATH."""
    merged = {**os.environ, **(env or {})}
    merged["PYTHONPATH"] = os.pathsep.join(p for p in (_ROOT, merged.get("PYTHONPATH", "")) if p)
    return merged


class ManagedProcess:
    """A subprocess whose output is collected; stop() ends it (SIGINT, then SIGTERM, then SIGKILL)."""

    def __init__(self, argv: Sequence[str], *, env: dict[str, str] | None = None, name: str = "") -> None:
        self.name = name or Path(argv[0]).name
        self.lines: list[str] = []
        self._lock = threading.Lock()
        self.proc = subprocess.Popen(
            list(argv),
            env=child_env(env),
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            bufsize=0,
            start_new_session=True,
        )
        self._bytes_read = 0
        self._partial = b""
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        """Read the pipe in chunks, each read and its lines taken under the lock (see output)."""
        assert self.proc.stdout is not None
        fd = self.proc.stdout.fileno()
        while True:
            select.select([fd], [], [])
            with self._lock:
                chunk = os.read(fd, 65536)
                self._bytes_read += len(chunk)
                data = self._partial + chunk
                if not chunk:  # end of output
                    if data:
                        self.lines.append(data.decode(errors="replace"))
                    self._partial = b""
                    return
                *complete, self._partial = data.split(b"\n")
                self.lines.extend(line.decode(errors="replace") for line in complete)

    def output(self) -> str:
        """Every line the process had written when this was called.

        A peer that logs a request and then replies can be answered before the reader has taken the log
        line from the pipe, so this waits until the bytes in the pipe at the call are read (at most 2 s).
        """
        assert self.proc.stdout is not None
        with self._lock:  # the reader reads only under the lock: count and pipe are consistent here
            target = self._bytes_read + _unread_bytes(self.proc.stdout.fileno())
        deadline = time.monotonic() + 2.0
        while True:
            with self._lock:
                if self._bytes_read >= target or time.monotonic() > deadline or not self._reader.is_alive():
                    return "\n".join(self.lines)
            time.sleep(0.002)

    def wait_for_line(self, predicate: Callable[[str], bool], timeout_s: float) -> str:
        """Wait until a line of output satisfies predicate; raise TimeoutError (with the output) if not."""
        deadline = time.monotonic() + timeout_s
        seen = 0
        while time.monotonic() < deadline:
            with self._lock:
                new = self.lines[seen:]
                seen = len(self.lines)
            for line in new:
                if predicate(line):
                    return line
            if self.proc.poll() is not None and seen == len(self.lines):
                raise RuntimeError(f"{self.name} exited with {self.proc.returncode}:\n{self.output()}")
            time.sleep(0.05)
        raise TimeoutError(f"{self.name}: no matching line in {timeout_s} s:\n{self.output()}")

    def alive(self) -> bool:
        return self.proc.poll() is None

    def stop(self, timeout_s: float = 10.0) -> int:
        """Stop the process group; returns the exit code."""
        for sig, wait in ((signal.SIGINT, timeout_s), (signal.SIGTERM, 3.0), (signal.SIGKILL, 3.0)):
            if self.proc.poll() is not None:
                break
            try:
                os.killpg(self.proc.pid, sig)
            except ProcessLookupError:
                break
            try:
                self.proc.wait(wait)
            except subprocess.TimeoutExpired:
                continue
        self._reader.join(2.0)
        return self.proc.returncode


def restore_sigint() -> None:
    """Give SIGINT back its default disposition, so that every child started after this stops on stop()'s SIGINT.

    A shell without job control starts a background command with SIGINT ignored (POSIX), exec keeps an ignored
    signal ignored, and a Python child then never sees a KeyboardInterrupt: each stop() of a script that relies on
    one waited its whole timeout for the SIGTERM. Call it from the main thread, before the first child starts.
    """
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


def _unread_bytes(fd: int) -> int:
    try:
        return struct.unpack("i", fcntl.ioctl(fd, termios.FIONREAD, b"\0\0\0\0"))[0]
    except OSError:  # closed: nothing more to read
        return 0


def python_module(module: str, *args: str) -> list[str]:
    """argv that runs a module with the interpreter of this test run."""
    return [sys.executable, "-u", "-m", module, *args]
