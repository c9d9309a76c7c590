// The touch HMI (the kiosk display): renders every state message from the
// host daemon and sends the display's commands (docs/rehand6600-remote.md).
// The daemon decides (UI rules, leases, D-8); the page shows why a control is
// disabled, never retries on its own, and never shows old values as live.
'use strict';
import {
  $, $$, clockTime, connect, endAllPresses, formatSpeed, holdButton, holdTone, motionText, setControlEnabled,
} from '/rehand/common.js';
import { buildChairView, showDistances } from '/rehand/distances.js';

const UNITS_KEY = 'rtukit-rehand6600-units';  // the unit is this display's choice, kept by its browser
const NOTICE_MS = 4000;           // how long a one-off message (a refusal, Stop's answer) stays
const VIEW_CLOSE_DELAY_MS = 3000;  // the obstacle view closes this long after the obstacle went away

let state = null;           // the last state message
let stateIsFresh = false;   // that state came on the socket that is open now
let savedUnit = localStorage.getItem(UNITS_KEY);
let mph = savedUnit === 'mph';
let acknowledgedError = 0;  // the error code the user acknowledged while it was active
let codeShown = '';
let codeDeadline = 0;
let postureRefusal = { text: '', at: 0 };
let viewOpenedBy = '';      // '', 'joystick' or 'obstacle'
let viewCloseTimer = null;
let nearObstacleBefore = false;
let shownPhones = '';       // the phone list last drawn (redrawn only when it changes)

const link = connect({
  path: '/ws?role=display',
  onMessage,
  onOpen: render,
  onClose: () => { stateIsFresh = false; render(); },
});

// ---------------------------------------------------------------- messages

function onMessage(m) {
  if (m.type === 'hello') {
    if (!savedUnit && typeof m.mph === 'boolean') mph = m.mph;
    return;
  }
  if (m.type === 'state') {
    state = m;
    stateIsFresh = true;
    if (!savedUnit && typeof m.mph === 'boolean') mph = m.mph;
    render();
    return;
  }
  if (m.type === 'event') return onEvent(m);
  if (m.type === 'error' && m.error) notice(m.error, true);
}

// The joystick's horn button (0x0023, "the host reads it and executes it"):
// a horn sounds while its button is held and stops when it is let go, or
// when the chair's state stops coming (nothing sounds on a stale reading).
const horn = holdTone();
function renderHorn(s, lost) {
  const held = !lost && !!s && !!s.values && s.values.horn_button === 1;
  if (held) horn.start(); else horn.stop();
  $('#horn-banner').classList.toggle('hidden', !held);
  document.body.dataset.horn = held ? 'on' : 'off';  // for the tests: audio is not observable headless
}

function onEvent(m) {
  if (m.event === 'view') {
    openView('joystick');
  } else if (m.event === 'near_obstacle') {
    openView('obstacle');
  } else if (m.event === 'replaced') {
    // A second connection of the same phone closed the first (a new tab, a
    // reconnect, or someone with its token): the display owner should know.
    const line = `Phone ${m.name || m.phone || '?'}: a new connection replaced the old one`;
    phoneNotice(line);
    notice(line);
  } else if (m.event === 'emergency' && m.phone) {
    // A phone lost control while driving (its link, or its renewals): the
    // daemon held the controller's stop command. Say which phone and why,
    // and keep it under the phone list: the stop itself lasts a moment.
    const line = `Emergency stop: phone ${m.phone}: ${m.reason}. Nothing restarts by itself.`;
    phoneNotice(line);
    notice(line, true, true);
  } else if (m.event === 'released') {
    // A press released by the daemon (its lease lapsed, or Stop): the chair
    // stopped that motion; say so, the user presses again if they want it.
    notice(m.reason || m.error || 'A held command was released: press again to move', true);
  }
}

// ---------------------------------------------------------------- the link

function isLost() { return !link.isOpen() || !stateIsFresh || !state || !state.connected; }

