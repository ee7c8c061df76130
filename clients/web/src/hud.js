// DOM overlay: scenario HUD text, connection status, the server's health, a "tracking lost"
// banner and a telemetry line.
// Desktop only (DOM labels do not show inside an immersive WebXR session; that client draws into
// the scene).

const EVENTS_SHOWN = 3;

function fmtUs(us) {
  return typeof us === 'number' ? `${(us / 1000).toFixed(2)} ms` : '–';
}

const fmtValue = (v) => (typeof v === 'number' ? String(+v.toFixed(3)) : JSON.stringify(v));

/** One scenario event as "12.34 s tap angle_deg -30 by experimenter". */
export function formatEvent({ tick, t, name, ...rest }) {
  const when = typeof t === 'number' ? `${t.toFixed(2)} s ` : '';
  const extra = Object.entries(rest).filter(([, v]) => v !== null).map(([k, v]) => `${k} ${typeof v === 'string' ? v : fmtValue(v)}`);
  return [`${when}${name ?? '?'}`, ...extra].join(' ');
}

// What a participant is told about a health reason: a few words, no internals (the console
// shows the full messages). Codes this client does not know read as a server problem.
const HEALTH_WORDS = {
  device_missing: 'device disconnected',
  device_host_down: 'devices restarting',
  device_host_restarted: 'devices restarting',
  loop_down: 'server restarting',
  loop_stalled: 'server not responding',
  tick_failures: 'server error',
  overruns: 'server overloaded',
  tracker_lost: 'tracking lost',
};

/** The short line for a `health` message: '' when ok or starting, else
 * 'Tactile feedback paused — device disconnected' (each distinct cause once). */
export function healthLine(health) {
  if (health?.status !== 'degraded') return '';
  const words = [...new Set((health.reasons ?? []).map((r) => HEALTH_WORDS[r.code] ?? 'server problem'))];
  return `Tactile feedback paused — ${words.length ? words.join(', ') : 'server problem'}`;
}

/** The banner while a tracker source is lost (state.tracking.lost): '' when none. A participant
 * is told what to do; operators and observers also see which sources. */
export function trackingLine(lost, { names = false } = {}) {
  if (!Array.isArray(lost) || lost.length === 0) return '';
  const which = names ? ` (${lost.map(String).join(', ')})` : '';
  return `Tracking lost${which} — move your hand back into the tracker's view`;
}

export class Hud {
  /**
   * @param {{hud: HTMLElement, status: HTMLElement, telemetry: HTMLElement, values?: HTMLElement,
   *          events?: HTMLElement, health?: HTMLElement}} els
   */
  constructor(els, { showValues = false } = {}) {
    this.els = els;
    this.showValues = showValues;
    this._text = null;
    this._values = null;
    this._events = []; // the last EVENTS_SHOWN, formatted
  }

  setText(text) {
    if (text === this._text) return;
    this._text = text;
    this.els.hud.textContent = text;
    this.els.hud.hidden = text === '';
  }

  setStatus(text, kind = 'info') {
    this.els.status.textContent = text;
    this.els.status.dataset.kind = kind;
  }

  /** The server's health (a `health` message): one short line while degraded, hidden otherwise. */
  setHealth(health) {
    if (!this.els.health) return;
    const line = healthLine(health);
    this.els.health.textContent = line;
    this.els.health.hidden = line === '';
    this.els.health.title = (health?.reasons ?? []).map((r) => r.message).join('\n');
  }

  /** Tracker sources lost right now (state.tracking.lost): a banner while any is, hidden otherwise. */
  setTracking(lost) {
    if (!this.els.tracking) return;
    const line = trackingLine(lost, { names: this.showValues });
    if (line === this._tracking) return;
    this._tracking = line;
    this.els.tracking.textContent = line;
    this.els.tracking.hidden = line === '';
  }

  /** Telemetry line: the server loop's p99 period and overruns, our fps and state rate. */
  setTelemetry({ telemetry = {}, fps = 0, stateHz = 0 } = {}) {
    const parts = [
      `loop p99 ${fmtUs(telemetry.period_p99_us)}`,
      `overruns ${telemetry.overruns ?? '–'}`,
      `state ${stateHz.toFixed(0)} Hz`,
      `${fps.toFixed(0)} fps`,
    ];
    if (telemetry.rt === false) parts.push('not real-time');
    this.els.telemetry.textContent = parts.join(' · ');
  }

  /** Scenario values (operators/observers only: they may give away the answer to a participant). */
  setValues(values) {
    if (!this.showValues || !this.els.values) return;
    const text = Object.entries(values ?? {})
      .map(([k, v]) => `${k} ${fmtValue(v)}`)
      .join(' · ');
    if (text === this._values) return;
    this._values = text;
    this.els.values.textContent = text;
  }

  /** Scenario events of one state frame: the last few stay on show (operators/observers only). */
  addEvents(events) {
    if (!this.showValues || !this.els.events || !events?.length) return;
    this._events = [...this._events, ...events.map(formatEvent)].slice(-EVENTS_SHOWN);
    this.els.events.textContent = this._events.join('\n');
  }
}
