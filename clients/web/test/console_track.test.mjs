// The console's psychophysics track (src/console/track.js) on a constructed tracks body.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { levelText, panelShapes, panelSummary, trackPanels, SIZE } from '../src/console/track.js';

const BODY = {
  session: 'ab12',
  tasks: [
    { task: 'detect', design: '2ifc', parameter: 'intensity_pct', unit: '%', procedure: 'up-down', finished: false,
      conditions: [
        { name: 'f250', finished: false, estimate: 14.2, trials: [
          { seq: 14, level: 16.0, answer: '1', correct: false, reversal: true },
          { seq: 12, level: 20.0, answer: '2', correct: true, reversal: false },
          { seq: 13, level: 18.0, answer: '2', correct: true, reversal: false },
        ] },
        { name: 'f100', finished: true, estimate: null, trials: [] },
      ] },
  ],
};

test('one panel per task × condition, trials in seq order and numbered from 1', () => {
  const panels = trackPanels(BODY);
  assert.deepEqual(panels.map((p) => [p.task, p.condition]), [['detect', 'f250'], ['detect', 'f100']]);
  const [p] = panels;
  assert.deepEqual(p.trials.map((t) => [t.n, t.seq, t.level, t.correct, t.reversal]),
    [[1, 12, 20, true, false], [2, 13, 18, true, false], [3, 14, 16, false, true]]);
  assert.equal(p.estimate, 14.2);
  assert.equal(panels[1].finished, true);
  assert.equal(panels[1].estimate, null);
  assert.deepEqual(trackPanels(null), []);
  assert.deepEqual(trackPanels({ tasks: [] }), []);
});

test('a condition without a name is "main"; trials without a finite level are left out', () => {
  const [p] = trackPanels({ tasks: [{ task: 't', conditions: [{ trials: [{ seq: 1, level: null }, { seq: 2, level: 3 }] }] }] });
  assert.equal(p.condition, 'main');
  assert.deepEqual(p.trials.map((t) => t.seq), [2]);
});

test('shapes: a point per trial marked correct / wrong, a ring per reversal, the estimate as a dashed line', () => {
  const [p] = trackPanels(BODY);
  const shapes = panelShapes(p);
  const points = shapes.filter((s) => s.tag === 'circle' && s.attrs.class.startsWith('c-track-point'));
  assert.deepEqual(points.map((s) => s.attrs.class), ['c-track-point c-track-correct', 'c-track-point c-track-correct',
    'c-track-point c-track-wrong']);
  assert.match(points[2].title, /trial 3 \(#14\): 16 %, answer 1, wrong, reversal/);
  const rings = shapes.filter((s) => s.attrs.class === 'c-track-reversal');
  assert.equal(rings.length, 1);
  assert.equal(rings[0].attrs.cx, points[2].attrs.cx);
  const est = shapes.find((s) => s.attrs.class === 'c-track-estimate');
  assert.equal(est.title, 'current estimate 14.2 %');
  // higher levels higher up; the estimate between the levels it lies between; everything in the box
  const ys = points.map((s) => s.attrs.cy);
  assert.ok(ys[0] < ys[1] && ys[1] < ys[2]);
  assert.ok(est.attrs.y1 > ys[2]);
  for (const s of points) {
    assert.ok(s.attrs.cx >= SIZE.left && s.attrs.cx <= SIZE.width - SIZE.right);
    assert.ok(s.attrs.cy >= SIZE.top && s.attrs.cy <= SIZE.height - SIZE.bottom);
  }
  assert.equal(shapes.filter((s) => s.tag === 'polyline').length, 1);
});

test('the summary says what the chart shows (for screen readers)', () => {
  const [p, empty] = trackPanels(BODY);
  assert.equal(panelSummary(p), 'detect, f250: 3 trials, last level 16 %, 2 correct, 1 wrong, 1 reversals, '
    + 'current estimate 14.2 %');
  assert.equal(panelSummary(empty), 'detect, f100: no trials yet');
  assert.equal(panelShapes(empty).filter((s) => s.tag === 'circle').length, 0);
});

test('levelText', () => {
  assert.equal(levelText(12.3456, '%'), '12.3 %');
  assert.equal(levelText(250, 'Hz'), '250 Hz');
  assert.equal(levelText(null, '%'), '—');
});
