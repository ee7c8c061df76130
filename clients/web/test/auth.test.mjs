// Token store, login/join codes in the fragment, the exchange (src/auth.js).
import { test, describe } from 'node:test';
import assert from 'node:assert/strict';
import { TokenStore, TOKEN_KEY, JOIN_TOKEN_KEY, takeCode, authHeaders, exchangeCode, redeemFragment, whoText }
  from '../src/auth.js';

class MemoryStorage {
  constructor() { this.map = new Map(); }
  getItem(k) { return this.map.has(k) ? this.map.get(k) : null; }
  setItem(k, v) { this.map.set(k, String(v)); }
  removeItem(k) { this.map.delete(k); }
}
class BrokenStorage {
  getItem() { throw new Error('denied'); }
  setItem() { throw new Error('denied'); }
  removeItem() { throw new Error('denied'); }
}

function answer(status, body) {
  return { ok: status < 400, status, json: async () => body };
}

describe('TokenStore', () => {
  test('the console token in local storage, the join token in session storage', () => {
    const local = new MemoryStorage();
    const session = new MemoryStorage();
    const store = new TokenStore({ local, session });
    assert.equal(store.token, null);
    store.save('adm');
    store.saveJoin('par');
    assert.equal(local.getItem(TOKEN_KEY), 'adm');
    assert.equal(session.getItem(JOIN_TOKEN_KEY), 'par');
    assert.equal(local.getItem(JOIN_TOKEN_KEY), null);
    assert.equal(store.forRole('participant'), 'par'); // a join link wins on the participant page
    assert.equal(store.forRole('observer'), 'adm');
    assert.equal(store.forRole('operator'), 'adm');
    store.clear();
    assert.equal(store.token, null);
    assert.equal(store.forRole('participant'), 'par');
  });

  test('a participant page without a join token uses the console token of this browser', () => {
    const store = new TokenStore({ local: new MemoryStorage(), session: new MemoryStorage() });
    store.save('adm');
    assert.equal(store.forRole('participant'), 'adm');
  });

  test('storage that throws keeps the token for the page only', () => {
    const store = new TokenStore({ local: new BrokenStorage(), session: new BrokenStorage() });
    store.save('t1');
    assert.equal(store.token, 't1');
    assert.equal(store.joinToken, null);
    store.clear();
    assert.equal(store.token, null);
  });
});

describe('takeCode', () => {
  test('takes a login or join code out of the fragment and keeps the rest', () => {
    assert.deepEqual(takeCode('#login=abc_DEF-12'), { kind: 'login', code: 'abc_DEF-12', rest: '' });
    assert.deepEqual(takeCode('#session=S1&join=xyz'), { kind: 'join', code: 'xyz', rest: '#session=S1' });
    assert.deepEqual(takeCode('#session=S1'), { kind: null, code: null, rest: '#session=S1' });
    assert.deepEqual(takeCode(''), { kind: null, code: null, rest: '' });
  });

  test('a malformed code is dropped, never exchanged', () => {
    assert.deepEqual(takeCode('#login=a%20b'), { kind: null, code: null, rest: '' });
    assert.deepEqual(takeCode('#login='), { kind: null, code: null, rest: '' });
  });

  test('a kind the page does not take stays in the fragment', () => {
    assert.deepEqual(takeCode('#join=abc', ['login']), { kind: null, code: null, rest: '#join=abc' });
  });
});

test('authHeaders: a bearer header only with a token', () => {
  assert.deepEqual(authHeaders('t'), { Authorization: 'Bearer t' });
  assert.deepEqual(authHeaders(null), {});
  assert.deepEqual(authHeaders(''), {});
});

