// The commander's keyboard and pointer rules (parolkit.gui).  Served from the package as
// /parolkit-static/commander.js; the key list comes from the page's #pk-keymap data island
// (parolkit.gui.jog.KEYMAP).  Every key goes to the server as the NiceGUI event "pk_key".
//
//  * Esc is E-STOP whatever has the focus (the editor too), except while a dialog or a menu
//    is open: then Esc only closes it.  A press on the E-STOP button latches it at once,
//    whatever is open (the event "pk_estop").
//  * Space is STOP whatever has the focus.  Only while nothing moves does Space in a text
//    field (an input, the editor) type a space: "something moves" (the robot moving or
//    homing, a command queued, a program starting, running or paused, a held jog) is the
//    server's data-moving attribute on .pk-motion, read at each keydown.  A Space typed that
//    way still goes to the server (typed: true), which sends STOP if something moves by then
//    (it may have started just before the key; the attribute follows every 0.1 s).  The page
//    takes Space before any button sees it, so a focused button is never "pressed again".
//  * Jog keys are ignored while typing (inputs, the editor) or adjusting a slider.
//  * A held jog ends on any pointer release or cancel anywhere on the page and when the
//    window loses focus.
//  * The 3D view draws 30 frames/s while something in it changes and 2 once nothing has for a
//    second (parolkit.gui.components.view3d: the server sets the scene's fps).  What the page
//    changes itself is drawn at once: the camera turned or zoomed (drag, wheel, touch), the
//    window resized; and pkSceneDraw(id) draws a change the server has just sent.  The
//    collision world's translucent meshes write no depth (what is inside a zone shows).
(() => {
  "use strict";
  const island = document.getElementById("pk-keymap");
  const keys = new Set(island ? JSON.parse(island.textContent) : []);
  // open overlays that own Esc (Quasar dialogs and menus, CodeMirror's completion list)
  const OVERLAYS = ".q-dialog, .q-menu, .cm-tooltip-autocomplete";

  const send = (key, down, typed = false) => {
    if (typeof window.emitEvent === "function") window.emitEvent("pk_key", { key: key, down: down, typed: typed });
  };
  const keyName = (e) => (e.key === " " ? " " : String(e.key || "").toLowerCase());
  const typing = (t) =>
    !!t && (t.isContentEditable || ["INPUT", "TEXTAREA", "SELECT"].includes(t.tagName));
  // a slider being adjusted with the keyboard: Quasar puts the focus on the slider's track,
  // inside the element with role=slider (the arrows adjust it and must not jog as well)
  const adjusting = (t) => t instanceof Element && t.closest("[role=slider]") !== null;
  const overlayOpen = () => document.querySelector(OVERLAYS) !== null;
  // the server's word on "something moves" (parolkit.gui.app: Commander.moving)
  const moving = () => {
    const el = document.querySelector(".pk-motion");
    return el !== null && el.getAttribute("data-moving") === "1";
  };

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
      if (typing(focus) && !moving()) { // a space in a text field; STOP if the server sees motion
        if (!e.repeat) send(" ", true, true);
        return;
      }
      e.preventDefault(); // no button, toggle, tab or text field sees this Space
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

  // E-STOP acts on the press, whatever pointer (mouse, pen, finger) and whatever is open: the
  // button is drawn above every overlay (commander.css, .pk-estop-layer), and the press is
  // taken here, before anything else sees it: an open menu takes a touch outside it for
  // closing itself and cancels that tap's click.  A click without a pointer (Enter on the
  // focused button, assistive technology) latches it too.
  const ESTOP = "[data-testid=btn-estop]";
  const onEstop = (e) => e.target instanceof Element && e.target.closest(ESTOP) !== null;
  const estop = () => {
    if (typeof window.emitEvent === "function") window.emitEvent("pk_estop", {});
  };
  window.addEventListener("pointerdown", (e) => { if (onEstop(e)) estop(); }, true);
  window.addEventListener("click", (e) => { if (onEstop(e) && e.detail === 0) estop(); }, true);

  // a jog button in continuous mode: the page times the press (parolkit.gui.components.jog_panel).
  // Held for the panel's data-tap-ms it jogs ("hold") until released; released sooner, by the
  // input's own times (the events' timeStamp), it is a tap ("tap": one step), also when a busy
  // page ran the hold timer before it saw the release (the server then stops that jog and steps
  // from where the press began).  The server moves nothing before one of the two.
  const JOG_BUTTON = ".pk-jog .q-btn[data-testid^=jog-]";
  let jogPress = null; // {id, el, held, t0, tapMs, timer}
  const jogEvent = (action, id) => {
    if (typeof window.emitEvent === "function") window.emitEvent("pk_jog", { action: action, id: id });
  };
  const endJogPress = () => {
    if (jogPress !== null) clearTimeout(jogPress.timer);
    jogPress = null;
  };
  window.addEventListener("pointerdown", (e) => {
    const b = e.target instanceof Element ? e.target.closest(JOG_BUTTON) : null;
    if (b === null || e.button !== 0 || b.disabled || b.classList.contains("disabled")) return;
    endJogPress();
    const panel = b.closest(".pk-jog");
    const given = Number(panel === null ? NaN : panel.dataset.tapMs);
    const tapMs = Number.isFinite(given) ? given : 250;
    const press = { id: b.dataset.testid, el: b, held: false, t0: e.timeStamp, tapMs: tapMs, timer: 0 };
    press.timer = setTimeout(() => {
      if (jogPress !== press) return;
      press.held = true;
      jogEvent("hold", press.id);
    }, tapMs);
    jogPress = press;
  }, true);
  // the pointer left the button before the press was judged: neither a tap nor a hold
  document.addEventListener("pointerleave", (e) => {
    if (jogPress !== null && e.target === jogPress.el) endJogPress();
  }, true);
  window.addEventListener("blur", endJogPress);

  // a held jog button may be greyed out under the pointer (limit reached): a disabled button
  // sends no pointerup, so any pointer release on the page also ends a held jog.  A jog
  // button's press released within its tap time is a tap: said first, then the release
  const release = (e) => {
    const press = jogPress;
    endJogPress();
    if (press !== null && e.type === "pointerup" && press.el.contains(e.target) &&
        e.timeStamp - press.t0 < press.tapMs) {
      jogEvent("tap", press.id);
    }
    send("release", false);
  };
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
    guardEditor();
    const bar = document.querySelector(".q-loading-bar:not([aria-label])");
    if (bar) bar.setAttribute("aria-label", "loading");
  };
  let naming = false;
  new MutationObserver(() => {
    guardEditor(); // at once: the editor's text is followed from its first keystroke
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

  // ---- the editor and the one program document (parolkit.gui.program_doc, editor_sync.py):
  // every tab edits the same program and nothing typed in any of them is lost.  The editor's
  // own changes (typing, paste, completion, Record point, undo) are kept as pending CodeMirror
  // change sets on `base` (the server's text as this page last had it) and pushed with the
  // revision of that text; the server applies them only while that is still its revision.
  // Otherwise the page first receives the updates it lacked (other tabs', the server's), moves
  // its pending changes over them (ChangeSet.map: the server's order first) and pushes them
  // again.  Others' updates are applied to the editor moved over the pending changes, so the
  // cursor and what is being typed stay where they are.  The editor takes typing from the
  // start: the text the server sends first ("hello", or again after missed messages) is
  // merged like an update (the difference from `base`).  NiceGUI's copy of the editor's value
  // (sent with every update of the element) never sets the text: it lags behind.
  const docSync = { CM: null, view: null, remote: null, base: null, revision: null, pending: [],
    pushing: false, waiters: [], refused: 0, merged: 0 };
  import("nicegui-codemirror").then((CM) => { docSync.CM = CM; guardEditor(); });
  const sendDoc = (msg) => {
    if (typeof window.emitEvent === "function") window.emitEvent("pk_doc", msg);
  };
  // a change set on the wire: the length of the text it applies to and its [from, to, insert]
  const wire = (changes) => {
    const c = [];
    changes.iterChanges((fromA, toA, _fromB, _toB, inserted) => c.push([fromA, toA, inserted.toString()]));
    return { n: changes.length, c: c };
  };
  const unwire = (w) => docSync.CM.ChangeSet.of(w.c.map(([from, to, insert]) => ({ from, to, insert })), w.n);
  // the change from text `a` to text `b`: the one range that differs
  const difference = (a, b) => {
    let start = 0;
    while (start < a.length && start < b.length && a[start] === b[start]) start++;
    let end = 0;
    while (end < a.length - start && end < b.length - start && a[a.length - 1 - end] === b[b.length - 1 - end]) end++;
    return docSync.CM.ChangeSet.of({ from: start, to: a.length - end, insert: b.slice(start, b.length - end) }, a.length);
  };
  const settle = () => {
    const d = docSync;
    if (d.revision === null || d.pushing || d.pending.length) return;
    for (const resolve of d.waiters.splice(0)) resolve(true);
  };
  const push = () => {
    const d = docSync;
    if (d.pushing || d.revision === null || !d.pending.length) { settle(); return; }
    d.pushing = true;
    sendDoc({ op: "push", base: d.revision, changes: d.pending.map(wire) });
  };
  const showChanges = (changes) => {
    const d = docSync;
    if (changes.empty) return;
    d.view.dispatch({ changes: changes, annotations: [d.remote.of(true), d.CM.Transaction.addToHistory.of(false)] });
  };
  // others' changes (composed, made on `base`) moved over ours and shown
  const applyRemote = (changes) => {
    const d = docSync;
    if (changes.empty) return;
    if (d.pending.length) d.merged++;
    d.base = changes.apply(d.base);
    let c = changes;
    d.pending = d.pending.map((mine) => {
      const moved = mine.map(c); // theirs came first on the server
      c = c.map(mine, true);
      return moved;
    });
    showChanges(c);
  };
  const receiveDoc = (msg) => {
    const d = docSync;
    if (msg.reset !== undefined) {
      if (msg.refused) { // the server refused our changes (malformed, too long): its text stands
        console.error(`program editor: the server refused ${d.pending.length} change(s): ${msg.refused}`);
        d.pending = [];
        showChanges(difference(d.view.state.doc.toString(), msg.reset));
        d.base = d.view.state.doc;
      } else {
        applyRemote(difference(d.base.toString(), msg.reset));
      }
      d.revision = msg.revision;
      d.pushing = false;
      push();
      return;
    }
    if (d.revision === null) return; // the whole text is on its way
    if (msg.from > d.revision) { // messages missed (a reconnect): ask again from ours
      if (msg.ack !== undefined) d.pushing = false; // (a push at an old revision is only refused)
      sendDoc({ op: "since", revision: d.revision });
      return;
    }
    let theirs = null;
    for (const [mine, w] of msg.updates.slice(d.revision - msg.from)) {
      if (mine) { // our oldest pending change, applied
        if (theirs !== null) { applyRemote(theirs); theirs = null; }
        if (!d.pending.length) throw new Error("the server confirmed a change this page does not have");
        d.base = d.pending.shift().apply(d.base);
      } else {
        const c = unwire(w);
        theirs = theirs === null ? c : theirs.compose(c);
      }
      d.revision++;
    }
    if (theirs !== null) applyRemote(theirs);
    if (msg.ack !== undefined) d.pushing = false;
    if (msg.ack === false) d.refused++;
    push();
  };
  window.pkDoc = {
    receive(msg) {
      const d = docSync;
      if (d.view === null) return;
      try {
        receiveDoc(msg);
        // the editor is the server's text with this page's pending changes, nothing else
        if (!d.pending.reduce((text, mine) => mine.apply(text), d.base).eq(d.view.state.doc)) {
          throw new Error("the editor's text is not the server's with this page's changes");
        }
      } catch (err) { // out of step: the server's text again (what was typed here merged into it)
        console.error("program editor out of step with the server, asking for its text again:", err);
        d.pending = [difference(d.base.toString(), d.view.state.doc.toString())].filter((c) => !c.empty);
        d.revision = null;
        d.pushing = false;
        sendDoc({ op: "hello" });
      }
    },
    // resolves once every change typed here has reached the server (Check, Run and Save wait)
    flush() {
      if (docSync.view === null) return Promise.resolve(true); // no editor: nothing typed here
      return new Promise((resolve) => { docSync.waiters.push(resolve); settle(); });
    },
    // for tests and the curious: where this page's editor stands, how many of its pushes the
    // server refused (others' came first) and how often others' changes were merged into its own
    state() {
      const d = docSync;
      return { revision: d.revision, pending: d.pending.length, pushing: d.pushing, refused: d.refused,
        merged: d.merged };
    },
  };
  // from the moment the editor is on the page (a mutation observer's callback runs before any
  // key can reach it): every change of its text is either ours (pending) or the server's
  const attachDoc = (view) => {
    const d = docSync;
    const CM = d.CM;
    view.pkDoc = true;
    Object.assign(d, { view: view, base: view.state.doc, revision: null, pending: [], pushing: false });
    d.remote = d.remote || CM.Annotation.define();
    view.dispatch({ effects: CM.StateEffect.appendConfig.of(CM.EditorView.updateListener.of((u) => {
      for (const tr of u.transactions) {
        if (tr.docChanged && !tr.annotation(d.remote)) d.pending.push(tr.changes);
      }
      if (d.pending.length) push();
    })) });
    sendDoc({ op: "hello" });
  };
  function guardEditor() {
    const host = document.querySelector("[data-testid=editor]");
    if (!host || typeof getElement !== "function") return;
    const comp = getElement(host.id.replace(/^c/, ""));
    if (!comp || typeof comp.setEditorValue !== "function") return;
    if (!comp.pkGuarded) {
      comp.setEditorValue = function () {}; // the text comes from the document alone (above)
      comp.pkGuarded = true;
    }
    if (comp.editor && !comp.editor.pkDoc && docSync.CM !== null) attachDoc(comp.editor);
  }

  // ---- completion in the program editor: the commands of RBTscript's table with valid
  // arguments (never a placeholder left as an error) at the start of a line, keyword arguments and words inside a call (items from
  // the #pk-completions data island, parolkit.gui.completion).  Up/Down choose, Enter or Tab
  // insert, Esc closes the list (it is an overlay: Esc is not E-STOP then).
  const compIsland = document.getElementById("pk-completions");
  const COMPLETIONS = compIsland ? JSON.parse(compIsland.textContent) : [];
  let popup = null;
  // the editor's text and cursor where Esc closed the list: a suggestion still pending for
  // that same state (a keyup or an animation frame late on a loaded machine) must not open
  // it again; any edit or cursor move ends it
  let dismissed = null;
  let pendingSuggest = 0;
  const editorView = () => {
    const host = document.querySelector("[data-testid=editor]");
    if (!host || typeof getElement !== "function") return null;
    const comp = getElement(host.id.replace(/^c/, ""));
    return comp && comp.editor ? comp.editor : null;
  };
  // the text the editor shows (Check and Run use it: the server's copy may lag behind)
  window.pkEditorText = () => {
    const view = editorView();
    return view === null ? null : view.state.doc.toString();
  };
  const closePopup = () => {
    if (popup !== null) popup.el.remove();
    popup = null;
  };
  // a move to a target is inserted with the robot's current joints or TCP pose (the Program
  // tab's live values, data-joints / data-pose), as the Insert menu does; the item's own
  // insert (the standby pose) when the page has none
  const itemText = (item) => {
    if (!item.live || !item.pattern) return item.insert;
    const el = document.querySelector("[data-testid=pk-live-values]");
    const values = el === null ? null : el.getAttribute(`data-${item.live}`);
    return values ? item.pattern.replace(`{${item.live}}`, values) : item.insert;
  };
  const acceptItem = (i) => {
    const p = popup;
    const item = p.items[i];
    const text = itemText(item);
    p.view.dispatch({
      changes: { from: p.from, to: p.to, insert: text },
      selection: { anchor: p.from + text.length },
    });
    closePopup();
    p.view.focus();
  };
  const renderPopup = () => {
    popup.el.replaceChildren(...popup.items.map((item, i) => {
      const row = document.createElement("div");
      row.className = "pk-completion" + (i === popup.index ? " selected" : "");
      row.setAttribute("role", "option");
      row.setAttribute("aria-selected", String(i === popup.index));
      row.setAttribute("data-testid", "completion");
      const label = document.createElement("span");
      label.className = "pk-completion-label";
      label.textContent = item.label;
      row.appendChild(label);
      const detail = document.createElement("span");
      detail.className = "pk-completion-detail";
      detail.textContent = item.detail;
      row.appendChild(detail);
      row.addEventListener("mousedown", (e) => { e.preventDefault(); acceptItem(i); });
      return row;
    }));
  };
  const suggest = () => {
    const view = editorView();
    if (view === null || !view.hasFocus) { closePopup(); return; }
    const sel = view.state.selection.main;
    if (!sel.empty) { closePopup(); return; }
    if (dismissed !== null) {
      if (dismissed.head === sel.head && dismissed.text === view.state.doc.toString()) { closePopup(); return; }
      dismissed = null;
    }
    const line = view.state.doc.lineAt(sel.head);
    const before = line.text.slice(0, sel.head - line.from);
    const m = /[A-Za-z_]\w*$/.exec(before);
    const head = m ? before.slice(0, before.length - m[0].length) : "";
    const inCall = head.includes("(") && !head.includes(")");
    if (m === null || (!inCall && head.trim() !== "") || /[#]|\/\//.test(head)) { closePopup(); return; }
    const word = m[0].toLowerCase();
    const items = COMPLETIONS.filter((c) => c.call === !inCall && c.label.toLowerCase().startsWith(word) &&
      c.insert !== m[0]);
    if (!items.length) { closePopup(); return; }
    const pos = view.coordsAtPos(sel.head);
    if (pos === null) { closePopup(); return; }
    if (popup === null) {
      const el = document.createElement("div");
      el.className = "pk-completions cm-tooltip-autocomplete"; // an overlay: Esc closes it (above)
      el.setAttribute("role", "listbox");
      el.setAttribute("aria-label", "completions");
      el.setAttribute("data-testid", "completions");
      document.body.appendChild(el);
      popup = { el: el };
    }
    Object.assign(popup, { items: items, index: 0, from: sel.head - m[0].length, to: sel.head, view: view });
    popup.el.setAttribute("data-word", m[0]); // the word it completes (tests wait for the newest list)
    popup.el.style.left = `${Math.round(pos.left)}px`;
    popup.el.style.top = `${Math.round(pos.bottom + 2)}px`;
    renderPopup();
  };
  window.addEventListener("keydown", (e) => {
    if (popup === null) return;
    if (e.key === "ArrowDown" || e.key === "ArrowUp") {
      const n = popup.items.length;
      popup.index = (popup.index + (e.key === "ArrowDown" ? 1 : n - 1)) % n;
      renderPopup();
    } else if (e.key === "Enter" || e.key === "Tab") {
      acceptItem(popup.index);
    } else if (e.key === "Escape") {
      cancelAnimationFrame(pendingSuggest);
      dismissed = { text: popup.view.state.doc.toString(), head: popup.view.state.selection.main.head };
      closePopup();
    } else {
      return;
    }
    e.preventDefault();
    e.stopPropagation();
  }, true);
  document.addEventListener("keyup", (e) => {
    if (["ArrowDown", "ArrowUp", "Enter", "Tab", "Escape", "Shift", "Control", "Alt", "Meta"].includes(e.key)) return;
    if (e.target instanceof Element && e.target.closest("[data-testid=editor]")) {
      cancelAnimationFrame(pendingSuggest);
      pendingSuggest = requestAnimationFrame(suggest);
    }
  }, true);
  document.addEventListener("focusout", (e) => {
    if (e.target instanceof Element && e.target.closest("[data-testid=editor]")) setTimeout(() => {
      const view = editorView();
      if (view === null || !view.hasFocus) closePopup();
    }, 150);
  }, true);

  // "Record point": the server sends the line; it goes in after the cursor's line (the end
  // of the program if the editor never had the cursor), and the cursor moves to its end (not
  // before the editor has the program's text: it would be replaced)
  window.pkInsertLine = (text) => {
    const view = editorView();
    if (view === null || docSync.revision === null) return false;
    const doc = view.state.doc;
    const line = doc.lineAt(view.state.selection.main.head);
    const atEnd = line.number === doc.lines;
    const insert = line.text.trim() === "" ? text : (atEnd ? "\n" : "") + text + (atEnd ? "" : "\n");
    const from = line.text.trim() === "" ? line.from : (atEnd ? line.to : line.to + 1);
    view.dispatch({ changes: { from: from, to: line.text.trim() === "" ? line.to : from, insert: insert },
      selection: { anchor: from + insert.length - (atEnd || line.text.trim() === "" ? 0 : 1) } });
    view.focus();
    return true;
  };

  // ---- the 3D view: a draw at the next animation frame, one per frame whatever asks ----
  const drawPending = new Set();
  const draw = (id) => {
    if (drawPending.has(id)) return;
    drawPending.add(id);
    requestAnimationFrame(() => {
      drawPending.delete(id);
      const s = typeof window.getElement === "function" ? window.getElement(id) : null;
      if (!s || !s.renderer || !s.scene || !s.camera) return;
      s.renderer.render(s.scene, s.camera);
      if (s.text_renderer) s.text_renderer.render(s.scene, s.camera);
      if (s.text3d_renderer) s.text3d_renderer.render(s.scene, s.camera);
    });
  };
  window.pkSceneDraw = draw;

  // The zones, the tool's shape and the held objects are see-through: their translucent
  // meshes write no depth, so what is inside or behind them (the path preview's points, red
  // where they pass through a zone) is drawn whatever order three.js sorts them in.  The
  // scene element names them (data-world-ids); checked before each draw, done once per world.
  const seeThrough = (host, s) => {
    const ids = host.dataset.worldIds || "{}";
    if (s.pkWorldIds === ids) return;
    let done = true;
    const walk = (v) => {
      if (Array.isArray(v)) {
        for (const id of v) {
          const o = s.objects.get(id);
          if (!o || !o.mesh) { done = false; continue; } // still being created: next draw
          const m = o.mesh.material;
          if (m && m.transparent) m.depthWrite = false;
        }
      } else if (v && typeof v === "object") Object.values(v).forEach(walk);
    };
    try { walk(JSON.parse(ids)); } catch { return; }
    if (done) s.pkWorldIds = ids;
  };
  setInterval(() => {
    if (typeof window.getElement !== "function") return;
    document.querySelectorAll("[data-testid=scene]").forEach((host) => {
      const s = window.getElement(host.id.slice(1));
      if (!s || !s.scene || s.scene.pkSeeThrough) return;
      s.scene.pkSeeThrough = true; // (a scene made anew, after a lost WebGL context, is hooked again)
      s.scene.onBeforeRender = () => seeThrough(host, s);
    });
  }, 500);
  const sceneOf = (t) => (t instanceof Element ? t.closest("[data-testid=scene]") : null);
  const drawScene = (el) => { if (el && el.id) draw(Number(el.id.slice(1))); };
  // the orbit controls move the camera in their own pointer and wheel handlers
  for (const type of ["pointerdown", "pointerup", "wheel"]) {
    document.addEventListener(type, (e) => drawScene(sceneOf(e.target)), { capture: true, passive: true });
  }
  document.addEventListener("pointermove", (e) => {
    if (e.buttons !== 0) drawScene(sceneOf(e.target));
  }, { capture: true, passive: true });
  window.addEventListener("resize", () => {
    // after the scene's own resize handler has sized its renderer (which clears the canvas)
    setTimeout(() => document.querySelectorAll("[data-testid=scene]").forEach(drawScene), 0);
  });

  // a tap must not leave a tooltip open.  A browser that reports no touch platform (a desktop
  // browser on a touch screen, a tablet asking for the desktop site) makes Quasar show tooltips
  // on mouseenter and hide them on mouseleave, and a tap sends the emulated mouseenter but no
  // mouseleave: the tooltip stuck until the next tap elsewhere.  The mouse events a touch
  // emulates do not reach the tooltips (a real mouse's still do; a phone's own long press
  // shows them as Quasar does on touch platforms)
  let touchedAt = -Infinity;
  window.addEventListener("pointerdown", (e) => { if (e.pointerType === "touch") touchedAt = e.timeStamp; }, true);
  window.addEventListener("pointerup", (e) => { if (e.pointerType === "touch") touchedAt = e.timeStamp; }, true);
  const fromTouch = (e) => {
    const caps = e.sourceCapabilities;
    if (caps && typeof caps.firesTouchEvents === "boolean") return caps.firesTouchEvents;
    return e.timeStamp - touchedAt < 1000;
  };
  window.addEventListener("mouseenter", (e) => { if (fromTouch(e)) e.stopPropagation(); }, true);

  // a long press on a jog button must not open the context menu (touch screens)
  document.addEventListener("contextmenu", (e) => {
    if (e.target instanceof Element && e.target.closest(".pk-jog .q-btn")) e.preventDefault();
  }, true);
})();
