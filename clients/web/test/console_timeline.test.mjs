// Console cue timeline, pure part (src/console/timeline.js, src/console/history.js): state frames →
// lanes of runs; pulse trains expanded into on/off; the window of the last 10 s.
import { test, describe } from 'node:test';
import assert from 'node:assert/strict';
import { History } from '../src/console/history.js';
import { cueSample, cueValues, directionName, laneText, pulseIntervals, runsOf, timelineLanes } from '../src/console/timeline.js';

/** A state frame as the server publishes it (docs/protocol.md), with only what the timeline reads. */
const frame = (t, cues = [], contact = false) => ({ type: 'state', t, tick: Math.round(t * 1000), contact, cues,
  hip: [0, 0, 0], proxy: [0, 0, 0] });
const TILT = { kind: 'tilt', direction_deg: 90, magnitude_pct: 100 };
const PULSE = { kind: 'pulse_train', t_on_ms: 50, t_off_ms: 200, intensity_pct: 80 };

describe('cueValues', () => {
  test('each cue kind fills its lane', () => {
    const v = cueValues([{ kind: 'vibration', intensity_pct: 40 }, PULSE, TILT, { kind: 'texture', period_us: 4000 },
      { kind: 'stiffness', k_n_per_m: 500, relative: 0.6 }, { kind: 'temperature', celsius: 34.5 },
      { kind: 'friction', coefficient: 0.3 }]);
    assert.equal(v.vibration, 40);
    assert.deepEqual(v.pulse, { on: 50, off: 200, intensity: 80 });
    assert.deepEqual(v.tilt, { direction: 90, magnitude: 100 });
    assert.deepEqual(v.texture, { hz: 250, intensity: 100 });
    assert.equal(v.stiffness, 0.6);
    assert.equal(v.temperature, 34.5);
    assert.equal(v.friction, 0.3);
  });

  test('a stop cue silences everything; unknown kinds are ignored', () => {
    const v = cueValues([TILT, { kind: 'stop' }]);
    assert.equal(v.tilt, null);
    assert.equal(v.stop, true);
    assert.equal(cueValues([{ kind: 'smell', strength: 3 }]).vibration, null);
    assert.equal(cueValues(undefined).tilt, null);
  });
});

describe('runsOf', () => {
  const samples = [{ t: 0, v: null }, { t: 1, v: 5 }, { t: 2, v: 5 }, { t: 3, v: 7 }, { t: 4, v: null }, { t: 5, v: 7 }];

  test('equal consecutive values merge; null leaves a gap; the last holds until the end', () => {
    const runs = runsOf(samples, (s) => s.v, 0, 6);
    assert.deepEqual(runs.map((r) => [r.t0, r.t1, r.value]), [[1, 3, 5], [3, 4, 7], [5, 6, 7]]);
  });

  test('runs are clipped to the window but remember where they began', () => {
    const runs = runsOf(samples, (s) => s.v, 2.5, 6);
    assert.deepEqual(runs.map((r) => [r.from, r.t0, r.t1]), [[1, 2.5, 3], [3, 3, 4], [5, 5, 6]]);
  });
});

describe('pulseIntervals', () => {
  test('on for t_on, off for t_off, from the start of the cue', () => {
    const on = pulseIntervals({ from: 0, t0: 0, t1: 1, value: { on: 50, off: 200 } });
    assert.equal(on.length, 4);
    assert.deepEqual(on.map(([a, b]) => [Number(a.toFixed(3)), Number(b.toFixed(3))]),
      [[0, 0.05], [0.25, 0.3], [0.5, 0.55], [0.75, 0.8]]);
  });

  test('the phase is kept when the window cuts into a pulse', () => {
    const on = pulseIntervals({ from: 0, t0: 0.27, t1: 0.6, value: { on: 50, off: 200 } });
    assert.deepEqual(on.map(([a, b]) => [Number(a.toFixed(3)), Number(b.toFixed(3))]), [[0.27, 0.3], [0.5, 0.55]]);
  });

  test('always on, never on, and too fast to draw', () => {
    assert.deepEqual(pulseIntervals({ from: 0, t0: 0, t1: 1, value: { on: 50, off: 0 } }), [[0, 1]]);
    assert.deepEqual(pulseIntervals({ from: 0, t0: 0, t1: 1, value: { on: 0, off: 50 } }), []);
    assert.equal(pulseIntervals({ from: 0, t0: 0, t1: 1, value: { on: 5, off: 5 } }), null);
  });
});

