// Live cue timeline: the device-independent cues of the state frames (docs/protocol.md `cues`,
// server/core/cues.py) over the last seconds, one lane per kind of cue: contact, vibration intensity,
// pulse train on/off, tilt direction, and texture / stiffness / temperature / friction when a
// scenario uses them.
//
// Pure part: cueSample (state frame → sample), cueValues, timelineLanes (samples → lanes of
// runs, pulses expanded into on/off from t_on/t_off), laneText. DOM part: drawTimeline on a 2D
// canvas context.

export const WINDOW_S = 10;
export const FAST_PULSE_MS = 30; // a pulse period shorter than this is drawn as a band, not pulses
const MAX_PULSES = 2000;

export const LANES = Object.freeze([
  { id: 'contact', label: 'contact', type: 'binary', color: '#9aa4ae', always: true },
  { id: 'vibration', label: 'vibration', type: 'level', unit: '%', max: 100, color: '#4fc3f7', always: true },
  { id: 'pulse', label: 'pulse on/off', type: 'pulse', unit: '%', max: 100, color: '#ffb020', always: true },
  { id: 'tilt', label: 'tilt direction', type: 'direction', color: '#3ddc84', always: true },
  { id: 'texture', label: 'texture', type: 'level', unit: 'Hz', max: null, color: '#ce93d8' },
  { id: 'stiffness', label: 'stiffness', type: 'level', unit: '', max: 1, color: '#f48fb1' },
  { id: 'temperature', label: 'temperature', type: 'level', unit: '°C', max: 50, color: '#ff7043' },
  { id: 'friction', label: 'friction', type: 'level', unit: 'µ', max: 5, color: '#bcaaa4' },
]);

/** A state frame reduced to what the timeline needs. */
export function cueSample(state) {
  return { t: state.t, contact: !!state.contact, cues: Array.isArray(state.cues) ? state.cues : [] };
}

/** The value of every lane in one frame's cues (null: not active). A `stop` cue silences all. */
const SILENT = Object.freeze({ vibration: null, pulse: null, tilt: null, texture: null, stiffness: null,
  temperature: null, friction: null });

export function cueValues(cues) {
  const v = { ...SILENT };
  for (const c of cues ?? []) {
    if (c?.kind === 'stop') return { ...SILENT, stop: true };
    switch (c?.kind) {
      case 'vibration': v.vibration = c.intensity_pct ?? 100; break;
      case 'pulse_train': v.pulse = { on: c.t_on_ms ?? 50, off: c.t_off_ms ?? 200, intensity: c.intensity_pct ?? 100 };
        break;
      case 'tilt': v.tilt = { direction: c.direction_deg ?? 0, magnitude: c.magnitude_pct ?? 100 }; break;
      case 'texture': v.texture = { hz: 1e6 / (c.period_us ?? 4000), intensity: c.intensity_pct ?? 100 }; break;
      case 'stiffness': v.stiffness = c.relative ?? 1; break;
      case 'temperature': v.temperature = c.celsius ?? 32; break;
      case 'friction': v.friction = c.coefficient ?? 0.5; break;
      default: break; // a newer cue kind: not plotted
    }
  }
  return v;
}

const same = (a, b) => a === b || (a !== null && b !== null && typeof a === 'object' && typeof b === 'object'
  && JSON.stringify(a) === JSON.stringify(b));

/**
 * Runs of equal values: [{t0, t1, value}] over [start, end], each sample's value held until the
 * next sample (the last one until `end`); null values leave gaps. Runs start at the sample where
 * the value appeared (t0 may be before `start`: `from` keeps the true start for pulse phases).
 */
export function runsOf(samples, get, start, end) {
  const runs = [];
  let cur = null;
  for (let i = 0; i < samples.length; i++) {
    const s = samples[i];
    const value = get(s);
    const t1 = i + 1 < samples.length ? samples[i + 1].t : end;
    if (cur && same(cur.value, value) && cur.t1 >= s.t) {
      cur.t1 = t1;
      continue;
    }
    cur = value === null || value === undefined || value === false ? null : { t0: s.t, t1, value };
    if (cur) runs.push(cur);
  }
  return runs.filter((r) => r.t1 > start && r.t0 < end)
    .map((r) => ({ from: r.t0, t0: Math.max(r.t0, start), t1: Math.min(r.t1, end), value: r.value }));
}

