// The Rehand 6600's Bluetooth LE service as bytes, for the phone app
// (docs/rehand6600-ble.md, "The service"; the C++ side is
// devices/rehand6600/include/rtukit/devices/rehand6600/ble_gatt.hpp, and
// WebAppText.GattJsSpeaksBleGattHpp checks that the two agree). Pure: no Web Bluetooth.
'use strict';

export const SERVICE_UUID = '7e6a6600-0001-4b1e-9c3d-52e4a8f0c6a1';
export const STATE_UUID = '7e6a6600-0002-4b1e-9c3d-52e4a8f0c6a1';    // read, notify
export const COMMAND_UUID = '7e6a6600-0003-4b1e-9c3d-52e4a8f0c6a1';  // write with response
export const RESULT_UUID = '7e6a6600-0004-4b1e-9c3d-52e4a8f0c6a1';   // read, notify

const VERSION = 1;         // commands and the state
const RESULT_VERSION = 2;  // results: byte 4 is the reason's code (ble_gatt.hpp)
export const OPS = { press: 1, renew: 2, release: 3, pulse: 4 };
// The phone's functions by the register key the Wi-Fi page sends (table 2).
export const FUNCTIONS = {
  phone_forward: 1, phone_reverse: 2, phone_left: 3, phone_right: 4, phone_horn: 5,
  phone_left_signal: 6, phone_right_signal: 7, phone_light: 8,
};
// A result's code.
export const RESULT = { accepted: 0, refused: 1, invalid: 2, ended: 3 };

// The 10-byte command: version, op, function, value, press id (u32), sequence (u16).
export function encodeCommand({ op, fn, press = 0, sequence }) {
  const bytes = new Uint8Array(10);
  const view = new DataView(bytes.buffer);
  bytes[0] = VERSION;
  bytes[1] = op;
  bytes[2] = fn;
  bytes[3] = 1;
  view.setUint32(4, press >>> 0, true);
  view.setUint16(8, sequence & 0xffff, true);
  return bytes;
}

// The 20-byte state (a DataView), or null when it is not one this page reads.
// Bytes 18 and 19 are the reasons' codes (REASONS in chair-text.js): 0 none.
export function decodeState(view) {
  if (view.byteLength < 18 || view.getUint8(0) !== VERSION) return null;
  const flags = view.getUint8(1);
  const disabled = view.getUint8(12);
  return {
    answers: !!(flags & 1),          // clear: error 1010, no contact with the controller
    charging: !!(flags & 2),
    clutchDrive: !!(flags & 4),
    light: !!(flags & 8),
    leftSignal: !!(flags & 16),
    rightSignal: !!(flags & 32),
    phoneDrives: !!(flags & 64),
    emergency: !!(flags & 128),
    battery: view.getUint8(2),
    speed: view.getUint8(3),
    motion: view.getUint8(4),
    postures: [5, 6, 7, 8, 9].map((i) => view.getUint8(i)),
    error: view.getUint16(10, true),
    disabled: { all: !!(disabled & 1), drive: !!(disabled & 2), raise: !!(disabled & 4) },
    distances: { front: view.getUint16(13, true), rear: view.getUint16(15, true) },
    counter: view.getUint8(17),
    reasons: view.byteLength >= 20 ? { all: view.getUint8(18), drive: view.getUint8(19) } : { all: 0, drive: 0 },
  };
}

// A result: {sequence, code, why (the reason's code), reason (its text, cut to fit)}, or null.
export function decodeResult(view) {
  if (view.byteLength < 5 || view.getUint8(0) !== RESULT_VERSION) return null;
  const reason = new TextDecoder().decode(new Uint8Array(view.buffer, view.byteOffset + 5, view.byteLength - 5));
  return { sequence: view.getUint16(1, true), code: view.getUint8(3), why: view.getUint8(4), reason };
}
