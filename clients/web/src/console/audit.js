// The audit log view: rows of GET /api/audit ({id, utc, token_id, role, site, action, target,
// result, session_id, detail}) as table cells, newest first. Pure formatting plus one DOM function.

import { h, fill } from './dom.js';

/** `utc` (UTC seconds or an ISO string) as local time of day, with the date when not today. */
export function auditTime(utc, today = new Date()) {
  const d = typeof utc === 'number' ? new Date(utc * 1000) : new Date(utc ?? '');
  if (Number.isNaN(d.getTime())) return String(utc ?? '');
  const time = d.toLocaleTimeString([], { hour12: false });
  return d.toDateString() === today.toDateString() ? time : `${d.toISOString().slice(0, 10)} ${time}`;
}

/** Whether a result is a refusal (anything that is not ok / a 2xx status). */
export function refused(result) {
  const r = String(result ?? '');
  return !(r === 'ok' || r === '' || /^2\d\d\b/.test(r) || r === 'granted' || r === 'queued' || r === 'held');
}

/** Table rows: newest first, each {id, time, who, action, target, result, refused}. */
export function auditRows(rows, today = new Date()) {
  return [...(rows ?? [])]
    .sort((a, b) => (b.id ?? 0) - (a.id ?? 0))
    .map((r) => ({
      id: r.id,
      time: auditTime(r.utc, today),
      who: r.token_id ? `${r.role ?? '?'}${r.site ? `@${r.site}` : ''} ${r.token_id}` : 'anonymous',
      action: r.action ?? '',
      target: [r.target, r.session_id && r.session_id !== r.target ? `session ${r.session_id}` : null]
        .filter(Boolean).join(' · '),
      result: String(r.result ?? ''),
      refused: refused(r.result),
    }));
}

export function renderAudit(table, rows) {
  fill(table,
    h('thead', {}, h('tr', {}, ['time', 'who', 'action', 'target', 'result'].map((c) => h('th', {}, c)))),
    h('tbody', {}, rows.length ? rows.map((r) => h('tr', { class: r.refused ? 'c-refused' : '' },
      h('td', {}, r.time), h('td', {}, r.who), h('td', {}, r.action), h('td', {}, r.target), h('td', {}, r.result)))
      : h('tr', {}, h('td', { colspan: 5, class: 'c-muted' }, 'no entries'))));
}
