"""Start the sim bridge (``python -m g1_sim.bridge.main``) in a subprocess, and read its status.

The caller must hold /tmp/g1_sim_cpu.lock (run under ``flock``): the bridge steps MuJoCo. The tests'
fixture that starts one per test is ``support.sim_bridge.sim_bridge_factory``.

Pitfall: never let an SDK client, publisher or subscriber be garbage-collected while the process
lives. cyclonedds-python may free an entity's listener before the entity itself; the next bridge's
readers or writers are then discovered, the matched-status callback jumps into freed memory and the
process dies with SIGSEGV. Keep such objects for the whole session (``shared_sim_status()``).
"""

from __future__ import annotations

import functools
import json
import time
from collections.abc import Sequence
from typing import Any

from harness.processes import ManagedProcess, python_module

READY_LINE = "sim_bridge ready"
#: Model compilation, policy load, three RPC servers (0.5 s each), writers: ~5-10 s on a busy machine.
READY_TIMEOUT_S = 60.0
STATUS_SERVICE = "g1_sim"
STATUS_API_VERSION = "1.0.0.0"
STATUS_GET = 9001
STATUS_RESET = 9002


def start_sim_bridge(sdk_domain: int, *, speed: float = 1.0, faults: dict[str, Any] | None = None,
                     extra_args: Sequence[str] = (), timeout_s: float = READY_TIMEOUT_S) -> ManagedProcess:
    """Start the bridge on ``sdk_domain`` (loopback) and wait for its ready line.

    Raises TimeoutError / RuntimeError with the bridge's output if it does not come up.
    """
    argv = python_module("g1_sim.bridge.main", "--domain", str(sdk_domain), "--interface", "lo",
                         "--speed", repr(float(speed)), *extra_args)
    if faults is not None:
        argv += ["--faults", json.dumps(faults)]
    proc = ManagedProcess(argv, name="sim_bridge")
    try:
        proc.wait_for_line(lambda line: line.strip() == READY_LINE, timeout_s)
    except BaseException:
        proc.stop()
        raise
    return proc


#: The SDK client's code for a call that got no reply within its timeout.
RPC_TIMEOUT = 3104
STATUS_TRIES = 3


class SimStatus:
    """Reads the bridge's status service (a sim-only RPC service) with the SDK's plain Client."""

    def __init__(self) -> None:
        from unitree_sdk2py.rpc.client import Client

        self._client = Client(STATUS_SERVICE, False)
        self._client._SetApiVerson(STATUS_API_VERSION)
        self._client._RegistApi(STATUS_GET, 0)
        self._client._RegistApi(STATUS_RESET, 0)
        self._client.SetTimeout(2.0)

    def get(self) -> dict[str, Any]:
        # a read: asked again when it timed out (3104), as a sim stepping a fall on a loaded machine can
        # answer later than the client's 2 s
        for _ in range(STATUS_TRIES):
            code, data = self._client._Call(STATUS_GET, "{}")
            if code != RPC_TIMEOUT:
                break
        if code != 0:
            raise RuntimeError(f"sim status call failed with {code}")
        return json.loads(data)

    def reset(self) -> dict[str, Any]:
        """Back to the boot state (standing, "ai", no faults); returns the status after it."""
        self._client.SetTimeout(10.0)
        try:
            code, data = self._client._Call(STATUS_RESET, "{}")
        finally:
            self._client.SetTimeout(2.0)
        if code != 0:
            raise RuntimeError(f"sim reset failed with {code}")
        return json.loads(data)

    def wait_ready(self, timeout_s: float = 10.0) -> dict[str, Any]:
        """Retry until the status service answers (a fresh client is not matched at once: 3102)."""
        deadline = time.monotonic() + timeout_s
        while True:
            try:
                return self.get()
            except RuntimeError:
                if time.monotonic() > deadline:
                    raise
                time.sleep(0.1)

    def wait_sim_time(self, t: float, timeout_s: float = 60.0) -> dict[str, Any]:
        """Poll until the bridge's sim time reaches ``t``; returns that status."""
        deadline = time.monotonic() + timeout_s
        while True:
            status = self.get()
            if status["sim_time"] >= t:
                return status
            if time.monotonic() > deadline:
                raise TimeoutError(f"sim time {status['sim_time']:.2f} < {t} after {timeout_s} s")
            time.sleep(0.02)


@functools.cache
def shared_sim_status() -> SimStatus:
    """One SimStatus client per process (see the pitfall above); needs the SDK domain initialised."""
    return SimStatus()