describe('timelineLanes', () => {
  // 12 s of frames at 10 Hz: contact and a tilt from 3 s to 6 s, a pulse train from 8 s on.
  const samples = [];
  for (let i = 0; i <= 120; i++) {
    const t = 100 + i / 10;
    const cues = [];
    if (t >= 103 && t < 106) cues.push(TILT);
    if (t >= 108) cues.push(PULSE);
    samples.push(cueSample(frame(t, cues, t >= 103 && t < 106)));
  }

  test('the four main lanes always, others only when used; the last 10 s', () => {
    const lanes = timelineLanes(samples, { now: 112, windowS: 10 });
    assert.deepEqual(lanes.map((l) => l.id), ['contact', 'vibration', 'pulse', 'tilt']);
    const by = Object.fromEntries(lanes.map((l) => [l.id, l]));
    assert.equal(by.contact.runs.length, 1);
    assert.ok(Math.abs(by.contact.runs[0].t0 - 103) < 1e-9 && Math.abs(by.contact.runs[0].t1 - 106) < 1e-9);
    assert.deepEqual(by.tilt.runs[0].value, { direction: 90, magnitude: 100 });
    assert.equal(by.vibration.runs.length, 0);
    assert.equal(by.pulse.runs.length, 1);
    assert.equal(by.pulse.pulses.length, 16, '4 s of 50/200 ms pulses');
    assert.equal(by.pulse.text, '50/200 ms 80%');
    assert.equal(by.tilt.text, 'off', 'the tilt has ended by now');
    assert.ok(lanes.every((l) => l.start === 102 && l.end === 112));
  });

  test('an older window sees only what was in it', () => {
    const lanes = timelineLanes(samples.filter((s) => s.t <= 105), { now: 105, windowS: 10 });
    const tilt = lanes.find((l) => l.id === 'tilt');
    assert.equal(tilt.text, '90° R 100%');
    assert.equal(lanes.find((l) => l.id === 'pulse').runs.length, 0);
  });

  test('a texture lane appears while a texture is played', () => {
    const s = [cueSample(frame(0, [{ kind: 'texture', period_us: 2000, intensity_pct: 100 }])), cueSample(frame(1))];
    const lanes = timelineLanes(s, { now: 2, windowS: 10 });
    const tex = lanes.find((l) => l.id === 'texture');
    assert.ok(tex);
    assert.equal(tex.runs[0].value.hz, 500);
    assert.equal(tex.max, 500);
  });

  test('no samples: empty lanes', () => {
    const lanes = timelineLanes([], { windowS: 10 });
    assert.equal(lanes.length, 4);
    assert.ok(lanes.every((l) => l.runs.length === 0 && l.current === null));
  });
});

test('laneText and directionName', () => {
  assert.equal(laneText('contact', true), 'yes');
  assert.equal(laneText('contact', null), 'no');
  assert.equal(laneText('vibration', 40), '40 %');
  assert.equal(laneText('vibration', null), 'off');
  assert.equal(laneText('temperature', 34.5), '34.5 °C');
  assert.deepEqual([0, 45, 90, 180, 270, 359, -90].map(directionName), ['F', 'FR', 'R', 'B', 'L', 'F', 'L']);
});

describe('History', () => {
  test('keeps the last maxAge seconds, in time order', () => {
    const h = new History(12);
    for (let i = 0; i <= 300; i++) h.push({ t: i / 10 });
    assert.equal(h.latest.t, 30);
    assert.ok(h.items[0].t >= 17.9 && h.items[0].t <= 18, String(h.items[0].t));
    h.push({ t: 29.95 }); // late: dropped
    assert.equal(h.latest.t, 30);
  });

  test('window: the last seconds plus the sample just before them', () => {
    const h = new History(60);
    for (let i = 0; i <= 20; i++) h.push({ t: i });
    assert.deepEqual(h.window(10).map((s) => s.t), [9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20]);
    assert.deepEqual(h.window(2, 5).map((s) => s.t), [2, 3, 4, 5]);
    assert.deepEqual(new History().window(10), []);
  });

  test('a clock that jumps back (server restart) starts a new history', () => {
    const h = new History(12);
    h.push({ t: 1000 });
    h.push({ t: 1001 });
    h.push({ t: 3 });
    assert.deepEqual(h.items.map((s) => s.t), [3]);
  });

  test('bad times are ignored; the length is capped', () => {
    const h = new History(1e9, 100);
    h.push({ t: NaN });
    h.push({});
    assert.equal(h.items.length, 0);
    for (let i = 0; i < 250; i++) h.push({ t: i });
    assert.equal(h.items.length, 100);
    assert.equal(h.items[0].t, 150);
  });
});
