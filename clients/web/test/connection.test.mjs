// Connection adapter (src/connection.js) against an in-memory fake WebSocket.
import { test, describe, beforeEach, afterEach, mock } from 'node:test';
import assert from 'node:assert/strict';
import { AUTH_RETRIES, Connection, FINAL_CLOSE_REASONS } from '../src/connection.js';
import * as P from '../src/protocol.js';

class FakeSocket {
  static instances = [];
  constructor(url, protocols) {
    this.url = url;
    this.protocols = protocols;
    this.readyState = 0;
    this.bufferedAmount = 0;
    this.protocol = '';
    this.sent = [];
    this.binaryType = 'blob';
    FakeSocket.instances.push(this);
  }
  send(data) { this.sent.push(data); }
  close(code = 1000) { this.readyState = 3; this.onclose?.({ code, reason: '' }); }
  // test helpers
  open(protocol = protocols0(this)) { this.protocol = protocol; this.readyState = 1; this.onopen?.(); }
  receive(msg, format = 'msgpack') {
    const data = P.encode(msg, format);
    this.onmessage?.({ data: format === 'msgpack' ? data.buffer.slice(data.byteOffset, data.byteOffset + data.byteLength) : data });
  }
  drop(code = 1006) { this.readyState = 3; this.onclose?.({ code, reason: '' }); }
  decoded(format = 'msgpack') { return this.sent.map((d) => P.decode(d, format)); }
}
const protocols0 = (s) => s.protocols[0];

const WELCOME = { type: 'welcome', v: 1, client_id: 7, role: 'participant', server: 'viestac/0.1.0', tick_hz: 1000, state_hz: 60, format: 'msgpack' };

function make(opts = {}) {
  const c = new Connection({ url: 'ws://x/ws', WebSocket: FakeSocket, now: () => 1000.5, backoffMinMs: 100, backoffMaxMs: 400, ...opts });
  const seen = { welcome: [], scene: [], state: [], error: [], status: [] };
  c.onWelcome = (m) => seen.welcome.push(m);
  c.onScene = (m) => seen.scene.push(m);
  c.onState = (m) => seen.state.push(m);
  c.onError = (e, src) => seen.error.push({ code: e.code, src });
  c.onStatus = (s) => seen.status.push(s);
  return { c, seen };
}

