// The commander's keyboard and pointer rules (parolkit.gui).  Served from the package as
// /parolkit-static/commander.js; the key list comes from the page's #pk-keymap data island
// (parolkit.gui.jog.KEYMAP).  Every key goes to the server as the NiceGUI event "pk_key".
//
//  * Esc is E-STOP whatever has the focus (the editor too), except while a dialog or a menu
//    is open: then Esc only closes it.
//  * Space is STOP whatever has the focus, except in a text field (it types a space there).
//    The page takes Space before any button sees it, so a focused button is never "pressed
//    again" by it.
//  * Jog keys are ignored while typing (inputs, the editor) or adjusting a slider.
//  * A held jog ends on any pointer release or cancel anywhere on the page and when the
//    window loses focus.
(() => {
  "use strict";
  const island = document.getElementById("pk-keymap");
  const keys = new Set(island ? JSON.parse(island.textContent) : []);
  // open overlays that own Esc (Quasar dialogs and menus, CodeMirror's completion list)
  const OVERLAYS = ".q-dialog, .q-menu, .cm-tooltip-autocomplete";

  const send = (key, down) => {
    if (typeof window.emitEvent === "function") window.emitEvent("pk_key", { key: key, down: down });
  };
  const keyName = (e) => (e.key === " " ? " " : String(e.key || "").toLowerCase());
  const typing = (t) =>
    !!t && (t.isContentEditable || ["INPUT", "TEXTAREA", "SELECT"].includes(t.tagName));
  const adjusting = (t) => !!t && typeof t.getAttribute === "function" && t.getAttribute("role") === "slider";
  const overlayOpen = () => document.querySelector(OVERLAYS) !== null;

  window.addEventListener("keydown", (e) => {
    const k = keyName(e);
    const focus = document.activeElement;
    if (k === "escape") {
      if (overlayOpen()) return; // Esc closes the dialog or menu (Quasar / CodeMirror do it)
      e.preventDefault();
      e.stopPropagation();
      if (!e.repeat) send("escape", true);
      return;
    }
    if (e.ctrlKey || e.metaKey || e.altKey) return;
    if (k === " ") {
      if (typing(focus)) return; // a space in a text field
      e.preventDefault(); // no button, toggle or tab sees this Space
      e.stopPropagation();
      if (!e.repeat) send(" ", true);
      return;
    }
    if (typing(focus) || adjusting(focus) || !keys.has(k)) return;
    e.preventDefault();
    if (e.repeat) return;
    send(k, true);
  }, true);

  window.addEventListener("keyup", (e) => {
    const k = keyName(e);
    if (k === " ") {
      if (!typing(document.activeElement)) {
        e.preventDefault(); // a native button would "click" on Space's keyup
        e.stopPropagation();
      }
      return;
    }
    if (k !== "escape" && keys.has(k)) send(k, false);
  }, true);

  window.addEventListener("blur", () => send("blur", false));

  // a held jog button may be greyed out under the pointer (limit reached): a disabled button
  // sends no pointerup, so any pointer release on the page also ends a held jog
  const release = () => send("release", false);
  document.addEventListener("pointerup", release, true);
  document.addEventListener("pointercancel", release, true);

  // after a pointer press a button or slider gives the keyboard focus back to the page, so
  // the keyboard shortcuts (arrows, letters) act on the robot, not on that control
  document.addEventListener("pointerup", (e) => {
    const control = e.target instanceof Element ? e.target.closest("button, .q-btn, [role=slider], .q-tab") : null;
    if (control === null) return;
    setTimeout(() => {
      const focus = document.activeElement;
      if (focus instanceof HTMLElement && !typing(focus) && (control.contains(focus) || focus === control)) focus.blur();
    }, 0);
  }, true);

  // names that Quasar's and CodeMirror's own elements lack (they are created and re-created
  // by the page: the editor each time the Program tab opens)
  const nameUnnamed = () => {
    const editor = document.querySelector("[data-testid=editor] .cm-content:not([aria-label])");
    if (editor) editor.setAttribute("aria-label", "RBTscript program");
    const bar = document.querySelector(".q-loading-bar:not([aria-label])");
    if (bar) bar.setAttribute("aria-label", "loading");
  };
  let naming = false;
  new MutationObserver(() => {
    if (naming) return;
    naming = true;
    requestAnimationFrame(() => { naming = false; nameUnnamed(); });
  }).observe(document.body, { childList: true, subtree: true });
  nameUnnamed();

  // the commander's own server gone (process exited, network down): NiceGUI only shows a
  // small toast and the page keeps showing the last state.  Say it loudly, mark the link and
  // state chips, and grey every control until the socket is back (the page reloads then).
  let serverLost = false;
  const showServerLost = (lost) => {
    if (lost === serverLost) return;
    serverLost = lost;
    document.body.classList.toggle("pk-server-lost", lost);
    let banner = document.getElementById("pk-server-banner");
    if (lost && banner === null) {
      banner = document.createElement("div");
      banner.id = "pk-server-banner";
      banner.setAttribute("role", "alert");
      banner.setAttribute("data-testid", "server-banner");
      banner.textContent = "DISCONNECTED: the commander's server is not answering. Nothing on this page is live " +
        "and the controls do nothing until it is back (restart `parolkit gui`; this page reconnects by itself).";
      document.body.appendChild(banner);
    }
    if (banner !== null) banner.hidden = !lost;
    for (const id of ["link-chip", "state-chip"]) {
      const chip = document.querySelector(`[data-testid=${id}] .q-chip__content`);
      if (chip === null) continue;
      if (lost) {
        chip.dataset.pkText = chip.textContent;
        chip.textContent = id === "link-chip" ? "DISCONNECTED" : "UNKNOWN";
      } else if (chip.dataset.pkText !== undefined) {
        chip.textContent = chip.dataset.pkText;
      }
    }
  };
  setInterval(() => {
    const sock = window.socket;
    if (sock && window.did_handshake) showServerLost(!sock.connected);
  }, 250);

  // the live charts: the server pushes only the new samples ([t, q1..q6, v1..v6], t in s of
  // the server's clock); the page keeps the last `windowS` seconds and redraws both charts
  const live = { rows: [] };
  window.pkLive = (posId, speedId, rows, windowS) => {
    live.rows.push(...rows);
    const tEnd = live.rows[live.rows.length - 1][0];
    let cut = 0;
    while (cut < live.rows.length && live.rows[cut][0] < tEnd - windowS) cut++;
    if (cut) live.rows.splice(0, cut);
    for (const [id, offset] of [[posId, 1], [speedId, 7]]) {
      const el = typeof getElement === "function" ? getElement(id) : null;
      if (!el || !el.chart) continue;
      const series = [];
      for (let j = 0; j < 6; j++) {
        series.push({ data: live.rows.map((r) => [Math.round((r[0] - tEnd) * 100) / 100, r[offset + j]]) });
      }
      el.chart.setOption({ series: series });
    }
  };

  // a long press on a jog button must not open the context menu (touch screens)
  document.addEventListener("contextmenu", (e) => {
    if (e.target instanceof Element && e.target.closest(".pk-jog .q-btn")) e.preventDefault();
  }, true);
})();
