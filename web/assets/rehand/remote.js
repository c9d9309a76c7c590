// The remote screen, one markup for both phone pages: the Wi-Fi phone page
// (phone.html, over the daemon's TLS WebSocket) and the Bluetooth app
// (app.html, over Web Bluetooth). Each page wires its own link to the same
// elements (ids below); only what a link needs differs: the app can connect
// again and disconnect, the Wi-Fi page reconnects by itself.
//
// Static markup only (no text from the chair or the user goes through here):
// the pages fill the values in with textContent.
'use strict';

const PAD = `
  <header><div><span class="label">Battery</span><span class="value" id="battery">--</span></div>
    <div><span class="label">Speed</span><span class="value" id="speed">--</span></div>
    <div><span class="label">Motion</span><span class="value" id="motion">--</span></div></header>
  <div class="reason" id="reason" role="status"></div>
  <div id="controls">
    <div id="pad">
      <button data-cmd="phone_forward" id="fwd">▲<br>Forward</button>
      <button data-cmd="phone_left" id="left">◀<br>Left</button>
      <div id="pad-center"><svg id="distances"></svg></div>
      <button data-cmd="phone_right" id="right">▶<br>Right</button>
      <button data-cmd="phone_reverse" id="rev">▼<br>Reverse</button>
    </div>
    <div class="row"><button id="horn">Horn</button><button id="light">Light</button></div>
    <div class="row"><button id="left-signal">◀ Signal</button><button id="right-signal">Signal ▶</button></div>
    <!-- The lost link covers the controls: it must dominate, not be one line. -->
    <div id="lost" role="alert">
      <h2>No contact since <span id="lost-since">--:--:--</span></h2>
      <p class="lost-what">Use the joystick on the chair to stop.</p>
      <p id="lost-why">Connecting to the chair…</p>
      RECONNECT
    </div>
  </div>
  DISCONNECT
  <div class="foot" id="who"></div>`;

// The light and the turn signals on their buttons, as the chair reports
// them (a pulse toggles: the button says what it is now). Unknown
// (undefined): neither on nor off is claimed.
export function showLights({ light, left, right }) {
  for (const [id, on] of [['light', light], ['left-signal', left], ['right-signal', right]]) {
    const b = document.getElementById(id);
    b.classList.toggle('on', on === true);
    if (on === undefined) b.removeAttribute('aria-pressed');
    else b.setAttribute('aria-pressed', String(on));
  }
}

// Fills `screen` (the page's empty <div id="remote">) with the remote.
//   connectAgain  a "Connect again" button (#reconnect) on the lost panel
//   disconnect    a "Disconnect" button (#disconnect) under the controls
export function buildRemote(screen, { connectAgain = false, disconnect = false } = {}) {
  screen.innerHTML = PAD
    .replace('RECONNECT', connectAgain ? '<button id="reconnect">Connect again</button>' : '')
    .replace('DISCONNECT', disconnect ? '<div class="row"><button id="disconnect">Disconnect</button></div>' : '');
}
