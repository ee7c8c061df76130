// The control lease as the console shows it (docs/security.md): who holds the rig, the queue,
// which participant session is open, and what this console may do about it. Pure (view model and
// timing); the DOM rendering is one function at the end that only touches `document` when called.

import { h, fill } from './dom.js';
import { whoText } from '../auth.js';

/**
 * Where `me` stands in a lease snapshot: 'holder' | 'queued' | 'none' and its queue position.
 * GET /api/lease says so itself (`you`, `position`); a `lease` message over the WebSocket does
 * not, so it is worked out from the token ids.
 */
export function standing(lease, me) {
  if (lease?.you) return { you: lease.you, position: lease.position ?? null };
  const id = me?.token_id;
  if (!lease || !id) return { you: 'none', position: null };
  if (lease.holder?.token_id === id) return { you: 'holder', position: null };
  const q = (lease.queue ?? []).find((e) => e.token_id === id);
  return q ? { you: 'queued', position: q.position ?? (lease.queue.indexOf(q) + 1) } : { you: 'none', position: null };
}

/** Seconds until `expires_at` (UTC seconds) by this clock corrected by the server's offset; null without. */
export function remainingS(expiresAt, nowMs, offsetMs = 0) {
  if (!Number.isFinite(expiresAt)) return null;
  return Math.max(0, expiresAt - (nowMs + offsetMs) / 1000);
}

/** How often the holder (or a queued requester) renews: a quarter of the lease's time to live. */
export function renewIntervalMs(ttlS) {
  const ttl = Number.isFinite(ttlS) && ttlS > 0 ? ttlS : 60;
  return Math.max(1000, Math.min(60_000, (ttl * 1000) / 4));
}

const ELEVATED = new Set(['admin', 'experimenter']);

/**
 * Everything the lease card shows: {holder, queue rows, session, you, position, actions}. An
 * action is offered only when the server would accept it: request (admin/experimenter not in it),
 * release (holder), leave (queued), hand over (holder, to each queued token), force release
 * (admin, when someone else holds it), join link (holder).
 */
export function leaseView(lease, me, { nowMs = Date.now(), offsetMs = 0 } = {}) {
  const { you, position } = standing(lease, me);
  const role = me?.role ?? null;
  const holder = lease?.holder ?? null;
  const canLead = ELEVATED.has(role);
  const queue = (lease?.queue ?? []).map((e, i) => ({
    tokenId: e.token_id,
    who: whoText(e),
    position: e.position ?? i + 1,
    mine: e.token_id === me?.token_id,
    handOver: you === 'holder' && e.token_id !== me?.token_id,
  }));
  return {
    holder: holder ? {
      tokenId: holder.token_id,
      who: whoText(holder),
      mine: you === 'holder',
      since: holder.since ?? null,
      remainingS: remainingS(holder.expires_at, nowMs, offsetMs),
    } : null,
    queue,
    session: lease?.session ?? null,
    ttlS: lease?.ttl_s ?? null,
    you,
    position,
    actions: {
      request: canLead && you === 'none',
      release: you === 'holder',
      leave: you === 'queued',
      renew: you === 'holder' || you === 'queued',
      forceRelease: role === 'admin' && holder !== null && you !== 'holder',
      joinLink: you === 'holder',
    },
  };
}

/** One line for the header: who controls the rig, from this console's point of view. */
export function leaseSummary(view) {
  if (!view.holder) return 'Nobody controls the rig';
  if (view.you === 'holder') return 'You control the rig';
  const q = view.you === 'queued' ? ` · you are #${view.position} in the queue` : '';
  return `${view.holder.who} controls the rig${q}`;
}

function fmtS(s) {
  if (s === null) return '';
  return s >= 90 ? `${Math.round(s / 60)} min` : `${Math.round(s)} s`;
}

/**
 * Releasing would close the open participant session while one of its trials runs: the words of
 * the warning before (null: nothing to warn about). `runningSeq`: the running trial of the
 * session this console has open (null: none), `sessionId` that session.
 */
