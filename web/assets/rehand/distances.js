// The chair seen from above, with its four ultrasonic sensors' distances
// (table 1, 0x0006..0x0009, in mm) as coloured zones around it. Built as
// inline SVG by the page itself: no image file, nothing a CSP could refuse.
'use strict';

const SVG = 'http://www.w3.org/2000/svg';

// Colour thresholds (mm). The daemon's near_obstacle (500 mm while moving)
// decides when the 360-degree view opens; these only colour the zones.
export const DANGER_MM = 300;
export const CAUTION_MM = 800;

// viewBox 0 0 260 320, front up. The zones frame the chair's outline
// (x 84..176, y 88..232) and leave a gap at the corners so four colours
// never run together.
// x, y: where the number is written, its unit under it.
const ZONES = [
  { side: 'front', points: '22,8 238,8 176,84 84,84', x: 130, y: 38 },
  { side: 'rear', points: '84,236 176,236 238,312 22,312', x: 130, y: 266 },
  { side: 'left', points: '8,22 80,92 80,228 8,298', x: 44, y: 148 },
  { side: 'right', points: '252,22 180,92 180,228 252,298', x: 216, y: 148 },
];

function svgElement(name, attributes = {}, parent = null) {
  const el = document.createElementNS(SVG, name);
  for (const [key, value] of Object.entries(attributes)) el.setAttribute(key, String(value));
  if (parent) parent.append(el);
  return el;
}

// Fills an empty <svg> with the chair and the four zones (once).
export function buildChairView(svg) {
  svg.setAttribute('viewBox', '0 0 260 320');
  svg.setAttribute('role', 'img');
  svg.setAttribute('aria-label', 'Distances around the chair, seen from above, front up');
  svg.classList.add('chair-view');
  for (const zone of ZONES) {
    const group = svgElement('g', { class: 'zone unknown', 'data-side': zone.side }, svg);
    svgElement('polygon', { points: zone.points }, group);
    const value = svgElement('text', { x: zone.x, y: zone.y, class: 'zone-value' }, group);
    value.textContent = '--';
    const unit = svgElement('text', { x: zone.x, y: zone.y + 27, class: 'zone-unit' }, group);
    unit.textContent = 'cm';
  }
  // The chair: seat, backrest (rear), drive wheels, footplate (front).
  const chair = svgElement('g', { class: 'chair' }, svg);
  svgElement('rect', { x: 92, y: 136, width: 10, height: 64, rx: 3, class: 'wheel' }, chair);
  svgElement('rect', { x: 158, y: 136, width: 10, height: 64, rx: 3, class: 'wheel' }, chair);
  svgElement('rect', { x: 104, y: 118, width: 52, height: 90, rx: 8, class: 'seat' }, chair);
  svgElement('rect', { x: 104, y: 208, width: 52, height: 14, rx: 4, class: 'back' }, chair);
  svgElement('rect', { x: 112, y: 96, width: 36, height: 14, rx: 3, class: 'foot' }, chair);
  svgElement('path', { d: 'M130,130 l12,16 h-24 z', class: 'front-mark' }, chair);
}

export function distanceLevel(mm) {
  if (typeof mm !== 'number' || !Number.isFinite(mm)) return 'unknown';
  if (mm < DANGER_MM) return 'danger';
  if (mm < CAUTION_MM) return 'caution';
  return 'clear';
}

// Shows distances {front, rear, left, right} (mm, written in cm). `live`
// false greys every zone: a stale distance must not look like a safe one.
export function showDistances(svg, distances, live) {
  svg.classList.toggle('stale', !live);
  for (const group of svg.querySelectorAll('.zone')) {
    const mm = distances ? distances[group.dataset.side] : undefined;
    const level = distanceLevel(mm);
    group.setAttribute('class', `zone ${level}`);
    group.dataset.mm = level === 'unknown' ? '' : String(mm);
    const [value] = group.getElementsByClassName('zone-value');
    // In cm: at most four digits (65535 mm), which fit a side zone at a size
    // read at arm's length (16 px on the board's 1024x600 panel, issue 37).
    value.textContent = level === 'unknown' ? '--' : String(Math.round(mm / 10));
  }
}
