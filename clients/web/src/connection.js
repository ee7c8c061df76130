// WebSocket adapter: turns socket events into protocol messages and back. No rendering, no
// scenario logic. Reconnects with capped exponential backoff; the tracker path drops samples
// instead of queueing them when the link is slow (ws.bufferedAmount > 0). The access token goes
// in `hello.token` (never in the URL).
//
// A refused token (error `unauthorized`, close 1008) is not retried until the page has a new
// token (`setToken`), with one exception: a refusal because the hello came after the server's
// grace period (its message says "no hello …"; a loaded machine can be that slow) is retried with
// the stored token, at most AUTH_RETRIES times in a row, with the same backoff. A close whose
// reason says the token is dead (`revoked`, `expired`) is final at once. A participant connection
// told `session_taken` (another tab or device of its session drives now) stays open and only
// watches until its next welcome (a reload takes the session back).

import * as protocol from './protocol.js';

const noop = () => {};

/** Late-hello refusals retried with the stored token before the page gives up. */
export const AUTH_RETRIES = 5;
/** The server's refusal of a hello that came after its grace period (server/hub/session.py). */
const LATE_HELLO = /\bno hello\b/i;
/** Close reasons (sent with close 1008) that retrying cannot help, in words for the page. */
export const FINAL_CLOSE_REASONS = {
  revoked: 'your access was revoked',
  expired: 'your access has expired',
};

/** The final close reason named by a close event's reason text (null: none of them). */
export function finalCloseReason(reason) {
  const m = /^\s*(revoked|expired)\b/i.exec(String(reason ?? ''));
  return m ? m[1].toLowerCase() : null;
}

export class Connection {
  /**
   * @param {object} opts
   * @param {string} opts.url            ws:// or wss:// URL of the server's /ws endpoint
   * @param {string} [opts.role]         participant | operator | observer
   * @param {string} [opts.client]       free-form client name sent in hello
   * @param {string} [opts.format]       'msgpack' (default) or 'json'
   * @param {string|Function} [opts.token] access token, or a function returning the current one
   * @param {Function} [opts.WebSocket]  WebSocket constructor (tests inject a fake)
   * @param {Function} [opts.now]        clock in ms for tracker timestamps
   * @param {number} [opts.backoffMinMs] first reconnect delay
   * @param {number} [opts.backoffMaxMs] cap of the reconnect delay
   */
  constructor(opts) {
    this.url = opts.url;
    this.role = opts.role ?? 'participant';
    this.client = opts.client ?? 'viestac-web/0.1';
    this.format = opts.format ?? 'msgpack';
    this.token = opts.token ?? null;
    this.WebSocket = opts.WebSocket ?? globalThis.WebSocket;
    this.now = opts.now ?? (() => performance.timeOrigin + performance.now());
    this.backoffMinMs = opts.backoffMinMs ?? 250;
    this.backoffMaxMs = opts.backoffMaxMs ?? 5000;

    this.onWelcome = noop;
    this.onScene = noop;
    this.onState = noop;
    this.onHealth = noop; // the server's health: {status, reasons: [{code, message}]}
    this.onLease = noop; // the control lease: {holder, queue, session, ttl_s} (protocol v1.3)
    this.onAsk = noop; // what the study asks of this participant: {session, seq, task, questions, audio, instructions} (v1.5)
    this.onUnauthorized = noop; // (message, reason): refused for good (reason: a FINAL_CLOSE_REASONS key or
    // 'unauthorized'); the page needs a new token (setToken)
    this.onError = noop; // (ProtocolError-like {code, message}, source: 'server' | 'client')
    this.onStatus = noop; // (status string, detail string)

    this.ws = null;
    this.welcome = null;
    this.seq = 0; // sample counter: counts samples offered while open, so gaps = dropped samples
    this.sent = 0;
    this.dropped = 0;
    this.attempt = 0;
    this.retryTimer = null;
    this.closedByUser = false;
    this.status = 'idle';
    this.unauthorized = null; // the server's reason once it refused the token
    this.authRetries = 0; // refusals retried since the last welcome
    this.finalReason = null; // why the page was refused for good (FINAL_CLOSE_REASONS key, 'unauthorized')
    this.refusal = null; // … in words
    this.watchOnly = false; // told `session_taken`: another connection of the session drives
  }

