// The phone app over Bluetooth LE (docs/rehand6600-ble.md, "The phone app"):
// the Wi-Fi phone page's remote, with Web Bluetooth as its link. The press
// rules are common.js's (holdButton: press, renew every 100 ms, release; the
// chair's 300-ms lease ends a press whose renewals stop); this file only
// carries them over GATT and reads the chair's state characteristic.
//
// Pairing is the phone's own: the first read asks the OS to pair, and the
// OS asks for the passkey the chair's display shows. The page never sees a
// key, a code or a token.
'use strict';
import { $, $$, clockTime, endAllPresses, formatSpeed, holdButton, setControlEnabled } from './common.js';
import { buildChairView, showDistances } from './distances.js';
import { buildRemote, showLights } from './remote.js';
import { COMMAND_UUID, FUNCTIONS, OPS, RESULT, RESULT_UUID, SERVICE_UUID, STATE_UUID, decodeResult, decodeState,
  encodeCommand } from './gatt.js';
import { ERRORS, MOTIONS, REASONS } from './chair-text.js';

buildRemote($('#remote'), { connectAgain: true, disconnect: true });

const STALE_MS = 1000;        // the chair notifies its state at 20 Hz: a second without one is a lost link
const NOTICE_MS = 4000;       // how long a refusal stays shown over the standing reason
const RESULT_TIMEOUT_MS = 1500;
const MAX_QUEUED_WRITES = 3;  // renewals beyond this are not queued: a link that slow lets the press lapse

let device = null;            // the chair (a BluetoothDevice) once chosen
let chars = null;             // {state, command, result} while connected
let state = null;             // the last decoded state
let stateAt = 0;              // when it came (Date.now())
let connecting = false;
let userDisconnected = false;
let refusal = { text: '', at: 0 };

// ---------------------------------------------------------------- the link

// The object holdButton sends through: send(op, fields, {timeoutMs}) resolves
// with {ok, error}, as the Wi-Fi page's socket does.
let sequence = 0;
let queuedWrites = 0;
let writes = Promise.resolve();
const pending = new Map();    // sequence -> {resolve, timer}
const pressFunction = new Map();  // press id -> function byte

const link = {
  lastMessageAt: null,
  isOpen() { return !!(chars && device && device.gatt.connected); },
  send(op, fields = {}, { timeoutMs = RESULT_TIMEOUT_MS } = {}) {
    if (!link.isOpen()) return Promise.resolve({ ok: false, error: 'no connection to the chair' });
    let fn = FUNCTIONS[fields.command];
    if (op === 'press') pressFunction.set(fields.press, fn);
    if (op === 'renew' || op === 'release') fn = pressFunction.get(fields.press);
    if (op === 'release') pressFunction.delete(fields.press);
    if (!fn || !OPS[op]) return Promise.resolve({ ok: false, error: `${fields.command || op}: not a phone function` });
    if (op === 'renew' && queuedWrites >= MAX_QUEUED_WRITES) return Promise.resolve({ ok: true });
    sequence = (sequence + 1) & 0xffff;
    const seq = sequence;
    const bytes = encodeCommand({ op: OPS[op], fn, press: op === 'pulse' ? 0 : fields.press, sequence: seq });
    const answer = new Promise((resolve) => {
      const timer = setTimeout(() => { pending.delete(seq); resolve({ ok: false, error: 'no answer from the chair' }); },
        timeoutMs);
      pending.set(seq, { resolve, timer });
    });
    // One GATT operation at a time (Web Bluetooth refuses a second in flight).
    ++queuedWrites;
    const characteristic = chars.command;
    writes = writes.then(() => characteristic.writeValueWithResponse(bytes)).catch((e) => {
      settle(seq, { ok: false, error: `the chair did not take the command (${e.message})` });
    }).finally(() => { --queuedWrites; });
    return answer;
  },
};

function settle(seq, result) {
  const entry = pending.get(seq);
  if (!entry) return;
  pending.delete(seq);
  clearTimeout(entry.timer);
  entry.resolve(result);
}

function onResult(event) {
  const r = decodeResult(event.target.value);
  if (!r) return;
  link.lastMessageAt = new Date();
  const ok = r.code === RESULT.accepted;
  settle(r.sequence, { ok, error: ok ? '' : reasonWords(r.why, r.reason), ended: r.code === RESULT.ended });
}

