"""The policy's remote keys against a fake remote on a fake clock and a fake runner: a verb per press (a combination
held on does not repeat, nor does one held across the load or across stale frames), on one worker thread, one at a
time (a press meanwhile is ignored and logged), each press and its answer logged at a severity of their own."""

from __future__ import annotations

import threading

import pytest
import rclpy.logging

from fakes.fake_clock import FakeClock
from g1_mode_manager.core.controller.phases import Phase
from g1_mode_manager.node.node_log import NodeLog
from g1_mode_manager.policy_loop.policy_keys import KeyCombo, PolicyKeys
from g1_mode_manager.protocol.remote import key_mask
from g1_mode_manager.relay.body_watch import REMOTE_FRESH_S
from support.mode_manager import wait_until

ENGAGE = KeyCombo("R1+X", key_mask(("R1", "X")))
DISENGAGE = KeyCombo("L2+Up", key_mask(("L2", "up")))
ESTOP = KeyCombo("L2+B", key_mask(("L2", "B")))


class Remote:
    """The key field of the newest remote frame, fresh for REMOTE_FRESH_S on the fake clock (as the body watch)."""

    def __init__(self, clock: FakeClock) -> None:
        self._clock = clock
        self._keys, self._at = 0, clock()
        self.asked = 0

    def hold(self, *names: str) -> None:
        self._keys, self._at = key_mask(names), self._clock()

    def __call__(self) -> int | None:
        self.asked += 1
        return self._keys if self._clock() - self._at <= REMOTE_FRESH_S else None


class Runner:
    """The runner's verbs, answered as told; ``gate`` (when set) holds a verb until it is set, as the robot would."""

    def __init__(self, phase: Phase = Phase.SHADOW) -> None:
        self.phase = phase
        self.calls: list[tuple[str, str]] = []  # (verb, thread name)
        self.answer: tuple[bool, str] = (True, "done")
        self.raises = False
        self.gate: threading.Event | None = None
        self.woken = 0
        self.on_phase_change = self._woken

    def _woken(self) -> None:
        self.woken += 1

    def _verb(self, name: str) -> tuple[bool, str]:
        self.calls.append((name, threading.current_thread().name))
        if self.gate is not None:
            assert self.gate.wait(5.0)
        if self.raises:
            raise RuntimeError("a bug in the verb")
        return self.answer

    def engage(self) -> tuple[bool, str]:
        return self._verb("engage")

    def disengage(self) -> tuple[bool, str]:
        return self._verb("disengage")


@pytest.fixture
def rig(clock: FakeClock, logs: list[tuple[str, str]]):
    runner, remote = Runner(), Remote(clock)
    keys = PolicyKeys(runner, remote, lambda level, text: logs.append((level, text)), engage=ENGAGE,
                      disengage=DISENGAGE, estop=ESTOP)
    yield keys, runner, remote, clock
    keys.stop()


def look(keys: PolicyKeys, clock: FakeClock, *held: str, remote: Remote | None = None, n: int = 1) -> None:
    """``n`` looks 10 ms apart, ``held`` on a fresh frame before each (when ``remote`` is given)."""
    for _ in range(n):
        clock.advance(0.01)
        if remote is not None:
            remote.hold(*held)
        keys.look()


def answered(runner: Runner, logs: list, n: int) -> bool:
    return wait_until(lambda: len(runner.calls) == n and sum(" by the remote (" in t and "): " in t
                                                             for _, t in logs) >= n, 5.0)


def test_a_press_engages_once_however_long_it_is_held(rig, logs) -> None:
    keys, runner, remote, clock = rig
    look(keys, clock, remote=remote, n=3)  # nothing held
    look(keys, clock, "R1", "X", remote=remote, n=20)  # pressed, then held for 0.2 s
    assert answered(runner, logs, 1)
    assert [c[0] for c in runner.calls] == ["engage"]
    assert ("info", "policy/engage requested by the remote (R1+X)") in logs
    assert ("info", "policy/engage by the remote (R1+X): done") in logs
    look(keys, clock, remote=remote, n=2)  # released
    look(keys, clock, "X", "R1", "A", remote=remote)  # pressed again (another key held as well)
    assert answered(runner, logs, 2)


def test_one_key_held_then_the_other_pressed_is_a_press(rig, logs) -> None:
    keys, runner, remote, clock = rig
    look(keys, clock, "L2", remote=remote, n=5)
    look(keys, clock, "L2", "up", remote=remote, n=5)
    assert answered(runner, logs, 1)
    assert runner.calls[0][0] == "disengage"


def test_a_combination_held_across_the_load_presses_nothing(rig, logs) -> None:
    keys, runner, remote, clock = rig
    runner.phase = Phase.UNLOADED
    look(keys, clock, "R1", "X", remote=remote, n=5)
    assert remote.asked == 0  # no policy loaded: the remote is not even read
    runner.phase = Phase.LOADED
    look(keys, clock, "R1", "X", remote=remote, n=5)
    look(keys, clock, remote=remote)
    assert runner.calls == [] and logs == []
    look(keys, clock, "R1", "X", remote=remote)  # released, pressed: now it is a press
    assert answered(runner, logs, 1)


def test_a_combination_held_across_stale_frames_does_not_press_again(rig, logs) -> None:
    keys, runner, remote, clock = rig
    look(keys, clock, remote=remote)
    look(keys, clock, "R1", "X", remote=remote)
    assert answered(runner, logs, 1)
    look(keys, clock, n=40)  # no fresh frame for 0.4 s: the keys are not known
    look(keys, clock, "R1", "X", remote=remote, n=3)  # fresh again, still held
    assert len(runner.calls) == 1


