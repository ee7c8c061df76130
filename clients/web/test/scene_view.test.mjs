// Shape geometry and camera construction (src/scene_view.js), without WebGL: the local geometry
// of each shape must match docs/protocol.md once mapped back to the scene frame.
import { test, describe } from 'node:test';
import assert from 'node:assert/strict';
import * as THREE from 'three';
import { buildShape, buildObject, meshGeometry, makeCamera, planeThickness, orthoHeight, halfWidthAcross }
  from '../src/scene_view.js';
import { threeToScene, sceneToThree, checkMesh } from '../src/protocol.js';
import { SkinLoader } from '../src/skins.js';

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

// Unit cube [0, 1]^3 in the scene frame: vertex i has x = bit 0, y = bit 1, z = bit 2 of
// [0, 1, 3, 2, 4, 5, 7, 6][i]; two triangles per side, counter-clockwise seen from outside.
const CUBE = {
  type: 'mesh',
  vertices: [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]],
  faces: [
    [0, 3, 2], [0, 2, 1], // bottom, -z
    [4, 5, 6], [4, 6, 7], // top, +z
    [1, 2, 6], [1, 6, 5], // front, +x
    [0, 4, 7], [0, 7, 3], // back, -x
    [3, 7, 6], [3, 6, 2], // right, +y
    [0, 1, 5], [0, 5, 4], // left, -y
  ],
};

describe('mesh shape', () => {
  const vertexAt = (attr, i) => [attr.getX(i), attr.getY(i), attr.getZ(i)];

  test('positions are the scene vertices of each face, in three.js axes', () => {
    const g = meshGeometry(CUBE);
    const pos = g.attributes.position;
    assert.equal(g.index, null, 'non-indexed: one normal per face');
    assert.equal(pos.count, 36);
    CUBE.faces.forEach((face, k) => face.forEach((v, j) => {
      assert.deepStrictEqual(vertexAt(pos, 3 * k + j), sceneToThree(CUBE.vertices[v]), `face ${k} corner ${j}`);
    }));
  });

  test('normals point outward; the scene +z face points to three.js +Y', () => {
    const g = meshGeometry(CUBE);
    const { position, normal } = g.attributes;
    const centre = new THREE.Vector3(0.5, 0.5, 0.5);
    for (let k = 0; k < CUBE.faces.length; k++) {
      const centroid = new THREE.Vector3();
      for (let j = 0; j < 3; j++) centroid.add(new THREE.Vector3(...vertexAt(position, 3 * k + j)));
      const outward = centroid.divideScalar(3).sub(centre); // convex: away from the centre
      for (let j = 0; j < 3; j++) {
        const n = new THREE.Vector3(...vertexAt(normal, 3 * k + j));
        assert.ok(Math.abs(n.length() - 1) < 1e-6 && n.dot(outward) > 0, `face ${k}: normal ${n.toArray()} points inward`);
      }
    }
    for (const k of [2, 3]) { // the top (+z) triangles
      for (let j = 0; j < 3; j++) near(vertexAt(normal, 3 * k + j), [0, 1, 0]);
    }
  });

  test('uvs run in scene units along the axes a box face would use', () => {
    const { uv } = meshGeometry(CUBE).attributes;
    const uvOf = (k) => [0, 1, 2].map((j) => [uv.getX(3 * k + j), uv.getY(3 * k + j)]);
    const along = (k, [u, v]) => CUBE.faces[k].map((i) => [CUBE.vertices[i][u], CUBE.vertices[i][v]]);
    assert.deepStrictEqual(uvOf(2), along(2, [0, 1])); // top: x, y
    assert.deepStrictEqual(uvOf(4), along(4, [2, 1])); // front: z, y
    assert.deepStrictEqual(uvOf(8), along(8, [0, 2])); // right: x, z
  });

  test('buildShape: the cube spans [0, 1] on every scene axis', () => {
    const b = sceneBox(CUBE);
    near(b.min, [0, 0, 0]);
    near(b.max, [1, 1, 1]);
  });

  test('bad mesh data is described', () => {
    assert.equal(checkMesh(CUBE), null);
    const cases = [
      [{ faces: [[0, 1, 8]] }, /faces\[0\] must be 3 vertex indices in 0\.\.7, got \[0,1,8\]/],
      [{ faces: [[0, 1, -1]] }, /faces\[0\] must be 3 vertex indices/],
      [{ faces: [[0, 1.5, 2]] }, /faces\[0\] must be 3 vertex indices/],
      [{ faces: [[0, 1]] }, /faces\[0\] must be 3 vertex indices/],
      [{ faces: [] }, /faces must be an array of 1\.\.40000/],
      [{ faces: null }, /faces must be an array/],
      [{ vertices: [[0, 0, 0], [1, 0], [0, 1, 0]] }, /vertices\[1\] must be \[x, y, z\], got \[1,0\]/],
      [{ vertices: [[0, 0, 0], [1, 0, 0], [0, 1, '0']] }, /vertices\[2\] must be \[x, y, z\]/],
      [{ vertices: Array(20001).fill([0, 0, 0]) }, /vertices must be an array of 3\.\.20000/],
      [{ vertices: 'cube' }, /vertices must be an array/],
    ];
    for (const [change, message] of cases) assert.match(checkMesh({ ...CUBE, ...change }) ?? '', message);
  });

  test('buildObject poses a good mesh and skips a bad one with a warning naming it', (t) => {
    const warn = t.mock.method(console, 'warn', () => {});
    const skins = new SkinLoader({ load: () => assert.fail('no skin to load') });
    const good = buildObject({ id: 'tube', shape: CUBE, pose: { pos: [0.1, 0.2, 0.3], quat: [1, 0, 0, 0] },
      material: { color: '#3a7bd5' }, haptic: false }, skins);
    assert.equal(good.name, 'tube');
    near(good.position.toArray(), sceneToThree([0.1, 0.2, 0.3]));
    assert.equal(warn.mock.callCount(), 0);

    const bad = buildObject({ id: 'hole', shape: { ...CUBE, faces: [[0, 1, 9]] }, haptic: false }, skins);
    assert.equal(bad, null);
    assert.equal(warn.mock.callCount(), 1);
    assert.match(warn.mock.calls[0].arguments[0], /mesh of hole is invalid \(faces\[0\] must be 3 vertex indices in 0\.\.7/);
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
