// The pool panel. The machine's rules are checked here for a quick answer
// (the same rules as the CLI: 1..50 segments, increasing end times, speeds
// 0..100, up to 99:59), and again by the panel's server, which runs every
// command through the typed client: the page never has the last word.
'use strict';

const $ = (s) => document.querySelector(s);
let ws = null;
let nextId = 1;
const pending = new Map();
let state = null;
let plans = [[], [], [], []];
let editing = 1;
let draft = null;  // the plan being edited: [{speed, end}] with end in seconds
let samples = [];

const ADVICE = {
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

function mmss(s) { return `${String(Math.floor(s / 60)).padStart(2, '0')}:${String(s % 60).padStart(2, '0')}`; }
function seconds(text) {
  const m = /^(\d{1,2}):([0-5]\d)$/.exec(String(text).trim());
  if (m) return Number(m[1]) * 60 + Number(m[2]);
  return /^\d+$/.test(String(text).trim()) ? Number(text) : NaN;
}

function connect() {
  ws = new WebSocket(`${location.protocol === 'https:' ? 'wss' : 'ws'}://${location.host}/ws`);
  ws.onmessage = (ev) => {
    const m = JSON.parse(ev.data);
    if (m.type === 'state') render(m);
    else if (m.type === 'history') { samples = m.samples; drawRun(); }
    else if (m.type === 'sample') { samples.push(m); if (samples.length > 14400) samples.shift(); drawRun(); }
    else if (m.type === 'plans') { plans = m.plans; if (!draft) loadDraft(); }
    else if (m.type === 'result' && pending.has(m.id)) { pending.get(m.id)(m); pending.delete(m.id); }
  };
  ws.onclose = () => { $('#offline').textContent = 'No connection to the panel'; $('#offline').classList.remove('hidden'); setTimeout(connect, 1000); };
  ws.onopen = () => $('#offline').classList.add('hidden');
}

function send(op, fields = {}) {
  if (!ws || ws.readyState !== WebSocket.OPEN) return Promise.resolve({ ok: false, error: 'no connection to the panel' });
  const id = nextId++;
  ws.send(JSON.stringify({ op, id, ...fields }));
  return new Promise((resolve) => pending.set(id, resolve));
}

async function act(op, fields, where = '#reason') {
  $(where).textContent = '';
  const r = await send(op, fields);
  if (!r.ok) $(where).textContent = r.error;
  return r;
}

function render(s) {
  state = s;
  $('#offline').textContent = 'The machine does not answer';
  $('#offline').classList.toggle('hidden', s.online !== false);
  if (s.state === undefined) return;
  $('#state').textContent = s.state;
  $('#mode').textContent = s.mode;
  $('#speed').textContent = `${s.speed} %`;
  $('#time').textContent = s.time;
  const faults = s.faults || [];
  $('#faults').classList.toggle('hidden', faults.length === 0);
  $('#fault-list').replaceChildren(...faults.map((f) => {
    const li = document.createElement('li');
    li.innerHTML = '<b></b>: <span></span>';
    li.querySelector('b').textContent = f;
    li.querySelector('span').textContent = ADVICE[f] || 'Call service.';
    return li;
  }));
  const st = s.state || '';
  $('#pause').disabled = !/running|starting/.test(st);
  $('#resume').disabled = !/paused/.test(st);
  $('#stop').disabled = st === 'off';
}

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

// ---- the plan editor
function loadDraft() {
  draft = (plans[editing - 1] || []).map((s) => ({ speed: s.speed, end: s.end }));
  renderDraft();
}

function validate(segments) {
  if (segments.length < 1 || segments.length > 50) return 'a plan has 1 to 50 segments';
  let prev = 0;
  for (let i = 0; i < segments.length; ++i) {
    const s = segments[i];
    if (!Number.isInteger(s.speed) || s.speed < 0 || s.speed > 100) return `segment ${i + 1}: speed must be 0..100 %`;
    if (!Number.isInteger(s.end) || s.end < 1 || s.end > 5999) return `segment ${i + 1}: end must be 00:01..99:59`;
    if (s.end <= prev) return `segment ${i + 1}: end ${mmss(s.end)} is not after ${mmss(prev)}`;
    prev = s.end;
  }
  return '';
}

function renderDraft() {
  for (const b of document.querySelectorAll('#plan-tabs button')) b.classList.toggle('on', Number(b.dataset.plan) === editing);
  const body = $('#segments tbody');
  body.replaceChildren(...draft.map((s, i) => {
    const tr = document.createElement('tr');
    tr.innerHTML = `<td>${i + 1}</td><td><input type="number" min="0" max="100"></td><td><input type="text" size="5"></td>
      <td><button data-a="up">↑</button><button data-a="down">↓</button><button data-a="del">✕</button></td>`;
    const [sp, en] = tr.querySelectorAll('input');
    sp.value = s.speed;
    en.value = mmss(s.end);
    sp.oninput = () => { s.speed = Number(sp.value); check(); };
    en.oninput = () => { s.end = seconds(en.value); check(); };
    tr.querySelector('[data-a=up]').onclick = () => { if (i > 0) { [draft[i - 1], draft[i]] = [draft[i], draft[i - 1]]; renderDraft(); } };
    tr.querySelector('[data-a=down]').onclick = () => { if (i + 1 < draft.length) { [draft[i + 1], draft[i]] = [draft[i], draft[i + 1]]; renderDraft(); } };
    tr.querySelector('[data-a=del]').onclick = () => { draft.splice(i, 1); renderDraft(); };
    return tr;
  }));
  check();
}

function check() {
  const why = validate(draft);
  $('#plan-reason').textContent = why;
  $('#plan-save').disabled = false;  // saving an invalid plan shows the reason, it is never sent
  drawPlan(draft.filter((s) => Number.isFinite(s.end)));
  return why;
}

$('#seg-add').onclick = () => {
  const last = draft[draft.length - 1];
  draft.push({ speed: last ? last.speed : 50, end: Math.min(5999, (last ? last.end : 0) + 300) });
  renderDraft();
};
$('#plan-save').onclick = async () => {
  const why = check();
  if (why) { $('#plan-reason').textContent = `not saved: ${why}`; return; }
  const r = await act('plan', { plan: editing, segments: draft.map((s) => ({ speed: s.speed, end: s.end })) }, '#plan-reason');
  if (r.ok) { $('#plan-reason').textContent = `plan ${editing} saved (${draft.length} segments)`; draft = null; }
};
$('#plan-revert').onclick = () => loadDraft();
for (const b of document.querySelectorAll('#plan-tabs button')) b.onclick = () => { editing = Number(b.dataset.plan); loadDraft(); };

// ---- the run
$('#start').onclick = () => {
  const how = $('#start-mode').value;
  const speed = Number($('#speed-in').value);
  if (how === 'timer') return act('start', { mode: 'timer', speed, duration: $('#timer-in').value });
  if (how === 'free') return act('start', { mode: 'free', speed });
  return act('start', { mode: 'plan', plan: Number(how.slice(4)) });
};
$('#pause').onclick = () => act('pause');
$('#resume').onclick = () => act('resume');
$('#stop').onclick = () => act('stop');
$('#set-speed').onclick = () => act('speed', { speed: Number($('#speed-in').value) });
$('#slower').onclick = () => { $('#speed-in').value = Math.max(0, (state ? state.speed : 0) - 5); act('speed', { speed: Number($('#speed-in').value) }); };
$('#faster').onclick = () => { $('#speed-in').value = Math.min(100, (state ? state.speed : 0) + 5); act('speed', { speed: Number($('#speed-in').value) }); };

connect();
