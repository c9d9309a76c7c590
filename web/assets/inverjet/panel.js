// The pool panel. What the swimmer types (a speed, a time, a plan's rows,
// a start) is read by the panel's server, by the device layer's rules
// ({"op": "check"}: devices/inverjet/typed.hpp, the CLI's parser and ranges):
// this page parses no time or speed itself. The server runs every command
// through the typed client again: the page never has the last word. The
// limits the panel sends (plans, segments, the longest time, a fast speed)
// build the lists and the warnings. What a fault or a
// refusal means, what to do about it and which buttons the machine takes now
// come from the device layer too (the state's fault_advice and allowed, a
// result's code and advice): nothing here reads message text.
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
let limits = null;         // the machine's, from the panel ("limits"): none until they come

// ---- durations and speeds: one format everywhere
function mmss(s) { return `${String(Math.floor(s / 60)).padStart(2, '0')}:${String(s % 60).padStart(2, '0')}`; }
// What was typed, read by the panel: {why: '' when right, ...the answer's
// fields}; without the panel, {why, offline: true}.
async function checkTyped(what) {
  const r = await send('check', what);
  if (r.code === 'no_panel') return { why: 'no connection to the panel', offline: true, row: -1, field: '' };
  return r;
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
// When a refused command's cause is gone (by the result's code): the fault
// cleared, the link back, or else the machine's state changed.
function causeGone(code) {
  const was = state && state.state;
  if (code === 'fault') return () => state && state.online === true && !(state.faults || []).length;
  if (code === 'no_answer' || code === 'no_panel') return () => !linkLost();
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
    else if (m.type === 'limits') { limits = m.limits; buildPlanChoices(); renderDraft(); }
    else if (m.type === 'result' && pending.has(m.id)) { pending.get(m.id)(m); pending.delete(m.id); }
  };
  ws.onclose = () => {
    const was = ws;
    wsOpen = false;
    for (const [, done] of pending) done(NO_PANEL);
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

// The one failure the page itself finds: the panel is not there to ask.
const NO_PANEL = {
  ok: false, code: 'no_panel', error: 'no connection to the panel',
  advice: 'This page lost the panel (Wi-Fi or the panel itself): to stop the machine now, press Stop on the machine itself.',
};
function send(op, fields = {}) {
  if (!ws || !wsOpen) return Promise.resolve(NO_PANEL);
  const id = nextId++;
  ws.send(JSON.stringify({ op, id, ...fields }));
  return new Promise((resolve) => pending.set(id, resolve));
}

async function act(op, fields, where = '#reason') {
  say(where, '');
  const r = await send(op, fields);
  if (!r.ok) say(where, `${op}: ${r.error}`, 'command', r.advice || '', causeGone(r.code));
  return r;
}

// A run is going (a start would replace it): the machine takes Stop and a speed.
function running() { return !!(state && state.allowed && state.allowed.speed); }

function render(s) {
  state = s;
  if (s.state !== undefined) {
    $('#state').textContent = s.state;
    $('#mode').textContent = s.mode && s.mode !== 'off' ? `mode: ${s.mode}` : '';
    // The water's speed, big: 0 % when the jet stands (paused, the fault
    // screen), with the set speed beside it, never the set speed as if it ran.
    const jet = typeof s.jet_speed === 'number' ? s.jet_speed : 0;
    $('#speed').textContent = `${jet} %`;
    $('#speed-set').textContent = s.speed !== jet ? `set ${s.speed} %` : '';
    $('#time').textContent = s.time;
    const faults = s.fault_advice || [];
    $('#faults').classList.toggle('hidden', faults.length === 0);
    $('#fault-list').replaceChildren(...faults.map((f) => {
      const li = document.createElement('li');
      const b = document.createElement('b');
      b.textContent = f.fault;
      li.append(b, `: ${f.advice[0].toUpperCase()}${f.advice.slice(1)}.`);
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
  // Which buttons the machine takes now: the device layer's (state.allowed).
  const allowed = state.allowed || {};
  $('#start').disabled = !allowed.start || !limits;
  $('#pause').disabled = !allowed.pause;
  $('#resume').disabled = !allowed.resume;
  $('#stop').disabled = !allowed.stop;
  for (const id of ['#slower', '#faster', '#set-speed']) $(id).disabled = !allowed.speed || !limits;
  $('#start-why').textContent = allowed.start ? '' : (state.fault ? 'Start is off while the machine shows a fault (see above).' : '');
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

// Axes: gridlines at quarters of the height in the SVG; the figures beside
// it as HTML (the SVG stretches to its box: text in it would stretch too).
function grid(svg) {
  for (const f of [0.25, 0.5, 0.75]) {
    const l = document.createElementNS('http://www.w3.org/2000/svg', 'line');
    l.setAttribute('x1', '0'); l.setAttribute('x2', '600');
    l.setAttribute('y1', String(120 - f * 115)); l.setAttribute('y2', String(120 - f * 115));
    l.setAttribute('stroke', '#2b5573'); l.setAttribute('stroke-width', '1');
    l.setAttribute('vector-effect', 'non-scaling-stroke');
    svg.append(l);
  }
}
function axes(svg, top, span) {
  const box = svg.closest('.chart-box');
  box.querySelector('.y-top').textContent = top;
  box.querySelector('.x-end').textContent = mmss(Math.round(span));
}

function drawRun() {
  const t0 = samples.length ? samples[0].t : 0;
  const span = Math.max(60, samples.length ? samples[samples.length - 1].t - t0 : 60);
  const a = $('#chart-speed'), b = $('#chart-temp');
  a.replaceChildren(); b.replaceChildren();
  grid(a); grid(b);
  axes(a, '100 % · 10 A', span);
  axes(b, '100 °C', span);
  polyline(a, samples.map((s) => [s.t - t0, s.speed]), span, 100, '#4fd1ff');
  polyline(a, samples.map((s) => [s.t - t0, s.current_a * 10]), span, 100, '#ffd166');
  polyline(b, samples.map((s) => [s.t - t0, s.mosfet_c]), span, 100, '#ff8fab');
  polyline(b, samples.map((s) => [s.t - t0, s.motor_c]), span, 100, '#b8f28b');
}

function drawPlan(segments) {
  const svg = $('#plan-chart');
  svg.replaceChildren();
  const end = Math.max(60, ...segments.map((s) => s.end || 0));
  grid(svg);
  axes(svg, '100 %', end);
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
    return { speed: s.speed, speedText: String(s.speed), end: s.end_s, endText: mmss(s.end_s) };
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
    sp.oninput = () => { s.speedText = sp.value; touched(); check(); };
    en.oninput = () => { s.endText = en.value; touched(); check(); };
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

// The plan being edited, read by the panel: the answer marks the first row
// at fault (red border, aria-invalid) and says why, until the plan is right;
// each row's values as they read draw the chart. Only the newest check of
// the plan on screen is shown. Returns the answer.
let checkSeq = 0;
function check() {
  const d = draft();
  const plan = editing;
  const seq = ++checkSeq;
  const typed = d.segments.map((s) => ({ speed: s.speedText, end: s.endText }));
  return checkTyped({ segments: typed }).then((r) => {
    if (seq === checkSeq && plan === editing && !r.offline) showCheck(d, r);
    return r;
  });
}
function showCheck(d, r) {
  const { why, row, field } = r;
  (r.segments || []).forEach((v, i) => {
    if (!d.segments[i]) return;
    d.segments[i].speed = v.speed === null ? NaN : v.speed;
    d.segments[i].end = v.end_s === null ? NaN : v.end_s;
  });
  [...$('#segments').children].forEach((el, i) => {
    el.classList.toggle('bad', i === row && field === 'end');
    el.classList.toggle('bad-speed', i === row && field === 'speed');
    el.querySelector('input.end').setAttribute('aria-invalid', String(i === row && field === 'end'));
    el.querySelector('input.speed').setAttribute('aria-invalid', String(i === row && field === 'speed'));
  });
  // A refusal goes away as soon as the plan is right again.
  if (why) say('#plan-reason', why, 'input');
  else if (shown['#plan-reason'] && shown['#plan-reason'].kind === 'input') say('#plan-reason', '');
  drawPlan(d.segments.filter((s) => Number.isFinite(s.end) && Number.isFinite(s.speed)));
}

$('#seg-add').onclick = () => {
  const list = draft().segments;
  const last = list[list.length - 1];
  const end = Math.min(limits ? limits.time_max_s : 0, (last && Number.isFinite(last.end) ? last.end : 0) + 300);
  const speed = last && Number.isFinite(last.speed) ? last.speed : 50;
  list.push({ speed, speedText: String(speed), end, endText: mmss(end) });
  touched();
  renderDraft();
};
$('#plan-save').onclick = async () => {
  const plan = editing;
  const d = draft();
  const typed = JSON.stringify(d.segments.map((s) => [s.speedText, s.endText]));
  const c = await check();
  if (c.offline) { sayOffline('#plan-reason', 'plan'); return; }
  if (c.why) { say('#plan-reason', `not saved: ${c.why}`, 'input'); return; }
  const segments = c.segments.map((s) => ({ speed: s.speed, end: mmss(s.end_s) }));
  const r = await act('plan', { plan, segments }, '#plan-reason');
  if (r.ok) {
    // What the machine stored comes back with the plans; edits typed while
    // it was being saved stay in the draft (unsaved), never thrown away.
    const now = JSON.stringify(d.segments.map((s) => [s.speedText, s.endText]));
    if (drafts.get(plan) === d && now === typed) drafts.delete(plan);
    say('#plan-reason', `plan ${plan} saved (${segments.length} segments)`, 'done');
    if (plan === editing) renderDraft();
  }
};
$('#plan-revert').onclick = () => { drafts.delete(editing); say('#plan-reason', ''); renderDraft(); };
// The plans the machine has (limits.plans): a tab each, and a choice each in the run's list.
function buildPlanChoices() {
  const tabs = [];
  const select = $('#start-mode');
  for (const o of [...select.options]) if (o.value.startsWith('plan')) o.remove();
  for (let p = 1; p <= limits.plans; ++p) {
    const b = document.createElement('button');
    b.dataset.plan = String(p);
    b.textContent = `Plan ${p}`;
    b.onclick = () => { editing = p; if (shown['#plan-reason'] && shown['#plan-reason'].kind !== 'input') say('#plan-reason', ''); renderDraft(); };
    tabs.push(b);
    select.append(new Option(`Plan ${p}`, `plan${p}`));
  }
  $('#plan-tabs').replaceChildren(...tabs);
  if (editing > limits.plans) editing = 1;
}

// ---- the run
// The start as typed, read by the panel: {fields} for the command, or {error}.
async function startFields() {
  const how = $('#start-mode').value;
  const typed = how.startsWith('plan')
    ? { mode: 'plan', plan: Number(how.slice(4)) }
    : { mode: how, speed: $('#speed-in').value, duration: how === 'timer' ? $('#timer-in').value : undefined };
  const r = await checkTyped({ start: typed });
  return r.why ? { error: r.why, offline: !!r.offline } : { fields: r.fields };
}
// A check the panel could not answer: the one failure the page finds
// itself, shown as a command's (it clears when the link is back).
function sayOffline(where, what) {
  say(where, `${what}: ${NO_PANEL.error}`, 'command', NO_PANEL.advice, causeGone('no_panel'));
}
// A refused input: the message stays until the input is right. Only the
// newest recheck's answer counts (an older one may be of a text since changed).
let recheckSeq = 0;
async function recheck() {
  const s = shown['#reason'];
  if (!s || s.kind !== 'input') return;
  const seq = ++recheckSeq;
  const f = await startFields();
  if (seq === recheckSeq && !f.error && shown['#reason'] === s) say('#reason', '');
}
for (const id of ['#speed-in', '#timer-in', '#start-mode']) $(id).addEventListener('input', recheck);
$('#start-mode').addEventListener('change', () => { recheck(); updateControls(); });

$('#start').onclick = async () => {
  const f = await startFields();
  if (f.offline) { sayOffline('#reason', 'start'); return; }
  if (f.error) { say('#reason', f.error, 'input'); return; }
  const what = f.fields.mode === 'plan' ? `plan ${f.fields.plan}` : `a ${f.fields.mode} run at ${f.fields.speed} %`;
  if (running() && !await confirmFirst(`A run is going (${state.state}, ${state.time}). Stop it and start ${what}?`, 'Yes, start again')) return;
  if (f.fields.speed > limits.fast_speed && !await confirmFirst(`Start at ${f.fields.speed} %? That is very fast.`, `Yes, ${f.fields.speed}\u00a0%`)) return;
  act('start', f.fields);
};
$('#pause').onclick = () => act('pause');
$('#resume').onclick = () => act('resume');
$('#stop').onclick = () => act('stop');
async function setSpeed(speed) {
  if (speed > limits.fast_speed && speed > (state ? state.speed : 0) && !await confirmFirst(`Go to ${speed} %? That is very fast.`, `Yes, ${speed}\u00a0%`)) return;
  $('#speed-in').value = speed;
  recheck();
  act('speed', { speed });
}
$('#set-speed').onclick = async () => {
  const r = await checkTyped({ speed: $('#speed-in').value });
  if (r.offline) { sayOffline('#reason', 'speed'); return; }
  if (r.why) { say('#reason', r.why, 'input'); return; }
  setSpeed(r.speed);
};
$('#slower').onclick = () => setSpeed(Math.max(limits.speed.min, (state ? state.speed : 0) - 5));
$('#faster').onclick = () => setSpeed(Math.min(limits.speed.max, (state ? state.speed : 0) + 5));

// With a password, the panel offers to log out.
fetch('/api/session', { cache: 'no-store' }).then((r) => r.json()).then((s) => {
  $('#logout').classList.toggle('hidden', !s.auth);
}, () => {});

renderDraft();
renderLink();
connect();