/** The on-intervals of a pulse run: on for `on` ms, off for `off` ms, from the run's true start. */
export function pulseIntervals(run, maxCount = MAX_PULSES) {
  const { on, off } = run.value;
  const period = (on + off) / 1000;
  if (on <= 0) return [];
  if (off <= 0) return [[run.t0, run.t1]];
  if (period * 1000 < FAST_PULSE_MS) return null; // too fast to draw one by one
  const out = [];
  let k = Math.max(0, Math.floor((run.t0 - run.from) / period));
  for (; out.length < maxCount; k++) {
    const a = run.from + k * period;
    if (a >= run.t1) break;
    const b = a + on / 1000;
    if (b > run.t0) out.push([Math.max(a, run.t0), Math.min(b, run.t1)]);
  }
  return out;
}

/** Text of a lane's current value ("off" when idle). */
export function laneText(id, value) {
  if (value === null || value === undefined || value === false) return id === 'contact' ? 'no' : 'off';
  const r = (x, d = 0) => String(Number(x.toFixed(d)));
  switch (id) {
    case 'contact': return 'yes';
    case 'vibration': return `${r(value)} %`;
    case 'pulse': return `${r(value.on)}/${r(value.off)} ms ${r(value.intensity)}%`;
    case 'tilt': return `${r(value.direction)}° ${directionName(value.direction)} ${r(value.magnitude)}%`;
    case 'texture': return `${r(value.hz, 1)} Hz ${r(value.intensity)}%`;
    case 'stiffness': return r(value, 2);
    case 'temperature': return `${r(value, 1)} °C`;
    case 'friction': return `µ ${r(value, 2)}`;
    default: return String(value);
  }
}

/** Tilt directions of server/core/cues.py (0 front, 90 right, 180 back, 270 left) as F, FR, R, … */
export function directionName(deg) {
  const names = ['F', 'FR', 'R', 'BR', 'B', 'BL', 'L', 'FL'];
  return names[Math.round((((deg % 360) + 360) % 360) / 45) % 8];
}

/**
 * The lanes to draw for `samples` (cueSample objects) over [now − windowS, now]: the always-shown
 * ones plus any other kind active in the window. Each lane: {id, label, type, unit, max, color,
 * runs: [{t0, t1, value}], pulses?: [[t0, t1]] | null (null: too fast), current, text}.
 */
export function timelineLanes(samples, { now, windowS = WINDOW_S } = {}) {
  const end = now ?? (samples.length ? samples[samples.length - 1].t : 0);
  const start = end - windowS;
  const values = samples.map((s) => ({ t: s.t, contact: s.contact, ...cueValues(s.cues) }));
  const lanes = [];
  for (const spec of LANES) {
    const runs = runsOf(values, (v) => v[spec.id], start, end);
    if (!spec.always && runs.length === 0) continue;
    const lane = { ...spec, runs, start, end };
    const last = values.length ? values[values.length - 1][spec.id] : null;
    lane.current = last ?? null;
    lane.text = laneText(spec.id, lane.current);
    if (spec.type === 'pulse') {
      lane.pulses = [];
      for (const run of runs) {
        const p = pulseIntervals(run);
        if (p === null) run.fast = true;
        else lane.pulses.push(...p);
      }
    }
    if (spec.id === 'texture') lane.max = Math.max(1, ...runs.map((r) => r.value.hz));
    lanes.push(lane);
  }
  return lanes;
}

// ---- drawing -------------------------------------------------------------------------------

const LABEL_W = 118; // lane name over its current value
const AXIS_H = 16;
export const LANE_H = 30;

/** The canvas height (CSS pixels) that gives every lane LANE_H. */
export const timelineHeight = (lanes) => AXIS_H + LANE_H * Math.max(1, lanes.length);

