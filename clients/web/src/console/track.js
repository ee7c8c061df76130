// The live track of a session's psychophysics tasks: GET /api/sessions/{id}/tracks (docs/psychophysics.md)
// drawn as one SVG chart per task and condition: the level of every trial (filled = correct, open =
// wrong, ringed = reversal) and the procedure's current estimate as a dashed line. The model and the
// shapes are pure (tested under node); only TrackPanel touches the DOM.

import { h, fill } from './dom.js';

const SVG = 'http://www.w3.org/2000/svg';
export const SIZE = { width: 460, height: 170, left: 48, right: 12, top: 12, bottom: 28 };

function finite(x) {
  return typeof x === 'number' && Number.isFinite(x);
}

/** A level with its unit, for labels: 12.5 %, 250 Hz. */
export function levelText(level, unit) {
  if (!finite(level)) return '—';
  const v = Math.abs(level) >= 100 ? level.toFixed(0) : Number(level.toPrecision(3)).toString();
  return unit ? `${v} ${unit}` : v;
}

/** The tracks body → one panel per task × condition, its trials numbered 1… in seq order. */
export function trackPanels(body) {
  const panels = [];
  for (const task of body?.tasks ?? []) {
    for (const cond of task.conditions ?? []) {
      const trials = [...(cond.trials ?? [])].filter((t) => finite(t.level))
        .sort((a, b) => (a.seq ?? 0) - (b.seq ?? 0))
        .map((t, i) => ({ n: i + 1, seq: t.seq, level: t.level, answer: t.answer ?? null,
          correct: typeof t.correct === 'boolean' ? t.correct : null, reversal: !!t.reversal }));
      panels.push({ task: task.task, condition: cond.name ?? 'main', design: task.design ?? '',
        parameter: task.parameter ?? 'level', unit: task.unit ?? '', procedure: task.procedure ?? '',
        finished: !!(cond.finished ?? task.finished), estimate: finite(cond.estimate) ? cond.estimate : null, trials });
    }
  }
  return panels;
}

/** Words for a screen reader: what the chart shows. */
export function panelSummary(p) {
  const last = p.trials.at(-1);
  const right = p.trials.filter((t) => t.correct === true).length;
  const wrong = p.trials.filter((t) => t.correct === false).length;
  const reversals = p.trials.filter((t) => t.reversal).length;
  if (!last) return `${p.task}, ${p.condition}: no trials yet`;
  return `${p.task}, ${p.condition}: ${p.trials.length} trials, last level ${levelText(last.level, p.unit)}, `
    + `${right} correct, ${wrong} wrong, ${reversals} reversals, current estimate ${levelText(p.estimate, p.unit)}`
    + `${p.finished ? ', finished' : ''}`;
}

function pointTitle(p, t) {
  const verdict = t.correct === null ? 'no verdict' : t.correct ? 'correct' : 'wrong';
  return `trial ${t.n} (#${t.seq}): ${levelText(t.level, p.unit)}, answer ${t.answer ?? '—'}, ${verdict}`
    + `${t.reversal ? ', reversal' : ''}`;
}

