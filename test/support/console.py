"""The operator console in a test: its process on a free loopback port, a page spoken to over a raw WebSocket,
a stand-in for the mode manager's public topics, and Debian's headless Chromium driven by selenium."""

from __future__ import annotations

import asyncio
import json
import os
import shutil
import tempfile
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import rclpy
from rclpy.executors import SingleThreadedExecutor

from support.processes import ManagedProcess, python_module

READY = "g1_console ready: "
CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"


@dataclass
class Console:
    proc: ManagedProcess
    url: str  # http://127.0.0.1:<port>/

    @property
    def port(self) -> int:
        return int(self.url.rsplit(":", 1)[1].strip("/"))

    def ws_url(self, token: str | None = None) -> str:
        return f"ws://127.0.0.1:{self.port}/ws" + (f"?token={token}" if token else "")


def start_console(*params: str, timeout_s: float = 20.0) -> Console:
    """``python -m g1_mode_manager.console.main`` on 127.0.0.1 and a port the kernel picks (never the fixed 8080)."""
    args = ["--ros-args", "-p", "port:=0"]
    for p in params:
        args += ["-p", p]
    proc = ManagedProcess(python_module("g1_mode_manager.console.main", *args), name="console")
    try:
        line = proc.wait_for_line(lambda text: READY in text, timeout_s)
    except BaseException:
        proc.stop()
        raise
    return Console(proc, line.split(READY, 1)[1].split()[0])


def http_get(url: str, headers: dict[str, str] | None = None) -> tuple[int, str]:
    """(status, body) of one GET, as a script (not a browser) sends it."""
    import aiohttp

    async def go() -> tuple[int, str]:
        async with aiohttp.ClientSession() as session, session.get(url, headers=headers or {}) as r:
            return r.status, await r.text()

    return asyncio.run(go())


class RawPage:
    """A console page without a browser: a WebSocket on an event loop of its own, keeping every message it gets.

    ``hold(vx, ...)`` sends a teleop heartbeat every ``period_s`` in the background, as the page does."""

    def __init__(self, url: str, *, headers: dict[str, str] | None = None) -> None:
        import aiohttp

        self._aiohttp = aiohttp
        self.received: list[dict[str, Any]] = []
        self.closed_with: int | None = None
        self._loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self._loop.run_forever, daemon=True)
        self._thread.start()
        self._beat: asyncio.Future | None = None
        self._closed = False
        try:
            self._run(self._open(url, headers or {}))
        except BaseException:
            self._stop_loop()
            raise

    def _run(self, coro: Any, timeout_s: float = 10.0) -> Any:
        return asyncio.run_coroutine_threadsafe(coro, self._loop).result(timeout_s)

    async def _open(self, url: str, headers: dict[str, str]) -> None:
        self._session = self._aiohttp.ClientSession()
        self._ws = await self._session.ws_connect(url, headers=headers, max_msg_size=0)
        self._reader = asyncio.ensure_future(self._read())

    async def _read(self) -> None:
        async for msg in self._ws:
            if msg.type == self._aiohttp.WSMsgType.TEXT:
                self.received.append(json.loads(msg.data))
        self.closed_with = self._ws.close_code

    def send(self, obj: Any) -> None:
        """A JSON object, or a raw str / bytes as it is."""
        data = obj if isinstance(obj, str | bytes) else json.dumps(obj)

        async def go() -> None:
            if isinstance(data, bytes):
                await self._ws.send_bytes(data)
            else:
                await self._ws.send_str(data)

        self._run(go())

    def send_many(self, texts: list[str]) -> None:
        """Back to back, as fast as the socket takes them (a flood)."""

        async def go() -> None:
            for text in texts:
                await self._ws.send_str(text)

        self._run(go(), 60.0)

    def hold(self, vx: float = 0.0, vy: float = 0.0, wz: float = 0.0, *, visible: bool = True, focused: bool = True,
             period_s: float = 0.1) -> None:
        self.release_beat()
        seq = iter(range(1, 2**31))

        async def beat() -> None:
            while True:
                msg = {"type": "teleop", "visible": visible, "focused": focused, "vx": vx, "vy": vy, "wz": wz,
                       "seq": next(seq)}
                await self._ws.send_str(json.dumps(msg))
                await asyncio.sleep(period_s)

        async def start() -> None:
            self._beat = asyncio.ensure_future(beat())

        self._run(start())

    def release_beat(self) -> None:
        """Stop sending heartbeats (the socket stays open: the server's deadline must let go)."""

        async def stop() -> None:
            if self._beat is not None:
                self._beat.cancel()
                self._beat = None

        self._run(stop())

    def states(self) -> list[dict[str, Any]]:
        return [m for m in list(self.received) if m.get("type") == "state"]

    def last(self, kind: str) -> dict[str, Any] | None:
        return next((m for m in reversed(list(self.received)) if m.get("type") == kind), None)

    def wait_for(self, predicate: Any, timeout_s: float = 5.0) -> dict[str, Any]:
        """The first message (old or new) that satisfies ``predicate``; AssertionError if none within the time."""
        deadline = time.monotonic() + timeout_s
        while True:
            for msg in list(self.received):
                if predicate(msg):
                    return msg
            assert time.monotonic() < deadline, f"no such message in {timeout_s} s; last: {self.received[-3:]}"
            time.sleep(0.02)

    def close(self) -> None:
        """Close the socket (the page is gone); a second call does nothing."""
        if self._closed:
            return
        self._closed = True

        async def go() -> None:
            if self._beat is not None:
                self._beat.cancel()
            await self._ws.close()
            await self._session.close()

        try:
            self._run(go())
        finally:
            self._stop_loop()

    def _stop_loop(self) -> None:
        self._loop.call_soon_threadsafe(self._loop.stop)
        self._thread.join(5.0)


