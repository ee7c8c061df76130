// Overlay geometry (src/overlays.js) without WebGL or a canvas: label text is "rasterised" by a
// fake that records what it was asked to draw.
import { test, describe } from 'node:test';
import assert from 'node:assert/strict';
import * as THREE from 'three';
import {
  angleScaleLayout, angleText, arcPoint, buildOverlay, haloColor, strokeGeometry, LINE_HEIGHT, RENDER_ORDER,
} from '../src/overlays.js';
import { sceneToThree, threeToScene } from '../src/protocol.js';

const near = (got, want, eps = 1e-9) => {
  assert.equal(got.length, want.length);
  got.forEach((g, i) => assert.ok(Math.abs(g - want[i]) < eps, `got ${got}, want ${want}`));
};

/** Fake rasteriser: every label is 2 boxes wide per box height; records the calls. */
function fakeRaster() {
  const calls = [];
  const rasterise = (text, color, halo) => {
    calls.push({ text, color, halo });
    return { texture: new THREE.Texture(), aspect: 2 };
  };
  return { calls, rasterise };
}

const SCALE = { id: 'angle_scale', kind: 'angle_scale', centre: [0, 0, 0], radius: 0.62 };

describe('angle scale layout', () => {
  const layout = angleScaleLayout(SCALE);
  const tick = (deg) => layout.ticks.find((t) => t.deg === deg);

  test('-90 is left (three -X), 0 the top (+Y), +90 right (+X), in the arc plane', () => {
    near(tick(-90).inner, [-0.62, 0, 0]);
    near(tick(0).inner, [0, 0.62, 0]);
    near(tick(90).inner, [0.62, 0, 0]);
    near(tick(-30).inner, sceneToThree([0, 0.62 * Math.sin(-Math.PI / 6), 0.62 * Math.cos(-Math.PI / 6)]));
  });

  test('ticks every 10° point outward, majors (every 30°) longer', () => {
    assert.equal(layout.ticks.length, 19);
    assert.deepStrictEqual(layout.ticks.filter((t) => t.major).map((t) => t.deg), [-90, -60, -30, 0, 30, 60, 90]);
    const len = (t) => Math.hypot(...t.outer.map((v, i) => v - t.inner[i]));
    assert.ok(Math.abs(len(tick(-90)) - 2 * len(tick(-80))) < 1e-9);
    near(tick(-90).outer, [-0.62 - len(tick(-90)), 0, 0]);
    near(tick(0).outer, [0, 0.62 + len(tick(0)), 0]);
    for (const t of layout.ticks) assert.ok(Math.hypot(...t.outer) > Math.hypot(...t.inner));
  });

  test('the default -90..90 step 30 gives 7 labels just outside the major ticks', () => {
    assert.deepStrictEqual(layout.labels.map((l) => l.text), ['-90°', '-60°', '-30°', '0°', '30°', '60°', '90°']);
    // With every label box 2 heights wide: each box clears its tick's outer end, and not by much.
    const [left, , , top, , , right] = angleScaleLayout(SCALE, () => 2).labels;
    const halfWidth = (l) => l.height;
    assert.ok(left.position[0] + halfWidth(left) < tick(-90).outer[0]);
    assert.ok(left.position[0] + halfWidth(left) > tick(-90).outer[0] - 0.05);
    assert.ok(top.position[1] - top.height / 2 > tick(0).outer[1]);
    assert.ok(right.position[0] - halfWidth(right) > tick(90).outer[0]);
    // Left/right mirror each other; the top label sits on the axis.
    near([left.position[0], left.position[1]], [-right.position[0], right.position[1]]);
    near([top.position[0], top.position[2]], [0, 0]);
    // Wider text is pushed further out at the sides.
    const wide = angleScaleLayout(SCALE, (text) => (text === '-90°' ? 4 : 2)).labels[0];
    near([wide.position[0]], [left.position[0] - left.height]);
  });

  test('centre offsets everything; a non-zero centre x moves the plane in depth', () => {
    const moved = angleScaleLayout({ ...SCALE, centre: [0.3, 1, 2] });
    const c = sceneToThree([0.3, 1, 2]);
    near(moved.ticks[0].inner, [c[0] - 0.62, c[1], c[2]]);
    for (const t of moved.ticks) assert.equal(threeToScene(t.outer)[0], 0.3);
  });

  test('range and steps come from the spec; majors are ticked even off the minor grid', () => {
    const l = angleScaleLayout({ ...SCALE, from_deg: -45, to_deg: 45, minor_deg: 20, major_deg: 45 });
    assert.deepStrictEqual(l.ticks.map((t) => t.deg), [-45, -40, -20, 0, 20, 40, 45]);
    assert.deepStrictEqual(l.labels.map((l) => l.text), ['-45°', '0°', '45°']);
  });

  test('angle text', () => {
    assert.equal(angleText(-60), '-60°');
    assert.equal(angleText(-0), '0°');
    assert.equal(angleText(12.5), '12.5°');
    assert.deepStrictEqual(arcPoint([0, 0, 0], 1, 90).map((v) => Math.round(v * 1e9) / 1e9), [1, 0, 0]);
  });
});

