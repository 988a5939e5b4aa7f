// The commander's gamepad, the page's end (parolkit.gui.gamepad is the server's).  Served from
// the package as /parolkit-static/gamepad.js; its settings come from the page's #pk-gamepad
// data island (parolkit.gui.gamepad.page_settings: one source of truth).
//
// The Gamepad API is polled every poll_ms (navigator.getGamepads()); each new state of the
// pad goes to the server as the NiceGUI event "pk_gamepad", at once, and the state again every
// heartbeat_ms while a pad is connected (the server stops the arm when the driving page falls
// silent).  The server maps sticks and buttons to speeds and holds the deadman's rules; the
// page says only what the pad is:
//  * connected: a pad is in the browser's list (gone from it, or a gamepaddisconnected event:
//    false at once);
//  * live: false while the deadman is held and the pad's timestamp has not changed for
//    stale_ms (its data froze: a radio dropout before the browser notices);
//  * visible: false once the page is hidden (another tab, minimised): sent at once;
//  * standard: the pad uses the standard button layout (the server's indices mean that);
//  * axes (-1..1) and buttons (values 0..1), rounded to 0.01.
// Closing the page closes its socket, which the server takes as the pad gone.
(() => {
  "use strict";
  let cfg = null;
  const settings = () => {
    if (cfg === null) {
      const island = document.getElementById("pk-gamepad");
      if (island === null) return null;
      cfg = JSON.parse(island.textContent);
    }
    return cfg;
  };
  const round = (v) => Math.round(Number(v) * 100) / 100;
  let index = null; // the pad followed (the first connected one)
  const gone = new Set(); // indices a gamepaddisconnected event named (until it connects again)
  let lastStamp = null;
  let stampAt = 0;
  let lastText = "";
  let lastSentAt = -Infinity;

  const pick = () => {
    const list = typeof navigator.getGamepads === "function" ? Array.from(navigator.getGamepads() || []) : [];
    const usable = (p) => !!p && p.connected && !gone.has(p.index);
    let pad = index !== null ? list[index] : null;
    if (!usable(pad)) {
      pad = list.find(usable) || null;
      index = pad ? pad.index : null;
      lastStamp = null;
    }
    return pad;
  };

  const state = (c) => {
    const visible = document.visibilityState !== "hidden";
    const pad = pick();
    if (pad === null) return { connected: false, visible: visible };
    const now = performance.now();
    if (pad.timestamp !== lastStamp) {
      lastStamp = pad.timestamp;
      stampAt = now;
    }
    const buttons = Array.from(pad.buttons || [], (b) => round(typeof b === "object" ? b.value : b));
    const held = (buttons[c.deadman] || 0) >= c.press;
    return {
      connected: true,
      live: !(held && now - stampAt > c.stale_ms),
      visible: visible,
      standard: pad.mapping === "standard",
      name: String(pad.id || "").slice(0, 200),
      axes: Array.from(pad.axes || [], round),
      buttons: buttons,
    };
  };

  const poll = () => {
    const c = settings();
    if (c === null || typeof window.emitEvent !== "function") return;
    const s = state(c);
    const text = JSON.stringify(s);
    const now = performance.now();
    if (text === lastText && !(s.connected && now - lastSentAt >= c.heartbeat_ms)) return;
    window.emitEvent("pk_gamepad", s);
    lastText = text;
    lastSentAt = now;
  };

  const start = () => {
    const c = settings();
    setInterval(poll, c === null ? 10 : c.poll_ms);
  };
  const padIndex = (e) => (e.gamepad && Number.isInteger(e.gamepad.index) ? e.gamepad.index : index);
  window.addEventListener("gamepadconnected", (e) => {
    gone.delete(padIndex(e));
    poll();
  });
  window.addEventListener("gamepaddisconnected", (e) => {
    const i = padIndex(e);
    if (i !== null) gone.add(i); // the list may still show it for a moment
    index = null;
    poll();
  });
  document.addEventListener("visibilitychange", poll);
  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", start);
  else start();
})();
