"""The web side: one page at ``/`` and the WebSocket at ``/ws``, served by aiohttp on the main thread's event loop.

Every request passes the access rules first (a token when one is set: 401 and nothing else without it). Each
WebSocket is a page: its messages are checked (messages.py), rate limited, and refused with a reason and a count
when bad; good ones reach the teleop (the dead-man) or a mode manager service, whose answer every page sees. The
state (mode, health, who drives, a plot sample) goes to every page at state_rate_hz and at once on a change.
The Recover button's sequence (recovery.py) asks its steps through the same service call as a loco button.
Handing the robot to the autonomy and taking it back are service calls too; the dead-man is the teleop's alone.
So are the Policy card's verbs (policy_card.py), whose status, targets and error plot go out with the state.
The last incident and its file are served over plain HTTP (incident_routes.py), behind the same access rules.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import json
import math
import sys
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

from aiohttp import WSMsgType, web

from g1_mode_manager.console import messages as m
from g1_mode_manager.console.access import Access
from g1_mode_manager.console.bridge import RosBridge, ServiceUnavailableError, loco_request, set_mode_request, trigger_request
from g1_mode_manager.console.cmd_vel_publisher import CmdVelPublisher
from g1_mode_manager.console.incident_routes import IncidentRoutes
from g1_mode_manager.console.page import build_page
from g1_mode_manager.console.policy_card import ANSWER_TIMEOUT_S as POLICY_TIMEOUT_S
from g1_mode_manager.console.policy_card import request as policy_request
from g1_mode_manager.console.policy_card import service as policy_service
from g1_mode_manager.console.policy_view import PolicyView
from g1_mode_manager.console.rate_limit import TokenBucket
from g1_mode_manager.console.recovery import Answer, RecoveryRunner
from g1_mode_manager.console.robot_view import RobotView
from g1_mode_manager.console.settings import ConsoleSettings
from g1_mode_manager.console.teleop import Teleop

#: A WebSocket frame above this closes the socket (1009) before it is even read whole; below it, messages
#: above max_message_bytes are refused one by one and the socket stays open.
FRAME_CAP_BYTES = 64 * 1024
#: How long a service answer may take before the page is told it timed out (s): the e-stop's bound is
#: estop_timeout_s (10 s) plus one call; a get-up's answer waits up to loco_get_up_timeout_s (12 s).
ANSWER_TIMEOUT_S = {"estop": 15.0, "set_mode": 30.0, "loco": 20.0, "clear_fault": 5.0, "hand_over": 5.0,
                    "take_over": 5.0, **{policy_service(verb): s for verb, s in POLICY_TIMEOUT_S.items()}}
#: The commands that call one of the mode manager's Trigger services: the service (the bridge's name for it) and
#: how the answer names the request.
TRIGGERS = {m.Estop: ("estop", "E-STOP"), m.ClearFault: ("clear_fault", "clear fault"),
            m.HandOver: ("hand_over", "hand over to autonomy"), m.TakeOver: ("take_over", "take over")}
#: Refusals a page is told about per second (all are counted).
REFUSAL_REPLIES_PER_S = 5.0
#: The heartbeat period the page is asked to keep (s): a third of the default deadline.
HEARTBEAT_PERIOD_S = 0.1
#: A page that does not take its state within this long is closed (one slow phone never delays the others).
SEND_TIMEOUT_S = 1.0


@dataclass
class _PageSocket:
    id: str
    label: str
    ws: web.WebSocketResponse
    bucket: TokenBucket
    refused: Counter = field(default_factory=Counter)
    busy: set[str] = field(default_factory=set)
    replies: TokenBucket = field(default_factory=lambda: TokenBucket(REFUSAL_REPLIES_PER_S, REFUSAL_REPLIES_PER_S))


class ConsoleServer:
    def __init__(self, settings: ConsoleSettings, access: Access, rules: m.MessageRules, teleop: Teleop,
                 view: RobotView, policy: PolicyView, bridge: RosBridge, publisher: CmdVelPublisher,
                 blocked: Callable[[float], str | None], hello: dict[str, Any], incidents: IncidentRoutes,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self._s = settings
        self._access = access
        self._rules = rules
        self._teleop = teleop
        self._view = view
        self._policy = policy
        self._bridge = bridge
        self._publisher = publisher
        self._blocked = blocked
        self._hello = hello
        self._incidents = incidents
        self._clock = clock
        self._started = clock()
        self._page = build_page()
        self._pages: dict[str, _PageSocket] = {}
        self._numbers = itertools.count(1)
        self.refused: Counter = Counter()  # by kind, every page together; also "clients" and "host"
        self._wake = asyncio.Event()
        self._runner: web.AppRunner | None = None
        self._tasks: set[asyncio.Task] = set()
        self._state_error_at = -math.inf
        self._recovery = RecoveryRunner(self._ask_for_recovery, self._tell_recovery, self._bridge.latest_mode)

    # --- life ----------------------------------------------------------------------------------------
    def app(self) -> web.Application:
        app = web.Application(middlewares=[self._guard], client_max_size=4096)
        app.router.add_get("/", self._serve_page)
        app.router.add_get("/ws", self._serve_socket)
        self._incidents.add_to(app)
        return app

    async def start(self) -> tuple[str, int]:
        """Bind and serve; returns the address and port actually bound (port 0: a free one)."""
        self._runner = web.AppRunner(self.app(), access_log=None, handle_signals=False)  # the token is in URLs
        await self._runner.setup()
        site = web.TCPSite(self._runner, self._s.host, self._s.port)
        await site.start()
        self._spawn(self._state_loop())
        host, port = self._runner.addresses[0][:2]
        return host, port

    async def stop(self) -> None:
        for task in list(self._tasks):
            task.cancel()
        for page in list(self._pages.values()):
            await page.ws.close(code=1001, message=b"console stopping")
        if self._runner is not None:
            await self._runner.cleanup()

    def changed(self) -> None:
        """Something the pages show changed (called on the event loop): send the state now."""
        self._wake.set()

    def _spawn(self, coro: Any) -> None:
        task = asyncio.ensure_future(coro)
        self._tasks.add(task)
        task.add_done_callback(self._tasks.discard)

    # --- HTTP ----------------------------------------------------------------------------------------
    @web.middleware
    async def _guard(self, request: web.Request, handler: Any) -> web.StreamResponse:
        if not self._access.host_ok(request.headers.get("Host")):
            self.refused["host"] += 1
            return web.Response(status=403, text="403: this console answers to loopback host names only\n")
        if not self._access.token_ok(request.query, request.headers):
            self.refused["token"] += 1
            return web.Response(status=401, text="401: a valid token is required\n",
                                headers={"WWW-Authenticate": 'Bearer realm="g1_console"'})
        return await handler(request)

    async def _serve_page(self, _request: web.Request) -> web.Response:
        return web.Response(body=self._page.html, content_type="text/html", charset="utf-8", headers={
            "Content-Security-Policy": self._page.csp, "Cache-Control": "no-store", "X-Content-Type-Options": "nosniff",
            "Referrer-Policy": "no-referrer", "X-Frame-Options": "DENY"})

    # --- WebSocket -----------------------------------------------------------------------------------
    async def _serve_socket(self, request: web.Request) -> web.StreamResponse:
        if not self._access.origin_ok(request.headers.get("Origin"), request.headers.get("Host")):
            self.refused["origin"] += 1
            return web.Response(status=403, text="403: a WebSocket from another origin\n")
        if len(self._pages) >= self._s.max_clients:
            self.refused["clients"] += 1
            return web.Response(status=503, text=f"503: {self._s.max_clients} consoles are open already\n")
        ws = web.WebSocketResponse(max_msg_size=FRAME_CAP_BYTES, autoping=True)
        await ws.prepare(request)
        number = next(self._numbers)
        page = _PageSocket(f"p{number}", f"console {number} ({request.remote})", ws,
                           TokenBucket(self._s.max_messages_per_s, self._s.max_messages_per_s))
        self._pages[page.id] = page
        self._teleop.join(page.id, page.label)
        try:
            await ws.send_str(json.dumps({"type": "hello", "you": page.label, **self._hello,
                                          "heartbeat_period_s": HEARTBEAT_PERIOD_S,
                                          "heartbeat_deadline_s": self._s.heartbeat_deadline_s,
                                          "history": self._view.history(),
                                          "policy_history": self._policy.history()}))
            self.changed()  # the others see one more console
            await self._read(page)
        finally:
            self._teleop.leave(page.id)  # the dead-man lets go with the socket
            self._pages.pop(page.id, None)
            self.changed()
        return ws

    async def _read(self, page: _PageSocket) -> None:
        while True:
            msg = await page.ws.receive()
            if msg.type == WSMsgType.TEXT:
                self._take(page, msg.data)
            elif msg.type == WSMsgType.BINARY:
                self._refuse(page, m.Refused(m.MALFORMED, "binary messages are not part of the protocol"))
            elif msg.type == WSMsgType.ERROR:
                # aiohttp has already closed the socket (1009 for a frame above FRAME_CAP_BYTES)
                kind = m.OVERSIZED if "exceeds limit" in str(msg.data) else m.MALFORMED
                self._count(page, kind)
                return
            else:  # CLOSE, CLOSING, CLOSED
                return

    def _take(self, page: _PageSocket, data: str) -> None:
        now = self._clock()
        parsed = self._rules.parse(data)
        # an e-stop is never refused for the rate: a page flooding itself must still be able to stop the robot
        if not isinstance(parsed, m.Estop) and not page.bucket.take(now):
            parsed = m.Refused(m.FLOOD, f"more than {self._s.max_messages_per_s:g} messages a second")
        if isinstance(parsed, m.Refused):
            self._refuse(page, parsed)
        elif isinstance(parsed, m.Teleop):
            self._teleop.heard(page.id, parsed, now)
        elif type(parsed) in TRIGGERS:
            service, what = TRIGGERS[type(parsed)]
            self._call(page, service, trigger_request(), what)
        elif isinstance(parsed, m.SetMode):
            self._call(page, "set_mode", set_mode_request(parsed.mode), f"set_mode {parsed.mode}")
        elif isinstance(parsed, m.Loco):
            value = f" {parsed.value}" if parsed.value else ""
            self._call(page, "loco", loco_request(parsed.command, parsed.value), f"loco {parsed.command}{value}")
        elif isinstance(parsed, m.Recover):
            why_not = self._recovery.start(page.label)
            if why_not:
                self._refuse(page, m.Refused(m.BUSY, f"recover: {why_not}"), to="recover")
        elif isinstance(parsed, m.Policy):
            named = f" {parsed.policy}" if parsed.policy else " (the node's default)" if parsed.verb == "load" else ""
            self._call(page, policy_service(parsed.verb), policy_request(parsed.verb, parsed.policy),
                       f"policy {parsed.verb}{named}")

    def _count(self, page: _PageSocket, kind: str) -> None:
        page.refused[kind] += 1
        self.refused[kind] += 1

    def _refuse(self, page: _PageSocket, refused: m.Refused, to: str | None = None) -> None:
        """Counted at once; the page is told about a few a second (a flood must not double itself in replies).
        ``to``: the button the refusal answers, where the page shows it too."""
        self._count(page, refused.kind)
        if page.replies.take(self._clock()):
            told = {"type": "refused", "kind": refused.kind, "reason": refused.reason,
                    "count": sum(page.refused.values())}
            self._spawn(self._send(page, told if to is None else {**told, "to": to}))

    def _call(self, page: _PageSocket, service: str, request: Any, what: str) -> None:
        """One call per service and page at a time (a second one is refused as busy); every page sees the answer."""
        if service in page.busy:
            self._refuse(page, m.Refused(m.BUSY, f"{what}: the previous {service} has not been answered"))
            return
        page.busy.add(service)
        self._spawn(self._answer(page, service, request, what))

    async def _answer(self, page: _PageSocket, service: str, request: Any, what: str) -> None:
        sent = self._clock()
        try:
            answer = {"type": "answer", "to": service, "request": what, "by": page.label,
                      **await self._ask(service, request)}
        finally:
            page.busy.discard(service)
        answer["after_s"] = round(self._clock() - sent, 3)
        await self._to_every_page(answer)

    async def _ask(self, service: str, request: Any) -> Answer:
        """One call of a mode manager's service: success and message always (a call not made or not answered is a
        failure that says why), the mode or the code and outcome_s as the node answered them."""
        try:
            r = await self._bridge.call(service, request, ANSWER_TIMEOUT_S[service])
        except ServiceUnavailableError as exc:
            return {"success": False, "message": f"not sent: {exc}"}
        except TimeoutError:
            return {"success": False, "message": f"no answer within {ANSWER_TIMEOUT_S[service]:g} s"}
        except Exception as exc:  # whatever went wrong, the page is told, and the console serves on
            return {"success": False, "message": f"not sent: {exc!r}"}
        answer: Answer = {"success": bool(r.success), "message": r.message}
        if service == "set_mode":
            answer["mode"] = r.mode_name
        elif service == "loco":
            answer.update(code=int(r.code), outcome_s=float(r.outcome_s))
        return answer

    async def _ask_for_recovery(self, service: str, argument: str) -> Answer:
        if service == "set_mode":
            return await self._ask("set_mode", set_mode_request(argument))
        return await self._ask("loco", loco_request(argument, 0))

    def _tell_recovery(self, event: dict[str, Any]) -> None:
        self._spawn(self._to_every_page({"type": "recover", **event}))

    async def _to_every_page(self, payload: dict[str, Any]) -> None:
        await asyncio.gather(*(self._send(p, payload) for p in list(self._pages.values())))
        self.changed()

    # --- state out -----------------------------------------------------------------------------------
    async def _state_loop(self) -> None:
        period = 1.0 / self._s.state_rate_hz
        while True:
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._wake.wait(), period)
            self._wake.clear()
            try:
                await self._send_state()
            except Exception as exc:  # a bad sample must not end the pages' state for good
                now = self._clock()
                if now - self._state_error_at > 5.0:
                    self._state_error_at = now
                    print(f"[g1_console] state not sent: {exc!r}", file=sys.stderr, flush=True)

    async def _send_state(self) -> None:
        now = self._clock()
        blocked = self._blocked(now)
        t = now - self._started
        common = self._view.snapshot(now)
        common.update(type="state", consoles=len(self._pages), driving=self._teleop.driving(),
                      refused=dict(self.refused), node_params=self._bridge.node_params,
                      recovery=self._recovery.status(),
                      sample=self._view.sample(now, t, self._publisher.commanded(now)),
                      policy=self._policy.snapshot(now), policy_sample=self._policy.sample(now, t))
        sends = []
        for page in list(self._pages.values()):
            status = asdict(self._teleop.status(page.id, now, blocked))
            sends.append(self._send(page, {**common, "teleop": status, "you": page.label,
                                           "your_refused": dict(page.refused)}))
        await asyncio.gather(*sends)

    async def _send(self, page: _PageSocket, payload: dict[str, Any]) -> None:
        if page.ws.closed:
            return
        try:
            await asyncio.wait_for(page.ws.send_str(json.dumps(payload)), SEND_TIMEOUT_S)
        except (TimeoutError, ConnectionError, RuntimeError):
            self._spawn(page.ws.close(code=1011, message=b"too slow or gone"))  # not awaited: closing may wait too
