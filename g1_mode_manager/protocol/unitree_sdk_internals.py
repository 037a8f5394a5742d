"""The private parts of unitree_sdk2py this project relies on, and nothing else.

The Python SDK keeps what a faster or better-instrumented client or server needs behind name-mangled
attributes with no accessor: the DDS participant, the channels of an RPC client, server and of a
publisher or subscriber, the cyclonedds reader and writer inside a channel and its matched-reader
count, and the ``Server``'s own dispatcher. Every other module calls the functions here instead of
spelling those names, so an SDK change that renames one breaks this module only, and
``test/sdk/test_unitree_sdk_internals.py`` names what moved. In ``protocol/`` because the sim and
``protocol/dds.py`` use it too. The SDK is imported on first call: importing this module (or
``protocol/dds.py``) does not load it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any


def channel_factory_initialized() -> bool:
    """Whether the SDK's process-wide DDS domain exists (``ChannelFactory.Init`` succeeded)."""
    from unitree_sdk2py.core.channel import ChannelFactory

    return bool(getattr(ChannelFactory, "_ChannelFactory__initialized", False))


def channel_factory_participant() -> Any | None:
    """The DomainParticipant of the SDK's process-wide domain, or None before ``ChannelFactory.Init``."""
    from unitree_sdk2py.core.channel import ChannelFactory

    return getattr(ChannelFactory, "_ChannelFactory__participant", None)


def client_stub(client: Any) -> Any:
    """The ``ClientStub`` of an SDK RPC client (``ClientBase``): its request and response channels."""
    return client._ClientBase__stub


def client_request_channel(stub: Any) -> Any:
    """The channel a ``ClientStub`` writes its requests on."""
    return stub._ClientStub__sendChannel


def client_response_channel(stub: Any) -> Any:
    """The channel a ``ClientStub`` receives every reply of its service on."""
    return stub._ClientStub__recvChannel


def server_request_channel(server: Any) -> Any:
    """The channel an SDK RPC server (``ServerBase``) receives requests on (None before it is started)."""
    return server._ServerBase__serverStub._ServerStub__recvChannel


def server_request_handler(server: Any) -> Callable[[Any], None]:
    """The SDK ``Server``'s own dispatcher of one request (the one ``Server.Start`` installs): api version
    query, handler lookup, reply."""
    return server._Server__ServerRequestHandler


def server_handler(server: Any, api_id: int) -> tuple[Callable[[str], Any] | None, bool]:
    """(handler, checks lease) registered on an SDK ``Server`` for ``api_id``; (None, False) if none."""
    return server._Server__GetHandler(api_id)


def publisher_channel(publisher: Any) -> Any:
    """The channel behind a ``ChannelPublisher``."""
    return publisher._ChannelPublisher__channel


def subscriber_channel(subscriber: Any) -> Any:
    """The channel behind a ``ChannelSubscriber``."""
    return subscriber._ChannelSubscriber__channel


def channel_datawriter(channel: Any) -> Any:
    """The cyclonedds DataWriter of a channel (None until its writer is set)."""
    return channel._Channel__writer._Writer__writer


def channel_datareader(channel: Any) -> Any:
    """The cyclonedds DataReader of a channel (None until its reader is set)."""
    return channel._Channel__reader._Reader__reader


def channel_matched_readers(channel: Any) -> int:
    """How many readers a channel's writer has matched now, as its matched listener last counted them (what
    the SDK's ``Write`` waits on)."""
    return channel._Channel__writer._Writer__publication_matched_count


#: The SDK modules whose constructors sleep after creating their entities (an RPC stub 0.5 s, a writer 0.2 s).
_SLEEPING_MODULES = ("unitree_sdk2py.rpc.server_stub", "unitree_sdk2py.rpc.client_stub", "unitree_sdk2py.core.channel")


def route_sdk_sleeps(sleep: Callable[[float], None]) -> None:
    """Make the SDK's own ``time.sleep`` calls (its constructors' discovery waits, its writers' match polls) call
    ``sleep`` instead; every other ``time`` function stays the standard one."""
    import importlib
    import time

    class _Time:
        def __getattr__(self, name: str) -> Any:
            return getattr(time, name)

    routed = _Time()
    routed.sleep = sleep  # type: ignore[attr-defined]
    for name in _SLEEPING_MODULES:
        importlib.import_module(name).time = routed  # type: ignore[attr-defined]
