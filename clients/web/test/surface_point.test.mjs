// The client's primitive geometry (src/surface_point.js) against the server's own
// (tests/vectors/surface_points.json, written from server/core/haptics/primitives.py), and the
// proxy the XR client predicts from it.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { PRIMITIVES, body, closestPoint, evalBody, predictProxy, touchableBodies } from '../src/surface_point.js';

const VECTOR = JSON.parse(readFileSync(new URL('../../../tests/vectors/surface_points.json', import.meta.url), 'utf8'));
const TOL = 1e-9;
const near = (got, want, what) => got.forEach((g, i) => assert.ok(Math.abs(g - want[i]) <= TOL, `${what}: got ${got}, want ${want}`));

test('every primitive the server touches is one the client knows', () => {
  assert.deepEqual([...PRIMITIVES].sort(), VECTOR.types);
});

test('signed distance, normal and closest point agree with the server to 1e-9', () => {
  let n = 0;
  for (const c of VECTOR.cases) {
    const b = body('b', c.shape, c.pose);
    for (const r of c.points) {
      const what = `${c.shape.type} at ${JSON.stringify(c.pose)}, p ${r.p}`;
      const [sd, ...normal] = evalBody(b, r.p);
      assert.ok(Math.abs(sd - r.sd) <= TOL, `${what}: sd ${sd}, want ${r.sd}`);
      near(normal, r.normal, `${what}: normal`);
      near(closestPoint(b, r.p), r.closest, `${what}: closest`);
      n++;
    }
  }
  assert.ok(n > 500, `${n} points`);
});

test('the offset surface: a point inside or within the offset lands `offset` outside along the normal', () => {
  const dome = body('dome', { type: 'hemisphere', radius: 0.6 });
  const q = closestPoint(dome, [0, 0.1, 0.5], 0.06);
  assert.ok(Math.abs(Math.hypot(...q) - 0.66) < 1e-12);
  assert.ok(Math.abs(q[1] / q[2] - 0.1 / 0.5) < 1e-12, 'along the radial normal');
});

test('a point free of every offset surface predicts nothing; one inside rests on the offset surface', () => {
  const bodies = [body('dome', { type: 'hemisphere', radius: 0.6 })];
  assert.equal(predictProxy(bodies, [0, 0, 0.7], 0.06), null);
  const p = predictProxy(bodies, [0, 0, 0.63], 0.06);
  assert.equal(p.id, 'dome');
  near(p.pos, [0, 0, 0.66], 'proxy on the dilated dome');
  assert.equal(predictProxy(bodies, [0, 0, 0.63], 0), null, 'a point proxy: outside the dome itself');
});

test('a point inside two bodies is pushed out of both (a corner between a box and the ground)', () => {
  const bodies = [body('ground', { type: 'plane', size: [4, 4] }),
    body('wall', { type: 'box', size: [0.2, 2, 2] }, { pos: [1, 0, 0] })];
  const { pos } = predictProxy(bodies, [0.95, 0, -0.01], 0.05);
  for (const b of bodies) assert.ok(evalBody(b, pos)[0] >= 0.05 - 1e-12, `outside ${b.id}: ${pos}`);
});

test('touchable bodies: haptic objects and primitives only, at the pose the state gives', () => {
  const scene = { objects: [
    { id: 'dome', shape: { type: 'hemisphere', radius: 0.6 }, pose: { pos: [0, 0, 0], quat: [1, 0, 0, 0] }, haptic: true },
    { id: 'legs', shape: { type: 'box', size: [1, 1, 1] }, haptic: false },
    { id: 'tube', shape: { type: 'mesh', vertices: [], faces: [] }, haptic: false },
    { id: 'ball', shape: { type: 'sphere', radius: 0.1 }, pose: { pos: [2, 0, 0] }, haptic: true },
  ] };
  assert.deepEqual(touchableBodies(scene).map((b) => b.id), ['dome', 'ball']);
  const moved = touchableBodies(scene, { objects: [['ball', [0, 3, 0], [1, 0, 0, 0]]], haptic: { dome: false, legs: true } });
  assert.deepEqual(moved.map((b) => b.id), ['legs', 'ball']);
  assert.deepEqual(moved[1].pos, [0, 3, 0]);
  assert.ok(evalBody(moved[1], [0, 3, 0.05])[0] < 0, 'the moved ball is where the state says');
});
