// The audit log view (src/console/audit.js).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { auditRows, auditTime, refused } from '../src/console/audit.js';

test('rows newest first, refusals marked, anonymous callers named so', () => {
  const today = new Date(2030, 0, 2, 12, 0, 0);
  const t = today.getTime() / 1000;
  const rows = auditRows([
    { id: 1, utc: t - 60, token_id: 'aa', role: 'experimenter', site: 'lab-a', action: 'lease.request', target: 'rig',
      result: 'granted', session_id: null },
    { id: 3, utc: t, token_id: null, role: null, site: null, action: 'POST /api/scenario', target: 'rig', result: '401',
      session_id: null },
    { id: 2, utc: t - 30, token_id: 'aa', role: 'experimenter', site: 'lab-a', action: 'trial.start', target: '4',
      result: 'ok', session_id: 's9' },
  ], today);
  assert.deepEqual(rows.map((r) => r.id), [3, 2, 1]);
  assert.equal(rows[0].who, 'anonymous');
  assert.equal(rows[0].refused, true);
  assert.equal(rows[1].who, 'experimenter@lab-a aa');
  assert.equal(rows[1].target, '4 · session s9');
  assert.equal(rows[1].refused, false);
  assert.equal(rows[2].refused, false);
});

test('refused: anything but ok, a 2xx or a lease grant', () => {
  for (const r of ['ok', '200', '204 no content', 'granted', 'queued']) assert.equal(refused(r), false, r);
  for (const r of ['403', 'forbidden', '409 conflict', 'error']) assert.equal(refused(r), true, r);
});

test('auditTime: time of day today, the date otherwise; ISO strings too', () => {
  const today = new Date(2030, 0, 2, 12, 0, 0);
  assert.doesNotMatch(auditTime(today.getTime() / 1000, today), /2030/);
  assert.match(auditTime(new Date(2029, 5, 1, 8, 0, 0).toISOString(), today), /^2029-06-01 /);
  assert.equal(auditTime('nonsense', today), 'nonsense');
});
