// The page's own actuators as the rig's browser device (protocol v1.6; docs/devices.md "A browser
// actuator", docs/xr.md "Controller haptics"): a WebXR controller's
// `gamepad.hapticActuators[0].pulse(value, ms)` and a gamepad's
// `vibrationActuator.playEffect('dual-rumble', {duration, strongMagnitude, weakMagnitude})`.
//
// The page tells the server what it has (`actuators`) and plays, in every frame it renders, the
// newest state frame's `actuator` ([value, on_ms, off_ms, duration_ms, onset]: the server's encoding
// of the primary tool's cues for the browser profile). Each call lasts until the drive's next edge,
// at most HOLD_MS: a page that stops rendering (a hidden tab, a crashed XR session) goes quiet
// within HOLD_MS on its own. Tracked hands have no actuator: the page says so.

export const HOLD_MS = 100; // one call's length when no edge comes sooner (several frames even at 30 Hz)
export const NO_ACTUATOR_HANDS = 'tracked hands have no actuator';
const LOG_SIZE = 4096;

/**
 * What a drive plays at `nowMs` (page clock), `startMs` being when the page first played it:
 * `{value, ms}`, `ms` until its next edge (a pulse train's on/off, the end of a timed stimulus), at
 * most `holdMs`; value 0: off. Pure.
 */
export function drivePulse(drive, startMs, nowMs, holdMs = HOLD_MS) {
  if (!Array.isArray(drive) || !(drive[0] > 0)) return { value: 0, ms: 0 };
  const [value, onMs, offMs, durationMs] = drive;
  const t = Math.max(0, nowMs - startMs);
  let left = durationMs > 0 ? durationMs - t : Infinity;
  if (left <= 0) return { value: 0, ms: 0 };
  if (offMs > 0) {
    const phase = t % (onMs + offMs);
    if (phase >= onMs) return { value: 0, ms: 0 };
    left = Math.min(left, onMs - phase);
  }
  return { value, ms: Math.max(1, Math.min(holdMs, left)) };
}

/** The actuators of a WebXR session's input sources and of the Gamepad API's pads:
 * `{list: [{kind, hand, target}], note}` (note: why there are none, e.g. tracked hands). */
export function findActuators(inputSources, gamepads) {
  const list = [];
  let hands = false;
  for (const source of inputSources ?? []) {
    const act = source.gamepad?.hapticActuators?.[0];
    if (act && typeof act.pulse === 'function') list.push({ kind: 'xr', hand: source.handedness || 'none', target: act });
    else if (source.hand) hands = true;
  }
  for (const pad of gamepads ?? []) {
    const act = pad?.vibrationActuator;
    if (pad?.connected !== false && act && typeof act.playEffect === 'function') {
      list.push({ kind: 'gamepad', hand: 'none', target: act });
    }
  }
  return { list, note: list.length === 0 && hands ? NO_ACTUATOR_HANDS : '' };
}

function play(a, value, ms) {
  if (a.kind === 'xr') return a.target.pulse(value, ms);
  return a.target.playEffect('dual-rumble', { startDelay: 0, duration: ms, strongMagnitude: value, weakMagnitude: value });
}

function stop(a) {
  if (a.kind === 'xr') return a.target.pulse(0, 0);
  return typeof a.target.reset === 'function' ? a.target.reset()
    : a.target.playEffect('dual-rumble', { startDelay: 0, duration: 0, strongMagnitude: 0, weakMagnitude: 0 });
}

/** The page side of the browser device: announce the actuators, play the newest drive each frame. */
export class PageActuators {
  /**
   * @param {object} o
   * @param {{sendActuators: (list: string[][], note: string) => boolean}} o.conn
   * @param {() => object[]} [o.gamepads] the Gamepad API's pads
   * @param {() => number} [o.now]
   */
  constructor({ conn, gamepads = () => globalThis.navigator?.getGamepads?.() ?? [], now = () => performance.now() }) {
    this.conn = conn;
    this.gamepads = gamepads;
    this.now = now;
    this.list = [];
    this.note = '';
    this.sent = null; // the offer the server has (its signature), null: none sent on this connection
    this.drive = null;
    this.driveKey = '';
    this.startMs = 0;
    this.playing = false;
    this.rigHasDevice = false; // the state frames carry `actuator`: the rig has a browser device
    this.frames = 0;
    this.log = []; // [page ms, frame, state tick, kind, hand, value, ms]: every call, for tests
    this.changes = []; // [page ms, frames rendered before it, state tick, drive]: each new drive as it arrived
  }

  /** A new connection (welcome): the server knows nothing of this page's actuators yet. */
  connected() {
    this.sent = null;
  }

  /** What the page offers now: `{kind, hand}` each, and why none. */
  offer() {
    return { actuators: this.list.map((a) => [a.kind, a.hand]), note: this.note };
  }

  /** What the participant is told when the rig has a browser device and this page has no actuator
   * ('' otherwise): the XR panel shows it. */
  notice() {
    if (!this.rigHasDevice || this.list.length) return '';
    return this.note === NO_ACTUATOR_HANDS ? 'Tracked hands have no actuator: hold the controllers to feel the cues'
      : '';
  }

  /** A state frame arrived: its `actuator` is the newest drive (absent: the rig has no browser device). */
  state(s) {
    this.tick = s.tick;
    const drive = Array.isArray(s.actuator) ? s.actuator : null;
    this.rigHasDevice = drive !== null;
    const key = drive ? JSON.stringify(drive) : '';
    if (key !== this.driveKey) { // a new drive (a new onset): its pattern starts at the next frame
      this.driveKey = key;
      this.drive = drive;
      this.startMs = null;
      this._push(this.changes, [this.now(), this.frames, s.tick, drive]);
    }
  }

  /**
   * One rendered frame: find the actuators (`inputSources`: the XR session's, or none), tell the
   * server when they changed, and play the drive. `hand`: the hand whose controller drives the HIP
   * (its actuator alone pulses; null: every one).
   */
  frame({ inputSources = null, inXr = false, hand = null } = {}) {
    this.frames++;
    const found = findActuators(inputSources, this.gamepads());
    this.list = found.list;
    this.note = found.note;
    const sig = JSON.stringify(this.offer());
    // a page that never had any actuator and is not in XR stays silent (most pages, most rigs)
    if (sig !== this.sent && (this.sent !== null || this.list.length || inXr)) {
      if (this.conn.sendActuators(this.offer().actuators, this.note)) this.sent = sig;
    }
    const now = this.now();
    if (this.drive && this.startMs === null) this.startMs = now;
    const { value, ms } = drivePulse(this.drive, this.startMs ?? now, now);
    const targets = this.list.filter((a) => a.kind !== 'xr' || hand === null || a.hand === hand);
    if (value > 0) {
      for (const a of targets) this._call(a, value, ms, now, () => play(a, value, ms));
      this.playing = true;
    } else if (this.playing) {
      for (const a of targets) this._call(a, 0, 0, now, () => stop(a));
      this.playing = false;
    }
  }

  _push(list, row) {
    list.push(row);
    if (list.length > LOG_SIZE) list.splice(0, list.length - LOG_SIZE);
  }

  _call(a, value, ms, now, fn) {
    this._push(this.log, [now, this.frames, this.tick ?? null, a.kind, a.hand, value, ms]);
    try {
      const p = fn();
      p?.catch?.(() => {}); // a preempted effect (the next frame's) rejects: expected
    } catch (e) {
      console.warn(`viestac actuators: ${a.kind} ${a.hand}: ${e.message ?? e}`);
    }
  }
}
