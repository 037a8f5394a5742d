"""The flight recorder's incident files, read as anyone without this package would: the ``mcap`` library's reader
and ``mcap_ros2``'s decoder alone (docs/recorder.md, "The file"). Times are the file's: UNIX seconds."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, NamedTuple

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from support.mode_manager import wait_until

#: The file's metadata record.
METADATA = "incident"
ROBOT_CALLS = "/recorder/robot_calls"


class Message(NamedTuple):
    topic: str
    t: float  # log time: when the node saw the thing
    published: float  # publish time: a call's answer has its request's here
    order: int  # the sequence number: the node's order, which orders messages of one log time
    data: Any  # the decoded ROS message


Json = tuple[Message, dict[str, Any]]


def incident_files(folder: Path, cause: str) -> list[Path]:
    """The written incident files of ``cause`` (fault, emergency, snapshot) in ``folder``, oldest first, by their
    documented name (a file still being written has a ``.part`` name)."""
    return sorted(folder.glob(f"incident_*_{cause}.mcap"))


def wait_for_incident(folder: Path, cause: str, timeout_s: float) -> Path:
    """The one ``cause`` file in ``folder``, waited for."""
    assert wait_until(lambda: bool(incident_files(folder, cause)), timeout_s), \
        f"no {cause} incident in {folder} within {timeout_s} s: {sorted(p.name for p in folder.iterdir())}"
    [path] = incident_files(folder, cause)
    return path


def messages(path: Path) -> list[Message]:
    """Every message of the file, in log time order (the node's order among those of one log time)."""
    with open(path, "rb") as stream:
        reader = make_reader(stream, decoder_factories=[DecoderFactory()])
        got = [Message(channel.topic, message.log_time / 1e9, message.publish_time / 1e9, message.sequence, decoded)
               for _schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=True)]
    return sorted(got, key=lambda m: (m.t, m.order))


def metadata(path: Path) -> dict[str, str]:
    """The file's ``incident`` metadata record (cause, mode, began, window_s, after_s, node)."""
    with open(path, "rb") as stream:
        found = [dict(m.metadata) for m in make_reader(stream).iter_metadata() if m.name == METADATA]
    assert len(found) == 1, f"{path.name}: {len(found)} '{METADATA}' metadata records"
    return found[0]


def json_of(got: list[Message], topic: str) -> list[Json]:
    """Each message on ``topic`` with the JSON of its std_msgs/String (status, robot calls, e-stop steps, notes)."""
    return [(m, json.loads(m.data.data)) for m in got if m.topic == topic]


def answers(got: list[Message]) -> dict[int, Json]:
    """Each robot call's answer by the call's id."""
    return {call["id"]: (m, call) for m, call in json_of(got, ROBOT_CALLS) if call["phase"] == "answer"}


def answered(got: list[Message], request: Json) -> Json:
    """A call's answer, checked against its request: its publish time is when the request was written (the
    request's log time, or microseconds after it), so log less publish time is the robot's latency, which its
    latency_ms says too (both to the nanosecond the file's integer times keep)."""
    by_id = answers(got)
    message, call = request
    assert call["id"] in by_id, f"no answer to {call} in the file"
    answer, value = by_id[call["id"]]
    assert message.t - 1e-6 <= answer.published <= answer.t, (message, answer)
    assert value["latency_ms"] is not None and abs(1e3 * (answer.t - answer.published) - value["latency_ms"]) < 0.01, \
        (answer, value)
    return answer, value
