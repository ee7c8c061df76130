// WebXR glue: Enter VR / Enter AR, the placement step, the headset's hands (or a controller's tip)
// as the tracker, the hand drawn with its fingertips held at their proxies, panels that face the
// user, and rendering at the headset's rate with the server's state blended between frames.
// A fingertip that goes into an object is drawn on its surface in the same frame, from the
// client's copy of the scene, until the server's proxy confirms it (xr_predict.js).
// The decisions live in the pure modules (xr_placement, xr_hands, xr_interp, xr_predict, xr_panels); this
// file reads WebXR, calls them and draws (docs/xr.md).

import * as THREE from 'three';
import { effectivePlacement, placementFromTouch, placementTransform, sceneToXr, xrToScene } from './xr_placement.js';
import { HAND_TTL_MS, controllerSample, drawnHand, handSample } from './xr_hands.js';
import { Blend, contactChanged } from './xr_interp.js';
import { ContactPrediction } from './xr_predict.js';
import { predictProxy, touchableBodies } from './surface_point.js';
import { PinchLatch, angleAt, answerKey, choiceAt, choiceLayout, countdown, panelLines } from './xr_panels.js';
import { TextPanel, XrHand } from './xr_view.js';
import { toolsOf } from './tools_view.js';
import { toolColor } from './hand.js';

export const MODES = { vr: 'immersive-vr', ar: 'immersive-ar' };
const PLACE_COUNTDOWN_MS = 3000;
const HAND_RADIUS_M = 0.02; // joints ~7 mm, bones ~4 mm across (tools_view.js HandView scales)
const LOG_SIZE = 4096;

/** The immersive modes this browser offers ('immersive-vr', 'immersive-ar'). */
export async function supportedModes(xr = globalThis.navigator?.xr) {
  if (!xr?.isSessionSupported) return [];
  const out = [];
  for (const mode of Object.values(MODES)) {
    try {
      if (await xr.isSessionSupported(mode)) out.push(mode);
    } catch {
      // not offered
    }
  }
  return out;
}

const v3 = (p) => [p.x, p.y, p.z];

export class XrSession {
  /**
   * @param {object} o
   * @param {import('./scene_view.js').SceneView} o.view
   * @param {import('./connection.js').Connection} o.conn
   * @param {{get: () => Promise<object>, put: (scope: string, p: object) => Promise<object>}} o.placementApi
   * @param {() => {hud: string, health: object, lost: Array}} o.status  what the panels show
   * @param {(state: object) => void} [o.onFrame]
   * @param {{frame: (o: object) => void}} [o.actuators]  the page's actuators (actuators.js), played each frame
   */
  constructor({ view, conn, placementApi, status, scale = null, ttlMs = HAND_TTL_MS, actuators = null }) {
    this.actuators = actuators;
    this.drivingHand = null; // the hand of the controller that drives the HIP (its actuator pulses)
    this.ttlMs = ttlMs;
    this.view = view;
    this.conn = conn;
    this.placementApi = placementApi;
    this.status = status;
    this.scaleOverride = scale;
    this.session = null;
    this.mode = null;
    this.placement = effectivePlacement();
    this.phase = 'idle'; // idle | placing | running
    this.camera = new THREE.PerspectiveCamera(70, 1, 0.01, 50);
    this.blend = new Blend();
    this.predict = new ContactPrediction();
    this.bodies = []; // the touchable bodies as the newest state leaves them (surface_point.js)
    this._bodiesKey = null;
    this.drawnPredicted = [];
    this.tools = [];
    this.question = null; // {id, kind: 'likert'|'angle', low, high, labels}
    this.answerSent = null;
    this.selectLatch = new PinchLatch();
    this.selected = false;
    this.stats = { frames: 0, fps: 0, samplesSent: 0, samplesDropped: 0, handSeen: false, source: null };
    this.log = { samples: [], draws: [], states: [] };
    this._drawnContact = null;
    this._stateContact = false;
    this._window = { frames: 0, start: 0 };
    this.joints = {};
  }

  get active() {
    return this.session !== null;
  }

