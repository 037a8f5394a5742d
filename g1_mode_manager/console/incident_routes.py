"""The incident card's HTTP side: the last incident as JSON (``GET /incident/last``) and an incident file itself
(``GET /incident/file/<name>``), behind the same access rules as every path of the console (server.py's guard).

The JSON carries an ETag: a page that sends it back in If-None-Match gets 304 and no body while the newest file is
the same, so its slow poll costs a folder listing. A download serves only an incident file's bare name from the
incident folder (400 for any other name, 404 for one not there), as an attachment.
"""

from __future__ import annotations

import asyncio

from aiohttp import web

from g1_mode_manager.console.last_incident import BadIncidentNameError, LastIncident

#: What every answer here says besides its body: never cached (a newer incident must show), never sniffed.
HEADERS = {"Cache-Control": "no-store", "X-Content-Type-Options": "nosniff"}


class IncidentRoutes:
    def __init__(self, incidents: LastIncident) -> None:
        self._incidents = incidents

    def add_to(self, app: web.Application) -> None:
        app.router.add_get("/incident/last", self._last)
        app.router.add_get("/incident/file/{name}", self._file)

    async def _last(self, request: web.Request) -> web.Response:
        latest = await asyncio.to_thread(self._incidents.latest)  # a new file's reading must not hold the e-stop
        headers = {**HEADERS, "ETag": latest.etag}
        if request.headers.get("If-None-Match") == latest.etag:
            return web.Response(status=304, headers=headers)
        return web.json_response(latest.payload, headers=headers)

    async def _file(self, request: web.Request) -> web.StreamResponse:
        name = request.match_info["name"]
        try:
            path = await asyncio.to_thread(self._incidents.file, name)
        except BadIncidentNameError as exc:
            return web.Response(status=400, text=f"400: {exc}\n", headers=HEADERS)
        if path is None:
            return web.Response(status=404, text=f"404: no incident file {name} in the incident folder\n",
                                headers=HEADERS)
        return web.FileResponse(path, headers={**HEADERS, "Content-Type": "application/octet-stream",
                                               "Content-Disposition": f'attachment; filename="{name}"'})