describe('Connection', () => {
  beforeEach(() => { FakeSocket.instances = []; mock.timers.enable({ apis: ['setTimeout'] }); });
  afterEach(() => mock.timers.reset());

  test('asks for the msgpack subprotocol, uses arraybuffer, sends hello on open', () => {
    const { c } = make({ role: 'operator', client: 'test/1' });
    c.connect();
    const ws = FakeSocket.instances[0];
    assert.deepStrictEqual(ws.protocols, ['viestac.v1.msgpack']);
    assert.equal(ws.binaryType, 'arraybuffer');
    ws.open();
    assert.deepStrictEqual(ws.decoded(), [{ type: 'hello', v: 1, role: 'operator', client: 'test/1' }]);
    assert.ok(ws.sent[0] instanceof Uint8Array);
  });

  test('dispatches welcome, scene, state and error; reports undecodable frames', () => {
    const { c, seen } = make();
    c.connect();
    const ws = FakeSocket.instances[0];
    ws.open();
    ws.receive(WELCOME);
    ws.receive({ type: 'error', code: 'busy', message: 'dropped' });
    ws.receive({ type: 'future_thing', x: 1 }); // unknown types are ignored silently
    ws.onmessage({ data: '{"type":"state"}' }); // text frame on a msgpack connection
    assert.equal(seen.welcome.length, 1);
    assert.equal(c.status, 'ready');
    assert.deepStrictEqual(seen.error, [{ code: 'busy', src: 'server' }, { code: 'bad_encoding', src: 'client' }]);
  });

  test('sendTracker skips the send while bytes are buffered', () => {
    const { c } = make();
    assert.equal(c.sendTracker([0, 0, 0]), false, 'not connected yet');
    c.connect();
    const ws = FakeSocket.instances[0];
    ws.open();
    ws.sent.length = 0;
    assert.equal(c.sendTracker([0, 0.5, 1]), true);
    ws.bufferedAmount = 10;
    assert.equal(c.sendTracker([0, 0.6, 1]), false);
    ws.bufferedAmount = 0;
    assert.equal(c.sendTracker([0, 0.7, 1], [1, 0, 0, 0]), true);
    const sent = ws.decoded();
    assert.deepStrictEqual(sent[0], { type: 'tracker', seq: 0, t: 1000.5, pos: [0, 0.5, 1] });
    // the dropped sample used seq 1: the gap tells the server a sample was dropped
    assert.deepStrictEqual(sent[1], { type: 'tracker', seq: 2, t: 1000.5, pos: [0, 0.7, 1], quat: [1, 0, 0, 0] });
    assert.equal(c.dropped, 1);
  });

  test('sendTracker carries a hand: the point, its other joints and a ttl', () => {
    const { c } = make();
    c.connect();
    const ws = FakeSocket.instances[0];
    ws.open();
    ws.sent.length = 0;
    const points = { 'right.thumb.tip': [0, 0.2, 1], 'right.wrist': [0, 0.4, 0.6] };
    assert.equal(c.sendTracker([0, 0.5, 1], null, { point: 'right.index.tip', points, ttl: 40 }), true);
    assert.deepStrictEqual(ws.decoded()[0],
      { type: 'tracker', seq: 0, t: 1000.5, pos: [0, 0.5, 1], point: 'right.index.tip', points, ttl: 40 });
    assert.throws(() => c.sendTracker([0, 0, 1], null, { points: { 'right.elbow': [0, 0, 0] } }),
      /points/, 'a name that is no tracked point is refused before it is sent');
  });

  test('observers send hello but no tracker or input', () => {
    const { c } = make({ role: 'observer' });
    c.connect();
    const ws = FakeSocket.instances[0];
    ws.open();
    assert.equal(c.sendTracker([0, 0, 0]), false);
    assert.equal(c.sendInput('r', 'down'), false);
    assert.deepStrictEqual(ws.decoded().map((m) => m.type), ['hello']);
  });

  test('sendInput encodes an input message', () => {
    const { c } = make();
    c.connect();
    FakeSocket.instances[0].open();
    c.sendInput('ArrowUp', 'down');
    assert.deepStrictEqual(FakeSocket.instances[0].decoded()[1], { type: 'input', key: 'ArrowUp', action: 'down' });
  });

  test('sendInput carries a command value only when given', () => {
    const { c } = make({ role: 'operator' });
    c.connect();
    const ws = FakeSocket.instances[0];
    ws.open();
    c.sendInput('tap_angle', 'press', -30);
    c.sendInput('scale', 'press', false);
    c.sendInput('release', 'press');
    assert.deepStrictEqual(ws.decoded().slice(1), [
      { type: 'input', key: 'tap_angle', action: 'press', value: -30 },
      { type: 'input', key: 'scale', action: 'press', value: false },
      { type: 'input', key: 'release', action: 'press' },
    ]);
  });

  test('json subprotocol: text frames both ways', () => {
    const { c, seen } = make({ format: 'json' });
    c.connect();
    const ws = FakeSocket.instances[0];
    assert.deepStrictEqual(ws.protocols, ['viestac.v1.json']);
    ws.open('viestac.v1.json');
    assert.equal(typeof ws.sent[0], 'string');
    ws.receive({ ...WELCOME, format: 'json' }, 'json');
    assert.equal(seen.welcome.length, 1);
  });

  test('reconnects with capped backoff, resets after welcome', () => {
    mock.method(Math, 'random', () => 0.5); // no jitter
    const { c } = make();
    c.connect();
    FakeSocket.instances[0].drop();
    assert.equal(c.status, 'reconnecting');
    mock.timers.tick(99);
    assert.equal(FakeSocket.instances.length, 1);
    mock.timers.tick(1);
    assert.equal(FakeSocket.instances.length, 2);
    FakeSocket.instances[1].drop();
    mock.timers.tick(200);
    assert.equal(FakeSocket.instances.length, 3);
    FakeSocket.instances[2].drop();
    mock.timers.tick(400);
    assert.equal(FakeSocket.instances.length, 4);
    FakeSocket.instances[3].drop();
    mock.timers.tick(400); // capped at backoffMaxMs
    assert.equal(FakeSocket.instances.length, 5);
    const ws = FakeSocket.instances[4];
    ws.open();
    ws.receive(WELCOME);
    assert.equal(c.attempt, 0);
    ws.drop();
    mock.timers.tick(100);
    assert.equal(FakeSocket.instances.length, 6);
    Math.random.mock.restore();
  });

  test('does not retry after close 1002 (unsupported version) or close()', () => {
    const { c } = make();
    c.connect();
    FakeSocket.instances[0].drop(1002);
    assert.equal(c.status, 'failed');
    mock.timers.tick(10000);
    assert.equal(FakeSocket.instances.length, 1);
    c.connect();
    c.close();
    mock.timers.tick(10000);
    assert.equal(FakeSocket.instances.length, 2);
  });
});

