import { test } from 'node:test';
import assert from 'node:assert/strict';
import { ContactPrediction, CONFIRM_GRACE_MS } from '../src/xr_predict.js';
import { drawnHand } from '../src/xr_hands.js';
import { Blend } from '../src/xr_interp.js';

const ME = 7;
const tip = 'right.index.tip';
const tool = (contact, extra = {}) => [{ name: tip, contact, lost: false, proxy: [0, 0, 0.66], ...extra }];

test('a guess is drawn from the frame it starts in, and dropped when the finger is free', () => {
  const p = new ContactPrediction();
  assert.deepEqual(p.frame({ [tip]: null }, 1, 0), {});
  assert.deepEqual(p.frame({ [tip]: [0, 0, 0.66] }, 2, 10), { [tip]: [0, 0, 0.66] });
  assert.deepEqual(p.frame({ [tip]: null }, 3, 20), {});
  assert.equal(p.episodes.size, 0);
});

test('states older than the guess, or within the grace, do not turn it down', () => {
  const p = new ContactPrediction();
  p.frame({ [tip]: [0, 0, 0.66] }, 5, 100);
  p.state(tool(false), [ME, 4], ME, 101); // the server has not seen sample 5 yet
  p.state(tool(false), null, ME, 102); // nobody drives yet
  p.state(tool(false), [ME, 5], ME, 100 + CONFIRM_GRACE_MS - 1); // seen, but the gate may be waiting out its dwell
  assert.deepEqual(p.frame({ [tip]: [0, 0, 0.65] }, 6, 120), { [tip]: [0, 0, 0.65] });
});

test('the server saying no contact for a sample it has seen, after the grace, drops the guess until the finger leaves', () => {
  const p = new ContactPrediction();
  p.frame({ [tip]: [0, 0, 0.66] }, 5, 100);
  p.state(tool(false), [ME, 6], ME, 100 + CONFIRM_GRACE_MS);
  assert.deepEqual(p.frame({ [tip]: [0, 0, 0.66] }, 7, 160), {});
  p.frame({ [tip]: null }, 8, 170); // out of the body
  assert.deepEqual(p.frame({ [tip]: [0, 0, 0.66] }, 9, 180), { [tip]: [0, 0, 0.66] }, 'a new stay inside guesses again');
});

test('a confirmed contact keeps the guess; a lost tool or another driver drops it', () => {
  const p = new ContactPrediction();
  p.frame({ [tip]: [0, 0, 0.66] }, 5, 100);
  p.state(tool(true), [ME, 5], ME, 200);
  assert.ok(tip in p.frame({ [tip]: [0, 0, 0.66] }, 6, 210));
  p.state(tool(false, { lost: true }), [ME, 6], ME, 211);
  assert.deepEqual(p.frame({ [tip]: [0, 0, 0.66] }, 7, 220), {});
  const q = new ContactPrediction();
  q.frame({ [tip]: [0, 0, 0.66] }, 5, 100);
  q.state(tool(false), [ME + 1, 99], ME, 101);
  assert.deepEqual(q.frame({ [tip]: [0, 0, 0.66] }, 6, 110), {});
});

test('drawn hand: the server\'s proxy wins over a guess; a guess holds a fingertip the server does not yet', () => {
  const local = { [tip]: [0, 0, 0.6], 'right.thumb.tip': [0, -0.2, 0.8] };
  const guess = { [tip]: [0, 0, 0.66] };
  const d = drawnHand(local, tool(false, { proxy: [0, 0, 0.9] }), guess);
  assert.deepEqual(d.points[tip], [0, 0, 0.66]);
  assert.deepEqual([d.held, d.predicted], [[tip], [tip]]);
  const s = drawnHand(local, tool(true, { proxy: [0, 0.01, 0.66] }), guess);
  assert.deepEqual(s.points[tip], [0, 0.01, 0.66]);
  assert.deepEqual([s.held, s.predicted], [[tip], []]);
  assert.deepEqual(drawnHand(local, tool(false)).held, []);
});

test('blend: the server\'s proxy arriving after a guess blends from the guess', () => {
  const b = new Blend(8);
  b.push({ p: [0, 0, 1] }, 0);
  b.sample(0);
  b.drawnAs('p', [0, 0, 0.6]);
  b.push({ p: [0, 0.08, 0.6] }, 10);
  assert.deepEqual(b.sample(10).p, [0, 0, 0.6]);
  assert.deepEqual(b.sample(14).p, [0, 0.04, 0.6]);
  assert.deepEqual(b.sample(18).p, [0, 0.08, 0.6]);
});
