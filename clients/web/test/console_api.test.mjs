// Console REST client (src/console/api.js): tokens per session, plain-words errors, the control probe.
import { test, describe } from 'node:test';
import assert from 'node:assert/strict';
import { Api, ApiError, TOKEN_PREFIX, clockOffset, detailText, errorText } from '../src/console/api.js';

class MemoryStorage {
  constructor() { this.map = new Map(); }
  getItem(k) { return this.map.has(k) ? this.map.get(k) : null; }
  setItem(k, v) { this.map.set(k, String(v)); }
  removeItem(k) { this.map.delete(k); }
}

/** A fetch that answers from `routes` ("METHOD /path" → [status, body]) and records every call. */
function fakeFetch(routes) {
  const calls = [];
  const fetch = async (url, init) => {
    calls.push({ url, ...init, headers: { ...init.headers } });
    const key = `${init.method} ${url}`;
    const found = Object.entries(routes).find(([k]) => key === k || (k.endsWith('*') && key.startsWith(k.slice(0, -1))));
    if (!found) return { ok: false, status: 404, headers: new Map(), json: async () => ({ detail: `no route ${key}` }) };
    const [status, body] = typeof found[1] === 'function' ? found[1](init) : found[1];
    return { ok: status < 400, status, headers: new Map([['date', 'Sat, 21 Nov 2026 07:43:06 GMT']]),
      json: async () => body };
  };
  return { fetch, calls };
}

describe('errorText', () => {
  test('every status says what happened in plain words, with the server detail', () => {
    assert.match(errorText(409, 'trial 2 is running; the next pending trial is 3'), /^Not possible now: trial 2 is running/);
    assert.match(errorText(409, 'x'), /refreshed/);
    assert.match(errorText(422, 'answer_deg must be a number from -90 to 90, got 200'), /^Not accepted: answer_deg must be/);
    assert.match(errorText(403, 'this console does not control the session'), /does not control the session/);
    assert.match(errorText(404, "unknown session 'abc'"), /^Not found: unknown session/);
    assert.match(errorText(503, 'loop busy'), /busy/);
    assert.match(errorText(0, 'Failed to fetch'), /did not answer \(Failed to fetch\)/);
    assert.match(errorText(500, 'boom'), /Server error 500: boom/);
  });

  test("FastAPI's validation list becomes field: message", () => {
    const detail = [{ loc: ['body', 'participant'], msg: 'Field required', type: 'missing' },
      { loc: ['body', 'experimenter'], msg: 'String should have at least 1 character' }];
    assert.equal(detailText(detail), 'participant: Field required; experimenter: String should have at least 1 character');
    assert.equal(detailText('plain'), 'plain');
    assert.equal(detailText(null), '');
  });
});

describe('Api', () => {
  test('a created session keeps its token in the storage; changes send it, reads do not', async () => {
    const storage = new MemoryStorage();
    const { fetch, calls } = fakeFetch({
      'POST /api/sessions': [201, { id: 's1', token: 'tok-1', trials: [] }],
      'POST /api/sessions/s1/trials/0/start': [200, { seq: 0, status: 'running' }],
      'GET /api/sessions/s1': [200, { id: 's1' }],
      'PUT /api/sessions/s1/trials/1/responses/answer_deg': [200, { seq: 1, question: 'answer_deg', value: -10 }],
    });
    const api = new Api({ fetch, storage });
    await api.createSession({ study: 'thesis-2021', participant: 'P42', experimenter: 'alice' });
    assert.equal(storage.getItem(`${TOKEN_PREFIX}s1`), 'tok-1');
    assert.equal(api.token('s1'), 'tok-1');
    assert.deepEqual(JSON.parse(calls[0].body), { study: 'thesis-2021', participant: 'P42', experimenter: 'alice' });
    await api.start('s1', 0);
    assert.equal(calls[1].headers['X-Control-Token'], 'tok-1');
    await api.session('s1');
    assert.equal(calls[2].headers['X-Control-Token'], undefined);
    await api.answer('s1', 1, 'answer_deg', -10, 'alice');
    assert.deepEqual(JSON.parse(calls[3].body), { value: -10, entered_by: 'alice' });
    assert.equal(calls[3].method, 'PUT');
  });

  test('taking control replaces the stored token', async () => {
    const storage = new MemoryStorage();
    storage.setItem(`${TOKEN_PREFIX}s1`, 'old');
    const { fetch, calls } = fakeFetch({ 'POST /api/sessions/s1/control': [200, { token: 'new' }] });
    const api = new Api({ fetch, storage });
    assert.equal(await api.takeControl('s1', 'bob'), 'new');
    assert.equal(api.token('s1'), 'new');
    assert.deepEqual(JSON.parse(calls[0].body), { experimenter: 'bob' });
  });

  test('an error answer rejects with ApiError: status, detail and the plain-words message', async () => {
    const { fetch } = fakeFetch({
      'POST /api/sessions/s1/trials/2/start': [409, { detail: 'trial 2 is running; the next pending trial is 3' }],
    });
    const api = new Api({ fetch, storage: new MemoryStorage() });
    await assert.rejects(api.start('s1', 2), (e) => e instanceof ApiError && e.status === 409
      && e.detail.startsWith('trial 2 is running') && e.message.startsWith('Not possible now'));
  });

  test('no answer at all is status 0', async () => {
    const api = new Api({ fetch: async () => { throw new TypeError('Failed to fetch'); }, storage: new MemoryStorage() });
    await assert.rejects(api.studies(), (e) => e.status === 0 && /did not answer/.test(e.message));
  });

  test('probeControl asks GET .../control with the token: yours, or not (another console took over)', async () => {
    let answer = [200, { yours: true, controlled: true, experimenter: 'alice', since: 't' }];
    const { fetch, calls } = fakeFetch({ 'GET /api/sessions/s1/control': () => answer });
    const api = new Api({ fetch, storage: new MemoryStorage() });
    assert.equal(await api.probeControl('s1'), false, 'no token: no control, nothing asked');
    assert.equal(calls.length, 0);
    api.setToken('s1', 'tok');
    assert.equal(await api.probeControl('s1'), true);
    assert.equal(calls[0].headers['X-Control-Token'], 'tok');
    answer = [200, { yours: false, controlled: true, experimenter: 'bob', since: 't2' }];
    assert.equal(await api.probeControl('s1'), false);
    assert.equal(api.lastControl.experimenter, 'bob');
    answer = [500, { detail: 'boom' }];
    assert.equal(await api.probeControl('s1'), null, 'unknown');
  });

  test('path segments are escaped', async () => {
    const { fetch, calls } = fakeFetch({ 'GET /api/studies/*': [200, {}] });
    await new Api({ fetch, storage: new MemoryStorage() }).study('a b/c');
    assert.equal(calls[0].url, '/api/studies/a%20b%2Fc');
  });
});

