"""Samples one node lifetime's resources at fixed ages (0, every ``period_s``), in a thread of its own, into rows
(kept, and appended to the run's CSV as they come: a run cut short keeps what it sampled)."""

from __future__ import annotations

import csv
import threading
import time
from typing import IO, Any

from soak import probes

#: The CSV's columns: when, which node, its mode, then the figures (docs/soak.md says what each counts).
COLUMNS = ("run_s", "lifetime", "age_s", "pid", "mode", "rss_kb", "rss_anon_kb", "threads", "fds", "ros_nodes",
           "ros_pubs", "ros_subs", "ros_services", "ros_clients", "sdk_participants", "sdk_node_writers",
           "sdk_node_readers", "sim_matched_readers", "sim_rss_kb", "ring_events", "ring_kb",
           "ring_peak_kb", "anon_net_kb")


class SampleLog:
    """Every row of the run, and its CSV file."""

    def __init__(self, path: str) -> None:
        self.rows: list[dict[str, Any]] = []
        self._file: IO[str] = open(path, "w", newline="")  # noqa: SIM115 (closed in close())
        self._csv = csv.DictWriter(self._file, COLUMNS)
        self._csv.writeheader()
        self._lock = threading.Lock()

    def add(self, row: dict[str, Any]) -> None:
        with self._lock:
            self.rows.append(row)
            self._csv.writerow(row)
            self._file.flush()

    def close(self) -> None:
        self._file.close()


class Sampler:
    """Samples the node ``pid`` at ages 0, period_s, 2 period_s ... below ``until_age_s`` (its e-stop)."""

    def __init__(self, log: SampleLog, *, lifetime: int, pid: int, bridge_pid: int, t_ready: float, t_run0: float,
                 period_s: float, until_age_s: float, ros_graph: Any, cyclone: probes.CycloneGraph, sim: Any,
                 mode: Any, ring: Any) -> None:
        self._log, self._lifetime, self._pid, self._bridge_pid = log, lifetime, pid, bridge_pid
        self._t_ready, self._t_run0, self._period, self._until = t_ready, t_run0, period_s, until_age_s
        self._ros_graph, self._cyclone, self._sim, self._mode = ros_graph, cyclone, sim, mode
        self._ring = ring  # () -> the recorder's last (kept_events, kept_kb) on /diagnostics, and the most kept_kb
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="sampler", daemon=True)
        self.errors: list[str] = []

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(10.0)

    def _run(self) -> None:
        k = 0
        while (age := k * self._period) < self._until:
            if self._stop.wait(max(0.0, self._t_ready + age - time.monotonic())):
                return
            try:
                self._log.add(self.sample(age))
            except (OSError, RuntimeError, KeyError) as e:  # a node gone, a status call lost: said, not fatal
                self.errors.append(f"age {age:g} s: {e!r}")
            k += 1

    def sample(self, age: float) -> dict[str, Any]:
        t = time.monotonic()
        row: dict[str, Any] = {"run_s": round(t - self._t_run0, 2), "lifetime": self._lifetime, "age_s": age,
                               "pid": self._pid, "mode": self._mode()}
        row |= probes.proc_figures(self._pid)
        row |= probes.ros_endpoints(self._ros_graph, "/", "g1_mode_manager")
        row |= self._cyclone.figures(self._pid)
        row["sim_matched_readers"] = probes.sim_matched_readers(self._sim.get())
        row["sim_rss_kb"] = probes.rss_kb(self._bridge_pid)
        row["ring_events"], row["ring_kb"], row["ring_peak_kb"] = self._ring()
        row["anon_net_kb"] = row["rss_anon_kb"] - round(row["ring_peak_kb"])  # what soak.growth judges
        return row
