// Shared by the touch HMI and the phone page: the WebSocket to the host
// daemon (docs/rehand6600-remote.md), press-and-hold buttons, and the small
// helpers both pages format values with.
//
// The dead-man rule lives here: a hold-type command is a *press* that is alive
// only while a finger is down, the page is visible and focused, and the socket
// is open. Every pointer-down starts a new press with a new id; the page
// renews it every 100 ms (the daemon's lease is 300 ms) and releases it the
// moment any of those conditions goes away. A press the daemon ended is never
// restarted by the page: the user lifts the finger and presses again.
'use strict';

export const RENEW_MS = 100;
// A press or renewal unanswered this long means the link is not carrying our
// renewals (the daemon answers each one at once): the daemon's 300-ms lease has
// ended the press anyway, so the page ends it too instead of pretending.
export const PRESS_ANSWER_TIMEOUT_MS = 1500;
const RECONNECT_MS = 1000;
// The daemon sends the state at least once a second (a heartbeat when
// nothing changes): a socket silent for this long is taken for dead, as if it
// had closed (a frozen daemon keeps its sockets open, and its last state
// would look live forever).
export const SILENT_MS = 3000;

export function $(selector) { return document.querySelector(selector); }
export function $$(selector) { return [...document.querySelectorAll(selector)]; }

// hh:mm:ss of a Date, in the chair's local time, as the daemon's last_contact.
export function clockTime(date) {
  const two = (n) => String(n).padStart(2, '0');
  return `${two(date.getHours())}:${two(date.getMinutes())}:${two(date.getSeconds())}`;
}

// The speed register holds km/h; mph is a display choice only.
export function formatSpeed(kmh, mph) {
  if (typeof kmh !== 'number') return '--';
  return mph ? `${(kmh * 0.621371).toFixed(1)} mph` : `${kmh} km/h`;
}

// "forward-left (6)" -> "forward-left": the register's number is for engineers.
export function motionText(state) {
  const text = state && state.text && state.text.motion;
  return typeof text === 'string' ? text.replace(/ \(\d+\)$/, '') : '--';
}

// A tone that sounds until stopped: the horn while its button is held.
// start() and stop() may be called at any time, any number of times.
export function holdTone(frequency = 440) {
  let ctx = null;
  return {
    start() {
      if (ctx) return;
      try {
        ctx = new (window.AudioContext || window.webkitAudioContext)();
        const tone = ctx.createOscillator();
        tone.frequency.value = frequency;
        tone.connect(ctx.destination);
        tone.start();
      } catch { ctx = null; /* no audio device */ }
    },
    stop() {
      if (ctx) ctx.close();
      ctx = null;
    },
  };
}

// ---------------------------------------------------------------- WebSocket

// One WebSocket to `path` on this page's own host: wss when the page came over
// https (the phone listener is TLS only), ws on the display's loopback.
//   onMessage(message)       every JSON message (results included)
//   onOpen()                 the socket opened (the phone authenticates here)
//   onClose(event)           the socket closed: event.reason is the daemon's
//   shouldReconnect(event)   false keeps it closed (a replaced phone, a phone
//                            that has not paired yet); default: always retry
//   autoOpen                 false: no socket until reopen() (the phone page
//                            reads its key first); default true
// Returns { send, isOpen, reopen, close, lastMessageAt }.
export function connect({ path, onMessage, onOpen = () => {}, onClose = () => {}, shouldReconnect = () => true,
  autoOpen = true }) {
  let socket = null;
  let nextRequestId = 1;
  let reconnectTimer = null;
  const pending = new Map();  // request id -> { resolve, timer }

  const link = {
    lastMessageAt: null,  // Date of the last message: "no contact since" when the socket is down

    // Sends {op, id, ...fields}; resolves with the daemon's result, or with
    // {ok:false} when the socket is not open, closes before the answer, or
    // (with timeoutMs) the answer does not come in time.
    send(op, fields = {}, { timeoutMs = 0 } = {}) {
      if (!link.isOpen()) return Promise.resolve({ ok: false, error: 'no connection to the chair' });
      const id = nextRequestId++;
      socket.send(JSON.stringify({ op, id, ...fields }));
      return new Promise((resolve) => {
        const entry = { resolve, timer: null };
        if (timeoutMs > 0) {
          entry.timer = setTimeout(() => {
            pending.delete(id);
            resolve({ ok: false, error: 'no answer from the chair', unanswered: true });
          }, timeoutMs);
        }
        pending.set(id, entry);
      });
    },
    isOpen() { return socket !== null && socket.readyState === WebSocket.OPEN; },
    // Opens a new socket now unless one is open or opening (the phone's "Pair"
    // and "Use this page again" buttons).
    reopen() {
      if (socket && (socket.readyState === WebSocket.OPEN || socket.readyState === WebSocket.CONNECTING)) return;
      clearTimeout(reconnectTimer);
      open();
    },
    close() { if (socket) socket.close(); },
  };

  function settleAll(result) {
    for (const [, entry] of pending) { clearTimeout(entry.timer); entry.resolve(result); }
    pending.clear();
  }

  // What a closed socket means, once per socket: its requests and presses
  // end, the page hears why, and a new socket follows (unless told not to).
  function lost(ws, event) {
    if (socket !== ws) return;
    socket = null;
    settleAll({ ok: false, error: 'connection to the chair lost' });
    // Before anything else: every press of this page ends with its socket
    // (the daemon drops them too; the page must not show them as held).
    endAllPresses('connection to the chair lost');
    onClose(event);
    if (shouldReconnect(event)) reconnectTimer = setTimeout(open, RECONNECT_MS);
  }

  // A socket open but silent past SILENT_MS: lost now, without waiting for a
  // closing handshake a frozen daemon would never answer.
  setInterval(() => {
    const ws = socket;
    if (!ws || ws.readyState !== WebSocket.OPEN) return;
    if (Date.now() - heardAt <= SILENT_MS) return;
    lost(ws, { code: 4000, reason: 'no message from the chair for 3 s' });
    ws.close();
  }, 500);
  let heardAt = 0;  // when the open socket last opened or brought a message

  function open() {
    const scheme = location.protocol === 'https:' ? 'wss:' : 'ws:';
    const ws = new WebSocket(`${scheme}//${location.host}${path}`);
    socket = ws;
    ws.onopen = () => {
      if (socket !== ws) return;
      heardAt = Date.now();
      onOpen();
    };
    ws.onmessage = (event) => {
      if (socket !== ws) return;
      let message;
      try { message = JSON.parse(event.data); } catch { return; }
      link.lastMessageAt = new Date();
      heardAt = link.lastMessageAt.getTime();
      if (message.type === 'result' && pending.has(message.id)) {
        const entry = pending.get(message.id);
        pending.delete(message.id);
        clearTimeout(entry.timer);
        entry.resolve(message);
      }
      onMessage(message);
    };
    ws.onclose = (event) => lost(ws, event);
  }
  if (autoOpen) open();
  return link;
}