// The time of the last trustworthy contact: the daemon's last_contact when it
// says the controller is gone (it knows best), else the last message this page
// got; empty when there was none.
function lastContact() {
  if (state && !state.connected && state.last_contact) return state.last_contact;
  return link.lastMessageAt ? clockTime(link.lastMessageAt) : '';
}

function renderLink(lost) {
  document.body.classList.toggle('lost', lost);
  $('#lost-since').textContent = lastContact() || 'this page opened';
  // Short: the banner is one line at 1024 px; the grey says the values are old.
  let why = '';
  let linkText = 'connected';
  if (!link.isOpen() && !link.lastMessageAt) {
    why = 'Connecting to the host program.';
    linkText = 'connecting';
  } else if (!link.isOpen()) {
    why = 'The display lost its host program.';
    linkText = 'no host';
  } else if (!stateIsFresh || !state) {
    why = 'Waiting for the chair.';
    linkText = 'connecting';
  } else if (!state.connected) {
    why = 'The controller does not answer.';
    linkText = 'no contact';
  }
  $('#lost-why').textContent = why;
  $('#link').textContent = linkText;
}

// ---------------------------------------------------------------- rendering

function render() {
  const lost = isLost();
  renderLink(lost);
  if (state) renderValues(state, lost);
  renderControls(lost);
  renderErrorOverlay(lost);
  renderHorn(state, lost);
  if (state) renderPhones(state);
  showCodeTime();
}

function renderValues(s, lost) {
  const v = s.values || {};
  $('#battery').textContent = typeof v.battery === 'number' ? `${v.battery} %${v.charging ? ' ⚡' : ''}` : '--';
  $('#battery-fill').style.width = `${Math.max(0, Math.min(100, v.battery || 0))}%`;
  $('#battery-fill').classList.toggle('low', v.battery < 20);
  $('#speed').textContent = formatSpeed(v.speed, mph);
  $('#motion').textContent = motionText(s);
  $('#lights').textContent = `${v.main_light ? 'On' : 'Off'}${v.left_signal ? ' ◀' : ''}${v.right_signal ? ' ▶' : ''}`;
  $('#charging-banner').classList.toggle('hidden', !v.charging);
  // STOP latches (the controller's stop command held): it stays on until lifted here.
  $('#stop-latched').classList.toggle('hidden', s.stop !== true);
  $('#clutch-banner').classList.toggle('hidden', v.clutch !== 0);
  for (const b of $$('#modes button')) b.classList.toggle('on', b.dataset.mode === s.drive_mode);
  for (const b of $$('#levels button')) b.classList.toggle('on', Number(b.dataset.level) === s.speed_level);
  $('#light').classList.toggle('on', v.main_light === 1);
  for (const b of $$('#units button')) b.classList.toggle('on', (b.dataset.unit === 'mph') === mph);
  renderPostures(s);
  showDistances($('#distances'), s.distances, !lost);
  showDistances($('#view-distances'), s.distances, !lost);
  // The 360 view opens by itself when an obstacle comes near (the daemon
  // decides what "near" is), and closes by itself a while after it left,
  // unless the joystick's button opened it.
  const near = s.near_obstacle === true && !lost;
  if (near) {
    clearTimeout(viewCloseTimer);
    viewCloseTimer = null;
    if (!nearObstacleBefore) openView('obstacle');
  } else if (viewOpenedBy === 'obstacle' && viewCloseTimer === null) {
    viewCloseTimer = setTimeout(closeView, VIEW_CLOSE_DELAY_MS);
  }
  nearObstacleBefore = near;
}

// Table 1's posture state, next to each posture's buttons: a badge for what
// the posture does and a bar per actuator for its position (0..1000
// per-mille); the stand row shows its progress. The badge's word and kind
// are the device layer's (postures_view: a fault first, then a motion under
// way, then a limit, else still): no rule of it lives here.
function renderPostures(s) {
  const byKey = new Map((s.postures || []).map((p) => [p.key, p]));
  for (const cell of $$('.posture-state')) {
    const key = cell.id.replace('posture-state-', '');
    showPostureState(cell, byKey.get(key), key === 'stand' ? s.stand_progress : undefined);
  }
}

