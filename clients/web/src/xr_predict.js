// Contact predicted in the frame of the pose (docs/xr.md "Timing"). The server's answer to a
// sample comes back one or two XR frames later, while the device moves within a few ms; so when
// the client's own copy of the scene (surface_point.js) puts a fingertip inside a touchable body,
// the fingertip is drawn on that body's surface in the same frame. Display only: the server's
// god-object stays the authority. Its proxy replaces the guess as soon as it says contact, and
// when it has seen the sample and still says no contact, the guess is dropped until the finger
// leaves the body. Pure: the clock and the sample counter come in.

// How long a "no contact" for a sample at least as new as the one that started the guess may be
// the server's contact gate still waiting out its minimum off-time (30 ms,
// server/core/haptics/contact_gate.py) rather than a real no: a little more than that.
export const CONFIRM_GRACE_MS = 50;

export class ContactPrediction {
  constructor({ graceMs = CONFIRM_GRACE_MS } = {}) {
    this.graceMs = graceMs;
    this.episodes = new Map(); // tool name → {seq, at, vetoed}: one stay of the fingertip inside a body
  }

  /**
   * One XR frame. `guesses`: tool name → predicted proxy [x, y, z] (the fingertip inside a body)
   * or null (free); `seq`: the tracker sample sent in this frame. Returns name → proxy for the
   * guesses the server has not turned down.
   */
  frame(guesses, seq, nowMs) {
    const out = {};
    for (const [name, pos] of Object.entries(guesses)) {
      if (!pos) {
        this.episodes.delete(name);
        continue;
      }
      let ep = this.episodes.get(name);
      if (!ep) {
        ep = { seq, at: nowMs, vetoed: false };
        this.episodes.set(name, ep);
      }
      if (!ep.vetoed) out[name] = pos;
    }
    for (const name of [...this.episodes.keys()]) if (!(name in guesses)) this.episodes.delete(name);
    return out;
  }

  /**
   * One state frame. `tools`: the state's tools; `driver`: state.driver ([client_id, seq] of the
   * source whose samples drive the tools, or null); `me`: this connection's client_id. A guess
   * is turned down when its tool is lost, when another source drives, or when the server has
   * applied a sample at least as new as the guess's first and, after the grace, says no contact.
   */
  state(tools, driver, me, nowMs) {
    for (const t of tools ?? []) {
      const ep = this.episodes.get(t.name);
      if (!ep || ep.vetoed || t.contact) continue;
      const other = Array.isArray(driver) && driver[0] !== me;
      const seen = Array.isArray(driver) && driver[0] === me && driver[1] >= ep.seq;
      if (t.lost || other || (seen && nowMs - ep.at >= this.graceMs)) ep.vetoed = true;
    }
  }
}
