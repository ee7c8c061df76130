// The console's health banner: what the server's `health` message says, for the experimenter.
// Pure (banner) plus one render function, so the words are tested under node.

import { fill, h } from './dom.js';

const TITLES = {
  degraded: 'The server is degraded',
  starting: 'The server is starting',
};

/** What the banner shows for a `health` message (null before any): hidden when ok. */
export function banner(health) {
  if (!health || health.status === 'ok') return { hidden: true, kind: 'ok', title: '', items: [] };
  const items = (health.reasons ?? []).map((r) => ({ code: r.code, text: r.message }));
  const title = TITLES[health.status] ?? `The server is ${health.status}`;
  return { hidden: false, kind: health.status === 'degraded' ? 'error' : 'warn', title, items };
}

/** Show `health` in the banner element (a title line and one line per reason). */
export function renderHealth(el, health) {
  if (!el) return;
  const b = banner(health);
  el.hidden = b.hidden;
  el.dataset.kind = b.kind;
  fill(el, h('strong', {}, b.title),
    b.items.length ? h('ul', {}, b.items.map((i) => h('li', { dataset: { code: i.code } }, i.text))) : null);
}
