// The server's health in the browser client: the connection hands `health` messages on, the
// participant's HUD shows one short line while degraded, the console's banner every reason.
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { Connection } from '../src/connection.js';
import { Hud, healthLine } from '../src/hud.js';
import { banner } from '../src/console/health.js';
import * as P from '../src/protocol.js';

const MISSING = { code: 'device_missing', message: "device 'ferrovibe' is disconnected: check its cable and power; "
  + "the running scenario 'contact-angle-v1' needs it for macro-roughness (tilt)" };
const STALLED = { code: 'loop_stalled', message: 'the haptic loop has not ticked for 0.07 s' };
const degraded = (...reasons) => ({ type: 'health', status: 'degraded', reasons });

test('the connection hands a health message to onHealth', () => {
  let socket;
  class FakeSocket {
    constructor() { socket = this; this.protocol = 'viestac.v1.json'; }
    send() {}
    close() {}
  }
  const c = new Connection({ url: 'ws://x/ws', WebSocket: FakeSocket, format: 'json' });
  const seen = [];
  c.onHealth = (h) => seen.push(h);
  c.connect();
  socket.onopen?.();
  socket.onmessage({ data: P.encode(degraded(MISSING), 'json') });
  socket.onmessage({ data: P.encode({ type: 'health', status: 'ok', reasons: [] }, 'json') });
  assert.deepStrictEqual(seen.map((h) => h.status), ['degraded', 'ok']);
  assert.deepStrictEqual(seen[0].reasons, [MISSING]);
});

test('the participant line names each cause once, in plain words', () => {
  assert.equal(healthLine(degraded(MISSING)), 'Tactile feedback paused — device disconnected');
  assert.equal(healthLine(degraded(MISSING, STALLED, MISSING)),
    'Tactile feedback paused — device disconnected, server not responding');
  assert.equal(healthLine(degraded({ code: 'something_new', message: 'x' })), 'Tactile feedback paused — server problem');
  assert.equal(healthLine({ status: 'ok', reasons: [] }), '');
  assert.equal(healthLine({ status: 'starting', reasons: [] }), '');
  assert.equal(healthLine(null), '');
});

test('a lost tracker reads as tracking lost, on the participant line and in the console banner', () => {
  const lost = { code: 'tracker_lost', message: "tracker source 'leap' (leap, ws://127.0.0.1:6437/v6.json) is lost: no sample for 420 ms" };
  assert.equal(healthLine(degraded(lost)), 'Tactile feedback paused — tracking lost');
  const b = banner(degraded(lost));
  assert.equal(b.hidden, false);
  assert.deepStrictEqual(b.items, [{ code: 'tracker_lost', text: lost.message }]);
});

test('the HUD shows the line while degraded and hides it when ok', () => {
  const els = { hud: {}, status: { dataset: {} }, telemetry: {}, health: { hidden: true } };
  const hud = new Hud(els);
  hud.setHealth(degraded(MISSING));
  assert.equal(els.health.hidden, false);
  assert.equal(els.health.textContent, 'Tactile feedback paused — device disconnected');
  assert.match(els.health.title, /ferrovibe/, 'the full message on hover');
  hud.setHealth({ type: 'health', status: 'ok', reasons: [] });
  assert.equal(els.health.hidden, true);
  new Hud({ hud: {}, status: { dataset: {} }, telemetry: {} }).setHealth(degraded(MISSING)); // no element: no-op
});

test('the console banner lists every reason and hides when ok', () => {
  const b = banner(degraded(MISSING, STALLED));
  assert.equal(b.hidden, false);
  assert.equal(b.kind, 'error');
  assert.equal(b.title, 'The server is degraded');
  assert.deepStrictEqual(b.items.map((i) => i.code), ['device_missing', 'loop_stalled']);
  assert.match(b.items[0].text, /check its cable and power/);
  assert.equal(banner({ status: 'ok', reasons: [] }).hidden, true);
  assert.equal(banner(null).hidden, true);
  assert.equal(banner({ status: 'starting', reasons: [] }).kind, 'warn');
});
