"""One chaos scenario, run: the operators, an optional SIGKILL and restart of the node, the e-stop aimed at its
cell (sent when the node shows the aimed row and the operators have the aimed column in flight, or at the
deadline), an optional second e-stop, then the judge on the robot's record.

The landing is what was observed when the e-stop went out, never the aim.
"""

from __future__ import annotations

import os
import random
import signal
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from g1_mode_manager_msgs.msg import Mode
from std_msgs.msg import Bool
from std_srvs.srv import Trigger

from chaos import policy
from chaos.coverage import Coverage, InFlight, Landing, row_of
from chaos.drivers import DriveLog, drive_cells
from chaos.operators import Operators
from chaos.plan import AIM_DEADLINE_S, SCRIPTS, Plan
from chaos.scenario import Claims, judge
from support.mode_manager import wait_until
from support.processes import ManagedProcess
from support.sim_record import Event, SimRecord

SETTLE_S = 12.0  # after the faults clear, supervision must get the robot damped within this
#: After the e-stop the operators go on this long (nothing they send may reach the robot), s, by scenario length: a
#: short scenario's (the suite's batch) half a second still holds tens of their messages at their 20-100 Hz.
AFTERMATH_S = {"short": 0.5, "medium": 1.0, "long": 1.0}
#: A node counts as exiting uncleanly if SIGINT takes longer than this, s.
CLEAN_EXIT_S = 5.0
DAMP = '{"data": 1}'


