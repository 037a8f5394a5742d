"""Locks that count their acquisitions, named by the line that created them.

Inside ``counting_locks()`` every ``threading.Lock`` and ``threading.RLock`` created (also the ones inside an
``Event`` or a ``Condition``) is a proxy that counts each successful acquisition under the name of the line
that asked for it, e.g. ``core/machine/state.py: self.lock``. A failed non-blocking try (a Condition probing
whether it owns its lock) is no acquisition and is not counted. Only locks created inside the block count;
the counts go on after it ends.
"""

from __future__ import annotations

import threading
import traceback
from collections import Counter
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

_HERE = Path(__file__).resolve()
_THREADING = Path(threading.__file__).resolve()


class CountingLock:
    def __init__(self, inner: object, name: str, counts: Counter[str]) -> None:
        self._inner = inner
        self.name = name
        self._counts = counts

    def acquire(self, blocking: bool = True, timeout: float = -1) -> bool:
        ok = self._inner.acquire(blocking, timeout)  # type: ignore[attr-defined]
        if ok:
            self._counts[self.name] += 1
        return ok

    def release(self) -> None:
        self._inner.release()  # type: ignore[attr-defined]

    def __enter__(self) -> bool:
        return self.acquire()

    def __exit__(self, *_exc: object) -> None:
        self.release()

    def __getattr__(self, name: str) -> object:  # locked(), and an RLock's hooks a Condition uses while waiting
        return getattr(self._inner, name)


def _site() -> str:
    """``path: target`` of the line that created the lock (the first frame outside threading and this file)."""
    for frame in reversed(traceback.extract_stack()):
        path = Path(frame.filename).resolve()
        if path in (_HERE, _THREADING):
            continue
        parts = path.parts
        root = max((i for i, p in enumerate(parts) if p in ("g1_mode_manager", "test")), default=len(parts) - 1)
        target = (frame.line or "").split("=")[0].strip()
        return f"{'/'.join(parts[root + 1:])}: {target}"
    return "?"


@contextmanager
def counting_locks() -> Iterator[Counter[str]]:
    """Locks created inside the block count their acquisitions in the yielded Counter, by creation site."""
    counts: Counter[str] = Counter()
    real_lock, real_rlock = threading.Lock, threading.RLock
    threading.Lock = lambda: CountingLock(real_lock(), _site(), counts)  # type: ignore[assignment, misc]
    threading.RLock = lambda: CountingLock(real_rlock(), _site(), counts)  # type: ignore[assignment, misc]
    try:
        yield counts
    finally:
        threading.Lock, threading.RLock = real_lock, real_rlock  # type: ignore[misc]