function showPostureState(cell, posture, progress) {
  if (!cell.firstChild) {
    const badge = document.createElement('span');
    badge.className = 'badge';
    const bars = document.createElement('div');
    bars.className = 'bars';
    cell.append(badge, bars);
  }
  const [badge, bars] = cell.children;
  const actuators = (posture && posture.actuators) || [];
  const text = posture ? posture.badge : '--';
  const kind = posture && posture.badge_kind !== 'still' ? posture.badge_kind : '';
  badge.textContent = text;
  badge.className = `badge ${kind}`;
  cell.dataset.state = kind || (posture ? 'still' : '');

  // The stand row: its progress (0..100 %) as a bar and a number; the
  // others: one bar per actuator.
  if (typeof progress === 'number') {
    const pct = Math.round(Math.max(0, Math.min(100, progress)));
    if (!bars.classList.contains('progress-line')) {
      bars.className = 'bars progress-line';
      const bar = document.createElement('div');
      bar.className = 'position progress';
      bar.append(document.createElement('div'));
      const number = document.createElement('span');
      number.className = 'pct';
      bars.replaceChildren(bar, number);
    }
    bars.firstChild.firstChild.style.width = `${pct}%`;
    bars.lastChild.textContent = `${pct} %`;
    cell.dataset.progress = String(pct);
    return;
  }
  while (bars.children.length > actuators.length) bars.lastChild.remove();
  while (bars.children.length < actuators.length) {
    const bar = document.createElement('div');
    bar.append(document.createElement('div'));
    bars.append(bar);
  }
  actuators.forEach((a, i) => {
    const bar = bars.children[i];
    const permille = Math.max(0, Math.min(1000, Number(a.position) || 0));
    bar.className = `position${a.state === 'moving' ? ' moving' : ''}`;
    bar.firstChild.style.width = `${permille / 10}%`;
    bar.title = `actuator ${a.n}: ${permille} ‰, ${a.state}`;
  });
}

function renderControls(lost) {
  const s = state;
  const off = lost || !s || !!(s.disabled && s.disabled.all);
  const raiseOff = off || !!(s && s.disabled && s.disabled.raise);
  for (const b of $$('#modes button, #levels button, #light')) setControlEnabled(b, !off);
  for (const b of $$('#postures button')) {
    const raises = (b.dataset.cmd === 'seat_lift' && b.dataset.value === 'up') || b.id === 'stand';
    setControlEnabled(b, !(raises ? raiseOff : off));
  }
  // Pairing and forgetting phones do not move the chair: they stay usable
  // while the controller is silent, as long as the daemon hears the display.
  const daemonUp = link.isOpen() && stateIsFresh;
  for (const b of $$('#pair, #pair-cancel, #phone-list button, #confirm-yes')) b.disabled = !daemonUp;
  $('#forget-all').disabled = !daemonUp || !(s && s.phones && s.phones.length);
  // The reason shown under the postures: a fresh refusal first (it answers
  // what the user just did), else why the buttons are off.
  const recent = postureRefusal.text && Date.now() - postureRefusal.at < NOTICE_MS;
  $('#posture-reason').textContent = recent ? postureRefusal.text
    : (s && s.disabled && (s.disabled.all || s.disabled.raise)) || '';
}