  /** The token hello carries (a function is asked at each connect, so a new login applies). */
  currentToken() {
    const t = typeof this.token === 'function' ? this.token() : this.token;
    return t || null;
  }

  /** A new token (after a log-in): reconnect with it if the old one was refused. */
  setToken(token) {
    this.token = token;
    if (this.finalReason !== null) {
      this.unauthorized = null;
      this.finalReason = null;
      this.refusal = null;
      this.authRetries = 0;
      this.attempt = 0;
      this.connect();
    }
  }

  connect() {
    this.closedByUser = false;
    clearTimeout(this.retryTimer);
    this.retryTimer = null;
    this._setStatus('connecting', this.url);
    let ws;
    try {
      ws = new this.WebSocket(this.url, [protocol.SUBPROTOCOLS[this.format]]);
    } catch (e) {
      this._setStatus('failed', String(e.message || e));
      this._scheduleReconnect();
      return;
    }
    ws.binaryType = 'arraybuffer';
    this.ws = ws;
    ws.onopen = () => this._onOpen(ws);
    ws.onmessage = (ev) => this._onMessage(ws, ev.data);
    ws.onclose = (ev) => this._onClose(ws, ev);
    ws.onerror = () => {}; // a close event always follows; handled there
  }

  close() {
    this.closedByUser = true;
    clearTimeout(this.retryTimer);
    if (this.ws) this.ws.close(1000, 'client closing');
    this.ws = null;
    this._setStatus('closed', 'by client');
  }

  /** Drop a connection that went silent and connect again (the usual backoff). */
  restart(why = 'no frames') {
    if (this.closedByUser || this.finalReason !== null || !this.ws) return;
    this.ws.close(4000, why.slice(0, 100));
  }

  get isOpen() {
    return this.ws !== null && this.ws.readyState === 1;
  }

  /** Whether this connection may send tracker/input (observers may not); the server's role wins. */
  get canSend() {
    return (this.welcome?.role ?? this.role) !== 'observer' && !this.watchOnly;
  }

  /**
   * Send one HIP sample (scene frame). Returns true if sent. Skips the send (returns false) when
   * the socket still has unsent bytes: a slow link drops samples rather than building a queue.
   * `extra`: the v1.4 fields `point`, `points` (a tracked hand's other joints) and `ttl` (ms).
   */
  sendTracker(pos, quat = null, extra = {}) {
    if (!this.isOpen || !this.canSend) return false;
    const seq = this.seq++;
    if (this.ws.bufferedAmount > 0) {
      this.dropped++;
      return false;
    }
    this._send(protocol.tracker(seq, this.now(), pos, quat, extra));
    this.sent++;
    return true;
  }

  /** Send a key/command event; `value` (a command's argument) only when given. Returns true if sent. */
  sendInput(key, action, value = undefined) {
    if (!this.isOpen || !this.canSend) return false;
    this._send(protocol.input(key, action, value));
    return true;
  }

  /** v1.5: the participant's answer to question `question` of trial `seq` (an `ask`). Returns true if sent. */
  sendAnswer(seq, question, value) {
    if (!this.isOpen || !this.canSend) return false;
    this._send(protocol.answer(seq, question, value));
    return true;
  }

  /** v1.6: the actuators this page can drive (`[[kind, hand], ...]`) and why none (`note`). */
  sendActuators(actuators, note = '') {
    if (!this.isOpen || !this.canSend) return false;
    this._send(protocol.actuators(actuators, note));
    return true;
  }

  // -- internals --------------------------------------------------------------------------------

  _send(msg) {
    const fmt = this.welcome?.format ?? this.format;
    this.ws.send(protocol.encode(msg, fmt));
  }

