// The lease card's view model (src/console/lease.js): standing, actions, renew interval.
import { test, describe } from 'node:test';
import assert from 'node:assert/strict';
import { standing, leaseView, leaseSummary, renewIntervalMs, remainingS } from '../src/console/lease.js';

const A = { token_id: 'aaaa0001', role: 'experimenter', site: 'lab-a', label: 'alice' };
const B = { token_id: 'bbbb0002', role: 'experimenter', site: 'lab-b', label: '' };
const ADMIN = { token_id: 'adad0003', role: 'admin', site: null, label: 'env' };
const OBS = { token_id: 'obob0004', role: 'observer', site: null, label: '' };

const held = (holder, queue = [], extra = {}) => ({
  holder: holder && { ...holder, since: 100, expires_at: 1060 },
  queue: queue.map((q, i) => ({ ...q, position: i + 1 })),
  session: null,
  ttl_s: 60,
  ...extra,
});

describe('standing', () => {
  test('from token ids when the snapshot does not say (the lease message)', () => {
    assert.deepEqual(standing(held(A, [B]), A), { you: 'holder', position: null });
    assert.deepEqual(standing(held(A, [ADMIN, B]), B), { you: 'queued', position: 2 });
    assert.deepEqual(standing(held(A, [B]), ADMIN), { you: 'none', position: null });
    assert.deepEqual(standing(null, A), { you: 'none', position: null });
  });

  test('GET /api/lease says it itself', () => {
    assert.deepEqual(standing({ ...held(A, [B]), you: 'queued', position: 1 }, null), { you: 'queued', position: 1 });
  });
});

describe('leaseView', () => {
  test('the holder may release, hand over to each queued token and make join links', () => {
    const v = leaseView(held(A, [B]), A, { nowMs: 1030_000 });
    assert.equal(v.you, 'holder');
    assert.equal(v.holder.who, 'alice (aaaa0001)');
    assert.equal(v.holder.remainingS, 30);
    assert.deepEqual(v.queue.map((q) => [q.tokenId, q.position, q.handOver]), [['bbbb0002', 1, true]]);
    assert.deepEqual(v.actions, { request: false, release: true, leave: false, renew: true, forceRelease: false,
      joinLink: true });
    assert.equal(leaseSummary(v), 'You control the rig');
  });

  test('a queued experimenter may leave and renews; it cannot hand over', () => {
    const v = leaseView(held(A, [B]), B, { nowMs: 0 });
    assert.equal(v.you, 'queued');
    assert.equal(v.queue[0].mine, true);
    assert.equal(v.queue[0].handOver, false);
    assert.deepEqual(v.actions, { request: false, release: false, leave: true, renew: true, forceRelease: false,
      joinLink: false });
    assert.equal(leaseSummary(v), 'alice (aaaa0001) controls the rig · you are #1 in the queue');
  });

  test('an admin outside may request and force release; an observer may do nothing', () => {
    const admin = leaseView(held(A), ADMIN, { nowMs: 0 }).actions;
    assert.equal(admin.request, true);
    assert.equal(admin.forceRelease, true);
    assert.equal(admin.renew, false);
    const obs = leaseView(held(A), OBS, { nowMs: 0 }).actions;
    assert.deepEqual(Object.values(obs).filter(Boolean), []);
  });

  test('nobody holding: request offered, no force release, summary says so', () => {
    const v = leaseView(held(null), ADMIN, { nowMs: 0 });
    assert.equal(v.holder, null);
    assert.equal(v.actions.request, true);
    assert.equal(v.actions.forceRelease, false);
    assert.equal(leaseSummary(v), 'Nobody controls the rig');
  });

  test('the open participant session is shown', () => {
    assert.equal(leaseView(held(A, [], { session: 'free-ab12' }), A).session, 'free-ab12');
  });
});

test('renewIntervalMs: a quarter of the time to live, within 1 s .. 60 s', () => {
  assert.equal(renewIntervalMs(60), 15_000);
  assert.equal(renewIntervalMs(2), 1000);
  assert.equal(renewIntervalMs(86400), 60_000);
  assert.equal(renewIntervalMs(undefined), 15_000);
});

test('remainingS uses the server clock offset and never goes below 0', () => {
  assert.equal(remainingS(100, 90_000, 0), 10);
  assert.equal(remainingS(100, 90_000, 5_000), 5);
  assert.equal(remainingS(100, 200_000, 0), 0);
  assert.equal(remainingS(null, 0), null);
});

test('a Release that closes the open participant session mid-trial is warned about, before and after', async () => {
  const { releaseWarning, closedWarning } = await import('../src/console/lease.js');
  const open = { holder: { token_id: 'a' }, queue: [], session: 's1' };
  const closed = { holder: null, queue: [], session: null };
  assert.match(releaseWarning(open, 's1', 3), /closes participant session s1 while trial #3 runs/);
  assert.equal(releaseWarning(open, 's1', null), null); // no trial runs
  assert.equal(releaseWarning(open, 's2', 3), null); // another session
  assert.equal(releaseWarning(closed, 's1', 3), null);
  assert.match(closedWarning(open, closed, 's1', 3), /s1 was closed while trial #3 runs/);
  assert.equal(closedWarning(open, open, 's1', 3), null);
  assert.equal(closedWarning(open, closed, 's1', null), null);
});
