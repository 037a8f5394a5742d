"""An SDK call made from a test process, with a request or reply lost in transport told apart from a robot
that did not answer, on the sim's record.

The SDK's RPC channels are best effort (Cyclone's default reader QoS, KEEP_LAST 1), and a test machine
running three workers on two cores drops UDP datagrams at full socket buffers (the kernel's RcvbufErrors);
a lost request or reply comes back as 3104 after the client's timeout, exactly as a robot that never
answered. The sim records every request it received ("req", at Cyclone's receive time) and every one it
handled ("done"), so the two can be told apart:

* the robot never received the request, or it handled it promptly and in time: the datagram was lost
  between the processes, and the call is made again (only idempotent calls belong here);
* the robot received it and answered late or never: that is the robot's failure, and the test fails
  saying so, whatever a second call would do.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any, TypeVar

from g1_mode_manager.protocol import api_ids as api
from support.sim_record import SimRecord, requests
from support.timing import HANDLED_WITHIN_S, RECORD_SETTLE_S

Result = TypeVar("Result", int, tuple[int, Any])


def call_robot(call: Callable[[], Result], record: SimRecord, api_id: int, *, timeout_s: float,
               attempts: int = 3) -> Result:
    """``call()``'s result (a code, or the SDK's (code, data)). A 3104 whose request or reply was lost in
    transport (see above) is called again, up to ``attempts`` calls in all; ``timeout_s`` is the client's
    timeout. Raises AssertionError if the record shows the robot received the request and did not answer it
    within ``HANDLED_WITHIN_S`` and the timeout."""
    for attempt in range(1, attempts + 1):
        t0 = time.monotonic()
        result = call()
        if (result[0] if isinstance(result, tuple) else result) != api.ERR_CLIENT_API_TIMEOUT:
            return result
        lost = _lost_in_transport(record, api_id, t0, timeout_s)
        print(f"call {attempt} of api {api_id}: 3104, {lost}; calling again" if attempt < attempts else
              f"call {attempt} of api {api_id}: 3104, {lost}; giving up")
    return result


def _lost_in_transport(record: SimRecord, api_id: int, t0: float, timeout_s: float) -> str:
    """Why a call from ``t0`` came back 3104 although the robot was not at fault, or AssertionError."""
    deadline = time.monotonic() + RECORD_SETTLE_S
    while True:
        events = record.events(t0)
        received, done = requests(events, api_id)[:1], requests(events, api_id, "done")[:1]
        if received and done:
            took = done[0]["t"] - received[0]["t"]
            assert took <= HANDLED_WITHIN_S and done[0]["t"] <= t0 + timeout_s, (
                f"the robot received the request {received[0]['t'] - t0:.3f} s after the call and answered "
                f"{took:.3f} s later: slow, not lost")
            return f"the robot answered it in {took * 1e3:.0f} ms (the reply was lost in transport)"
        if time.monotonic() >= deadline:
            assert not received, (
                f"the robot received the request {received[0]['t'] - t0:.3f} s after the call and did not answer it")
            return "the robot never received the request (lost in transport)"
        time.sleep(0.05)
