// The pool panel. The machine's rules are checked here for a quick answer
// (the same rules as the CLI: 1..50 segments, increasing end times, speeds
// 0..100, up to 99:59), and again by the panel's server, which runs every
// command through the typed client: the page never has the last word.
//
// For a swimmer: a lost link never looks live (values greyed, "No contact
// since", every control disabled, what to do instead); an empty or unclear
// field is refused with the reason and nothing is sent; a start over a
// running run and speeds above 80 % ask first; unsaved plan edits survive a
// change of tab; messages clear themselves when their cause is gone.
'use strict';

const $ = (s) => document.querySelector(s);
let ws = null;
let wsOpen = false;
let nextId = 1;
const pending = new Map();
let state = null;          // the last state from the panel
let lastFromPanel = null;  // when the page last heard from the panel (Date)
let lastPong = 0;
let plans = [[], [], [], []];
let editing = 1;
const drafts = new Map();  // plan -> {segments: [{speed, speedText, end, endText}], dirty}
let samples = [];
const FAST = 80;           // speeds above this ask first

const FAULT_ADVICE = {
  'voltage': 'Mains voltage out of range: check the supply; the machine restarts when it is back in range.',
  'output over-current': 'The motor drew too much current: check the propeller for blockage, then restart.',
  'current-sensor bias': 'Current sensor fault: switch the machine off and on; call service if it returns.',
  'MOSFET over-temperature': 'The drive is too hot: let it cool down and check the cooling water flow.',
  'enclosure over-temperature': 'The enclosure is too hot: check ventilation of the technical room.',
  'temperature sensor 1': 'Temperature sensor fault: call service.',
  'temperature sensor 2': 'Temperature sensor fault: call service.',
  'motor drive': 'Motor drive fault: switch off, check the motor cable, then restart; call service if it returns.',
  'driver-board communication': 'The display lost the driver board: check the cable between them.',
};

// What the swimmer can do about a refused command.
function advice(error) {
  const e = String(error || '');
  if (/fault/.test(e)) return 'The machine shows a fault: see the fault box for what to do; it can start again once the fault is cleared.';
  if (/masked/.test(e)) return 'The machine ignores remote control right now (control mask): use its own buttons, or ask the pool staff.';
  if (/not possible while|nothing to pause|nothing is paused/.test(e)) return 'The machine is not in a state for that: look at the state above and try the matching button.';
  if (/exception 04/i.test(e)) return 'The machine refused: check its display; press Stop on the machine if in doubt.';
  if (/exception 0[123]/i.test(e)) return 'The machine did not accept the values: check the speed and time.';
  if (/timeout|no response|I\/O error|not connected|connection/i.test(e)) return 'The machine did not answer: check its power and cable. To stop it, press Stop on the machine itself.';
  if (/busy/.test(e)) return 'Too many commands at once: wait a moment and try again.';
  return '';
}

// ---- durations and speeds: one format everywhere
function mmss(s) { return `${String(Math.floor(s / 60)).padStart(2, '0')}:${String(s % 60).padStart(2, '0')}`; }
const EXAMPLE = 'write 30:00, 30m or 90s';
function parseDuration(text, what = 'Time') {
  const t = String(text).trim().toLowerCase();
  if (t === '') return { error: `${what} is empty: ${EXAMPLE}.` };
  if (/^\d+$/.test(t)) return { error: `${what} "${t}" has no unit: ${EXAMPLE}.` };
  let m = /^(\d{1,2}):([0-5]\d)$/.exec(t);
  let s;
  if (m) s = Number(m[1]) * 60 + Number(m[2]);
  else if ((m = /^(?:(\d{1,2})m)?(?:(\d{1,4})s)?$/.exec(t)) && (m[1] || m[2])) s = Number(m[1] || 0) * 60 + Number(m[2] || 0);
  else return { error: `${what} "${String(text).trim()}" is not a time: ${EXAMPLE}.` };
  if (s < 1 || s > 5999) return { error: `${what} ${String(text).trim()} is out of range: 00:01 to 99:59.` };
  return { seconds: s };
}
function parseSpeed(text) {
  const t = String(text).trim().replace(/\s*%$/, '');
  if (t === '') return { error: 'Speed is empty: enter 0 to 100 %, for example 60.' };
  if (!/^\d{1,3}$/.test(t) || Number(t) > 100) return { error: `Speed "${String(text).trim()}" is not 0 to 100 %: for example 60.` };
  return { speed: Number(t) };
}