  /** Start an immersive session (mode 'immersive-vr' or 'immersive-ar'). */
  async enter(mode = MODES.vr) {
    if (this.session) return;
    const xr = navigator.xr;
    const session = await xr.requestSession(mode, { optionalFeatures: ['local-floor', 'hand-tracking'] });
    const renderer = this.view.renderer;
    renderer.xr.enabled = true;
    let space = 'local-floor';
    try {
      await session.requestReferenceSpace('local-floor');
    } catch {
      space = 'local'; // then the floor is wherever the session started: the placement step fixes it
    }
    renderer.xr.setReferenceSpaceType(space);
    await renderer.xr.setSession(session);
    this.session = session;
    this.mode = mode;
    this.ar = mode === MODES.ar;
    this._savedBackground = this.view.scene.background;
    this._savedClear = renderer.getClearAlpha();
    if (this.ar) {
      this.view.scene.background = null;
      renderer.setClearAlpha(0); // passthrough shows the room
    }
    session.addEventListener('end', () => this._ended());
    session.addEventListener('select', () => { this.selected = true; });
    this.panel = new TextPanel({ name: 'xr-instructions' });
    this.choice = new TextPanel({ name: 'xr-answer', heightM: 0.12 });
    this.view.scene.add(this.panel.mesh, this.choice.mesh);
    this.hand = new XrHand(this.view.root, HAND_RADIUS_M);
    this.view.hand.group.visible = false; // the server's copy of our own hand: we draw it locally
    await this._loadPlacement();
    renderer.setAnimationLoop((time, frame) => this._frame(time, frame));
  }

  exit() {
    this.session?.end();
  }

  _ended() {
    const renderer = this.view.renderer;
    renderer.setAnimationLoop(null);
    this.session = null;
    this.phase = 'idle';
    this.view.scene.background = this._savedBackground ?? null;
    renderer.setClearAlpha(this._savedClear ?? 1);
    this.view.root.position.set(0, 0, 0);
    this.view.root.rotation.set(0, 0, 0);
    this.view.root.scale.setScalar(1);
    this.view.root.visible = true;
    this.view.hand.group.visible = true;
    for (const p of [this.panel, this.choice]) {
      this.view.scene.remove(p.mesh);
      p.dispose();
    }
    this.hand.dispose();
    for (const m of this.view.tools.values()) m.hip.visible = true;
    this.view.resize();
  }

  async _loadPlacement() {
    let stored = {};
    try {
      stored = (await this.placementApi.get()) ?? {};
    } catch (e) {
      console.warn(`viestac xr: no stored placement (${e.message})`);
    }
    const have = stored.session ?? stored.rig ?? null;
    this.applyPlacement(effectivePlacement(stored.session, stored.rig));
    this.phase = have ? 'running' : 'placing';
    this._placeEnd = null;
  }

  applyPlacement(p) {
    this.placement = this.scaleOverride ? { ...p, scale_m_per_unit: this.scaleOverride } : p;
    const t = placementTransform(this.placement);
    this.view.root.position.fromArray(t.position);
    this.view.root.rotation.set(0, t.yaw, 0);
    this.view.root.scale.setScalar(t.scale);
    this.hand?.setScale(t.scale); // a hand is drawn in metres, whatever the scene's scale
  }

  /** Run the placement step again (a panel button, or the console). */
  place() {
    this.phase = 'placing';
    this._placeEnd = null;
  }

  /** Ask the participant (a study question for this trial, xr_panels.questionOf): likert {low, high,
   * labels}, buttons {items} or angle; null asks nothing. The same question again keeps its state. */
  ask(question) {
    if (question && this.question && question.id === this.question.id && question.seq === this.question.seq) return;
    this.question = question;
    this.answerSent = null;
  }

  /** Every state frame: the tools for drawing (proxies blended, contact changes snap). */
  onState(state) {
    const tools = toolsOf(state);
    const now = performance.now();
    this._updateBodies(state);
    this.predict.state(tools, state.driver ?? null, this.conn.welcome?.client_id, now);
    // a contact drawn from the client's guess blends to the server's proxy; other changes snap
    const snap = contactChanged(this.tools, tools).filter((n) => !this.drawnPredicted.includes(n));
    this.blend.push(Object.fromEntries(tools.filter((t) => Array.isArray(t.proxy)).map((t) => [t.name, t.proxy])), now, snap);
    this.tools = tools;
    const contact = !!tools[0]?.contact;
    if (contact !== this._stateContact) {
      this._stateContact = contact;
      this._push(this.log.states, [now, contact, state.frame]);
    }
  }

  _updateBodies(state) {
    const spec = this.view.sceneSpec;
    const key = JSON.stringify([state.scene, state.objects ?? [], state.haptic ?? {}]);
    if (spec === this._bodiesSpec && key === this._bodiesKey) return;
    this._bodiesSpec = spec;
    this._bodiesKey = key;
    this.bodies = touchableBodies(spec, state);
  }

  _push(list, row) {
    list.push(row);
    if (list.length > LOG_SIZE) list.splice(0, list.length - LOG_SIZE);
  }

