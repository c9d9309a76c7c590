// The phone remote (docs/rehand6600-remote.md). No credential ever goes in a
// URL, and none is stored: the page opens /ws, the daemon's hello carries a
// challenge, and the page answers by signing it with this phone's key
// (phone-key.js: made at pairing, not extractable), or pairs on that same
// socket with the display's code and a new key. Driving is a dead-man: a direction is pressed only
// while a finger is down, the page visible and the socket alive; the daemon's
// 300-ms lease stops the chair when the renewals stop coming.
'use strict';
import { $, $$, clockTime, connect, formatSpeed, holdButton, motionText, setControlEnabled } from '/rehand/common.js';
import { buildChairView, showDistances } from '/rehand/distances.js';
import { buildRemote, showLights } from '/rehand/remote.js';
import { forgetIdentity, loadIdentity, newKeys, publicKeyText, saveIdentity, signChallenge } from '/rehand/phone-key.js';

buildRemote($('#remote'));

// Pages before 2026-11-29 kept a permanent token here, which one clicked-through
// certificate warning could hand to a phishing page. It opens nothing now: removed.
localStorage.removeItem('rtukit-rehand6600-token');
const REPLACED_REASON = 'replaced by a new connection';  // the daemon's close reason
const NOTICE_MS = 4000;  // how long a refusal stays shown over the standing reason
const PAIR_RETRY_MS = 1000;  // before a pairing whose socket did not open tries a new one

let identity = null;               // { phone, name, keys } once paired (IndexedDB)
let me = { phone: '', name: '' };  // this phone, as the daemon names it
let authenticated = false;         // the open socket is authenticated (auth or pair answered ok)
let replaced = false;              // another page of this phone took over: stay closed
let pendingPair = null;            // { code, name, retried, keys } to send once the hello came
let challenge = '';                // the open socket's, from the daemon's hello
let state = null;
let stateIsFresh = false;          // the state came on the socket that is open now
let mph = false;
let refusal = { text: '', at: 0 };

const link = connect({
  path: '/ws',
  onOpen,
  onMessage,
  onClose,
  // Unpaired there is nothing to reconnect for: the pairing form opens a
  // socket when the user asks to pair. A replaced page stays closed.
  shouldReconnect: () => !!identity && !replaced,
  autoOpen: false,  // once the key is read (loadIdentity, below)
});

// ---------------------------------------------------------------- the socket

function onOpen() {
  authenticated = false;
  challenge = '';
  render();
}

// The daemon's first message: this connection's challenge. The answer is a
// pairing (asked for) or a signature of it (paired).
function onHello(hello) {
  if (typeof hello.challenge !== 'string') return;
  challenge = hello.challenge;
  if (pendingPair) sendPair(hello.challenge);
  else if (identity) sendAuth(hello.challenge);
}

// A refusal is the daemon's own answer; a local failure (socket closed before
// the answer) is not, and must not cost the phone its pairing.
const refusedByDaemon = (r) => r.type === 'result' && !r.ok;

async function sendAuth(challenge) {
  let signature;
  try {
    signature = await signChallenge(identity.keys, challenge);
  } catch {
    forgetPairing('This phone\'s key for the chair is gone (the browser\'s storage was cleared?). Pair it again with a new code from the display.');
    return;
  }
  link.send('auth', { phone: identity.phone, signature }).then((r) => {
    if (r.ok) {
      authenticated = true;
      me = { phone: r.phone || '', name: r.name || '' };
      showScreen('remote');
      render();
    } else if (refusedByDaemon(r) && /not paired/i.test(r.error || '')) {
      forgetPairing(`This phone is no longer paired (${r.error}). Pair it again with a new code from the display.`);
    } else if (refusedByDaemon(r)) {
      showRefusal(r.error || 'refused');  // too many tries from this network: the key stays
    }
  });
}

