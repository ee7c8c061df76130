// Every tool of a state frame and the tracked hand (src/tools_view.js), without WebGL.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import * as THREE from 'three';
import { FREE_PROXY_COLOR, HandView, LOST_OPACITY, PROXY_COLOR, ToolMarker, lostSources, toolColor, toolsOf }
  from '../src/tools_view.js';
import { sceneToThree, threeToScene } from '../src/protocol.js';

const near = (got, want, eps = 1e-9) => {
  got.forEach((g, i) => assert.ok(Math.abs(g - want[i]) < eps, `got ${got}, want ${want}`));
};

const INDEX = { name: 'right.index.tip', hip: [0, 0, 0.5], proxy: [0, 0, 0.6], contact: true, lost: false };
const THUMB = { name: 'right.thumb.tip', hip: [0, 0.3, 0.5], proxy: [0, 0.3, 0.5], contact: false, lost: true };

test('toolsOf: the frame\'s tools, primary first; an older server\'s frame is its one HIP', () => {
  assert.deepEqual(toolsOf({ hip: [1, 1, 1], proxy: [1, 1, 1], tools: [INDEX, THUMB] }), [INDEX, THUMB]);
  assert.deepEqual(toolsOf({ hip: [1, 2, 3], proxy: [1, 2, 4], contact: true }),
    [{ name: 'right.index.tip', hip: [1, 2, 3], proxy: [1, 2, 4], contact: true, lost: false }]);
  assert.deepEqual(toolsOf({ hip: [1, 2, 3], proxy: [1, 2, 3], tools: [] })[0].name, 'right.index.tip');
});

test('lostSources: the lost sources, or none', () => {
  assert.deepEqual(lostSources({ tracking: { lost: ['leap', 7] } }), ['leap', 7]);
  assert.deepEqual(lostSources({ tracking: { lost: [] } }), []);
  assert.deepEqual(lostSources({}), []);
  assert.deepEqual(lostSources({ tracking: { lost: 'leap' } }), []);
});

test('toolColor: the primary keeps the scene\'s HIP colour, the thumb differs from it', () => {
  assert.equal(toolColor('right.index.tip', '#ffd400'), '#ffd400');
  const thumb = toolColor('right.thumb.tip', '#ffd400');
  assert.notEqual(thumb, '#ffd400');
  assert.notEqual(toolColor('right.middle.tip', '#ffd400'), thumb);
  assert.match(toolColor('robot', '#ffd400'), /^#[0-9a-f]{6}$/);
});

test('a tool in contact glows in its colour with a contact-coloured proxy; its proxy shows apart from the HIP', () => {
  const m = new ToolMarker(INDEX.name);
  m.style(0.06, 0.06, '#ffd400');
  m.update(INDEX);
  near(threeToScene(m.hip.position.toArray()), INDEX.hip);
  near(threeToScene(m.proxy.position.toArray()), INDEX.proxy);
  assert.ok(m.hip.visible && m.proxy.visible && m.contact);
  assert.equal(`#${m.hip.material.emissive.getHexString()}`, '#ffd400');
  assert.ok(m.hip.material.emissiveIntensity > 0);
  assert.equal(`#${m.proxy.material.color.getHexString()}`, PROXY_COLOR);
  m.update({ ...INDEX, contact: false });
  assert.ok(m.proxy.visible && `#${m.proxy.material.color.getHexString()}` === FREE_PROXY_COLOR,
    'apart from the HIP without debounced contact: shown, not in the contact colour');
  m.update({ ...INDEX, contact: false, proxy: INDEX.hip });
  assert.ok(!m.proxy.visible, 'a free proxy sits on the HIP: hidden');
  assert.equal(m.hip.material.emissiveIntensity, 0);
  assert.equal(m.hip.material.opacity, 1);
});

test('a lost tool fades, shows no contact and no proxy', () => {
  const m = new ToolMarker(THUMB.name);
  m.update({ ...THUMB, contact: true, proxy: [0, 0.3, 0.6] });
  assert.ok(m.hip.visible && m.lost && !m.contact && !m.proxy.visible && !m.ghost.visible);
  assert.ok(m.hip.material.transparent && m.hip.material.opacity === LOST_OPACITY);
  m.update({ ...THUMB, lost: false });
  assert.ok(!m.lost && m.hip.material.opacity === 1 && m.ghost.visible);
});

test('a hand: one joint sphere per point, each bone a cylinder from joint to joint', () => {
  const hand = new HandView();
  hand.setRadius(0.06);
  const points = { 'right.wrist': [0, 0, 0], 'right.index.metacarpal': [0.1, 0.2, 0.3] };
  hand.update(points, [{ name: 'right.index.tip', hip: [0.1, 0.2, 1.3] }]);
  const joints = hand.joints.filter((j) => j.visible);
  const bones = hand.bones.filter((b) => b.visible);
  assert.equal(joints.length, 3);
  assert.equal(bones.length, 2);
  // the unit cylinder runs along local +Y from -0.5 to 0.5: its ends must land on the joints
  const ends = (mesh) => [new THREE.Vector3(0, -0.5, 0), new THREE.Vector3(0, 0.5, 0)].map((v) => {
    mesh.updateMatrixWorld(true);
    return threeToScene(v.applyMatrix4(mesh.matrixWorld).toArray());
  });
  const [a, b] = ends(bones[1]);
  near(a, [0.1, 0.2, 0.3], 1e-6);
  near(b, [0.1, 0.2, 1.3], 1e-6);
  near(joints[0].position.toArray(), sceneToThree([0, 0, 0]));
  hand.update({}, []);
  assert.equal(hand.joints.filter((j) => j.visible).length + hand.bones.filter((x) => x.visible).length, 0,
    'the hand goes when its points do');
});