  _readInputs(frame, space) {
    const hands = {};
    let controller = null;
    let ray = null;
    for (const source of this.session.inputSources) {
      if (source.hand) {
        const joints = {};
        for (const [name, jointSpace] of source.hand) {
          const pose = frame.getJointPose(jointSpace, space);
          if (pose) joints[name] = v3(pose.transform.position);
        }
        if (Object.keys(joints).length) hands[source.handedness] = joints;
      } else if (source.targetRaySpace && !controller) {
        const pose = frame.getPose(source.targetRaySpace, space);
        if (pose) {
          const m = new THREE.Matrix4().fromArray(pose.transform.matrix);
          const dir = new THREE.Vector3(0, 0, -1).transformDirection(m);
          controller = { origin: v3(pose.transform.position), dir: v3(dir), hand: source.handedness || 'none' };
        }
      }
      if (source.handedness === 'right' && source.targetRaySpace) {
        const pose = frame.getPose(source.targetRaySpace, space);
        if (pose) {
          const m = new THREE.Matrix4().fromArray(pose.transform.matrix);
          ray = new THREE.Ray(new THREE.Vector3(...v3(pose.transform.position)), new THREE.Vector3(0, 0, -1).transformDirection(m));
        }
      }
    }
    return { hands, controller, ray };
  }

  _frame(time, frame) {
    if (!frame || !this.session) return;
    const now = performance.now();
    const renderer = this.view.renderer;
    const space = renderer.xr.getReferenceSpace();
    const viewer = frame.getViewerPose(space);
    const head = viewer ? v3(viewer.transform.position) : [0, 1.6, 0];
    const { hands, controller, ray } = this._readInputs(frame, space);
    this.joints = hands;
    this.stats.handSeen = Object.keys(hands).length > 0;

    if (this.phase === 'placing') this._placing(hands, head, now);

    // the tracker sample of this frame (not while placing: the scene is not where the hand thinks)
    let sample = null;
    let seq = null;
    if (this.phase === 'running') {
      sample = handSample(hands, this.placement, { ttl: this.ttlMs });
      this.stats.source = sample ? 'hand' : null;
      if (!sample && controller) {
        sample = controllerSample(controller.origin, controller.dir, this.placement, { ttl: this.ttlMs });
        this.stats.source = sample ? 'controller' : null;
      }
      this.drivingHand = this.stats.source === 'controller' ? controller.hand : null;
      this.controllerRay = controller; // where the driving controller points (tests aim it)
      if (sample) {
        seq = this.conn.seq;
        if (this.conn.sendTracker(sample.pos, null, { point: sample.point, points: sample.points, ttl: sample.ttl })) {
          this.stats.samplesSent++;
          this._push(this.log.samples, [seq, now, sample.pos, this.stats.frames]);
        } else {
          this.stats.samplesDropped++;
        }
      }
    }

    // the hand as drawn: this frame's joints, a touching fingertip held at its (blended) proxy
    const proxies = this.blend.sample(now);
    const tools = this.tools.map((t) => ({ ...t, proxy: proxies[t.name] ?? t.proxy }));
    const local = sample ? { ...sample.points, [sample.point]: sample.pos } : {};
    // the contact of this frame's pose, from the client's copy of the scene
    const radius = Number(this.view.hipSpec?.proxy_radius) || 0;
    const guesses = {};
    for (const t of tools) if (t.name in local) guesses[t.name] = predictProxy(this.bodies, local[t.name], radius)?.pos ?? null;
    const predicted = this.predict.frame(guesses, seq, now);
    const drawn = drawnHand(local, tools, predicted);
    for (const name of drawn.predicted) this.blend.drawnAs(name, drawn.points[name]);
    this.drawnPredicted = drawn.predicted;
    const shown = tools.filter((t) => t.name in drawn.points).map((t) => (drawn.predicted.includes(t.name) ? { ...t, contact: true } : t));
    this.hand.update(drawn.points, shown, (n) => toolColor(n, this.view.hipSpec?.color ?? '#ffd400'));
    for (const t of tools) {
      const m = this.view.tools.get(t.name);
      if (m && t.name in local) m.hip.visible = false; // the finger is the hand drawn here
    }
    this.view.root.visible = this.phase !== 'placing';
    this.drawnHeld = drawn.held;

    this._panels(head, hands, ray, local, now);

    renderer.render(this.view.scene, this.camera);
    // the newest state's drive on the controller that drives the HIP (tracked hands have none)
    this.actuators?.frame({ inputSources: this.session.inputSources, inXr: true, hand: this.drivingHand });
    const drawnAt = performance.now();
    const primary = tools[0]?.name;
    const contact = drawn.held.includes(primary) || (!!tools[0]?.contact && !(primary in local));
    // how the primary fingertip sits on the surface: the client's guess or the server's proxy
    const how = contact ? (drawn.predicted.includes(primary) ? 'predicted' : 'server') : null;
    if (how !== this._drawnContact) {
      this._drawnContact = how;
      this._push(this.log.draws, [drawnAt, contact, this.stats.frames, how, drawn.points[primary] ?? null]);
    }
    this._count(now);
    this.selected = false;
  }

