// Skin repeats and loading (src/skins.js) without a network or WebGL: a fake TextureLoader.
import { test, describe } from 'node:test';
import assert from 'node:assert/strict';
import * as THREE from 'three';
import { skinRepeats, makeMaterials, SkinLoader, BOX_FACE_AXES } from '../src/skins.js';
import { buildShape } from '../src/scene_view.js';
import { threeToScene } from '../src/protocol.js';

const near = (got, want, eps = 1e-9) => {
  assert.equal(got.length, want.length);
  got.forEach((g, i) => assert.ok(Math.abs(g - want[i]) < eps, `got ${got}, want ${want}`));
};

/** Holds load requests; the test decides when each one loads or fails. */
class FakeLoader {
  constructor() { this.requests = []; }
  load(url, onLoad, onProgress, onError) {
    const texture = new THREE.Texture();
    this.requests.push({ url, load: () => onLoad(texture), fail: () => onError(new Error('404')), texture });
    return texture;
  }
}

describe('skin repeats', () => {
  test('plane: top face only, every tx along local x and ty along local y', () => {
    const r = skinRepeats({ type: 'plane', size: [3, 2] }, [0.5, 0.25]);
    assert.equal(r.length, 6);
    assert.deepStrictEqual(r.filter((x) => x !== null), [[8, 6]]); // u along y: 2 / 0.25, v along x: 3 / 0.5
    assert.deepStrictEqual(r[2], [8, 6]);
    assert.deepStrictEqual(skinRepeats({ type: 'plane', size: [3, 3] }, [0.5, 0.5])[2], [6, 6]);
  });

  test('box: every face, by the scene axes its u and v run along', () => {
    const r = skinRepeats({ type: 'box', size: [1, 2, 3] }, [0.5, 0.25]);
    assert.deepStrictEqual(r, [[2, 12], [2, 12], [8, 2], [8, 2], [8, 6], [8, 6]]);
  });

  test('round shapes: around the circumference and along the surface', () => {
    near(skinRepeats({ type: 'sphere', radius: 1 }, [1, 1])[0], [2 * Math.PI, Math.PI]);
    near(skinRepeats({ type: 'hemisphere', radius: 1 }, [1, 1])[0], [2 * Math.PI, Math.PI / 2]);
    near(skinRepeats({ type: 'cylinder', radius: 0.5, height: 2 }, [1, 0.5])[0], [Math.PI, 4]);
    near(skinRepeats({ type: 'cone', radius: 0.3, height: 0.4 }, [1, 0.5])[0], [0.6 * Math.PI, 1]);
  });

  test('mesh: its uvs are scene units, so one repeat per tile', () => {
    near(skinRepeats({ type: 'mesh', vertices: [], faces: [] }, [0.5, 0.25])[0], [2, 4]);
  });

  test("BoxGeometry's faces run u and v along the axes the repeats assume", () => {
    // Correlate each face group's uv with its vertex positions (scene frame).
    const mesh = buildShape({ type: 'box', size: [1, 2, 3] }, new THREE.MeshBasicMaterial());
    const { position, uv } = mesh.geometry.attributes;
    mesh.geometry.groups.forEach((g, face) => {
      const axisOf = (channel) => {
        const spread = [0, 1, 2].map((axis) => {
          const pts = [];
          for (let i = g.start; i < g.start + g.count; i++) {
            const v = mesh.geometry.index.getX(i);
            pts.push([threeToScene([position.getX(v), position.getY(v), position.getZ(v)])[axis], uv.getComponent(v, channel)]);
          }
          // |covariance| of the scene coordinate with the uv channel
          const mean = (k) => pts.reduce((s, p) => s + p[k], 0) / pts.length;
          const [mp, mu] = [mean(0), mean(1)];
          return Math.abs(pts.reduce((s, p) => s + (p[0] - mp) * (p[1] - mu), 0));
        });
        return 'xyz'[spread.indexOf(Math.max(...spread))];
      };
      assert.deepStrictEqual([axisOf(0), axisOf(1)], BOX_FACE_AXES[face], `face ${face}`);
    });
  });
});

describe('skinned materials', () => {
  const plane = { type: 'plane', size: [3, 3] };

  test('no skin: one material in the object colour', () => {
    const m = makeMaterials({ color: '#b89f7a' }, plane, new SkinLoader(new FakeLoader()));
    assert.ok(m.isMeshStandardMaterial);
    assert.equal(m.color.getHexString(), new THREE.Color('#b89f7a').getHexString());
  });

  test('skinned plane: the image goes on the top face once loaded, tinted by the colour', () => {
    const loader = new FakeLoader();
    const skins = new SkinLoader(loader);
    const spec = { color: '#b89f7a', skin: { image: '/skins/stripes.svg', tile: [0.5, 0.25] } };
    const ms = makeMaterials(spec, plane, skins);
    assert.equal(ms.length, 6);
    assert.equal(loader.requests.length, 1);
    assert.equal(loader.requests[0].url, '/skins/stripes.svg');
    assert.equal(skins.pending, 1);
    assert.equal(ms[2].map, null, 'no map before the image is there (it would sample black)');
    loader.requests[0].load();
    assert.equal(skins.pending, 0);
    const tex = ms[2].map;
    assert.equal(tex, loader.requests[0].texture);
    assert.equal(tex.wrapS, THREE.RepeatWrapping);
    assert.equal(tex.wrapT, THREE.RepeatWrapping);
    near(tex.repeat.toArray(), [12, 6]);
    assert.equal(tex.colorSpace, THREE.SRGBColorSpace);
    assert.ok(ms.every((m, i) => (i === 2) === (m.map !== null)));
    assert.ok(ms.every((m) => m.color.getHexString() === new THREE.Color('#b89f7a').getHexString()));
    // A plane mesh takes the per-face array: its BoxGeometry has one group per face.
    assert.equal(buildShape(plane, ms).geometry.groups.length, 6);
  });

  test('a sphere gets one skinned material', () => {
    const loader = new FakeLoader();
    const m = makeMaterials({ skin: { image: '/skins/dots.svg' } }, { type: 'sphere', radius: 1 }, new SkinLoader(loader));
    assert.ok(m.isMeshStandardMaterial);
    loader.requests[0].load();
    near(m.map.repeat.toArray(), [4 * Math.PI, 2 * Math.PI]); // default tile 0.5
  });

  test('a failed image leaves the plain colour; a cancelled build drops late images', () => {
    const loader = new FakeLoader();
    const skins = new SkinLoader(loader);
    const spec = { skin: { image: '/skins/missing.png' } };
    const failed = makeMaterials(spec, plane, skins);
    const late = makeMaterials(spec, plane, skins);
    loader.requests[0].fail();
    assert.deepStrictEqual(skins.failed, ['/skins/missing.png']);
    assert.equal(failed[2].map, null);
    skins.cancel();
    let disposed = false;
    loader.requests[1].texture.addEventListener('dispose', () => { disposed = true; });
    loader.requests[1].load();
    assert.equal(late[2].map, null);
    assert.ok(disposed, 'the late texture is freed');
    assert.equal(skins.pending, 0);
  });
});
