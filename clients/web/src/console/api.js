// REST client of the experimenter console: the experiment API (server/api/experiment_routes.py)
// and the access API (identity, control lease, join links, audit; server/api/access_routes.py).
// Every request carries `Authorization: Bearer` with the console's access token (auth.js); a 401
// calls `onUnauthorized` so the page can ask for a log-in. A session's control token, where the
// server still hands one out, goes in `X-Control-Token`, kept in sessionStorage per session.
//
// Errors become ApiError with the HTTP status and a sentence for a person (errorText), so the
// page can show them next to the button that caused them. Pure except for `fetch` and the
// storage, both injected (tests pass fakes).

import { authHeaders } from '../auth.js';

export const TOKEN_PREFIX = 'viestac.console.token.';

export class ApiError extends Error {
  constructor(status, detail, text) {
    super(text);
    this.name = 'ApiError';
    this.status = status; // 0: no answer (network)
    this.detail = detail; // the server's `detail` (string, or FastAPI's validation list)
  }
}

/** FastAPI's `detail` as one sentence: a string as is, a validation list as "field: message; …". */
export function detailText(detail) {
  if (detail == null) return '';
  if (typeof detail === 'string') return detail;
  if (Array.isArray(detail)) {
    return detail.map((d) => {
      const loc = (d?.loc ?? []).filter((p) => p !== 'body').join('.');
      const msg = d?.msg ?? JSON.stringify(d);
      return loc ? `${loc}: ${msg}` : msg;
    }).join('; ');
  }
  return JSON.stringify(detail);
}

/** What went wrong, in plain words, from the HTTP status and the server's detail. */
export function errorText(status, detail) {
  const why = detailText(detail);
  switch (status) {
    case 0: return `The server did not answer${why ? ` (${why})` : ''}. Check the connection and try again.`;
    case 401: return `Not logged in: ${why || 'log in with a token'}.`;
    case 403: return `Not allowed: ${why || 'this needs the control lease or another role'}.`;
    case 404: return `Not found: ${why || 'no such study, session or trial'}.`;
    case 409: return `Not possible now: ${why || 'the session changed meanwhile'}. The queue has been refreshed.`;
    case 422: return `Not accepted: ${why || 'the input does not fit'}.`;
    case 429: return `Too many requests: ${why || 'wait a moment and try again'}.`;
    case 503: return `The server is busy: ${why || 'try again in a moment'}.`;
    default: return `Server error ${status}${why ? `: ${why}` : ''}.`;
  }
}

const seg = (s) => encodeURIComponent(String(s));

/**
 * The server clock minus this one, in ms, from an HTTP Date header received between `sent` and
 * `received` (this clock). The header has whole seconds, and a server may refresh it only once a
 * second (uvicorn does), so it can lag the true time by up to 2 s: an estimate within ±2.5 s is
 * that noise and counts as 0 (the same machine, or clocks kept by NTP); a larger one is a real
 * skew, corrected to about a second.
 */
export function clockOffset(date, sent, received) {
  const estimate = date + 1000 - (sent + received) / 2;
  return Math.abs(estimate) <= 2500 ? 0 : Math.round(estimate);
}

export class Api {
  /**
   * @param {object} [opts]
   * @param {string} [opts.base]     HTTP origin of the server ('' = this page's)
   * @param {Function} [opts.fetch]  fetch implementation
   * @param {Storage} [opts.storage] where session control tokens live (sessionStorage)
   * @param {Function} [opts.bearer] () → the access token (auth.js TokenStore), or null
   */
  constructor(opts = {}) {
    this.base = opts.base ?? '';
    this.fetch = opts.fetch ?? ((...a) => globalThis.fetch(...a));
    this.storage = opts.storage ?? globalThis.sessionStorage;
    this.bearer = opts.bearer ?? (() => null);
    this.onUnauthorized = null; // (ApiError) on every 401
    this.clockOffsetMs = 0; // server clock − this clock, from the Date headers (clockOffset)
  }

  token(sessionId) {
    try {
      return this.storage?.getItem(TOKEN_PREFIX + sessionId) ?? null;
    } catch {
      return null;
    }
  }

  setToken(sessionId, token) {
    try {
      if (token) this.storage?.setItem(TOKEN_PREFIX + sessionId, token);
      else this.storage?.removeItem(TOKEN_PREFIX + sessionId);
    } catch { /* storage disabled: control lasts as long as the page */ }
  }

  /** One request; resolves to the decoded JSON answer, rejects with ApiError. */
  async request(method, path, { body, sessionId } = {}) {
    const headers = { ...authHeaders(this.bearer()) };
    if (body !== undefined) headers['Content-Type'] = 'application/json';
    const token = sessionId ? this.token(sessionId) : null;
    if (token) headers['X-Control-Token'] = token;
    let res;
    const sent = Date.now();
    try {
      res = await this.fetch(`${this.base}${path}`, {
        method, headers, body: body === undefined ? undefined : JSON.stringify(body), cache: 'no-store',
      });
    } catch (e) {
      throw new ApiError(0, String(e?.message ?? e), errorText(0, String(e?.message ?? e)));
    }
    const date = Date.parse(res.headers?.get?.('date') ?? '');
    if (Number.isFinite(date)) this.clockOffsetMs = clockOffset(date, sent, Date.now());
    let answer = null;
    try {
      answer = await res.json();
    } catch {
      answer = null;
    }
    if (!res.ok) {
      const detail = answer?.detail ?? answer;
      const err = new ApiError(res.status, detail, errorText(res.status, detail));
      if (res.status === 401) this.onUnauthorized?.(err);
      throw err;
    }
    return answer;
  }

