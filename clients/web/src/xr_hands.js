// WebXR hands (and controllers) → protocol v1.4 tracker samples, and the hand as drawn in XR.
// Pure: joint positions come in as plain arrays (XR reference space, metres); the glue
// (xr_session.js) reads them from XRFrame.getJointPose. Point names are hand.js's (the WebXR
// Hand Input joints shortened: 'index-finger-tip' of the right hand is 'right.index.tip',
// server/core/points.py point_from_webxr).

import { FINGERS, HANDS, PRIMARY_POINT, fingerJoints } from './hand.js';
import { xrToScene } from './xr_placement.js';

const WEBXR_FINGER = { thumb: 'thumb', index: 'index-finger', middle: 'middle-finger', ring: 'ring-finger', pinky: 'pinky-finger' };
const WEBXR_JOINT = { metacarpal: 'metacarpal', proximal: 'phalanx-proximal', intermediate: 'phalanx-intermediate',
  distal: 'phalanx-distal', tip: 'tip' };

/** The 25 WebXR Hand Input joint names, in the specification's order. */
export const WEBXR_JOINTS = ['wrist',
  ...FINGERS.flatMap((f) => fingerJoints(f).map((j) => `${WEBXR_FINGER[f]}-${WEBXR_JOINT[j]}`))];

const POINT_OF = new Map(FINGERS.flatMap((f) => fingerJoints(f).map((j) => [`${WEBXR_FINGER[f]}-${WEBXR_JOINT[j]}`, `${f}.${j}`])));
POINT_OF.set('wrist', 'wrist');

/** 'right', 'index-finger-tip' → 'right.index.tip'; null for a joint or hand WebXR does not define. */
export function pointFromWebxr(handedness, joint) {
  if (!HANDS.includes(handedness)) return null;
  const p = POINT_OF.get(joint);
  return p ? `${handedness}.${p}` : null;
}

export const WORKSPACE = 10; // |x|, |y|, |z| ≤ this many scene units (docs/protocol.md "Bounds")
// A headset's hand tracker runs at the display rate (72-120 Hz): a sample is good for a few
// frames; longer than that the server calls the hand lost and its tools go home.
export const HAND_TTL_MS = 100;

const inWorkspace = (p) => p.every((v) => Number.isFinite(v) && Math.abs(v) <= WORKSPACE);
const round = (v) => Math.round(v * 1e6) / 1e6; // µ-units: far below tracking noise, shorter frames

/**
 * One tracker sample of the hands seen in a frame. `hands`: {right?: {joint: [x,y,z]}, left?: …},
 * WebXR joint names, XR metres. The primary point (right.index.tip) is `pos` when the right hand's
 * index tip is seen, else the first hand's index tip is `pos` with its own `point` (it drives a
 * tool only if the rig has one on that finger; otherwise it is drawn). Points outside the
 * workspace are left out (the server would refuse the whole sample); a sample whose `pos` is
 * outside is null.
 * Returns {pos, point, points, ttl} for Connection.sendTracker, or null.
 */
export function handSample(hands, placement, { ttl = HAND_TTL_MS } = {}) {
  const points = {};
  for (const hand of HANDS) {
    for (const [joint, xr] of Object.entries(hands?.[hand] ?? {})) {
      const name = pointFromWebxr(hand, joint);
      if (!name || !Array.isArray(xr)) continue;
      const p = xrToScene(xr, placement).map(round);
      if (inWorkspace(p)) points[name] = p;
    }
  }
  const point = [PRIMARY_POINT, 'left.index.tip'].find((n) => n in points);
  if (!point) return null;
  const pos = points[point];
  delete points[point];
  return { pos, point, points, ttl };
}

/** The fallback without hand tracking: a controller's tip (the target ray's origin pushed
 * `reachM` along the ray) drives the primary point. Null outside the workspace. */
export function controllerSample(origin, direction, placement, { reachM = 0.05, ttl = HAND_TTL_MS } = {}) {
  const tip = origin.map((v, i) => v + direction[i] * reachM);
  const pos = xrToScene(tip, placement).map(round);
  return inWorkspace(pos) ? { pos, point: PRIMARY_POINT, points: {}, ttl } : null;
}

/**
 * The hand as drawn in XR (scene frame): this frame's own joints (no network delay), except that a
 * fingertip whose tool is in contact is drawn at the tool's proxy, on the surface, while the real
 * finger goes in (a visual god-object). `local`: point name → scene position (this frame);
 * `tools`: the state's tools ({name, proxy, contact, lost}); `predicted`: name → proxy guessed in
 * this frame from the client's copy of the scene (xr_predict.js), drawn where the server does not
 * (yet) say contact. Returns {points, held: [names drawn on the surface], predicted: [those of
 * them drawn at a guess]}.
 */
export function drawnHand(local, tools, predicted = {}) {
  const points = { ...local };
  const held = [];
  const guessed = [];
  for (const t of tools ?? []) {
    if (!(t.name in points)) continue;
    if (t.contact && !t.lost && Array.isArray(t.proxy)) {
      points[t.name] = t.proxy;
      held.push(t.name);
    } else if (Array.isArray(predicted[t.name])) {
      points[t.name] = predicted[t.name];
      held.push(t.name);
      guessed.push(t.name);
    }
  }
  return { points, held, predicted: guessed };
}

/** Whether a hand pinches: thumb tip and index tip closer than `closeM` (metres, XR frame). Used
 * where the emulator or the browser gives no select event for hands. */
export function pinching(joints, closeM = 0.015) {
  const a = joints?.['thumb-tip'];
  const b = joints?.['index-finger-tip'];
  return !!(a && b) && Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]) < closeM;
}
