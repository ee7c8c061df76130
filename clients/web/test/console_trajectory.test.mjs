// Console trajectory plot, pure part (src/console/trajectory.js): views, windowing, bounds with
// hysteresis, projection at equal scale.
import { test, describe } from 'node:test';
import assert from 'node:assert/strict';
import { VIEWS, fitBounds, niceLength, projector, toView, trajSample, windowed } from '../src/console/trajectory.js';

describe('views (scene frame: x toward the viewer, y right, z up)', () => {
  test('side: y right, z up; top: y right, x toward the viewer pointing down', () => {
    assert.deepEqual(toView([0.1, 0.2, 0.3], VIEWS.side), [0.2, 0.3]);
    assert.deepEqual(toView([0.1, 0.2, 0.3], VIEWS.top), [0.2, -0.1]);
  });

  test('trajSample keeps time, HIP, proxy and contact of a state frame', () => {
    const s = trajSample({ type: 'state', t: 5, hip: [0, 0.3, 0.45], proxy: [0, 0.25, 0.4], contact: true, cues: [] });
    assert.deepEqual(s, { t: 5, hip: [0, 0.3, 0.45], proxy: [0, 0.25, 0.4], contact: true });
  });
});

test('windowed: the samples of the last seconds', () => {
  const samples = Array.from({ length: 30 }, (_, i) => ({ t: i }));
  assert.deepEqual(windowed(samples, 29, 10).map((s) => s.t), [19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29]);
  assert.deepEqual(windowed(samples, 5, 2).map((s) => s.t), [3, 4, 5]);
});

describe('fitBounds', () => {
  test('holds every point with a margin and a minimum span', () => {
    const b = fitBounds([[0, 0], [1, 0.1]], null, { minSpan: 0.5, pad: 0.1 });
    assert.ok(b.h0 < 0 && b.h1 > 1);
    assert.ok(Math.abs((b.h1 - b.h0) - 1.2) < 1e-9);
    assert.ok(Math.abs((b.v1 - b.v0) - 0.6) < 1e-9, 'the 0.1 high cloud gets the 0.5 minimum, padded');
    assert.ok(Math.abs((b.v0 + b.v1) / 2 - 0.05) < 1e-9, 'centred on the points');
  });

  test('no points: a default box, or the previous bounds', () => {
    const b = fitBounds([], null, { minSpan: 0.5 });
    assert.deepEqual(b, { h0: -0.25, h1: 0.25, v0: -0.25, v1: 0.25 });
    assert.equal(fitBounds([], b), b);
  });

  test('hysteresis: steady while the points fit and fill a fair part, grows at once, shrinks late', () => {
    const prev = fitBounds([[0, 0], [1, 1]]);
    assert.equal(fitBounds([[0.2, 0.2], [0.8, 0.7]], prev), prev, 'inside and using most of it: unchanged');
    const grown = fitBounds([[0, 0], [2, 1]], prev);
    assert.ok(grown.h1 > 2, 'a point outside grows the bounds');
    const shrunk = fitBounds([[0.5, 0.5], [0.52, 0.51]], prev);
    assert.ok(shrunk.h1 - shrunk.h0 < prev.h1 - prev.h0, 'a small cloud in big bounds shrinks them');
  });
});

describe('projector', () => {
  test('equal scale on both axes, centred, v up', () => {
    const { map, scale } = projector({ h0: 0, h1: 2, v0: 0, v1: 1 }, 220, 220, 10);
    assert.equal(scale, 100);
    assert.deepEqual(map([1, 0.5]), [110, 110], 'the centre of the bounds is the centre of the canvas');
    assert.deepEqual(map([0, 0]), [10, 160]);
    assert.deepEqual(map([2, 1]), [210, 60], 'up is up');
  });
});

test('niceLength: 1, 2 or 5 times a power of ten', () => {
  assert.equal(niceLength(0.27), 0.2);
  assert.equal(niceLength(0.07), 0.05);
  assert.equal(niceLength(1.9), 1);
  assert.equal(niceLength(3), 2);
  assert.equal(niceLength(0), 1);
});

describe('several tools (state.tools, a thumb besides the index)', async () => {
  const { drawTrajectory, otherTrails } = await import('../src/console/trajectory.js');
  const THUMB = 'right.thumb.tip';
  const frame = (t, contact) => ({ t, hip: [0, 0.2, 0.5], proxy: [0, 0.2, 0.5], contact: false,
    tools: [{ name: 'right.index.tip', hip: [0, 0.2, 0.5], proxy: [0, 0.2, 0.5], contact: false, lost: false },
      { name: THUMB, hip: [0, -0.1 * t, 0.4], proxy: [0, -0.1 * t, 0.4], contact, lost: false }] });

  test('trajSample keeps the other tools, otherTrails gathers each one\'s trail', () => {
    const samples = [trajSample(frame(1, false)), trajSample(frame(2, true))];
    assert.deepEqual(samples[1].others, [{ name: THUMB, hip: [0, -0.2, 0.4], contact: true }]);
    assert.deepEqual([...otherTrails(samples).get(THUMB)].map((p) => [p.t, p.contact]), [[1, false], [2, true]]);
    assert.equal(trajSample({ t: 0, hip: [0, 0, 0], proxy: [0, 0, 0], tools: [frame(0).tools[0]] }).others, undefined,
      'one tool: the sample is as before');
  });

  test('the thumb\'s trail and dot are drawn in its colour, thicker in contact', () => {
    const strokes = [];
    const fills = [];
    let path = [];
    const ctx = {
      clearRect() {}, fillRect() {}, fillText() {}, setLineDash() {}, arc(x, y) { path.push([x, y]); },
      beginPath() { path = []; }, moveTo(x, y) { path.push([x, y]); }, lineTo(x, y) { path.push([x, y]); },
      stroke() { strokes.push({ color: this.strokeStyle, width: this.lineWidth }); },
      fill() { fills.push(this.fillStyle); },
    };
    const samples = [1, 2, 3].map((t) => trajSample(frame(t, t === 3)));
    drawTrajectory(ctx, samples, VIEWS.side, { width: 200, height: 100, now: 3 });
    const thumb = strokes.filter((s) => s.color === '#35c4e8');
    assert.deepEqual(thumb.map((s) => s.width), [1.5, 3]);
    assert.ok(fills.includes('#35c4e8'), 'the newest thumb position is a dot');
  });
});
