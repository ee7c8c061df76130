// A short memory of timed samples ({t, ...}, t in seconds on the server's clock) for the live
// plots: keeps the last `maxAgeS` seconds, forgets everything when the clock jumps back (a
// restarted server starts its monotonic clock anew). Pure: no DOM, no timers.

export class History {
  constructor(maxAgeS = 12, maxLength = 5000) {
    this.maxAgeS = maxAgeS;
    this.maxLength = maxLength;
    this.items = [];
  }

  get latest() {
    return this.items.length ? this.items[this.items.length - 1] : null;
  }

  clear() {
    this.items = [];
  }

  push(sample) {
    if (!Number.isFinite(sample?.t)) return;
    const last = this.latest;
    if (last && sample.t < last.t - 0.5) this.clear(); // the clock restarted
    else if (last && sample.t < last.t) return; // a late frame: the plots want time order
    this.items.push(sample);
    const oldest = sample.t - this.maxAgeS;
    let drop = 0;
    while (drop < this.items.length - 1 && this.items[drop + 1].t <= oldest) drop++;
    drop = Math.max(drop, this.items.length - this.maxLength);
    if (drop > 0) this.items.splice(0, drop);
  }

  /** The samples of the last `seconds` before `now` (default: the newest sample's time), plus the
   * one just before the window, so a value held since before the window still shows. */
  window(seconds, now = this.latest?.t) {
    if (now === undefined) return [];
    const start = now - seconds;
    let i = this.items.length;
    while (i > 0 && this.items[i - 1].t >= start) i--;
    return this.items.slice(Math.max(0, i - 1)).filter((s) => s.t <= now);
  }
}
