"""One page's editor kept in step with the shared program document (NiceGUI side).

The page's half is commander.js ``pkDoc`` (see :mod:`parolkit.gui.program_doc` for the
scheme).  Messages, page to server (the NiceGUI event ``pk_doc``):

* ``{"op": "hello"}``: the editor is on the page: it gets the whole text and its revision (and
  merges what was typed meanwhile into it, as the difference from the text it started with).
* ``{"op": "push", "base": r, "changes": [...]}``: the changes typed on the text of revision
  ``r``; the answer says whether they were applied (``ack``), after any updates it lacked.
* ``{"op": "since", "revision": r}``: the page missed messages (a reconnect): it gets the
  updates after ``r`` (or the whole text).

Server to page (``pkDoc.receive``): ``{"from": r, "updates": [[mine, change], ...], "ack": bool}``
(``ack`` only in the answer to a push; ``mine`` 1 for the page's own updates, which confirm its
changes) or ``{"reset": text, "revision": r}`` (with ``"refused": reason`` when the page's
changes were refused: it drops them).  The server's updates reach every page at once.
"""

from __future__ import annotations

import json
from typing import Any

from nicegui import ui

from parolkit.gui.eventlog import EventLog, Level
from parolkit.gui.program_doc import EditRefused, ProgramDoc

__all__ = ["EditorSync", "FLUSH_TIMEOUT_S"]

#: how long Check, Run and Save wait for the page's changes to reach the document, s
FLUSH_TIMEOUT_S = 3.0


class EditorSync:
    """The page's editor and the document: the page's pushes applied, the document's updates
    sent on (from the page's hello on)."""

    def __init__(self, doc: ProgramDoc, log: EventLog) -> None:
        self.doc = doc
        self.log = log
        self.client = ui.context.client
        self.editor_id = doc.attach()
        #: the revision the page has been sent up to (None: its editor has not said hello)
        self._sent: int | None = None
        ui.on("pk_doc", self._on_message)
        doc.subscribe(self._send_updates)
        self.client.on_delete(lambda: doc.unsubscribe(self._send_updates))

    def _on_message(self, e: Any) -> None:
        args = e.args if isinstance(e.args, dict) else {}
        op = args.get("op")
        if op == "hello":
            self._reset()
        elif op == "push":
            self._push(args.get("base"), args.get("changes"))
        elif op == "since":
            revision = args.get("revision")
            if isinstance(revision, int) and self.doc.since(revision) is not None:
                self._sent = revision
                self._send_updates()
            else:
                self._reset()

    def _push(self, base: object, changes: object) -> None:
        if self._sent is None:
            self._reset()  # a push before hello (a page from before a restart): it gets the text
            return
        try:
            accepted = self.doc.push(self.editor_id, base, changes)
        except EditRefused as exc:
            self.log.error(f"an edit from a page was refused (that page shows the program as it was): {exc}")
            self._reset(refused=str(exc))
            return
        self._send_updates(ack=accepted)

    def _reset(self, refused: str | None = None) -> None:
        """The page takes the whole text (``refused``: why its pending changes were refused)."""
        self._sent = self.doc.revision
        msg: dict[str, Any] = {"reset": self.doc.text, "revision": self.doc.revision}
        if refused is not None:
            msg["refused"] = refused
        self._call(msg)

    def _send_updates(self, ack: bool | None = None) -> None:
        """Send the page the updates it has not been sent (and the answer to its push)."""
        if self._sent is None:
            return
        updates = self.doc.since(self._sent)
        if updates is None:
            self._reset()
            return
        if not updates and ack is None:
            return
        msg: dict[str, Any] = {"from": self._sent,
                               "updates": [[int(u.editor == self.editor_id), u.change.to_wire()] for u in updates]}
        if ack is not None:
            msg["ack"] = ack
        self._sent = self.doc.revision
        self._call(msg)

    def _call(self, msg: dict[str, Any]) -> None:
        self.client.run_javascript(f"window.pkDoc && window.pkDoc.receive({json.dumps(msg)})")

    async def flush(self) -> None:
        """Wait until the changes typed in the page have reached the document (at most
        :data:`FLUSH_TIMEOUT_S`; a page that does not answer leaves the document as it is)."""
        if self._sent is None:
            return
        try:
            await self.client.run_javascript("window.pkDoc ? window.pkDoc.flush() : null", timeout=FLUSH_TIMEOUT_S)
        except TimeoutError:
            self.log.add(f"the page's latest edits did not arrive within {FLUSH_TIMEOUT_S:g} s: using the "
                         "program as the server has it", Level.WARNING)
