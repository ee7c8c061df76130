// The console's devices panel: every configured device's state and link quality (GET /api/devices,
// polled every POLL_MS), and what the running scenario needs of it (the capability check of GET
// /api/scenario). It also names device trouble for the health banner (health.js): a device that
// is not connected, the device host down, watchdog trips rising, write errors.
//
// Pure (DeviceWatch, deviceView, deviceTrouble) plus one render function, so the words are tested
// under node. Rates come from the counters of successive polls; the age of a last error from its
// status event when there is one, else from when this console first saw it.

import { fill, h } from './dom.js';

export const POLL_MS = 500; // a killed emulator shows within 1 s (a poll, the pty's read error)
export const RATE_WINDOW_S = 10; // trips and errors "per 10 s": what the banner calls rising
export const WRITE_ERROR_RECENT_S = 30; // a write error older than this is history, not trouble
// Trips in RATE_WINDOW_S that make the banner speak: one a second. The panel shows every trip; a
// busy 2-core machine trips now and then (docs/devices.md "Faults"), and a banner that never goes
// away is read by nobody; the 33-minute run of the issue tripped about twice a second.
export const TRIPS_RISING = 10;

const REJECTS = ['framing', 'too_long', 'bad_length', 'bad_crc', 'unknown_type', 'bad_value'];

/** Counters of successive polls, per device, for rates over the last RATE_WINDOW_S. */
export class DeviceWatch {
  constructor() {
    this.samples = new Map(); // name → [{t (ms), trips, errors, disconnects}]
    this.errorSeen = new Map(); // name → {text, t (ms)}: when this console first saw a last_error
  }

  /** Note one /api/devices answer at `nowMs` (this clock); returns the per-device rates. */
  update(snapshot, nowMs) {
    const rates = new Map();
    for (const d of snapshot?.devices ?? []) {
      const c = d.counters ?? {};
      const sample = { t: nowMs, trips: c.watchdog_trips ?? 0, errors: linkErrors(c), disconnects: d.disconnects ?? 0 };
      const list = (this.samples.get(d.name) ?? []).filter((s) => nowMs - s.t <= RATE_WINDOW_S * 1000);
      // a restarted device host counts from 0 again: start over rather than show a negative rate
      const base = list.find((s) => s.trips <= sample.trips && s.errors <= sample.errors) ?? sample;
      list.push(sample);
      this.samples.set(d.name, list.filter((s) => s.t >= base.t));
      rates.set(d.name, {
        trips: sample.trips - base.trips, errors: sample.errors - base.errors,
        disconnects: Math.max(0, sample.disconnects - base.disconnects),
        spanS: (nowMs - base.t) / 1000,
      });
      const seen = this.errorSeen.get(d.name);
      if (!d.last_error) this.errorSeen.delete(d.name);
      else if (!seen || seen.text !== d.last_error) this.errorSeen.set(d.name, { text: d.last_error, t: nowMs });
    }
    return rates;
  }

  /** When the device's last error happened (ms, this clock): the server's `last_error_at`, else its
   * status event's time, else when this console first saw it. */
  errorAt(device, offsetMs = 0) {
    if (device.last_error_at) return device.last_error_at * 1000 - offsetMs;
    const ev = [...(device.events ?? [])].reverse().find((e) => e.reason === device.last_error && e.t);
    if (ev) return ev.t * 1000 - offsetMs;
    return this.errorSeen.get(device.name)?.t ?? null;
  }
}

/** A device's link errors: the device's ERROR replies and every frame it rejected or we rejected. */
export function linkErrors(counters) {
  return (counters.device_errors ?? 0) + REJECTS.reduce((n, k) => n + (counters[k] ?? 0), 0);
}

/** What the running scenario needs of device `name`, from GET /api/scenario's `capability`. */
export function need(capability, name) {
  if (!capability) return { needed: false, text: 'running scenario unknown' };
  const d = (capability.devices ?? []).find((x) => x.name === name);
  const scenario = capability.scenario ?? 'the running scenario';
  if (!capability.requires?.length) return { needed: false, text: `${scenario} needs no tactile device` };
  if (!d) return { needed: false, text: `not configured for ${scenario}` };
  const dims = Object.entries(d.dimensions ?? {});
  const shown = dims.filter(([, v]) => v.shown).map(([k, v]) => `${k.replace(/_/g, '-')}${v.how ? ` (${v.how})` : ''}`);
  if (d.usable || shown.length) return { needed: true, text: `${scenario} shows ${shown.join(', ')} on it` };
  const why = dims.map(([, v]) => v.reason).filter(Boolean)[0];
  return { needed: false, text: `not used by ${scenario}${why ? `: ${why}` : ''}` };
}

