// The phone remote. Driving is a dead-man: a direction is held only while a
// finger is down, the page visible and the socket alive; the daemon's lease
// (300 ms) stops the chair when the renewals stop coming.
'use strict';
import { connect, holdButton, $ } from '/rehand/common.js';

const KEY = 'rtukit-rehand6600-token';
let token = localStorage.getItem(KEY) || '';
let mph = false;
let api = null;

function onMessage(m) {
  if (m.type === 'hello') {
    mph = m.mph;
    $('#pairing').classList.toggle('hidden', m.paired);
    $('#remote').classList.toggle('hidden', !m.paired);
    if (!m.paired && token) { localStorage.removeItem(KEY); token = ''; $('#pair-reason').textContent = 'This phone is no longer paired.'; }
    return;
  }
  if (m.type === 'state') return render(m);
  if (m.type === 'result' && m.op === 'pair') {
    if (!m.ok) { $('#pair-reason').textContent = m.error; return; }
    token = m.token;
    localStorage.setItem(KEY, token);
    $('#pairing').classList.add('hidden');
    $('#remote').classList.remove('hidden');
    api.close();  // reconnect with the token
    return;
  }
  if (m.type === 'result' && !m.ok && m.error) $('#reason').textContent = m.error;
}

function render(s) {
  const v = s.values;
  $('#battery').textContent = `${v.battery} %`;
  $('#speed').textContent = mph ? `${(v.speed * 0.621371).toFixed(1)} mph` : `${v.speed} km/h`;
  $('#motion').textContent = s.text.motion.replace(/ \(\d+\)$/, '');
  const me = s.phones.find((p) => p.driving);
  $('#who').textContent = me ? `${me.name} is driving` : `${s.phones.length} phone(s) connected`;
  const why = s.error ? `${s.error_text}: every function is disabled` : s.disabled.drive;
  $('#reason').textContent = why || '';
  for (const b of document.querySelectorAll('#pad button')) b.disabled = !!why && !b.classList.contains('held');
  for (const b of ['#horn', '#light', '#left-signal', '#right-signal']) $(b).disabled = !!s.error;
}

api = connect(() => `role=phone&token=${encodeURIComponent(token)}`, onMessage, (up) => {
  if (!up) $('#reason').textContent = 'no connection to the chair';
});

// Opened from the display's QR code: the code is in the address.
const fromQr = new URLSearchParams(location.search).get('code');
if (fromQr) $('#pair-code').value = fromQr;
$('#pair-go').onclick = () => api.send('pair', { code: $('#pair-code').value.trim(), name: $('#pair-name').value.trim() });
for (const b of document.querySelectorAll('#pad button')) {
  holdButton(b, api, () => api.send('drive', { dir: b.dataset.dir }).then((r) => {
    if (!r.ok) $('#reason').textContent = r.error;
  }), () => api.send('drive', { dir: 'none' }));
}
holdButton($('#horn'), api, () => api.send('horn', { on: true }), () => api.send('horn', { on: false }));
$('#light').onclick = () => api.send('pulse', { command: 'light' });
$('#left-signal').onclick = () => api.send('pulse', { command: 'left_signal' });
$('#right-signal').onclick = () => api.send('pulse', { command: 'right_signal' });
