"""What the soak samples: a process's memory, threads and fds from /proc, the node's ROS endpoints from the ROS
graph, and the node's Unitree SDK (Cyclone DDS) entities from Cyclone's discovery data and from the sim."""

from __future__ import annotations

import os
from typing import Any


def proc_figures(pid: int) -> dict[str, int]:
    """VmRSS and RssAnon (kB), threads (/proc/<pid>/task) and open fds (/proc/<pid>/fd) of a live process."""
    fields = {}
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            key, _, value = line.partition(":")
            if key in ("VmRSS", "RssAnon"):
                fields[key] = int(value.split()[0])
    return {"rss_kb": fields["VmRSS"], "rss_anon_kb": fields["RssAnon"],
            "threads": len(os.listdir(f"/proc/{pid}/task")), "fds": len(os.listdir(f"/proc/{pid}/fd"))}


def rss_kb(pid: int) -> int:
    return proc_figures(pid)["rss_kb"]


def ros_endpoints(graph: Any, namespace: str, prefix: str) -> dict[str, int]:
    """The ROS endpoints of every node in ``namespace`` whose name starts with ``prefix`` (the mode manager and its
    side nodes), as ``graph`` (an rclpy Node of this process) discovers them.

    Publishers and subscriptions are counted one by one (per topic, each endpoint of those nodes); services and
    clients by name (rclpy has no per-endpoint query for them: a second server of one name would not show)."""
    nodes = [(n, ns) for n, ns in graph.get_node_names_and_namespaces() if ns == namespace and n.startswith(prefix)]
    ours = set(nodes)
    out = {"ros_nodes": len(nodes), "ros_pubs": 0, "ros_subs": 0, "ros_services": 0, "ros_clients": 0}
    pub_topics: set[str] = set()
    sub_topics: set[str] = set()
    for name, ns in set(nodes):
        pub_topics |= {t for t, _ in graph.get_publisher_names_and_types_by_node(name, ns)}
        sub_topics |= {t for t, _ in graph.get_subscriber_names_and_types_by_node(name, ns)}
        out["ros_services"] += len(graph.get_service_names_and_types_by_node(name, ns))
        out["ros_clients"] += len(graph.get_client_names_and_types_by_node(name, ns))
    for topic in pub_topics:
        out["ros_pubs"] += sum((e.node_name, e.node_namespace) in ours for e in graph.get_publishers_info_by_topic(topic))
    for topic in sub_topics:
        out["ros_subs"] += sum((e.node_name, e.node_namespace) in ours for e in graph.get_subscriptions_info_by_topic(topic))
    return out


class CycloneGraph:
    """Cyclone DDS discovery on the SDK domain, read through the built-in topics of this process's SDK participant:
    which participants are alive, and the writers and readers of one process's participant (by the ``__Pid``
    property Cyclone puts in every participant's discovery data).

    Made once per process and kept: the SDK's entities must never be garbage-collected while the process lives
    (see harness.sim_bridge)."""

    def __init__(self) -> None:
        from cyclonedds.builtin import (
            BuiltinDataReader,
            BuiltinTopicDcpsParticipant,
            BuiltinTopicDcpsPublication,
            BuiltinTopicDcpsSubscription,
        )
        from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState

        from g1_mode_manager.protocol.unitree_sdk_internals import channel_factory_participant

        participant = channel_factory_participant()
        alive = SampleState.Any | ViewState.Any | InstanceState.Alive  # a lost or deleted entity is no longer Alive
        self._readers = [BuiltinDataReader(participant, topic) for topic in
                         (BuiltinTopicDcpsParticipant, BuiltinTopicDcpsPublication, BuiltinTopicDcpsSubscription)]
        self._alive = [ReadCondition(r, alive) for r in self._readers]

    def _read(self, k: int) -> list[Any]:
        return list(self._readers[k].read(N=100_000, condition=self._alive[k]))

    def figures(self, pid: int) -> dict[str, int]:
        """Alive participants on the domain, and the writers and readers of ``pid``'s participants."""
        participants = self._read(0)
        theirs = {str(p.key) for p in participants if _pid_of(p) == pid}
        writers = sum(str(w.participant_key) in theirs for w in self._read(1))
        readers = sum(str(r.participant_key) in theirs for r in self._read(2))
        return {"sdk_participants": len(participants), "sdk_node_writers": writers, "sdk_node_readers": readers}


def _pid_of(participant: Any) -> int | None:
    for policy in participant.qos or ():
        if getattr(policy, "key", None) == "__Pid":
            try:
                return int(policy.value)
            except ValueError:
                return None
    return None


def sim_matched_readers(status: dict[str, Any]) -> int:
    """Readers the sim's state writers have matched (its status' ``readers``, one count per state topic), summed."""
    return sum(max(0, n) for n in status.get("readers", {}).values())