async function sendPair(challenge) {
  const request = pendingPair;
  pendingPair = null;
  $('#pair-go').disabled = true;
  $('#pair-reason').textContent = 'Pairing…';
  let keys, key, signature;
  try {
    keys = request.keys || await newKeys();
    key = await publicKeyText(keys);
    signature = await signChallenge(keys, challenge);
  } catch {
    $('#pair-go').disabled = false;
    $('#pair-reason').textContent = 'This browser cannot make a key (WebCrypto): open the page over https in a current browser.';
    return;
  }
  link.send('pair', { code: request.code, name: request.name, key, signature }).then(async (r) => {
    $('#pair-go').disabled = false;
    if (r.ok && r.phone) {
      identity = { phone: r.phone, name: r.name || request.name, keys };
      try { await saveIdentity(identity); } catch { /* kept for this page only: pair again after a reload */ }
      authenticated = true;  // this same socket now commands the chair
      me = { phone: r.phone || '', name: r.name || request.name };
      $('#pair-reason').textContent = '';
      showScreen('remote');
      render();
    } else if (!refusedByDaemon(r) && !request.retried) {
      // The socket closed under the request (the daemon closes a socket
      // that has not authenticated within 5 s): once more on a new one.
      pendingPair = { ...request, keys, retried: true };
      link.reopen();
    } else {
      $('#pair-reason').textContent = r.error || 'Pairing refused.';
    }
  });
}

function onClose(event) {
  authenticated = false;
  stateIsFresh = false;
  // A pairing asked for on a socket that never opened (the daemon busy, the
  // Wi-Fi gone): once more on a new socket, then a reason; never silence.
  if (pendingPair) {
    if (!pendingPair.retried) {
      pendingPair = { ...pendingPair, retried: true };
      setTimeout(() => link.reopen(), PAIR_RETRY_MS);
    } else {
      pendingPair = null;
      $('#pair-go').disabled = false;
      $('#pair-reason').textContent = 'Could not reach the chair\'s display: check the Wi-Fi and tap Pair again.';
    }
  }
  if (event.reason === REPLACED_REASON) becomeReplaced();
  else if (identity && /not paired|forgotten|expired/i.test(event.reason || '')) {
    forgetPairing(`This phone is no longer paired (${event.reason}). Pair it again with a new code from the display.`);
  }
  render();
}

function forgetPairing(why) {
  identity = null;
  forgetIdentity();
  authenticated = false;
  state = null;
  stateIsFresh = false;
  $('#pair-reason').textContent = why;
  showScreen('pairing');
}

function becomeReplaced() {
  replaced = true;
  showScreen('replaced');
}

function onMessage(m) {
  if (typeof m.mph === 'boolean') mph = m.mph;  // the daemon's --mph, if it says
  if (m.type === 'hello') onHello(m);
  else if (m.type === 'state') {
    state = m;
    stateIsFresh = true;
    render();
  } else if (m.type === 'event') {
    // This page's own replacement comes as the close's reason
    // (REPLACED_REASON); the daemon's "replaced" events are the display's.
    if (m.event === 'released') {
      showRefusal(m.reason || m.error || 'released: lift the finger and press again');
    }
  } else if (m.type === 'error' && m.error) {
    showRefusal(m.error);
  }
}

// ---------------------------------------------------------------- rendering

function showScreen(name) {
  for (const screen of ['pairing', 'replaced', 'remote']) $(`#${screen}`).classList.toggle('hidden', screen !== name);
}

function isLost() { return !link.isOpen() || !authenticated || !stateIsFresh || !state || !state.connected; }

function lastContact() {
  if (state && !state.connected && state.last_contact) return state.last_contact;
  return link.lastMessageAt ? clockTime(link.lastMessageAt) : '';
}