function age(ms) {
  if (!Number.isFinite(ms)) return '';
  const s = Math.max(0, Math.round(ms / 1000));
  return s < 60 ? `${s} s ago` : s < 3600 ? `${Math.round(s / 60)} min ago` : `${Math.round(s / 3600)} h ago`;
}

/** The panel's rows and the banner's trouble, from one poll (snapshot), the scenario info and the watch. */
export function deviceView(snapshot, scenario, watch, nowMs, { offsetMs = 0 } = {}) {
  const rates = watch.update(snapshot, nowMs);
  const capability = scenario?.capability ?? null;
  const hostDown = snapshot?.host ? snapshot.host.alive === false : false;
  const rows = (snapshot?.devices ?? []).map((d) => {
    const c = d.counters ?? {};
    const r = rates.get(d.name) ?? { trips: 0, errors: 0, disconnects: 0, spanS: 0 };
    const errorAt = d.last_error ? watch.errorAt(d, offsetMs) : null;
    return {
      name: d.name,
      model: d.profile?.model ?? d.identity?.model ?? '',
      finger: d.finger ?? '',
      status: hostDown ? 'host down' : d.status,
      connected: !hostDown && d.status === 'connected',
      rttMs: d.rtt_ms,
      framesIn: c.frames_in ?? 0,
      framesOut: c.frames_out ?? 0,
      errors: linkErrors(c),
      disconnects: d.disconnects ?? 0,
      trips: c.watchdog_trips ?? 0,
      recentTrips: r.trips,
      recentErrors: r.errors,
      lastError: d.last_error || '',
      lastErrorAgeMs: errorAt === null ? null : nowMs - errorAt,
      need: need(capability, d.name),
    };
  });
  return { rows, hostDown, scenario: capability?.scenario ?? scenario?.id ?? null,
    trouble: deviceTrouble(rows, hostDown) };
}

/** What to do about a device that is not connected (devices/capability.py device_advice). */
function advice(r) {
  return r.model === 'browser' ? "the participant's page offers no actuator (hold the controllers: tracked hands have none)"
    : 'check its cable and power';
}

/** Banner items ({code, device, text}) for device trouble. */
export function deviceTrouble(rows, hostDown) {
  const out = [];
  if (hostDown) {
    out.push({ code: 'device_host_down', device: null,
      text: 'The device host process is down: no tactile device is driven until the server has restarted it.' });
  }
  for (const r of rows) {
    if (!hostDown && !r.connected) {
      out.push(r.need.needed
        ? { code: 'device_missing', device: r.name,
          text: `Device '${r.name}' is ${r.status}: ${advice(r)}; ${r.need.text}.` }
        : { code: 'device_disconnected', device: r.name,
          text: `Device '${r.name}' is ${r.status} (${r.need.text}).` });
    }
    if (r.recentTrips >= TRIPS_RISING) {
      out.push({ code: 'watchdog_trips', device: r.name,
        text: `Device '${r.name}': its watchdog turned every actuator off ${r.recentTrips} time${r.recentTrips > 1
          ? 's' : ''} in the last ${RATE_WINDOW_S} s (${r.trips} in all): the server's frames reach it late.` });
    }
    if (r.lastError.startsWith('write failed') && r.lastErrorAgeMs !== null
        && r.lastErrorAgeMs <= WRITE_ERROR_RECENT_S * 1000) {
      out.push({ code: 'write_errors', device: r.name,
        text: `Device '${r.name}': writing to it failed ${age(r.lastErrorAgeMs)} (${r.lastError}).` });
    }
  }
  return out;
}