class ScenarioRun:
    def __init__(self, p: Plan, stack: Any, ends: Any, *, restart: Callable[[], ManagedProcess]) -> None:
        self.plan = p
        self.stack = stack
        self.ends = ends
        self._restart = restart
        self.exits: list[tuple[int | None, float, str]] = []  # (code, s, output) of every node stopped by SIGINT
        self._killed: list[ManagedProcess] = []
        self.landing: Landing | None = None
        self.timing: dict[str, float] = {}  # s from the scenario's start: aimed, answered, operators, damped
        self.renewed = False  # a node left in EMERGENCY by the noise was replaced before the setup
        self.features: list[str] = []  # what the scenario exercised (coverage.Coverage.features)

    def run(self, latencies: list[float], coverage: Coverage) -> list[str]:
        p, stack = self.plan, self.stack
        claims = self.ends.claims = Claims(drives=DriveLog(planner_command=p.planner_command))
        estop_pub = self.ends.estop_pubs.get(p.estop_via)
        stop = threading.Event()
        in_flight = InFlight()
        ops = Operators(stack, p, in_flight, stop, claims.drives)
        try:
            stack.sim.reset()
            stack.ros.wait_node_answers(f"{stack.ns}/g1_mode_manager")
            assert self.ends.estop_client.wait_for_service(timeout_sec=10.0)
            assert estop_pub is None or wait_until(lambda: estop_pub.get_subscription_count() >= 1, 10.0)
            stack.set_faults(p.faults)
            stack.set_gantry(p.gantry)
            t0 = time.monotonic()
            operators = threading.Thread(target=ops.run, args=(t0, lambda: _fault_claimed(claims)), daemon=True)
            operators.start()
            if p.kill_at is not None:
                threading.Thread(target=self._kill_and_restart, args=(t0, ops, claims), daemon=True).start()
            landing = self.landing = self._aim(t0, ops, in_flight, claims)
            landing.path = p.path
            self.timing["aimed"] = time.monotonic() - t0
            if p.race is not None:
                ops.send_race(p.race)
            self._estop(p.estop_via, claims, first=True)
            self.timing["answered"] = time.monotonic() - t0
            if p.second_estop_after is not None:
                time.sleep(p.second_estop_after)
                self._estop(p.second_via, claims, first=False)
            operators.join(AFTERMATH_S[p.length])
            stop.set()  # a call still in flight (a pre-empted transition's) ends on its own, in its thread
            ops.node_back.wait(30.0)
            self.timing["operators"] = time.monotonic() - t0
            stack.set_faults({})
            # the robot damped, and by the node's e-stop: the remote's L2+B damps it by itself (the built-in
            # controller), while an e-stop from UNINITIALIZED first connects
            wait_until(lambda: _damped(stack.sim.get()) and _damp_since(stack.record, claims.t_estop), SETTLE_S, 0.1)
            self.timing["damped"] = time.monotonic() - t0
            time.sleep(0.3)
            end_state = stack.sim.get()
            alive = stack.node.alive()
            events = stack.record.after_last_reset()
            self.features = self._features(claims, events)
            coverage.add(landing, self.features)
            with claims.lock:
                claims.restarts = [(t_kill, next((t for t in ops.mode_calls if t > t_kill), float("inf")))
                                   for t_kill, _ in claims.restarts]
                claims.engages = list(ops.engage_calls)
            first_damp = next((e["t"] for e in events if e["k"] == "req" and e["t"] >= claims.t_estop
                               and e.get("api") == 7101 and e.get("p") == DAMP), None)
            if first_damp is not None and landing.connected and not claims.restarts:
                latencies.append(first_damp - claims.t_estop)
            crashed = [] if alive else [f"the node died during the scenario (exit {stack.node.proc.returncode}): "
                                        f"{stack.node.output()[-1500:]}"]
            return crashed + judge(events, claims, end_state, path=p.path)
        finally:
            stop.set()
            t_stop = time.monotonic()
            code = stack.node.stop()  # before the next reset: its supervision would damp the fresh robot
            self.exits.append((code, time.monotonic() - t_stop, stack.node.output()))
            for killed in self._killed:
                killed.stop()

    # --- the e-stop's aim --------------------------------------------------------------------------------
    def _aim(self, t0: float, ops: Operators, in_flight: InFlight, claims: Claims) -> Landing:
        """Wait until the node shows the aimed row and the aimed column is in flight (or the deadline); returns
        where the e-stop lands, observed just before it goes out."""
        p = self.plan
        row, column = p.aim
        rng = random.Random(p.seed ^ 0x5EED)
        if p.aim == ("UNINITIALIZED", "nothing"):  # no request at all: an e-stop before any connect
            time.sleep(max(0.0, t0 + rng.uniform(0.1, 1.0) - time.monotonic()))
            return self._landing(claims, in_flight)
        ops.node_back.wait(60.0)  # a restarted node is up (an e-stop sent to a dead one is lost)
        assert self.ends.estop_client.wait_for_service(timeout_sec=10.0)
        pub = self.ends.estop_pubs.get(p.estop_via)
        assert pub is None or wait_until(lambda: pub.get_subscription_count() >= 1, 10.0)
        deadline = max(t0 + p.setup_at, time.monotonic()) + AIM_DEADLINE_S
        sent = False
        scripted = p.script in SCRIPTS  # the row is reached once the setup's script has played there
        while time.monotonic() < deadline:
            if not ops.node_checked.is_set() and time.monotonic() >= t0 + p.setup_at and ops.node_back.is_set():
                # here, in the thread that sends the e-stop, so that it never goes to a node being replaced
                if self._renew_latched(claims):
                    deadline = max(deadline, time.monotonic() + AIM_DEADLINE_S)
                ops.node_checked.set()
            if _row(claims) == row and (not scripted or ops.setup_done.is_set()):
                ops.row_reached.set()
                if column in _columns(claims, in_flight):
                    break
                if not sent:
                    sent = ops.send_column()
                    if sent:
                        continue  # the e-stop goes out now if the request is still unanswered
            in_flight.wait(0.002)
        ops.node_checked.set()  # the row was reached during the noise: the setup goes on with this node
        if column in ("nothing", "stream", "policy"):  # somewhere inside it, not only at its start
            time.sleep(rng.uniform(0.0, 0.3))
        return self._landing(claims, in_flight)

    @staticmethod
    def _landing(claims: Claims, in_flight: InFlight) -> Landing:
        with claims.lock:  # the node that gets the e-stop: the one started after the last kill
            since = claims.restarts[-1][0] if claims.restarts else float("-inf")
            connected = any(m.mode != Mode.UNINITIALIZED for t, m in claims.modes if t > since)
        return Landing(_row(claims), _columns(claims, in_flight), connected)

    def _estop(self, via: str, claims: Claims, *, first: bool) -> None:
        t = time.monotonic()
        if first:
            claims.t_estop = t
        if via == "service":
            try:
                reply = _call(self.ends.estop_client, 40.0)
            except TimeoutError as e:
                raise TimeoutError(f"{e}; {self._diagnosis()}") from None
            if first:
                claims.t_answer, claims.estop_success = time.monotonic(), reply.success
            else:
                claims.later_estops.append((time.monotonic(), reply.success))
        else:
            self.ends.estop_pubs[via].publish(Bool(data=True))

    # --- SIGKILL and restart -----------------------------------------------------------------------------
    def _kill_and_restart(self, t0: float, ops: Operators, claims: Claims) -> None:
        """SIGKILL the node at its planned time and start a fresh one in the same namespace."""
        time.sleep(max(0.0, t0 + (self.plan.kill_at or 0.0) - time.monotonic()))
        old = self.stack.node
        os.kill(old.proc.pid, signal.SIGKILL)
        t_kill = time.monotonic()
        old.proc.wait(10.0)
        self._killed.append(old)
        with claims.lock:
            claims.restarts.append((t_kill, float("inf")))
        try:
            self.stack.node = self._restart()
            self.stack.ros.wait_node_answers(f"{self.stack.ns}/g1_mode_manager")
        except TimeoutError as e:
            print(f"chaos seed {self.plan.seed}: the restarted node did not answer: {e}; {self._diagnosis()}", flush=True)
            raise
        finally:
            ops.node_back.set()

    def _renew_latched(self, claims: Claims) -> bool:
        """A node the noise left in EMERGENCY (the remote's L2+B, most often) is stopped by SIGINT and a fresh one
        started in its place, as after a SIGKILL: judged as a restart (it forwards nothing before it is asked for a
        mode), and its exit as any other."""
        with claims.lock:
            last = claims.modes[-1][1] if claims.modes else None
        if last is None or last.mode != Mode.EMERGENCY:
            return False
        old = self.stack.node
        t_stop = time.monotonic()
        code = old.stop()
        t_exit = time.monotonic()  # its last claims were sent before this: its life ends here
        with claims.lock:
            claims.restarts.append((t_exit, float("inf")))
        self.exits.append((code, t_exit - t_stop, old.output()))
        self.renewed = True
        self.stack.node = self._restart()
        self.stack.ros.wait_node_answers(f"{self.stack.ns}/g1_mode_manager")
        assert self.ends.estop_client.wait_for_service(timeout_sec=10.0)
        pub = self.ends.estop_pubs.get(self.plan.estop_via)
        assert pub is None or wait_until(lambda: pub.get_subscription_count() >= 1, 10.0)
        return True

    def _diagnosis(self) -> str:
        """Which side is stuck when the node does not answer: the node (dead, or alive with its services in the
        graph but serving nothing) or the test's kept clients (a fresh client gets an answer)."""
        from rcl_interfaces.srv import GetParameters

        from g1_mode_manager.cli.client import call_service

        node, ros, name = self.stack.node, self.stack.ros, f"{self.stack.ns}/g1_mode_manager"
        try:
            call_service(ros.node, GetParameters, f"{name}/get_parameters", GetParameters.Request(names=["dds_domain"]),
                         timeout_s=5.0, discovery_timeout_s=5.0)
            fresh = "a fresh client's get_parameters answered"
        except TimeoutError as e:
            fresh = f"a fresh client failed too ({e})"
        return (f"node pid {node.proc.pid} alive={node.alive()}, estop servers in the graph: "
                f"{ros.node.count_services(f'{name}/estop')}, {fresh}; node output:\n{node.output()[-3000:]}"
                f"{_stacks(node.proc.pid) if node.alive() else ''}")

    def _features(self, claims: Claims, events: list[Event]) -> list[str]:
        p = self.plan
        with claims.lock:
            claimed = list(claims.modes)
        modes = [m for _, m in claimed]
        return [f"{p.length} scenarios",
                *(["second e-stops"] if p.second_estop_after is not None else []),
                *(["node SIGKILLed and restarted"] if p.kill_at is not None else []),
                *(["node renewed after the noise's EMERGENCY"] if self.renewed else []),
                *(["FAULT entered"] if any(m.mode == Mode.FAULT for m in modes) else []),
                *(["holds"] if any(m.holds for m in modes) else []),
                *(["hung in the gantry"] if p.gantry else []),
                *(["user control damping on silence"] if "user_ctrl_silence:=damp" in p.node_params else []),
                *([f"{p.race} with the e-stop"] if p.race is not None else []),
                *drive_cells(events, claimed, claims.drives, claims.t_estop),
                *policy.features(events, claims.policy)]


