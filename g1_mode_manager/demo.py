"""g1_demo (make run): the simulated G1, the mode manager and the operator console, a short scripted tour, then
yours to drive.

Starts the MuJoCo sim bridge, the mode_manager node and the console (a web page) as three processes on
loopback, walks the robot through HIGH_LEVEL -> Start -> cmd_vel -> LOW_LEVEL by user control -> handed back ->
walking again -> walking under the locomotion policy in the node's own loop -> a stretch of holosoma's dance in the
same loop -> E-STOP (``--release``: LOW_LEVEL by
ReleaseMode, limp) while printing what happens, then keeps them running for the console's page and `g1ctl` in
another terminal until Ctrl-C. The console is only a
client of the node: if it cannot start (its port taken), the rest runs on without it.
"""

from __future__ import annotations

import argparse
import math
import os
import signal
import subprocess
import sys
import threading
import time

from g1_mode_manager.cli.client import ManagerClient, default_discovery_to_localhost


class Child:
    """A child process whose output is echoed with a prefix and searched for a ready line."""

    def __init__(self, name: str, argv: list[str], ready_text: str, env: dict[str, str] | None = None) -> None:
        self.name = name
        self.ready = threading.Event()
        self.ready_line = ""
        self._ready_text = ready_text
        self.proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1,
                                     start_new_session=True,
                                     env={**os.environ, "PYTHONUNBUFFERED": "1", **(env or {})})
        threading.Thread(target=self._pump, daemon=True).start()

    def _pump(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            print(f"[{self.name}] {line.rstrip()}", flush=True)
            if self._ready_text in line and not self.ready.is_set():
                self.ready_line = line.strip()
                self.ready.set()

    def wait_ready(self, timeout_s: float) -> None:
        deadline = time.monotonic() + timeout_s
        while not self.ready.wait(0.2):
            if self.proc.poll() is not None:
                raise RuntimeError(f"{self.name} exited with code {self.proc.returncode}")
            if time.monotonic() > deadline:
                raise TimeoutError(f"{self.name} not ready within {timeout_s} s")

    def stop(self) -> None:
        for sig, wait in ((signal.SIGINT, 10.0), (signal.SIGKILL, 3.0)):
            if self.proc.poll() is not None:
                return
            os.killpg(self.proc.pid, sig)
            try:
                self.proc.wait(wait)
            except subprocess.TimeoutExpired:
                continue


def _odom_xy(client: ManagerClient):
    from nav_msgs.msg import Odometry

    latest: dict[str, Odometry] = {}

    def keep(msg: Odometry) -> None:
        latest["odom"] = msg

    # the sim's ground truth: the sim node's own topic (~/odom of g1_sim_bridge)
    client.node.create_subscription(Odometry, "/g1_sim_bridge/odom", keep, 10)

    def get() -> tuple[float, float] | None:
        msg = latest.get("odom")
        return None if msg is None else (msg.pose.pose.position.x, msg.pose.pose.position.y)

    return get


class _ModePrinter:
    """Prints ~/mode when it changes (it is also re-published at 1 Hz)."""

    def __init__(self) -> None:
        self._last: tuple | None = None

    def __call__(self, msg) -> None:
        from g1_mode_manager.core.modes import Mode

        key = (msg.mode, msg.transition_in_progress, msg.transition_target)
        if key == self._last:
            return
        self._last = key
        target = f" -> {Mode(msg.transition_target).name} (in progress)" if msg.transition_in_progress else ""
        print(f"  ~/mode: {msg.name}{target}", flush=True)


def scripted_tour(client: ManagerClient, release: bool = False) -> bool:
    """HIGH_LEVEL, Start, walk 0.5 m/s for 4 s, stop by watchdog, LOW_LEVEL (by user control, or ``release``), the
    locomotion policy in the node's loop walked and disengaged, a stretch of the dance (user control only), E-STOP.
    Returns True if all went as expected."""
    odom = _odom_xy(client)
    client.on_mode(_ModePrinter())
    steps_ok = True
    deadline = time.monotonic() + 15.0
    while odom() is None and time.monotonic() < deadline:
        time.sleep(0.1)

    def step(title: str, ok: bool, detail: str) -> None:
        nonlocal steps_ok
        steps_ok &= ok
        print(f"{'OK  ' if ok else 'FAIL'} {title}: {detail}", flush=True)

    r = client.set_mode("high_level")
    step("set_mode high_level", r.success, r.message)
    r = client.loco("start")
    step("loco start (walk mode, fsm 500)", r.success, r.message)
    time.sleep(1.0)
    start, moved = _drive(client, odom, 0.5, 4.0)
    time.sleep(2.0)  # no cmd_vel: the node's watchdog sends StopMove
    stopped = odom()
    if start and moved and stopped:
        dist = math.dist(start, moved)
        drift = math.dist(moved, stopped)
        step("cmd_vel 0.5 m/s for 4 s", dist > 1.0, f"walked {dist:.2f} m, then {drift:.2f} m more after cmd_vel stopped")
    else:
        step("cmd_vel 0.5 m/s for 4 s", False, "no /g1_sim_bridge/odom from the sim bridge")
    if release:
        r = client.set_mode("low_level")
        step("set_mode low_level (release path: robot goes limp)", r.success, r.message)
        r = client.estop()
        step("E-STOP from LOW_LEVEL (re-select service, then Damp)", r.success, r.message)
    else:
        _user_ctrl_and_back(client, step, odom)
        _policy_walk(client, step, odom)
        _policy_dance(client, step)
        r = client.estop()
        step("E-STOP (Damp verified)", r.success, r.message)
    r = client.set_mode("idle")
    step("set_mode idle after E-STOP is refused", not r.success, r.message)
    return steps_ok


def _drive(client: ManagerClient, odom, vx: float, seconds: float) -> tuple:
    """cmd_vel ``vx`` at 20 Hz for ``seconds``: where the robot was before and after (the sim's odometry)."""
    start = odom()
    t_end = time.monotonic() + seconds
    while time.monotonic() < t_end:
        client.drive(vx)
        time.sleep(0.05)
    return start, odom()


def _user_ctrl_and_back(client: ManagerClient, step, odom) -> None:
    """LOW_LEVEL by user control with no controller: the robot held, then handed back to its own controller when
    ~/lowcmd stays silent (IDLE, standing), then HIGH_LEVEL and walking again."""
    r = client.set_mode("low_level")
    step("set_mode low_level (user control: hand-over frame, fsm 1000 seen; robot held)", r.success, r.message)
    # no ~/lowcmd: the hand-over frame holds the robot for the first frame's grace (user_ctrl_first_frame_s), then
    # the node hands it back
    deadline = time.monotonic() + 5.0
    mode = client.wait_for_mode()
    while (mode is None or mode.name != "IDLE") and time.monotonic() < deadline:
        time.sleep(0.1)
        mode = client.wait_for_mode()
    name = mode.name if mode is not None else "?"
    why = mode.last_error if mode is not None else ""
    step("no ~/lowcmd: robot handed back to its walk-run controller, standing", name == "IDLE", f"{name}: {why}")
    r = client.set_mode("high_level")
    step("set_mode high_level (the robot never went limp)", r.success, r.message)
    start, moved = _drive(client, odom, 0.5, 3.0)
    if start and moved:
        step("walking again after user control", math.dist(start, moved) > 0.5, f"walked {math.dist(start, moved):.2f} m")


def _policy_walk(client: ManagerClient, step, odom) -> None:
    """The locomotion policy in the node's own loop: loaded, shadowed, engaged by user control, driven by cmd_vel,
    disengaged back to the robot's own controller standing."""
    time.sleep(2.5)  # the walk's StopMove and the robot at rest: the user-control entry waits for it
    r = client.load_policy("loco_ppo")
    step("policy load loco_ppo (checked, nothing sent)", r.success, r.message)
    r = client.trigger("policy/shadow")
    step("policy shadow (runs on the live state, nothing sent)", r.success, r.message)
    time.sleep(3.0)
    r = client.trigger("policy/engage", 30.0)
    step("policy engage (user control, blend from the measured pose)", r.success, r.message)
    time.sleep(2.5)  # the blend
    start, moved = _drive(client, odom, 0.5, 4.0)
    if start and moved:
        step("cmd_vel 0.5 m/s for 4 s under the node's policy", math.dist(start, moved) > 1.0,
             f"walked {math.dist(start, moved):.2f} m")
    time.sleep(1.0)
    r = client.trigger("policy/disengage", 30.0)
    step("policy disengage (the robot's own controller takes it back standing)", r.success, r.message)


#: The dance the tour plays a stretch of, and how much of its clip, s.
DANCE = "dance_ppo"
DANCE_STRETCH_S = 20.0


def _policy_dance(client: ManagerClient, step) -> None:
    """A stretch of holosoma's dance (a whole-body tracking policy) in the node's loop: loaded (the action scale its
    model was trained with), shadowed, engaged, played, disengaged back to the robot's own controller standing."""
    time.sleep(2.5)  # the walker's hand-back settles: the user-control entry waits for the robot at rest
    r = client.load_policy(DANCE)
    step(f"policy load {DANCE}", r.success, r.message)
    r = client.trigger("policy/shadow")
    step(f"policy shadow {DANCE}", r.success, r.message)
    time.sleep(1.0)
    r = client.trigger("policy/engage", 30.0)
    step(f"policy engage {DANCE} (user control, the ready pose, then the clip)", r.success, r.message)
    deadline = time.monotonic() + 0.5 + 2.0 + DANCE_STRETCH_S  # the blend, the start hold, the stretch
    while time.monotonic() < deadline and (s := client.policy_status()) is not None and s.phase != "loaded":
        time.sleep(0.5)
    s = client.policy_status()
    dancing = s is not None and s.phase == "running"
    detail = "no ~/policy/status" if s is None else (
        f"{s.progress * 100:.1f} % of the clip, RMS joint error {s.tracking_error_rad:.3f} rad against its reference, "
        f"{sum(s.clamps)} targets clamped at a joint's stop" if dancing else f"{s.phase}: {s.last_fault}")
    step(f"{DANCE_STRETCH_S:g} s of the dance under the node's policy", dancing, detail)
    r = client.trigger("policy/disengage", 30.0)
    step("policy disengage (the robot's own controller takes it back standing)", r.success, r.message)


def _start_console(py: str, port: int, children: list[Child]) -> str | None:
    """The operator console on 127.0.0.1, as the launch files run it; its URL, or None if it did not come up."""
    if port < 0:
        return None
    console = Child("console", [py, "-u", "-m", "g1_mode_manager.console.main", "--ros-args", "-p", f"port:={port}"],
                    "g1_console ready", env={"RMW_IMPLEMENTATION": "rmw_fastrtps_cpp"})
    children.append(console)
    try:
        console.wait_ready(15.0)
    except (RuntimeError, TimeoutError) as exc:
        print(f"WARN the operator console did not start ({exc}); the sim and the node run on without it", flush=True)
        return None
    url = console.ready_line.split("ready:", 1)[1].split()[0]
    print(f"\nOperator console: {url}  (open it in a browser to watch the tour)\n", flush=True)
    return url


def _interrupt(_sig: int, _frame: object) -> None:
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="g1_demo", description=__doc__)
    parser.add_argument("--dds-domain", type=int, default=int(os.environ.get("G1_DDS_DOMAIN", "0")),
                        help="Unitree SDK2 DDS domain of the sim (loopback)")
    parser.add_argument("--speed", type=float, default=1.0, help="sim speed (1 = real time)")
    parser.add_argument("--no-tour", action="store_true", help="skip the scripted tour")
    parser.add_argument("--viewer", action="store_true", help="open MuJoCo's viewer on the sim (needs a display)")
    parser.add_argument("--exit", action="store_true", help="stop after the tour instead of waiting for Ctrl-C")
    parser.add_argument("--console-port", type=int, default=8080,
                        help="port of the operator console on 127.0.0.1 (0: any free port; -1: no console)")
    parser.add_argument("--release", action="store_true",
                        help="LOW_LEVEL by ReleaseMode (the robot limp) instead of user control")
    args = parser.parse_args(argv)
    default_discovery_to_localhost()
    signal.signal(signal.SIGTERM, _interrupt)

    py = sys.executable
    sim = Child("sim", [py, "-u", "-m", "g1_sim.bridge.main", "--speed", str(args.speed),
                        *(["--viewer"] if args.viewer else []), "--ros-args",
                        "-p", f"dds_domain:={args.dds_domain}", "-p", "network_interface:=lo"], "sim_bridge ready")
    children = [sim]
    try:
        sim.wait_ready(60.0)
        # as the launch files run it: odometry on, on Fast DDS whatever the shell exports (node/one_dds_stack.py)
        node = Child("node", [py, "-u", "-m", "g1_mode_manager.node.main", "--ros-args",
                              "-p", f"dds_domain:={args.dds_domain}", "-p", "network_interface:=lo",
                              "-p", "odom_rate_hz:=20.0",
                              "-p", f"low_level_path:={'release' if args.release else 'user_ctrl'}"], "ready in",
                     env={"RMW_IMPLEMENTATION": "rmw_fastrtps_cpp"})
        children.append(node)
        node.wait_ready(30.0)
        console_url = _start_console(py, args.console_port, children)
        ok = True
        with ManagerClient() as client:
            if not args.no_tour:
                ok = scripted_tour(client, release=args.release)
        print("\nThe simulated G1 and the mode manager are running. In another terminal:\n"
              "  .venv/bin/g1ctl mode --watch\n  .venv/bin/g1ctl set-mode high_level\n  .venv/bin/g1ctl loco start\n"
              "  .venv/bin/g1ctl drive\n  .venv/bin/g1ctl estop\n", flush=True)
        if console_url:
            print(f"Operator console: {console_url}" + ("" if args.no_tour else "  (the tour ended in EMERGENCY; to drive "
                  "from the console, start without it: .venv/bin/g1_demo --no-tour)") + "\n", flush=True)
        if args.exit:
            return 0 if ok else 1
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        return 0
    finally:
        for child in reversed(children):
            child.stop()


if __name__ == "__main__":
    sys.exit(main())
