"""Cyclone DDS set-up for the Unitree SDK2: robot type compatibility and a loopback-only domain."""

from __future__ import annotations

import threading
from typing import Any

from g1_mode_manager.protocol.cyclone_internals import minimal_type_hash, use_byte_and_char8_kinds
from g1_mode_manager.protocol.unitree_sdk_internals import channel_factory_initialized, channel_factory_participant

_compat_lock = threading.Lock()
_compat_applied = False


def apply_robot_type_compat() -> None:
    """Describe uint8/int8 the way the robot's Cyclone DDS 0.10 does.

    cyclonedds-python 11 uses XTypes kinds for uint8/int8 that 0.10 does not know, so a real G1
    never matches our topics (every RPC answers 3102). With BYTE/CHAR8 the minimal type identifiers
    equal those compiled into the robot's C++ SDK. Must run before the first topic is created.
    """
    global _compat_applied
    with _compat_lock:
        if not _compat_applied:
            use_byte_and_char8_kinds()
            _compat_applied = True


def minimal_type_id(idl_type: type) -> str:
    """Hex of the 14-byte minimal type hash of an IDL type: a real G1 matches a topic only if it equals the
    hash compiled into the robot's C++ SDK."""
    return minimal_type_hash(idl_type).hex()


LOOPBACK_INTERFACE = "lo"


def cyclone_config(interface: str, *, peers: tuple[str, ...] = (), serve_multicast: bool = False) -> str:
    """Cyclone DDS XML for one network interface.

    On loopback discovery is by unicast to 127.0.0.1 with auto participant indices, so tests never
    announce themselves onto the machine's network. ``serve_multicast`` (the sim bridge: a robot must be
    found by every kind of client) also enables multicast on lo, which never leaves the machine: the
    SDK's plain ``ChannelFactoryInitialize(d, "lo")`` on cyclonedds 11 discovers only by multicast there,
    Cyclone 0.10 and our clients only by unicast. On a robot interface the robot's own defaults apply
    (multicast discovery on that interface only).
    """
    if interface == LOOPBACK_INTERFACE:
        peers = peers or ("127.0.0.1",)
        peer_xml = "".join(f'<Peer address="{p}"/>' for p in peers)
        multicast = ('<NetworkInterface name="lo" multicast="true"/></Interfaces><AllowMulticast>true'
                     if serve_multicast else '<NetworkInterface name="lo"/></Interfaces><AllowMulticast>false')
        return (
            '<?xml version="1.0" encoding="UTF-8" ?><CycloneDDS><Domain Id="any">'
            f"<General><Interfaces>{multicast}</AllowMulticast></General>"
            "<Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>60"
            f"</MaxAutoParticipantIndex><Peers>{peer_xml}</Peers></Discovery>"
            "</Domain></CycloneDDS>"
        )
    return (
        '<?xml version="1.0" encoding="UTF-8" ?><CycloneDDS><Domain Id="any">'
        f'<General><Interfaces><NetworkInterface name="{interface}" priority="default" '
        'multicast="default"/></Interfaces></General></Domain></CycloneDDS>'
    )


def init_channels(domain_id: int, interface: str, *, serve_multicast: bool = False) -> None:
    """Initialise the SDK's process-wide DDS domain (idempotent; one domain per process).

    Unlike ``ChannelFactoryInitialize`` this uses our configuration (``cyclone_config``): no trace log
    in /tmp, and on loopback no multicast unless ``serve_multicast``. Raises RuntimeError if the domain
    cannot be created.
    """
    from unitree_sdk2py.core import channel as sdk_channel

    apply_robot_type_compat()
    factory = sdk_channel.ChannelFactory()
    if channel_factory_initialized():
        return
    original = sdk_channel.ChannelConfigHasInterface
    sdk_channel.ChannelConfigHasInterface = cyclone_config(interface, serve_multicast=serve_multicast)
    try:
        ok = factory.Init(domain_id, interface)
    finally:
        sdk_channel.ChannelConfigHasInterface = original
    if not ok:
        raise RuntimeError(f"cannot create the Unitree SDK2 DDS domain {domain_id} on interface {interface!r}")


def sdk_participant() -> Any:
    """The DDS participant of the SDK's process-wide domain (private in the SDK: no accessor)."""
    participant = channel_factory_participant()
    if participant is None:
        raise RuntimeError("the SDK's DDS domain is not initialised (call protocol.dds.init_channels first)")
    return participant
