// Entry point: wires the connection, the three.js view, input, the HUD and (operators only) the
// operator panel together.
// URL query: ?ws=ws://host:port/ws  ?role=participant|operator|observer  ?format=msgpack|json
//            ?depth_step=0.02 (scene units per wheel notch / PageUp/PageDown)
//            ?audio=speech,contact (spoken instructions, contact clicks: off unless asked)
//            ?xr_emulator=quest3 (tests, bench: the emulated headset, iwer) ?xr_scale=0.1 (m per unit)
// URL fragment: #join=CODE (a participant join link) or #login=CODE, exchanged for a token at
// once and removed from the address bar (auth.js); the token goes in hello.

import { Connection } from './connection.js';
import { SceneView } from './scene_view.js';
import { PointerInput, KeyForwarder, localKeys } from './input.js';
import { ViewOrbit } from './orbit.js';
import { Hud } from './hud.js';
import { OperatorPanel, httpBase } from './operator_panel.js';
import { ROLES } from './protocol.js';
import { TokenStore, redeemFragment, authHeaders } from './auth.js';
import { pageState } from './waiting.js';
import { lostSources, toolsOf } from './tools_view.js';
import { XrSession, supportedModes, MODES } from './xr_session.js';
import { questionOf } from './xr_panels.js';
import { AudioPlan, Clicker, Speaker, audioSettings } from './audio.js';
import { CONTINUE_KEYS, CONTINUE_QUESTION, OnsetWatch, answerForKey, continueQuestion, intervalMarks, keyFor,
  pacingLines, pacingView, wordKeyFor } from './pacing.js';
import { PageActuators } from './actuators.js';

const CLIENT_NAME = 'viestac-web/0.1';
const STALE_S = 3; // an open connection without a state frame this long shows "reconnecting"
const RESTART_S = 10; // … and this long is dropped and opened again

function options(search) {
  const q = new URLSearchParams(search);
  const scheme = location.protocol === 'https:' ? 'wss:' : 'ws:';
  const role = q.get('role') || 'participant';
  const depthStep = Number(q.get('depth_step'));
  return {
    url: q.get('ws') || `${scheme}//${location.host}/ws`,
    role: ROLES.includes(role) ? role : 'participant',
    format: q.get('format') === 'json' ? 'json' : 'msgpack',
    depthStep: Number.isFinite(depthStep) && depthStep > 0 ? depthStep : 0.02,
    xrEmulator: q.get('xr_emulator'),
    xrScale: Number(q.get('xr_scale')) > 0 ? Number(q.get('xr_scale')) : null,
    audio: q.get('audio'),
    xrTtlMs: Number(q.get('xr_ttl')) >= 1 ? Number(q.get('xr_ttl')) : undefined,
  };
}

