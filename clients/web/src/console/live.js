// The console's live panels: one observer WebSocket (connection.js, role "observer": it sends no
// tracker and no input), whose state frames feed the cue timeline and the trajectory plots.
// The participant's scene itself is the observer page of the web client in an <iframe>.

import { Connection } from '../connection.js';
import { History } from './history.js';
import { cueSample, timelineLanes, drawTimeline, timelineHeight, WINDOW_S } from './timeline.js';
import { trajSample, windowed, drawTrajectory, VIEWS } from './trajectory.js';

/** Size a canvas's backing store to its CSS size × devicePixelRatio; returns its 2D context. */
function prepare(canvas) {
  const dpr = window.devicePixelRatio || 1;
  const w = canvas.clientWidth;
  const hgt = canvas.clientHeight;
  if (canvas.width !== Math.round(w * dpr) || canvas.height !== Math.round(hgt * dpr)) {
    canvas.width = Math.round(w * dpr);
    canvas.height = Math.round(hgt * dpr);
  }
  const ctx = canvas.getContext('2d');
  ctx.setTransform(dpr, 0, 0, dpr, 0, 0);
  return { ctx, width: w, height: hgt };
}

export class LivePanels {
  /**
   * @param {object} els  {timeline, side, top: canvases; status: element}
   * @param {object} opts {url: ws URL, format, token: () => access token}
   */
  constructor(els, { url, format = 'msgpack', token = null }) {
    this.els = els;
    this.cues = new History(WINDOW_S + 2);
    this.traj = new History(WINDOW_S + 2);
    this.stats = { frames: 0, scene: null, status: 'idle', lastT: null, health: null };
    this.bounds = { side: null, top: null };
    this.conn = new Connection({ url, role: 'observer', format, client: 'viestac-console/0.1', token });
    this.conn.onStatus = (status, detail) => {
      this.stats.status = status;
      this.onStatus?.(status, detail);
    };
    this.conn.onScene = (m) => { this.stats.scene = m.scene?.name ?? m.hash; };
    this.conn.onState = (s) => {
      this.stats.frames++;
      this.stats.lastT = s.t;
      this.cues.push(cueSample(s));
      this.traj.push(trajSample(s));
    };
    this.conn.onHealth = (h) => {
      this.stats.health = h;
      this.onHealth?.(h);
    };
    this.conn.onLease = (l) => this.onLease?.(l);
    this.conn.onUnauthorized = (why) => this.onUnauthorized?.(why);
    this.conn.onError = () => {};
    this.onStatus = null;
    this.onHealth = null;
    this.onLease = null; // the `lease` message (protocol v1.3)
    this.onUnauthorized = null;
    this._raf = null;
    this._lastDraw = 0;
  }

  start() {
    this.conn.connect();
    const loop = (now) => {
      if (now - this._lastDraw >= 33) { // ~30 plots a second are plenty
        this._lastDraw = now;
        this.draw();
      }
      this._raf = requestAnimationFrame(loop);
    };
    this._raf = requestAnimationFrame(loop);
  }

  lanes() {
    return timelineLanes(this.cues.window(WINDOW_S), { windowS: WINDOW_S, now: this.cues.latest?.t });
  }

  trajectory() {
    const now = this.traj.latest?.t;
    return now === undefined ? [] : windowed(this.traj.items, now, WINDOW_S);
  }

  draw() {
    const { timeline, side, top } = this.els;
    if (timeline?.clientWidth) {
      const lanes = this.lanes();
      const want = `${timelineHeight(lanes)}px`;
      if (timeline.style.height !== want) timeline.style.height = want; // a lane more: the canvas grows
      const { ctx, width, height } = prepare(timeline);
      drawTimeline(ctx, lanes, { width, height, windowS: WINDOW_S });
    }
    const samples = this.trajectory();
    for (const [canvas, view] of [[side, VIEWS.side], [top, VIEWS.top]]) {
      if (!canvas?.clientWidth) continue;
      const { ctx, width, height } = prepare(canvas);
      this.bounds[view.id] = drawTrajectory(ctx, samples, view, { width, height, windowS: WINDOW_S,
        now: this.traj.latest?.t, prev: this.bounds[view.id] });
    }
  }
}
