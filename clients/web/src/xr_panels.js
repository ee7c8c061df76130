// What the participant reads and answers in XR, as data: the panels' lines, the count-down,
// the answer choices and which one a ray or pinch picks. DOM text does not show inside an
// immersive session, so xr_view.js draws these onto canvas textures. Pure.

import { healthLine, trackingLine } from './hud.js';

/** Lines of the instructions panel: the HUD text (scenario instructions, count-downs), then the
 * health and tracking banners when they apply. Empty lines are left out. */
export function panelLines({ hud = '', health = null, lost = [], extra = [] } = {}) {
  return [String(hud ?? ''), healthLine(health), trackingLine(lost), ...extra].flatMap((t) => t.split('\n')).filter((t) => t.trim() !== '');
}

/** Whole seconds left of a count-down ending at `endMs` (≥ 0), as shown: 3, 2, 1, then 0. */
export function countdown(endMs, nowMs) {
  return Math.max(0, Math.ceil((endMs - nowMs) / 1000));
}

/** Yaw (radians, about Y) that turns a panel at `pos` to face `head` (three.js axes: a plane's
 * front is +Z). */
export function facingYaw(pos, head) {
  return Math.atan2(head[0] - pos[0], head[2] - pos[2]);
}

/**
 * The buttons of a choice panel, left to right across u ∈ [0, 1]: a Likert scale
 * ({kind: 'likert', low, high, labels}) or buttons given as {kind: 'buttons', items: [{label, value}]}.
 * Returns [{label, value, u0, u1}].
 */
export function choiceLayout(spec) {
  const items = spec.kind === 'likert'
    ? Array.from({ length: spec.high - spec.low + 1 }, (_, i) => {
      const v = spec.low + i;
      return { label: String(v), value: v, anchor: spec.labels?.[v] ?? null };
    })
    : spec.items;
  const w = 1 / items.length;
  return items.map((it, i) => ({ ...it, u0: i * w, u1: (i + 1) * w }));
}

/** The button at u (the ray's or fingertip's hit on the panel, 0..1 left to right), or null. */
export function choiceAt(layout, u) {
  if (!(u >= 0 && u <= 1)) return null;
  return layout.find((b) => u >= b.u0 && u < b.u1) ?? layout[layout.length - 1];
}

/**
 * The angle a scene point names on an angle scale (overlay `angle_scale`: angle a sits at
 * centre + r·(0, sin a, cos a)), rounded to `stepDeg`, within the scale's range; null when the
 * point is too close to the centre to name one.
 */
export function angleAt(point, scale, stepDeg = 1) {
  const dy = point[1] - scale.centre[1];
  const dz = point[2] - scale.centre[2];
  if (Math.hypot(dy, dz) < 1e-6) return null;
  const a = (Math.atan2(dy, dz) * 180) / Math.PI;
  const from = scale.from_deg ?? -90;
  const to = scale.to_deg ?? 90;
  return Math.min(to, Math.max(from, Math.round(a / stepDeg) * stepDeg));
}

/** A pinch (or select) confirms a choice only after the hand opened again since the last one:
 * a held pinch answers once. Pure state machine. */
export class PinchLatch {
  constructor() {
    this.down = false;
  }

  /** @returns {boolean} true on the frame the pinch closes */
  update(pinched) {
    const fired = pinched && !this.down;
    this.down = pinched;
    return fired;
  }
}

/**
 * The question to show from an `ask` message (protocol v1.5): the first of the participant's
 * questions not yet answered, as a panel spec with the trial's `seq` — a Likert scale, a choice
 * as buttons, a number as the angle the right index tip points at on the angle scale (within the
 * question's bounds). null when nothing is asked.
 */
export function questionOf(ask) {
  const q = (ask?.questions ?? []).find((x) => x.answer === null || x.answer === undefined);
  if (!q || ask.seq === null || ask.seq === undefined) return null;
  const base = { id: q.id, text: q.text, seq: ask.seq };
  if (q.kind === 'likert') {
    const labels = Object.fromEntries(Object.entries(q.labels ?? {}).map(([k, v]) => [Number(k), v]));
    return { ...base, kind: 'likert', low: q.low ?? 1, high: q.high ?? 7, labels };
  }
  if (q.kind === 'choice') return { ...base, kind: 'buttons', items: q.choices.map((c) => ({ label: String(c), value: c })) };
  if (q.kind === 'number') return { ...base, kind: 'angle', low: q.low ?? null, high: q.high ?? null };
  return null;
}

/** The `input` key that carries a participant's XR answer to the console's event list (a key,
 * not a command value: the running scenario declares no answer command). */
export function answerKey(question, value) {
  return `answer:${question}=${value}`.slice(0, 32);
}
