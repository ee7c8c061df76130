// Live trajectory plot: the HIP (and the god-object proxy where it differs) of the last seconds,
// with the trails of the other tools (a thumb besides the index) in their fingers' colours,
// seen from the side (y right, z up) and from the top (y right, x toward the viewer = down), in
// scene units (docs/protocol.md: x toward the viewer, y right, z up).
//
// Pure part: trajSample, VIEWS, toView, fitBounds (with hysteresis, so the plot does not jitter),
// projector (equal scale on both axes). DOM part: drawTrajectory on a 2D canvas context.

import { toolColor } from '../hand.js';

export const WINDOW_S = 10;
const HIP_COLOR = '#ffd400';

/** The two views: which scene axis runs right (h) and which up (v), with its sign. */
export const VIEWS = Object.freeze({
  side: { id: 'side', label: 'side (y →, z ↑)', h: 1, v: 2, vSign: 1, hName: 'y', vName: 'z' },
  top: { id: 'top', label: 'top (y →, x ↓ toward viewer)', h: 1, v: 0, vSign: -1, hName: 'y', vName: 'x' },
});

/** A state frame reduced to what the plot needs; `others`: the tools after the primary (only
 * when the frame has some), each {name, hip, contact}. */
export function trajSample(state) {
  const sample = { t: state.t, hip: state.hip, proxy: state.proxy, contact: !!state.contact };
  if (Array.isArray(state.tools) && state.tools.length > 1) {
    sample.others = state.tools.slice(1).map((t) => ({ name: t.name, hip: t.hip, contact: !!t.contact && !t.lost }));
  }
  return sample;
}

/** The trail of one other tool: [{t, hip, contact}] of the samples that have it. */
export function otherTrails(samples) {
  const trails = new Map();
  for (const s of samples) {
    for (const o of s.others ?? []) {
      if (!trails.has(o.name)) trails.set(o.name, []);
      trails.get(o.name).push({ t: s.t, hip: o.hip, contact: o.contact });
    }
  }
  return trails;
}

/** A scene point [x, y, z] in a view's 2D frame [h, v] (v grows upward). */
export function toView(p, view) {
  return [p[view.h], view.vSign * p[view.v]];
}

/** The samples with t in [now − windowS, now]. */
export function windowed(samples, now, windowS = WINDOW_S) {
  return samples.filter((s) => s.t >= now - windowS && s.t <= now);
}

/**
 * Bounds {h0, h1, v0, v1} holding every 2D point with a margin, at least `minSpan` wide and high.
 * With `prev`, the bounds stay put while the points fit inside them and fill a fair part of them
 * (hysteresis: growing at once, shrinking only when the points use less than a third).
 */
export function fitBounds(points, prev = null, { minSpan = 0.5, pad = 0.15 } = {}) {
  if (!points.length) return prev ?? { h0: -minSpan / 2, h1: minSpan / 2, v0: -minSpan / 2, v1: minSpan / 2 };
  let h0 = Infinity; let h1 = -Infinity; let v0 = Infinity; let v1 = -Infinity;
  for (const [h, v] of points) {
    if (h < h0) h0 = h;
    if (h > h1) h1 = h;
    if (v < v0) v0 = v;
    if (v > v1) v1 = v;
  }
  if (prev && h0 >= prev.h0 && h1 <= prev.h1 && v0 >= prev.v0 && v1 <= prev.v1) {
    const used = Math.max((h1 - h0) / (prev.h1 - prev.h0), (v1 - v0) / (prev.v1 - prev.v0));
    if (used > 1 / 3 || Math.max(prev.h1 - prev.h0, prev.v1 - prev.v0) <= minSpan * (1 + 2 * pad) + 1e-9) return prev;
  }
  const grow = (a, b) => {
    const span = Math.max(b - a, minSpan);
    const mid = (a + b) / 2;
    const half = (span * (1 + 2 * pad)) / 2;
    return [mid - half, mid + half];
  };
  const [nh0, nh1] = grow(h0, h1);
  const [nv0, nv1] = grow(v0, v1);
  return { h0: nh0, h1: nh1, v0: nv0, v1: nv1 };
}

/**
 * Map view coordinates into a `width` × `height` box with `margin` pixels, the same scale on both
 * axes (so a circle stays a circle), centred; v up. Returns {map([h, v]) → [px, py], scale}.
 */
export function projector(bounds, width, height, margin = 10) {
  const w = Math.max(1, width - 2 * margin);
  const hgt = Math.max(1, height - 2 * margin);
  const scale = Math.min(w / (bounds.h1 - bounds.h0), hgt / (bounds.v1 - bounds.v0));
  const ch = (bounds.h0 + bounds.h1) / 2;
  const cv = (bounds.v0 + bounds.v1) / 2;
  return {
    scale,
    map: ([h, v]) => [width / 2 + (h - ch) * scale, height / 2 - (v - cv) * scale],
  };
}

/** A "nice" scale bar length (1, 2 or 5 × 10^k) of about `target` units. */
export function niceLength(target) {
  if (!(target > 0)) return 1;
  const k = 10 ** Math.floor(Math.log10(target));
  const m = target / k;
  return (m >= 5 ? 5 : m >= 2 ? 2 : 1) * k;
}

// ---- drawing -------------------------------------------------------------------------------

/** One tool's trail fading with age, thicker (and a darker shade of the HIP's yellow for the
 * primary) in contact. */
