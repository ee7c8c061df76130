// The client's copy of the tracked point names and hand bones (src/hand.js) against the vector
// file the Python owner writes (tests/vectors/hand_points.json from server/core/points.py), and
// what is drawn of a hand from a state frame's points.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { HANDS, FINGERS, POINT_NAMES, PRIMARY_POINT, bones, handFrame, handOf, handPoints } from '../src/hand.js';

const VECTOR = JSON.parse(readFileSync(new URL('../../../tests/vectors/hand_points.json', import.meta.url), 'utf8'));

test('point names, hands, fingers and the primary point are the Python ones', () => {
  assert.deepEqual(HANDS, VECTOR.hands);
  assert.deepEqual(FINGERS, VECTOR.fingers);
  assert.deepEqual(POINT_NAMES, VECTOR.points);
  assert.equal(PRIMARY_POINT, VECTOR.primary);
});

test('bones are the Python bone list, hand by hand, in order', () => {
  for (const hand of HANDS) assert.deepEqual(bones(hand), VECTOR.bones[hand]);
});

test('handOf names the hand of a point and nothing else', () => {
  assert.equal(handOf('left.thumb.tip'), 'left');
  assert.equal(handOf('middle.tip'), null);
  assert.equal(handOf(3), null);
});

/** Every joint of a hand at a distinct position (x = its index), as a tracker would send. */
function wholeHand(hand) {
  return Object.fromEntries(handPoints(hand).map((n, i) => [n, [i, 0, 1]]));
}

test('a whole hand is drawn with every joint and exactly the bone list', () => {
  const frame = handFrame(wholeHand('right'));
  assert.deepEqual(frame.joints.map(([n]) => n), handPoints('right'));
  assert.deepEqual(frame.bones.map(([a, b]) => [a, b]), VECTOR.bones.right);
  const [a, b, pa, pb] = frame.bones[0];
  assert.deepEqual([pa, pb], [wholeHand('right')[a], wholeHand('right')[b]]);
});

test('the tools\' fingertips join the hand they belong to; a tool alone is no hand', () => {
  const points = wholeHand('right');
  delete points['right.index.tip'];
  delete points['right.thumb.tip'];
  const tools = [{ name: 'right.index.tip', hip: [9, 9, 9] }, { name: 'right.thumb.tip', hip: [8, 8, 8] }];
  const frame = handFrame(points, tools);
  assert.deepEqual(frame.bones.map(([a, b]) => [a, b]), VECTOR.bones.right);
  assert.deepEqual(new Map(frame.joints).get('right.index.tip'), [9, 9, 9]);
  assert.deepEqual(handFrame({}, tools), { joints: [], bones: [] }, 'the mouse alone draws no hand');
  assert.deepEqual(handFrame({ 'left.palm': [0, 0, 0] }, tools).joints.map(([n]) => n), ['left.palm'],
    'a right-hand tool does not join a left hand');
});

test('a tracker with fewer joints still gets each finger drawn wrist to tip', () => {
  // Leap-like: wrist, palm, and per finger proximal, distal and tip only
  const points = { 'right.wrist': [0, 0, 0], 'right.palm': [0, 0, 1] };
  for (const f of FINGERS) for (const j of ['proximal', 'distal', 'tip']) points[`right.${f}.${j}`] = [1, 2, 3];
  const frame = handFrame(points);
  assert.equal(frame.joints.length, 2 + 15);
  const index = frame.bones.filter(([a, b]) => a.includes('index') || b.includes('index')).map(([a, b]) => `${a}>${b}`);
  assert.deepEqual(index, ['right.wrist>right.index.proximal', 'right.index.proximal>right.index.distal',
    'right.index.distal>right.index.tip']);
});

test('names that are not points and positions that are not vectors are skipped', () => {
  const frame = handFrame({ 'right.wrist': [0, 0, 0], 'right.index.tip': [0, Number.NaN, 0], 'robot.arm': [1, 1, 1] });
  assert.deepEqual(frame.joints.map(([n]) => n), ['right.wrist']);
  assert.deepEqual(frame.bones, []);
});
