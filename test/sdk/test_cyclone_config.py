"""Our Cyclone XML: unicast-only loopback for our clients, loopback multicast + unicast for the sim bridge
(found by every kind of client, docs/robot_compat.md), the robot's defaults on a real interface."""

from __future__ import annotations

import xml.etree.ElementTree as ET

from g1_mode_manager.protocol.dds import cyclone_config


def _parse(xml: str) -> ET.Element:
    return ET.fromstring(xml.split("?>", 1)[1])


def test_loopback_clients_discover_by_unicast_only() -> None:
    root = _parse(cyclone_config("lo"))
    assert root.findtext(".//AllowMulticast") == "false"
    assert [p.get("address") for p in root.iter("Peer")] == ["127.0.0.1"]
    assert root.findtext(".//ParticipantIndex") == "auto"


def test_the_bridge_on_loopback_also_serves_multicast_and_stays_on_lo() -> None:
    root = _parse(cyclone_config("lo", serve_multicast=True))
    assert root.findtext(".//AllowMulticast") == "true"
    assert [(n.get("name"), n.get("multicast")) for n in root.iter("NetworkInterface")] == [("lo", "true")]
    assert [p.get("address") for p in root.iter("Peer")] == ["127.0.0.1"]  # unicast clients: still found
    assert root.findtext(".//ParticipantIndex") == "auto"  # Cyclone 0.10 clients probe the index ports


def test_robot_interface_keeps_the_robots_defaults() -> None:
    root = _parse(cyclone_config("eth0", serve_multicast=True))
    assert [n.get("name") for n in root.iter("NetworkInterface")] == ["eth0"]
    assert root.find(".//Peer") is None and root.find(".//AllowMulticast") is None
