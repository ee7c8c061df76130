// The console's tracker card: health rows, the calibration pairs and bodies, capture warnings.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { DEFAULT_MARKS, calibrationBody, capturedPoint, pairsReady, sourceRows } from '../src/console/trackers.js';

test('a health row says status, rate, age, gaps and why', () => {
  const [row] = sourceRows([{ name: 'leap', kind: 'leap', status: 'degraded', rate_hz: 54, nominal_hz: 110,
    age_ms: 12.4, gaps: 2, longest_gap_ms: 480, confidence: 0.91, reasons: ['rate 54/s below half of 110/s'],
    note: 'connected', calibration: { method: 'points', residual: 0.0021 } }]);
  assert.equal(row.status, 'degraded');
  assert.equal(row.rate, '54 / 110 Hz');
  assert.equal(row.age, '12 ms');
  assert.equal(row.gaps, '2 (longest 480 ms)');
  assert.equal(row.confidence, '0.91');
  assert.equal(row.why, 'rate 54/s below half of 110/s; connected');
  assert.equal(row.calibration, 'points, residual 2.1·10⁻³');
  assert.equal(sourceRows([{ name: 'x', status: 'lost', age_ms: null }])[0].age, 'never');
});

test('a points fit needs three captured marks', () => {
  const caps = [[1, 2, 3], undefined, [4, 5, 6]];
  assert.equal(pairsReady(DEFAULT_MARKS, caps).ready, false);
  caps[1] = [7, 8, 9];
  const { pairs, ready } = pairsReady(DEFAULT_MARKS, caps);
  assert.ok(ready);
  assert.deepEqual(pairs[1], { source: [7, 8, 9], scene: DEFAULT_MARKS[1].scene });
  assert.deepEqual(calibrationBody('points', pairs).pairs.length, 3);
  assert.deepEqual(calibrationBody('hold', pairs), { method: 'hold', pairs: [pairs[0]] });
});

test('a capture with a moving finger warns', () => {
  const still = capturedPoint({ units: 'mm', points: { 'right.index.tip': { mean: [1, 2, 3], spread: 0.5 } } });
  assert.deepEqual(still, { point: [1, 2, 3], warning: '' });
  const moved = capturedPoint({ units: 'mm', points: { 'right.index.tip': { mean: [1, 2, 3], spread: 6 } } });
  assert.match(moved.warning, /moved 6\.0 mm/);
  assert.equal(capturedPoint({ points: {} }).point, null);
});
