// The console's health banner: what the server's `health` message says, for the experimenter, and
// the device trouble the devices panel sees (devices.js: a device not connected, the device host
// down, watchdog trips rising, write errors), which the server's health does not all carry.
// Pure (banner) plus one render function, so the words are tested under node.
//
// Once shown, the banner stays HOLD_MS after the last trouble cleared (marked "cleared"): on a
// loaded machine the loop misses a 50 ms deadline now and then, and a banner that appears and
// vanishes dozens of times is read by nobody.

import { fill, h } from './dom.js';

export const HOLD_MS = 3000;

const TITLES = {
  degraded: 'The server is degraded',
  starting: 'The server is starting',
};

/** What the banner shows for a `health` message (null before any) and device trouble items
 * ({code, device, text}); hidden when both are clear. A device the server's reasons already name
 * is not named twice. */
export function banner(health, devices = []) {
  const serverOk = !health || health.status === 'ok';
  const items = serverOk ? [] : (health.reasons ?? []).map((r) => ({ code: r.code, text: r.message }));
  const named = (d) => items.some((i) => (d.device ? i.text.includes(`'${d.device}'`) && i.code === d.code.replace(
    'device_disconnected', 'device_missing') : i.code === d.code));
  const extra = devices.filter((d) => !named(d));
  if (serverOk && !extra.length) return { hidden: true, kind: 'ok', title: '', items: [] };
  const title = !serverOk ? TITLES[health.status] ?? `The server is ${health.status}` : 'Device trouble';
  const kind = !serverOk && health.status === 'degraded' ? 'error'
    : extra.some((d) => d.code === 'device_missing' || d.code === 'device_host_down') ? 'error' : 'warn';
  return { hidden: false, kind, title, items: [...items, ...extra.map((d) => ({ code: d.code, text: d.text }))] };
}

/** Show `health` and device trouble in the banner element (a title line and one line per reason),
 * holding the last trouble HOLD_MS after it cleared. */
export function renderHealth(el, health, devices = [], nowMs = Date.now()) {
  if (!el) return;
  let b = banner(health, devices);
  if (!b.hidden) el._shown = { b, at: nowMs };
  else if (el._shown && nowMs - el._shown.at < HOLD_MS) {
    b = { ...el._shown.b, kind: 'warn', title: `${el._shown.b.title} (cleared)` };
    setTimeout(() => el._rerender?.(), HOLD_MS - (nowMs - el._shown.at) + 10);
  } else el._shown = null;
  el.hidden = b.hidden;
  el.dataset.kind = b.kind;
  fill(el, h('strong', {}, b.title),
    b.items.length ? h('ul', {}, b.items.map((i) => h('li', { dataset: { code: i.code } }, i.text))) : null);
}