function render() {
  const lost = isLost();
  document.body.classList.toggle('lost', lost);
  $('#lost-since').textContent = lastContact() || 'this page opened';
  const everConnected = link.lastMessageAt !== null;
  $('#lost-why').textContent = !link.isOpen() && everConnected ? 'This phone has no connection to the chair. Reconnecting…'
    : !link.isOpen() || !authenticated ? 'Connecting to the chair…'
      : !stateIsFresh || !state ? 'Waiting for the chair…'
        : 'The chair\'s display has no contact with its controller.';

  const s = state;
  const v = (s && s.values) || {};
  $('#battery').textContent = typeof v.battery === 'number' ? `${v.battery} %` : '--';
  $('#speed').textContent = formatSpeed(v.speed, mph);
  $('#motion').textContent = s ? motionText(s) : '--';
  showDistances($('#distances'), s && s.distances, !lost);

  const disabled = (s && s.disabled) || {};
  const errorOn = !!(s && s.error);
  const allOff = lost || errorOn || !!disabled.all;
  const driveOff = allOff || !!disabled.drive;
  for (const b of $$('#pad button')) setControlEnabled(b, !driveOff);
  setControlEnabled($('#horn'), !allOff);
  for (const b of $$('#light, #left-signal, #right-signal')) b.disabled = allOff;
  showLights(lost ? {} : { light: v.main_light === 1, left: v.left_signal === 1, right: v.right_signal === 1 });

  // The reason: an error first, then a fresh refusal of what the user just
  // did, then why driving is off. Empty when the phone may drive.
  const recent = refusal.text && Date.now() - refusal.at < NOTICE_MS;
  $('#reason').textContent = lost ? ''
    : errorOn ? `${s.error_text}: every function is disabled`
      : recent ? refusal.text
        : disabled.drive || '';

  const driving = s && s.driver ? (s.driver === me.phone ? 'you are driving' : 'another phone is driving') : '';
  $('#who').textContent = [me.name && `Paired as ${me.name}`, driving].filter(Boolean).join(' · ');
}

function showRefusal(text) {
  refusal = { text, at: Date.now() };
  render();
  setTimeout(render, NOTICE_MS + 50);  // then the standing reason again
}

// ---------------------------------------------------------------- controls

for (const b of $$('#pad button')) holdButton(b, link, { command: b.dataset.cmd, value: 1, onEnded: showRefusal });
holdButton($('#horn'), link, { command: 'phone_horn', value: 1, onEnded: showRefusal });

function pulse(command) {
  link.send('pulse', { command }).then((r) => { if (refusedByDaemon(r)) showRefusal(r.error || `${command} refused`); });
}
$('#light').addEventListener('click', () => pulse('phone_light'));
$('#left-signal').addEventListener('click', () => pulse('phone_left_signal'));
$('#right-signal').addEventListener('click', () => pulse('phone_right_signal'));

$('#pair-go').addEventListener('click', () => {
  const code = $('#pair-code').value.replace(/\D/g, '');
  if (!/^\d{6}$/.test(code)) {
    $('#pair-reason').textContent = 'Enter the 6 digits the display shows.';
    return;
  }
  pendingPair = { code, name: $('#pair-name').value.trim() || 'Phone', retried: false };
  if (link.isOpen() && !authenticated && challenge) sendPair(challenge);
  else {
    $('#pair-go').disabled = true;
    $('#pair-reason').textContent = 'Pairing…';
    link.reopen();  // onOpen sends it as the socket's first message
  }
});

$('#reconnect').addEventListener('click', () => {
  replaced = false;
  showScreen(identity ? 'remote' : 'pairing');
  link.reopen();
});

// Opened from the display's QR code: the one-time code and the certificate's
// fingerprint are in the address's fragment, which the browser never sends
// to a server. Read once, then removed from the address bar and history.
function readFragment() {
  if (!location.hash) return;
  const fromQr = new URLSearchParams(location.hash.slice(1));
  const codeFromQr = fromQr.get('code');
  if (codeFromQr) $('#pair-code').value = codeFromQr.replace(/\D/g, '').slice(0, 6);
  const fingerprintFromQr = fromQr.get('fp');
  if (fingerprintFromQr && $('#pair-fingerprint')) {
    $('#pair-fingerprint').textContent =
      `The display's certificate is SHA-256 ${fingerprintFromQr}: compare it with your browser's (the padlock).`;
  }
  history.replaceState(null, '', location.pathname);
}
readFragment();
// Scanned again while the page is open: only the fragment changes.
window.addEventListener('hashchange', readFragment);

buildChairView($('#distances'));
showScreen('pairing');
render();
loadIdentity().then((found) => {
  identity = found;
  if (identity) me = { phone: identity.phone, name: identity.name };
  showScreen(identity ? 'remote' : 'pairing');
  if (identity) link.reopen();  // the hello's challenge is signed in onHello
  render();
});
