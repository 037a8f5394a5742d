"""The private parts of cyclonedds-python this project relies on, and nothing else.

cyclonedds-python has no public way to write or take samples as ready-made CDR bytes, to keep the
listener an entity holds alive, to delete an entity before the garbage collector does, to read a type's
minimal and complete identifiers, or to choose the XTypes kinds of uint8/int8 (the robot's Cyclone DDS 0.10 uses
others); the product's hot paths, its robot compatibility and the sim need all of them. Every other
module calls the functions here instead of touching cyclonedds' private names, so a cyclonedds
upgrade that moves one breaks this module only, and ``test/sdk/test_cyclone_internals.py`` names what
moved. In ``protocol/`` because the sim uses it too.
"""

from __future__ import annotations

from typing import Any, Final

from cyclonedds import _clayer
from cyclonedds.core import InstanceState, SampleState, ViewState
from cyclonedds.idl._typesupport.DDS import XTypes

_ANY_STATE: Final = SampleState.Any | ViewState.Any | InstanceState.Any


def use_byte_and_char8_kinds() -> None:
    """From now on describe uint8 as the XTypes kind BYTE and int8 as CHAR8, in every type of the process
    (``protocol.dds.apply_robot_type_compat`` says why)."""
    XTypes.TK_UINT8 = XTypes.TK_BYTE
    XTypes.TK_INT8 = XTypes.TK_CHAR8


def minimal_type_hash(idl_type: type) -> bytes:
    """The 14-byte hash of an IDL type's minimal XTypes identifier, as announced in discovery."""
    from cyclonedds.idl._xt_builder import XTBuilder

    info, _ = XTBuilder.process_type(idl_type)
    return bytes(info.minimal.typeid_with_size.type_id.value)


def complete_type_id(idl_type: type) -> bytes:
    """The value of an IDL type's complete XTypes identifier: what a discovered endpoint's ``type_id`` holds."""
    from cyclonedds.idl._xt_builder import XTBuilder

    info, _ = XTBuilder.process_type(idl_type)
    return bytes(info.complete.typeid_with_size.type_id.value)


def take_serialized(reader: Any, max_samples: int) -> list[tuple[bytes, Any]]:
    """Take up to ``max_samples`` samples of any state from a DataReader, undecoded: (CDR bytes with their
    encapsulation header, SampleInfo) each, oldest first; an empty list if none (or DDS refused)."""
    taken = _clayer.ddspy_take(reader._ref, _ANY_STATE, max_samples)
    return [] if isinstance(taken, int) else taken


def write_serialized(writer: Any, data: bytes) -> bool:
    """Publish one sample given as CDR bytes (encapsulation header first) on a DataWriter; False if DDS
    refused it. The bytes are not checked: they must be what ``writer.write`` would have produced."""
    return _clayer.ddspy_write(writer._ref, data) >= 0


def writer_use_version_2(writer: Any) -> bool | None:
    """The ``use_version_2`` a DataWriter serialises with (None: the type's own; True: XCDR2; False: XCDR1),
    so that ready-made bytes can be checked against its own serialisation."""
    return writer._use_version_2


def held_listener(entity: Any) -> Any:
    """The Listener object an entity holds (``get_listener()`` returns a copy), or None."""
    return entity._listener


def delete_entity(entity: Any) -> None:
    """Delete a DDS entity now (cyclonedds deletes it only when its Python object is collected)."""
    entity.__del__()