// The error overlay: shown while an error is active; after it clears it stays
// until acknowledged, so nobody misses that the chair stopped (D-8: nothing
// restarts by itself). Stop stays above it and usable.
function renderErrorOverlay(lost) {
  const overlay = $('#error-overlay');
  const contact = $('#error-contact');
  contact.classList.toggle('hidden', !lost);
  contact.textContent = `No contact since ${lastContact() || 'this page opened'}. Use the joystick's own stop.`;
  const s = state;
  if (s && s.error) {
    $('#error-text').textContent = s.error_text || `${s.error.toString(16).toUpperCase()} Error`;
    // The link's own error (1010) is the one raised while the daemon has no contact.
    $('#error-detail').textContent = s.connected === false
      ? 'No communication with the controller. Every function is disabled.'
      : 'Every function is disabled until the error clears.';
    // What to check, as table 3 says (the device layer's advice, as `rtukit rehand6600 errors`).
    const advice = s.error_advice || '';
    $('#error-advice').textContent = advice ? `${advice[0].toUpperCase()}${advice.slice(1)}` : '';
    $('#ack').textContent = acknowledgedError === s.error ? 'Acknowledged: waiting for the error to clear' : 'Acknowledge';
    overlay.classList.remove('hidden');
  } else if (!overlay.classList.contains('hidden') && lost) {
    // No contact (the host gone, or its state old): nothing is known about
    // the error, so nothing may say it cleared (it once read "The error has
    // cleared" above "No contact since" after a host death).
    $('#error-detail').textContent = 'Whether the error has cleared is not known: no contact. Every function is disabled.';
    $('#error-advice').textContent = '';
  } else if (!overlay.classList.contains('hidden') && stateIsFresh) {
    if (acknowledgedError) {
      acknowledgedError = 0;
      overlay.classList.add('hidden');
    } else {
      $('#error-detail').textContent = 'The error has cleared. Nothing restarts by itself: press again to move.';
      $('#error-advice').textContent = '';
      $('#ack').textContent = 'Acknowledge';
    }
  }
}

// ---------------------------------------------------------------- phones

function renderPhones(s) {
  const code = s.pairing_code || '';
  $('#code-box').classList.toggle('hidden', !code);
  $('#pair').classList.toggle('hidden', !!code);
  $('#code').textContent = code || '------';
  if (code && $('#qr').dataset.code !== code) {
    $('#qr').dataset.code = code;
    $('#qr').src = `/api/pair/qr.svg?c=${encodeURIComponent(code)}`;
  }
  if (code && codeShown !== code) {
    codeShown = code;
    codeDeadline = Date.now() + (s.pairing_seconds || 0) * 1000;
  }
  if (!code) codeShown = '';
  showFingerprint(s.fingerprint || '');
  // A phone pairing over Bluetooth LE: the passkey BlueZ asked the display to show.
  const passkey = s.ble_passkey || '';
  $('#ble-passkey-box').classList.toggle('hidden', !passkey);
  $('#ble-passkey').textContent = passkey;
  $('#ble-passkey-for').textContent = passkey && s.ble_passkey_for ? `for “${s.ble_passkey_for}”: is it your phone?` : '';

  const phones = s.phones || [];
  const drawn = JSON.stringify(phones);
  if (drawn === shownPhones) return;
  shownPhones = drawn;
  const list = $('#phone-list');
  if (!phones.length) {
    const none = document.createElement('div');
    none.className = 'no-phones';
    none.textContent = 'No phone is paired.';
    list.replaceChildren(none);
  } else {
    list.replaceChildren(...phones.map(phoneRow));
  }
  renderControls(isLost());  // the new Forget buttons take the current enabled state
  // Who drives, where everyone at the chair sees it (the phone list's
  // 'driving' is small, in the side column).
  const driving = phones.find((p) => p.driving);
  $('#driver-banner').textContent = driving
    ? `${driving.name || driving.phone}${driving.link === 'ble' ? ' (Bluetooth)' : ''} drives the chair. STOP stops it.` : '';
  $('#driver-banner').classList.toggle('hidden', !driving);
}

