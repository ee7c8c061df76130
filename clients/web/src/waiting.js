// May this page drive the HIP now? A participant may only in the session the lease holder opened
// for it; an experimenter's page only while its token holds the lease (docs/security.md). The
// page says "waiting for the experimenter" instead of looking broken. Pure: the page feeds it the
// welcome's identity, the last `lease` message and the last `forbidden` error, with times in ms.

const FORBIDDEN_HOLD_MS = 3000; // the server repeats a refusal at most once a second

/**
 * {waiting: bool, reason: string}. `role` is the granted role (observers never wait: they do not
 * drive); `lease` the last lease snapshot (null: none seen yet); `forbiddenAt`/`leaseAt` when the
 * last forbidden error and the last lease message came.
 */
export function waitingState({ role, identity, lease = null, leaseAt = -Infinity, forbiddenAt = -Infinity,
  nowMs = 0, ask = null } = {}) {
  if (role === 'observer' || !identity) return { waiting: false, reason: '' };
  let leaseSays = null; // true: may drive, false: may not, null: no lease message yet
  if (identity.role === 'participant' && Number.isInteger(ask?.seq)) {
    leaseSays = true; // its session's trial runs: that is its permission, whoever holds the lease
  } else if (lease) {
    if (identity.role === 'participant') leaseSays = !!identity.session && lease.session === identity.session;
    else leaseSays = !!lease.holder && lease.holder.token_id === identity.token_id;
  }
  const refusedLately = forbiddenAt > leaseAt && nowMs - forbiddenAt < FORBIDDEN_HOLD_MS;
  if (leaseSays === false || refusedLately) {
    return {
      waiting: true,
      reason: identity.role === 'participant'
        ? 'Waiting for the experimenter to start your session.'
        : 'Waiting for control: this browser does not hold the lease (request it in the console).',
    };
  }
  return { waiting: false, reason: '' };
}

/**
 * The one state the page shows over the scene, in one place (the lead adapts the words here):
 * {kind, text, showQuestion}. kind: 'refused' (for good: a dead token, a used-up join link) |
 * 'taken' (another tab or device of the session drives: the server said `session_taken`) |
 * 'reconnecting' | 'waiting' | '' (nothing: the page is live). The participant's
 * question and the scene's HUD text show only when nothing else does, so a page never says
 * "Trial 4: which angle…" and "Waiting for the experimenter" at once.
 *
 * `conn`: {status, finalReason, refusal, attempt} of connection.js; `joinError`: why a join link
 * could not be used; `ask`: the last `ask` (its `seq`: the running trial); `admittedBefore`: the
 * lease named this page's session earlier (the session was closed since).
 */
export function pageState({ role, identity = null, lease = null, leaseAt = -Infinity, forbiddenAt = -Infinity,
  nowMs = 0, conn = {}, joinError = null, ask = null, admittedBefore = false } = {}) {
  const participant = role === 'participant';
  if (joinError && !identity) return { kind: 'refused', text: joinError, showQuestion: false };
  if (conn.finalReason) {
    const why = conn.refusal ?? conn.finalReason;
    let text;
    if (participant) {
      text = `This page is not admitted (${why}). Ask the experimenter for a new join link (each join link works once).`;
    } else {
      text = `Not logged in (${why}). Log in at the console (console.html), then reload.`;
    }
    return { kind: 'refused', text, showQuestion: false };
  }
  const down = ['reconnecting', 'closed', 'failed'].includes(conn.status)
    || (conn.status === 'connecting' && (conn.attempt ?? 0) > 0);
  if (down) return { kind: 'reconnecting', text: 'Connection lost: reconnecting…', showQuestion: false };
  if (conn.watchOnly) {
    return { kind: 'taken', showQuestion: false, text: 'This session was opened in another tab or on another '
      + 'device, which takes part now; this page only watches. Reload it to take part here again.' };
  }
  const w = waitingState({ role, identity, lease, leaseAt, forbiddenAt, nowMs, ask });
  if (!w.waiting) return { kind: '', text: '', showQuestion: true };
  if (identity?.role === 'participant' && admittedBefore) {
    return { kind: 'waiting', showQuestion: false,
      text: 'Waiting for the experimenter: your session was closed for now; it goes on when it is reopened.' };
  }
  return { kind: 'waiting', text: w.reason, showQuestion: false };
}