// ---- messages: each knows what clears it
const shown = { '#reason': null, '#plan-reason': null };
function say(where, text, kind, extra = '', gone = null) {
  const el = $(where);
  el.replaceChildren();
  shown[where] = text ? { kind, gone } : null;
  if (!text) return;
  el.append(text);
  if (extra) {
    const a = document.createElement('span');
    a.className = 'advice';
    a.textContent = extra;
    el.append(a);
  }
}
// When a refused command's cause is gone: the fault cleared, the link back,
// or else the machine's state changed.
function causeGone(error) {
  const was = state && state.state;
  if (/fault/.test(error)) return () => state && state.online === true && !(state.faults || []).length;
  if (/timeout|no response|I\/O error|not connected|connection/i.test(error)) return () => !linkLost();
  return () => !state || state.state !== was;
}

// ---- the link
function connect() {
  ws = new WebSocket(`${location.protocol === 'https:' ? 'wss' : 'ws'}://${location.host}/ws`);
  ws.onopen = () => { wsOpen = true; lastPong = Date.now(); lastFromPanel = new Date(); renderLink(); };
  ws.onmessage = (ev) => {
    lastFromPanel = new Date();
    const m = JSON.parse(ev.data);
    if (m.type === 'pong') lastPong = Date.now();
    else if (m.type === 'state') render(m);
    else if (m.type === 'history') { samples = m.samples; drawRun(); }
    else if (m.type === 'sample') { samples.push(m); if (samples.length > 14400) samples.shift(); drawRun(); }
    else if (m.type === 'plans') { plans = m.plans; refreshDrafts(); }
    else if (m.type === 'result' && pending.has(m.id)) { pending.get(m.id)(m); pending.delete(m.id); }
  };
  ws.onclose = () => {
    const was = ws;
    wsOpen = false;
    for (const [, done] of pending) done({ ok: false, error: 'no connection to the panel' });
    pending.clear();
    renderLink();
    // Logged out or the session ended: back to the login page. Else try again.
    fetch('/api/session', { cache: 'no-store' }).then((r) => {
      if (r.status === 401) location.assign('/login');
      else if (ws === was) setTimeout(connect, 1000);
    }, () => { if (ws === was) setTimeout(connect, 2000); });
  };
}

// A half-open connection (Wi-Fi gone at the pool's edge) closes no socket:
// the page asks every 3 s and takes 8 s of silence as a lost link.
setInterval(() => {
  if (!ws || !wsOpen) return;
  if (Date.now() - lastPong > 8000) { ws.close(); wsOpen = false; renderLink(); return; }
  ws.send(JSON.stringify({ op: 'ping' }));
}, 3000);

function linkLost() { return !wsOpen || !state || state.online !== true; }

function renderLink() {
  const lost = linkLost();
  document.body.classList.toggle('lost', lost);
  if (lost) {
    const machineLast = state && state.last_contact_ms ? new Date(state.last_contact_ms) : null;
    const since = wsOpen || !(state && state.online) ? machineLast : lastFromPanel;
    const everLive = since !== null;
    $('#lost-title').textContent = everLive
      ? `No contact since ${since.toLocaleTimeString('en-GB')}`
      : (wsOpen ? 'No contact with the machine yet' : 'Connecting to the panel…');
    $('#lost-what').textContent = (!wsOpen
      ? 'This page lost the panel (Wi-Fi or the panel itself). '
      : 'The panel lost the machine (its cable or power). ')
      + 'The buttons here are off: to stop the machine now, press Stop on the machine itself.';
    if (confirmDone) confirmDone(false);
  }
  // A message about the link goes away when the link is back.
  for (const where of Object.keys(shown)) {
    const s = shown[where];
    if (s && s.kind === 'command' && s.gone && s.gone()) say(where, '');
  }
  updateControls();
}

function send(op, fields = {}) {
  if (!ws || !wsOpen) return Promise.resolve({ ok: false, error: 'no connection to the panel' });
  const id = nextId++;
  ws.send(JSON.stringify({ op, id, ...fields }));
  return new Promise((resolve) => pending.set(id, resolve));
}

