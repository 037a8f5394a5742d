"""A flake census: each chosen test file run N times alone on the machine, and the whole suite M times as
``make test`` runs it (its own load), every failure kept with its test and first assertion line.

Each run is a separate pytest process (as CI starts it), its outcome read from its JUnit XML, never from its exit
code alone: a run that collected nothing or crashed before writing its report counts as failed, with why. Nothing
is retried: a red run is counted and shown. The files run as their make target runs them: ``make latency``'s with
``G1_TIMING=strict``, ``make policy-faults``' with its marker. Prints, then writes to ``--out``, one table:

    file | runs | failed runs | failures: test (times) first assertion line

The last line is ``flakes: R runs, F failed``; the exit status is 1 when F > 0.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
SUITE = "make test"


@dataclass
class Tally:
    runs: int = 0
    failed_runs: int = 0
    failures: Counter[tuple[str, str]] = field(default_factory=Counter)  # (test, first assertion line)
    seconds: float = 0.0


def _run(args: list[str], env: dict[str, str], report: Path) -> tuple[bool, list[tuple[str, str]], float]:
    """One pytest process (``args`` after ``python -m pytest``; ``make test`` itself for the suite); (green, its
    failures, wall s)."""
    started = time.monotonic()
    if args == [SUITE]:
        command = ["make", "-s", "test"]
        env = {**env, "PYTEST_ADDOPTS": f"--junitxml={report}"}
    else:
        command = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", f"--junitxml={report}", *args]
    proc = subprocess.run(command, cwd=REPO, env=env, capture_output=True, text=True)
    wall = time.monotonic() - started
    if not report.exists():
        tail = (proc.stdout + proc.stderr).strip().splitlines()[-1:] or ["no output"]
        return False, [("(no report)", f"exit {proc.returncode}: {tail[0]}")], wall
    failures: list[tuple[str, str]] = []
    tests = 0
    for case in ET.parse(report).iter("testcase"):
        tests += 1
        for bad in (*case.findall("failure"), *case.findall("error")):
            name = f"{case.get('classname', '').rsplit('.', 1)[-1]}::{case.get('name')}"
            failures.append((name, _first_assertion(bad)))
    if tests == 0:
        failures.append(("(no test ran)", f"exit {proc.returncode}"))
    return proc.returncode == 0 and not failures, failures, wall


def _first_assertion(element: ET.Element) -> str:
    """The first ``E `` line of a failure's text (pytest's), else its message, shortened."""
    for line in (element.text or "").splitlines():
        if line.startswith("E "):
            return line[1:].strip()[:160]
    return (element.get("message") or "").splitlines()[0][:160] if element.get("message") else ""


def census(latency: list[str], policy_faults: list[str], runs: int, suites: int,
           echo: bool = True) -> dict[str, Tally]:
    """``latency``: files run as ``make latency`` runs them (``G1_TIMING=strict``); ``policy_faults``: as ``make
    policy-faults`` does (its marker); each ``runs`` times alone; then ``make test`` ``suites`` times."""
    tallies: dict[str, Tally] = {}
    work = Path(tempfile.mkdtemp(prefix="g1_flakes_"))
    base = {**os.environ, "PYTHONUNBUFFERED": "1"}
    plan = [*((path, [path], {**base, "G1_TIMING": "strict"}) for path in latency),
            *((path, ["-m", "policy_faults", path], base) for path in policy_faults)]
    for key, args, env in [*[p for p in plan for _ in range(runs)], *[(SUITE, [SUITE], base)] * suites]:
        tally = tallies.setdefault(key, Tally())
        green, failures, wall = _run(args, env, work / f"{len(list(work.iterdir()))}.xml")
        tally.runs += 1
        tally.seconds += wall
        tally.failed_runs += not green
        tally.failures.update(failures)
        if echo:
            print(f"{key}: run {tally.runs} {'green' if green else 'RED'} in {wall:.0f} s"
                  + "".join(f"\n    {t}: {line}" for t, line in failures), flush=True)
    return tallies


def table(tallies: dict[str, Tally]) -> str:
    rows = ["| file | runs | failed runs | mean s | failures: test (times) first assertion line |",
            "| --- | --- | --- | --- | --- |"]
    for key, t in tallies.items():
        failures = "; ".join(f"`{test}` ({n}) {line}" for (test, line), n in t.failures.most_common()) or "none"
        rows.append(f"| `{key}` | {t.runs} | {t.failed_runs} | {t.seconds / max(1, t.runs):.0f} | {failures} |")
    total, red = sum(t.runs for t in tallies.values()), sum(t.failed_runs for t in tallies.values())
    return "\n".join(rows) + f"\n\nflakes: {total} runs, {red} failed"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="flakes", description=__doc__.split("\n\n")[0])
    parser.add_argument("--latency", nargs="*", default=[], help="files run as make latency runs them")
    parser.add_argument("--policy-faults", nargs="*", default=[], help="files run as make policy-faults runs them")
    parser.add_argument("--runs", type=int, default=20, help="runs of each file")
    parser.add_argument("--suites", type=int, default=0, help="runs of the whole suite, as make test runs it")
    parser.add_argument("--out", default="artifacts/flakes.md", help="where the table is written")
    args = parser.parse_args(argv)
    tallies = census(args.latency, args.policy_faults, args.runs, args.suites)
    text = table(tallies)
    print(text)
    out = REPO / args.out
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text + "\n")
    return 1 if any(t.failed_runs for t in tallies.values()) else 0