/** Draw the lanes on a 2D context of a canvas `width` × `height` CSS pixels (already scaled). */
export function drawTimeline(ctx, lanes, { width, height, windowS = WINDOW_S } = {}) {
  ctx.clearRect(0, 0, width, height);
  ctx.fillStyle = '#15191e';
  ctx.fillRect(0, 0, width, height);
  const x0 = LABEL_W;
  const x1 = Math.max(x0 + 10, width - 8);
  const laneH = Math.max(12, (height - AXIS_H) / Math.max(1, lanes.length));
  const end = lanes[0]?.end ?? 0;
  const start = end - windowS;
  const X = (t) => x0 + ((t - start) / windowS) * (x1 - x0);
  ctx.font = '11px ui-monospace, monospace';
  ctx.textBaseline = 'middle';

  // time grid: one line per second, labels every 2 s (every 5 s when narrow)
  const every = (x1 - x0) / windowS >= 30 ? 2 : 5;
  ctx.strokeStyle = '#2a3038';
  ctx.fillStyle = '#7d8893';
  ctx.lineWidth = 1;
  for (let s = 0; s <= windowS; s++) {
    const x = Math.round(X(start + s)) + 0.5;
    ctx.beginPath();
    ctx.moveTo(x, 0);
    ctx.lineTo(x, height - AXIS_H);
    ctx.stroke();
    if (s % every === 0) {
      ctx.textAlign = s === windowS ? 'right' : s === 0 ? 'left' : 'center';
      ctx.fillText(s === windowS ? 'now' : `−${windowS - s} s`, x, height - AXIS_H / 2);
    }
  }

  lanes.forEach((lane, i) => {
    const top = i * laneH;
    const pad = 3;
    const y0 = top + pad;
    const hh = laneH - 2 * pad;
    ctx.strokeStyle = '#2a3038';
    ctx.beginPath();
    ctx.moveTo(0, top + laneH + 0.5);
    ctx.lineTo(width, top + laneH + 0.5);
    ctx.stroke();
    ctx.textAlign = 'left';
    ctx.fillStyle = lane.color;
    ctx.fillText(lane.label, 6, top + laneH * 0.3);
    ctx.fillStyle = lane.current === null ? '#7d8893' : '#e8e8e8';
    ctx.fillText(lane.text, 6, top + laneH * 0.72);
    ctx.fillStyle = lane.color;
    ctx.strokeStyle = lane.color;

    if (lane.type === 'binary') {
      for (const r of lane.runs) ctx.fillRect(X(r.t0), y0 + hh * 0.25, Math.max(1, X(r.t1) - X(r.t0)), hh * 0.5);
    } else if (lane.type === 'level') {
      for (const r of lane.runs) {
        const v = typeof r.value === 'object' ? r.value.hz : r.value;
        const f = Math.max(0.04, Math.min(1, v / (lane.max || 1)));
        ctx.fillRect(X(r.t0), y0 + hh * (1 - f), Math.max(1, X(r.t1) - X(r.t0)), hh * f);
      }
    } else if (lane.type === 'pulse') {
      for (const r of lane.runs) {
        if (!r.fast) continue;
        ctx.globalAlpha = 0.45;
        ctx.fillRect(X(r.t0), y0, Math.max(1, X(r.t1) - X(r.t0)), hh);
        ctx.globalAlpha = 1;
      }
      const intensityAt = (t) => lane.runs.find((r) => r.t0 <= t && t <= r.t1)?.value.intensity ?? 100;
      for (const [a, b] of lane.pulses ?? []) {
        const f = Math.max(0.15, intensityAt(a) / 100);
        ctx.fillRect(X(a), y0 + hh * (1 - f), Math.max(1, X(b) - X(a)), hh * f);
      }
    } else if (lane.type === 'direction') {
      ctx.strokeStyle = '#2a3038'; // guides at right, back and left (front is the lane's top)
      for (const d of [90, 180, 270]) {
        const y = Math.round(y0 + hh * (d / 360)) + 0.5;
        ctx.beginPath();
        ctx.moveTo(x0, y);
        ctx.lineTo(x1, y);
        ctx.stroke();
      }
      ctx.fillStyle = lane.color;
      for (const r of lane.runs) {
        const y = y0 + hh * (r.value.direction / 360);
        ctx.globalAlpha = 0.35 + 0.65 * Math.min(1, r.value.magnitude / 100);
        ctx.fillRect(X(r.t0), y - 2, Math.max(2, X(r.t1) - X(r.t0)), 4);
      }
      ctx.globalAlpha = 1;
    }
  });
}
