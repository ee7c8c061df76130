// "Waiting for the experimenter" (src/waiting.js).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { waitingState } from '../src/waiting.js';

const P = { token_id: 'p1', role: 'participant', site: 'lab-a', session: 'free-ab12' };
const E = { token_id: 'e1', role: 'experimenter', site: 'lab-a', session: null };
const lease = (session, holder = 'e1') => ({ holder: holder && { token_id: holder }, queue: [], session, ttl_s: 60 });

test('a participant waits until its session is the open one', () => {
  assert.equal(waitingState({ role: 'participant', identity: P, lease: lease(null), leaseAt: 0, nowMs: 10 }).waiting, true);
  assert.match(waitingState({ role: 'participant', identity: P, lease: lease('other'), leaseAt: 0, nowMs: 10 }).reason,
    /Waiting for the experimenter/);
  assert.equal(waitingState({ role: 'participant', identity: P, lease: lease('free-ab12'), leaseAt: 0, nowMs: 10 })
    .waiting, false);
});

test('an experimenter page waits while its token does not hold the lease', () => {
  assert.equal(waitingState({ role: 'participant', identity: E, lease: lease(null, 'x9'), leaseAt: 0 }).waiting, true);
  assert.equal(waitingState({ role: 'operator', identity: E, lease: lease(null, 'e1'), leaseAt: 0 }).waiting, false);
  assert.equal(waitingState({ role: 'operator', identity: E, lease: lease(null, null), leaseAt: 0 }).waiting, true);
});

test('a forbidden error newer than the lease makes it wait for 3 s', () => {
  const base = { role: 'participant', identity: P, lease: lease('free-ab12'), leaseAt: 100 };
  assert.equal(waitingState({ ...base, forbiddenAt: 200, nowMs: 1000 }).waiting, true);
  assert.equal(waitingState({ ...base, forbiddenAt: 200, nowMs: 3300 }).waiting, false);
  assert.equal(waitingState({ ...base, leaseAt: 300, forbiddenAt: 200, nowMs: 400 }).waiting, false);
  // no lease message yet: only refusals decide
  assert.equal(waitingState({ role: 'participant', identity: P, forbiddenAt: 5, nowMs: 10 }).waiting, true);
  assert.equal(waitingState({ role: 'participant', identity: P, nowMs: 10 }).waiting, false);
});

test('observers and pages without an identity never wait', () => {
  assert.equal(waitingState({ role: 'observer', identity: P, lease: lease(null) }).waiting, false);
  assert.equal(waitingState({ role: 'participant', identity: null, lease: lease(null) }).waiting, false);
});

test('pageState: one state at a time, the question only when nothing else shows', async () => {
  const { pageState } = await import('../src/waiting.js');
  const open = lease('free-ab12');
  const live = pageState({ role: 'participant', identity: P, lease: open, leaseAt: 0, nowMs: 10, conn: { status: 'ready' } });
  assert.deepStrictEqual(live, { kind: '', text: '', showQuestion: true });
  // the lease holder's session closed while trial 4 runs: the running trial is the participant's
  // permission (docs/security.md), so the page stays live with its question
  const running = pageState({ role: 'participant', identity: P, lease: lease(null), leaseAt: 0, nowMs: 10,
    conn: { status: 'ready' }, ask: { seq: 4 } });
  assert.deepStrictEqual(running, { kind: '', text: '', showQuestion: true });
  assert.match(pageState({ role: 'participant', identity: P, lease: lease(null), conn: { status: 'ready' },
    admittedBefore: true }).text, /Waiting for the experimenter: your session was closed/);
  // the connection is down: reconnecting, not waiting
  for (const status of ['reconnecting', 'closed']) {
    assert.equal(pageState({ role: 'participant', identity: P, lease: open, conn: { status } }).kind, 'reconnecting');
  }
  assert.equal(pageState({ role: 'observer', conn: { status: 'connecting', attempt: 0 } }).kind, '');
  // refused for good, in words; never the old "open the join link" advice
  const refused = pageState({ role: 'participant', conn: { status: 'unauthorized', finalReason: 'unauthorized',
    refusal: 'unknown token' } });
  assert.equal(refused.kind, 'refused');
  assert.match(refused.text, /not admitted \(unknown token\)\. Ask the experimenter for a new join link/);
  assert.doesNotMatch(refused.text, /Open the join link/);
  // another tab of the session drives (session_taken): this one says so and only watches
  const taken = pageState({ role: 'participant', identity: { role: 'participant', session: 's1' },
    lease: { session: 's1' }, conn: { status: 'ready', watchOnly: true } });
  assert.equal(taken.kind, 'taken');
  assert.match(taken.text, /opened in another tab/);
  assert.equal(taken.showQuestion, false);
  // its session's trial runs: it may drive whoever holds the lease (no lockout, docs/security.md)
  assert.equal(pageState({ role: 'participant', identity: { role: 'participant', session: 's1' },
    lease: { session: null, holder: null }, ask: { seq: 3 }, conn: { status: 'ready' } }).kind, '');
  assert.match(pageState({ role: 'observer', conn: { finalReason: 'revoked', refusal: 'your access was revoked' } }).text,
    /^Not logged in \(your access was revoked\)/);
  assert.equal(pageState({ role: 'participant', joinError: 'This join link is not valid any more.' }).text,
    'This join link is not valid any more.');
});
