"""The unitree_sdk2py private names ``protocol/unitree_sdk_internals.py`` relies on still exist, with their shapes.

Each check names the SDK class and attribute that changed, so an SDK upgrade fails here first, with the
place to fix. Real SDK objects on loopback, on this run's own domain (``sdk_channels``); the started
server runs in a subprocess, as every SDK server of the test suite does.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from unitree_sdk2py.core.channel import Channel, ChannelPublisher, ChannelSubscriber
from unitree_sdk2py.rpc.client import Client
from unitree_sdk2py.rpc.client_stub import ClientStub
from unitree_sdk2py.rpc.server import Server

from g1_mode_manager.protocol.idl import SportModeState_
from g1_mode_manager.protocol.unitree_sdk_internals import (
    channel_datareader,
    channel_datawriter,
    channel_factory_initialized,
    channel_factory_participant,
    channel_matched_readers,
    client_request_channel,
    client_response_channel,
    client_stub,
    publisher_channel,
    server_handler,
    server_request_channel,
    server_request_handler,
    subscriber_channel,
)
from support.mode_manager import wait_until

ROOT = Path(__file__).resolve().parents[2]
HOME = "see g1_mode_manager/protocol/unitree_sdk_internals.py"


def changed(what: str) -> str:
    return f"unitree_sdk2py changed: {what}; {HOME}"


def private(read: Callable[..., Any], *args: Any, what: str) -> Any:
    """``read(*args)``, failing with ``what`` if the SDK no longer has the attribute it reads."""
    try:
        return read(*args)
    except AttributeError as exc:
        pytest.fail(changed(f"{what} ({exc})"))


def test_channel_factory_keeps_its_participant(sdk_channels: int) -> None:
    assert private(channel_factory_initialized, what="ChannelFactory has no __initialized") is True, changed(
        "ChannelFactory.__initialized is not True after Init")
    participant = private(channel_factory_participant, what="ChannelFactory has no __participant")
    assert isinstance(participant, DomainParticipant), changed("ChannelFactory.__participant is not a DomainParticipant")


@pytest.fixture(scope="module")
def client(sdk_channels: int) -> Client:
    return Client(f"internals_probe_{os.getpid()}", False)  # a service nobody serves


def test_client_stub_channels_hold_a_writer_and_a_reader(client: Client) -> None:
    stub = private(client_stub, client, what="ClientBase has no __stub")
    assert isinstance(stub, ClientStub), changed("ClientBase.__stub is not a ClientStub")
    request = private(client_request_channel, stub, what="ClientStub has no __sendChannel")
    response = private(client_response_channel, stub, what="ClientStub has no __recvChannel")
    assert isinstance(request, Channel) and isinstance(response, Channel), changed("a ClientStub channel is not a Channel")
    writer = private(channel_datawriter, request, what="Channel has no __writer, or its __Writer no __writer")
    assert isinstance(writer, DataWriter), changed("Channel.__writer.__writer is not a cyclonedds DataWriter")
    reader = private(channel_datareader, response, what="Channel has no __reader, or its __Reader no __reader")
    assert isinstance(reader, DataReader), changed("Channel.__reader.__reader is not a cyclonedds DataReader")
    count = private(channel_matched_readers, request, what="Channel.__writer has no __publication_matched_count")
    assert count == 0, changed(f"the matched count of an unserved request channel is {count!r}, not 0")


def test_publisher_and_subscriber_channels_count_matched_readers(sdk_channels: int) -> None:
    topic = f"test/unitree_sdk_internals_{os.getpid()}"
    publisher = ChannelPublisher(topic, SportModeState_)
    publisher.Init()
    subscriber = ChannelSubscriber(topic, SportModeState_)
    subscriber.Init(lambda _msg: None, 0)
    pub_channel = private(publisher_channel, publisher, what="ChannelPublisher has no __channel")
    sub_channel = private(subscriber_channel, subscriber, what="ChannelSubscriber has no __channel")
    assert isinstance(pub_channel, Channel) and isinstance(sub_channel, Channel), changed(
        "a ChannelPublisher/ChannelSubscriber channel is not a Channel")
    assert isinstance(channel_datareader(sub_channel), DataReader)
    assert wait_until(lambda: channel_matched_readers(pub_channel) >= 1, 10.0), changed(
        "Channel.__writer.__publication_matched_count no longer follows the matched readers")
    publisher.Close()
    subscriber.Close()


def test_server_keeps_its_handlers_and_dispatcher() -> None:
    server = Server(f"internals_probe_{os.getpid()}")  # not started: no DDS
    server._RegistHandler(7001, lambda _parameter: (0, ""), False)
    handler, lease = private(server_handler, server, 7001, what="Server has no __GetHandler")
    assert callable(handler) and lease is False, changed("Server.__GetHandler(api_id) is not (handler, checks lease)")
    assert private(server_handler, server, 7002, what="Server has no __GetHandler") == (None, False), changed(
        "Server.__GetHandler(unknown id) is not (None, False)")
    dispatch = private(server_request_handler, server, what="Server has no __ServerRequestHandler")
    assert callable(dispatch), changed("Server.__ServerRequestHandler is not callable")
    assert private(server_request_channel, server, what="ServerBase has no __serverStub, or ServerStub no __recvChannel") is None


_STARTED_SERVER = """
import json, sys
from g1_mode_manager.protocol.dds import init_channels
from g1_mode_manager.protocol.unitree_sdk_internals import channel_datareader, server_request_channel
from unitree_sdk2py.rpc.server import Server

init_channels(int(sys.argv[1]), "lo")
server = Server(sys.argv[2])
server.Start()
channel = server_request_channel(server)
print(json.dumps({"channel": type(channel).__name__, "reader": type(channel_datareader(channel)).__name__}))
"""


def test_a_started_server_receives_on_a_channel_with_a_datareader(sdk_domain: int) -> None:
    path = os.pathsep.join(filter(None, (str(ROOT), os.environ.get("PYTHONPATH"))))  # this checkout's package
    argv = [sys.executable, "-c", _STARTED_SERVER, str(sdk_domain), f"internals_server_{os.getpid()}"]
    done = subprocess.run(argv, cwd=ROOT, env={**os.environ, "PYTHONPATH": path}, capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 0, changed(f"a started Server's request channel is unreachable:\n{done.stderr}")
    shapes = json.loads(done.stdout.strip().splitlines()[-1])
    assert shapes == {"channel": "Channel", "reader": "DataReader"}, changed(f"a started Server's request channel: {shapes}")
