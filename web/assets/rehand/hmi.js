// The touch HMI: renders every state message from the host daemon and sends
// commands. The daemon decides (UI rules, leases, D-8); the page shows why a
// control is disabled and never retries on its own.
'use strict';
import { connect, holdButton, $, beep } from '/rehand/common.js';

let state = null;
let mph = false;
let acknowledged = 0;  // the error code the user acknowledged
let codeShown = '';
let codeDeadline = 0;
function showCodeTime() {
  const left = Math.max(0, Math.round((codeDeadline - Date.now()) / 1000));
  $('#code-time').textContent = codeShown ? `valid ${Math.floor(left / 60)}:${String(left % 60).padStart(2, '0')}` : '';
}
setInterval(showCodeTime, 1000);
const all = () => [...document.querySelectorAll('main button')];

const api = connect(() => 'role=display', onMessage, (up) => {
  if (!up) { $('#link').textContent = 'no connection to the host'; showOverlay('1010 Master Error', 'The display lost its host program.'); }
});

function onMessage(m) {
  if (m.type === 'hello') {
    const saved = localStorage.getItem('rtukit-rehand6600-units');
    mph = saved ? saved === 'mph' : m.mph;
    return;
  }
  if (m.type === 'state') return render(m);
  if (m.type === 'event') {
    if (m.event === 'horn') {
      beep();
      $('#horn-banner').classList.remove('hidden');
      setTimeout(() => $('#horn-banner').classList.add('hidden'), 1500);
    }
    if (m.event === 'view') $('#view-overlay').classList.remove('hidden');
    return;
  }
  if (m.type === 'result' && !m.ok && m.error) $('#posture-reason').textContent = m.error;
}

function showOverlay(title, detail) {
  $('#error-text').textContent = title;
  $('#error-detail').textContent = detail;
  $('#error-overlay').classList.remove('hidden');
}

function render(s) {
  state = s;
  const v = s.values;
  $('#battery').textContent = `${v.battery} %${v.charging ? ' ⚡ charging' : ''}`;
  $('#battery-fill').style.width = `${v.battery}%`;
  $('#battery-fill').classList.toggle('low', v.battery < 20);
  $('#speed').textContent = mph ? `${(v.speed * 0.621371).toFixed(1)} mph` : `${v.speed} km/h`;
  $('#motion').textContent = s.text.motion.replace(/ \(\d+\)$/, '');
  $('#lights').textContent = `${v.main_light ? 'Light on' : 'Light off'}${v.left_signal ? ' ◀' : ''}${v.right_signal ? ' ▶' : ''}`;
  $('#link').textContent = s.connected ? 'connected' : 'no connection';
  $('#charging-banner').classList.toggle('hidden', !v.charging);
  $('#clutch-banner').classList.toggle('hidden', v.clutch !== 0 || !s.connected);
  for (const b of document.querySelectorAll('#modes button')) b.classList.toggle('on', b.dataset.mode === s.drive_mode);
  for (const b of document.querySelectorAll('#levels button')) b.classList.toggle('on', Number(b.dataset.level) === s.speed_level);
  $('#light').classList.toggle('on', v.main_light === 1);
  for (const b of document.querySelectorAll('#units button')) b.classList.toggle('on', (b.dataset.unit === 'mph') === mph);
  $('#stand').classList.toggle('on', s.one_touch === 'stand');
  $('#sit').classList.toggle('on', s.one_touch === 'sit');
  // Disabled with the reason the UI rules give.
  const off = s.disabled.all;
  for (const b of all()) if (!b.closest('#phones') && !b.closest('#units')) b.disabled = !!off;
  if (!off && s.disabled.raise) {
    for (const b of document.querySelectorAll('[data-cmd="seat_lift"][data-value="up"], #stand')) b.disabled = true;
  }
  $('#posture-reason').textContent = off || s.disabled.raise || '';
  $('#drive-reason').textContent = off || '';
  // The overlay: shown while an error is active; after it clears it stays
  // until acknowledged, so nobody misses that the chair stopped.
  if (s.error) {
    showOverlay(s.error_text, s.error === 0x1010 ? 'No communication with the controller. Every function is disabled.'
                                                   : 'Every function is disabled until the error clears.');
    $('#ack').textContent = acknowledged === s.error ? 'Acknowledged: waiting for the error to clear' : 'Acknowledge';
  } else if (!$('#error-overlay').classList.contains('hidden') && acknowledged) {
    $('#error-overlay').classList.add('hidden');
  } else if (!$('#error-overlay').classList.contains('hidden')) {
    $('#error-detail').textContent = 'The error has cleared. Nothing restarts by itself.';
    $('#ack').textContent = 'Acknowledge';
  }
  // Pairing and phones.
  const code = s.pairing_code || '';
  $('#code-box').classList.toggle('hidden', !code);
  $('#pair').classList.toggle('hidden', !!code);
  $('#code').textContent = code;
  if (code && $('#qr').dataset.code !== code) {
    $('#qr').dataset.code = code;
    $('#qr').src = `/api/pair/qr.svg?c=${code}`;
  }
  if (code && codeShown !== code) {
    codeShown = code;
    codeDeadline = Date.now() + s.pairing_seconds * 1000;
  }
  if (!code) codeShown = '';
  showCodeTime();
  const list = $('#phone-list');
  list.replaceChildren(...s.phones.map((p) => {
    const row = document.createElement('div');
    row.className = `phone${p.driving ? ' driving' : ''}`;
    const name = document.createElement('span');
    name.textContent = `${p.name}${p.driving ? ' — driving' : ''}`;
    const revoke = document.createElement('button');
    revoke.textContent = 'Revoke';
    revoke.onclick = () => api.send('revoke', { client: p.client });
    row.append(name, revoke);
    return row;
  }));
}

$('#ack').onclick = () => {
  if (state && state.error) { acknowledged = state.error; $('#ack').textContent = 'Acknowledged: waiting for the error to clear'; return; }
  acknowledged = 0;
  $('#error-overlay').classList.add('hidden');
};
$('#view-close').onclick = () => $('#view-overlay').classList.add('hidden');
for (const b of document.querySelectorAll('#modes button')) b.onclick = () => api.send('set', { key: 'drive_mode', value: b.dataset.mode });
for (const b of document.querySelectorAll('#levels button')) b.onclick = () => api.send('set', { key: 'speed_level', value: Number(b.dataset.level) });
$('#light').onclick = () => api.send('pulse', { command: 'light' });
for (const b of document.querySelectorAll('#units button')) {
  b.onclick = () => {  // a display setting, kept by this browser
    mph = b.dataset.unit === 'mph';
    localStorage.setItem('rtukit-rehand6600-units', b.dataset.unit);
    if (state) render(state);
  };
}
for (const id of ['stand', 'sit']) {
  $(`#${id}`).onclick = () => api.send('one_touch', { value: state && state.one_touch === id ? 'stop' : id });
}
for (const b of document.querySelectorAll('#postures button')) {
  holdButton(b, api, () => api.send('hold', { command: b.dataset.cmd, value: b.dataset.value }).then((r) => {
    if (!r.ok) $('#posture-reason').textContent = r.error;
  }), () => api.send('release', { command: b.dataset.cmd }));
}
$('#pair').onclick = () => api.send('pair_start');
$('#pair-cancel').onclick = () => api.send('pair_cancel');
