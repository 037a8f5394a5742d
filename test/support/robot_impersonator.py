"""A G1 impersonated on the robot's own DDS stack: run it with ``.venv-cyclone010/bin/python`` (Cyclone 0.10.2).

Nothing of this project is imported: only the Unitree SDK2 Python code, its ``Server`` class for the
``sport`` and ``motion_switcher`` services, and its publishers for ``rt/lowstate`` and
``rt/sportmodestate``, initialised the SDK's own way (``ChannelFactoryInitialize(DOMAIN, "lo")``) and
with no type fix: the types are described as the robot's Cyclone 0.10 describes them. A node that works
against this works against the robot's DDS, down to the type identifiers and discovery.

Behind the services is a minimal fake firmware: the selected service ("ai" at boot, "" after ReleaseMode,
when sport answers 3203), the fsm id (4 at boot; SelectMode comes back in 0, as the robot does) and
fsm_mode (1 while a non-zero Move is running in a walking fsm). Every request is printed as a JSON line
``{"event": "request", "t", "svc", "api", "p"}`` and every state change as ``{"event": "state", "fsm", "svc"}``;
``{"event": "ready"}`` once the servers and writers are up.

    python robot_impersonator.py DOMAIN

(No ``from __future__ import annotations`` here: cyclonedds resolves the IDL field types at run time.)
"""

import json
import sys
import threading
import time
from dataclasses import dataclass

import cyclonedds.idl as idl
import cyclonedds.idl.annotations as annotate
import cyclonedds.idl.types as types

WALKING = {200, 500, 501, 801, 802}


@dataclass
@annotate.final
@annotate.autoid("sequential")
class SportModeState_(idl.IdlStruct, typename="unitree_hg.msg.dds_.SportModeState_"):
    """unitree_hg SportModeState_ (no Python build of the SDK ships it), as in the robot's C++ headers."""

    fsm_id: types.uint32
    fsm_mode: types.uint32
    task_id: types.uint32
    task_time: types.float32


class Firmware:
    """The robot's rules, as little as the node's protocol needs."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.svc, self.fsm, self.moving_until = "ai", 4, 0.0

    def fsm_mode(self) -> int:
        return 1 if self.fsm in WALKING and time.monotonic() < self.moving_until else 0

    def state(self) -> None:
        emit("state", fsm=self.fsm, svc=self.svc)


def emit(event: str, **fields: object) -> None:
    print(json.dumps({"event": event, "t": time.monotonic(), **fields}), flush=True)


def main(domain: int) -> int:
    from unitree_sdk2py.core.channel import ChannelFactoryInitialize, ChannelPublisher
    from unitree_sdk2py.idl.default import unitree_hg_msg_dds__LowState_
    from unitree_sdk2py.idl.unitree_hg.msg.dds_ import LowState_
    from unitree_sdk2py.rpc.server import Server
    from unitree_sdk2py.utils.crc import CRC

    ChannelFactoryInitialize(domain, "lo")
    fw = Firmware()

    def logged(svc: str, api: int, handler):
        def run(parameter: str) -> tuple[int, str]:
            emit("request", svc=svc, api=api, p=parameter)
            with fw.lock:
                return handler(json.loads(parameter or "{}"))

        return run

    def sport(handler):
        return lambda p: handler(p) if fw.svc else (3203, "")

    def set_fsm(p: dict) -> tuple[int, str]:
        fsm = int(p["data"])
        if (fsm == 4 and fw.fsm not in {1, 4} | WALKING) or (fw.fsm_mode() == 1 and fsm != 1):
            return (7301, "")
        fw.fsm, fw.moving_until = fsm, 0.0
        fw.state()
        return (0, "")

    def set_velocity(p: dict) -> tuple[int, str]:
        if fw.fsm not in WALKING:
            return (7301, "")
        moving = any(abs(v) > 0 for v in p["velocity"])
        fw.moving_until = time.monotonic() + float(p.get("duration", 1.0)) if moving else 0.0
        return (0, "")

    def select(p: dict) -> tuple[int, str]:
        if p.get("name") != fw.svc:
            fw.svc, fw.fsm = str(p.get("name")), 0
            fw.state()
        return (0, "")

    def release(p: dict) -> tuple[int, str]:
        fw.svc, fw.fsm = "", 0
        fw.state()
        return (0, "")

    sport_table = {
        7001: lambda p: (0, json.dumps({"data": fw.fsm})),
        7002: lambda p: (0, json.dumps({"data": fw.fsm_mode()})),
        7101: set_fsm,
        7102: lambda p: (0, ""),
        7105: set_velocity,
        7107: lambda p: (0, ""),
    }
    switcher_table = {
        1001: lambda p: (0, json.dumps({"form": "0", "name": fw.svc})),
        1002: select,
        1003: release,
    }
    servers = []
    for name, version, table, wrap in (("sport", "1.0.0.0", sport_table, sport),
                                       ("motion_switcher", "1.0.0.1", switcher_table, lambda h: h)):
        server = Server(name)
        server._SetApiVersion(version)
        for api, handler in table.items():
            server._RegistHandler(api, logged(name, api, wrap(handler)), False)
        server.Start()
        servers.append(server)

    low = ChannelPublisher("rt/lowstate", LowState_)
    low.Init()
    sport_pub = ChannelPublisher("rt/sportmodestate", SportModeState_)
    sport_pub.Init()
    msg, crc = unitree_hg_msg_dds__LowState_(), CRC()
    msg.mode_machine = 5
    fw.state()
    emit("ready")
    tick = 0
    while True:  # 50 Hz until killed
        tick += 20
        msg.tick = tick
        msg.crc = crc.Crc(msg)
        low.Write(msg)
        with fw.lock:
            state = SportModeState_(fsm_id=fw.fsm if fw.svc else 0, fsm_mode=fw.fsm_mode(), task_id=0, task_time=0.0)
        sport_pub.Write(state)
        time.sleep(0.02)


if __name__ == "__main__":
    sys.exit(main(int(sys.argv[1])))