/** The chart as shapes: [{tag, attrs, title?, text?}] in drawing order, in a SIZE box. */
export function panelShapes(p, size = SIZE) {
  const { width, height, left, right, top, bottom } = size;
  const values = [...p.trials.map((t) => t.level), ...(p.estimate === null ? [] : [p.estimate])];
  let lo = values.length ? Math.min(...values) : 0;
  let hi = values.length ? Math.max(...values) : 1;
  if (hi - lo < 1e-9) { lo -= 1; hi += 1; }
  const pad = (hi - lo) * 0.08;
  lo -= pad; hi += pad;
  const n = Math.max(p.trials.length, 2);
  const x = (i) => left + (width - left - right) * (i - 1) / (n - 1);
  const y = (v) => top + (height - top - bottom) * (hi - v) / (hi - lo);
  const r = (v) => Math.round(v * 10) / 10;
  const shapes = [
    { tag: 'line', attrs: { class: 'c-track-axis', x1: left, y1: height - bottom, x2: width - right, y2: height - bottom } },
    { tag: 'line', attrs: { class: 'c-track-axis', x1: left, y1: top, x2: left, y2: height - bottom } },
    { tag: 'text', attrs: { class: 'c-track-tick', x: left - 4, y: r(y(hi - pad)) + 4, 'text-anchor': 'end' },
      text: levelText(hi - pad, '') },
    { tag: 'text', attrs: { class: 'c-track-tick', x: left - 4, y: r(y(lo + pad)) + 4, 'text-anchor': 'end' },
      text: levelText(lo + pad, '') },
    { tag: 'text', attrs: { class: 'c-track-tick', x: width - right, y: height - 8, 'text-anchor': 'end' },
      text: `trial ${p.trials.length}` },
  ];
  if (p.trials.length > 1) {
    shapes.push({ tag: 'polyline', attrs: { class: 'c-track-line', fill: 'none',
      points: p.trials.map((t) => `${r(x(t.n))},${r(y(t.level))}`).join(' ') } });
  }
  if (p.estimate !== null) {
    shapes.push({ tag: 'line', attrs: { class: 'c-track-estimate', x1: left, x2: width - right,
      y1: r(y(p.estimate)), y2: r(y(p.estimate)), 'stroke-dasharray': '5 3' },
    title: `current estimate ${levelText(p.estimate, p.unit)}` });
  }
  for (const t of p.trials) {
    const cls = t.correct === null ? 'c-track-none' : t.correct ? 'c-track-correct' : 'c-track-wrong';
    shapes.push({ tag: 'circle', attrs: { class: `c-track-point ${cls}`, cx: r(x(t.n)), cy: r(y(t.level)), r: 3.5 },
      title: pointTitle(p, t) });
    if (t.reversal) {
      shapes.push({ tag: 'circle', attrs: { class: 'c-track-reversal', cx: r(x(t.n)), cy: r(y(t.level)), r: 7,
        fill: 'none' } });
    }
  }
  return shapes;
}

function svgElement(tag, attrs, text) {
  const el = document.createElementNS(SVG, tag);
  for (const [k, v] of Object.entries(attrs)) el.setAttribute(k, String(v));
  if (text != null) el.textContent = text;
  return el;
}

/** One panel's <figure>: an SVG with role img, a title and a description, and a caption. */
export function renderPanel(p, index, size = SIZE) {
  const id = `track-${index}`;
  const svg = svgElement('svg', { viewBox: `0 0 ${size.width} ${size.height}`, role: 'img', class: 'c-track',
    'aria-labelledby': `${id}-title ${id}-desc`, width: size.width, height: size.height });
  svg.append(svgElement('title', { id: `${id}-title` }, `${p.task} ${p.condition}: ${p.parameter} per trial`));
  svg.append(svgElement('desc', { id: `${id}-desc` }, panelSummary(p)));
  for (const s of panelShapes(p, size)) {
    const el = svgElement(s.tag, s.attrs, s.text);
    if (s.title) el.append(svgElement('title', {}, s.title));
    svg.append(el);
  }
  const caption = `${p.task} · ${p.condition} · ${p.design}${p.procedure ? ` · ${p.procedure}` : ''} · `
    + `estimate ${levelText(p.estimate, p.unit)}${p.finished ? ' · finished' : ''}`;
  return h('figure', { class: 'c-track-figure' }, svg, h('figcaption', {}, caption));
}

/**
 * The console's track card: `refresh(sessionId)` fetches the tracks and redraws when they
 * changed; a session without psychophysics tasks (or a server without the endpoint) hides the card.
 */
export class TrackPanel {
  constructor(card, body, fetchTracks) {
    this.card = card;
    this.body = body;
    this.fetchTracks = fetchTracks;
    this.sig = '';
    this.n = 0;
  }

  async refresh(sessionId) {
    const n = ++this.n;
    let data = null;
    if (sessionId) {
      try {
        data = await this.fetchTracks(sessionId);
      } catch {
        data = null; // 404: no psychophysics task in this session (or no such endpoint)
      }
    }
    if (n !== this.n) return; // a newer refresh overtook this one
    const panels = trackPanels(data);
    this.card.hidden = panels.length === 0;
    const sig = JSON.stringify(panels);
    if (sig === this.sig) return;
    this.sig = sig;
    fill(this.body, panels.map((p, i) => renderPanel(p, i)));
  }
}