function onState(event) {
  const s = decodeState(event.target.value);
  if (!s) return;
  state = s;
  stateAt = Date.now();
  link.lastMessageAt = new Date();
  render();
}

function linkLost(why) {
  chars = null;
  for (const seq of [...pending.keys()]) settle(seq, { ok: false, error: why });
  // Every press ends with the link (the chair stops a lost phone's drive itself).
  endAllPresses(why);
  render();
}

async function connect(chosen) {
  if (connecting) return;
  connecting = true;
  let stage = 'connect';  // then 'access': the first encrypted access, where a phone without a bond is refused
  userDisconnected = false;
  say('Connecting…');
  try {
    if (device !== chosen) {
      device = chosen;
      device.addEventListener('gattserverdisconnected', () => {
        const wasLive = chars !== null;
        linkLost('the Bluetooth link to the chair was lost');
        // A link that was live and went: the remote stays, under the red
        // "no contact" panel (nothing may look live), with Connect again.
        // Disconnect, or a connection that failed (its reason kept): the
        // connect screen.
        if (wasLive && !userDisconnected) return;
        if (userDisconnected) say('Disconnected.');
        showScreen('connect');
      });
    }
    const server = await device.gatt.connect();
    const service = await server.getPrimaryService(SERVICE_UUID);
    const found = {
      state: await service.getCharacteristic(STATE_UUID),
      command: await service.getCharacteristic(COMMAND_UUID),
      result: await service.getCharacteristic(RESULT_UUID),
    };
    // The first encrypted access: the phone's OS pairs here the first time.
    stage = 'access';
    say('If your phone asks, enter the passkey the chair\'s display shows.');
    found.result.addEventListener('characteristicvaluechanged', onResult);
    await found.result.startNotifications();
    found.state.addEventListener('characteristicvaluechanged', onState);
    await found.state.startNotifications();
    chars = found;
    onState({ target: { value: await found.state.readValue() } });
    say('');
    showScreen('remote');
  } catch (e) {
    chars = null;
    console.warn(`connecting failed at ${stage}: ${e && e.name}: ${e && e.message}`);  // for the engineer
    say(connectError(e, stage));
    if (device && device.gatt.connected) device.gatt.disconnect();
    showScreen('connect');
  } finally {
    connecting = false;
    render();
  }
}

function connectError(e, stage = 'choose') {
  const m = e && e.message ? e.message : String(e);
  // Connected, then refused at the first read or subscription: the chair
  // serves only bonded phones (the browser's words for it vary).
  if (stage === 'access' || /not authorized|authentication|insufficient|security/i.test(m)) {
    return 'The chair refused this phone: open "Pair a phone" on the chair\'s display, then connect again and ' +
      'enter the passkey it shows.';
  }
  if (e && e.name === 'NotFoundError') return 'No chair chosen.';
  return `Could not connect to the chair: ${m}`;
}

// ---------------------------------------------------------------- screens

function say(text) { $('#connect-reason').textContent = text; }

function showScreen(name) {
  for (const screen of ['connect', 'remote']) $(`#${screen}`).classList.toggle('hidden', screen !== name);
}

function isLost() { return !link.isOpen() || !state || Date.now() - stateAt > STALE_MS || !state.answers; }

// The chair's words for a reason's code (reasons.hpp, through chair-text.js),
// else the text that came (cut to fit a Bluetooth value).
const ERROR_ACTIVE = 1;
const PRESS_ENDED = 14;
function reasonWords(code, text = '') {
  if (code === PRESS_ENDED) return `this press ${REASONS[code]}`;
  if (code && code !== ERROR_ACTIVE && REASONS[code]) return REASONS[code];
  return text || 'refused';
}

function stopReason(s) {
  if (s.error) {
    const e = ERRORS[s.error.toString(16).toUpperCase().padStart(4, '0')];
    const text = e ? e.text : `error ${s.error.toString(16).toUpperCase()}`;
    const advice = e && e.advice ? `. ${e.advice[0].toUpperCase()}${e.advice.slice(1)}` : '';
    return `${text}: every function is disabled${advice}`;
  }
  // The chair's own reason first: its STOP holds the stop command too (the
  // emergency flag), and must not read as a lost phone.
  if (s.disabled.all && s.reasons.all) return reasonWords(s.reasons.all);
  if (s.emergency) return 'Stopped: a phone lost its link while driving; the chair stops and holds until still';
  if (s.disabled.all) return 'every function is disabled: see the chair\'s display';
  if (s.disabled.drive) {
    if (s.phoneDrives && !s.reasons.drive) return 'another phone is driving';
    return reasonWords(s.reasons.drive, 'driving is off: the chair must be still, seated and the joystick at rest');
  }
  return '';
}

