// Shape geometry and camera construction (src/scene_view.js), without WebGL: the local geometry
// of each shape must match docs/protocol.md once mapped back to the scene frame.
import { test, describe } from 'node:test';
import assert from 'node:assert/strict';
import * as THREE from 'three';
import { buildShape, makeCamera, planeThickness, orthoHeight, halfWidthAcross } from '../src/scene_view.js';
import { threeToScene, sceneToThree } from '../src/protocol.js';

/** Bounding box of a shape's meshes in its local scene frame: {min: [x,y,z], max: [x,y,z]}. */
function sceneBox(shape) {
  const obj = buildShape(shape, new THREE.MeshBasicMaterial());
  obj.updateMatrixWorld(true);
  const box = new THREE.Box3().setFromObject(obj);
  const a = threeToScene(box.min.toArray());
  const b = threeToScene(box.max.toArray());
  return { min: a.map((v, i) => Math.min(v, b[i])), max: a.map((v, i) => Math.max(v, b[i])) };
}

const near = (got, want, eps = 1e-6) => {
  got.forEach((g, i) => assert.ok(Math.abs(g - want[i]) < eps, `got ${got}, want ${want}`));
};

describe('shapes in their local scene frame', () => {
  test('sphere is centred', () => {
    const b = sceneBox({ type: 'sphere', radius: 0.5 });
    near(b.min, [-0.5, -0.5, -0.5]);
    near(b.max, [0.5, 0.5, 0.5]);
  });
  test('box size is [sx, sy, sz] along scene x, y, z', () => {
    const b = sceneBox({ type: 'box', size: [0.2, 0.4, 0.6] });
    near(b.min, [-0.1, -0.2, -0.3]);
    near(b.max, [0.1, 0.2, 0.3]);
  });
  test('cylinder: axis +z, base at z = 0', () => {
    const b = sceneBox({ type: 'cylinder', radius: 0.1, height: 0.5 });
    near(b.min, [-0.1, -0.1, 0]);
    near(b.max, [0.1, 0.1, 0.5]);
  });
  test('cone: base at z = 0, apex at z = height', () => {
    const obj = buildShape({ type: 'cone', radius: 0.2, height: 0.3 }, new THREE.MeshBasicMaterial());
    const pos = obj.geometry.attributes.position;
    let apex = -Infinity;
    for (let i = 0; i < pos.count; i++) apex = Math.max(apex, pos.getY(i));
    assert.ok(Math.abs(apex - 0.3) < 1e-6); // float32 attribute
    const b = sceneBox({ type: 'cone', radius: 0.2, height: 0.3 });
    near(b.min, [-0.2, -0.2, 0]);
  });
  test('plane: top face at z = 0, size [sx, sy], solid below', () => {
    const b = sceneBox({ type: 'plane', size: [3, 2] });
    near(b.min, [-1.5, -1, -planeThickness([3, 2])]);
    near(b.max, [1.5, 1, 0]);
  });
  test('hemisphere: dome over z >= 0 with a base disc at z = 0', () => {
    const b = sceneBox({ type: 'hemisphere', radius: 0.6 });
    near(b.min, [-0.6, -0.6, 0]);
    near(b.max, [0.6, 0.6, 0.6]);
    assert.equal(buildShape({ type: 'hemisphere', radius: 0.6 }, null).children.length, 2);
  });
  test('unknown shapes are skipped', () => {
    assert.equal(buildShape({ type: 'torus' }, null), null);
  });
});

describe('camera', () => {
  const spec = { projection: 'orthographic', position: [5, 0, 0.35], target: [0, 0, 0.35], up: [0, 0, 1], height: 1.6 };
  test('orthographic: visible height and aspect', () => {
    const { camera, target } = makeCamera(spec, 2);
    assert.equal(camera.top - camera.bottom, 1.6);
    assert.equal(camera.right - camera.left, 3.2);
    near(target.toArray(), sceneToThree([0, 0, 0.35]));
  });
  test('looks along scene -x with scene +y to the right and +z up', () => {
    const { camera } = makeCamera(spec, 4 / 3);
    const dir = camera.getWorldDirection(new THREE.Vector3());
    near(threeToScene(dir.toArray()), [-1, 0, 0]);
    const right = new THREE.Vector3(1, 0, 0).applyQuaternion(camera.quaternion);
    near(threeToScene(right.toArray()), [0, 1, 0]);
    const up = new THREE.Vector3(0, 1, 0).applyQuaternion(camera.quaternion);
    near(threeToScene(up.toArray()), [0, 0, 1]);
    // the scene point (0, 0.4, 0.35) is right of centre on screen
    const p = new THREE.Vector3(...sceneToThree([0, 0.4, 0.35])).project(camera);
    assert.ok(p.x > 0 && Math.abs(p.y) < 1e-9);
  });
  test('perspective uses fov_deg', () => {
    const { camera } = makeCamera({ ...spec, projection: 'perspective', fov_deg: 40 }, 1.5);
    assert.ok(camera.isPerspectiveCamera);
    assert.equal(camera.fov, 40);
    assert.equal(camera.aspect, 1.5);
  });
});

describe('orthographic fit', () => {
  const spec = { projection: 'orthographic', position: [5, 0, 0.55], target: [0, 0, 0.55], up: [0, 0, 1], height: 2.2 };
  const sphereAt = (y) => {
    const m = buildShape({ type: 'sphere', radius: 0.4 }, new THREE.MeshBasicMaterial());
    m.position.fromArray(sceneToThree([0, y, 0.4]));
    return m;
  };
  test('extent across the view from the camera target', () => {
    const { camera, target } = makeCamera(spec, 4 / 3);
    const half = halfWidthAcross([sphereAt(-1.1), sphereAt(0), sphereAt(1.1)], camera, target);
    assert.ok(Math.abs(half - 1.5) < 1e-6, half);
    assert.equal(halfWidthAcross([], camera, target), 0);
  });
  test('the scene height holds unless a narrow view would clip objects at the sides', () => {
    assert.equal(orthoHeight(2.2, 16 / 9, 1.5), 2.2); // 3.9 units wide: everything fits
    assert.ok(Math.abs(orthoHeight(2.2, 4 / 3, 1.5) - (2 * 1.5 * 1.05) / (4 / 3)) < 1e-12);
    assert.equal(orthoHeight(1.6, 4 / 3, 0.6), 1.6); // contact angle: the dome fits at 4:3
  });
});
