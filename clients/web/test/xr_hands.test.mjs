import { test } from 'node:test';
import assert from 'node:assert/strict';
import { WEBXR_JOINTS, pointFromWebxr, handSample, controllerSample, drawnHand, pinching } from '../src/xr_hands.js';
import { handPoints } from '../src/hand.js';
import { sceneToXr } from '../src/xr_placement.js';

const placement = { table_height_m: 0.8, origin_m: [0, -0.4], yaw_deg: 20, scale_m_per_unit: 0.1 };

test('25 WebXR joints, each a point of hand.js (every point but the palm)', () => {
  assert.equal(WEBXR_JOINTS.length, 25);
  assert.equal(new Set(WEBXR_JOINTS).size, 25);
  const names = WEBXR_JOINTS.map((j) => pointFromWebxr('right', j));
  assert.deepEqual(new Set(names), new Set(handPoints('right').filter((n) => n !== 'right.palm')));
  assert.equal(pointFromWebxr('right', 'index-finger-tip'), 'right.index.tip');
  assert.equal(pointFromWebxr('left', 'thumb-phalanx-distal'), 'left.thumb.distal');
  assert.equal(pointFromWebxr('right', 'thumb-phalanx-intermediate'), null, 'the thumb has no intermediate');
  assert.equal(pointFromWebxr('none', 'wrist'), null);
});

test('a hand becomes one v1.4 sample: the right index tip is pos, the rest points, with a ttl', () => {
  const joints = {};
  WEBXR_JOINTS.forEach((j, i) => { joints[j] = sceneToXr([0.01 * i, 0.2, 0.5 + 0.01 * i], placement); });
  const s = handSample({ right: joints }, placement, { ttl: 80 });
  assert.equal(s.point, 'right.index.tip');
  assert.equal(s.ttl, 80);
  const k = WEBXR_JOINTS.indexOf('index-finger-tip');
  s.pos.forEach((v, i) => assert.ok(Math.abs(v - [0.01 * k, 0.2, 0.5 + 0.01 * k][i]) < 1e-6));
  assert.equal(Object.keys(s.points).length, 24);
  assert.ok(!('right.index.tip' in s.points));
});

test('points outside the workspace are left out; a pos outside means no sample', () => {
  const far = sceneToXr([0, 11, 0], placement);
  const s = handSample({ right: { 'index-finger-tip': sceneToXr([0, 0, 1], placement), wrist: far } }, placement);
  assert.deepEqual(Object.keys(s.points), []);
  assert.equal(handSample({ right: { 'index-finger-tip': far } }, placement), null);
  assert.equal(handSample({}, placement), null);
  const left = handSample({ left: { 'index-finger-tip': sceneToXr([0, 0, 1], placement) } }, placement);
  assert.equal(left.point, 'left.index.tip');
});

test('controller fallback: the tip ahead of the ray drives the primary point', () => {
  const origin = sceneToXr([0, 0, 1], placement);
  const s = controllerSample(origin, [0, -1, 0], placement, { reachM: 0.05 });
  assert.equal(s.point, 'right.index.tip');
  assert.ok(Math.abs(s.pos[2] - 0.5) < 1e-6, 'five cm down is half a unit at 0.1 m per unit');
});

test('visual god-object: a tip in contact is drawn at its proxy, others where they are', () => {
  const local = { 'right.index.tip': [0, 0, 0.55], 'right.thumb.tip': [0, -0.2, 0.8] };
  const tools = [{ name: 'right.index.tip', proxy: [0, 0, 0.66], contact: true, lost: false },
    { name: 'right.thumb.tip', proxy: [0, -0.2, 0.7], contact: false, lost: false }];
  const d = drawnHand(local, tools);
  assert.deepEqual(d.points['right.index.tip'], [0, 0, 0.66]);
  assert.deepEqual(d.points['right.thumb.tip'], [0, -0.2, 0.8]);
  assert.deepEqual(d.held, ['right.index.tip']);
  assert.deepEqual(drawnHand(local, [{ ...tools[0], lost: true }]).held, []);
});

test('pinch: thumb and index tips close together', () => {
  assert.ok(pinching({ 'thumb-tip': [0, 0, 0], 'index-finger-tip': [0.01, 0, 0] }));
  assert.ok(!pinching({ 'thumb-tip': [0, 0, 0], 'index-finger-tip': [0.05, 0, 0] }));
  assert.ok(!pinching({}));
});
