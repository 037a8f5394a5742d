"""An RPC client on the SDK's ``Client`` base that raises instead of returning codes, with per-call timeouts.

The SDK's ``Client._Call`` reads one timeout shared by every thread (``SetTimeout``), waits up to twice
that long (once for the topic match, once for the reply), never removes the future of a timed-out call
(``RequestFutureQueue.Remove`` tests the builtin ``id``), and returns bare codes that callers drop.
Here each call has its own deadline, ids are unique across threads, a call that gives up is
forgotten, and every failure raises :class:`RobotError`. The SDK's ``ClientStub`` still creates the
service's DDS topics and request writer (a thread-safe DDS writer, so calls from several threads at
once, an e-stop's damp while a select_mode waits, are safe). Requests are written on that writer as
ready-made bytes (``request_writer.py``), and replies are taken as bytes by a reader of our own on the
SDK's response topic, which matches them to the waiting calls by request id under a lock
(``response_reader.py``; the stub's own reader is silenced): neither side goes through the generic
IDL (de)serialiser, which costs more per message than struct packing.
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Iterable
from typing import Any

from unitree_sdk2py.rpc.client import Client
from unitree_sdk2py.rpc.internal import RPC_API_ID_INTERNAL_API_VERSION

from g1_mode_manager.core.port import RobotError
from g1_mode_manager.protocol.api_ids import (
    ERR_CLIENT_API_DATA,
    ERR_CLIENT_API_NOT_MATCH,
    ERR_CLIENT_API_NOT_REG,
    ERR_CLIENT_API_TIMEOUT,
    ERR_CLIENT_SEND,
    OK,
)
from g1_mode_manager.protocol.unitree_sdk_internals import client_stub
from g1_mode_manager.sdk.request_writer import RequestWriter
from g1_mode_manager.sdk.response_reader import Pending, ResponseReader


class RpcClient(Client):
    """One SDK RPC client for one service (creating it costs the SDK's built-in 0.5 s sleep)."""

    def __init__(self, service: str, api_version: str, api_ids: Iterable[int], timeout_s: float) -> None:
        if not timeout_s > 0:
            raise ValueError(f"timeout_s must be > 0, got {timeout_s!r}")
        super().__init__(service, False)
        self.service = service
        self.timeout_s = float(timeout_s)
        self._SetApiVerson(api_version)
        self._api_ids = frozenset(api_ids)
        for api_id in self._api_ids:
            self._RegistApi(api_id, 0)
        # Used only by the SDK's own no-reply path (its wait for a topic match); never changed later.
        self.SetTimeout(self.timeout_s)
        self._stub = client_stub(self)  # the SDK's transport: its topics and request writer
        self._writer = RequestWriter(self._stub)
        self._replies = ResponseReader(self._stub)
        self._id_lock = threading.Lock()
        self._last_id = 0

    def close(self) -> None:
        """Stop taking replies (the SDK's client has no close of its own): calls waiting for one, and later
        ones, raise RobotError at once."""
        self._replies.close()

    @property
    def closed(self) -> bool:
        return self._replies.closed

    def _next_id(self) -> int:
        """Request ids as the SDK makes them (monotonic ns), but never equal across threads."""
        with self._id_lock:
            self._last_id = max(time.monotonic_ns(), self._last_id + 1)
            return self._last_id

    def call(self, name: str, api_id: int, parameter: Any = None, *, timeout_s: float | None = None) -> str:
        """Send a request and wait for its reply; returns the reply's data string.

        ``parameter`` is JSON-encoded (None sends ``{}``). Raises RobotError with the robot's code,
        or 3102 (not sent: no server matched in time), 3104 (no reply within the timeout).
        """
        return self.send(name, api_id, parameter, timeout_s=timeout_s, match_wait=True).wait()

    def send(self, name: str, api_id: int, parameter: Any = None, *, timeout_s: float | None = None,
             match_wait: bool = False) -> PendingCall:
        """Write a request now; its reply is awaited by the returned call's ``wait()``.

        With ``match_wait`` the write first waits (within the timeout) for a matched server, as the SDK
        does; without it nothing waits here, and with no server matched it raises RobotError (3102) at
        once: for a caller that holds a lock around the write.
        """
        if api_id != RPC_API_ID_INTERNAL_API_VERSION and api_id not in self._api_ids:
            raise RobotError(name, ERR_CLIENT_API_NOT_REG, f"api {api_id} not registered for {self.service!r}")
        timeout = self.timeout_s if timeout_s is None else float(timeout_s)
        deadline = time.monotonic() + timeout
        text = "{}" if parameter is None else json.dumps(parameter)
        request_id = self._next_id()
        pending = self._replies.expect(request_id)  # before the write: the reply may come before write() returns
        if not self._writer.write(request_id, api_id, text, False, timeout if match_wait else 0.0):
            self._replies.forget(request_id)
            waited = f"within {timeout:.2f} s" if match_wait else "(not waited for)"
            raise RobotError(name, ERR_CLIENT_SEND, f"no {self.service!r} server matched {waited}")
        return PendingCall(self, name, api_id, text, request_id, pending, timeout, deadline)

    def call_no_reply(self, name: str, api_id: int, parameter: Any = None, *, text: str | None = None) -> None:
        """Send a request flagged no-reply (the server runs it and answers nothing): written at once.

        The SDK's own ``_CallNoReply`` first waits up to the client's timeout (1 s) for a matched server,
        polling every 0.1 s: an e-stop's first shot on a dead link sat there, in front of everything
        after it. Here nothing waits: with no server matched the request reaches nobody, and what
        follows (the e-stop's Damp with its own timeout) finds that out. Raises RobotError(3102) only
        if the DDS write itself failed. ``text``: the parameter already JSON-encoded (the e-stop's, made once).
        """
        if text is None:
            text = "{}" if parameter is None else json.dumps(parameter)
        if api_id not in self._api_ids:
            raise RobotError(name, ERR_CLIENT_API_NOT_REG, f"api {api_id} not registered for {self.service!r}")
        if not self._writer.write(self._next_id(), api_id, text, True, None):  # None: no wait for a match
            raise RobotError(name, ERR_CLIENT_SEND, f"{self.service} api {api_id} {text} (no-reply)")

    def server_api_version(self, *, timeout_s: float | None = None) -> str:
        """The server's api version (the SDK's internal api 1): a cheap readiness probe."""
        return self.call("GetServerApiVersion", RPC_API_ID_INTERNAL_API_VERSION, timeout_s=timeout_s)

    def wait_ready(self, budget_s: float, *, attempt_timeout_s: float = 0.5) -> str:
        """Probe the server until it answers or ``budget_s`` passed (the first call after discovery can
        be lost while the reply topic is still matching). Returns its version; raises the last RobotError."""
        deadline = time.monotonic() + budget_s
        while True:
            remaining = deadline - time.monotonic()
            try:
                return self.server_api_version(timeout_s=max(0.05, min(attempt_timeout_s, remaining)))
            except RobotError:
                if deadline - time.monotonic() <= 0 or self.closed:
                    raise


class PendingCall:
    """A request written, its reply still to come (``RpcClient.send``)."""

    __slots__ = ("_api_id", "_client", "_deadline", "_name", "_pending", "_request_id", "_text", "_timeout_s")

    def __init__(self, client: RpcClient, name: str, api_id: int, text: str, request_id: int, pending: Pending,
                 timeout_s: float, deadline: float) -> None:
        self._client = client
        self._name = name
        self._api_id = api_id
        self._text = text
        self._request_id = request_id
        self._pending = pending
        self._timeout_s = timeout_s
        self._deadline = deadline  # set before the write: a wait for a matched server counts too

    def wait(self) -> str:
        """The reply's data string, once it came; raises RobotError (3104 when the timeout passed first)."""
        client = self._client
        reply = client._replies.wait(self._pending, max(0.0, self._deadline - time.monotonic()))
        if reply is None and self._pending.closed:
            raise RobotError(self._name, ERR_CLIENT_SEND, f"{client.service!r} client closed (the node is shutting "
                             "down): no reply is taken")
        if reply is None:
            client._replies.forget(self._request_id)
            raise RobotError(self._name, ERR_CLIENT_API_TIMEOUT, f"no reply from {client.service!r} in {self._timeout_s:.2f} s")
        if reply.api_id != self._api_id:
            raise RobotError(self._name, ERR_CLIENT_API_NOT_MATCH, f"reply for api {reply.api_id}")
        if reply.code != OK:
            raise RobotError(self._name, reply.code, f"{client.service} api {self._api_id} {self._text}")
        return reply.data


def parse_data(name: str, data: str, key: str = "data") -> Any:
    """A getter's value from its reply: ``{"data": v}`` as the C++ SDK parses it, or a bare JSON value."""
    try:
        value = json.loads(data)
    except (TypeError, ValueError):
        raise RobotError(name, ERR_CLIENT_API_DATA, f"reply is not JSON: {data!r}") from None
    if isinstance(value, dict):
        if key not in value:
            raise RobotError(name, ERR_CLIENT_API_DATA, f"reply has no {key!r}: {data!r}")
        return value[key]
    return value


def parse_number(name: str, data: str, kind: type[int] | type[float]) -> Any:
    """A numeric getter's value (int or float); bools and non-numbers raise RobotError(3106)."""
    value = parse_data(name, data)
    if isinstance(value, str):
        try:
            value = json.loads(value)
        except ValueError:
            pass
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise RobotError(name, ERR_CLIENT_API_DATA, f"reply is not a number: {data!r}")
    if kind is int and value != int(value):
        raise RobotError(name, ERR_CLIENT_API_DATA, f"reply is not an integer: {data!r}")
    return kind(value)
