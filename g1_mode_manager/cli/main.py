"""g1ctl: set modes, e-stop, send loco commands, hand the robot to the autonomy and take it back, drive with the
keyboard, watch the mode, list the flight recorder's incidents."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from g1_mode_manager.cli.client import ManagerClient, default_discovery_to_localhost
from g1_mode_manager.cli.incidents import print_incidents
from g1_mode_manager.core.loco_verbs import LOCO_VERBS
from g1_mode_manager.core.recorder.incidents import folder_for

POLICY_VERBS = ("load", "shadow", "engage", "disengage", "hold", "unload")


def _print_mode(msg) -> None:
    extra = f" -> {msg.transition_target}" if msg.transition_in_progress else ""
    service = "unknown" if not msg.high_level_service_known else ("active" if msg.high_level_service_active else "released")
    line = f"{msg.name}{extra}  service={service}  link_ok={msg.link_ok}  driver={msg.driver}"
    if msg.autonomy_suspended:
        line += f"  autonomy={msg.autonomy_suspended!r}"
    if msg.name == "EMERGENCY":
        line += f"  damp_confirmed={msg.damp_confirmed}"
    if msg.last_refusal:
        line += f"  last_refusal={msg.last_refusal!r}"
    print(line, flush=True)


#: How long `g1ctl incidents` waits for the node to name its incident folder, s.
INCIDENTS_ASK_S = 10.0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="g1ctl", description=__doc__)
    parser.add_argument("--manager", default="/g1_mode_manager", help="the mode manager node (default %(default)s)")
    sub = parser.add_subparsers(dest="cmd", required=True)
    p = sub.add_parser("mode", help="print the current mode (--watch: every update)")
    p.add_argument("--watch", action="store_true")
    p = sub.add_parser("set-mode", help="request a mode: idle, high_level, low_level, emergency")
    p.add_argument("name")
    sub.add_parser("estop", help="emergency stop (Damp); the mode stays EMERGENCY")
    p = sub.add_parser("loco", help=f"built-in controller command: {', '.join(LOCO_VERBS)}")
    p.add_argument("command")
    ranges = ", ".join(f"{name} {v.values.start}..{v.values.stop - 1}" for name, v in LOCO_VERBS.items() if v.values)
    p.add_argument("value", nargs="?", type=int, default=0,
                   help=f"{ranges} (shake_hand 0 holds the hand out, 1 withdraws it)")
    sub.add_parser("recover", help="a robot on the floor or folded in a squat up again: HIGH_LEVEL if needed, damp, "
                                   "lie_to_stand or squat_to_stand by its posture, balance_stand, each verified on "
                                   "the robot (from IDLE or HIGH_LEVEL; an e-stop ends it)")
    sub.add_parser("hand-over", help="HIGH_LEVEL: the autonomy (a planner on cmd_vel_nav) drives, within its own "
                                     "limits, until a teleop command or take-over")
    sub.add_parser("take-over", help="the teleop (cmd_vel) drives again; the autonomy's Moves stop")
    sub.add_parser("drive", help="keyboard teleop on <namespace of --manager>/cmd_vel")
    p = sub.add_parser("policy", help="a policy in the node's loop (docs/policies.md): load [NAME|PATH.yaml], "
                                      "shadow, engage, disengage, hold, unload")
    p.add_argument("verb", choices=POLICY_VERBS)
    p.add_argument("policy", nargs="?", default="", help="load: a built-in name or a deploy config's path; "
                                                         "default the node's parameter `policy`")
    p = sub.add_parser("incidents", help="the flight recorder's incident files (docs/recorder.md): when, mode, cause")
    p.add_argument("--dir", type=Path, default=None,
                   help="the folder (default: the running node's recorder_dir, else the recorder's default folder)")
    args = parser.parse_args(argv)

    if args.cmd == "incidents" and args.dir is not None:  # nothing to ask the node
        return print_incidents(args.dir)
    default_discovery_to_localhost()
    with ManagerClient(args.manager) as client:
        try:
            return _run(args, client)
        except TimeoutError as exc:
            print(f"g1ctl: {exc}", file=sys.stderr)
            return 3
        except KeyboardInterrupt:
            return 130


def _run(args: argparse.Namespace, client: ManagerClient) -> int:
    if args.cmd == "mode":
        if args.watch:
            client.on_mode(_print_mode)
            import time

            while True:
                time.sleep(1.0)
        msg = client.wait_for_mode()
        if msg is None:
            print("g1ctl: no ~/mode received: is the mode manager running?", file=sys.stderr)
            return 3
        _print_mode(msg)
        return 0
    if args.cmd == "incidents":
        # the node's answer names its folder; a node just started or a loaded machine may take seconds to answer
        folder = client.parameter("recorder_dir", timeout_s=INCIDENTS_ASK_S)
        if folder is None:
            print(f"g1ctl: the mode manager did not say its recorder_dir within {INCIDENTS_ASK_S:g} s (is it "
                  f"running?): listing the default folder", file=sys.stderr)
        return print_incidents(folder_for(str(folder or "")))
    if args.cmd == "set-mode":
        r = client.set_mode(args.name)
        print(f"success={r.success} mode={r.mode_name}: {r.message}")
        return 0 if r.success else 1
    if args.cmd == "estop":
        r = client.estop()
        print(f"success={r.success}: {r.message}")
        return 0 if r.success else 1
    if args.cmd in ("hand-over", "take-over"):
        r = client.trigger("hand_over_to_autonomy" if args.cmd == "hand-over" else "take_over")
        print(f"success={r.success}: {r.message}")
        return 0 if r.success else 1
    if args.cmd == "policy":
        timeout_s = 60.0  # engage and disengage wait for the robot's switch, like set-mode
        r = (client.load_policy(args.policy) if args.verb == "load"
             else client.trigger(f"policy/{args.verb}", timeout_s))
        print(f"success={r.success}: {r.message}")
        return 0 if r.success else 1
    if args.cmd == "loco":
        r = client.loco(args.command, args.value)
        outcome = f" outcome after {r.outcome_s:.2f} s" if r.outcome_s >= 0.0 else ""
        print(f"success={r.success} code={r.code}{outcome}: {r.message}")
        return 0 if r.success else 1
    if args.cmd == "recover":
        from g1_mode_manager.core.recovery import recover

        client.wait_for_mode()
        results = recover(client, on_step=lambda r: print(
            f"{r.step}: success={r.success} after {r.took_s:.2f} s: {r.message}", flush=True))
        failed = [r for r in results if not r.success]
        print(f"recover: failed at {failed[0].step}" if failed else "recover: the robot stands")
        return 1 if failed else 0
    from g1_mode_manager.cli.keyboard import run_keyboard

    return run_keyboard(client)


if __name__ == "__main__":
    sys.exit(main())