describe('exchangeCode', () => {
  test('POSTs the code in the body (not the URL) and returns the token and identity', async () => {
    const calls = [];
    const fetch = async (url, init) => {
      calls.push({ url, init });
      return answer(200, { token: 'tok', identity: { token_id: 'ab12cd34', role: 'admin' } });
    };
    const out = await exchangeCode('login', 'CODE1', { base: 'http://h:1', fetch });
    assert.deepEqual(out, { token: 'tok', identity: { token_id: 'ab12cd34', role: 'admin' } });
    assert.equal(calls[0].url, 'http://h:1/api/auth/login');
    assert.equal(calls[0].init.method, 'POST');
    assert.deepEqual(JSON.parse(calls[0].init.body), { code: 'CODE1' });
    assert.ok(!calls[0].url.includes('CODE1'));
  });

  test('a used or expired code says so in words; no answer too', async () => {
    await assert.rejects(exchangeCode('join', 'c', { fetch: async () => answer(401, { detail: 'unknown code' }) }),
      (e) => e.status === 401 && /join link is not valid any more/.test(e.message));
    await assert.rejects(exchangeCode('login', 'c', { fetch: async () => answer(429, {}) }),
      (e) => e.status === 429 && /Too many attempts/.test(e.message));
    await assert.rejects(exchangeCode('login', 'c', { fetch: async () => { throw new Error('offline'); } }),
      (e) => e.status === 0 && /did not answer \(offline\)/.test(e.message));
    await assert.rejects(exchangeCode('login', 'c', { fetch: async () => answer(200, { nope: 1 }) }),
      (e) => /could not be used/.test(e.message));
  });
});

describe('redeemFragment', () => {
  const loc = (hash) => ({ pathname: '/index.html', search: '?role=participant', hash });
  function history() {
    return { state: null, urls: [], replaceState(_s, _t, url) { this.urls.push(url); } };
  }

  test('a join code: removed from the address bar, exchanged, kept in session storage', async () => {
    const local = new MemoryStorage();
    const session = new MemoryStorage();
    const store = new TokenStore({ local, session });
    const h = history();
    const out = await redeemFragment(store, { loc: loc('#join=J1'), history: h,
      fetch: async () => answer(200, { token: 'ptok', identity: { role: 'participant', session: 'free-1' } }) });
    assert.deepEqual(h.urls, ['/index.html?role=participant']);
    assert.equal(out.kind, 'join');
    assert.equal(session.getItem(JOIN_TOKEN_KEY), 'ptok');
    assert.equal(local.getItem(TOKEN_KEY), null);
  });

  test('a login code goes to local storage; the address bar is cleaned even when the code fails', async () => {
    const local = new MemoryStorage();
    const store = new TokenStore({ local, session: new MemoryStorage() });
    const h = history();
    await redeemFragment(store, { loc: loc('#login=L1&session=S2'), history: h,
      fetch: async () => answer(200, { token: 'atok', identity: { role: 'admin' } }) });
    assert.equal(local.getItem(TOKEN_KEY), 'atok');
    assert.deepEqual(h.urls, ['/index.html?role=participant#session=S2']);
    const h2 = history();
    await assert.rejects(redeemFragment(store, { loc: loc('#login=L1'), history: h2,
      fetch: async () => answer(401, { detail: 'used' }) }));
    assert.deepEqual(h2.urls, ['/index.html?role=participant']);
    assert.equal(local.getItem(TOKEN_KEY), 'atok'); // the old token stays
  });

  test('no code: nothing is fetched and the URL is left alone', async () => {
    const h = history();
    const out = await redeemFragment(new TokenStore({ local: new MemoryStorage(), session: new MemoryStorage() }),
      { loc: loc('#session=S1'), history: h, fetch: async () => assert.fail('fetched') });
    assert.deepEqual(out, { kind: null, identity: null });
    assert.deepEqual(h.urls, []);
  });
});

test('whoText: label or role@site, with the token id', () => {
  assert.equal(whoText({ token_id: 'aa', role: 'experimenter', site: 'lab-a', label: '' }), 'experimenter@lab-a (aa)');
  assert.equal(whoText({ token_id: 'bb', role: 'admin', label: 'env' }), 'env (bb)');
  assert.equal(whoText(null), 'nobody');
});
