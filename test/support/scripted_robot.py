"""A scripted G1 protocol peer for adapter tests: the SDK's real ``Server`` for "sport" and "motion_switcher".

Not the simulator: no physics, just the services' protocol with behaviour from a JSON script, every
request and frame it receives logged as a JSON line on stdout (``event`` = ready | request | frame),
with ``t`` = ``time.monotonic()`` (system-wide on Linux, so comparable with the test's clock).

Run ``python scripted_robot.py '<json>'`` (``start_scripted_robot`` does it as a ManagedProcess). Script keys:
  domain (required)     SDK DDS domain, on loopback ("lo", no multicast)
  mode, form            motion switcher's active service name ('' = released) and form ("ai", "0")
  fsm_id, fsm_mode      loco state reported by getters and rt/sportmodestate (1, 0)
  codes                 {api_id: code}: reply code per api id (default 0)
  delays                {api_id: s}: the handler sleeps this long before replying
  replies               {api_id: data}: raw reply data per api id, replacing the modelled one
  lowstate_hz           publish rt/lowstate at this rate (0 = never), with ``mode_machine`` (5)
  sportmodestate_hz     publish rt/sportmodestate at this rate (0 = never)
  record_frames         log each rt/lowcmd and rt/arm_sdk frame, its CRC checked with the SDK's CRC
While released (mode ''), every sport api answers 3203, as the robot's sport service does in debug mode.
"""

from __future__ import annotations

import json
import os
import sys
import threading
import time
from pathlib import Path
from typing import Any

if __package__ in (None, ""):  # run by path: make ``support`` importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from support.processes import ManagedProcess

RELEASED_CODE = 3203
#: q of motor i in the published rt/lowstate, so a test can check joint_positions().
LOWSTATE_Q0, LOWSTATE_DQ = 0.1, 0.01


def lowstate_q(i: int) -> float:
    return LOWSTATE_Q0 + LOWSTATE_DQ * i


def start_scripted_robot(script: dict[str, Any], timeout_s: float = 20.0) -> ManagedProcess:
    """Start the scripted robot and wait for its ``ready`` line (servers started, writers created)."""
    argv = [sys.executable, "-u", str(Path(__file__).resolve()), json.dumps(script)]
    proc = ManagedProcess(argv, name="scripted_robot", env={"PYTHONUNBUFFERED": "1"})
    try:
        proc.wait_for_line(lambda line: '"event": "ready"' in line, timeout_s)
    except BaseException:
        proc.stop()
        raise
    return proc


def events(proc: ManagedProcess, kind: str, **match: Any) -> list[dict[str, Any]]:
    """The logged events of one kind (and matching fields) so far, in order."""
    found = []
    for line in proc.output().splitlines():
        if not line.startswith("{"):
            continue
        try:
            event = json.loads(line)
        except ValueError:
            continue
        if event.get("event") == kind and all(event.get(k) == v for k, v in match.items()):
            found.append(event)
    return found


def wait_event(proc: ManagedProcess, kind: str, timeout_s: float = 5.0, count: int = 1,
               **match: Any) -> list[dict[str, Any]]:
    """Wait until at least ``count`` matching events were logged; returns them all. TimeoutError if not."""
    deadline = time.monotonic() + timeout_s
    while True:
        found = events(proc, kind, **match)
        if len(found) >= count:
            return found
        if time.monotonic() > deadline:
            raise TimeoutError(f"{count} {kind} {match} not logged in {timeout_s} s; output:\n{proc.output()}")
        time.sleep(0.02)


# --- the robot side (runs in the subprocess) ---------------------------------------------------------
class _Log:
    def __init__(self) -> None:
        self._lock = threading.Lock()

    def __call__(self, event: str, **fields: Any) -> None:
        line = json.dumps({"event": event, "t": time.monotonic(), **fields})
        with self._lock:
            sys.stdout.write(line + "\n")
            sys.stdout.flush()


class _Robot:
    """The scripted state: motion switcher mode, loco values, per-api codes/delays/replies."""

    def __init__(self, script: dict[str, Any]) -> None:
        self.lock = threading.Lock()
        self.mode = str(script.get("mode", "ai"))
        self.form = str(script.get("form", "0"))
        self.silent = False
        self.values = {7001: int(script.get("fsm_id", 1)), 7002: int(script.get("fsm_mode", 0)), 7003: 0,
                       7004: 0.09, 7005: 0.75, 7006: [0.0, 0.0]}
        self.codes = {int(k): int(v) for k, v in script.get("codes", {}).items()}
        self.delays = {int(k): float(v) for k, v in script.get("delays", {}).items()}
        self.replies = {int(k): str(v) for k, v in script.get("replies", {}).items()}

    def _scripted(self, api_id: int) -> int:
        delay = self.delays.get(api_id, 0.0)
        if delay > 0:
            time.sleep(delay)
        return self.codes.get(api_id, 0)

    def loco(self, api_id: int, parameter: str) -> tuple[int, str]:
        code = self._scripted(api_id)
        with self.lock:
            if self.mode == "":
                return RELEASED_CODE, ""
            if code != 0:
                return code, ""
            if api_id in self.replies:
                return 0, self.replies[api_id]
            if api_id < 7100:
                return 0, json.dumps({"data": self.values[api_id]})
            setters = {7101: 7001, 7102: 7003, 7103: 7004, 7104: 7005}
            if api_id in setters:
                self.values[setters[api_id]] = json.loads(parameter)["data"]
            return 0, ""

    def switcher(self, api_id: int, parameter: str) -> tuple[int, str]:
        code = self._scripted(api_id)
        if code != 0:
            return code, ""
        with self.lock:
            if api_id in self.replies:
                return 0, self.replies[api_id]
            if api_id == 1001:
                return 0, json.dumps({"form": self.form, "name": self.mode})
            if api_id == 1002:
                self.mode = json.loads(parameter)["name"]
            elif api_id == 1003:
                self.mode = ""
            elif api_id == 1004:
                self.silent = bool(json.loads(parameter)["silent"])
            elif api_id == 1005:
                return 0, json.dumps({"silent": self.silent})
            return 0, ""


