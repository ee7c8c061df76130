// Where the scene stands in the room (WebXR): table height, where the scene's origin sits on it,
// which way it faces and how many metres one scene unit is. Scene units are not metres (the
// contact-angle dome is 0.6 units), so the scale is part of the placement. Pure: no three.js,
// no WebXR; the XR frame is the session's reference space (three.js axes: Y up, metres).
//
// A scene point p goes: scene → three axes (protocol.sceneToThree) → × scale → turned by yaw
// about Y → + (origin x, table height, origin z).

import { sceneToThree, threeToScene } from './protocol.js';

export const DEFAULT_PLACEMENT = Object.freeze({
  table_height_m: 0.75, // a desk
  origin_m: Object.freeze([0, -0.35]), // [x, z]: 35 cm in front of where the session started
  yaw_deg: 0, // 0: the scene's +x (toward its viewer) points at +Z, back toward the user
  scale_m_per_unit: 0.1, // the contact-angle dome (0.6 units) becomes 6 cm across its radius
});

// The bounds the server checks too (server/api/placement_routes.py).
export const LIMITS = Object.freeze({ table_height_m: [0, 2.5], origin_m: 5, scale_m_per_unit: [0.005, 2], yaw_deg: 360 });

const finite = (x) => typeof x === 'number' && Number.isFinite(x);

/** A placement with every field checked; throws an Error naming the first bad field. */
export function checkPlacement(p) {
  const [hLo, hHi] = LIMITS.table_height_m;
  const [sLo, sHi] = LIMITS.scale_m_per_unit;
  if (!p || typeof p !== 'object') throw new Error('placement must be an object');
  if (!finite(p.table_height_m) || p.table_height_m < hLo || p.table_height_m > hHi) {
    throw new Error(`table_height_m must be in [${hLo}, ${hHi}]`);
  }
  if (!Array.isArray(p.origin_m) || p.origin_m.length !== 2 || !p.origin_m.every((v) => finite(v) && Math.abs(v) <= LIMITS.origin_m)) {
    throw new Error(`origin_m must be [x, z] within ±${LIMITS.origin_m} m`);
  }
  if (!finite(p.yaw_deg) || Math.abs(p.yaw_deg) > LIMITS.yaw_deg) throw new Error(`yaw_deg must be within ±${LIMITS.yaw_deg}`);
  if (!finite(p.scale_m_per_unit) || p.scale_m_per_unit < sLo || p.scale_m_per_unit > sHi) {
    throw new Error(`scale_m_per_unit must be in [${sLo}, ${sHi}]`);
  }
  return { table_height_m: p.table_height_m, origin_m: [...p.origin_m], yaw_deg: p.yaw_deg, scale_m_per_unit: p.scale_m_per_unit };
}

/** The placement to use: the session's, else the rig's, else the default (each one checked; a
 * bad stored one is skipped). */
export function effectivePlacement(...candidates) {
  for (const c of candidates) {
    if (c == null) continue;
    try {
      return checkPlacement(c);
    } catch {
      // fall through to the next
    }
  }
  return checkPlacement(DEFAULT_PLACEMENT);
}

/** Position, yaw (radians) and uniform scale of the three.js group that carries the scene. */
export function placementTransform(p) {
  return { position: [p.origin_m[0], p.table_height_m, p.origin_m[1]], yaw: (p.yaw_deg * Math.PI) / 180, scale: p.scale_m_per_unit };
}

/** Scene point → XR reference space (metres). */
export function sceneToXr(pos, p) {
  const [X, Y, Z] = sceneToThree(pos).map((v) => v * p.scale_m_per_unit);
  const a = (p.yaw_deg * Math.PI) / 180;
  const c = Math.cos(a);
  const s = Math.sin(a);
  return [X * c + Z * s + p.origin_m[0], Y + p.table_height_m, -X * s + Z * c + p.origin_m[1]];
}

/** XR reference space point (metres) → scene point. */
export function xrToScene(xr, p) {
  const X0 = xr[0] - p.origin_m[0];
  const Y = xr[1] - p.table_height_m;
  const Z0 = xr[2] - p.origin_m[1];
  const a = (p.yaw_deg * Math.PI) / 180;
  const c = Math.cos(a);
  const s = Math.sin(a);
  const k = 1 / p.scale_m_per_unit;
  return threeToScene([(X0 * c - Z0 * s) * k, Y * k, (X0 * s + Z0 * c) * k]);
}

/**
 * The placement step: the fingertip rests on the table where the scene's origin should stand; the
 * table height and origin are taken from it, and the scene turns to face the head (its +x, toward
 * its viewer, points from the origin to the head, horizontally). The scale is kept.
 */
export function placementFromTouch(tipXr, headXr, scale = DEFAULT_PLACEMENT.scale_m_per_unit) {
  const dx = headXr[0] - tipXr[0];
  const dz = headXr[2] - tipXr[2];
  const yaw = Math.hypot(dx, dz) < 1e-6 ? 0 : (Math.atan2(dx, dz) * 180) / Math.PI;
  return checkPlacement({ table_height_m: tipXr[1], origin_m: [tipXr[0], tipXr[2]], yaw_deg: yaw, scale_m_per_unit: scale });
}

/** The scale that makes `sceneWidth` scene units `metres` wide (the placement step's scale
 * buttons step through the presets around it). */
export function scaleFor(sceneWidth, metres) {
  const [lo, hi] = LIMITS.scale_m_per_unit;
  return Math.min(hi, Math.max(lo, metres / sceneWidth));
}

export const SCALE_STEP = 1.25; // one press of "larger"/"smaller"

/** The scale one step larger (+1) or smaller (−1), within the limits. */
export function stepScale(scale, dir) {
  const [lo, hi] = LIMITS.scale_m_per_unit;
  return Math.min(hi, Math.max(lo, scale * SCALE_STEP ** Math.sign(dir)));
}
