// An `ask` message (protocol v1.5) becomes the question the XR panel and the desktop page show.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { choiceLayout, questionOf } from '../src/xr_panels.js';

const likert = { id: 'sharpness', kind: 'likert', text: 'How sharp?', low: 1, high: 7, labels: { 1: 'blunt', 7: 'sharp' },
  choices: [], answer: null };
const ask = (questions, seq = 4) => ({ session: 's', seq, task: 't', questions, audio: {}, instructions: '' });

test('the first unanswered question of the running trial, with its seq', () => {
  const q = questionOf(ask([likert]));
  assert.deepEqual(q, { id: 'sharpness', text: 'How sharp?', seq: 4, kind: 'likert', low: 1, high: 7,
    labels: { 1: 'blunt', 7: 'sharp' } });
  assert.deepEqual(choiceLayout(q).map((b) => [b.value, b.anchor]).slice(0, 2), [[1, 'blunt'], [2, null]]);
  const answered = { ...likert, answer: 5 };
  const choice = { id: 'which', kind: 'choice', text: 'Which?', choices: ['P1', 500], answer: null };
  assert.deepEqual(questionOf(ask([answered, choice])).items, [{ label: 'P1', value: 'P1' }, { label: '500', value: 500 }]);
  assert.equal(questionOf(ask([answered])), null);
  assert.equal(questionOf(ask([likert], null)), null); // nothing runs
  assert.equal(questionOf(null), null);
});

test('a number question is the angle pointed at, within its bounds', () => {
  const q = questionOf(ask([{ id: 'angle_deg', kind: 'number', text: 'Angle?', low: -90, high: 90, answer: null }]));
  assert.deepEqual([q.kind, q.low, q.high, q.seq], ['angle', -90, 90, 4]);
});
