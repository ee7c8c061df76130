// The headset draws at 72-120 Hz, the server sends state at 60 Hz (and in every tick whose cues
// changed). Between frames a moved object or proxy is blended from where it was drawn toward
// the newest state over a short window, so motion is smooth without waiting a whole state period;
// a change of contact is drawn at once, so the picture never trails the tactile cue by the blend
// (docs/xr.md "Timing"). Pure: the clock is passed in (ms).

export const BLEND_MS = 8; // at most this much later than the newest state; < the 15 ms budget

const lerp = (a, b, k) => a.map((v, i) => v + (b[i] - v) * k);

export class Blend {
  constructor(blendMs = BLEND_MS) {
    this.blendMs = blendMs;
    this.from = new Map(); // key → position drawn when the newest target came
    this.to = new Map(); // key → newest target
    this.at = -Infinity; // ms when the newest targets came
    this.drawn = new Map();
  }

  /** New targets (key → [x,y,z]) arrived at `nowMs`; `snap`: keys to draw at their target at once. */
  push(targets, nowMs, snap = []) {
    const snapSet = new Set(snap);
    for (const [key, p] of Object.entries(targets)) {
      const drawn = this.drawn.get(key);
      this.from.set(key, drawn && !snapSet.has(key) ? drawn : p);
      this.to.set(key, p);
    }
    for (const key of [...this.to.keys()]) {
      if (!(key in targets)) {
        this.to.delete(key);
        this.from.delete(key);
        this.drawn.delete(key);
      }
    }
    this.at = nowMs;
  }

  /** `key` was drawn at `p` by something other than the blend (a contact predicted in the
   * frame, xr_predict.js): the next target blends from there instead of jumping. */
  drawnAs(key, p) {
    this.drawn.set(key, p);
  }

  /** The positions to draw at `nowMs`. */
  sample(nowMs) {
    const k = this.blendMs <= 0 ? 1 : Math.min(1, Math.max(0, (nowMs - this.at) / this.blendMs));
    const out = {};
    for (const [key, to] of this.to) {
      const p = lerp(this.from.get(key), to, k);
      this.drawn.set(key, p);
      out[key] = p;
    }
    return out;
  }
}

/** The tools whose contact changed between two state frames' tool lists: they snap. */
export function contactChanged(prevTools, tools) {
  const before = new Map((prevTools ?? []).map((t) => [t.name, !!t.contact]));
  return (tools ?? []).filter((t) => before.get(t.name) !== !!t.contact).map((t) => t.name);
}
