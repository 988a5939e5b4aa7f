// The commander's keyboard rules (parolkit.gui).  Served from the package as
// /parolkit-static/commander.js; the key list comes from the page's #pk-keymap data island
// (parolkit.gui.jog.KEYMAP).  Every key goes to the server as the NiceGUI event "pk_key".
(() => {
  "use strict";
  const island = document.getElementById("pk-keymap");
  const keys = new Set(island ? JSON.parse(island.textContent) : []);
  const send = (key, down) => {
    if (typeof window.emitEvent === "function") window.emitEvent("pk_key", { key: key, down: down });
  };
  const editing = () => {
    const t = document.activeElement;
    return t && (t.isContentEditable || ["INPUT", "TEXTAREA", "SELECT"].includes(t.tagName));
  };
  document.addEventListener("keydown", (e) => {
    const k = e.key === " " ? " " : e.key.toLowerCase();
    if (k === "escape") { e.preventDefault(); send(k, true); return; }
    if (editing() || e.ctrlKey || e.metaKey || e.altKey || !keys.has(k)) return;
    e.preventDefault();
    if (e.repeat) return;
    send(k, true);
  });
  document.addEventListener("keyup", (e) => {
    const k = e.key === " " ? " " : e.key.toLowerCase();
    if (keys.has(k) && k !== "escape") send(k, false);
  });
  window.addEventListener("blur", () => send("blur", false));
  // a held jog button may be greyed out under the pointer (limit reached): a disabled button
  // emits no mouseup, so any mouseup / touchend on the page also ends a held jog
  document.addEventListener("mouseup", () => send("release", false), true);
  document.addEventListener("touchend", () => send("release", false), true);
})();