async function act(op, fields, where = '#reason') {
  say(where, '');
  const r = await send(op, fields);
  if (!r.ok) say(where, `${op}: ${r.error}`, 'command', advice(r.error), causeGone(r.error));
  return r;
}

function running() { return state && /running|starting|paused|initial/.test(state.state || ''); }

function render(s) {
  state = s;
  if (s.state !== undefined) {
    $('#state').textContent = s.state;
    $('#mode').textContent = s.mode ? `mode: ${s.mode}` : '';
    $('#speed').textContent = `${s.speed} %`;
    $('#time').textContent = s.time;
    const faults = s.faults || [];
    $('#faults').classList.toggle('hidden', faults.length === 0);
    $('#fault-list').replaceChildren(...faults.map((f) => {
      const li = document.createElement('li');
      const b = document.createElement('b');
      b.textContent = f;
      li.append(b, `: ${FAULT_ADVICE[f] || 'Call service.'}`);
      return li;
    }));
  }
  renderLink();
}

function updateControls() {
  const lost = linkLost();
  for (const el of document.querySelectorAll('#run button, #run input, #run select, #plans .seg button, #plans .seg input, #seg-add, #plan-save, #plan-revert'))
    el.disabled = lost;
  if (lost) return;
  const rows = $('#segments').children;  // the first goes no higher, the last no lower
  if (rows.length) {
    rows[0].querySelectorAll('.tools button')[0].disabled = true;
    rows[rows.length - 1].querySelectorAll('.tools button')[1].disabled = true;
  }
  const st = state.state || '';
  $('#pause').disabled = !/running|starting/.test(st);
  $('#resume').disabled = !/paused/.test(st);
  $('#stop').disabled = st === 'off';
  for (const id of ['#slower', '#faster', '#set-speed']) $(id).disabled = !/running|starting|paused/.test(st);
  const how = $('#start-mode').value;
  $('#timer-field').classList.toggle('hidden', how !== 'timer');
  $('#timer-hint').classList.toggle('hidden', how !== 'timer');
  $('#speed-field').classList.toggle('hidden', how.startsWith('plan'));
}

// ---- the in-page confirmation (big buttons; not window.confirm)
let confirmDone = null;
function confirmFirst(text, yes) {
  if (confirmDone) confirmDone(false);
  return new Promise((resolve) => {
    $('#confirm-text').textContent = text;
    $('#confirm-yes').textContent = yes;
    $('#confirm').classList.remove('hidden');
    confirmDone = (v) => { confirmDone = null; $('#confirm').classList.add('hidden'); resolve(v); };
    $('#confirm-no').focus();
  });
}
$('#confirm-yes').onclick = () => confirmDone && confirmDone(true);
$('#confirm-no').onclick = () => confirmDone && confirmDone(false);

// ---- charts (SVG, drawn by hand: no library fetched at run time)
function polyline(svg, points, xmax, ymax, color) {
  const p = document.createElementNS('http://www.w3.org/2000/svg', 'polyline');
  p.setAttribute('points', points.map(([x, y]) => `${(x / xmax) * 600},${120 - (y / ymax) * 115}`).join(' '));
  p.setAttribute('fill', 'none');
  p.setAttribute('stroke', color);
  p.setAttribute('stroke-width', '2');
  p.setAttribute('vector-effect', 'non-scaling-stroke');
  svg.append(p);
}

function drawRun() {
  const t0 = samples.length ? samples[0].t : 0;
  const span = Math.max(60, samples.length ? samples[samples.length - 1].t - t0 : 60);
  const a = $('#chart-speed'), b = $('#chart-temp');
  a.replaceChildren(); b.replaceChildren();
  polyline(a, samples.map((s) => [s.t - t0, s.speed]), span, 100, '#4fd1ff');
  polyline(a, samples.map((s) => [s.t - t0, s.current_a * 10]), span, 100, '#ffd166');
  polyline(b, samples.map((s) => [s.t - t0, s.mosfet_c]), span, 100, '#ff8fab');
  polyline(b, samples.map((s) => [s.t - t0, s.motor_c]), span, 100, '#b8f28b');
}