def _serve(script: dict[str, Any]) -> None:
    from unitree_sdk2py.core.channel import ChannelPublisher, ChannelSubscriber
    from unitree_sdk2py.idl.default import unitree_hg_msg_dds__LowState_
    from unitree_sdk2py.rpc.server import Server
    from unitree_sdk2py.utils.crc import CRC

    from g1_mode_manager.protocol import api_ids as api
    from g1_mode_manager.protocol import topics
    from g1_mode_manager.protocol.crc import lowstate_crc
    from g1_mode_manager.protocol.dds import init_channels
    from g1_mode_manager.protocol.idl import LowCmd_, LowState_, SportModeState_
    from g1_mode_manager.protocol.side_by_side import side_by_side

    log = _Log()
    robot = _Robot(script)
    init_channels(int(script["domain"]), "lo")

    class LoggingServer(Server):
        """The SDK's Server, logging each request (id, api, parameter, no-reply flag) as it is taken."""

        def Start(self, enablePrioQueue: bool = False) -> None:  # noqa: N803 - the SDK's signature
            inner = self._Server__ServerRequestHandler
            service = self.GetName()

            def handle(request: Any) -> None:
                identity = request.header.identity
                log("request", service=service, api_id=int(identity.api_id), id=int(identity.id),
                    parameter=request.parameter, noreply=bool(request.header.policy.noreply))
                inner(request)

            self._SetServerRequestHandler(handle)
            self._Start(enablePrioQueue)

    servers = []
    for service, version, ids, handler in (
        (api.LOCO_SERVICE, api.LOCO_API_VERSION, api.LOCO_GET_APIS + api.LOCO_SET_APIS, robot.loco),
        (api.MOTION_SWITCHER_SERVICE, api.MOTION_SWITCHER_API_VERSION, range(1001, 1006), robot.switcher),
    ):
        server = LoggingServer(service)
        server._SetApiVersion(version)
        for api_id in ids:
            server._RegistHandler(api_id, lambda p, a=api_id, h=handler: h(a, p), False)
        servers.append(server)
    side_by_side(*(lambda server=server: server.Start(False) for server in servers))  # their SDK sleeps overlap

    subscribers = []
    if script.get("record_frames"):
        crc = CRC()

        def recorder(topic: str) -> Any:
            def on_frame(msg: LowCmd_) -> None:
                m = msg.motor_cmd
                log("frame", topic=topic, crc_ok=crc.Crc(msg) == msg.crc, mode_pr=msg.mode_pr,
                    mode_machine=msg.mode_machine, mode=[c.mode for c in m], q=[c.q for c in m],
                    dq=[c.dq for c in m], tau=[c.tau for c in m], kp=[c.kp for c in m], kd=[c.kd for c in m])
            return on_frame

        for topic in (topics.LOWCMD, topics.ARM_SDK):
            sub = ChannelSubscriber(topic, LowCmd_)
            sub.Init(recorder(topic), 0)
            subscribers.append(sub)

    stop = threading.Event()
    threads = []
    if float(script.get("lowstate_hz", 0)) > 0:
        lowstate_pub = ChannelPublisher(topics.LOWSTATE, LowState_)
        lowstate_pub.Init()

        def publish_lowstate(period: float = 1.0 / float(script["lowstate_hz"])) -> None:
            msg = unitree_hg_msg_dds__LowState_()
            msg.mode_machine = int(script.get("mode_machine", 5))
            for i, motor in enumerate(msg.motor_state):
                motor.q = lowstate_q(i)
            while not stop.wait(period):
                msg.tick += 1
                msg.crc = lowstate_crc(msg)
                lowstate_pub.Write(msg)

        threads.append(threading.Thread(target=publish_lowstate, daemon=True))
    if float(script.get("sportmodestate_hz", 0)) > 0:
        sport_pub = ChannelPublisher(topics.SPORTMODESTATE, SportModeState_)
        sport_pub.Init()

        def publish_sport(period: float = 1.0 / float(script["sportmodestate_hz"])) -> None:
            while not stop.wait(period):
                with robot.lock:
                    fsm_id, fsm_mode = int(robot.values[7001]), int(robot.values[7002])
                sport_pub.Write(SportModeState_(fsm_id=fsm_id, fsm_mode=fsm_mode, task_id=0, task_time=0.0))

        threads.append(threading.Thread(target=publish_sport, daemon=True))
    for thread in threads:
        thread.start()
    log("ready", pid=os.getpid())
    try:
        while True:
            time.sleep(3600)
    except KeyboardInterrupt:
        stop.set()
    os._exit(0)  # skip DDS teardown in interpreter shutdown: the test only needs the process gone


if __name__ == "__main__":
    _serve(json.loads(sys.argv[1]))