  _setStatus(status, detail = '') {
    this.status = status;
    this.onStatus(status, detail);
  }

  _onOpen(ws) {
    if (ws !== this.ws) return;
    // A server that picked no subprotocol speaks the default (msgpack).
    if (ws.protocol === protocol.SUBPROTOCOLS.json) this.format = 'json';
    else if (ws.protocol === protocol.SUBPROTOCOLS.msgpack) this.format = 'msgpack';
    this._setStatus('open', this.url);
    // Observers may skip hello, but sending it states the protocol version explicitly.
    this._send(protocol.hello(this.role, this.client, this.currentToken()));
  }

  _onMessage(ws, data) {
    if (ws !== this.ws) return;
    const fmt = this.welcome?.format ?? this.format;
    const { msg, error } = protocol.parse(data, fmt);
    if (error) {
      if (error.code === 'unknown_type') return; // newer server, newer message: ignore
      this.onError(error, 'client');
      return;
    }
    switch (msg.type) {
      case 'welcome':
        this.welcome = msg;
        this.watchOnly = false; // a new welcome takes the session (the server tells the other one)
        this.attempt = 0;
        this.authRetries = 0;
        this.unauthorized = null;
        this._setStatus('ready', `client ${msg.client_id} (${msg.role}, ${msg.format})`);
        this.onWelcome(msg);
        break;
      case 'scene':
        this.onScene(msg);
        break;
      case 'state':
        this.onState(msg);
        break;
      case 'health':
        this.onHealth(msg);
        break;
      case 'lease':
        this.onLease(msg);
        break;
      case 'ask':
        this.onAsk(msg);
        break;
      case 'error':
        if (msg.code === 'unauthorized') this.unauthorized = msg.message ?? 'unauthorized';
        if (msg.code === 'session_taken') this.watchOnly = true;
        this.onError(msg, 'server');
        break;
      default:
        break; // client → server types echoed back, or anything else: ignore
    }
  }

  _onClose(ws, ev) {
    if (ws !== this.ws) return;
    this.ws = null;
    this.welcome = null;
    if (this.closedByUser) return;
    const final = finalCloseReason(ev.reason); // whatever the code (1008 today)
    const refused = final !== null || this.unauthorized !== null
      || (ev.code === 1008 && /unauthori[sz]ed/i.test(ev.reason ?? ''));
    if (refused) {
      const why = final !== null ? FINAL_CLOSE_REASONS[final] : (this.unauthorized ?? (ev.reason || 'unauthorized'));
      this.unauthorized = null;
      if (final === null && LATE_HELLO.test(why) && this.authRetries < AUTH_RETRIES) {
        // Only slow, not refused: the same token gets in on the next attempt.
        this.authRetries++;
        this._setStatus('closed', `refused (${why}); trying again (${this.authRetries} of ${AUTH_RETRIES})`);
        this._scheduleReconnect();
        return;
      }
      // The same token would be refused again: wait for setToken().
      this.finalReason = final ?? 'unauthorized';
      this.refusal = why;
      this._setStatus('unauthorized', why);
      this.onUnauthorized(why, this.finalReason);
      return;
    }
    if (ev.code === 1002) {
      // unsupported_version: retrying cannot help.
      this._setStatus('failed', `server closed: protocol error (${ev.reason || 1002})`);
      return;
    }
    this._setStatus('closed', `code ${ev.code}${ev.reason ? `: ${ev.reason}` : ''}`);
    this._scheduleReconnect();
  }

  _scheduleReconnect() {
    if (this.closedByUser) return;
    const base = Math.min(this.backoffMaxMs, this.backoffMinMs * 2 ** this.attempt);
    const delay = Math.round(base * (0.75 + 0.5 * Math.random()));
    this.attempt++;
    this._setStatus('reconnecting', `in ${(delay / 1000).toFixed(1)} s`);
    this.retryTimer = setTimeout(() => this.connect(), delay);
  }
}
