// Console answer form, pure part (src/console/answers.js): question spec → field, parsing like the
// server, missing and changed answers.
import { test, describe } from 'node:test';
import assert from 'node:assert/strict';
import { changedAnswers, fieldFor, missingAnswers, parseAnswer, questionsFor, rawOf } from '../src/console/answers.js';

// Question specs as GET /api/studies/thesis-2021 returns them (trimmed).
const ANGLE = { id: 'answer_deg', kind: 'number', text: 'Which angle do you feel?', low: -90, high: 90, integer: false,
  labels: {}, choices: [], required: true };
const LEVEL = { id: 'answer_level', kind: 'number', text: 'How stiff?', low: 1, high: 10, integer: true, labels: {},
  choices: [], required: true };
const RATING = { id: 'rating', kind: 'likert', text: 'Second vs first?', low: 1, high: 7, integer: false,
  labels: { 1: 'much smoother', 4: 'same', 7: 'much rougher' }, choices: [], required: true };
const HZ = { id: 'answer_hz', kind: 'choice', text: 'Which texture is this?', low: null, high: null, integer: false,
  labels: {}, choices: [500, 333.33, 250, 200, 166.67], required: true };
const BEST = { id: 'best_pattern', kind: 'choice', text: 'Which pattern aided the most?', choices: ['P1', 'P2', 'P3',
  'all felt the same'], labels: {}, required: true };
const COMMENT = { id: 'comment', kind: 'text', text: 'Anything else?', required: false };

const STUDY = {
  tasks: [
    { id: 'contact_angle', questions: [ANGLE], end_questions: [] },
    { id: 'positioning_patterns', questions: [{ ...RATING, id: 'helpfulness' }], end_questions: [BEST, COMMENT] },
  ],
};

describe('questionsFor', () => {
  test("a trial's question ids resolve against its task's per-trial and end questions", () => {
    assert.deepEqual(questionsFor(STUDY, { task: 'contact_angle', questions: ['answer_deg'] }), [ANGLE]);
    assert.deepEqual(questionsFor(STUDY, { task: 'positioning_patterns', questions: ['best_pattern'] }), [BEST]);
    assert.deepEqual(questionsFor(STUDY, { task: 'contact_angle', questions: [] }), []);
  });

  test('an id the study does not know stays answerable as optional text', () => {
    const [q] = questionsFor(STUDY, { task: 'contact_angle', questions: ['gone'] });
    assert.deepEqual(q, { id: 'gone', kind: 'text', text: 'gone', required: false, unknown: true });
    assert.equal(questionsFor(null, { task: 'x', questions: ['a'] })[0].kind, 'text');
  });
});

describe('fieldFor', () => {
  test('likert: radio points low..high with the anchor labels', () => {
    const f = fieldFor(RATING);
    assert.equal(f.control, 'likert');
    assert.deepEqual(f.options.map((o) => o.value), [1, 2, 3, 4, 5, 6, 7]);
    assert.deepEqual(f.options.map((o) => o.anchor), ['much smoother', '', '', 'same', '', '', 'much rougher']);
    assert.equal(f.required, true);
  });

  test('number: min/max from low/high, step 1 only for whole numbers', () => {
    assert.deepEqual([fieldFor(ANGLE).min, fieldFor(ANGLE).max, fieldFor(ANGLE).step], [-90, 90, 'any']);
    assert.deepEqual([fieldFor(LEVEL).min, fieldFor(LEVEL).max, fieldFor(LEVEL).step], [1, 10, 1]);
    const open = fieldFor({ id: 'n', kind: 'number', text: 'n', low: null, high: null });
    assert.equal(open.min, null);
    assert.equal(open.max, null);
  });

  test('choice: one option per choice, numbers stay numbers; "all felt the same" is a choice', () => {
    assert.deepEqual(fieldFor(HZ).options.map((o) => o.value), [500, 333.33, 250, 200, 166.67]);
    assert.deepEqual(fieldFor(BEST).options.map((o) => o.label), ['P1', 'P2', 'P3', 'all felt the same']);
  });

  test('text, and optional questions', () => {
    const f = fieldFor(COMMENT);
    assert.equal(f.control, 'text');
    assert.equal(f.required, false);
  });
});

