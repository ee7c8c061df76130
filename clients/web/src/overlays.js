// Scene overlays (scene.overlays): drawn-only aids such as the contact-angle protractor and text
// labels. They never collide and are annotations, so they are drawn over the scene objects
// (no depth test) but under the HIP and proxy (scene_view gives those a later render order).
//
// Geometry is computed in the scene frame and converted with protocol.sceneToThree; the angle
// scale lies in the scene's y-z plane through its centre: angle a sits at
// centre + radius·(0, sin a, cos a), so −90 is left, 0 the top and +90 right.

import * as THREE from 'three';
import { sceneToThree } from './protocol.js';

export const RENDER_ORDER = Object.freeze({ halo: 1, stroke: 2, label: 2 });
const ANGLE_SCALE_DEFAULTS = Object.freeze({
  from_deg: -90, to_deg: 90, minor_deg: 10, major_deg: 30, color: '#1b1b1b',
});
const LABEL_DEFAULTS = Object.freeze({ size: 0.12, color: '#1b1b1b' });

// Angle-scale proportions, as fractions of its radius.
const MINOR_TICK = 0.05;
const MAJOR_TICK = 0.1;
const STROKE = 0.008;
const HALO = 0.006; // contrast outline on each side of a stroke
const LETTER = 0.085; // label letter height
const LABEL_GAP = 0.01;
const ARC_STEP_DEG = 2;
const EPS = 1e-9;

/** A label's drawn box height per unit of letter height (room for descenders and the halo). */
export const LINE_HEIGHT = 1.5;

/** The point at `dist` from `centre` at angle `deg` on the scale's arc, in three.js coordinates. */
export function arcPoint(centre, dist, deg) {
  const a = (deg * Math.PI) / 180;
  return sceneToThree([centre[0], centre[1] + dist * Math.sin(a), centre[2] + dist * Math.cos(a)]);
}

/** Multiples of `step` within [from, to], tolerant of float steps. */
function multiples(from, to, step) {
  const out = [];
  for (let k = Math.ceil(from / step - EPS); k <= Math.floor(to / step + EPS); k++) out.push(k * step);
  return out;
}

/** "-60°", "0°", "30°", "12.5°". */
export function angleText(deg) {
  const v = Math.round(deg * 10) / 10;
  return `${v === 0 ? 0 : v}°`;
}

/** Width / height of a label's box, guessed from its length (the view passes measured ones). */
export function estimateAspect(text) {
  return (0.6 * text.length + 0.5) / LINE_HEIGHT;
}

/**
 * Where an angle scale's parts go. Returns {arc: {radius, from, to}, ticks: [{deg, major, inner,
 * outer}], labels: [{deg, text, position, height}]} with points in three.js coordinates and
 * `height` the label box height in scene units. Ticks sit at multiples of minor_deg and
 * major_deg within [from_deg, to_deg] and point outward; major ones are longer and labelled.
 * A label's centre is pushed out until its box clears the major ticks, whatever its angle.
 */
export function angleScaleLayout(spec, labelAspect = estimateAspect) {
  const s = { ...ANGLE_SCALE_DEFAULTS, ...spec };
  const r = s.radius;
  const from = s.from_deg;
  const to = s.to_deg;
  const majors = multiples(from, to, s.major_deg);
  const isMajor = (d) => majors.some((m) => Math.abs(m - d) < 1e-6);
  const degs = [...new Set([...multiples(from, to, s.minor_deg), ...majors].map((d) => +d.toFixed(6)))]
    .sort((a, b) => a - b);
  const ticks = degs.map((deg) => {
    const major = isMajor(deg);
    const len = (major ? MAJOR_TICK : MINOR_TICK) * r;
    return { deg, major, inner: arcPoint(s.centre, r, deg), outer: arcPoint(s.centre, r + len, deg) };
  });
  const height = LETTER * r * LINE_HEIGHT;
  const labels = majors.map((deg) => {
    const text = angleText(deg);
    const width = height * labelAspect(text);
    const a = (deg * Math.PI) / 180;
    // Half the box's extent along the radial direction (0, sin a, cos a).
    const extent = Math.abs((width / 2) * Math.sin(a)) + Math.abs((height / 2) * Math.cos(a));
    const dist = r + (MAJOR_TICK + LABEL_GAP) * r + extent;
    return { deg, text, position: arcPoint(s.centre, dist, deg), height };
  });
  return { arc: { radius: r, from, to }, ticks, labels };
}

/** A colour that stands out against `hex`: light for dark colours, dark for light ones. */
export function haloColor(hex) {
  const c = new THREE.Color(hex); // linear
  const luminance = 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b;
  return luminance < 0.18 ? '#eeeeee' : '#141414';
}

/**
 * Flat quads (two triangles each) along three.js segments [[x,y,z], [x,y,z]] lying in a plane of
 * constant three Z, `width` wide, with square caps so a polyline's joints have no gaps.
 */
