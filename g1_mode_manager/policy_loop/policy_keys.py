"""The robot's remote drives the policy's lifecycle: a press of one combination engages the loaded policy, a press of
another disengages it, as unitree_rl_lab's G1 deploy starts its velocity policy on R1+X and stands the robot on
L2+Up (docs/policies.md). In user control nothing on the robot listens to the remote but the node.

A press is an edge: the combination held on a fresh remote frame after a frame on which it was not. A combination
held on does not press again, nor does one held across the policy's load or across a gap in the remote's frames.
The verbs are the runner's own, which decide as they do for their services (engage still needs the shadow's checks):
a key only asks. They wait on the robot for seconds, so they run on a worker thread of their own, one at a time; a
press while one runs is ignored and logged, and ``look`` (the body watch's thread) never waits for one.
"""

from __future__ import annotations

import queue
import threading
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from g1_mode_manager.core.controller.phases import Phase
from g1_mode_manager.core.events import LogFn

Answer = tuple[bool, str]


class PolicyVerbs(Protocol):
    """What the keys ask of the policy runner (policy_loop/policy_runner.py)."""

    phase: Phase
    on_phase_change: Callable[[], None]

    def engage(self) -> Answer: ...
    def disengage(self) -> Answer: ...


@dataclass(frozen=True)
class KeyCombo:
    """A combination as configured ('R1+X') and its mask in the remote's key field (0: off)."""

    text: str
    mask: int


@dataclass(frozen=True)
class _Binding:
    verb: str
    combo: KeyCombo
    run: Callable[[], Answer]


class PolicyKeys:
    def __init__(self, runner: PolicyVerbs, keys: Callable[[], int | None], log: LogFn, *, engage: KeyCombo,
                 disengage: KeyCombo, estop: KeyCombo) -> None:
        """``keys``: the remote's key field as of a fresh frame, or None (BodyWatch.fresh_keys)."""
        self._runner = runner
        self._keys = keys
        self._log = log
        self._estop = estop
        self._bindings = tuple(_Binding(verb, combo, run) for verb, combo, run in
                               (("engage", engage, runner.engage), ("disengage", disengage, runner.disengage))
                               if combo.mask)
        self._before: int | None = None  # the key field of the last fresh frame while a policy was loaded
        self._lock = threading.Lock()  # the running verb and the worker
        self._running: str | None = None
        self._stopped = False
        self._jobs: queue.SimpleQueue[_Binding | None] = queue.SimpleQueue()
        self._worker: threading.Thread | None = None  # started by the first press

    def look(self) -> None:
        """One look at the remote: a press starts its verb on the worker; never waits."""
        if self._runner.phase is Phase.UNLOADED:
            self._before = None
            return
        keys = self._keys()
        if keys is None:  # no fresh frame: what is held now is not known, and the last known state stands
            return
        before, self._before = self._before, keys
        if before is None:  # the first frame since the load: a combination held now was pressed before it
            return
        for binding in self._bindings:
            mask = binding.combo.mask
            if keys & mask == mask and before & mask != mask:
                self._press(binding, keys)

    def busy(self) -> bool:
        """A verb a press asked for is under way."""
        with self._lock:
            return self._running is not None

    def stop(self, timeout_s: float = 3.0) -> None:
        """No press is taken from now on; waits a while for a verb under way (the robot is handed back after it)."""
        with self._lock:
            self._stopped = True
            worker = self._worker
        if worker is not None:
            self._jobs.put(None)
            worker.join(timeout_s)

    def _press(self, binding: _Binding, keys: int) -> None:
        verb, text = binding.verb, binding.combo.text
        estop = self._estop.mask
        if estop and keys & estop == estop:
            self._log("warn", f"policy/{verb} by the remote ({text}) ignored: the e-stop keys "
                      f"({self._estop.text}) are held too")
            return
        with self._lock:
            if self._stopped:
                return
            running = self._running
            if running is None:
                self._running = verb
                if self._worker is None:
                    self._worker = threading.Thread(target=self._work, name="policy_keys", daemon=True)
                    self._worker.start()
        if running is not None:
            self._log("warn", f"policy/{verb} by the remote ({text}) ignored: policy/{running} is still under way")
            return
        self._log("info", f"policy/{verb} requested by the remote ({text})")
        self._jobs.put(binding)

    def _work(self) -> None:
        while (binding := self._jobs.get()) is not None:
            try:
                self._answer(binding)
            finally:
                with self._lock:
                    self._running = None

    def _answer(self, binding: _Binding) -> None:
        verb, text = binding.verb, binding.combo.text
        try:
            success, message = binding.run()
        except Exception as exc:  # a verb's bug is logged; the next press is taken
            self._log("error", f"policy/{verb} by the remote ({text}) failed: {type(exc).__name__}: {exc}\n"
                      f"{traceback.format_exc()}")
            return
        finally:
            self._runner.on_phase_change()  # ~/policy/status: a service's answer publishes it, a key's wakes it
        # done at info, refused at warning (NodeLog.relay gives each severity its own rclpy call site)
        if success:
            self._log("info", f"policy/{verb} by the remote ({text}): {message}")
        else:
            self._log("warn", f"policy/{verb} by the remote ({text}): {message}")
