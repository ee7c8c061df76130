// pacing.js: what the participant's page shows of a participant-paced task, the answer keys, and
// a stimulus scenario's interval marks.
import { test } from 'node:test';
import assert from 'node:assert/strict';

import { CONTINUE_QUESTION, OnsetWatch, answerForKey, continueQuestion, intervalMarks, pacingLines, pacingView,
  wordKeyFor } from '../src/pacing.js';
import { questionOf } from '../src/xr_panels.js';

const ask = (choices, pacing = null) => ({ session: 's', seq: 4, task: 't', pacing,
  questions: [{ id: 'response', kind: 'choice', text: 'Which?', choices, answer: null }] });

test('progress counts the trial being answered; the states read as sentences', () => {
  assert.deepEqual(pacingView({ state: 'trial', done: 2, total: 20, feedback: null }),
    { progress: 'Trial 3 of 20', text: '', feedback: null, continue: false });
  assert.equal(pacingView({ state: 'next', done: 3, total: 20 }).progress, 'Trial 3 of 20');
  assert.equal(pacingView({ state: 'paused', done: 3, total: 20 }).text, 'Paused by the experimenter.');
  const brk = pacingView({ state: 'break', done: 10, total: 20, feedback: null });
  assert.equal(brk.continue, true);
  assert.match(brk.text, /Break: 10 of 20 done/);
  assert.equal(pacingView(null), null);
});

test('feedback shows correct or wrong only in the feedback state', () => {
  assert.deepEqual(pacingView({ state: 'feedback', done: 1, total: 4, feedback: 'correct' }),
    { progress: 'Trial 1 of 4', text: 'Correct', feedback: 'correct', continue: false });
  assert.equal(pacingView({ state: 'feedback', done: 1, total: 4, feedback: 'wrong' }).text, 'Wrong');
  assert.equal(pacingView({ state: 'next', done: 1, total: 4, feedback: 'wrong' }).feedback, null);
});

test('digits choose the nth choice, y/n and s/d the choice of that meaning', () => {
  assert.equal(answerForKey(questionOf(ask(['1', '2'])), '2'), '2');
  assert.equal(answerForKey(questionOf(ask(['left', 'right'])), '1'), 'left');
  assert.equal(answerForKey(questionOf(ask(['1', '2'])), '3'), undefined);
  assert.equal(answerForKey(questionOf(ask(['yes', 'no'])), 'n'), 'no');
  assert.equal(answerForKey(questionOf(ask(['yes', 'no'])), 'Y'), 'yes');
  assert.equal(answerForKey(questionOf(ask(['same', 'different'])), 'd'), 'different');
  assert.equal(answerForKey(questionOf(ask(['same', 'different'])), 'y'), undefined);
  assert.equal(answerForKey(null, '1'), undefined);
  const likert = questionOf({ seq: 1, questions: [{ id: 'r', kind: 'likert', text: 'R', low: 1, high: 7, answer: null }] });
  assert.equal(answerForKey(likert, '7'), 7);
  assert.equal(wordKeyFor({ label: 'Same' }), 's');
});

test('a break is a one-button panel in XR that sends the continue answer', () => {
  assert.equal(continueQuestion({ state: 'trial' }), null);
  const q = continueQuestion({ state: 'break', done: 2, total: 4 });
  assert.equal(q.id, CONTINUE_QUESTION);
  assert.deepEqual(q.items, [{ label: 'Continue', value: 1 }]);
  assert.deepEqual(pacingLines({ state: 'paused', done: 2, total: 4 }), ['Trial 2 of 4', 'Paused by the experimenter.']);
  assert.deepEqual(pacingLines(null), []);
});

test('interval marks light the interval on, and each onset is seen once', () => {
  assert.equal(intervalMarks({ a: 1 }), null);
  assert.deepEqual(intervalMarks({ interval: 2, n_intervals: 2, stage: 'interval' }), { n: 2, on: 2, respond: false });
  assert.deepEqual(intervalMarks({ interval: 0, n_intervals: 2, stage: 'respond' }), { n: 2, on: 0, respond: true });
  const w = new OnsetWatch();
  const frames = [0, 1, 1, 0, 2, 2, 0].map((k) => w.update(intervalMarks({ interval: k, n_intervals: 2, stage: 'x' })));
  assert.deepEqual(frames, [false, true, false, false, true, false, false]);
});
