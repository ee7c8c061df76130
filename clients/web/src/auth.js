// Who this browser is to the server: the token store and the single-use codes of login and join
// links (docs/security.md). An experimenter's or admin's token lives in localStorage (every tab of
// the console and the pages it opens use it); a participant's join token lives in sessionStorage
// (this tab only: closing it ends the participant's part). Codes travel only in the URL fragment,
// which the browser never sends to the server, and are exchanged at once for a token; the page
// then removes them from the address bar. Pure except for the injected storages and fetch.

export const TOKEN_KEY = 'viestac.token';
export const JOIN_TOKEN_KEY = 'viestac.join.token';
const CODE_KINDS = ['login', 'join'];
const CODE = /^[A-Za-z0-9_-]{1,200}$/;

function read(storage, key) {
  try {
    return storage?.getItem(key) || null;
  } catch {
    return null; // storage disabled
  }
}

function write(storage, key, value) {
  try {
    if (value) storage?.setItem(key, value);
    else storage?.removeItem(key);
  } catch { /* storage disabled: the token lasts as long as the page */ }
}

export class TokenStore {
  /**
   * @param {object} [opts]
   * @param {Storage} [opts.local]    localStorage (the console's token)
   * @param {Storage} [opts.session]  sessionStorage (a participant's join token)
   */
  constructor(opts = {}) {
    this.local = opts.local ?? globalThis.localStorage;
    this.session = opts.session ?? globalThis.sessionStorage;
    this.memory = null; // when no storage works
  }

  /** The console's token (admin / experimenter / observer). */
  get token() {
    return read(this.local, TOKEN_KEY) ?? this.memory;
  }

  /** A participant's join token of this tab. */
  get joinToken() {
    return read(this.session, JOIN_TOKEN_KEY);
  }

  /**
   * The token a page sends: a participant page its join token first (so a join link opened in a
   * browser where an experimenter is logged in joins as the participant), else the console's.
   */
  forRole(role) {
    return (role === 'participant' ? this.joinToken : null) ?? this.token;
  }

  save(token) {
    this.memory = token || null;
    write(this.local, TOKEN_KEY, token);
  }

  saveJoin(token) {
    write(this.session, JOIN_TOKEN_KEY, token);
  }

  clear() {
    this.memory = null;
    write(this.local, TOKEN_KEY, null);
  }
}

/**
 * The fragment without its login/join code: {kind: 'login'|'join'|null, code, rest} where `rest`
 * is the fragment to keep ('' or '#…', e.g. '#session=S1'). A malformed code is dropped too; a
 * kind not in `kinds` stays in `rest` untouched.
 */
export function takeCode(hash, kinds = CODE_KINDS) {
  const raw = String(hash ?? '').replace(/^#/, '');
  let kind = null;
  let code = null;
  const keep = [];
  for (const part of raw.split('&')) {
    if (!part) continue;
    const eq = part.indexOf('=');
    const name = eq < 0 ? part : part.slice(0, eq);
    if (kinds.includes(name)) {
      const value = decodeURIComponent(part.slice(eq + 1));
      if (kind === null && CODE.test(value)) {
        kind = name;
        code = value;
      }
      continue;
    }
    keep.push(part);
  }
  return { kind, code, rest: keep.length ? `#${keep.join('&')}` : '' };
}

/** Bearer header for a token (none without one). */
export function authHeaders(token) {
  return token ? { Authorization: `Bearer ${token}` } : {};
}

/** The server's words for a refused code, for a person. */
export function exchangeErrorText(kind, status, detail) {
  const what = kind === 'join' ? 'This join link' : 'This login link';
  if (status === 0) return `The server did not answer (${detail || 'network'}); reload to try again.`;
  if (status === 429) return 'Too many attempts: wait a minute, then reload.';
  if (status === 400 || status === 401 || status === 403 || status === 404 || status === 410 || status === 422) {
    return `${what} is not valid any more (used, expired or mistyped): ask for a new one.`;
  }
  return `${what} could not be used: server error ${status}${detail ? ` (${detail})` : ''}.`;
}

/**
 * Exchange a code at POST /api/auth/{login|join} → {token, identity}; throws an Error whose
 * message is for a person (and `.status`).
 */
export async function exchangeCode(kind, code, { base = '', fetch = (...a) => globalThis.fetch(...a) } = {}) {
  if (!CODE_KINDS.includes(kind)) throw new Error(`unknown code kind ${kind}`);
  let res;
  try {
    res = await fetch(`${base}/api/auth/${kind}`, {
      method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify({ code }),
      cache: 'no-store',
    });
  } catch (e) {
    const err = new Error(exchangeErrorText(kind, 0, String(e?.message ?? e)));
    err.status = 0;
    throw err;
  }
  let body = null;
  try {
    body = await res.json();
  } catch { /* no JSON */ }
  if (!res.ok || typeof body?.token !== 'string') {
    const detail = typeof body?.detail === 'string' ? body.detail : '';
    const err = new Error(exchangeErrorText(kind, res.ok ? 500 : res.status, detail));
    err.status = res.status;
    throw err;
  }
  return { token: body.token, identity: body.identity ?? null };
}

/**
 * Redeem a code found in `location.hash`, if any: remove it from the address bar first (so it
 * never lingers in history or a bookmark, even when the exchange fails), then exchange it and
 * keep the token. Resolves to {kind, identity} (kind null: no code), rejects with the exchange
 * error. `loc`/`history` are injected for tests.
 */
export async function redeemFragment(store, { loc = globalThis.location, history = globalThis.history,
  base = '', fetch, kinds = CODE_KINDS } = {}) {
  const { kind, code, rest } = takeCode(loc?.hash, kinds);
  if (!kind) return { kind: null, identity: null };
  history?.replaceState?.(history.state ?? null, '', `${loc.pathname}${loc.search}${rest}`);
  const { token, identity } = await exchangeCode(kind, code, { base, fetch });
  if (kind === 'join') store.saveJoin(token);
  else store.save(token);
  return { kind, identity };
}

/** A short name for an identity or a lease entry: label, else role@site, plus the token id. */
export function whoText(who) {
  if (!who) return 'nobody';
  const name = who.label || `${who.role ?? '?'}${who.site ? `@${who.site}` : ''}`;
  return `${name} (${who.token_id ?? '?'})`;
}
