// This phone's key for the chair (docs/rehand6600-remote.md, "How a phone
// proves it is paired"). At pairing the page makes an ECDSA P-256 key pair
// whose private half cannot be exported: the browser keeps it for this
// origin, in IndexedDB, and only signs with it. The daemon keeps the public
// half. On each connection the daemon sends a new challenge and the page
// signs it; nothing the page sends can be replayed on another connection,
// and nothing stored here can be read out and used elsewhere.
'use strict';

const DB_NAME = 'rtukit-rehand6600';
const STORE = 'identity';
const RECORD = 'phone';
// The daemon's prefix (challenge_message in rehand_host.cpp): a signature
// made for the chair means nothing anywhere else.
const SIGNED_PREFIX = 'rtukit-rehand6600-phone:';

function base64url(bytes) {
  let text = '';
  for (const b of new Uint8Array(bytes)) text += String.fromCharCode(b);
  return btoa(text).replace(/\+/g, '-').replace(/\//g, '_').replace(/=+$/, '');
}

function withStore(mode, work) {
  return new Promise((resolve, reject) => {
    const open = indexedDB.open(DB_NAME, 1);
    open.onupgradeneeded = () => open.result.createObjectStore(STORE);
    open.onerror = () => reject(open.error);
    open.onsuccess = () => {
      const db = open.result;
      const tx = db.transaction(STORE, mode);
      const request = work(tx.objectStore(STORE));
      tx.oncomplete = () => { db.close(); resolve(request && request.result); };
      tx.onerror = () => { db.close(); reject(tx.error); };
    };
  });
}

// { phone, name, keys } of a paired phone, or null (never paired, or the
// browser's storage was cleared: pair again).
export async function loadIdentity() {
  try {
    const found = await withStore('readonly', (store) => store.get(RECORD));
    return found && found.phone && found.keys ? found : null;
  } catch {
    return null;
  }
}

export async function saveIdentity(identity) {
  await withStore('readwrite', (store) => store.put(identity, RECORD));
}

export async function forgetIdentity() {
  try { await withStore('readwrite', (store) => store.delete(RECORD)); } catch { /* nothing stored */ }
}

// A new key pair; the private key is not extractable.
export async function newKeys() {
  return crypto.subtle.generateKey({ name: 'ECDSA', namedCurve: 'P-256' }, false, ['sign', 'verify']);
}

// The public key as the daemon takes it: the raw point, base64url.
export async function publicKeyText(keys) {
  return base64url(await crypto.subtle.exportKey('raw', keys.publicKey));
}

// The challenge of this connection, signed (r||s, base64url).
export async function signChallenge(keys, challenge) {
  const data = new TextEncoder().encode(SIGNED_PREFIX + challenge);
  return base64url(await crypto.subtle.sign({ name: 'ECDSA', hash: 'SHA-256' }, keys.privateKey, data));
}
