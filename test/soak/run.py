"""The soak run: the real sim bridge (with its record, the robot hung in its gantry) and the real node, node
lifetime after node lifetime, each under the planned random load (soak.schedule) and ended by an e-stop, then
the node restarted and the robot reset. Every lifetime is judged like a chaos scenario (chaos.scenario.judge,
on the sim's record of that lifetime); the node's resources are sampled at fixed ages (soak.sampler) and judged
for growth (soak.growth). Every node writes its flight recorder's incidents into one folder, ``--out``/incidents,
with small rotation limits, and the folder is judged after each lifetime (soak.recorder). Writes samples.csv,
soak.svg, report.md and each node's log (node_<lifetime>.log) to ``--out``; its last line is
``soak: M minutes, V violations, growth: none|<what grew>``, and it exits non-zero on a violation or growth.

Every process it starts is stopped at the end, on Ctrl-C or SIGTERM too (they run in sessions of their own, so a
terminal's Ctrl-C reaches only this process).
"""

from __future__ import annotations

import argparse
import json
import shutil
import signal
import threading
import time
import traceback
from pathlib import Path
from typing import Any

from chaos.scenario import Claims, judge
from e2e.conftest import Stack
from soak import growth, report
from soak.load import NO_FAULTS, Load
from soak.recorder import Limits, RecorderLedger
from soak.sampler import SampleLog, Sampler
from soak.schedule import Lifetime, plan_soak
from soak.svg_plot import write_svg
from support.mode_manager import RosClient, start_mode_manager, wait_until
from support.processes import ManagedProcess
from support.sim_bridge import shared_sim_status, start_sim_bridge
from support.sim_record import SimRecord, damped, is_damp, requests

NODE = "/g1_mode_manager"
RECORDER_STATUS = "g1_mode_manager: recorder"  # its /diagnostics status: what the ring keeps
ESTOP_TIMEOUT_S = 40.0  # the e-stop's bound (estop_timeout_s 10 s + a call) with room for a starved machine
AFTER_ESTOP_S = 2.0  # the streams go on this long after the e-stop: none of it may reach the robot
SETTLE_S = 12.0  # after the e-stop the robot must be seen damped within this (as in the chaos suite)
LOAD_JOIN_S = 40.0  # an operator's call in flight at the e-stop (a set_mode waits up to 20 s)
#: The flight recorder's limits for the run: small, so that the run's incidents (an e-stop and a snapshot or two
#: per lifetime, and each FAULT's) rotate, by count and sometimes by size. This load's files took 268-467 KiB
#: (a 30 s window), so four of them take 1.1-1.9 MB: about half the time over 1.5 MB.
RECORDER_MAX_FILES = 4
RECORDER_MAX_TOTAL_MB = 1.5
#: The e-stop's incident is written this long after EMERGENCY's entry: well before the node is stopped.
RECORDER_AFTER_S = 1.0
FOLDER_LOOK_S = 1.0  # how often the folder is looked at during a lifetime (sizes of files later rotated away)


def parse(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="python -m soak", description=__doc__.split("\n\n")[0])
    p.add_argument("--minutes", type=float, default=30.0, help="how long the run lasts (about; default 30)")
    p.add_argument("--seed", type=int, default=None, help="the load's seed (default: from the clock; printed)")
    p.add_argument("--lifetime-s", type=float, default=300.0, help="a node lifetime's mean length, s (default 300)")
    p.add_argument("--sample-s", type=float, default=30.0, help="sampling period, s (default 30)")
    p.add_argument("--warmup-s", type=float, default=growth.WARMUP_S, help="samples younger than this are "
                   f"not judged within a lifetime, s (default {growth.WARMUP_S:g})")
    p.add_argument("--out", default="artifacts/soak", help="where samples.csv, soak.svg, report.md and modes.jsonl go")
    p.add_argument("--keep-record", action="store_true", help="keep the sim's record even if nothing failed")
    return p.parse_args(argv)


