// The console's devices panel (src/console/devices.js), its banner lines (health.js), the scenario
// card's parameter parsing (scenario.js) and the console's words for API refusals (words.js).
import { test } from 'node:test';
import assert from 'node:assert/strict';

import { DeviceWatch, deviceView, need } from '../src/console/devices.js';
import { banner } from '../src/console/health.js';
import { controlSpec, readParams, rangeText } from '../src/console/scenario.js';
import { consoleWords } from '../src/console/words.js';

const CAPABILITY = {
  scenario: 'contact-angle-v1', requires: ['macro_roughness'], ok: true,
  devices: [
    { name: 'fingertac', usable: false, dimensions: { macro_roughness: { shown: false, reason: 'fingertac cannot show the tilt cue' } } },
    { name: 'ferrovibe', usable: true, dimensions: { macro_roughness: { shown: true, how: 'direct' } } },
  ],
};

function snapshot({ trips = 0, status = 'connected', lastError = '', at = null, hostAlive = true } = {}) {
  return {
    host: { alive: hostAlive },
    devices: [
      { name: 'fingertac', status: 'connected', counters: { watchdog_trips: 0 }, disconnects: 0, last_error: '' },
      { name: 'ferrovibe', status, counters: { watchdog_trips: trips, device_errors: 1, bad_crc: 2 }, disconnects: 1,
        last_error: lastError, last_error_at: at },
    ],
  };
}

test('what the running scenario needs of each device', () => {
  assert.deepEqual(need(CAPABILITY, 'ferrovibe'), { needed: true, text: 'contact-angle-v1 shows macro-roughness (direct) on it' });
  assert.equal(need(CAPABILITY, 'fingertac').needed, false);
  assert.match(need(CAPABILITY, 'fingertac').text, /not used by contact-angle-v1: fingertac cannot show/);
});

test('watchdog trips are a rate over the last 10 s, and a restart of the counters is not negative', () => {
  const watch = new DeviceWatch();
  const scenario = { capability: CAPABILITY };
  let v = deviceView(snapshot({ trips: 100 }), scenario, watch, 0);
  assert.equal(v.rows[1].recentTrips, 0);
  assert.deepEqual(v.trouble, [], 'old trips are history');
  v = deviceView(snapshot({ trips: 103 }), scenario, watch, 2000);
  assert.equal(v.rows[1].recentTrips, 3);
  assert.equal(v.rows[1].errors, 3, 'device errors and rejected frames');
  assert.deepEqual(v.trouble, [], 'a few trips: the panel shows them, the banner does not');
  v = deviceView(snapshot({ trips: 113 }), scenario, watch, 4000);
  assert.equal(v.rows[1].recentTrips, 13);
  assert.deepEqual(v.trouble.map((t) => t.code), ['watchdog_trips'], 'one a second or more: rising');
  v = deviceView(snapshot({ trips: 113 }), scenario, watch, 15000);
  assert.equal(v.rows[1].recentTrips, 0, 'none in the last 10 s');
  v = deviceView(snapshot({ trips: 1 }), scenario, watch, 14000);
  assert.equal(v.rows[1].recentTrips, 0, 'a restarted device host counts from 0');
});

test('a needed device that is off, the host down and a recent write error are trouble', () => {
  const watch = new DeviceWatch();
  const scenario = { capability: CAPABILITY };
  const now = 1_000_000;
  let v = deviceView(snapshot({ status: 'disconnected', lastError: 'write failed: Write timeout', at: (now - 5000) / 1000 }),
    scenario, watch, now);
  assert.deepEqual(v.trouble.map((t) => t.code), ['device_missing', 'write_errors']);
  assert.match(v.trouble[0].text, /Device 'ferrovibe' is disconnected: check its cable/);
  assert.match(v.trouble[1].text, /writing to it failed 5 s ago/);
  v = deviceView(snapshot({ hostAlive: false }), scenario, watch, now);
  assert.deepEqual(v.trouble.map((t) => t.code), ['device_host_down']);
  assert.equal(v.rows[0].status, 'host down');
});

test('the banner shows device trouble when the server is ok, and does not name a device twice', () => {
  const trouble = [{ code: 'device_missing', device: 'ferrovibe', text: "Device 'ferrovibe' is disconnected" },
    { code: 'watchdog_trips', device: 'fingertac', text: "Device 'fingertac': its watchdog …" }];
  const ok = banner({ status: 'ok', reasons: [] }, trouble);
  assert.equal(ok.hidden, false);
  assert.equal(ok.title, 'Device trouble');
  assert.equal(ok.kind, 'error');
  const degraded = banner({ status: 'degraded', reasons: [{ code: 'device_missing', message: "device 'ferrovibe' is disconnected: …" }] },
    trouble);
  assert.deepEqual(degraded.items.map((i) => i.code), ['device_missing', 'watchdog_trips']);
  assert.equal(banner({ status: 'ok', reasons: [] }, []).hidden, true);
});

test('scenario parameters: declared ranges, choices and refusals before sending', () => {
  const decl = [
    { name: 'magnitude_pct', kind: 'number', low: 0, high: 100, unit: '%', default: 100 },
    { name: 'probe', kind: 'choice', choices: ['hip', 'proxy'], default: 'hip' },
    { name: 'period_us', kind: 'choice', choices: [2000, 4000], default: 4000, optional: true },
    { name: 'labels', kind: 'bool', default: true },
  ];
  assert.equal(rangeText(decl[0]), '0 – 100 %');
  assert.deepEqual(controlSpec(decl[0]).attrs.min, 0);
  assert.deepEqual(controlSpec(decl[1], 'proxy').options.map((o) => o.selected), [false, true]);
  assert.deepEqual(readParams(decl, { magnitude_pct: '50', probe: '"proxy"', period_us: '', labels: false }),
    { params: { magnitude_pct: 50, probe: 'proxy', labels: false } });
  assert.deepEqual(readParams(decl, { magnitude_pct: '150', probe: '"hip"' }).error,
    { name: 'magnitude_pct', text: 'magnitude_pct: 150 is outside 0 – 100 %' });
  assert.equal(readParams(decl, { magnitude_pct: 'x', probe: '"hip"' }).error.name, 'magnitude_pct');
});

test('API refusals in the console\'s words', () => {
  const said = consoleWords('Not allowed: this changes the rig: request the control lease first (POST /api/lease).');
  assert.equal(said, 'Not allowed: this changes the rig: press “Request control” (in “Control of the rig”) first.');
  assert.doesNotMatch(consoleWords('session s1 has no controlling console; take control first'), /take control first/);
  assert.doesNotMatch(consoleWords('a study id (GET /api/studies) is needed'), /\/api\//);
});

test('a missing browser device is the participant\'s page, not a cable', () => {
  const capability = { scenario: 'contact-angle-v1', requires: ['macro_roughness'], devices: [
    { name: 'browser', usable: false, dimensions: { macro_roughness: { shown: true, how: 'as vibration' } } }] };
  const v = deviceView({ devices: [{ name: 'browser', status: 'disconnected', profile: { model: 'browser' }, counters: {},
    last_error: 'client 3: tracked hands have no actuator' }], host: { alive: true } }, { capability }, new DeviceWatch(), 1000);
  assert.deepEqual(v.trouble.map((t) => t.code), ['device_missing']);
  assert.match(v.trouble[0].text, /Device 'browser' is disconnected: the participant's page offers no actuator \(hold the controllers/);
  assert.doesNotMatch(v.trouble[0].text, /cable/);
});
