"""The one page: static/index.html with its style and scripts inlined at start, so a single response carries
everything (nothing else is served, nothing is fetched at run time), and a Content-Security-Policy that lets
only these exact scripts and styles run (by their hashes) and only this console's WebSocket be reached."""

from __future__ import annotations

import base64
import hashlib
from dataclasses import dataclass
from pathlib import Path

STATIC = Path(__file__).resolve().with_name("static")
#: In the order they run: the plot, teleop, policy and incident card helpers before the page's main script.
SCRIPTS = ("plot.js", "teleop.js", "policy.js", "incident.js", "console.js")
STYLES = ("console.css",)


@dataclass(frozen=True)
class Page:
    html: bytes
    csp: str


def _hash(text: str) -> str:
    return "'sha256-" + base64.b64encode(hashlib.sha256(text.encode()).digest()).decode() + "'"


def build_page(static: Path = STATIC) -> Page:
    html = (static / "index.html").read_text(encoding="utf-8")
    styles = [(static / name).read_text(encoding="utf-8") for name in STYLES]
    scripts = [(static / name).read_text(encoding="utf-8") for name in SCRIPTS]
    for marker in ("<!-- styles -->", "<!-- scripts -->"):
        if html.count(marker) != 1:
            raise ValueError(f"index.html must hold {marker} once")
    html = html.replace("<!-- styles -->", "".join(f"<style>{s}</style>" for s in styles))
    html = html.replace("<!-- scripts -->", "".join(f"<script>{s}</script>" for s in scripts))
    csp = "; ".join([
        "default-src 'none'",
        f"script-src {' '.join(_hash(s) for s in scripts)}",
        f"style-src {' '.join(_hash(s) for s in styles)}",
        "connect-src 'self'",  # the console's own WebSocket and its incident JSON (same host and port)
        "img-src 'self' data:",
        "frame-ancestors 'none'",  # no other page may frame the E-STOP and the drive pad
        "base-uri 'none'",
        "form-action 'none'",
    ])
    return Page(html.encode("utf-8"), csp)