function drawPlan(segments) {
  const svg = $('#plan-chart');
  svg.replaceChildren();
  const end = Math.max(60, ...segments.map((s) => s.end || 0));
  const pts = [];
  let from = 0;
  for (const s of segments) {
    pts.push([from, s.speed], [s.end, s.speed]);
    from = s.end;
  }
  if (pts.length) polyline(svg, pts, end, 100, '#4fd1ff');
}

// ---- the plan editor: one draft per plan, kept until saved or reverted
function fromMachine(p) {
  return (plans[p - 1] || []).map((s) => {
    const end = typeof s.end_s === 'number' ? s.end_s : (typeof s.end === 'number' ? s.end : parseDuration(s.end).seconds);
    return { speed: s.speed, speedText: String(s.speed), end, endText: mmss(end) };
  });
}
function draft() {
  if (!drafts.has(editing)) drafts.set(editing, { segments: fromMachine(editing), dirty: false });
  return drafts.get(editing);
}
function refreshDrafts() {  // the machine's plans arrived: drafts nobody touched follow them
  for (const [p, d] of drafts) if (!d.dirty) drafts.set(p, { segments: fromMachine(p), dirty: false });
  renderDraft();
}
function touched() { draft().dirty = true; markTabs(); }
function markTabs() {
  for (const b of document.querySelectorAll('#plan-tabs button')) {
    const p = Number(b.dataset.plan);
    b.classList.toggle('on', p === editing);
    const dirty = drafts.has(p) && drafts.get(p).dirty;
    b.classList.toggle('dirty', dirty);
    b.title = dirty ? `plan ${p}: unsaved edits` : '';
  }
}

function validate(segments) {
  if (segments.length < 1 || segments.length > 50) return 'a plan has 1 to 50 segments';
  let prev = 0;
  for (let i = 0; i < segments.length; ++i) {
    const s = segments[i];
    const sp = parseSpeed(s.speedText);
    if (sp.error) return `segment ${i + 1}: ${sp.error}`;
    const d = parseDuration(s.endText, 'End');
    if (d.error) return `segment ${i + 1}: ${d.error}`;
    if (d.seconds <= prev) return `segment ${i + 1}: end ${mmss(d.seconds)} is not after ${mmss(prev)}`;
    prev = d.seconds;
  }
  return '';
}

function button(text, label) {
  const b = document.createElement('button');
  b.textContent = text;
  b.setAttribute('aria-label', label);
  return b;
}

function renderDraft() {
  markTabs();
  const d = draft();
  const list = d.segments;
  $('#segments').replaceChildren(...list.map((s, i) => {
    const row = document.createElement('div');
    row.className = 'seg';
    const n = document.createElement('span');
    n.className = 'n';
    n.textContent = i + 1;
    const sp = document.createElement('input');
    sp.className = 'speed';
    sp.inputMode = 'numeric';
    sp.value = s.speedText;
    sp.setAttribute('aria-label', `segment ${i + 1} speed %`);
    const en = document.createElement('input');
    en.className = 'end';
    en.value = s.endText;
    en.setAttribute('aria-label', `segment ${i + 1} ends at`);
    sp.oninput = () => { s.speedText = sp.value; s.speed = parseSpeed(sp.value).speed; touched(); check(); };
    en.oninput = () => { s.endText = en.value; s.end = parseDuration(en.value).seconds; touched(); check(); };
    const tools = document.createElement('div');
    tools.className = 'tools';
    const up = button('↑', `move segment ${i + 1} up`);
    const down = button('↓', `move segment ${i + 1} down`);
    const del = button('✕', `delete segment ${i + 1}`);
    up.onclick = () => { [list[i - 1], list[i]] = [list[i], list[i - 1]]; touched(); renderDraft(); };
    down.onclick = () => { [list[i + 1], list[i]] = [list[i], list[i + 1]]; touched(); renderDraft(); };
    del.onclick = () => { list.splice(i, 1); touched(); renderDraft(); };
    tools.append(up, down, del);
    row.append(n, sp, en, tools);
    return row;
  }));
  check();
  updateControls();
}

function check() {
  const why = validate(draft().segments);
  // A refusal goes away as soon as the plan is right again.
  if (why) say('#plan-reason', why, 'input');
  else if (shown['#plan-reason'] && shown['#plan-reason'].kind === 'input') say('#plan-reason', '');
  drawPlan(draft().segments.filter((s) => Number.isFinite(s.end) && Number.isFinite(s.speed)));
  return why;
}