function phoneRow(p) {
  const row = document.createElement('div');
  row.className = `phone${p.connected ? ' connected' : ''}${p.driving ? ' driving' : ''}`;
  row.dataset.phone = p.phone;
  const text = document.createElement('div');
  text.className = 'phone-text';
  const name = document.createElement('span');
  name.className = 'phone-name';
  // The name is the phone's own word; the code it paired with is the
  // display user's proof of which phone this is.
  const how = p.link === 'ble' ? ' (Bluetooth)' : p.paired_code ? ` (code ${p.paired_code})` : '';
  name.textContent = `${p.name || p.phone}${how}`;
  const status = document.createElement('span');
  status.className = 'phone-status';
  status.textContent = p.driving ? 'driving' : p.confirmed === false ? 'may not drive yet'
    : p.connected ? 'connected' : `last contact ${p.last_contact || 'never'}`;
  text.append(name, status);
  row.append(text);
  // a new phone drives once the person at the display, seeing its
  // name, allows it.
  if (p.confirmed === false) {
    const allow = document.createElement('button');
    allow.className = 'allow';
    allow.textContent = 'Allow to drive';
    allow.title = `Allow ${p.name || p.phone} to drive the chair`;
    allow.addEventListener('click', () => command('confirm', { phone: p.phone }));
    row.append(allow);
  }
  const forget = document.createElement('button');
  forget.textContent = 'Forget';
  forget.title = `Forget ${p.name || p.phone}: it must pair again`;
  forget.addEventListener('click', () => command('forget', { phone: p.phone }));
  row.append(forget);
  return row;
}

// "AB:CD:EF:..." (32 bytes) in groups of four bytes that wrap as a whole, so
// the user can compare it piece by piece with the phone's certificate viewer.
function showFingerprint(fingerprint) {
  const box = $('#fingerprint');
  if (box.dataset.fingerprint === fingerprint) return;
  box.dataset.fingerprint = fingerprint;
  const bytes = fingerprint.includes(':') ? fingerprint.split(':') : (fingerprint.match(/.{1,2}/g) || []);
  const groups = [];
  for (let i = 0; i < bytes.length; i += 4) {
    const group = document.createElement('span');
    group.textContent = bytes.slice(i, i + 4).join(':').toUpperCase();
    groups.push(group);
  }
  box.replaceChildren(...groups);
  $('#fingerprint-box').classList.toggle('hidden', !fingerprint);
}

function showCodeTime() {
  const left = Math.max(0, Math.round((codeDeadline - Date.now()) / 1000));
  $('#code-time').textContent = codeShown ? `valid ${Math.floor(left / 60)}:${String(left % 60).padStart(2, '0')}` : '';
}
setInterval(showCodeTime, 1000);

// ---------------------------------------------------------------- notices

// A notice that matters more (Stop's confirmation, a phone's emergency
// stop: `important`) stays its time and is not replaced by the ordinary ones
// its own effects bring (each press it ended reports "released"): they once
// overwrote STOP's confirmation with a red fragment.
let noticeTimer = null;
let importantUntil = 0;
function notice(text, bad = false, important = false) {
  if (!important && Date.now() < importantUntil) return;
  const el = $('#notice');
  el.textContent = text;
  el.classList.toggle('bad', bad);
  el.classList.remove('hidden');
  clearTimeout(noticeTimer);
  const ms = important ? 2 * NOTICE_MS : NOTICE_MS;
  importantUntil = important ? Date.now() + ms : 0;
  noticeTimer = setTimeout(() => { el.classList.add('hidden'); importantUntil = 0; }, ms);
}

// What happened to a phone's connection (a connection replaced by a new
// one): one line under the phone list, with the time, kept until the next.
function phoneNotice(text) {
  const el = $('#phone-event');
  el.textContent = `${clockTime(new Date())} ${text}`;
  el.classList.remove('hidden');
}

// A command that is not a press: its refusal is shown, nothing is retried.
function command(op, fields = {}) {
  return link.send(op, fields).then((r) => {
    if (!r.ok) notice(r.error || `${op} refused`, true);
    return r;
  });
}

// ---------------------------------------------------------------- overlays

