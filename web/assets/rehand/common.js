// Shared by the HMI and the phone page: the WebSocket to the host daemon,
// reconnecting, and press-and-hold buttons (the dead-man rule: a command is
// held only while a finger is down, the page is visible and the socket is open).
'use strict';

export function connect(query, onMessage, onStatus) {
  let ws = null;
  let nextId = 1;
  const pending = new Map();
  const api = {
    send(op, fields = {}) {
      if (!ws || ws.readyState !== WebSocket.OPEN) return Promise.resolve({ ok: false, error: 'no connection to the host' });
      const id = nextId++;
      ws.send(JSON.stringify({ op, id, ...fields }));
      return new Promise((resolve) => pending.set(id, resolve));
    },
    open() { return ws && ws.readyState === WebSocket.OPEN; },
    close() { if (ws) ws.close(); },
    onclose: [],
  };
  function open() {
    const proto = location.protocol === 'https:' ? 'wss:' : 'ws:';
    ws = new WebSocket(`${proto}//${location.host}/ws?${query()}`);
    ws.onopen = () => onStatus(true);
    ws.onmessage = (ev) => {
      let m;
      try { m = JSON.parse(ev.data); } catch { return; }
      if (m.type === 'result' && pending.has(m.id)) {
        pending.get(m.id)(m);
        pending.delete(m.id);
      }
      onMessage(m);
    };
    ws.onclose = () => {
      onStatus(false);
      for (const [, resolve] of pending) resolve({ ok: false, error: 'connection lost' });
      pending.clear();
      for (const f of api.onclose) f();
      setTimeout(open, 1000);
    };
  }
  open();
  return api;
}

// A press-and-hold button: `start()` on pointer down and every `renewMs`
// while held; `stop()` on pointer up, cancel, leaving the button, the page
// hidden or the socket closing. Returns a function that releases it.
export function holdButton(el, api, start, stop, renewMs = 100) {
  let timer = null;
  const release = () => {
    if (timer === null) return;
    clearInterval(timer);
    timer = null;
    el.classList.remove('held');
    stop();
  };
  el.addEventListener('pointerdown', (ev) => {
    if (el.disabled || timer !== null) return;
    ev.preventDefault();
    try { el.setPointerCapture(ev.pointerId); } catch { /* synthetic events */ }
    el.classList.add('held');
    start();
    timer = setInterval(start, renewMs);
  });
  for (const t of ['pointerup', 'pointercancel', 'pointerleave', 'lostpointercapture']) el.addEventListener(t, release);
  el.addEventListener('contextmenu', (ev) => ev.preventDefault());
  document.addEventListener('visibilitychange', () => { if (document.hidden) release(); });
  window.addEventListener('pagehide', release);
  window.addEventListener('blur', release);
  api.onclose.push(release);
  return release;
}

export function $(sel) { return document.querySelector(sel); }

export function beep(ms = 300) {
  try {
    const ctx = new (window.AudioContext || window.webkitAudioContext)();
    const o = ctx.createOscillator();
    o.frequency.value = 440;
    o.connect(ctx.destination);
    o.start();
    setTimeout(() => { o.stop(); ctx.close(); }, ms);
  } catch { /* no audio device */ }
}