describe('parseAnswer', () => {
  test('numbers: range and wholeness checked as the server does, decimal comma accepted', () => {
    const angle = fieldFor(ANGLE);
    assert.deepEqual(parseAnswer(angle, '-10'), { value: -10 });
    assert.deepEqual(parseAnswer(angle, ' 12,5 '), { value: 12.5 });
    assert.deepEqual(parseAnswer(angle, '90'), { value: 90 });
    assert.match(parseAnswer(angle, '200').error, /answer_deg must be a number from -90 to 90, not "200"/);
    assert.match(parseAnswer(angle, 'abc').error, /must be a number/);
    assert.deepEqual(parseAnswer(angle, ''), { empty: true });
    const level = fieldFor(LEVEL);
    assert.deepEqual(parseAnswer(level, '7'), { value: 7 });
    assert.match(parseAnswer(level, '7.5').error, /whole number from 1 to 10/);
    assert.match(parseAnswer(fieldFor({ id: 'n', kind: 'number', text: '', low: 0 }), '-1').error, /of at least 0/);
  });

  test('likert: a whole point of the scale', () => {
    const r = fieldFor(RATING);
    assert.deepEqual(parseAnswer(r, '4'), { value: 4 });
    assert.match(parseAnswer(r, '8').error, /from 1 to 7/);
    assert.match(parseAnswer(r, '2.5').error, /whole number/);
  });

  test('choice: by label; a number choice goes out as the number', () => {
    assert.deepEqual(parseAnswer(fieldFor(HZ), '333.33'), { value: 333.33 });
    assert.deepEqual(parseAnswer(fieldFor(BEST), 'all felt the same'), { value: 'all felt the same' });
    assert.match(parseAnswer(fieldFor(BEST), 'P4').error, /one of P1, P2, P3, all felt the same/);
  });

  test('text: kept as typed, up to 2000 characters', () => {
    const c = fieldFor(COMMENT);
    assert.deepEqual(parseAnswer(c, ' felt odd '), { value: ' felt odd ' });
    assert.deepEqual(parseAnswer(c, '   '), { empty: true });
    assert.match(parseAnswer(c, 'x'.repeat(2001)).error, /at most 2000/);
  });

  test('rawOf: saved values as the inputs hold them', () => {
    assert.equal(rawOf(-10), '-10');
    assert.equal(rawOf(333.33), '333.33');
    assert.equal(rawOf(0.1 + 0.2), '0.3');
    assert.equal(rawOf(null), '');
    assert.equal(rawOf('P1'), 'P1');
    // what is saved parses back to itself
    for (const [q, v] of [[ANGLE, -10], [HZ, 166.67], [RATING, 7], [BEST, 'P2']]) {
      assert.deepEqual(parseAnswer(fieldFor(q), rawOf(v)), { value: v });
    }
  });
});

describe('missing and changed answers', () => {
  const fields = [fieldFor(BEST), fieldFor(COMMENT)];

  test('a required answer is missing unless saved or typed validly', () => {
    assert.deepEqual(missingAnswers(fields, {}, {}).map((f) => f.id), ['best_pattern']);
    assert.deepEqual(missingAnswers(fields, { best_pattern: 'P1' }, {}), []);
    assert.deepEqual(missingAnswers(fields, {}, { best_pattern: 'P2' }), []);
    assert.deepEqual(missingAnswers(fields, {}, { best_pattern: 'P9' }).map((f) => f.id), ['best_pattern']);
    assert.deepEqual(missingAnswers(fields, { best_pattern: 'P1' }, { best_pattern: '' }).map((f) => f.id),
      ['best_pattern'], 'cleared in the form');
  });

  test('changedAnswers: only drafts that differ from what is saved, bad ones with their error', () => {
    const angle = [fieldFor(ANGLE)];
    assert.deepEqual(changedAnswers(angle, { answer_deg: -10 }, { answer_deg: '-10' }), []);
    assert.deepEqual(changedAnswers(angle, { answer_deg: -10 }, { answer_deg: '-10.0' }), []);
    const [c] = changedAnswers(angle, { answer_deg: -10 }, { answer_deg: '20' });
    assert.deepEqual(c.parsed, { value: 20 });
    assert.ok(changedAnswers(angle, {}, { answer_deg: '200' })[0].parsed.error);
    assert.deepEqual(changedAnswers(angle, {}, { answer_deg: '' }), [], 'nothing typed: nothing to send');
    assert.deepEqual(changedAnswers(angle, {}, {}), []);
  });
});
