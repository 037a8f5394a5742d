"""The Last incident card's endpoints on the console process, over real HTTP: the newest incident as JSON (with an
ETag a page sends back to be told "unchanged"), the file itself as an attachment with the bytes on disk; a name that
is not an incident file's, or a path out of the folder, refused; a damaged newest file reported, the console serving
on; and, as on every other path, nothing at all without the token. A console without a folder of its own shows the
mode manager's."""

from __future__ import annotations

import asyncio
import http.client
import json
from collections.abc import Iterator, Mapping
from pathlib import Path

import pytest

from support.console import Console, FakeManager, start_console
from support.incident_files import EPOCH, STOP, VIA, estop_incident
from support.mode_manager import wait_until
from support.timing import margin

TOKEN = "incident-card-token"
BEARER = {"Authorization": f"Bearer {TOKEN}"}


def _get(url: str, headers: dict[str, str] | None = None) -> tuple[int, Mapping[str, str], bytes]:
    """(status, headers (any case), body) of one GET, as a script sends it."""
    import aiohttp

    async def go() -> tuple[int, Mapping[str, str], bytes]:
        async with aiohttp.ClientSession() as session, session.get(url, headers=headers or {}) as r:
            return r.status, r.headers.copy(), await r.read()

    return asyncio.run(go())


def _raw(console: Console, path: str) -> tuple[int, bytes]:
    """A GET of ``path`` exactly as written (no client normalises a ``..`` or a ``%2F`` away)."""
    conn = http.client.HTTPConnection("127.0.0.1", console.port, timeout=10)
    try:
        conn.putrequest("GET", path, skip_host=True)
        conn.putheader("Host", f"127.0.0.1:{console.port}")
        conn.putheader("Authorization", f"Bearer {TOKEN}")
        conn.endheaders()
        r = conn.getresponse()
        return r.status, r.read()
    finally:
        conn.close()


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("incident_http") / "incidents"


@pytest.fixture(scope="module")
def console(folder: Path) -> Iterator[Console]:
    c = start_console(f"token:={TOKEN}", f"recorder_dir:={folder}")
    yield c
    assert c.proc.stop() == 0, c.proc.output()


def test_without_the_token_neither_the_incident_nor_its_file_is_served(console: Console, folder: Path) -> None:
    path = estop_incident(folder)
    for url in (f"{console.url}incident/last", f"{console.url}incident/file/{path.name}"):
        for headers in (None, {"Authorization": "Bearer wrong"}):
            status, _h, body = _get(url, headers)
            assert status == 401 and body == b"401: a valid token is required\n", (url, status, body[:80])
        status, _h, _b = _get(url + "?token=wrong")
        assert status == 401


def test_the_newest_incident_as_json_then_304_while_it_stays_the_newest(console: Console, folder: Path) -> None:
    estop_incident(folder, began=EPOCH + STOP)
    newest = estop_incident(folder, began=EPOCH + STOP + 3600.0)
    status, headers, body = _get(f"{console.url}incident/last?token={TOKEN}")
    assert status == 200 and headers["Content-Type"].startswith("application/json")
    assert headers["Cache-Control"] == "no-store"
    payload = json.loads(body)
    incident = payload["incident"]
    assert payload["folder"] == str(folder)
    assert incident["name"] == newest.name and incident["cause"] == f"EMERGENCY from HIGH_LEVEL ({VIA})"
    assert incident["mode"] == "EMERGENCY" and incident["series"]["tilt"] and incident["steps"]
    etag = headers["ETag"]
    status, again, body = _get(f"{console.url}incident/last", {**BEARER, "If-None-Match": etag})
    assert status == 304 and body == b"" and again["ETag"] == etag
    newer = estop_incident(folder, began=EPOCH + STOP + 7200.0)  # a new incident: the old tag no longer matches
    status, _h, body = _get(f"{console.url}incident/last", {**BEARER, "If-None-Match": etag})
    assert status == 200 and json.loads(body)["incident"]["name"] == newer.name


def test_the_file_downloads_as_an_attachment_with_the_bytes_on_disk(console: Console, folder: Path) -> None:
    path = estop_incident(folder, began=EPOCH + STOP + 10800.0)
    status, headers, body = _get(f"{console.url}incident/file/{path.name}?token={TOKEN}")
    assert status == 200 and body == path.read_bytes()
    assert headers["Content-Disposition"] == f'attachment; filename="{path.name}"'
    assert headers["Content-Type"] == "application/octet-stream"


def test_names_that_are_not_an_incident_file_of_the_folder_are_refused(console: Console, folder: Path) -> None:
    path = estop_incident(folder, began=EPOCH + STOP + 14400.0)
    secret = folder.parent / path.name  # an incident's name outside the folder, one level up
    secret.write_bytes(b"SECRET outside the incident folder")
    (folder / "notes.txt").write_bytes(b"SECRET in the folder, not an incident")
    (folder / (path.name + ".part")).write_bytes(b"SECRET half written")
    refused = {f"/incident/file/..%2F{path.name}": 400, "/incident/file/notes.txt": 400,
               f"/incident/file/{path.name}.part": 400, "/incident/file/%2Fetc%2Fpasswd": 400,
               f"/incident/file/{path.name.replace('emergency', 'fault')}": 404}
    for target, expected in refused.items():
        status, body = _raw(console, target + f"?token={TOKEN}")
        assert status == expected and b"SECRET" not in body, (target, status, body[:100])
    for target in (f"/incident/file/../{path.name}", f"/incident/file/../../{folder.parent.name}/{path.name}",
                   "/incident/file/../../../../etc/passwd"):
        status, body = _raw(console, target)
        assert status in (400, 404) and b"SECRET" not in body and b"root:" not in body, (target, status, body[:100])


def test_a_damaged_newest_file_is_reported_and_the_console_serves_on(console: Console, folder: Path) -> None:
    path = estop_incident(folder, began=EPOCH + STOP + 18000.0)
    path.write_bytes(path.read_bytes()[:700])
    status, _h, body = _get(f"{console.url}incident/last", BEARER)
    incident = json.loads(body)["incident"]
    assert status == 200 and incident["name"] == path.name
    assert incident["error"].startswith(f"{path.name} cannot be read: ") and "series" not in incident
    assert _get(console.url, BEARER)[0] == 200 and console.proc.alive()
    status, _h, body = _get(f"{console.url}incident/file/{path.name}", BEARER)  # still downloadable, as it is
    assert status == 200 and body == path.read_bytes()


def test_without_a_folder_of_its_own_the_console_shows_the_mode_managers(tmp_path: Path) -> None:
    folder = tmp_path / "the_nodes_incidents"
    path = estop_incident(folder)
    manager = FakeManager("HIGH_LEVEL", recorder_dir=str(folder))
    try:
        c = start_console()  # no recorder_dir: the node's, read with its other parameters
        try:
            last = lambda: json.loads(_get(f"{c.url}incident/last")[2])  # noqa: E731
            assert wait_until(lambda: last()["folder"] == str(folder), margin(10.0)), last()
            assert last()["incident"]["name"] == path.name
        finally:
            assert c.proc.stop() == 0, c.proc.output()
    finally:
        manager.close()