def _columns(claims: Claims, in_flight: InFlight) -> tuple[str, ...]:
    """What the operators have in flight, with "policy" while the node that gets the e-stop shows one at work."""
    columns = in_flight.columns()
    with claims.lock:
        since = claims.restarts[-1][0] if claims.restarts else float("-inf")
        working = policy.at_work(claims.policy, since)
    return (*(c for c in columns if c != "nothing"), "policy") if working else columns


def _row(claims: Claims) -> str:
    with claims.lock:
        last = claims.modes[-1][1] if claims.modes else None
    if last is None:
        return "UNINITIALIZED"
    return row_of(last.name, last.transition_in_progress, _mode_name(last.transition_target))


def _mode_name(value: int) -> str:
    names = {Mode.UNINITIALIZED: "UNINITIALIZED", Mode.IDLE: "IDLE", Mode.HIGH_LEVEL: "HIGH_LEVEL",
             Mode.LOW_LEVEL: "LOW_LEVEL", Mode.EMERGENCY: "EMERGENCY", Mode.FAULT: "FAULT"}
    return names.get(value, str(value))


def _fault_claimed(claims: Claims) -> bool:
    with claims.lock:
        last = claims.modes[-1][1] if claims.modes else None
    return last is not None and (last.mode == Mode.FAULT or bool(last.holds))


def _damp_since(record: SimRecord, t: float) -> bool:
    return any(e["k"] == "req" and e.get("api") == 7101 and e.get("p") == DAMP for e in record.events(t))


def _damped(status: dict) -> bool:
    return status["sport"]["fsm_id"] == 1 and status["sport"]["mode"] != ""


def _stacks(pid: int) -> str:
    """The node's threads' stacks (py-spy, if installed): where a node that serves nothing is waiting."""
    import shutil
    import subprocess
    import sys

    spy = shutil.which("py-spy") or str(Path(sys.executable).with_name("py-spy"))
    try:
        done = subprocess.run([spy, "dump", "--pid", str(pid)], capture_output=True, text=True, timeout=20)
    except (OSError, subprocess.TimeoutExpired) as e:
        return f"\n(no stacks: {e})"
    return f"\nnode stacks:\n{done.stdout[-6000:]}{done.stderr[-500:]}"


def _call(client: Any, timeout_s: float) -> Any:
    done = threading.Event()
    future = client.call_async(Trigger.Request())
    future.add_done_callback(lambda _f: done.set())
    if not done.wait(timeout_s):
        raise TimeoutError(f"~/estop did not answer within {timeout_s} s")
    return future.result()
