"""The cyclonedds-python private names ``protocol/cyclone_internals.py`` relies on still exist and still work.

Each check names what changed, so a cyclonedds upgrade that breaks the product's fast paths fails here
first, with the place to fix. DDS on loopback, on this run's own domain (``sdk_channels``).
"""

from __future__ import annotations

import os

import pytest
from cyclonedds.core import Listener
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

from g1_mode_manager.protocol.cyclone_internals import (
    complete_type_id,
    delete_entity,
    held_listener,
    minimal_type_hash,
    take_serialized,
    write_serialized,
    writer_use_version_2,
)
from g1_mode_manager.protocol.dds import apply_robot_type_compat, sdk_participant
from g1_mode_manager.protocol.idl import SportModeState_
from support.mode_manager import wait_until

HOME = "see g1_mode_manager/protocol/cyclone_internals.py"


def changed(what: str) -> str:
    return f"cyclonedds changed: {what}; {HOME}"


def test_the_c_layer_still_writes_and_takes_serialised_samples() -> None:
    from cyclonedds import _clayer

    for name in ("ddspy_take", "ddspy_write"):
        assert callable(getattr(_clayer, name, None)), changed(f"cyclonedds._clayer has no {name}")


def test_xtypes_kinds_of_uint8_and_int8_can_be_chosen() -> None:
    from cyclonedds.idl._typesupport.DDS import XTypes

    for name in ("TK_UINT8", "TK_INT8", "TK_BYTE", "TK_CHAR8"):
        assert isinstance(getattr(XTypes, name, None), int), changed(f"cyclonedds.idl._typesupport.DDS.XTypes has no {name}")
    apply_robot_type_compat()  # what every process of the product does before its first topic
    assert (XTypes.TK_UINT8, XTypes.TK_INT8) == (XTypes.TK_BYTE, XTypes.TK_CHAR8), changed("XTypes kinds are not settable")


def test_minimal_type_hash_is_still_built_by_xtbuilder() -> None:
    try:
        from cyclonedds.idl._xt_builder import XTBuilder
    except ImportError:
        pytest.fail(changed("cyclonedds.idl._xt_builder.XTBuilder is gone"))
    assert callable(getattr(XTBuilder, "process_type", None)), changed("XTBuilder has no process_type")
    digest = minimal_type_hash(SportModeState_)
    assert isinstance(digest, bytes) and len(digest) == 14, changed(f"a minimal type hash is {digest!r}, not 14 bytes")
    complete = complete_type_id(SportModeState_)
    assert isinstance(complete, bytes) and complete, changed(f"a complete type id is {complete!r}")


@pytest.fixture
def endpoints(sdk_channels: int):
    """A writer and a reader (with a listener) of one topic of this test, on the SDK's participant."""
    participant = sdk_participant()
    assert isinstance(participant, DomainParticipant)
    topic = Topic(participant, f"test/cyclone_internals_{os.getpid()}", SportModeState_)
    listener = Listener()
    writer = DataWriter(participant, topic)
    reader = DataReader(participant, topic, listener=listener)
    yield writer, reader, listener
    delete_entity(writer)


def test_entities_still_have_the_private_attributes_used(endpoints) -> None:
    writer, reader, listener = endpoints
    for entity in (writer, reader):
        assert isinstance(getattr(entity, "_ref", None), int), changed(f"{type(entity).__name__} has no int _ref")
    assert hasattr(writer, "_use_version_2"), changed("DataWriter has no _use_version_2")
    assert writer_use_version_2(writer) in (None, True, False), changed("DataWriter._use_version_2 is not None/bool")
    assert hasattr(reader, "_listener"), changed("DataReader has no _listener")
    assert held_listener(reader) is listener, changed("DataReader._listener is not the Listener it was given")


def test_serialised_samples_written_and_taken_are_the_serialiser_s_bytes(endpoints) -> None:
    writer, reader, _ = endpoints
    sample = SportModeState_(fsm_id=501, fsm_mode=2, task_id=7, task_time=1.5)
    data = sample.serialize(use_version_2=writer_use_version_2(writer))
    assert wait_until(lambda: writer.get_publication_matched_status().current_count >= 1, 10.0)
    assert write_serialized(writer, data), changed("ddspy_write(writer._ref, bytes) refused a serialised sample")
    taken: list[tuple[bytes, object]] = []

    def took() -> bool:
        taken.extend(take_serialized(reader, 4))
        return bool(taken)

    assert wait_until(took, 5.0), changed("ddspy_take(reader._ref, mask, n) returned nothing")
    raw, info = taken[0]
    assert getattr(info, "valid_data", False), changed("ddspy_take's SampleInfo has no valid_data")
    assert SportModeState_.deserialize(raw) == sample, changed("ddspy_take's bytes are not the serialised sample")
    assert take_serialized(reader, 4) == []


def test_delete_entity_deletes_it_now(endpoints) -> None:
    writer, reader, _ = endpoints
    assert wait_until(lambda: writer.get_publication_matched_status().current_count >= 1, 10.0)
    delete_entity(reader)
    assert wait_until(lambda: writer.get_publication_matched_status().current_count == 0, 5.0), changed(
        "Entity.__del__() no longer deletes the DDS entity")
    assert take_serialized(reader, 1) == []  # a deleted reader: DDS refuses, nothing taken