  // -- identity, the control lease, join links, audit (server/api/access_routes.py) -------------
  me() { return this.request('GET', '/api/auth/me'); }

  /** GET /api/lease → {holder, queue, session, ttl_s, you: 'holder'|'queued'|'none', position}. */
  lease() { return this.request('GET', '/api/lease'); }

  /** Ask for the lease → {status: 'granted'|'held'|'queued', position, lease}. */
  requestLease() { return this.request('POST', '/api/lease'); }

  renewLease() { return this.request('POST', '/api/lease/renew'); }

  /** Give the lease up (the next in the queue gets it), or leave the queue. */
  releaseLease() { return this.request('DELETE', '/api/lease'); }

  handOver(tokenId) { return this.request('POST', '/api/lease/handover', { body: { token_id: tokenId } }); }

  forceRelease() { return this.request('POST', '/api/lease/force-release'); }

  /** A participant join link for a study session (null: free exploration) → {url, expires_at, session, qr_svg}. */
  joinLink(sessionId = null, ttlS = undefined) {
    const body = { session_id: sessionId };
    if (ttlS !== undefined) body.ttl_s = ttlS;
    return this.request('POST', '/api/join-links', { body });
  }

  audit({ sessionId = null, limit = 100 } = {}) {
    const q = new URLSearchParams();
    if (sessionId) q.set('session_id', sessionId);
    q.set('limit', String(limit));
    return this.request('GET', `/api/audit?${q}`);
  }

  // -- studies and sessions ---------------------------------------------------------------------
  studies() { return this.request('GET', '/api/studies'); }

  study(id) { return this.request('GET', `/api/studies/${seg(id)}`); }

  sessions() { return this.request('GET', '/api/sessions'); }

  /** GET /api/sessions/{id}; its `now_utc` (the server's clock) sets the offset exactly. */
  async session(id) {
    const sent = Date.now();
    const s = await this.request('GET', `/api/sessions/${seg(id)}`);
    const now = Date.parse(s?.now_utc ?? '');
    if (Number.isFinite(now)) this.clockOffsetMs = Math.round(now - (sent + Date.now()) / 2);
    return s;
  }

  /** POST /api/sessions; keeps the returned control token for the new session. */
  async createSession(fields) {
    const s = await this.request('POST', '/api/sessions', { body: fields });
    this.setToken(s.id, s.token);
    return s;
  }

  /** POST .../control; the new token replaces any other console's. */
  async takeControl(sessionId, experimenter) {
    const { token } = await this.request('POST', `/api/sessions/${seg(sessionId)}/control`,
      { body: { experimenter } });
    this.setToken(sessionId, token);
    return token;
  }

  /**
   * Does this console still hold the session's control token? true / false / null (unknown: no
   * answer). GET .../control is read-only; it also says who holds control and since when
   * (`this.lastControl`).
   */
  async probeControl(sessionId) {
    if (!this.token(sessionId)) return false;
    try {
      this.lastControl = await this.request('GET', `/api/sessions/${seg(sessionId)}/control`, { sessionId });
      return this.lastControl.yours;
    } catch {
      return null;
    }
  }

  setNotes(sessionId, notes) {
    return this.request('PUT', `/api/sessions/${seg(sessionId)}/notes`, { body: { notes }, sessionId });
  }

  // -- the trial lifecycle ----------------------------------------------------------------------
  trial(sessionId, seq, action, body) {
    return this.request('POST', `/api/sessions/${seg(sessionId)}/trials/${seg(seq)}/${action}`,
      { body, sessionId });
  }

  start(sessionId, seq) { return this.trial(sessionId, seq, 'start'); }

  finish(sessionId, seq) { return this.trial(sessionId, seq, 'finish'); }

  abort(sessionId, seq, reason) { return this.trial(sessionId, seq, 'abort', { reason: reason ?? '' }); }

  retry(sessionId, seq) { return this.trial(sessionId, seq, 'retry'); }

  exclude(sessionId, seq, reason) { return this.trial(sessionId, seq, 'exclude', { reason }); }

  /** A participant-paced task: `action` 'pause' or 'resume' (docs/studies.md "Participant-paced tasks"). */
  pacing(sessionId, action) {
    return this.request('POST', `/api/sessions/${seg(sessionId)}/pacing/${action}`, { sessionId });
  }

  answer(sessionId, seq, question, value, enteredBy = 'experimenter') {
    return this.request('PUT', `/api/sessions/${seg(sessionId)}/trials/${seg(seq)}/responses/${seg(question)}`,
      { body: { value, entered_by: enteredBy }, sessionId });
  }
}
