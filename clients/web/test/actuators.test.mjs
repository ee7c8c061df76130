import { test } from 'node:test';
import assert from 'node:assert/strict';
import { HOLD_MS, NO_ACTUATOR_HANDS, PageActuators, drivePulse, findActuators } from '../src/actuators.js';
import { actuators as actuatorsMessage } from '../src/protocol.js';

test('a continuous drive plays its value for at most a hold, until the next drive', () => {
  assert.deepEqual(drivePulse([0.6, 0, 0, 0, 10], 1000, 1000), { value: 0.6, ms: HOLD_MS });
  assert.deepEqual(drivePulse([0.6, 0, 0, 0, 10], 1000, 99000), { value: 0.6, ms: HOLD_MS });
  assert.deepEqual(drivePulse([0, 0, 0, 0, 10], 1000, 1000), { value: 0, ms: 0 });
  assert.deepEqual(drivePulse(null, 0, 0), { value: 0, ms: 0 });
});

test('a pulse train is on for on_ms and off for off_ms from its start; a call ends at the next edge', () => {
  const d = [0.5, 100, 200, 0, 7];
  assert.deepEqual(drivePulse(d, 0, 0), { value: 0.5, ms: 100 });
  assert.deepEqual(drivePulse(d, 0, 60), { value: 0.5, ms: 40 });
  assert.deepEqual(drivePulse(d, 0, 150), { value: 0, ms: 0 });
  assert.deepEqual(drivePulse(d, 0, 310), { value: 0.5, ms: 90 });
});

test('a timed stimulus ends exactly duration_ms after it started', () => {
  const d = [0.4, 0, 0, 250, 7];
  assert.deepEqual(drivePulse(d, 0, 0), { value: 0.4, ms: HOLD_MS });
  assert.deepEqual(drivePulse(d, 0, 200), { value: 0.4, ms: 50 });
  assert.deepEqual(drivePulse(d, 0, 250), { value: 0, ms: 0 });
});

test('controllers and gamepads are found; tracked hands have none, and say so', () => {
  const pulse = () => Promise.resolve(true);
  const right = { handedness: 'right', gamepad: { hapticActuators: [{ pulse }] } };
  const hand = { handedness: 'left', hand: new Map() };
  const pad = { connected: true, vibrationActuator: { playEffect: () => Promise.resolve('complete') } };
  const found = findActuators([right, hand], [null, pad]);
  assert.deepEqual(found.list.map((a) => [a.kind, a.hand]), [['xr', 'right'], ['gamepad', 'none']]);
  assert.equal(found.note, '');
  assert.deepEqual(findActuators([hand, { ...hand, handedness: 'right' }], []), { list: [], note: NO_ACTUATOR_HANDS });
  assert.deepEqual(actuatorsMessage([], NO_ACTUATOR_HANDS), { type: 'actuators', actuators: [], note: NO_ACTUATOR_HANDS });
  assert.throws(() => actuatorsMessage([['glove', 'right']]), /actuators must be/);
});

test('the page announces its actuators once, plays the newest drive each frame and stops it once', () => {
  const sent = [];
  const calls = [];
  let now = 0;
  const pad = { connected: true, vibrationActuator: {
    playEffect: (kind, p) => { calls.push([kind, p.strongMagnitude, p.duration]); return Promise.resolve('complete'); },
    reset: () => { calls.push(['reset']); return Promise.resolve('complete'); } } };
  let pads = [];
  const page = new PageActuators({ conn: { sendActuators: (a, note) => sent.push([a, note]) && true },
    gamepads: () => pads, now: () => now });
  page.frame();
  assert.deepEqual(sent, [], 'a page that never had an actuator stays silent');
  pads = [pad];
  page.frame();
  page.frame();
  assert.deepEqual(sent, [[[['gamepad', 'none']], '']], 'announced once');
  page.state({ tick: 5, actuator: [0.7, 0, 0, 0, 5] });
  assert.deepEqual(page.changes.at(-1).slice(1), [3, 5, [0.7, 0, 0, 0, 5]], 'arrived after three frames');
  now = 16;
  page.frame();
  assert.deepEqual(calls, [['dual-rumble', 0.7, HOLD_MS]]);
  assert.deepEqual(page.log.at(-1).slice(1), [4, 5, 'gamepad', 'none', 0.7, HOLD_MS]);
  page.state({ tick: 9, actuator: [0, 0, 0, 0, 9] });
  page.frame();
  page.frame();
  assert.deepEqual(calls.slice(1), [['reset']], 'off: one stop, then nothing');
  pads = [];
  page.frame();
  assert.deepEqual(sent.at(-1), [[], ''], 'the pad went: the server is told');
});

test('tracked hands on a rig with a browser device: the participant is told', () => {
  const page = new PageActuators({ conn: { sendActuators: () => true }, gamepads: () => [] });
  page.frame({ inputSources: [{ handedness: 'right', hand: new Map() }], inXr: true });
  assert.equal(page.notice(), '', 'no browser device on the rig (no state.actuator): nothing to say');
  page.state({ tick: 1, actuator: [0, 0, 0, 0, 1] });
  assert.match(page.notice(), /^Tracked hands have no actuator/);
});
