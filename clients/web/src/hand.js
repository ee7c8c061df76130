// Tracked point names and how a hand is drawn from them: this client's copy of
// server/core/points.py (names follow the WebXR Hand Input joints: `right.index.tip`, plus
// `HAND.palm`), tested against tests/vectors/hand_points.json, which the Python side writes.
// The colour of each finger's tool is here too. Pure: no three.js, no DOM.

export const HANDS = ['left', 'right'];
export const FINGERS = ['thumb', 'index', 'middle', 'ring', 'pinky'];
const FINGER_JOINTS = ['metacarpal', 'proximal', 'intermediate', 'distal', 'tip'];
const THUMB_JOINTS = ['metacarpal', 'proximal', 'distal', 'tip']; // the thumb has no intermediate

/** The point a single-point tracker (the mouse) drives: the primary tool, the HIP. */
export const PRIMARY_POINT = 'right.index.tip';

export function fingerJoints(finger) {
  return finger === 'thumb' ? THUMB_JOINTS : FINGER_JOINTS;
}

/** Every point name of one hand: wrist, palm, then each finger from base to tip. */
export function handPoints(hand) {
  return [`${hand}.wrist`, `${hand}.palm`,
    ...FINGERS.flatMap((f) => fingerJoints(f).map((j) => `${hand}.${f}.${j}`))];
}

export const POINT_NAMES = HANDS.flatMap(handPoints);

/** The segments a hand is drawn with: wrist → each finger's base, then joint to joint. */
export function bones(hand) {
  return FINGERS.flatMap((f) => {
    const chain = [`${hand}.wrist`, ...fingerJoints(f).map((j) => `${hand}.${f}.${j}`)];
    return chain.slice(1).map((b, i) => [chain[i], b]);
  });
}

/** "right" of "right.index.tip"; null for a name that is not a point. */
export function handOf(name) {
  const hand = typeof name === 'string' ? name.split('.')[0] : null;
  return HANDS.includes(hand) ? hand : null;
}

// Colours by finger: the primary (the index) keeps the scene's HIP colour; the thumb is cyan, so
// two fingers on one object are told apart at a glance (the view and the console's plots).
const FINGER_COLORS = { thumb: '#35c4e8', middle: '#b57cff', ring: '#7cd992', pinky: '#ff9f43' };
const OTHER_COLOR = '#cccccc';

/** A tool's drawn colour: the scene's HIP colour for an index finger, else one per finger. */
export function toolColor(name, hipColor) {
  const finger = typeof name === 'string' ? name.split('.')[1] : null;
  if (finger === 'index') return hipColor;
  return FINGER_COLORS[finger] ?? OTHER_COLOR;
}

const isVec3 = (p) => Array.isArray(p) && p.length === 3 && p.every(Number.isFinite);

/**
 * What to draw of the hands in one state frame. `points` (state.points) holds the tracked points
 * that drive no tool; `tools` (each {name, hip}) adds the fingertips that do, so a tracked hand
 * is drawn whole. A hand is drawn only when `points` has one of its joints: a tool alone (the
 * mouse) is no hand. Bones join the joints present, bridging a missing one, so a tracker that
 * reports fewer joints (no metacarpals) still gets each finger drawn wrist to tip; with every
 * joint present they are exactly `bones(hand)`.
 * Returns {joints: [[name, [x,y,z]]], bones: [[from, to, [x,y,z], [x,y,z]]]} in the scene frame.
 */
export function handFrame(points, tools = []) {
  const given = Object.entries(points ?? {}).filter(([name, p]) => handOf(name) && isVec3(p));
  const hands = new Set(given.map(([name]) => handOf(name)));
  const at = new Map(given);
  for (const t of tools) {
    if (hands.has(handOf(t.name)) && !at.has(t.name) && isVec3(t.hip)) at.set(t.name, t.hip);
  }
  const joints = [];
  const segments = [];
  for (const hand of HANDS) {
    if (!hands.has(hand)) continue;
    for (const name of handPoints(hand)) if (at.has(name)) joints.push([name, at.get(name)]);
    for (const f of FINGERS) {
      const chain = [`${hand}.wrist`, ...fingerJoints(f).map((j) => `${hand}.${f}.${j}`)].filter((n) => at.has(n));
      for (let i = 1; i < chain.length; i++) segments.push([chain[i - 1], chain[i], at.get(chain[i - 1]), at.get(chain[i])]);
    }
  }
  return { joints, bones: segments };
}
