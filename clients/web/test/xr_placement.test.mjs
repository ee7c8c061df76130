import { test } from 'node:test';
import assert from 'node:assert/strict';
import { DEFAULT_PLACEMENT, checkPlacement, effectivePlacement, placementFromTouch, placementTransform,
  sceneToXr, stepScale, xrToScene, scaleFor } from '../src/xr_placement.js';

const close = (a, b, eps = 1e-9) => a.forEach((v, i) => assert.ok(Math.abs(v - b[i]) < eps, `${a} vs ${b}`));

test('scene → XR: scale, table height, origin; and back', () => {
  const p = { table_height_m: 0.8, origin_m: [0.1, -0.4], yaw_deg: 0, scale_m_per_unit: 0.1 };
  // scene z up → XR Y up; scene x (toward the viewer) → +Z; scene y (right) → +X
  close(sceneToXr([0, 0, 0.6], p), [0.1, 0.86, -0.4]);
  close(sceneToXr([1, 0, 0], p), [0.1, 0.8, -0.3]);
  close(sceneToXr([0, 1, 0], p), [0.2, 0.8, -0.4]);
  for (const yaw of [0, 30, -135, 180]) {
    const q = { ...p, yaw_deg: yaw };
    for (const s of [[0.3, -0.2, 0.5], [-2, 4, 1]]) close(xrToScene(sceneToXr(s, q), q), s, 1e-12);
  }
});

test('yaw turns the scene about the vertical, as three.js rotation.y does', () => {
  const p = { table_height_m: 0, origin_m: [0, 0], yaw_deg: 90, scale_m_per_unit: 1 };
  // three's R_y(90°) takes +Z to +X: the scene's +x (three +Z) now points at +X
  close(sceneToXr([1, 0, 0], p), [1, 0, 0]);
  const t = placementTransform(p);
  assert.equal(t.yaw, Math.PI / 2);
  assert.deepEqual(t.position, [0, 0, 0]);
});

test('the placement step: origin and height from the fingertip, facing the head', () => {
  const p = placementFromTouch([0.2, 0.74, -0.5], [0.2, 1.6, 0.1], 0.05);
  assert.equal(p.table_height_m, 0.74);
  assert.deepEqual(p.origin_m, [0.2, -0.5]);
  assert.ok(Math.abs(p.yaw_deg) < 1e-9, 'the head straight behind +Z: no turn');
  const side = placementFromTouch([0, 0.7, 0], [1, 1.6, 0]);
  assert.ok(Math.abs(side.yaw_deg - 90) < 1e-9);
  // the scene's viewer side (+x) points to the head
  const toward = sceneToXr([1, 0, 0], side);
  assert.ok(toward[0] > 0 && Math.abs(toward[2]) < 1e-9);
});

test('bad placements are refused; the effective one falls back', () => {
  assert.throws(() => checkPlacement({ ...DEFAULT_PLACEMENT, scale_m_per_unit: 0 }), /scale_m_per_unit/);
  assert.throws(() => checkPlacement({ ...DEFAULT_PLACEMENT, table_height_m: NaN }), /table_height_m/);
  assert.throws(() => checkPlacement({ ...DEFAULT_PLACEMENT, origin_m: [0, 9] }), /origin_m/);
  const rig = { ...DEFAULT_PLACEMENT, table_height_m: 0.9 };
  assert.equal(effectivePlacement(null, rig).table_height_m, 0.9);
  assert.equal(effectivePlacement({ bad: 1 }, rig).table_height_m, 0.9);
  assert.equal(effectivePlacement({ ...rig, table_height_m: 1.1 }, rig).table_height_m, 1.1);
  assert.deepEqual(effectivePlacement(), checkPlacement(DEFAULT_PLACEMENT));
});

test('scale steps stay within the limits', () => {
  assert.ok(Math.abs(stepScale(0.1, 1) - 0.125) < 1e-12);
  assert.ok(Math.abs(stepScale(0.1, -1) - 0.08) < 1e-12);
  assert.equal(stepScale(2, 1), 2);
  assert.ok(Math.abs(scaleFor(3, 0.3) - 0.1) < 1e-12);
  assert.equal(scaleFor(1, 100), 2);
});
