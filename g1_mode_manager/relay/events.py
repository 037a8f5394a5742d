"""The relays' counters and throttled log lines live in ``core.events`` (the head LED display reports
through them too); this name stays for the node's wiring, which still imports them from here."""

from g1_mode_manager.core.events import RelayEvents

__all__ = ["RelayEvents"]
