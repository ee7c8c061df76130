// The console's tracker card: each tracker source's health (GET /api/trackers, `sources`) and the
// calibration routines (docs/trackers.md "Calibration"): capture the tracked finger at three or
// more marked scene points, fit; or hold still at one reference; or reset to the default.
// Pure view models (sourceRows, pairsReady, calibrationBody) tested under node; `mountTrackers`
// is the thin DOM part, started by console.html on its own (it only needs the Api).

import { Api } from './api.js';
import { TokenStore } from '../auth.js';
import { fill, h, say } from './dom.js';

export const POLL_MS = 500;

// Marked points of the contact-angle scene a finger can touch: the dome's top and 45° either side,
// at the HIP sphere's centre when touching (dome radius 0.6 + HIP radius 0.06).
export const DEFAULT_MARKS = [
  { label: 'dome top', scene: [0, 0, 0.66] },
  { label: 'dome 45° left', scene: [0, -0.4667, 0.4667] },
  { label: 'dome 45° right', scene: [0, 0.4667, 0.4667] },
];

const num = (x, digits = 0) => (x == null || !Number.isFinite(x) ? '–' : x.toFixed(digits));

/** One row per source: what the health table shows. */
export function sourceRows(sources = []) {
  return sources.map((s) => ({
    name: s.name,
    kind: s.kind ?? '',
    status: s.status ?? 'lost',
    rate: `${num(s.rate_hz)} / ${num(s.nominal_hz)} Hz`,
    age: s.age_ms == null ? 'never' : `${num(s.age_ms)} ms`,
    gaps: `${s.gaps ?? 0}${s.longest_gap_ms ? ` (longest ${num(s.longest_gap_ms)} ms)` : ''}`,
    confidence: s.confidence == null ? '–' : num(s.confidence, 2),
    why: [...(s.reasons ?? []), s.note && s.status !== 'ok' ? s.note : null].filter(Boolean).join('; '),
    calibration: s.calibration ? `${s.calibration.method}${s.calibration.residual != null
      ? `, residual ${num(s.calibration.residual * 1000, 1)}·10⁻³` : ''}` : '–',
  }));
}

/** The captured pairs a points fit can use (a capture and its mark), and whether there are enough. */
export function pairsReady(marks, captures) {
  const pairs = marks.map((m, i) => (captures[i] ? { source: captures[i], scene: m.scene } : null)).filter(Boolean);
  return { pairs, ready: pairs.length >= 3 };
}

/** The PUT /api/trackers/{source}/calibration body. */
export function calibrationBody(method, pairs) {
  if (method === 'hold') return { method, pairs: pairs.slice(0, 1) };
  return { method: 'points', pairs };
}

/** The raw point of `point` from a capture answer, with a warning when the finger moved. */
export function capturedPoint(answer, point = 'right.index.tip', maxSpread = 2.0) {
  const p = answer?.points?.[point];
  if (!p) return { point: null, warning: `no ${point} in the capture` };
  const moved = p.spread > maxSpread && answer.units === 'mm';
  return { point: p.mean, warning: moved ? `the finger moved ${p.spread.toFixed(1)} mm: capture again` : '' };
}

export function mountTrackers(root, api, { point = 'right.index.tip', marks = DEFAULT_MARKS } = {}) {
  const table = h('table', { class: 'c-table' });
  const msg = h('div', { class: 'c-msg', role: 'alert' });
  const select = h('select', { 'aria-label': 'tracker source' });
  const captures = [];
  const markRows = h('ul', {});
  const renderMarks = () => fill(markRows, marks.map((m, i) => h('li', {},
    `${m.label} [${m.scene.join(', ')}] `,
    h('button', { type: 'button', class: 'c-small', onclick: () => capture(i) }, captures[i] ? 'capture again' : 'capture'),
    captures[i] ? ` ✓ ${captures[i].map((v) => v.toFixed(1)).join(', ')}` : '')));
  const act = async (fn) => {
    try { await fn(); } catch (e) { say(msg, e.message ?? String(e), 'error'); }
  };
  const source = () => select.value;
  const capture = (i) => act(async () => {
    const answer = await api.request('POST', `/api/trackers/${encodeURIComponent(source())}/capture`, { body: { seconds: 0.5 } });
    const got = capturedPoint(answer, point);
    if (!got.point) throw new Error(got.warning);
    captures[i] = got.point;
    say(msg, got.warning || `captured ${marks[i].label}`, got.warning ? 'warn' : 'ok');
    renderMarks();
  });
  const calibrate = (method) => act(async () => {
    const { pairs, ready } = pairsReady(marks, captures);
    if (method === 'points' && !ready) throw new Error('capture at least 3 marked points first');
    if (method === 'hold' && !pairs.length) throw new Error('capture the reference (the first mark) first');
    const answer = await api.request('PUT', `/api/trackers/${encodeURIComponent(source())}/calibration`,
      { body: calibrationBody(method, pairs) });
    const r = answer.calibration?.residual;
    say(msg, `calibrated (${method})${r != null ? `, residual ${(r * 1000).toFixed(1)}·10⁻³ scene units` : ''}`, 'ok');
    captures.length = 0;
    renderMarks();
  });
  const reset = () => act(async () => {
    await api.request('DELETE', `/api/trackers/${encodeURIComponent(source())}/calibration`);
    say(msg, 'back to the default calibration', 'ok');
  });
  fill(root, h('h2', {}, 'Trackers'), table,
    h('details', {}, h('summary', {}, 'Calibrate'),
      h('label', {}, 'source ', select),
      h('p', { class: 'c-muted' }, `Touch each mark with ${point} and hold still, then capture.`), markRows,
      h('div', { class: 'c-actions' },
        h('button', { type: 'button', onclick: () => calibrate('points') }, 'Fit from the marks'),
        h('button', { type: 'button', onclick: () => calibrate('hold') }, 'Hold at the first mark'),
        h('button', { type: 'button', onclick: reset }, 'Reset'))),
    msg);
  renderMarks();
  const poll = async () => {
    let sources = [];
    try { sources = (await api.request('GET', '/api/trackers?limit=1')).sources ?? []; } catch { return; }
    root.hidden = sources.length === 0;
    const rows = sourceRows(sources);
    fill(table, h('tr', {}, ['source', 'status', 'rate', 'latest', 'gaps', 'confidence', 'calibration', 'why']
      .map((c) => h('th', {}, c))),
    rows.map((r) => h('tr', { dataset: { status: r.status } },
      [r.name, r.status, r.rate, r.age, r.gaps, r.confidence, r.calibration, r.why].map((c) => h('td', {}, c)))));
    const names = sources.map((s) => s.name);
    if ([...select.options].map((o) => o.value).join() !== names.join()) {
      fill(select, names.map((n) => h('option', { value: n }, n)));
    }
  };
  poll();
  return setInterval(poll, POLL_MS);
}

if (typeof document !== 'undefined' && document.getElementById('trackers-card')) {
  const store = new TokenStore();
  mountTrackers(document.getElementById('trackers-card'), new Api({ bearer: () => store.token }));
}