def test_a_press_while_a_verb_runs_is_ignored_and_logged(rig, logs) -> None:
    keys, runner, remote, clock = rig
    runner.gate = threading.Event()
    look(keys, clock, remote=remote)
    look(keys, clock, "R1", "X", remote=remote)  # engage starts and waits on "the robot"
    assert wait_until(lambda: len(runner.calls) == 1, 5.0)
    look(keys, clock, remote=remote)
    look(keys, clock, "L2", "up", remote=remote)  # look returns at once: it never waits for the verb
    assert ("warn", "policy/disengage by the remote (L2+Up) ignored: policy/engage is still under way") in logs
    runner.gate.set()
    assert answered(runner, logs, 1)
    assert wait_until(lambda: runner.woken == 1, 5.0)  # ~/policy/status is woken after the verb
    look(keys, clock, remote=remote)
    look(keys, clock, "L2", "up", remote=remote)  # the verb is over: a press is taken again
    assert answered(runner, logs, 2)
    assert [c[0] for c in runner.calls] == ["engage", "disengage"]


def test_the_verbs_run_on_one_worker_thread_never_on_the_lookers(rig, logs) -> None:
    keys, runner, remote, clock = rig
    for combo in (("R1", "X"), ("L2", "up"), ("R1", "X")):
        look(keys, clock, remote=remote)
        look(keys, clock, *combo, remote=remote)
        assert wait_until(lambda: not keys.busy(), 5.0)
    assert answered(runner, logs, 3)
    threads = {name for _, name in runner.calls}
    assert threads == {"policy_keys"} and threading.current_thread().name not in threads


def test_a_refusal_is_logged_as_a_warning_and_a_verbs_bug_as_an_error(rig, logs) -> None:
    keys, runner, remote, clock = rig
    runner.answer = (False, "shadow the policy first: engaging needs its targets seen against the live robot")
    look(keys, clock, remote=remote)
    look(keys, clock, "R1", "X", remote=remote)
    assert answered(runner, logs, 1)
    assert ("warn", f"policy/engage by the remote (R1+X): {runner.answer[1]}") in logs
    runner.raises = True
    look(keys, clock, remote=remote)
    look(keys, clock, "R1", "X", remote=remote)
    assert wait_until(lambda: any(lv == "error" and "RuntimeError: a bug in the verb" in t for lv, t in logs), 5.0)
    runner.raises = False
    look(keys, clock, remote=remote)
    look(keys, clock, "R1", "X", remote=remote)  # the worker lives on
    assert wait_until(lambda: len(runner.calls) == 3, 5.0)


def test_a_press_with_the_estop_keys_held_is_ignored(rig, logs) -> None:
    keys, runner, remote, clock = rig
    look(keys, clock, remote=remote)
    look(keys, clock, "L2", "B", "up", remote=remote)
    assert runner.calls == []
    assert ("warn", "policy/disengage by the remote (L2+Up) ignored: the e-stop keys (L2+B) are held too") in logs


def test_a_combination_set_off_is_never_pressed(clock, logs) -> None:
    runner, remote = Runner(), Remote(clock)
    keys = PolicyKeys(runner, remote, lambda level, text: logs.append((level, text)), engage=KeyCombo("", 0),
                      disengage=DISENGAGE, estop=ESTOP)
    look(keys, clock, remote=remote)
    look(keys, clock, *("R1", "X"), remote=remote)
    assert runner.calls == [] and logs == []


def test_no_press_is_taken_once_stopped(rig, logs) -> None:
    keys, runner, remote, clock = rig
    keys.stop()
    look(keys, clock, remote=remote)
    look(keys, clock, "R1", "X", remote=remote)
    assert runner.calls == [] and logs == []


def test_answers_of_both_severities_go_through_the_nodes_logger() -> None:
    """rclpy raises when one call site logs at a second severity; every press and answer passes NodeLog's."""
    clock, runner = FakeClock(), Runner()
    remote = Remote(clock)
    keys = PolicyKeys(runner, remote, NodeLog(rclpy.logging.get_logger("policy_keys_test")).relay, engage=ENGAGE,
                      disengage=DISENGAGE, estop=ESTOP)
    errors: list[BaseException] = []
    threading.excepthook = lambda args: errors.append(args.exc_value)  # type: ignore[assignment]
    try:
        for answer in ((True, "engaged"), (False, "refused"), (True, "engaged again")):
            runner.answer = answer
            look(keys, clock, remote=remote)
            look(keys, clock, "R1", "X", remote=remote)
            n = len(runner.calls) + 1
            assert wait_until(lambda n=n: len(runner.calls) == n and not keys.busy(), 5.0)
        runner.gate = threading.Event()
        look(keys, clock, remote=remote)
        look(keys, clock, "R1", "X", remote=remote)
        assert wait_until(lambda: len(runner.calls) == 4, 5.0)
        look(keys, clock, remote=remote)
        look(keys, clock, "R1", "X", remote=remote)  # ignored: a warning from the press's side
        runner.gate.set()
        assert wait_until(lambda: not keys.busy(), 5.0)
    finally:
        threading.excepthook = threading.__excepthook__
        keys.stop()
    assert not errors, errors
