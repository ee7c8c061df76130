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
  nowMs = 0 } = {}) {
  if (role === 'observer' || !identity) return { waiting: false, reason: '' };
  let leaseSays = null; // true: may drive, false: may not, null: no lease message yet
  if (lease) {
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
