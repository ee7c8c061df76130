// HUD values and events (src/hud.js) with plain objects standing in for the DOM elements.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { Hud, formatEvent } from '../src/hud.js';

const els = () => ({ hud: {}, status: { dataset: {} }, telemetry: {}, values: {}, events: {} });

test('an event reads as time, name and its fields', () => {
  assert.equal(formatEvent({ tick: 20010, t: 20.01, name: 'tap', angle_deg: -20.5, by: 'experimenter' }),
    '20.01 s tap angle_deg -20.5 by experimenter');
  assert.equal(formatEvent({ name: 'release', angle_deg: null }), 'release');
});

test('operators see the last three events', () => {
  const e = els();
  const hud = new Hud(e, { showValues: true });
  hud.addEvents([{ t: 1, name: 'a' }, { t: 2, name: 'b' }]);
  hud.addEvents([]);
  assert.equal(e.events.textContent, '1.00 s a\n2.00 s b');
  hud.addEvents([{ t: 3, name: 'c' }, { t: 4, name: 'd' }]);
  assert.equal(e.events.textContent, '2.00 s b\n3.00 s c\n4.00 s d');
});

test('participants see neither values nor events', () => {
  const e = els();
  const hud = new Hud(e);
  hud.setValues({ angle_deg: 3 });
  hud.addEvents([{ t: 1, name: 'tap' }]);
  assert.equal(e.values.textContent, undefined);
  assert.equal(e.events.textContent, undefined);
});

test('tracking lost: a banner while any source is lost; operators see which', async () => {
  const { trackingLine } = await import('../src/hud.js');
  assert.equal(trackingLine([]), '');
  assert.equal(trackingLine(undefined), '');
  assert.match(trackingLine(['leap']), /^Tracking lost — /);
  assert.match(trackingLine(['leap', 3], { names: true }), /^Tracking lost \(leap, 3\) — /);
  const e = { ...els(), tracking: {} };
  const participant = new Hud(e);
  participant.setTracking(['leap']);
  assert.equal(e.tracking.hidden, false);
  assert.doesNotMatch(e.tracking.textContent, /leap/, 'a participant is told what to do, not the source');
  participant.setTracking([]);
  assert.equal(e.tracking.hidden, true);
  assert.equal(e.tracking.textContent, '');
});