$('#seg-add').onclick = () => {
  const list = draft().segments;
  const last = list[list.length - 1];
  const end = Math.min(5999, (last && Number.isFinite(last.end) ? last.end : 0) + 300);
  const speed = last && Number.isFinite(last.speed) ? last.speed : 50;
  list.push({ speed, speedText: String(speed), end, endText: mmss(end) });
  touched();
  renderDraft();
};
$('#plan-save').onclick = async () => {
  const why = check();
  if (why) { say('#plan-reason', `not saved: ${why}`, 'input'); return; }
  const d = draft();
  const plan = editing;
  const segments = d.segments.map((s) => ({ speed: parseSpeed(s.speedText).speed, end: mmss(parseDuration(s.endText).seconds) }));
  const r = await act('plan', { plan, segments }, '#plan-reason');
  if (r.ok) {
    drafts.delete(plan);  // what the machine stored comes back with the plans
    say('#plan-reason', `plan ${plan} saved (${segments.length} segments)`, 'done');
    if (plan === editing) renderDraft();
  }
};
$('#plan-revert').onclick = () => { drafts.delete(editing); say('#plan-reason', ''); renderDraft(); };
for (const b of document.querySelectorAll('#plan-tabs button'))
  b.onclick = () => { editing = Number(b.dataset.plan); if (shown['#plan-reason'] && shown['#plan-reason'].kind !== 'input') say('#plan-reason', ''); renderDraft(); };

// ---- the run
function startFields() {
  const how = $('#start-mode').value;
  if (how.startsWith('plan')) return { fields: { mode: 'plan', plan: Number(how.slice(4)) } };
  const sp = parseSpeed($('#speed-in').value);
  if (sp.error) return { error: sp.error };
  const fields = { mode: how, speed: sp.speed };
  if (how === 'timer') {
    const d = parseDuration($('#timer-in').value);
    if (d.error) return { error: d.error };
    fields.duration = mmss(d.seconds);
  }
  return { fields };
}
// A refused input: the message stays until the input is right.
function recheck() {
  const s = shown['#reason'];
  if (s && s.kind === 'input' && !startFields().error) say('#reason', '');
}
for (const id of ['#speed-in', '#timer-in', '#start-mode']) $(id).addEventListener('input', recheck);
$('#start-mode').addEventListener('change', () => { recheck(); updateControls(); });

$('#start').onclick = async () => {
  const f = startFields();
  if (f.error) { say('#reason', f.error, 'input'); return; }
  const what = f.fields.mode === 'plan' ? `plan ${f.fields.plan}` : `a ${f.fields.mode} run at ${f.fields.speed} %`;
  if (running() && !await confirmFirst(`A run is going (${state.state}, ${state.time}). Stop it and start ${what}?`, 'Yes, start again')) return;
  if (f.fields.speed > FAST && !await confirmFirst(`Start at ${f.fields.speed} %? That is very fast.`, `Yes, ${f.fields.speed}\u00a0%`)) return;
  act('start', f.fields);
};
$('#pause').onclick = () => act('pause');
$('#resume').onclick = () => act('resume');
$('#stop').onclick = () => act('stop');
async function setSpeed(speed) {
  if (speed > FAST && speed > (state ? state.speed : 0) && !await confirmFirst(`Go to ${speed} %? That is very fast.`, `Yes, ${speed}\u00a0%`)) return;
  $('#speed-in').value = speed;
  recheck();
  act('speed', { speed });
}
$('#set-speed').onclick = () => {
  const sp = parseSpeed($('#speed-in').value);
  if (sp.error) { say('#reason', sp.error, 'input'); return; }
  setSpeed(sp.speed);
};
$('#slower').onclick = () => setSpeed(Math.max(0, (state ? state.speed : 0) - 5));
$('#faster').onclick = () => setSpeed(Math.min(100, (state ? state.speed : 0) + 5));

// With a password, the panel offers to log out.
fetch('/api/session', { cache: 'no-store' }).then((r) => r.json()).then((s) => {
  $('#logout').classList.toggle('hidden', !s.auth);
}, () => {});

renderDraft();
renderLink();
connect();