describe('clockOffset', () => {
  const header = (ms) => Math.floor(ms / 1000) * 1000; // a Date header: whole seconds

  test('the same clock reads 0 even with a Date header up to 2 s stale', () => {
    for (let local = 10_000; local < 12_000; local += 37) {
      for (const stale of [0, 400, 999, 1500, 1999]) {
        assert.equal(clockOffset(header(local + 10 - stale), local, local + 20), 0, `${local} ${stale}`);
      }
    }
  });

  test('a real skew is corrected to about a second', () => {
    for (const skew of [5_000, -7_300, 3_600_000]) {
      const local = 50_123;
      const got = clockOffset(header(local + 10 + skew), local, local + 20);
      assert.ok(Math.abs(got - skew) <= 1000, `${skew} → ${got}`);
    }
  });
});

describe('access', () => {
  test('every request carries the bearer token; a 401 calls onUnauthorized', async () => {
    let token = 'adm';
    const { fetch, calls } = fakeFetch({
      'GET /api/studies': [200, []],
      'POST /api/lease': [200, { status: 'queued', position: 2, lease: {} }],
      'GET /api/auth/me': [401, { detail: 'invalid token' }],
    });
    const api = new Api({ fetch, storage: new MemoryStorage(), bearer: () => token });
    const refusals = [];
    api.onUnauthorized = (e) => refusals.push(e.status);
    await api.studies();
    assert.equal(calls[0].headers.Authorization, 'Bearer adm');
    token = 'other';
    assert.deepEqual(await api.requestLease(), { status: 'queued', position: 2, lease: {} });
    assert.equal(calls[1].headers.Authorization, 'Bearer other');
    await assert.rejects(api.me(), (e) => e.status === 401 && /^Not logged in: invalid token/.test(e.message));
    assert.deepEqual(refusals, [401]);
    token = null;
    await api.studies();
    assert.ok(!('Authorization' in calls[3].headers));
  });

  test('lease, join link and audit routes', async () => {
    const { fetch, calls } = fakeFetch({
      'DELETE /api/lease': [200, {}],
      'POST /api/lease/handover': [200, {}],
      'POST /api/lease/force-release': [200, {}],
      'POST /api/lease/renew': [200, {}],
      'POST /api/join-links': [200, { url: 'http://h/index.html?role=participant#join=c', session: 'free-1' }],
      'GET /api/audit*': [200, []],
    });
    const api = new Api({ fetch, storage: new MemoryStorage(), bearer: () => 't' });
    await api.releaseLease();
    await api.handOver('bbbb0002');
    await api.forceRelease();
    await api.renewLease();
    await api.joinLink('s1');
    await api.joinLink();
    await api.audit({ sessionId: 's1', limit: 5 });
    assert.deepEqual(calls.map((c) => `${c.method} ${c.url}`), [
      'DELETE /api/lease', 'POST /api/lease/handover', 'POST /api/lease/force-release', 'POST /api/lease/renew',
      'POST /api/join-links', 'POST /api/join-links', 'GET /api/audit?session_id=s1&limit=5']);
    assert.deepEqual(JSON.parse(calls[1].body), { token_id: 'bbbb0002' });
    assert.deepEqual(JSON.parse(calls[4].body), { session_id: 's1' });
    assert.deepEqual(JSON.parse(calls[5].body), { session_id: null });
  });

  test('429 and 401 in plain words', () => {
    assert.match(errorText(429, ''), /^Too many requests/);
    assert.match(errorText(401, ''), /log in with a token/);
  });
});