@dataclass
class Twists:
    """Every cmd_vel a subscriber saw: (receive time, vx, vy, wz)."""

    seen: list[tuple[float, float, float, float]] = field(default_factory=list)

    def __call__(self, msg: Any) -> None:
        self.seen.append((time.monotonic(), msg.linear.x, msg.linear.y, msg.angular.z))

    def since(self, t: float) -> list[tuple[float, float, float, float]]:
        return [s for s in list(self.seen) if s[0] >= t]


class FakeManager:
    """The mode manager's public face and nothing else: a node named g1_mode_manager with the parameters the
    console reads, ~/mode published at 2 Hz as told, cmd_vel received, and ~/hand_over_to_autonomy and
    ~/take_over, which change ``driver`` and keep each call's name in ``called``; of the policy's services
    ~/policy/load (it publishes the loaded phase on ~/policy/status) and ~/policy/engage (it refuses), the others
    left out; ``recorder_dir``, if given, as the node's parameter of that name. For console tests without a robot."""

    def __init__(self, mode: str = "HIGH_LEVEL", recorder_dir: str | None = None) -> None:
        from g1_mode_manager_msgs.msg import Mode, PolicyStatus
        from g1_mode_manager_msgs.srv import LoadPolicy
        from geometry_msgs.msg import Twist
        from std_srvs.srv import Trigger

        from g1_mode_manager.core.modes import Mode as Modes
        from g1_mode_manager.topic_qos import MODE_QOS

        self._modes = Modes
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node("g1_mode_manager", context=self.context)
        self.node.declare_parameter("cmd_vel_stamped", False)
        self.node.declare_parameter("cmd_vel_timeout_s", 0.5)
        for m in Modes:
            self.node.declare_parameter(f"head_led_{m.name.lower()}", "0 255 0 pulse 2.0")
        self.node.declare_parameter("head_led_autonomy", "0 255 255 pulse 1.5")
        if recorder_dir is not None:
            self.node.declare_parameter("recorder_dir", recorder_dir)
        self.mode = mode
        self.driver = "teleop"
        self.called: list[str] = []
        self.twists = Twists()
        self.node.create_subscription(Twist, "/cmd_vel", self.twists, 50)
        self._pub = self.node.create_publisher(Mode, "~/mode", MODE_QOS)
        self._msg_type = Mode
        self.node.create_timer(0.5, self._publish)
        for service, driver in (("hand_over_to_autonomy", "autonomy"), ("take_over", "teleop")):
            self.node.create_service(Trigger, f"~/{service}",
                                     lambda _req, res, service=service, driver=driver: self._drive(service, driver, res))
        self._policy_pub = self.node.create_publisher(PolicyStatus, "~/policy/status", MODE_QOS)
        self._policy_msg = PolicyStatus
        self._policy_pub.publish(PolicyStatus(phase="unloaded", progress=-1.0, tracking_error_rad=-1.0))
        self.node.create_service(LoadPolicy, "~/policy/load", self._load)
        self.node.create_service(Trigger, "~/policy/engage", self._refuse_engage)
        self._executor = SingleThreadedExecutor(context=self.context)
        self._executor.add_node(self.node)
        self._thread = threading.Thread(target=self._executor.spin, daemon=True)
        self._thread.start()

    def _publish(self) -> None:
        mode = self._modes[self.mode]
        msg = self._msg_type(mode=int(mode), name=mode.name, high_level_service_known=True,
                             high_level_service_active=True, link_ok=True, driver=self.driver)
        self._pub.publish(msg)

    def _drive(self, service: str, driver: str, response: Any) -> Any:
        self.called.append(service)
        self.driver = driver
        self._publish()  # as the node does: a change of driver goes out at once
        response.success, response.message = True, f"stand-in {service}: the {driver} drives"
        return response

    def _load(self, request: Any, response: Any) -> Any:
        self.called.append(f"policy/load {request.policy}")
        self._policy_pub.publish(self._policy_msg(policy=request.policy or "loco_ppo", phase="loaded", progress=-1.0,
                                                  tracking_error_rad=-1.0))
        response.success, response.message = True, f"stand-in: policy {request.policy or 'loco_ppo'} loaded"
        return response

    def _refuse_engage(self, _request: Any, response: Any) -> Any:
        self.called.append("policy/engage")
        response.success, response.message = False, "engage refused: policy is loaded, not shadow; nothing sent"
        return response

    def close(self) -> None:
        self._executor.shutdown()
        self._thread.join(5.0)
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


