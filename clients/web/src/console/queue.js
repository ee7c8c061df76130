// The trial queue of a session (GET /api/sessions/{id}: trials with seq, task, kind, index,
// params, status, attempt, responses, reason; `next` and `running` seqs).
//
// Pure part: queueRows (what each row shows and which actions it allows), formatting, progress.
// DOM part: renderQueue draws the table; a click on a row selects it.

import { h, fill } from './dom.js';
import { fmtNumber } from './answers.js';

export const KIND_LABEL = Object.freeze({
  training: 'training', trial: 'practice', main: 'main', questionnaire: 'questionnaire',
});

/** A value short: numbers without float noise, strings as is, null as "–". */
export function formatValue(v) {
  if (v === null || v === undefined) return '–';
  if (typeof v === 'number') return fmtNumber(v);
  if (typeof v === 'string') return v;
  return JSON.stringify(v);
}

/** Trial parameters as "angle_deg −10 · time_limit_s 30" (null ones left out). */
export function formatParams(params) {
  return Object.entries(params ?? {}).filter(([, v]) => v !== null && v !== undefined)
    .map(([k, v]) => `${k} ${formatValue(v)}`).join(' · ');
}

/** Answers as "answer_deg = −10" in the trial's question order, then any others. */
export function formatAnswers(responses, questions = []) {
  const r = responses ?? {};
  const order = [...questions.filter((q) => q in r), ...Object.keys(r).filter((q) => !questions.includes(q))];
  return order.map((q) => `${q} = ${formatValue(r[q])}`).join(' · ');
}

/** One row per trial: what the table shows, its highlight and the actions its status allows. */
export function queueRows(session) {
  const trials = session?.trials ?? [];
  return trials.map((t) => ({
    seq: t.seq,
    task: t.task,
    kind: t.kind,
    kindLabel: KIND_LABEL[t.kind] ?? t.kind,
    index: t.index,
    params: formatParams(t.params),
    status: t.status,
    attempt: t.attempt,
    answers: formatAnswers(t.responses, t.questions),
    questions: t.questions ?? [],
    reason: t.reason ?? '',
    deviceOff: t.device_off ?? [], // devices the trial needed that were off while it was recorded (recorder.py)
    isNext: session.next === t.seq,
    isRunning: session.running === t.seq,
    canAnswer: (t.questions?.length ?? 0) > 0 && (t.status === 'running' || t.status === 'answered'),
    canRetry: t.status === 'aborted',
    canExclude: t.status === 'answered' || t.status === 'aborted',
  }));
}

/** Counts per status and the done fraction (answered, aborted and excluded count as done). */
export function progress(session) {
  const counts = { pending: 0, running: 0, answered: 0, aborted: 0, excluded: 0 };
  for (const t of session?.trials ?? []) counts[t.status] = (counts[t.status] ?? 0) + 1;
  const total = session?.trials?.length ?? 0;
  const done = counts.answered + counts.aborted + counts.excluded;
  return { ...counts, total, done };
}

export const trialBySeq = (session, seq) => session?.trials?.find((t) => t.seq === seq) ?? null;

/** "#1 contact_angle · practice 1" — how the console names a trial in buttons and messages. */
export function trialName(t) {
  if (!t) return '';
  return `#${t.seq} ${t.task} · ${KIND_LABEL[t.kind] ?? t.kind} ${t.index + 1}`;
}

// ---- DOM -----------------------------------------------------------------------------------

// [heading, class of the <col> (its width in console.css)]
const COLUMNS = [['#', 'c-col-seq'], ['task', 'c-col-task'], ['kind', 'c-col-kind'], ['params', 'c-col-params'],
  ['status', 'c-col-status'], ['att.', 'c-col-att'], ['answers', 'c-col-answers']];

/**
 * Draw `rows` into `table` (a <table>); `selected` is the selected seq; `onSelect(seq)` on click.
 * Redraws only when something shown changed; returns the row element of `scrollTo` if any.
 */
export function renderQueue(table, rows, { selected = null, onSelect = () => {} } = {}) {
  const sig = JSON.stringify([rows, selected]);
  if (table.dataset.sig === sig) return;
  table.dataset.sig = sig;
  if (!table.tHead) {
    table.append(h('colgroup', {}, COLUMNS.map(([, cls]) => h('col', { class: cls }))),
      h('thead', {}, h('tr', {}, COLUMNS.map(([c]) => h('th', {}, c)))));
  }
  const body = table.tBodies[0] ?? table.appendChild(h('tbody'));
  fill(body, rows.map((r) => h('tr', {
    class: ['c-row', `c-status-${r.status}`, r.isNext ? 'c-next' : '', r.isRunning ? 'c-running' : '',
      r.seq === selected ? 'c-selected' : ''].filter(Boolean).join(' '),
    dataset: { seq: r.seq, status: r.status, deviceOff: r.deviceOff.join(' ') },
    tabindex: 0,
    onclick: () => onSelect(r.seq),
    onkeydown: (e) => { if (e.key === 'Enter' || e.key === ' ') { e.preventDefault(); onSelect(r.seq); } },
  },
  h('td', { class: 'c-num', title: r.isRunning ? 'running' : r.isNext ? 'next to start' : null }, r.seq),
  h('td', { class: 'c-task', title: r.task }, r.task),
  h('td', { title: `${r.kind} phase, index ${r.index}` }, `${r.kindLabel} ${r.index + 1}`),
  h('td', { class: 'c-params', title: r.params }, r.params),
  h('td', { class: 'c-status' }, h('span', { class: 'c-badge', dataset: { status: r.status } }, r.status),
    r.reason ? h('div', { class: 'c-reason', title: r.reason }, r.reason) : null,
    r.deviceOff.length ? h('div', { class: 'c-device-off', title: `recorded while ${r.deviceOff.join(', ')} (needed `
      + 'by its scenario) was off: see events.csv' }, `⚠ ${r.deviceOff.join(', ')} off`) : null),
  h('td', { class: 'c-num' }, r.attempt),
  h('td', { class: 'c-answers', title: r.answers }, r.answers))));
}
