"""The commander's two file downloads: a recording (``GET /parolkit-recordings/<name>``) and a
saved program (``GET /parolkit-programs/<name>``), each served only from its folder.

A name follows its folder's rules (else 400) and must be one the folder lists (else 404):
nothing outside the folder is ever served.  ``:path`` in the routes lets a name with a
separator ('../x', '..%2Fx') reach the name check and be refused with 400, instead of falling
through to the page (NiceGUI's root page answers every path).
"""

from __future__ import annotations

from fastapi import Response
from fastapi.responses import FileResponse, PlainTextResponse
from nicegui import app

from parolkit.gui.commander import Commander
from parolkit.gui.programs import ProgramNameError
from parolkit.gui.programs_panel import PROGRAMS_URL
from parolkit.gui.recordings import RECORDINGS_URL, RecordingNameError, RecordingNotListed

__all__ = ["install_downloads", "download_recording", "download_program"]


def download_recording(commander: Commander, name: str) -> Response:
    """The listed recording ``name`` as a file download; the file still being recorded is not
    served (409)."""
    try:
        path = commander.recordings.listed(name)
    except RecordingNotListed as exc:
        return PlainTextResponse(f"{exc}\n", status_code=404)
    except RecordingNameError as exc:
        return PlainTextResponse(f"{exc}\n", status_code=400)
    if path.name == commander.recording.active_name:
        return PlainTextResponse(f"{path.name} is still being recorded: stop the recording first\n",
                                 status_code=409)
    return FileResponse(path, filename=path.name, media_type="application/octet-stream",
                        headers={"cache-control": "no-store"})


def download_program(commander: Commander, name: str) -> Response:
    """The saved program ``name`` as a file download (an attachment)."""
    folder = commander.programs
    try:
        file_name = folder.file_name(name)
        path = folder.path(file_name)
    except ProgramNameError as exc:
        return PlainTextResponse(f"{exc}\n", status_code=400)
    if file_name not in folder.names():
        return PlainTextResponse(f"there is no program {file_name!r} in {folder.root}\n", status_code=404)
    return FileResponse(path, filename=file_name, media_type="text/plain; charset=utf-8",
                        content_disposition_type="attachment", headers={"cache-control": "no-store"})


def install_downloads(commander: Commander) -> None:
    """Add both routes to the app."""
    app.add_api_route(f"{RECORDINGS_URL}/{{name:path}}", lambda name: download_recording(commander, name),
                      methods=["GET"], include_in_schema=False)
    app.add_api_route(f"{PROGRAMS_URL}/{{name:path}}", lambda name: download_program(commander, name),
                      methods=["GET"], include_in_schema=False)