export function strokeGeometry(segments, width) {
  const h = width / 2;
  const pos = [];
  for (const [p, q] of segments) {
    const len = Math.hypot(q[0] - p[0], q[1] - p[1]) || 1;
    const dx = (q[0] - p[0]) / len;
    const dy = (q[1] - p[1]) / len;
    const corner = (pt, along, side) => [pt[0] + along * dx - side * dy, pt[1] + along * dy + side * dx, pt[2]];
    const a = corner(p, -h, -h);
    const b = corner(p, -h, h);
    const c = corner(q, h, h);
    const d = corner(q, h, -h);
    pos.push(...a, ...b, ...c, ...a, ...c, ...d);
  }
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.Float32BufferAttribute(pos, 3));
  return g;
}

function overlayMaterial(color) {
  return new THREE.MeshBasicMaterial({ color: new THREE.Color(color), side: THREE.DoubleSide,
    depthTest: false, depthWrite: false });
}

/** A camera-facing sprite of a rasterised label, `height` scene units tall, centred on `position` (three). */
function labelSprite({ texture, aspect }, height, position) {
  const sprite = new THREE.Sprite(new THREE.SpriteMaterial({ map: texture, depthTest: false, depthWrite: false,
    transparent: true }));
  sprite.scale.set(height * aspect, height, 1);
  sprite.position.fromArray(position);
  sprite.renderOrder = RENDER_ORDER.label;
  return sprite;
}

function buildAngleScale(spec, rasterise) {
  const s = { ...ANGLE_SCALE_DEFAULTS, ...spec };
  const rasters = new Map(); // rasterise each label once: measured for layout, then drawn
  const raster = (text) => {
    if (!rasters.has(text)) rasters.set(text, rasterise(text, s.color, haloColor(s.color)));
    return rasters.get(text);
  };
  const layout = angleScaleLayout(s, (text) => raster(text).aspect);
  const { radius, from, to } = layout.arc;
  const segments = [];
  const steps = Math.max(1, Math.ceil((to - from) / ARC_STEP_DEG));
  for (let i = 0; i < steps; i++) {
    const a = from + ((to - from) * i) / steps;
    const b = from + ((to - from) * (i + 1)) / steps;
    segments.push([arcPoint(s.centre, radius, a), arcPoint(s.centre, radius, b)]);
  }
  for (const t of layout.ticks) segments.push([t.inner, t.outer]);

  const group = new THREE.Group();
  const width = STROKE * radius;
  const halo = new THREE.Mesh(strokeGeometry(segments, width + 2 * HALO * radius), overlayMaterial(haloColor(s.color)));
  halo.renderOrder = RENDER_ORDER.halo;
  const stroke = new THREE.Mesh(strokeGeometry(segments, width), overlayMaterial(s.color));
  stroke.renderOrder = RENDER_ORDER.stroke;
  group.add(halo, stroke);
  for (const l of layout.labels) group.add(labelSprite(raster(l.text), l.height, l.position));
  group.userData.labels = layout.labels.map((l) => ({ text: l.text, position: l.position }));
  return group;
}

function buildLabel(spec, rasterise) {
  const s = { ...LABEL_DEFAULTS, ...spec };
  const group = new THREE.Group();
  const raster = rasterise(s.text, s.color, haloColor(s.color));
  const position = sceneToThree(s.pos);
  group.add(labelSprite(raster, s.size * LINE_HEIGHT, position));
  group.userData.labels = [{ text: s.text, position }];
  return group;
}

/**
 * The three.js object of one overlay, or null for a kind this client does not know (a newer
 * server may send some). `rasterise(text, color, halo)` → {texture, aspect} draws label text;
 * the browser uses canvasText, tests inject a fake.
 */
export function buildOverlay(spec, rasterise = canvasText) {
  switch (spec.kind) {
    case 'angle_scale': return buildAngleScale(spec, rasterise);
    case 'label': return buildLabel(spec, rasterise);
    default: return null;
  }
}

const FONT_PX = 64;

/** Text drawn into a canvas texture: `color` letters with a `halo` outline, centred. */
function canvasText(text, color, halo) {
  const canvas = document.createElement('canvas');
  const font = `600 ${FONT_PX}px system-ui, -apple-system, "Segoe UI", sans-serif`;
  const g = canvas.getContext('2d');
  g.font = font;
  const outline = FONT_PX * 0.16;
  canvas.width = Math.ceil(g.measureText(text).width + 2 * outline + FONT_PX * 0.2);
  canvas.height = Math.ceil(FONT_PX * LINE_HEIGHT);
  g.font = font; // resizing the canvas reset the context's state
  g.textAlign = 'center';
  g.textBaseline = 'middle';
  g.lineJoin = 'round';
  g.lineWidth = 2 * outline;
  g.strokeStyle = halo;
  g.strokeText(text, canvas.width / 2, canvas.height / 2);
  g.fillStyle = color;
  g.fillText(text, canvas.width / 2, canvas.height / 2);
  const texture = new THREE.CanvasTexture(canvas);
  texture.colorSpace = THREE.SRGBColorSpace;
  return { texture, aspect: canvas.width / canvas.height };
}