async function main() {
  const opts = options(location.search);
  const store = new TokenStore();
  const waitingEl = document.getElementById('waiting');
  let joinError = null;
  try {
    await redeemFragment(store, { base: httpBase(opts.url) });
  } catch (e) {
    joinError = e.message;
  }
  const canvas = document.getElementById('view');
  const hud = new Hud({
    hud: document.getElementById('hud'),
    status: document.getElementById('status'),
    telemetry: document.getElementById('telemetry'),
    values: document.getElementById('values'),
    events: document.getElementById('events'),
    health: document.getElementById('health'),
    tracking: document.getElementById('tracking'),
  }, { showValues: opts.role !== 'participant' });

  const stats = { framesReceived: 0, trackerSent: 0, trackerDropped: 0, lastStateFrame: null, lastError: null };
  const view = new SceneView(canvas);
  const conn = new Connection({ url: opts.url, role: opts.role, format: opts.format, client: CLIENT_NAME,
    token: () => store.forRole(opts.role) });
  const orbit = new ViewOrbit(canvas, view); // perspective scenes only; purely local, every role
  const pointer = new PointerInput({ element: canvas, view, depthStep: opts.depthStep,
    ignoreWheel: (e) => orbit.takesWheel(e) });
  const sends = opts.role !== 'observer'; // an observer page sends no input at all
  const keys = new KeyForwarder(window, sends ? (key, action) => conn.sendInput(key, action) : () => {}, {
    consume: localKeys({ changeDepth: (steps) => pointer.changeDepth(steps), resetView: () => orbit.reset() }),
  });

  // Only operators get the panel: participants must not see the commands (they could give the
  // answer away), and observers may not send.
  const panel = opts.role === 'operator'
    ? new OperatorPanel(document.getElementById('operator'), (key, value) => conn.sendInput(key, 'press', value),
      () => refreshPanel())
    : null;

  const hook = {
    ready: false,
    role: opts.role,
    clientId: null,
    sceneHash: null,
    renderedHash: null, // hash of the scene last drawn
    health: null, // the server's last `health` message
    identity: null, // welcome.identity: {token_id, role, site, session}
    lease: null, // the last `lease` message
    ask: null, // the last `ask` message: what the study asks of this participant (v1.5)
    waiting: () => page.kind === 'waiting', // the page waits for the experimenter (pageState)
    stats,
    renderer: view.rendererInfo(),
    memory: () => ({ ...view.renderer.info.memory }),
    skins: () => ({ pending: view.skins.pending, failed: [...view.skins.failed] }),
    panelKeys: () => panel?.keys() ?? null,
    sceneGraph: () => view.sceneGraph(),
    hand: () => view.handGraph(),
    screenPosition: (scenePos) => view.screenPosition(scenePos),
    hipTarget: () => pointer.position(),
    depth: () => pointer.depth,
    orbit: () => orbit.state(),
    connection: conn,
    keys,
  };
  window.__viestac = hook;

  // WebXR: Enter VR / Enter AR where the browser (or the emulator a test asks for) offers them.
  if (opts.xrEmulator) {
    const { installEmulator } = await import('./xr_emulator.js');
    hook.xrDevice = (await installEmulator(opts.xrEmulator)).device;
  }
  const placementApi = {
    get: async () => {
      const r = await fetch(`${httpBase(opts.url)}/api/placement`, { headers: authHeaders(store.forRole(opts.role)) });
      if (!r.ok) throw new Error(`GET /api/placement: HTTP ${r.status}`);
      return r.json();
    },
    put: async (scope, placement) => {
      const r = await fetch(`${httpBase(opts.url)}/api/placement/${scope}`, { method: 'PUT',
        headers: { ...authHeaders(store.forRole(opts.role)), 'Content-Type': 'application/json' }, body: JSON.stringify(placement) });
      if (!r.ok) throw new Error(`PUT /api/placement/${scope}: HTTP ${r.status}`);
      return r.json();
    },
  };
  // the page's own actuators (controllers, gamepads) as the rig's browser device (v1.6); observers feel nothing
  const actuators = sends ? new PageActuators({ conn }) : null;
  hook.actuators = actuators;
  const xr = new XrSession({ view, conn, placementApi, scale: opts.xrScale, ttlMs: opts.xrTtlMs, actuators,
    status: () => ({ hud: lastHud, health: hook.health, lost: lastLost, extra: pacingLines(hook.ask?.pacing) }) });
  hook.xr = xr;
  const xrBar = document.getElementById('xr');
  if (xrBar && opts.role !== 'observer') {
    const modes = await supportedModes();
    for (const [label, mode] of [['Enter VR', MODES.vr], ['Enter AR', MODES.ar]]) {
      if (!modes.includes(mode)) continue;
      const b = document.createElement('button');
      b.textContent = label;
      b.dataset.mode = mode;
      b.addEventListener('click', () => xr.enter(mode).catch((e) => {
        stats.lastError = { code: 'xr', message: String(e.message || e), source: 'client' };
        showStatus();
      }));
      xrBar.append(b);
    }
    xrBar.hidden = xrBar.children.length === 0;
  }
  const audioPlan = new AudioPlan(audioSettings(opts.audio));
  const speaker = new Speaker();
  const clicker = new Clicker();
  hook.audio = { speaker, clicker };
  let lastHud = '';
  let sceneBuilt = false;
  let sceneHudText = '';
  let lastLost = [];

  let statusText = 'connecting';
  const showStatus = () => {
    const who = hook.clientId === null ? opts.role : `${opts.role} #${hook.clientId}`;
    const kind = conn.status === 'ready' ? 'ok' : conn.status === 'failed' ? 'error' : 'warn';
    const err = stats.lastError ? ` · error: ${stats.lastError.code}: ${stats.lastError.message}` : '';
    hud.setStatus(`${who} · ${statusText}${err}`, kind);
  };
  conn.onStatus = (status, detail) => {
    statusText = detail ? `${status} (${detail})` : status;
    showStatus();
    updateWaiting();
  };
  conn.onWelcome = (w) => {
    hook.clientId = w.client_id;
    hook.identity = w.identity ?? null;
    actuators?.connected(); // a new connection: the server hears the actuators again
    stats.lastError = null; // admitted again: an old refusal no longer applies
    lastStateAt = performance.now();
    showStatus();
    updateWaiting();
  };
  conn.onLease = (l) => {
    hook.lease = l;
    leaseAt = performance.now();
    if (hook.identity?.session && l.session === hook.identity.session) admittedBefore = true;
    updateWaiting();
  };
  // What the study asks (v1.5 `ask`): its audio, and the participant's questions — in XR on a
  // panel (xr_session.js), on the desktop page as a row of buttons.
  const answerEl = document.getElementById('answer');
  conn.onAsk = (a) => {
    hook.ask = a;
    audioPlan.setStudy(a.audio);
    const say = audioPlan.say(a.instructions);
    if (say) speaker.speak(say);
    const q = questionOf(a);
    xr.ask(q ?? continueQuestion(a.pacing)); // in XR a break's Continue is a panel too
    showQuestion(q);
    showPacing(a.pacing ?? null);
    updateWaiting();
  };

  // A participant-paced task (pacing.js, ask.pacing v1.6): progress, the state, feedback, a break.
  const pacingEl = document.getElementById('pacing');
  let pacingShown = null;
  hook.pacing = () => pacingShown;
  hook.pacingSeen = []; // every pacing state shown, in order (tests: a feedback or a break may be brief)
  function showPacing(pacing) {
    pacingShown = pacingView(pacing);
    const seen = pacing ? `${pacing.state}${pacing.feedback ? `:${pacing.feedback}` : ''}` : null;
    if (seen !== null && hook.pacingSeen.at(-1) !== seen) hook.pacingSeen.push(seen);
    if (!pacingEl) return;
    pacingEl.hidden = pacingShown === null || !page.showQuestion;
    if (pacingShown === null) return;
    pacingEl.querySelector('.progress').textContent = pacingShown.progress;
    pacingEl.querySelector('.text').textContent = pacingShown.text;
    pacingEl.dataset.feedback = pacingShown.feedback ?? '';
    pacingEl.querySelector('.continue').hidden = !pacingShown.continue;
  }
  const continueBreak = () => pacingShown?.continue && conn.sendAnswer(0, CONTINUE_QUESTION, 1);
  pacingEl?.querySelector('.continue').addEventListener('click', continueBreak);
  // Keys answer what the page asks (digits: the nth choice; y/n, s/d) and end a break (Space,
  // Enter); they are not forwarded to the scenario then. Captured before KeyForwarder sees them.
  window.addEventListener('keydown', (e) => {
    if (opts.role !== 'participant' || !page.showQuestion || e.repeat || e.target?.closest?.('input, textarea, select')) return;
    if (pacingShown?.continue && CONTINUE_KEYS.includes(e.key)) {
      continueBreak();
    } else {
      const q = hook.ask ? questionOf(hook.ask) : null;
      const value = answerForKey(q, e.key);
      if (value === undefined) return;
      conn.sendAnswer(q.seq, q.id, value);
    }
    e.preventDefault();
    e.stopImmediatePropagation();
  }, { capture: true });

  // A stimulus scenario's interval marks (state values.interval / stage): "1", "2" lit in turn, a
  // short tone at each onset.
  const marksEl = document.getElementById('marks');
  const onsets = new OnsetWatch();
  let marksKey = '';
  hook.marks = () => ({ key: marksKey, tones: clicker.tones });
  function showMarks(values) {
    const marks = intervalMarks(values);
    if (onsets.update(marks)) clicker.tone(marks.on);
    const key = marks === null || !page.showQuestion ? '' : `${marks.n}:${marks.on}:${marks.respond}`;
    if (!marksEl || key === marksKey) return;
    marksKey = key;
    marksEl.hidden = key === '';
    if (key === '') return;
    marksEl.dataset.respond = String(marks.respond);
    marksEl.replaceChildren(...Array.from({ length: marks.n }, (_, i) => {
      const mark = document.createElement('span');
      mark.textContent = String(i + 1);
      mark.dataset.on = String(marks.on === i + 1);
      return mark;
    }));
  }
  function showQuestion(q) {
    if (!answerEl) return;
    answerEl.replaceChildren();
    answerEl.hidden = q === null || !page.showQuestion;
    if (q === null) return;
    const text = document.createElement('p');
    text.textContent = q.text;
    answerEl.append(text);
    const send = (value) => conn.sendAnswer(q.seq, q.id, value);
    if (q.kind === 'angle') { // a number: typed on the desktop page
      const input = document.createElement('input');
      input.type = 'number';
      input.name = q.id;
      input.setAttribute('aria-label', q.text);
      const ok = document.createElement('button');
      ok.textContent = 'Answer';
      ok.addEventListener('click', () => input.value !== '' && send(Number(input.value)));
      answerEl.append(input, ok);
      return;
    }
    const items = q.kind === 'likert'
      ? Array.from({ length: q.high - q.low + 1 }, (_, i) => ({ label: String(q.low + i), value: q.low + i,
        anchor: q.labels?.[q.low + i] ?? '' }))
      : q.items;
    for (const [i, it] of items.entries()) {
      const b = document.createElement('button');
      b.textContent = it.anchor ? `${it.label} (${it.anchor})` : it.label;
      b.dataset.value = String(it.value);
      const shortcuts = [keyFor(items, i), wordKeyFor(it)].filter((k) => k !== null);
      if (shortcuts.length) b.setAttribute('aria-keyshortcuts', shortcuts.join(' '));
      b.addEventListener('click', () => send(it.value));
      answerEl.append(b);
    }
  }
  conn.onUnauthorized = () => updateWaiting(); // pageState says it in words
  conn.onScene = (m) => {
    view.build(m.scene, m.hash);
    view.resize();
    orbit.attach(); // the scene's camera is a new object
    pointer.reset();
    hook.sceneHash = m.hash;
    sceneHudText = m.scene.hud?.text ?? '';
    hud.setText(page.showQuestion ? sceneHudText : '');
    sceneBuilt = true;
    if (panel) refreshPanel();
  };
  conn.onState = (s) => {
    stats.framesReceived++;
    stats.lastStateFrame = s.frame;
    stateCount++;
    if (view.built) view.applyState(s);
    lastStateAt = performance.now();
    lastHud = s.hud || sceneHudText; // an empty state hud shows the scene's hud text
    hud.setText(page.showQuestion ? lastHud : ''); // no task text while the page waits or reconnects
    lastLost = lostSources(s);
    actuators?.state(s); // the newest drive, played from the next rendered frame
    if (xr.active) xr.onState(s);
    const say = audioPlan.say(lastHud);
    if (say) speaker.speak(say);
    for (let n = audioPlan.clicks(toolsOf(s)); n > 0; n--) clicker.click();
    hud.setValues(s.values);
    showMarks(s.values);
    hud.addEvents(s.events);
    hud.setTracking(lostSources(s));
    lastTelemetry = s.telemetry;
  };
  conn.onHealth = (h) => {
    hook.health = h;
    hud.setHealth(h);
  };
  conn.onError = (e, source) => {
    stats.lastError = { code: e.code, message: e.message, source };
    if (e.code === 'forbidden' && source === 'server') {
      forbiddenAt = performance.now();
      updateWaiting();
    }
    console.warn(`viestac ${source} error ${e.code}: ${e.message}`);
    showStatus();
  };

  window.addEventListener('resize', () => view.resize());

  // The one state the page shows over the scene (waiting.js pageState): refused, reconnecting,
  // waiting for the experimenter, or nothing (live). The question and the HUD text show only then.
  let forbiddenAt = -Infinity;
  let leaseAt = -Infinity;
  let admittedBefore = false; // the lease named this page's session once (it may be closed since)
  let lastStateAt = performance.now();
  let page = { kind: '', text: '', showQuestion: true };
  hook.page = () => page;
  function showWaiting(text) {
    if (!waitingEl) return;
    waitingEl.hidden = !text;
    waitingEl.textContent = text ?? '';
  }
  function updateWaiting() {
    const before = page;
    page = pageState({ role: conn.welcome?.role ?? opts.role, identity: hook.identity, lease: hook.lease, leaseAt,
      forbiddenAt, nowMs: performance.now(), conn, joinError, ask: hook.ask, admittedBefore });
    const silentS = (performance.now() - lastStateAt) / 1000;
    if (page.kind === '' && conn.status === 'ready' && sceneBuilt && silentS > STALE_S) {
      // open but silent: a frozen picture would look live; say so, and connect again
      page = { kind: 'reconnecting', text: `No updates from the server for ${Math.round(silentS)} s: reconnecting…`,
        showQuestion: false };
      if (silentS > RESTART_S) {
        lastStateAt = performance.now();
        conn.restart('no state frames');
      }
    }
    if (page.kind === '' && stats.lastError?.code === 'forbidden') { // recovered: the refusal is history
      stats.lastError = null;
      showStatus();
    }
    document.body.dataset.page = page.kind;
    showWaiting(page.text);
    if (before.showQuestion !== page.showQuestion) {
      showQuestion(hook.ask ? questionOf(hook.ask) : null);
      showPacing(hook.ask?.pacing ?? null);
      hud.setText(page.showQuestion ? lastHud || sceneHudText : '');
    }
  }
  setInterval(updateWaiting, 1000); // a refusal that stopped coming no longer holds the page
  updateWaiting();

  const api = httpBase(opts.url);
  let panelRequests = 0;
  async function refreshPanel() {
    const n = ++panelRequests;
    try {
      const r = await fetch(`${api}/api/scenario`, { headers: authHeaders(store.forRole(opts.role)) });
      if (!r.ok) throw new Error(`GET /api/scenario: HTTP ${r.status}`);
      const body = await r.json();
      if (n !== panelRequests) return; // a newer scene came in meanwhile
      panel.show(body);
    } catch (e) {
      if (n === panelRequests) panel.showError(String(e.message || e));
    }
  }

  let stateCount = 0;
  let lastTelemetry = {};
  let frames = 0;
  let windowStart = performance.now();
  let fps = 0;
  let stateHz = 0;

  function frame(now) {
    if (xr.active) { // the headset's frames draw (xr_session.js); the pointer does not drive
      requestAnimationFrame(frame);
      return;
    }
    if (sends) {
      const p = pointer.peek();
      if (p !== null && conn.isOpen) {
        if (conn.sendTracker(p)) {
          pointer.commit(p);
          stats.trackerSent++;
        } else {
          stats.trackerDropped++; // still pending: retried next frame
        }
      }
    }
    view.render();
    actuators?.frame(); // gamepads (the desktop page; in XR the headset's frames play them)
    hook.renderedHash = view.hash;
    if (sceneBuilt && !hook.ready) hook.ready = true; // built and drawn at least once

    frames++;
    const dt = now - windowStart;
    if (dt >= 500) {
      fps = (frames * 1000) / dt;
      stateHz = (stateCount * 1000) / dt;
      frames = 0;
      stateCount = 0;
      windowStart = now;
      hud.setTelemetry({ telemetry: lastTelemetry, fps, stateHz });
    }
    requestAnimationFrame(frame);
  }

  conn.connect();
  requestAnimationFrame(frame);
}

main();
