"""The harness stops its children with SIGINT: they must get it, however the run itself was started."""

from __future__ import annotations

import subprocess
import sys
import textwrap

#: A parent started as a shell without job control starts a background command (SIGINT ignored, which exec
#: keeps), starting a child that only a KeyboardInterrupt ends well, then stopping it as the harness does.
_PARENT = textwrap.dedent("""
    import signal, sys
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    from harness.processes import ManagedProcess, restore_sigint
    if sys.argv[1] == "restore":
        restore_sigint()
    child = ManagedProcess([sys.executable, "-u", "-c", sys.argv[2]], name="child")
    child.wait_for_line(lambda line: line == "waiting", 20.0)
    print("exit", child.stop(timeout_s=float(sys.argv[3])), child.output().splitlines()[-1], flush=True)
""")
_CHILD = textwrap.dedent("""
    import time
    print("waiting", flush=True)
    try:
        time.sleep(3600)
    except KeyboardInterrupt:
        print("interrupted", flush=True)
""")


def _stop_child(how: str, timeout_s: float) -> str:
    out = subprocess.run([sys.executable, "-c", _PARENT, how, _CHILD, str(timeout_s)], capture_output=True,
                         text=True, timeout=60.0, check=True)
    return out.stdout.strip().splitlines()[-1]


def test_a_child_of_a_run_started_with_sigint_ignored_stops_on_sigint_after_restore_sigint() -> None:
    assert _stop_child("restore", 10.0) == "exit 0 interrupted"


def test_without_restore_sigint_the_child_ignores_sigint_and_needs_sigterm() -> None:
    """The case restore_sigint exists for: the child inherits the ignored SIGINT and only SIGTERM ends it."""
    assert _stop_child("keep", 0.5) == f"exit {-15} waiting"