test('the role in welcome decides whether the client may send', () => {
  FakeSocket.instances = [];
  const { c } = make({ role: 'participant' });
  c.connect();
  const ws = FakeSocket.instances[0];
  ws.open();
  ws.receive({ ...WELCOME, role: 'observer' });
  assert.equal(c.sendTracker([0, 0, 0]), false);
  assert.equal(c.sendInput('r', 'down'), false);
});

describe('access token', () => {
  beforeEach(() => { FakeSocket.instances = []; mock.timers.enable({ apis: ['setTimeout'] }); });
  afterEach(() => mock.timers.reset());

  test('hello carries the token; a function is asked at each connect', () => {
    let token = 'first';
    const { c } = make({ role: 'operator', client: 'test/1', token: () => token });
    c.connect();
    FakeSocket.instances[0].open();
    assert.deepStrictEqual(FakeSocket.instances[0].decoded(),
      [{ type: 'hello', v: 1, role: 'operator', client: 'test/1', token: 'first' }]);
    token = 'second';
    FakeSocket.instances[0].drop();
    mock.timers.tick(1000);
    FakeSocket.instances[1].open();
    assert.equal(FakeSocket.instances[1].decoded()[0].token, 'second');
    assert.ok(!FakeSocket.instances[1].url.includes('second')); // never in the URL
  });

  test('no token: hello without one', () => {
    const { c } = make({ role: 'observer' });
    c.connect();
    FakeSocket.instances[0].open();
    assert.ok(!('token' in FakeSocket.instances[0].decoded()[0]));
  });

  test('a refused token (close 1008 unauthorized) is not retried until setToken', () => {
    const { c } = make({ token: 'bad' });
    const why = [];
    c.onUnauthorized = (w) => why.push(w);
    c.connect();
    const ws = FakeSocket.instances[0];
    ws.open();
    ws.readyState = 3;
    ws.onclose({ code: 1008, reason: 'unauthorized: unknown token' });
    assert.equal(c.status, 'unauthorized');
    assert.deepStrictEqual(why, ['unauthorized: unknown token']);
    mock.timers.tick(20000);
    assert.equal(FakeSocket.instances.length, 1);
    c.setToken('good');
    assert.equal(FakeSocket.instances.length, 2);
    FakeSocket.instances[1].open();
    assert.equal(FakeSocket.instances[1].decoded()[0].token, 'good');
  });

  test('another 1008 (e.g. too many connections) is retried with backoff', () => {
    const { c } = make({ token: 'ok' });
    c.connect();
    const ws = FakeSocket.instances[0];
    ws.readyState = 3;
    ws.onclose({ code: 1008, reason: 'rate_limited' });
    assert.equal(c.status, 'reconnecting');
    mock.timers.tick(1000);
    assert.equal(FakeSocket.instances.length, 2);
  });

  test('the unauthorized error marks the connection before the close', { skip: !P.ERROR_CODES.includes('unauthorized') }, () => {
    const { c, seen } = make({ token: 'bad' });
    c.connect();
    const ws = FakeSocket.instances[0];
    ws.open();
    ws.receive({ type: 'error', code: 'unauthorized', message: 'unknown token' });
    assert.deepStrictEqual(seen.error, [{ code: 'unauthorized', src: 'server' }]);
    ws.drop(1008);
    assert.equal(c.status, 'unauthorized');
    mock.timers.tick(20000);
    assert.equal(FakeSocket.instances.length, 1);
  });

  test('a hello refused as late is retried with the stored token, a bounded number of times', { skip: !P.ERROR_CODES.includes('unauthorized') }, () => {
    const { c, seen } = make({ token: 'slow' });
    const why = [];
    c.onUnauthorized = (w, reason) => why.push([w, reason]);
    c.connect();
    for (let i = 0; i < AUTH_RETRIES; i++) {
      const ws = FakeSocket.instances.at(-1);
      ws.open();
      ws.receive({ type: 'error', code: 'unauthorized', message: 'no hello with a token within 1 s of connecting' });
      ws.drop(1008);
      assert.equal(c.status, 'reconnecting');
      mock.timers.tick(1000);
      assert.equal(FakeSocket.instances.length, i + 2);
      assert.equal(FakeSocket.instances.at(-1).url, 'ws://x/ws');
    }
    FakeSocket.instances.at(-1).open();
    assert.equal(FakeSocket.instances.at(-1).decoded()[0].token, 'slow');
    FakeSocket.instances.at(-1).receive({ type: 'error', code: 'unauthorized', message: 'no hello with a token within 1 s' });
    FakeSocket.instances.at(-1).drop(1008);
    assert.equal(c.status, 'unauthorized'); // bounded: the page stops and says so
    assert.deepStrictEqual(why, [['no hello with a token within 1 s', 'unauthorized']]);
    assert.ok(seen.status.includes('reconnecting'));
    // a welcome starts the count again
    c.setToken('slow');
    const ws = FakeSocket.instances.at(-1);
    ws.open();
    ws.receive(WELCOME);
    assert.equal(c.authRetries, 0);
  });

  test('a session_taken error makes the connection watch only until its next welcome', () => {
    const { c } = make({ token: 't' });
    c.connect();
    const ws = FakeSocket.instances[0];
    ws.open();
    ws.receive(WELCOME);
    assert.equal(c.canSend, true);
    ws.receive({ type: 'error', code: 'session_taken', message: 'another tab drives' });
    assert.equal(c.watchOnly, true);
    assert.equal(c.canSend, false);
    assert.equal(c.sendTracker([0, 0.2, 0.9]), false);
    ws.receive(WELCOME);
    assert.equal(c.canSend, true);
  });

  for (const reason of ['revoked', 'expired']) {
    test(`a close 1008 '${reason}' is final and said in words`, () => {
      const { c } = make({ token: 't' });
      const why = [];
      c.onUnauthorized = (w, r) => why.push([w, r]);
      c.connect();
      const ws = FakeSocket.instances[0];
      ws.open();
      ws.receive(WELCOME);
      ws.readyState = 3;
      ws.onclose({ code: 1008, reason });
      assert.equal(c.status, 'unauthorized');
      assert.deepStrictEqual(why, [[FINAL_CLOSE_REASONS[reason], reason]]);
      mock.timers.tick(20000);
      assert.equal(FakeSocket.instances.length, 1);
    });
  }

  test('lease messages reach onLease', { skip: !P.MESSAGE_TYPES.includes('lease') }, () => {
    const { c } = make();
    const leases = [];
    c.onLease = (l) => leases.push(l);
    c.connect();
    const ws = FakeSocket.instances[0];
    ws.open();
    ws.receive({ type: 'lease', holder: null, queue: [], session: null, ttl_s: 60 });
    assert.equal(leases.length, 1);
    assert.equal(leases[0].ttl_s, 60);
  });
});