function openView(why) {
  // The joystick's request wins: an obstacle that goes away does not close a
  // view the user asked for.
  if (why === 'joystick' || viewOpenedBy !== 'joystick') viewOpenedBy = why;
  clearTimeout(viewCloseTimer);
  viewCloseTimer = null;
  $('#view-why').textContent = viewOpenedBy === 'obstacle'
    ? 'Obstacle near the chair: this view opened by itself.'
    : 'Camera view requested by the joystick button.';
  $('#view-overlay').classList.remove('hidden');
}

function closeView() {
  clearTimeout(viewCloseTimer);
  viewCloseTimer = null;
  viewOpenedBy = '';
  $('#view-overlay').classList.add('hidden');
}

// ---------------------------------------------------------------- controls

// Stop: an emergency stop (the controller's stop command, 0x006A) that ends
// every press of every client at once (the daemon), and every press of this
// page at once (here); it stays on, refusing every press, until Lift STOP.
// Pointer-down, not click: it must act the moment it is touched. A click
// without a pointer-down (keyboard) counts too.
let stopPointerAt = 0;
function stopEverything() {
  const answer = link.send('stop', {}, { timeoutMs: 2000 });
  endAllPresses('stopped with the Stop button');
  answer.then((r) => {
    if (r.ok) notice('Stopped: every command released. Lift STOP to use the chair again', false, true);
    else if (r.type === 'result') notice(`Stop refused (${r.error}): use the joystick's own stop`, true, true);
    else if (r.unanswered) notice('Stop not confirmed: use the joystick\'s own stop', true, true);
    else notice('Stop not sent (no connection): use the joystick\'s own stop', true, true);
  });
}
$('#stop').addEventListener('pointerdown', (event) => {
  event.preventDefault();
  stopPointerAt = Date.now();
  stopEverything();
});
$('#stop').addEventListener('click', () => { if (Date.now() - stopPointerAt > 1000) stopEverything(); });
$('#stop').addEventListener('contextmenu', (event) => event.preventDefault());
$('#lift-stop').addEventListener('click', () => command('lift_stop'));

for (const b of $$('#postures button')) {
  holdButton(b, link, {
    command: b.dataset.cmd,
    value: b.dataset.value,
    onEnded: (reason) => {
      postureRefusal = { text: reason, at: Date.now() };
      render();
      setTimeout(render, NOTICE_MS + 50);  // the refusal gives way to the standing reason
    },
  });
}

for (const b of $$('#modes button')) b.addEventListener('click', () => command('set', { key: 'drive_mode', value: b.dataset.mode }));
for (const b of $$('#levels button')) b.addEventListener('click', () => command('set', { key: 'speed_level', value: Number(b.dataset.level) }));
$('#light').addEventListener('click', () => command('pulse', { command: 'light' }));
for (const b of $$('#units button')) {
  b.addEventListener('click', () => {
    mph = b.dataset.unit === 'mph';
    savedUnit = b.dataset.unit;
    localStorage.setItem(UNITS_KEY, savedUnit);
    render();
  });
}

$('#ack').addEventListener('click', () => {
  if (state && state.error) {
    acknowledgedError = state.error;
    $('#ack').textContent = 'Acknowledged: waiting for the error to clear';
    return;
  }
  acknowledgedError = 0;
  $('#error-overlay').classList.add('hidden');
});
$('#view-close').addEventListener('click', closeView);

$('#pair').addEventListener('click', () => command('pair_start'));
$('#pair-cancel').addEventListener('click', () => command('pair_cancel'));
$('#forget-all').addEventListener('click', () => $('#confirm').classList.remove('hidden'));
$('#confirm-no').addEventListener('click', () => $('#confirm').classList.add('hidden'));
$('#confirm-yes').addEventListener('click', () => {
  $('#confirm').classList.add('hidden');
  command('forget_all');
});

buildChairView($('#distances'));
buildChairView($('#view-distances'));
render();
