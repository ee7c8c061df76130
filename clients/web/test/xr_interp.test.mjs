import { test } from 'node:test';
import assert from 'node:assert/strict';
import { Blend, contactChanged, BLEND_MS } from '../src/xr_interp.js';

test('a new target is reached within the blend window, smoothly', () => {
  const b = new Blend(8);
  b.push({ p: [0, 0, 0] }, 0);
  assert.deepEqual(b.sample(0), { p: [0, 0, 0] });
  b.push({ p: [1, 0, 0] }, 100);
  assert.deepEqual(b.sample(100).p, [0, 0, 0]);
  assert.deepEqual(b.sample(104).p, [0.5, 0, 0]);
  assert.deepEqual(b.sample(108).p, [1, 0, 0]);
  assert.deepEqual(b.sample(200).p, [1, 0, 0]);
});

test('a target that comes mid-blend starts from where it was drawn', () => {
  const b = new Blend(10);
  b.push({ p: [0, 0, 0] }, 0);
  b.sample(0);
  b.push({ p: [10, 0, 0] }, 0);
  assert.deepEqual(b.sample(5).p, [5, 0, 0]);
  b.push({ p: [5, 0, 0] }, 5);
  assert.deepEqual(b.sample(5).p, [5, 0, 0]);
});

test('snapped keys jump to the target; keys no longer sent are dropped', () => {
  const b = new Blend(8);
  b.push({ a: [0, 0, 0], b: [0, 0, 0] }, 0);
  b.sample(0);
  b.push({ a: [1, 1, 1], b: [1, 1, 1] }, 10, ['a']);
  const s = b.sample(10);
  assert.deepEqual(s.a, [1, 1, 1]);
  assert.deepEqual(s.b, [0, 0, 0]);
  b.push({ a: [2, 2, 2] }, 20);
  assert.deepEqual(Object.keys(b.sample(30)), ['a']);
});

test('the blend stays inside the 15 ms tactile-before-visual budget', () => {
  assert.ok(BLEND_MS < 15);
});

test('contact changes name the tools that snap', () => {
  const a = [{ name: 'i', contact: false }, { name: 't', contact: true }];
  const b = [{ name: 'i', contact: true }, { name: 't', contact: true }, { name: 'm', contact: false }];
  assert.deepEqual(contactChanged(a, b), ['i', 'm']);
  assert.deepEqual(contactChanged(b, b), []);
});
