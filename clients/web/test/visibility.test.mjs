// state.visible application (src/visibility.js): overrides on top of the scene's values.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import * as THREE from 'three';
import { Visibility } from '../src/visibility.js';

function setup() {
  const v = new Visibility();
  const dome = new THREE.Object3D();
  const scale = new THREE.Object3D();
  const hidden = new THREE.Object3D();
  v.add('dome', dome, true);
  v.add('angle_scale', scale, true);
  v.add('target', hidden, false);
  return { v, dome, scale, hidden };
}

test('elements start with their scene value', () => {
  const { dome, hidden } = setup();
  assert.equal(dome.visible, true);
  assert.equal(hidden.visible, false);
});

test('the map is the complete set of overrides: absent ids go back to the scene value', () => {
  const { v, scale, hidden } = setup();
  assert.deepStrictEqual(v.apply({ angle_scale: false, target: true }), ['angle_scale', 'target']);
  assert.equal(scale.visible, false);
  assert.equal(hidden.visible, true);
  assert.deepStrictEqual(v.apply({ target: true }), ['angle_scale']);
  assert.equal(scale.visible, true);
  assert.deepStrictEqual(v.apply({}), ['target']);
  assert.equal(hidden.visible, false);
  assert.deepStrictEqual(v.apply(undefined), []);
});

test('only changes are touched', () => {
  const { v, scale } = setup();
  v.apply({ angle_scale: false });
  let writes = 0;
  const real = scale.visible;
  Object.defineProperty(scale, 'visible', { get: () => real, set: () => { writes++; } });
  for (let i = 0; i < 100; i++) assert.deepStrictEqual(v.apply({ angle_scale: false }), []);
  assert.equal(writes, 0);
});

test('an override equal to the scene value still counts, unknown ids are ignored', () => {
  const { v, dome } = setup();
  assert.deepStrictEqual(v.apply({ dome: true, nothing: false }), ['dome']);
  assert.equal(dome.visible, true);
  assert.deepStrictEqual(v.apply({ dome: false, nothing: false }), ['dome']);
  assert.equal(dome.visible, false);
});

test('clear forgets elements and overrides (new scene)', () => {
  const { v, scale } = setup();
  v.apply({ angle_scale: false });
  v.clear();
  assert.deepStrictEqual(v.apply({}), []);
  assert.equal(scale.visible, false, 'an element of the old scene is not touched');
});