class Soak:
    def __init__(self, args: argparse.Namespace, sdk_domain: int) -> None:
        self.args = args
        self.sdk_domain = sdk_domain
        self.out = Path(args.out)
        self.out.mkdir(parents=True, exist_ok=True)
        self.record_path = self.out / "sim_record.jsonl"
        self.record_path.unlink(missing_ok=True)
        (self.out / "modes.jsonl").unlink(missing_ok=True)
        incidents = self.out / "incidents"
        shutil.rmtree(incidents, ignore_errors=True)  # rotation is judged on this run's files alone
        self.recorder = RecorderLedger(incidents, Limits(RECORDER_MAX_FILES, RECORDER_MAX_TOTAL_MB), RECORDER_AFTER_S)
        self.log = SampleLog(str(self.out / "samples.csv"))
        self.plan = plan_soak(args.seed, args.minutes, args.lifetime_s)
        self.violations: dict[int, list[str]] = {}
        self.notes: list[str] = []  # not violations: unclean exits, sampling errors, the load's timeouts
        self.t0 = time.monotonic()
        self.bridge: ManagedProcess | None = None
        self.node: ManagedProcess | None = None
        self.ros: RosClient | None = None
        self.claims = Claims()
        self.load_stop = threading.Event()
        self.t_estop_wall = 0.0
        #: the recorder's last kept events and kB on /diagnostics (once a second), and the most kB this lifetime
        self._ring: tuple[int, float, float] = (0, 0.0, 0.0)

    # --- the parts, made once ---------------------------------------------------------------------------------
    def start(self) -> None:
        from diagnostic_msgs.msg import DiagnosticArray
        from g1_mode_manager_msgs.msg import Mode
        from rclpy.qos import QoSProfile, ReliabilityPolicy
        from std_msgs.msg import Bool

        from g1_mode_manager.protocol.dds import init_channels
        from g1_mode_manager.topic_qos import MODE_QOS
        from soak.probes import CycloneGraph

        init_channels(self.sdk_domain, "lo")  # this process's SDK clients: the sim's status, Cyclone's discovery
        self.bridge = start_sim_bridge(self.sdk_domain, speed=1.0,
                                       extra_args=("--record", str(self.record_path), "--gantry"))
        self.ros = RosClient("soak_client")
        self.sim = shared_sim_status()
        self.sim.wait_ready(15.0)
        self.cyclone = CycloneGraph()
        self.stack = Stack(self.bridge, None, self.ros, self.sim, None)  # type: ignore[arg-type]  # node: per lifetime
        node = self.ros.node
        node.create_subscription(Mode, self.stack.name("mode"), self._on_mode, MODE_QOS)
        node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, 10)
        self.estop_pubs = {"topic_reliable": node.create_publisher(Bool, "/estop", QoSProfile(depth=10)),
                           "topic_best_effort": node.create_publisher(
                               Bool, "/estop", QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT))}
        self.load = Load(self.stack, self._last_mode, self.recorder.snapshot_answered)
        self.load.publishers()

    def _on_mode(self, msg: Any) -> None:
        claims = self.claims
        with claims.lock:
            claims.modes.append((time.monotonic(), msg))

    def _on_diagnostics(self, msg: Any) -> None:
        for st in msg.status:
            if st.name == RECORDER_STATUS:
                values = {v.key: v.value for v in st.values}
                kb = float(values.get("kept_kb", 0.0))
                self._ring = (int(values.get("kept_events", 0)), kb, max(kb, self._ring[2]))

    def _ring_kept(self) -> tuple[int, float, float]:
        return self._ring

    def _last_mode(self) -> int | None:
        with self.claims.lock:
            return self.claims.modes[-1][1].mode if self.claims.modes else None

    def _last_mode_name(self) -> str:
        with self.claims.lock:
            return self.claims.modes[-1][1].name if self.claims.modes else ""

    # --- the run ----------------------------------------------------------------------------------------------
    def run(self) -> None:
        a = self.args
        print(f"soak: seed {a.seed}, {len(self.plan)} node lifetimes of "
              f"{', '.join(f'{p.length_s:.0f}' for p in self.plan)} s, sampled every {a.sample_s:g} s; out {self.out}",
              flush=True)
        self.start()
        for p in self.plan:
            bad = self.lifetime(p)
            self.violations[p.index] = bad
            for b in bad:
                print(f"soak: VIOLATION lifetime {p.index} (seed {a.seed}): {b}", flush=True)

    def lifetime(self, p: Lifetime) -> list[str]:
        """One node, from its start to its e-stop and stop: the violations of the chaos invariants in it."""
        assert self.ros is not None and self.bridge is not None
        record = SimRecord(self.record_path, from_now=True)  # from just before the reset: it holds the boot state
        self.sim.reset()
        self.stack.set_faults(NO_FAULTS)  # the reset cleared the robot's; the parameter must say so too
        self.claims = Claims()
        self.recorder.lifetime_starts()
        self._ring = (0, 0.0, 0.0)  # the last node's figures are not this one's
        self.node = node = start_mode_manager(self.sdk_domain, *self.recorder.node_params())
        t_ready = time.monotonic()
        self.stack.node, self.stack.record = node, record
        sampler = Sampler(self.log, lifetime=p.index, pid=node.proc.pid, bridge_pid=self.bridge.proc.pid,
                          t_ready=t_ready, t_run0=self.t0, period_s=self.args.sample_s, until_age_s=p.length_s,
                          ros_graph=self.ros.node, cyclone=self.cyclone, sim=self.sim, mode=self._last_mode_name,
                          ring=self._ring_kept)
        sampler.start()  # before waiting for discovery: its first sample is the node at its ready line
        self.ros.wait_node_answers(NODE)
        bad: list[str] = []
        estop_pub = self.estop_pubs.get(p.estop_via)
        if estop_pub is not None and not wait_until(lambda: estop_pub.get_subscription_count() >= 1, 10.0):
            bad.append(f"the node's /estop subscription did not match within 10 s ({p.estop_via})")
        self.load_stop = stop = threading.Event()
        operators = self.load.start(p, t_ready, stop)
        operators.append(threading.Thread(target=self._look_at_folder, args=(stop,), daemon=True, name="folder"))
        operators[-1].start()
        time.sleep(max(0.0, t_ready + p.length_s - time.monotonic()))
        bad += self._estop(p, estop_pub)
        time.sleep(AFTER_ESTOP_S)
        stop.set()
        for th in operators:
            th.join(LOAD_JOIN_S)
        sampler.stop()
        self.notes += [f"lifetime {p.index} sampling: {e}" for e in sampler.errors]
        self.stack.set_faults(NO_FAULTS)  # a lost link the e-stop cut short comes back
        t_estop = self.claims.t_estop
        wait_until(lambda: _damped(self.sim.get()) and any(is_damp(e) for e in requests(record.events(t_estop))),
                   SETTLE_S, 0.1)
        time.sleep(0.3)
        end_state = self.sim.get()
        if not node.alive():
            bad.append(f"the node died during lifetime {p.index} (exit {node.proc.returncode}): {node.output()[-1500:]}")
        bad += judge(record.after_last_reset(), self.claims, end_state)
        self._save_claims(p.index)
        estop_there = self.recorder.estop_file_there(self.t_estop_wall)
        t_stop = time.monotonic()
        code = node.stop()
        self.node = None
        if code not in (0, None) or time.monotonic() - t_stop > 5.0:
            self.notes.append(f"lifetime {p.index}: the node exited {code} after {time.monotonic() - t_stop:.1f} s "
                              f"on SIGINT: {node.output()[-1500:]}")
        self.ros.wait_service_gone(f"{NODE}/set_mode")
        # the node's own account beside its samples: what it did when its memory stepped
        (self.out / f"node_{p.index}.log").write_text(node.output())
        bad += self.recorder.judge(p.index, node.output(), estop_wall=self.t_estop_wall,
                                   estop_before_stop=estop_there)
        files = self.recorder.lifetimes[-1]
        print(f"soak: lifetime {p.index} done at {(time.monotonic() - self.t0) / 60:.1f} min: {p.length_s:.0f} s, "
              f"e-stop via {p.estop_via} ({self._estop_said()}), {len(bad)} violations, exit {code}; incidents "
              f"{files.written} written, {files.removed} rotated away, {files.kept} kept "
              f"({files.total_bytes / 1024:.0f} KiB); load {dict(sorted(self.load.outcomes.items()))}", flush=True)
        self.load.outcomes.clear()
        return bad

    def _look_at_folder(self, stop: threading.Event) -> None:
        """The folder's files and sizes during the lifetime: a file rotated away before the lifetime's end is still
        counted, and its size known to the rotation's judge."""
        while not stop.wait(FOLDER_LOOK_S):
            try:
                self.recorder.look()
            except OSError as e:  # a listing racing a removal: the next look sees the folder settled
                self.notes.append(f"incident folder: {e}")

    def _save_claims(self, lifetime: int) -> None:
        """What the node said on ~/mode in this lifetime, and when (the judge's input beside the sim's record)."""
        c = self.claims
        with c.lock, (self.out / "modes.jsonl").open("a") as f:
            f.write(json.dumps({"lifetime": lifetime, "t_estop": c.t_estop, "estop_success": c.estop_success,
                                "t_answer": c.t_answer}) + "\n")
            for t, m in c.modes:
                f.write(json.dumps({"lifetime": lifetime, "t": t, "mode": m.name, "transition": m.transition_in_progress,
                                    "damp_confirmed": m.damp_confirmed, "faults": list(m.faults),
                                    "holds": list(m.holds), "last_refusal": m.last_refusal}) + "\n")

    def _estop(self, p: Lifetime, topic_pub: Any) -> list[str]:
        from std_msgs.msg import Bool
        from std_srvs.srv import Trigger

        claims = self.claims
        claims.t_estop, self.t_estop_wall = time.monotonic(), time.time()  # UNIX time: the incidents' clock
        if topic_pub is not None:
            topic_pub.publish(Bool(data=True))
            return []
        assert self.ros is not None
        try:
            reply = self.ros.call(Trigger, f"{NODE}/estop", Trigger.Request(), ESTOP_TIMEOUT_S)
        except TimeoutError as e:
            return [f"e-stop: {e}"]
        claims.t_answer, claims.estop_success = time.monotonic(), reply.success
        return []

    def _estop_said(self) -> str:
        c = self.claims
        if c.estop_success is None:
            return "topic"
        return f"success {c.estop_success} after {c.t_answer - c.t_estop:.3f} s"

    # --- the end ----------------------------------------------------------------------------------------------
    def close(self) -> None:
        """Stop everything this run started (each step whatever the one before did)."""
        self.load_stop.set()
        for proc in (self.node, self.bridge):
            if proc is not None and proc.alive():
                code = proc.stop()
                if code not in (0, None):
                    print(f"soak: {proc.name} exited {code}; its last output:\n{proc.output()[-2000:]}", flush=True)
        if self.ros is not None:
            self.ros.close()
        self.log.close()

    def finish(self, failure: str = "") -> int:
        """The report, the plot and the last line; the exit status (0: no violation, no growth, the whole run)."""
        a, rows = self.args, self.log.rows
        minutes = (time.monotonic() - self.t0) / 60
        grew = growth.judge_growth(rows, warmup_s=a.warmup_s)
        n_bad = sum(len(v) for v in self.violations.values())  # a failed run says so on the line above the last
        counts = {k: len(v) for k, v in self.violations.items()}
        text = [f"# soak seed {a.seed}: {minutes:.1f} min, {len(self.violations)} of {len(self.plan)} lifetimes run, "
                f"sampled every {a.sample_s:g} s, warm-up {a.warmup_s:g} s", "",
                "Each figure at age 0 → the first sample after the warm-up → the last sample before the e-stop.", "",
                *report.figures_table(rows, a.warmup_s, counts), "", "Noise (growth.noise) and thresholds:",
                *report.noise_lines(rows, a.warmup_s), "",
                f"The flight recorder's folder ({self.recorder.folder}), judged after each lifetime:", "",
                *self.recorder.table(), "", self.recorder.sizes_line(), ""]
        text += [f"violation, lifetime {k}: {b}" for k, v in self.violations.items() for b in v]
        text += [f"note: {n}" for n in self.notes] + ([f"the run failed: {failure}"] if failure else [])
        text.append(self.recorder.summary())
        text.append(report.last_line(minutes, n_bad, grew))
        (self.out / "report.md").write_text("\n".join(text) + "\n")
        write_svg(rows, str(self.out / "soak.svg"), f"make soak: seed {a.seed}, {minutes:.0f} min, "
                  f"a sample every {a.sample_s:g} s, node restarts dashed")
        if n_bad == 0 and not failure and not a.keep_record:  # the judge's inputs are kept where something failed
            self.record_path.unlink(missing_ok=True)
            (self.out / "modes.jsonl").unlink(missing_ok=True)
        print("\n".join(text), flush=True)
        complete = len(self.violations) == len(self.plan)
        return 0 if n_bad == 0 and not grew and complete and not failure else 1


def _damped(status: dict[str, Any]) -> bool:
    return damped({"fsm": status["sport"]["fsm_id"], "svc": status["sport"]["mode"]})


def _interrupt(_signum: int, _frame: Any) -> None:
    raise KeyboardInterrupt


def main(argv: list[str] | None = None, *, sdk_domain: int) -> int:
    args = parse(argv)
    if args.seed is None:
        args.seed = int(time.time())
    signal.signal(signal.SIGTERM, _interrupt)
    soak = Soak(args, sdk_domain)
    failure = ""
    try:
        soak.run()
    except KeyboardInterrupt:
        failure = "interrupted"
    except Exception as e:  # the report still says what was sampled and judged until then
        traceback.print_exc()
        failure = repr(e)
    finally:
        print("soak: stopping everything it started", flush=True)
        soak.close()
    code = soak.finish(failure)
    return 130 if failure == "interrupted" else code
