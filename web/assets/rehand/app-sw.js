// The Bluetooth app's service worker: the app opens without a network (a
// chair outdoors, a phone without data) once it has been opened online.
// Network first, so an update is taken whenever the origin answers; the cache
// only when it does not. Only the app's own files: every other page of the
// origin (the daemon's display and Wi-Fi phone pages) goes to the network
// untouched.
'use strict';
const CACHE = 'rehand6600-app-2';
const FILES = ['app.html', 'app.js', 'app.webmanifest', 'app-icon.svg', 'gatt.js', 'chair-text.js', 'common.js',
  'distances.js', 'remote.js', 'style.css', 'phone.css'];
const mine = (url) => FILES.some((f) => url === new URL(f, self.registration.scope).href);

self.addEventListener('install', (event) => {
  event.waitUntil(caches.open(CACHE).then((c) => c.addAll(FILES)).then(() => self.skipWaiting()));
});
self.addEventListener('activate', (event) => {
  event.waitUntil(caches.keys().then((keys) => Promise.all(keys.filter((k) => k !== CACHE).map((k) => caches.delete(k))))
    .then(() => self.clients.claim()));
});
self.addEventListener('fetch', (event) => {
  const url = event.request.url.split('#')[0].split('?')[0];
  if (event.request.method !== 'GET' || !mine(url)) return;
  event.respondWith(fetch(event.request).then((response) => {
    if (response.ok) {
      const copy = response.clone();
      caches.open(CACHE).then((c) => c.put(url, copy));
    }
    return response;
  }).catch(() => caches.match(url).then((cached) => cached || Response.error())));
});