export function releaseWarning(lease, sessionId, runningSeq) {
  const open = lease?.session ?? null;
  if (!open || open !== sessionId || runningSeq === null || runningSeq === undefined) return null;
  return `Releasing closes participant session ${open} while trial #${runningSeq} runs: the participant's page `
    + 'stops driving and cannot answer until the session is opened again (Create join link). Release anyway?';
}

/** The participant session the lease had open was closed while a trial of it ran: the card's words. */
export function closedWarning(before, after, sessionId, runningSeq) {
  const was = before?.session ?? null;
  if (!was || was === (after?.session ?? null) || was !== sessionId) return null;
  if (runningSeq === null || runningSeq === undefined) return null;
  return `Participant session ${was} was closed while trial #${runningSeq} runs: the participant waits and cannot `
    + 'answer. To reopen it, hold the lease (Request control) and create a join link for it again.';
}

/** What the card shows, without the seconds that tick: it is drawn again only when this changes. */
function cardSignature(view, warning) {
  return JSON.stringify({ ...view, holder: view.holder && { ...view.holder, remainingS: null }, warning });
}

const expiresText = (holder) => (holder?.remainingS !== null && holder?.remainingS !== undefined
  ? ` · expires in ${fmtS(holder.remainingS)} unless renewed` : '');

/**
 * Draw the lease card into `el` (DOM). `on` = {request, release, leave, forceRelease, handOver(tokenId)}.
 * The card is built again only when what it says changes (a button that is replaced under a click
 * is lost); the expiry countdown is updated in place. `warning`: a participant session closed mid-trial.
 */
export function renderLease(el, view, on, warning = null) {
  const sig = cardSignature(view, warning);
  if (el.dataset.sig === sig) {
    const exp = el.querySelector('#lease-expires');
    if (exp) exp.textContent = expiresText(view.holder);
    return;
  }
  el.dataset.sig = sig;
  const holder = view.holder
    ? h('div', { class: 'c-lease-holder', dataset: { mine: view.holder.mine ? 'yes' : 'no' } },
      h('span', { class: 'c-muted' }, 'holder '), h('strong', { id: 'lease-holder' }, view.holder.who),
      view.holder.mine ? ' (you)' : '',
      h('span', { class: 'c-muted', id: 'lease-expires' }, expiresText(view.holder)))
    : h('div', { class: 'c-lease-holder' }, h('strong', { id: 'lease-holder' }, 'nobody'),
      h('span', { class: 'c-muted' }, ' holds the lease'));
  const queue = view.queue.length
    ? h('ol', { class: 'c-lease-queue', id: 'lease-queue' }, view.queue.map((q) => h('li', { dataset: { token: q.tokenId } },
      q.who, q.mine ? ' (you)' : '',
      q.handOver ? h('button', { type: 'button', class: 'c-small', onclick: () => on.handOver(q.tokenId) }, 'hand over') : null)))
    : h('div', { class: 'c-muted', id: 'lease-queue' }, 'queue empty');
  const a = view.actions;
  const buttons = [
    a.request ? h('button', { type: 'button', id: 'lease-request', class: 'c-primary', onclick: on.request }, 'Request control') : null,
    a.release ? h('button', { type: 'button', id: 'lease-release', onclick: on.release }, 'Release') : null,
    a.leave ? h('button', { type: 'button', id: 'lease-leave', onclick: on.release }, 'Leave the queue') : null,
    a.forceRelease ? h('button', { type: 'button', id: 'lease-force', class: 'c-danger', onclick: on.forceRelease },
      'Force release') : null,
  ].filter(Boolean);
  fill(el, holder, queue,
    view.session ? h('div', { class: 'c-muted' }, 'participant session open: ', h('code', {}, view.session)) : null,
    warning ? h('div', { class: 'c-warn', id: 'lease-warning', role: 'alert' }, warning) : null,
    buttons.length ? h('div', { class: 'c-actions' }, buttons) : null);
}