def browser_missing() -> str | None:
    """Why no browser test can run here, or None."""
    for path, package in ((CHROMIUM, "chromium"), (CHROMEDRIVER, "chromium-driver")):
        if not os.access(path, os.X_OK):
            return f"{path} is missing (Debian {package}: `make setup` installs it as root, scripts/check_system.sh)"
    try:
        import selenium  # noqa: F401
    except ImportError:
        return "selenium is not installed (requirements.txt: `make setup`)"
    return None


@contextmanager
def chromium(width: int = 1280, height: int = 1000) -> Iterator[Any]:
    """Debian's Chromium, headless, through Debian's chromedriver (selenium never looks for or downloads one)."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    profile = tempfile.mkdtemp(prefix="g1_console_chromium_")
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                "--disable-background-networking", "--disable-component-update", "--disable-sync",
                "--disable-extensions", f"--user-data-dir={profile}", f"--window-size={width},{height}"):
        options.add_argument(arg)
    driver = webdriver.Chrome(service=Service(executable_path=CHROMEDRIVER), options=options)
    try:
        yield driver
    finally:
        driver.quit()
        shutil.rmtree(profile, ignore_errors=True)


def set_window_state(driver: Any, state: str) -> None:
    """'minimized' hides the page for real (visibilitychange to hidden, and a blur), 'normal' shows it again."""
    window = driver.execute_cdp_cmd("Browser.getWindowForTarget", {})["windowId"]
    driver.execute_cdp_cmd("Browser.setWindowBounds", {"windowId": window, "bounds": {"windowState": state}})
