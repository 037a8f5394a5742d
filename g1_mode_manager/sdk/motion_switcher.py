"""The G1's motion switcher service: which built-in service owns the motors ('' = released, debug mode)."""

from __future__ import annotations

import json
from dataclasses import dataclass

from g1_mode_manager.core.port import RobotError
from g1_mode_manager.protocol import api_ids as api
from g1_mode_manager.sdk.rpc_client import RpcClient

_API_IDS = (api.MS_CHECK_MODE, api.MS_SELECT_MODE, api.MS_RELEASE_MODE, api.MS_SET_SILENT, api.MS_GET_SILENT)


@dataclass(frozen=True)
class ModeInfo:
    """CheckMode's answer: ``name`` of the active service ('' when released) and its ``form``."""

    form: str
    name: str

    @property
    def released(self) -> bool:
        return self.name == ""


def _object(call: str, data: str) -> dict:
    try:
        value = json.loads(data) if data else {}
    except ValueError:
        raise RobotError(call, api.ERR_CLIENT_API_DATA, f"reply is not JSON: {data!r}") from None
    if not isinstance(value, dict):
        raise RobotError(call, api.ERR_CLIENT_API_DATA, f"reply is not an object: {data!r}")
    return value


class MotionSwitcherClient(RpcClient):
    """Motion switcher calls. SelectMode can take seconds on a robot: give it a longer ``timeout_s``."""

    def __init__(self, timeout_s: float = 5.0) -> None:
        super().__init__(api.MOTION_SWITCHER_SERVICE, api.MOTION_SWITCHER_API_VERSION, _API_IDS, timeout_s)

    def check_mode_info(self, *, timeout_s: float | None = None) -> ModeInfo:
        value = _object("CheckMode", self.call("CheckMode", api.MS_CHECK_MODE, timeout_s=timeout_s))
        name, form = value.get("name", ""), value.get("form", "")
        if not isinstance(name, str):
            raise RobotError("CheckMode", api.ERR_CLIENT_API_DATA, f"name is not a string: {value!r}")
        return ModeInfo(form=str(form), name=name)

    def check_mode(self, *, timeout_s: float | None = None) -> str:
        """The active service's name, '' when released (debug mode)."""
        return self.check_mode_info(timeout_s=timeout_s).name

    def select_mode(self, name: str, *, timeout_s: float | None = None) -> None:
        if not name:
            raise ValueError("SelectMode: name must not be empty (use release_mode)")
        self.call("SelectMode", api.MS_SELECT_MODE, {"name": name}, timeout_s=timeout_s)

    def release_mode(self, *, timeout_s: float | None = None) -> None:
        self.call("ReleaseMode", api.MS_RELEASE_MODE, timeout_s=timeout_s)

    def set_silent(self, silent: bool, *, timeout_s: float | None = None) -> None:
        self.call("SetSilent", api.MS_SET_SILENT, {"silent": bool(silent)}, timeout_s=timeout_s)

    def get_silent(self, *, timeout_s: float | None = None) -> bool:
        data = self.call("GetSilent", api.MS_GET_SILENT, timeout_s=timeout_s)
        try:
            value = json.loads(data)
        except ValueError:
            raise RobotError("GetSilent", api.ERR_CLIENT_API_DATA, f"reply is not JSON: {data!r}") from None
        if isinstance(value, dict):
            value = value.get("silent", value.get("data"))
        if not isinstance(value, bool | int):
            raise RobotError("GetSilent", api.ERR_CLIENT_API_DATA, f"reply has no silent flag: {data!r}")
        return bool(value)