function render() {
  const lost = isLost();
  document.body.classList.toggle('lost', lost);
  const last = link.lastMessageAt;
  $('#lost-since').textContent = last ? clockTime(last) : 'this page opened';
  $('#lost-why').textContent = !link.isOpen() ? 'This phone has no Bluetooth link to the chair.'
    : !state || Date.now() - stateAt > STALE_MS ? 'The chair\'s state stopped coming.'
      : 'The chair\'s display has no contact with its controller.';
  $('#reconnect').hidden = link.isOpen() || connecting;
  const s = state;
  $('#battery').textContent = s ? `${s.battery} %` : '--';
  $('#speed').textContent = s ? formatSpeed(s.speed, false) : '--';
  $('#motion').textContent = s ? (MOTIONS[s.motion] || String(s.motion)) : '--';
  showDistances($('#distances'), s && { front: s.distances.front, rear: s.distances.rear }, !lost);

  const allOff = lost || !!(s && (s.error || s.disabled.all));
  const driveOff = allOff || !!(s && s.disabled.drive);
  for (const b of $$('#pad button')) setControlEnabled(b, !driveOff);
  setControlEnabled($('#horn'), !allOff);
  for (const b of $$('#light, #left-signal, #right-signal')) b.disabled = allOff;
  showLights(lost || !s ? {} : { light: s.light, left: s.leftSignal, right: s.rightSignal });

  const recent = refusal.text && Date.now() - refusal.at < NOTICE_MS;
  $('#reason').textContent = lost ? '' : recent ? refusal.text : s ? stopReason(s) : '';
  $('#who').textContent = device ? `${device.name || 'Rehand 6600'} over Bluetooth` : '';
}

function showRefusal(text) {
  refusal = { text, at: Date.now() };
  render();
  setTimeout(render, NOTICE_MS + 50);
}

// ---------------------------------------------------------------- controls

for (const b of $$('#pad button')) holdButton(b, link, { command: b.dataset.cmd, value: 1, onEnded: showRefusal });
holdButton($('#horn'), link, { command: 'phone_horn', value: 1, onEnded: showRefusal });
function pulse(command) {
  link.send('pulse', { command }).then((r) => { if (!r.ok) showRefusal(r.error || `${command} refused`); });
}
$('#light').addEventListener('click', () => pulse('phone_light'));
$('#left-signal').addEventListener('click', () => pulse('phone_left_signal'));
$('#right-signal').addEventListener('click', () => pulse('phone_right_signal'));

$('#connect-go').addEventListener('click', () => {
  if (!navigator.bluetooth) {
    say('This browser has no Web Bluetooth: use Chrome on Android (or a desktop Chrome with Bluetooth).');
    return;
  }
  // A chair this page knows (chosen before, or remembered by the browser:
  // getDevices at load) connects without the chooser.
  if (device) connect(device);
  else choose();
});
// requestDevice straight from the click (it needs the user's gesture: no await before it).
function choose() {
  navigator.bluetooth.requestDevice({ filters: [{ services: [SERVICE_UUID] }] }).then(connect, (e) => say(connectError(e)));
}
$('#choose').addEventListener('click', choose);
$('#reconnect').addEventListener('click', () => { if (device) connect(device); else choose(); });
$('#disconnect').addEventListener('click', () => {
  userDisconnected = true;
  if (device && device.gatt.connected) device.gatt.disconnect();
  else linkLost('disconnected');
});
// The stale-data timer: a state that stops coming turns the page "lost"
// even while the link claims to be up.
setInterval(render, 250);

// A chair the browser remembers for this origin (Chrome's getDevices).
if (navigator.bluetooth && navigator.bluetooth.getDevices) {
  navigator.bluetooth.getDevices().then((known) => { if (!device && known.length > 0) device = known[0]; }, () => {});
}
// Installable and usable offline where the browser allows (a secure context).
if ('serviceWorker' in navigator && window.isSecureContext) {
  navigator.serviceWorker.register('app-sw.js').catch(() => { /* the app works without it, online */ });
}
buildChairView($('#distances'));
showScreen('connect');
render();
