import { test } from 'node:test';
import assert from 'node:assert/strict';
import { panelLines, countdown, facingYaw, choiceLayout, choiceAt, angleAt, PinchLatch, answerKey } from '../src/xr_panels.js';
import { AudioPlan, audioSettings } from '../src/audio.js';

test('panel lines: HUD text, then health and tracking banners when they apply', () => {
  assert.deepEqual(panelLines({ hud: 'Touch the dome\nthen hold' }), ['Touch the dome', 'then hold']);
  const lines = panelLines({ hud: '', health: { status: 'degraded', reasons: [{ code: 'device_missing' }] }, lost: ['xr'] });
  assert.equal(lines.length, 2);
  assert.match(lines[0], /Tactile feedback paused/);
  assert.match(lines[1], /Tracking lost/);
  assert.deepEqual(panelLines({}), []);
});

test('count-down in whole seconds', () => {
  assert.equal(countdown(3000, 0), 3);
  assert.equal(countdown(3000, 100), 3);
  assert.equal(countdown(3000, 1000), 2);
  assert.equal(countdown(3000, 2999), 1);
  assert.equal(countdown(3000, 4000), 0);
});

test('a panel turns to face the head', () => {
  assert.equal(facingYaw([0, 1, -1], [0, 1.6, 0]), 0);
  assert.ok(Math.abs(facingYaw([0, 1, 0], [1, 1.6, 0]) - Math.PI / 2) < 1e-12);
});

test('likert buttons across the panel; the hit picks one', () => {
  const l = choiceLayout({ kind: 'likert', low: 1, high: 7, labels: { 1: 'bad', 7: 'good' } });
  assert.equal(l.length, 7);
  assert.equal(l[0].anchor, 'bad');
  assert.equal(choiceAt(l, 0).value, 1);
  assert.equal(choiceAt(l, 0.5).value, 4);
  assert.equal(choiceAt(l, 1).value, 7);
  assert.equal(choiceAt(l, 1.2), null);
  const b = choiceLayout({ kind: 'buttons', items: [{ label: 'A', value: 'a' }, { label: 'B', value: 'b' }] });
  assert.equal(choiceAt(b, 0.7).value, 'b');
});

test('an angle named on the angle scale, as the overlay draws it', () => {
  const scale = { centre: [0, 0, 0], from_deg: -90, to_deg: 90 };
  const at = (deg) => [0, Math.sin((deg * Math.PI) / 180), Math.cos((deg * Math.PI) / 180)];
  assert.equal(angleAt(at(-30), scale), -30);
  assert.equal(angleAt(at(47.4), scale), 47);
  assert.equal(angleAt(at(47.4), scale, 5), 45);
  assert.equal(angleAt([0, 0.2, -1], scale), 90, 'below the centre: clamped to the range');
  assert.equal(angleAt([0, 0, 0], scale), null);
});

test('a held pinch answers once', () => {
  const l = new PinchLatch();
  assert.deepEqual([false, true, true, false, true].map((p) => l.update(p)), [false, true, false, false, true]);
  assert.equal(answerKey('angle', -30), 'answer:angle=-30');
  assert.ok(answerKey('a'.repeat(40), 1).length <= 32);
});

test('audio: off unless asked; speaks new instructions once; clicks at contact onsets', () => {
  assert.deepEqual(audioSettings(null), { speech: false, contact: false });
  assert.deepEqual(audioSettings('speech, Contact'), { speech: true, contact: true });
  const off = new AudioPlan(audioSettings(''));
  assert.equal(off.say('Touch the dome'), null);
  assert.equal(off.clicks([{ name: 'i', contact: true }]), 0);
  const on = new AudioPlan(audioSettings('speech,contact'));
  assert.equal(on.say('Touch the dome'), 'Touch the dome');
  assert.equal(on.say('Touch the dome'), null);
  assert.equal(on.say(''), null);
  assert.equal(on.say('3'), '3');
  assert.equal(on.clicks([{ name: 'i', contact: true }, { name: 't', contact: false }]), 1);
  assert.equal(on.clicks([{ name: 'i', contact: true }, { name: 't', contact: true }]), 1);
  assert.equal(on.clicks([{ name: 'i', contact: true, lost: true }]), 0);
  assert.equal(on.clicks([{ name: 'i', contact: true }]), 1);
});