  _placing(hands, head, now) {
    const tip = hands.right?.['index-finger-tip'] ?? hands.left?.['index-finger-tip'];
    if (!tip) {
      this._placeEnd = null; // the count-down starts once a fingertip is seen
      return;
    }
    this._placeEnd = this._placeEnd ?? now + PLACE_COUNTDOWN_MS;
    if (countdown(this._placeEnd, now) > 0) return;
    const scale = this.scaleOverride ?? this.placement.scale_m_per_unit;
    this.applyPlacement(placementFromTouch(tip, head, scale));
    this.phase = 'running';
    this.placementApi.put('session', this.placement).catch((e) => console.warn(`viestac xr: placement not stored (${e.message})`));
  }

  _panels(head, hands, ray, local, now) {
    const origin = sceneToXr([-0.8, 0, 2.2], this.placement); // above the scene and behind it
    const s = this.status();
    let lines;
    if (this.phase === 'placing') {
      lines = ['Placement: rest your right index fingertip on the table',
        'where the scene should stand, and hold it there',
        this._placeEnd ? String(countdown(this._placeEnd, now)) : 'show your hand'];
    } else {
      lines = panelLines({ hud: s.hud, health: s.health, lost: s.lost,
        extra: [...(s.extra ?? []), this.actuators?.notice() ?? ''] });
    }
    const pos = this.phase === 'placing' ? [head[0], head[1] - 0.25, head[2] - 0.6] : origin;
    this.panel.show(lines);
    this.panel.place(pos, head);

    // the participant's answer, where the study asks it
    const q = this.question;
    if (!q || this.phase !== 'running') {
      this.choice.show([]);
      return;
    }
    const choicePos = [pos[0], pos[1] - 0.16, pos[2]];
    this.choice.place(choicePos, head);
    if (this.answerSent !== null) {
      this.choice.show([`Answer sent: ${this.answerSent}`]);
      return;
    }
    if (q.kind === 'angle') {
      const scale = (this.view.sceneSpec?.overlays ?? []).find((o) => o.kind === 'angle_scale') ?? { centre: [0, 0, 0] };
      const tip = local['right.index.tip'];
      let angle = tip ? angleAt(tip, scale) : null;
      if (angle !== null && q.low != null) angle = Math.max(q.low, angle); // the question's bounds
      if (angle !== null && q.high != null) angle = Math.min(q.high, angle);
      this.choice.show([angle === null ? 'Point at the scale' : `${angle}° — pinch the other hand or select to answer`]);
      if (angle !== null && this.selected) this._answer(q, angle);
      return;
    }
    const layout = choiceLayout(q);
    const hit = ray ? this.choice.hit(ray) : null;
    const pick = hit ? choiceAt(layout, hit.u) : null;
    this.choice.show([q.text ?? 'Your answer'], layout.map((b) => ({ ...b, selected: pick?.value === b.value })));
    if (pick && this.selected) this._answer(q, pick.value);
  }

  _answer(q, value) {
    if (q.seq !== undefined && q.seq !== null) { // a study's question (an `ask`): the server records it
      this.conn.sendAnswer(q.seq, q.id, value);
    } else { // a demo's question: an event for the console's list only
      this.conn.sendInput(answerKey(q.id, value), 'down');
      this.conn.sendInput(answerKey(q.id, value), 'up');
    }
    this.answerSent = value;
  }

  _count(now) {
    this.stats.frames++;
    const w = this._window;
    if (w.frames === 0) w.start = now;
    w.frames++;
    if (now - w.start >= 1000) {
      this.stats.fps = ((w.frames - 1) * 1000) / (now - w.start);
      w.frames = 0;
    }
  }

  /** For tests and the bench. */
  toXr(scenePos) {
    return sceneToXr(scenePos, this.placement);
  }

  toScene(xrPos) {
    return xrToScene(xrPos, this.placement);
  }
}