// ---------------------------------------------------------------- presses

// Press ids: one counter for the whole page that only grows, so a late answer
// or renewal can never be taken for a newer press (the daemon requires ids to
// grow on one connection).
let lastPressId = 0;
const holdButtons = new Set();

// A press-and-hold button for one command and value.
//   onEnded(reason)  the daemon refused or ended the press while the finger
//                    was down (or the socket closed): show the reason
// The button gets class "held" while its press is alive and "ended" while the
// finger is still down on a press that is over (lift and press again).
export function holdButton(el, link, { command, value, onEnded = () => {} }) {
  const button = {
    el, command, value,
    press: 0,            // the live press's id, 0 when none
    fingerDown: false,   // a pointer is down on the button (its press may have ended)
    pointerId: null,
    renewTimer: null,
    wantsDisabled: false,  // setControlEnabled(false) came while the finger was down

    start(event) {
      if (el.disabled || button.fingerDown) return;
      event.preventDefault();
      button.fingerDown = true;
      button.pointerId = event.pointerId;
      // Capture: the pointer-up reaches this button even when the finger
      // slides off it (pointerleave still fires and releases).
      try { el.setPointerCapture(event.pointerId); } catch { /* synthetic events */ }
      const press = ++lastPressId;
      button.press = press;
      el.classList.remove('ended');
      el.classList.add('held');
      const answered = (result) => { if (button.press === press && !result.ok) button.end(result.error || 'refused'); };
      link.send('press', { command, value, press }, { timeoutMs: PRESS_ANSWER_TIMEOUT_MS }).then(answered);
      button.renewTimer = setInterval(() => {
        link.send('renew', { press }, { timeoutMs: PRESS_ANSWER_TIMEOUT_MS }).then(answered);
      }, RENEW_MS);
    },

    // Ends the live press (if any). `reason`: why it ended without the finger
    // lifting; null for a normal release.
    end(reason) {
      if (!button.press) return;
      const press = button.press;
      button.press = 0;
      clearInterval(button.renewTimer);
      button.renewTimer = null;
      el.classList.remove('held');
      // Always tell the daemon, even after a refusal: releasing is always
      // allowed and never starts anything, and it leaves no doubt.
      link.send('release', { press });
      if (reason !== null) {
        if (button.fingerDown) el.classList.add('ended');
        onEnded(reason);
      }
    },

    // The finger lifted, the pointer was cancelled or left the button.
    lift() { if (button.fingerDown) button.forgetFinger(); },

    // Releases the press and forgets the finger; a disable that waited for
    // the finger applies now.
    forgetFinger() {
      button.fingerDown = false;
      button.pointerId = null;
      el.classList.remove('ended');
      button.end(null);
      if (button.wantsDisabled) el.disabled = true;
    },
  };
  el.addEventListener('pointerdown', button.start);
  for (const type of ['pointerup', 'pointercancel', 'pointerleave', 'lostpointercapture']) {
    el.addEventListener(type, (event) => { if (event.pointerId === button.pointerId) button.lift(); });
  }
  el.addEventListener('contextmenu', (event) => event.preventDefault());  // a long press is not a right-click
  holdButtons.add(button);
  return button;
}

// Ends every press of this page at once (Stop, the socket closing). The
// fingers may still be down: their buttons show "ended" until lifted.
export function endAllPresses(reason) {
  for (const button of holdButtons) button.end(reason);
}

// The page hidden, left or unfocused: the pointer-up may never come, so the
// buttons forget their fingers too (else they would ignore the next touch).
function abandonAllPresses() {
  for (const button of holdButtons) button.forgetFinger();
}
document.addEventListener('visibilitychange', () => { if (document.hidden) abandonAllPresses(); });
window.addEventListener('pagehide', abandonAllPresses);
window.addEventListener('blur', abandonAllPresses);

// Enables or disables a control. A hold button with a finger on it is
// disabled only when the finger lifts: a disabled button gets no pointer-up,
// and its press must still be released (and the daemon ends a press it
// refuses anyway, which the button then shows as "ended").
export function setControlEnabled(el, enabled) {
  const button = [...holdButtons].find((b) => b.el === el);
  if (button) {
    button.wantsDisabled = !enabled;
    if (button.fingerDown) return;
  }
  el.disabled = !enabled;
}
