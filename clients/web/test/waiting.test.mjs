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
