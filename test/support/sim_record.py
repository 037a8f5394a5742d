"""The sim's own record (``harness.sim_record``, shared with the benchmarks), under the name the tests import."""

from harness.sim_record import (
    Event,
    IncompleteRecordError,
    SimRecord,
    confirming_damp,
    damped,
    fsm_of,
    is_damp,
    of_kind,
    requests,
    sent_at,
    states,
    velocity_of,
)

__all__ = ["Event", "IncompleteRecordError", "SimRecord", "confirming_damp", "damped", "fsm_of", "is_damp", "of_kind",
           "requests", "sent_at", "states", "velocity_of"]
