"""``sim_bridge``: the MuJoCo G1 behind the robot's own Unitree SDK2 DDS interface, plus a ROS 2 node.

    sim_bridge [--speed X] [--domain N] [--interface lo] [--faults JSON] [--gantry] [--soc PERCENT]
               [--user-ctrl none|from_damp|from_walkrun|either] [--boot-posture standing|squat|lying]
               [--record FILE] [--ros-args -p "faults:='{...}'"]

ROS parameter values are YAML, so a JSON faults value needs YAML quotes inside the shell's:
``--ros-args -p "faults:='{\"drop\": [7101]}'"``.

Prints ``sim_bridge ready`` once every service and topic is up. SIGINT/SIGTERM stop it cleanly (exit 0).
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import signal
import sys
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from g1_sim.bridge.record import record_state
from g1_sim.firmware.user_ctrl import DEFAULT_OPTION, UserCtrlOption
from g1_sim.physics.battery import START_SOC
from g1_sim.physics.boot_posture import BootPosture

READY_LINE = "sim_bridge ready"
EXIT_BAD_CONFIG = 2
EXIT_FAILED = 1

log = logging.getLogger("g1_sim.bridge")


def parse_cli(argv: Sequence[str]) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="sim_bridge", description=__doc__.split("\n\n")[0])
    p.add_argument("--speed", type=float, help="sim time per wall time (1 real time, 0 as fast as possible)")
    p.add_argument("--domain", type=int, help="Unitree SDK2 DDS domain id (parameter dds_domain)")
    p.add_argument("--interface", help="network interface of the DDS domain (parameter network_interface)")
    p.add_argument("--faults", help="faults JSON (parameter faults)")
    p.add_argument("--no-ros-publish", action="store_true", help="do not publish joint_states, ~/odom, /clock")
    p.add_argument("--assets", help="simulation assets folder (default: the installed ones)")
    p.add_argument("--seed", type=int, default=0, help="seed of the simulation's random numbers")
    p.add_argument("--record", help="append every request, frame and state change the robot saw to this JSONL file")
    p.add_argument("--gantry", action="store_true",
                   help="hang the pelvis from a gantry's elastic band (parameter gantry, switchable at run time)")
    p.add_argument("--soc", type=float, default=START_SOC, help=f"battery charge at start, %% (default {START_SOC:g})")
    p.add_argument("--user-ctrl", choices=[o.value for o in UserCtrlOption], default=DEFAULT_OPTION.value,
                   help="the firmware's SwitchToUserCtrl (sport 7110): where it is accepted, or 'none' (3203, older "
                        f"firmware); fault key user_ctrl changes it at run time (default {DEFAULT_OPTION.value})")
    p.add_argument("--boot-posture", choices=[b.value for b in BootPosture], default=BootPosture.STANDING.value,
                   help="how the robot starts, and comes back after a reset: standing in lock stand (fsm 4), or "
                        "folded in a squat or lying on its back, damped (fsm 1): the vendor's power-on flows "
                        f"(default {BootPosture.STANDING.value})")
    p.add_argument("--viewer", action="store_true",
                   help="MuJoCo's passive viewer with the head LED drawn (needs a display; headless: a warning)")
    args = p.parse_args(list(argv))
    if args.speed is not None and args.speed < 0:
        p.error("--speed must be >= 0")
    if not 0.0 <= args.soc <= 100.0:
        p.error("--soc must be within 0..100")
    return args


def _overrides(args: argparse.Namespace) -> dict[str, object]:
    given = {"speed": args.speed, "dds_domain": args.domain, "network_interface": args.interface,
             "faults": args.faults}
    out: dict[str, object] = {k: v for k, v in given.items() if v is not None}
    if args.no_ros_publish:
        out["publish_ros"] = False
    if args.gantry:
        out["gantry"] = True
    return out


class _Stop:
    """Set by SIGINT/SIGTERM; the main thread polls it."""

    def __init__(self) -> None:
        self.event = threading.Event()

    def install(self) -> None:
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, lambda *_: self.event.set())


def main(argv: Sequence[str] | None = None) -> int:
    logging.basicConfig(level=logging.INFO, format="[%(name)s] %(levelname)s: %(message)s", stream=sys.stderr)
    stop = _Stop()
    stop.install()
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.signals import SignalHandlerOptions
    from rclpy.utilities import remove_ros_args

    args_in = list(sys.argv if argv is None else ["sim_bridge", *argv])
    try:
        rclpy.init(args=args_in, signal_handler_options=SignalHandlerOptions.NO)
    except RuntimeError as e:  # RCLError: malformed --ros-args (e.g. an unquoted JSON value)
        log.error("bad ROS arguments: %s", e)
        return EXIT_BAD_CONFIG
    args = parse_cli(remove_ros_args(args_in)[1:])
    node = executor = spin = bridge = viewer = None
    code = 0
    try:
        from g1_sim.bridge.faults import FaultConfigError
        from g1_sim.bridge.ros_face import BridgeNode

        node = BridgeNode(overrides=_overrides(args))
        try:
            bridge = Bridge(node, assets=args.assets, seed=args.seed, stop=stop.event, record=args.record,
                            soc=args.soc, user_ctrl=args.user_ctrl, boot_posture=args.boot_posture)
        except FaultConfigError as e:
            node.get_logger().error(f"bad faults parameter: {e}")
            return EXIT_BAD_CONFIG
        if stop.event.is_set():
            return 0
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        spin = threading.Thread(target=executor.spin, name="ros_spin", daemon=True)
        spin.start()
        bridge.start()
        if args.viewer:
            from g1_sim.bridge.viewer import Viewer

            viewer = Viewer(bridge.robot, lambda: list(bridge.voice.led))
            viewer.start()
        print(READY_LINE, flush=True)
        while not stop.event.wait(0.2):
            if not bridge.loop.running:
                log.error("sim loop stopped: %r", bridge.loop.error)
                code = EXIT_FAILED
                break
    finally:
        if viewer is not None:
            viewer.stop()
        if bridge is not None:
            bridge.shutdown()
            summary = {k: v for k, v in bridge.status().items() if k in ("sim_time", "requests", "frames", "published")}
            print(f"sim_bridge final {json.dumps(summary)}", flush=True)
        if executor is not None:
            executor.shutdown()
        if spin is not None:
            spin.join(5.0)
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return code


class Bridge:
    """Everything but the ROS executor: the robot, its RPC services, topics and the sim thread."""

    def __init__(self, node: Any, *, assets: str | None, seed: int, stop: threading.Event,
                 record: str | None = None, soc: float = START_SOC,
                 user_ctrl: str = DEFAULT_OPTION.value, boot_posture: str = BootPosture.STANDING.value) -> None:
        from g1_mode_manager.protocol import api_ids as api
        from g1_mode_manager.protocol.dds import init_channels
        from g1_mode_manager.protocol.side_by_side import side_by_side
        from g1_sim.bridge.clock import Pacer, StampClock
        from g1_sim.bridge.commands import USER_LOWCMD, CommandIntake
        from g1_sim.bridge.faults import FaultConfig, Faults, parse_faults
        from g1_sim.bridge.record import Recorder
        from g1_sim.bridge.rpc_services import (
            RequestCounter,
            SimServer,
            arm_action_handlers,
            motion_switcher_handlers,
            sport_handlers,
        )
        from g1_sim.bridge.sim_loop import SimLoop
        from g1_sim.bridge.status import STATUS_API_VERSION, STATUS_SERVICE, status_handlers
        from g1_sim.bridge.streams import CommandSubscribers, StatePublishers
        from g1_sim.bridge.swap import RobotSlot
        from g1_sim.bridge.voice import VoiceState, voice_handlers
        from g1_sim.firmware import SimG1

        p = node.params()
        self.faults = Faults(parse_faults(p.faults))
        self.pacer = Pacer(p.speed)
        node.on_faults = self.faults.set_json
        node.on_speed = self.pacer.set_speed
        node.on_gantry = self.set_gantry
        self._faults_cleared: Callable[[], None] = node.faults_cleared
        t0 = time.monotonic()
        self._gantry = p.gantry  # a rig setting: a reset keeps it
        self._user_ctrl = user_ctrl  # the firmware option unless the faults' user_ctrl says otherwise
        self._boot_posture = BootPosture(boot_posture)  # where a reset starts the robot again
        self._make_robot = lambda: SimG1(assets, seed=seed, start_soc=soc, gantry=self._gantry, user_ctrl=user_ctrl,
                                         start_posture=self._boot_posture)
        self.robot = RobotSlot(self._make_robot())  # every part holds the slot, so reset() can swap the robot
        log.info("robot ready in %.1f s (dt %.4f s)", time.monotonic() - t0, self.robot.dt)
        init_channels(p.dds_domain, p.network_interface, serve_multicast=True)  # found by every kind of client
        self.record = Recorder(record)
        if self._gantry:
            self.record.event("gantry", on=True)
        self._faults_changed(FaultConfig(), self.faults.config)  # --faults: keys held, a push, recorded
        self.faults.on_change = self._faults_changed
        self.requests = RequestCounter()
        hooks = {"on_received": self._received, "on_handled": self._handled} if self.record.enabled else {}
        self.servers = [
            SimServer(api.LOCO_SERVICE, api.LOCO_API_VERSION, sport_handlers(self.robot, self.faults),
                      faults=self.faults, counter=self.requests, **hooks),
            SimServer(api.MOTION_SWITCHER_SERVICE, api.MOTION_SWITCHER_API_VERSION,
                      motion_switcher_handlers(self.robot), faults=self.faults, counter=self.requests, **hooks),
            # arm actions: counted, not faulted or recorded (its ids overlap the sport service's 7106/7107)
            SimServer(api.ARM_SERVICE, api.ARM_API_VERSION, arm_action_handlers(self.robot), counter=self.requests),
            SimServer(STATUS_SERVICE, STATUS_API_VERSION, status_handlers(self.status, self.reset)),
        ]
        # voice (head LED, TTS): counted, but neither faulted nor recorded: its api ids overlap the motion
        # switcher's (1001..1005), and the record and faults are about the robot's motion services
        self.voice = VoiceState()
        self.servers.append(SimServer(api.VOICE_SERVICE, api.VOICE_API_VERSION, voice_handlers(self.voice),
                                      counter=self.requests))
        self._record_state()
        if not stop.is_set():
            side_by_side(*(server.Start for server in self.servers))  # five SDK stub sleeps overlapping
        self.publishers = StatePublishers()
        self._user_lowcmd_topic = USER_LOWCMD
        frame_hook = self._frame if self.record.enabled else None
        self.intake = CommandIntake(self.robot, on_frame=frame_hook)
        self.subscribers = CommandSubscribers(self.intake, on_drop=self._dropped if self.record.enabled else None)
        self.loop = SimLoop(self.robot, self.publishers, self.faults, self.pacer, node=node, stamps=StampClock(),
                            on_body=self._body if self.record.enabled else None,
                            on_odom=self._odom if self.record.enabled else None,
                            sport_state=self._record_state if self.record.enabled else None,
                            frames_within=self.intake.frames_within)
        self._params = p

    def start(self) -> None:
        self.loop.start()

    def shutdown(self) -> None:
        self.loop.stop()
        self.subscribers.stop()
        for server in self.servers:
            server.cancel_delayed()
        self.record.close()

    def reset(self) -> None:
        """Back to the boot state: a fresh robot ("ai" selected; standing, or as --boot-posture put it), no faults,
        nothing delayed in flight."""
        from g1_sim.bridge.faults import FaultConfig

        for server in self.servers:
            server.cancel_delayed()
        self.faults.set(FaultConfig())
        self._faults_cleared()
        self.robot.swap(self._make_robot())
        self.pacer.set_speed(self.pacer.speed)  # sim time restarts: pace from here
        self.record.reset()
        self._record_state()

    # --- the body: injections and the gantry --------------------------------------------------------
    def _faults_changed(self, old: Any, new: Any) -> None:
        """Hand the body's injections to the robot (keys held, a push) and record every change."""
        self.robot.set_remote_keys(new.remote_keys)
        if (new.odom, new.seed) != (old.odom, old.seed):
            self.robot.set_odometry_errors(new.odom, new.seed)
        if new.push is not None:
            self.robot.push(new.push.force_xy, new.push.duration_s)
        if new.runaway_motor is not None:
            r = new.runaway_motor
            self.robot.run_away(r.motor, r.direction, r.duration_s)
        if (new.user_ctrl, new.user_ctrl_delay_s) != (old.user_ctrl, old.user_ctrl_delay_s):
            self.robot.set_user_ctrl(new.user_ctrl or self._user_ctrl, new.user_ctrl_delay_s)
        self._record_injections(old, new)

    def _record_injections(self, old: Any, new: Any) -> None:
        """One ``inject`` event per fault key that changed (``on``: it differs from no fault), and per push or
        runaway (each setting acts once)."""
        from g1_sim.bridge.faults import FaultConfig

        before, after, none = old.to_json(), new.to_json(), FaultConfig().to_json()
        for key, value in after.items():
            if value != before[key] or (key in ("push", "runaway_motor") and value is not None):
                self.record.event("inject", what=key, on=value != none[key], value=value)

    def set_gantry(self, on: bool) -> None:
        """Hook the pelvis to the gantry's band (anchored above where it is now) or unhook it."""
        self._gantry = on
        self.robot.set_gantry(on)
        self.record.event("gantry", on=on)

    # --- the robot's record ---------------------------------------------------------------------------
    def _received(self, service: str, api_id: int, parameter: str, noreply: bool, at: float | None,
                  request_id: int) -> None:
        self.record.event("req", at=at, svc=service, api=api_id, p=parameter, noreply=noreply, id=request_id)

    def _handled(self, service: str, api_id: int, parameter: str, code: int) -> None:
        self.record.event("done", svc=service, api=api_id, p=parameter, code=code)
        self._record_state()

    def _frame(self, topic: str, why: str | None, weight: float, kp_max: float, crc: str, at: float | None,
               n: int | None, written: float | None = None, past: float = 0.0) -> None:
        applied = time.monotonic()
        if topic == self._user_lowcmd_topic:  # the switch to fsm 1000 is on the record before any user frame it let through
            self._record_state()
        self.record.event("frame", at=at, topic=topic, n=n, ok=why is None, why=why, w=weight, kp_max=kp_max, crc=crc,
                          src=None if written is None else round(written, 6), ap=round(applied, 6),
                          past=round(past, 4) if math.isfinite(past) else None)

    def _dropped(self, topic: str, first: int, count: int) -> None:
        """Frames that reached the sim and were never looked at: the record is not complete, and says so."""
        self.record.event("drop", topic=topic, n=first, count=count)

    def _body(self, sim_time: float, s: Any, report: Any) -> None:
        """The record's ``body`` event (every 10 ms of sim time): what a body supervisor's checks read."""
        from g1_sim.firmware.state import tilt_rad

        z = float(self.robot.base_pose().position[2])
        self.record.event("body", st=round(sim_time, 3), tilt=round(tilt_rad(s.imu_quaternion), 4),
                          gyro=round(float(np.abs(s.imu_gyroscope).max()), 3), dq=round(float(np.abs(s.dq).max()), 3),
                          winding=round(report.hottest_winding_c, 2), casing=round(report.hottest_casing_c, 2),
                          soc=round(report.battery.soc, 3), z=round(z, 4))
        self._record_state()  # a change without a request (the remote's Damp) is recorded within 10 ms too

    def _odom(self, sim_time: float, o: Any) -> None:
        """The record's ``odom`` event (every rt/lf/odommodestate sample): the estimate as published (float32)
        and the truth."""
        est = np.array([o.position[0], o.position[1], o.rpy[2], o.velocity[0], o.velocity[1], o.yaw_speed],
                       dtype=np.float32).tolist()
        x, y, yaw, vx, vy, wz = (round(v, 6) for v in est)
        self.record.event("odom", st=round(sim_time, 3), x=x, y=y, yaw=yaw, vx=vx, vy=vy, wz=wz,
                          true_x=round(float(o.true_position[0]), 6), true_y=round(float(o.true_position[1]), 6),
                          true_yaw=round(float(o.true_yaw), 6))

    def _record_state(self) -> tuple[int, int]:
        # one robot for the whole read, though a reset may swap the slot meanwhile
        return record_state(self.record, self.robot.current)

    def status(self) -> dict[str, Any]:
        """Counters, sport state, base pose and real-time factor (the g1_sim status service's reply)."""
        robot = self.robot
        fsm_id, fsm_mode = robot.sport_state()
        form, name = robot.check_mode()
        b = robot.base_pose()
        return {
            "sim_time": robot.time,
            "boot_posture": self._boot_posture.value,
            "speed": self.pacer.speed,
            "real_time_factor": self.loop.rate.real_time_factor,
            "mean_real_time_factor": self.loop.rate.mean_real_time_factor,
            "sport": {"fsm_id": fsm_id, "fsm_mode": fsm_mode, "active": robot.sport_active(), "mode": name,
                      "form": form, "task": list(robot.arm_task())},
            "base": {"position": b.position.tolist(), "quaternion": b.quaternion.tolist(),
                     "linear_velocity": b.linear_velocity.tolist(),
                     "angular_velocity": b.angular_velocity.tolist()},
            "requests": self.requests.snapshot(),
            "recent_requests": self.requests.recent(),
            "frames": self.intake.counts(),
            "frame_readers": self.subscribers.stats(),
            "published": self.publishers.counts(),
            "readers": self.publishers.readers(),
            "firmware": dict(getattr(robot, "counters", {})),
            "faults": self.faults.config.to_json(),
            "damp_fails_left": self.faults.damp_fails_left,
            "voice": self.voice.status(),
            "body": self._body_status(),
            **self._user_ctrl_status(),
        }

    def _user_ctrl_status(self) -> dict[str, Any]:
        """``user_ctrl`` (fsm 1000 in force), ``user_ctrl_switching`` (7110 accepted, its delay running),
        ``user_ctrl_option`` (the firmware option now) and ``user_ctrl_delay_s``."""
        uc = self.robot.user_ctrl_status()
        return {"user_ctrl": uc["user_ctrl"], "user_ctrl_switching": uc["switching"],
                "user_ctrl_option": uc["option"], "user_ctrl_delay_s": uc["delay_s"]}

    def _body_status(self) -> dict[str, Any]:
        """Hottest winding and casing, soc (as the robot reports them, injections included), tilt, gantry."""
        from g1_sim.firmware.state import tilt_rad

        report = self.loop.body if hasattr(self, "loop") else None
        pose = self.robot.base_pose()
        out: dict[str, Any] = {"tilt": tilt_rad(pose.quaternion), "pelvis_z": float(pose.position[2]),
                               "gantry": self.robot.gantry, "posture": self.robot.posture.value}
        if report is not None:
            b = report.battery
            out |= {"winding_c": report.hottest_winding_c, "casing_c": report.hottest_casing_c, "soc": b.soc,
                    "pack_v": b.pack_v, "current_a": b.current_a, "power_w": b.power_w,
                    "remote_keys": sorted(report.remote_keys)}
        return out


if __name__ == "__main__":
    sys.exit(main())
