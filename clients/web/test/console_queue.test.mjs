// Console trial queue, pure part (src/console/queue.js): rows, highlights, allowed actions, text.
import { test, describe } from 'node:test';
import assert from 'node:assert/strict';
import { formatAnswers, formatParams, formatValue, progress, queueRows, trialBySeq, trialName } from '../src/console/queue.js';

const trial = (seq, kind, index, status, extra = {}) => ({
  seq, task: 'contact_angle', kind, index, status, attempt: status === 'pending' ? 0 : 1, params: {},
  questions: kind === 'training' ? [] : ['answer_deg'], responses: {}, reason: '', ...extra,
});

// The shape of GET /api/sessions/{id} (trimmed): training answered, practice 1 answered, practice 2
// running, practice 3 aborted then retried (pending again), a main trial excluded.
const SESSION = {
  id: 's1', next: 3, running: 2,
  trials: [
    trial(0, 'training', 0, 'answered'),
    trial(1, 'trial', 0, 'answered', { params: { angle_deg: -10, time_limit_s: 30 }, responses: { answer_deg: -10 } }),
    trial(2, 'trial', 1, 'running', { params: { angle_deg: -90, time_limit_s: 30 } }),
    trial(3, 'trial', 2, 'pending', { attempt: 1, reason: 'retry' }),
    trial(4, 'main', 0, 'aborted', { reason: 'participant sneezed' }),
    trial(5, 'main', 1, 'excluded', { reason: 'outlier', responses: { answer_deg: 50 } }),
  ],
};

describe('queueRows', () => {
  const rows = queueRows(SESSION);

  test('one row per trial with what the table shows', () => {
    assert.equal(rows.length, 6);
    assert.deepEqual(rows.map((r) => r.kindLabel), ['training', 'practice', 'practice', 'practice', 'main', 'main']);
    assert.equal(rows[1].params, 'angle_deg -10 · time_limit_s 30');
    assert.equal(rows[1].answers, 'answer_deg = -10');
    assert.equal(rows[3].attempt, 1);
    assert.equal(rows[4].reason, 'participant sneezed');
  });

  test('the next and the running trial are marked', () => {
    assert.deepEqual(rows.filter((r) => r.isNext).map((r) => r.seq), [3]);
    assert.deepEqual(rows.filter((r) => r.isRunning).map((r) => r.seq), [2]);
  });

  test('actions follow the lifecycle: answers to running/answered, retry aborted, exclude answered/aborted', () => {
    const by = Object.fromEntries(rows.map((r) => [r.seq, r]));
    assert.deepEqual([0, 1, 2, 3, 4, 5].map((s) => by[s].canAnswer), [false, true, true, false, false, false]);
    assert.deepEqual([0, 1, 2, 3, 4, 5].map((s) => by[s].canRetry), [false, false, false, false, true, false]);
    assert.deepEqual([0, 1, 2, 3, 4, 5].map((s) => by[s].canExclude), [true, true, false, false, true, false]);
  });

  test('an empty or missing session gives no rows', () => {
    assert.deepEqual(queueRows(null), []);
    assert.deepEqual(queueRows({ trials: [] }), []);
  });
});

describe('formatting', () => {
  test('values: no float noise, null as a dash', () => {
    assert.equal(formatValue(0.1 + 0.2), '0.3');
    assert.equal(formatValue(-10), '-10');
    assert.equal(formatValue(null), '–');
    assert.equal(formatValue('P1'), 'P1');
    assert.equal(formatValue([1, 2]), '[1,2]');
  });

  test('params leave out null ones', () => {
    assert.equal(formatParams({ period_us: 6000, second_period_us: null }), 'period_us 6000');
    assert.equal(formatParams({}), '');
    assert.equal(formatParams(undefined), '');
  });

  test('answers in the question order, then others', () => {
    assert.equal(formatAnswers({ better_by: 3, better_mode: 'no vibration at target' }, ['better_mode', 'better_by']),
      'better_mode = no vibration at target · better_by = 3');
    assert.equal(formatAnswers({ extra: 1, a: 2 }, ['a']), 'a = 2 · extra = 1');
    assert.equal(formatAnswers({}, ['a']), '');
  });

  test('trial names count from 1, as people do', () => {
    assert.equal(trialName(trialBySeq(SESSION, 2)), '#2 contact_angle · practice 2');
    assert.equal(trialName(null), '');
    assert.equal(trialBySeq(SESSION, 99), null);
  });
});

test('progress counts statuses; answered, aborted and excluded are done', () => {
  assert.deepEqual(progress(SESSION), { pending: 1, running: 1, answered: 2, aborted: 1, excluded: 1, total: 6, done: 4 });
  assert.equal(progress(null).total, 0);
});
