"""The machine's change listener is handed out before its listeners exist: each added later is still called."""

from __future__ import annotations

from g1_mode_manager.node.wiring import ChangeListeners


def test_listeners_added_after_the_hand_out_are_called_in_the_order_added() -> None:
    changes = ChangeListeners()
    on_change = changes  # what the machine keeps
    on_change("before any listener")  # nothing to call yet: nothing happens
    heard: list[tuple[str, object]] = []
    changes.add(lambda status: heard.append(("wake", status)))
    changes.add(lambda status: heard.append(("publish", status)))
    on_change("status")
    assert heard == [("wake", "status"), ("publish", "status")]