function drawTrail(ctx, trail, color, map, view, age) {
  for (let i = 1; i < trail.length; i++) {
    const a = trail[i - 1];
    const b = trail[i];
    ctx.globalAlpha = 1 - 0.85 * age(b.t);
    ctx.strokeStyle = b.contact && color === HIP_COLOR ? '#ffb020' : color;
    ctx.lineWidth = b.contact ? 3 : 1.5;
    const [ax, ay] = map(toView(a.hip, view));
    const [bx, by] = map(toView(b.hip, view));
    ctx.beginPath();
    ctx.moveTo(ax, ay);
    ctx.lineTo(bx, by);
    ctx.stroke();
  }
}

/**
 * Draw one view of `samples` (already windowed): the HIP trail fading with age, contact parts
 * thicker in orange, the proxy in red where it is away from the HIP, the newest HIP as a dot, the
 * other tools' trails and newest positions in their fingers' colours (thicker in contact),
 * the ground line (z = 0) in the side view, axis names and a scale bar. Returns the bounds used
 * (pass them back as `prev` next time).
 */
export function drawTrajectory(ctx, samples, view, { width, height, now, windowS = WINDOW_S, prev = null } = {}) {
  ctx.clearRect(0, 0, width, height);
  ctx.fillStyle = '#15191e';
  ctx.fillRect(0, 0, width, height);
  const pts = [];
  for (const s of samples) {
    pts.push(toView(s.hip, view));
    if (s.proxy) pts.push(toView(s.proxy, view));
    for (const o of s.others ?? []) pts.push(toView(o.hip, view));
  }
  const bounds = fitBounds(pts, prev);
  const { map, scale } = projector(bounds, width, height, 14);
  ctx.font = '11px ui-monospace, monospace';

  // ground (z = 0) in the side view
  if (view.v === 2 && bounds.v0 <= 0 && bounds.v1 >= 0) {
    const [, gy] = map([0, 0]);
    ctx.strokeStyle = '#4a535d';
    ctx.setLineDash([4, 4]);
    ctx.beginPath();
    ctx.moveTo(0, gy);
    ctx.lineTo(width, gy);
    ctx.stroke();
    ctx.setLineDash([]);
    ctx.fillStyle = '#7d8893';
    ctx.textAlign = 'right';
    ctx.fillText('z = 0', width - 4, gy - 6);
  }

  const t1 = now ?? samples[samples.length - 1]?.t ?? 0;
  const age = (t) => Math.max(0, Math.min(1, (t1 - t) / windowS));
  // proxy where it is off the HIP (a contact pushes the HIP into an object)
  ctx.strokeStyle = '#ff4d4f';
  ctx.lineWidth = 1.5;
  for (let i = 1; i < samples.length; i++) {
    const a = samples[i - 1];
    const b = samples[i];
    if (!b.contact || !a.proxy || !b.proxy) continue;
    ctx.globalAlpha = 1 - 0.8 * age(b.t);
    const [ax, ay] = map(toView(a.proxy, view));
    const [bx, by] = map(toView(b.proxy, view));
    ctx.beginPath();
    ctx.moveTo(ax, ay);
    ctx.lineTo(bx, by);
    ctx.stroke();
  }
  // other tools' trails (under the primary's), then the HIP trail
  for (const [name, trail] of otherTrails(samples)) drawTrail(ctx, trail, toolColor(name, HIP_COLOR), map, view, age);
  drawTrail(ctx, samples, HIP_COLOR, map, view, age);
  ctx.globalAlpha = 1;
  const last = samples[samples.length - 1];
  for (const o of last?.others ?? []) {
    const [x, y] = map(toView(o.hip, view));
    ctx.fillStyle = toolColor(o.name, HIP_COLOR);
    ctx.beginPath();
    ctx.arc(x, y, 4, 0, 2 * Math.PI);
    ctx.fill();
  }
  if (last) {
    const [x, y] = map(toView(last.hip, view));
    ctx.fillStyle = HIP_COLOR;
    ctx.beginPath();
    ctx.arc(x, y, 4, 0, 2 * Math.PI);
    ctx.fill();
    if (last.contact && last.proxy) {
      const [px, py] = map(toView(last.proxy, view));
      ctx.fillStyle = '#ff4d4f';
      ctx.beginPath();
      ctx.arc(px, py, 3.5, 0, 2 * Math.PI);
      ctx.fill();
    }
  }

  // labels: the view, the axes, a scale bar
  ctx.fillStyle = '#9aa4ae';
  ctx.textAlign = 'left';
  ctx.textBaseline = 'top';
  ctx.fillText(view.label, 6, 4);
  const len = niceLength((width * 0.25) / scale);
  const barPx = len * scale;
  ctx.strokeStyle = '#9aa4ae';
  ctx.lineWidth = 1;
  ctx.beginPath();
  ctx.moveTo(width - 8 - barPx, height - 8);
  ctx.lineTo(width - 8, height - 8);
  ctx.moveTo(width - 8 - barPx, height - 11);
  ctx.lineTo(width - 8 - barPx, height - 5);
  ctx.moveTo(width - 8, height - 11);
  ctx.lineTo(width - 8, height - 5);
  ctx.stroke();
  ctx.textAlign = 'right';
  ctx.textBaseline = 'bottom';
  ctx.fillText(`${len} units`, width - 8, height - 12);
  ctx.textAlign = 'left';
  if (!samples.length) {
    ctx.textBaseline = 'middle';
    ctx.textAlign = 'center';
    // two short lines: one long one was cut off on a plot narrower than it
    ctx.fillText('no HIP samples', width / 2, height / 2 - 7);
    ctx.fillText('in the last 10 s', width / 2, height / 2 + 7);
  }
  ctx.textBaseline = 'alphabetic';
  return bounds;
}