/** Show the panel in `el` (a card's body). */
export function renderDevices(el, view, error = '') {
  if (!el) return;
  if (error) {
    el.dataset.sig = '';
    fill(el, h('div', { class: 'c-msg', dataset: { kind: 'error' } }, error));
    return;
  }
  if (!view.rows.length) {
    fill(el, h('div', { class: 'c-muted' }, 'No tactile device is configured (serve --rig or a rig file).'));
    return;
  }
  // redrawn only when something shown changed (a poll every 500 ms must not churn the DOM)
  const sig = JSON.stringify([view.rows.map((r) => ({ ...r, lastErrorAgeMs: age(r.lastErrorAgeMs) })), view.trouble]);
  if (el.dataset.sig === sig) return;
  el.dataset.sig = sig;
  const bad = new Set(view.trouble.map((t) => t.device));
  fill(el,
    view.hostDown ? h('div', { class: 'c-msg', dataset: { kind: 'error' } }, view.trouble[0].text) : null,
    h('ul', { class: 'c-devices', 'aria-label': 'devices' }, view.rows.map((r) => h('li', {
      dataset: { device: r.name, status: r.connected ? 'ok' : 'bad', trouble: bad.has(r.name) ? 'yes' : 'no' },
    },
    h('div', { class: 'c-device-head' }, h('strong', {}, r.name), ' ',
      h('span', { class: 'c-badge', dataset: { status: r.connected ? 'finished' : 'aborted' } }, r.status), ' ',
      h('span', { class: 'c-muted' }, [r.model !== r.name ? r.model : '', r.finger].filter(Boolean).join(' · '))),
    h('div', { class: 'c-device-need', dataset: { needed: r.need.needed ? 'yes' : 'no' } },
      r.need.needed ? h('strong', {}, 'needed: ') : 'not needed: ', r.need.text),
    h('div', { class: 'c-muted' }, `link: ${r.framesOut} frames out · ${r.framesIn} in · ${r.errors} errors · `
      + `${r.disconnects} disconnects${r.rttMs == null ? '' : ` · rtt ${r.rttMs} ms`}`),
    h('div', { class: r.recentTrips >= TRIPS_RISING ? 'c-device-warn' : 'c-muted' },
      `watchdog trips: ${r.recentTrips} in the last ${RATE_WINDOW_S} s · ${r.trips} in all`),
    r.lastError ? h('div', { class: 'c-muted' }, `last error: ${r.lastError}`,
      r.lastErrorAgeMs !== null ? ` (${age(r.lastErrorAgeMs)})` : '') : null))));
}

/** The panel's I/O shell: polls GET /api/devices every POLL_MS (and GET /api/scenario every 5th
 * poll, or when the scene changed), renders, and hands the trouble to `onTrouble(items)`. */
export class DevicesCard {
  constructor(el, api, { onTrouble = () => {}, active = () => true } = {}) {
    this.el = el;
    this.api = api;
    this.onTrouble = onTrouble;
    this.active = active; // false: not polled (logged out, paused)
    this.watch = new DeviceWatch();
    this.view = null;
    this.scenario = null;
    this.polls = 0;
    this.timer = null;
    this.busy = false;
  }

  start() {
    if (!this.timer) this.timer = setInterval(() => this.poll(), POLL_MS);
    return this.poll();
  }

  /** The running scenario changed (a `scene` message): read its capability at the next poll. */
  scenarioChanged() { this.polls = 0; }

  async poll() {
    if (!this.active()) return;
    if (this.busy) { // one in flight: read again right after it (a pushed change must not wait a period)
      this.again = true;
      return;
    }
    this.busy = true;
    this.again = false;
    try {
      if (this.polls++ % 5 === 0 || !this.scenario) {
        try {
          this.scenario = await this.api.request('GET', '/api/scenario');
        } catch { /* 503 while the loop starts: the devices still show */ }
      }
      const snapshot = await this.api.request('GET', '/api/devices');
      this.view = deviceView(snapshot, this.scenario, this.watch, Date.now(), { offsetMs: this.api.clockOffsetMs ?? 0 });
      renderDevices(this.el, this.view);
      this.onTrouble(this.view.trouble);
    } catch (e) {
      if (e?.status === 401) return;
      const why = e?.status === 0 ? 'The server did not answer: the devices are unknown.' : e?.message ?? String(e);
      renderDevices(this.el, null, why);
      this.onTrouble(e?.status === 0 ? [] : [{ code: 'devices_unknown', device: null, text: why }]);
    } finally {
      this.busy = false;
      if (this.again) this.poll();
    }
  }
}
