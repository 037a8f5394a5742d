"""Who may use the console: a token for any bind beyond loopback, and the Host and Origin a browser sends.

A console bound to loopback without a token is reachable only from this machine, but any web page open in a
browser here could still talk to it: a page of another origin is refused by its Origin header (a browser
always sends it on a WebSocket), and a DNS name rebound to 127.0.0.1 by its Host header. With a token, every
request (the page and the WebSocket alike) must present it, or gets 401 and nothing else.
"""

from __future__ import annotations

import hmac
import ipaddress
from collections.abc import Mapping
from pathlib import Path
from urllib.parse import urlsplit

#: Host names that mean this machine; anything else must be an address in a loopback range.
LOOPBACK_NAMES = frozenset({"localhost", "ip6-localhost", "ip6-loopback"})
#: The query parameter that carries the token (a browser cannot set headers on a WebSocket).
TOKEN_QUERY = "token"


def is_loopback(host: str) -> bool:
    """``host`` (a name or an address, with or without IPv6 brackets) is this machine only."""
    name = host.strip().strip("[]").lower()
    if name in LOOPBACK_NAMES:
        return True
    try:
        return ipaddress.ip_address(name).is_loopback
    except ValueError:
        return False


def load_token(token: str, token_file: str) -> str:
    """The token from the parameter or from a file (its first line); both given is an error."""
    if token and token_file:
        raise ValueError("give either token or token_file, not both")
    if token_file:
        lines = Path(token_file).read_text(encoding="utf-8").splitlines()
        token = lines[0] if lines else ""
        if not token.strip():
            raise ValueError(f"token_file {token_file}: empty")
    return token.strip()


def _hostname(host_header: str) -> str:
    """The name of a Host header, without its port ("[::1]:8080" -> "::1")."""
    return urlsplit(f"//{host_header}").hostname or ""


class Access:
    """The rules for one bind address and token."""

    def __init__(self, bind_host: str, token: str) -> None:
        if not token and not is_loopback(bind_host):
            raise ValueError(f"binding to {bind_host} reaches other machines: it needs a token (parameter token or "
                             "token_file); without one, bind to 127.0.0.1")
        self._token = token.encode()
        self.loopback_only = is_loopback(bind_host)

    @property
    def needs_token(self) -> bool:
        return bool(self._token)

    def token_ok(self, query: Mapping[str, str], headers: Mapping[str, str]) -> bool:
        """The token from ``?token=`` or ``Authorization: Bearer``, compared in constant time."""
        if not self._token:
            return True
        presented = query.get(TOKEN_QUERY)
        if presented is None:
            scheme, _, value = headers.get("Authorization", "").partition(" ")
            presented = value.strip() if scheme.lower() == "bearer" else ""
        return hmac.compare_digest(presented.encode(), self._token)

    def host_ok(self, host_header: str | None) -> bool:
        """Without a token only loopback names are served: a foreign DNS name resolving to 127.0.0.1 (DNS
        rebinding) would otherwise let a remote page in through the operator's browser."""
        if self._token or not self.loopback_only:
            return True
        return host_header is not None and is_loopback(_hostname(host_header))

    @staticmethod
    def origin_ok(origin: str | None, host_header: str | None) -> bool:
        """A WebSocket from a browser must come from this console's own page (same host and port). No Origin:
        not a browser (a script, a test), which a web page cannot make use of."""
        if origin is None:
            return True
        if host_header is None:
            return False
        return urlsplit(origin).netloc.lower() == host_header.lower()