describe('building overlays', () => {
  test('angle scale: halo and stroke meshes, one sprite per label at its layout position', () => {
    const { calls, rasterise } = fakeRaster();
    const group = buildOverlay(SCALE, rasterise);
    const meshes = group.children.filter((c) => c.isMesh);
    const sprites = group.children.filter((c) => c.isSprite);
    assert.equal(meshes.length, 2);
    assert.equal(sprites.length, 7);
    assert.deepStrictEqual(calls.map((c) => c.text), ['-90°', '-60°', '-30°', '0°', '30°', '60°', '90°']);
    assert.equal(calls[0].color, '#1b1b1b');
    assert.equal(calls[0].halo, '#eeeeee'); // dark scale on a dark page: light outline
    const layout = angleScaleLayout(SCALE, () => 2);
    sprites.forEach((s, i) => {
      near(s.position.toArray(), layout.labels[i].position);
      near([s.scale.x, s.scale.y], [layout.labels[i].height * 2, layout.labels[i].height]);
    });
    assert.deepStrictEqual(group.userData.labels.map((l) => l.text), calls.map((c) => c.text));
    // Annotations: no depth test, drawn after the objects (order 0) and before the HIP (3).
    for (const o of [...meshes, ...sprites]) {
      assert.equal(o.material.depthTest, false);
      assert.ok(o.renderOrder > 0 && o.renderOrder < 3);
    }
    const [halo, stroke] = meshes;
    assert.ok(halo.renderOrder < stroke.renderOrder, 'the halo is drawn under the stroke');
    assert.equal(halo.renderOrder, RENDER_ORDER.halo);
  });

  test('angle scale strokes lie in the scene y-z plane through the centre', () => {
    const group = buildOverlay({ ...SCALE, centre: [0.25, 0, 0] }, fakeRaster().rasterise);
    const pos = group.children[1].geometry.attributes.position;
    const box = new THREE.Box3().setFromBufferAttribute(pos);
    assert.ok(Math.abs(box.min.z - 0.25) < 1e-6 && Math.abs(box.max.z - 0.25) < 1e-6);
    assert.ok(box.min.x < -0.62 && box.max.x > 0.62 && box.max.y > 0.62 && box.min.y < 0.01);
  });

  test('label: a camera-facing sprite centred on pos, size = letter height', () => {
    const { calls, rasterise } = fakeRaster();
    const spec = { id: 'soft', kind: 'label', pos: [0.2, -1, 1], text: '1 (softest)', size: 0.12, color: '#ffffff' };
    const group = buildOverlay(spec, rasterise);
    const [sprite] = group.children;
    assert.ok(sprite.isSprite);
    near(sprite.position.toArray(), sceneToThree(spec.pos));
    near(sprite.center.toArray(), [0.5, 0.5]);
    near([sprite.scale.x, sprite.scale.y], [0.12 * LINE_HEIGHT * 2, 0.12 * LINE_HEIGHT]);
    assert.deepStrictEqual(calls, [{ text: '1 (softest)', color: '#ffffff', halo: '#141414' }]);
    assert.deepStrictEqual(group.userData.labels, [{ text: '1 (softest)', position: sceneToThree(spec.pos) }]);
  });

  test('label defaults and unknown kinds', () => {
    const group = buildOverlay({ id: 'x', kind: 'label', pos: [0, 0, 0], text: 'hi' }, fakeRaster().rasterise);
    assert.ok(Math.abs(group.children[0].scale.y - 0.12 * LINE_HEIGHT) < 1e-12);
    assert.equal(buildOverlay({ id: 'h', kind: 'hologram' }, fakeRaster().rasterise), null);
  });

  test('stroke geometry: one quad per segment, width across it', () => {
    const g = strokeGeometry([[[0, 0, 1], [1, 0, 1]]], 0.2);
    const pos = g.attributes.position;
    assert.equal(pos.count, 6);
    const box = new THREE.Box3().setFromBufferAttribute(pos);
    near(box.min.toArray(), [-0.1, -0.1, 1], 1e-6);
    near(box.max.toArray(), [1.1, 0.1, 1], 1e-6);
  });

  test('halo colour contrasts with the stroke', () => {
    assert.equal(haloColor('#1b1b1b'), '#eeeeee');
    assert.equal(haloColor('#ffd400'), '#141414');
    assert.equal(haloColor('#ffffff'), '#141414');
  });
});
