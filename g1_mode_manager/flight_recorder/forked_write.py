"""One write done by a forked child of the node: whatever the write allocates is gone with the child.

Converting a window of the flight ring into an incident file builds tens of thousands of short-lived objects. In
the node's own process the allocators keep that memory once it is freed (pymalloc frees an arena only when every
object in it is gone, and the node's threads allocate long-lived ring entries into the same arenas meanwhile), so
each larger incident left the node's RSS higher for good: megabytes over a soak's lifetime that no object held.
A child made by ``fork`` sees the ring as it was (copy-on-write), writes, and exits; the node's heap never holds the
conversion, and the conversion holds no GIL the node's threads wait for.

The child runs only the write it is given and ``os._exit``: no log line, no print (a lock another thread held at
the fork would stay held in the child), no atexit handler, nothing of DDS. The parent waits for its answer at
most ``timeout_s`` and kills it after that. Where no child can be made (the system refuses the fork), the write runs
here: an incident is worth more than the memory it leaves behind.
"""

from __future__ import annotations

import os
import select
import signal
import time
from collections.abc import Callable
from typing import Final

#: The longest answer a child sends back (a count, or an error's type and text).
_MAX_ANSWER: Final = 4096


class ChildWriteError(OSError):
    """The child's write raised; the message is its exception's type and text."""


def in_child(write: Callable[[], int], timeout_s: float) -> int:
    """Run ``write`` in a forked child and return what it returned (a count). Raises ChildWriteError with the child's
    exception (or how it ended without one), TimeoutError (the child killed) if no answer came within ``timeout_s``.
    If no child can be made, runs ``write`` in this process."""
    read_fd, write_fd = os.pipe()
    try:
        pid = os.fork()
    except OSError:
        os.close(read_fd)
        os.close(write_fd)
        return write()
    if pid == 0:  # the child: only this thread goes on; it never returns from here
        code = 1
        try:
            os.close(read_fd)
            try:
                answer, code = f"ok {int(write())}", 0
            except BaseException as exc:  # reported to the parent, never raised here
                answer = f"error {type(exc).__name__}: {exc}"
            os.write(write_fd, answer.encode(errors="replace")[:_MAX_ANSWER])
        finally:
            os._exit(code)
    os.close(write_fd)
    try:
        answer = _read_answer(read_fd, time.monotonic() + timeout_s)
    finally:
        os.close(read_fd)
    if answer is None:
        _kill(pid)
        raise TimeoutError(f"the incident write did not end within {timeout_s:g} s (its process was killed)")
    _, status = os.waitpid(pid, 0)
    if answer.startswith("ok "):
        return int(answer[3:])
    if answer.startswith("error "):
        raise ChildWriteError(answer.removeprefix("error "))
    raise ChildWriteError(f"the incident write's process ended without an answer (exit {os.waitstatus_to_exitcode(status)})")


def _read_answer(fd: int, deadline: float) -> str | None:
    """The child's whole answer (it closes its end by exiting), or None at the deadline."""
    chunks: list[bytes] = []
    while True:
        left = deadline - time.monotonic()
        if left <= 0.0:
            return None
        ready, _, _ = select.select([fd], [], [], left)
        if not ready:
            continue
        chunk = os.read(fd, _MAX_ANSWER)
        if not chunk:
            return b"".join(chunks).decode(errors="replace")
        chunks.append(chunk)


def _kill(pid: int) -> None:
    try:
        os.kill(pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    os.waitpid(pid, 0)
