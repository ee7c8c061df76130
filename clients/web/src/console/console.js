// The experimenter console (console.html): choose a study, create or open a session, take control
// of it, run its trials (start, answer, finish, abort, retry, exclude) and watch the participant
// live. Everything about the session comes from REST (api.js); the participant's pages never ask
// for it, and no answer ever goes over the WebSocket. The live panels are an observer.
//
// Access (docs/security.md): every request carries the console's token (auth.js); a login link
// `#login=CODE` is exchanged at once and removed from the address bar; a 401 shows the log-in
// screen. The lease card shows who controls the rig and the queue, and requests, renews,
// releases, hands over or (admin) force-releases it; the join card makes a participant link + QR.
//
// URL: console.html[?ws=ws://host:port/ws][#session=ID][#login=CODE]. Test hook: window.__console.

import { Api } from './api.js';
import { h, fill, fillOnChange, say } from './dom.js';
import { AnswerForm, changedAnswers, fieldFor, missingAnswers, questionsFor } from './answers.js';
import { formatAnswers, formatParams, progress, queueRows, renderQueue, trialBySeq, trialName } from './queue.js';
import { LivePanels } from './live.js';
import { renderHealth } from './health.js';
import { TokenStore, redeemFragment, whoText } from '../auth.js';
import { closedWarning, leaseView, leaseSummary, releaseWarning, renderLease, renewIntervalMs } from './lease.js';
import { auditRows, renderAudit } from './audit.js';
import { DevicesCard } from './devices.js';
import { ScenarioCard } from './scenario.js';
import { BUTTONS, consoleWords } from './words.js';
import { TrackPanel } from './track.js';

const REFRESH_MS = 2000;
const SESSIONS_REFRESH_MS = 10000;
// The server's rule (server/experiment/participant.py): a pseudonymous code with a digit, never a name.
const PARTICIPANT_CODE = /^(?=[^0-9]*[0-9])[A-Za-z0-9_-]{1,32}$/;
const $ = (id) => document.getElementById(id);

const store = new TokenStore();
const api = new Api({ bearer: () => store.token });
const state = {
  identity: null, // GET /api/auth/me
  lease: null, // the last snapshot (GET /api/lease or the `lease` message)
  leaseWarning: null, // the open participant session was closed mid-trial (lease.js closedWarning)
  join: null, // the last join link made here
  loginShown: false,
  studies: [],
  studyId: null,
  studyDetails: new Map(), // study id → GET /api/studies/{id}
  sessions: [],
  sessionId: null,
  session: null,
  control: 'none', // 'yes' | 'lost' | 'none' (view only)
  controlDetail: '',
  selected: null,
  lastRunning: null,
  drafts: new Map(), // "session:seq:attempt" → {question id: raw input}
  busy: 0,
  refreshN: 0,
  paused: false,
};

const form = new AnswerForm($('answers'), {
  onInput: () => { // a corrected answer: the old complaints no longer apply
    for (const id of ['run-msg', 'answers-msg']) if ($(id).dataset.kind === 'error') say($(id), '');
    renderRun();
  },
});

// ---- helpers -------------------------------------------------------------------------------

function experimenter() {
  return $('experimenter').value.trim();
}

function studyOfSession() {
  return state.session ? state.studyDetails.get(state.session.study_id) ?? null : null;
}

function draftsFor(t) {
  const key = `${state.sessionId}:${t.seq}:${t.attempt}`;
  if (!state.drafts.has(key)) state.drafts.set(key, {});
  return { key, drafts: state.drafts.get(key) };
}

function fieldsFor(t) {
  return questionsFor(studyOfSession(), t).map(fieldFor);
}

const inControl = () => state.control === 'yes';

/** Run an action: buttons stay usable, the message goes next to the action, the queue reloads. */
async function act(msgEl, fn, okText = '') {
  say(msgEl, '');
  state.busy++;
  renderRun();
  let out;
  let done = false;
  try {
    out = await fn();
    done = true;
    return out;
  } catch (e) {
    say(msgEl, consoleWords(e.message ?? String(e)), 'error');
    if (sessionRefusal(e)) lostControl(e.detail);
    return undefined;
  } finally {
    await refresh(); // still busy: no periodic refresh overtakes this one, so the new state is drawn
    state.busy--;
    renderRun();
    // said once the server's new state is drawn, never beside the old one
    if (done && okText) say(msgEl, typeof okText === 'function' ? okText(out) : okText, 'ok');
  }
}

/** A 403 about the session's control token (not the rig's lease, not the role): control is lost. */
function sessionRefusal(e) {
  return e?.status === 403 && !/control lease|may not do this/.test(typeof e.detail === 'string' ? e.detail : '');
}

function lostControl(detail) {
  if (!state.sessionId) return;
  state.control = api.token(state.sessionId) ? 'lost' : 'none';
  state.controlDetail = typeof detail === 'string' ? detail : '';
  renderControl();
  renderRun();
}

function fmtClock(s) {
  if (!Number.isFinite(s)) return '–';
  const sign = s < 0 ? '−' : '';
  const a = Math.abs(Math.round(s));
  return `${sign}${Math.floor(a / 60)}:${String(a % 60).padStart(2, '0')}`;
}

function utcShort(iso) {
  if (!iso) return '';
  const d = new Date(iso);
  return Number.isNaN(d.getTime()) ? iso : d.toLocaleString();
}

// ---- studies ---------------------------------------------------------------------------------

async function loadStudies() {
  try {
    state.studies = await api.studies();
  } catch (e) {
    say($('study-errors'), e.message, 'error');
    return;
  }
  const sel = $('study');
  const good = state.studies.filter((s) => !s.error);
  fill(sel, state.studies.map((s) => (s.error
    ? h('option', { value: '', disabled: true }, `${s.file} — cannot be used (see below)`)
    : h('option', { value: s.id }, `${s.title} (${s.id})`))));
  fill($('study-errors'), state.studies.filter((s) => s.error).map((s) => h('div', { class: 'c-study-error' },
    h('strong', {}, s.file), ': ', s.error)));
  if (!good.length) {
    say($('study-info'), 'No usable study file in the studies directory.', 'error');
    return;
  }
  const keep = good.find((s) => s.id === state.studyId) ?? good[0];
  sel.value = keep.id;
  await selectStudy(keep.id);
}

async function fullStudy(id) {
  if (!state.studyDetails.has(id)) state.studyDetails.set(id, await api.study(id));
  return state.studyDetails.get(id);
}

async function selectStudy(id) {
  state.studyId = id;
  let study;
  try {
    study = await fullStudy(id);
  } catch (e) {
    say($('study-info'), e.message, 'error');
    return;
  }
  say($('study-info'), `${study.participants} participants planned · ${study.tasks.length} tasks · seed ${study.seed}`
    + (study.blocks.length ? ` · counterbalanced blocks: ${study.blocks.map((b) => b.id).join(', ')}` : ''));
  renderTasks(study);
  const devices = [...new Set(study.tasks.map((t) => t.device).filter(Boolean))];
  fill($('devices'), devices.map((d) => h('option', { value: d })));
  renderSessionList();
}

function renderTasks(study) {
  const q = (qs) => qs.map((x) => `${x.id} (${x.kind}${x.required ? '' : ', optional'})`).join(', ');
  const trials = (t) => [
    t.training_s ? `training ${t.training_s} s` : null,
    t.practice ? `${t.practice} practice` : null,
    t.conditions.length ? `${t.conditions.length}×${t.repetitions} main (${t.order})` : null,
    t.block ? `block ${t.block}` : null,
  ].filter(Boolean).join(' · ') || '–';
  const questions = (t) => [
    t.questions.length ? `per trial: ${q(t.questions)}` : null,
    t.end_questions.length ? `end: ${q(t.end_questions)}` : null,
  ].filter(Boolean).join(' · ') || '–';
  const row = (t) => h('tr', {},
    h('td', { title: t.title }, h('strong', {}, t.id), h('div', { class: 'c-muted' }, t.title)),
    h('td', {}, t.scenario, t.subtask ? h('div', { class: 'c-muted' }, `subtask ${t.subtask}`) : null),
    h('td', {}, t.device ?? '–'),
    h('td', {}, trials(t)),
    h('td', {}, questions(t)));
  fill($('tasks-table'),
    h('thead', {}, h('tr', {}, ['task', 'scenario', 'device', 'trials', 'questions'].map((c) => h('th', {}, c)))),
    h('tbody', {}, study.tasks.map(row)));
}

// ---- sessions --------------------------------------------------------------------------------

async function loadSessions() {
  try {
    state.sessions = await api.sessions();
    say($('open-msg'), '');
  } catch (e) {
    say($('open-msg'), e.message, 'error');
  }
  renderSessionList();
}

function renderSessionList() {
  const sel = $('sessions');
  const before = sel.value;
  const list = [...state.sessions].sort((a, b) => String(b.created_utc).localeCompare(String(a.created_utc)));
  fill(sel, list.length ? list.map((s) => h('option', { value: s.id, selected: s.id === (before || state.sessionId) },
    `${s.participant} · ${s.study_id} · ${s.done ?? 0}/${s.trials} done · ${s.status} · ${utcShort(s.created_utc)}`))
    : h('option', { value: '', disabled: true }, 'no sessions yet'));
}

async function createSession(ev) {
  ev.preventDefault();
  const msg = $('create-msg');
  const participant = $('participant').value.trim();
  if (!state.studyId) return say(msg, 'Choose a study first.', 'error');
  if (!PARTICIPANT_CODE.test(participant)) {
    return say(msg, 'The participant code must not be a name: use a pseudonymous code of 1-32 letters, digits, '
      + '- or _ with at least one digit, such as P07.', 'error');
  }
  if (!experimenter()) {
    $('experimenter').focus();
    return say(msg, 'Fill in the experimenter (top right) first.', 'error');
  }
  const session = await act(msg, () => api.createSession({
    study: state.studyId, participant, experimenter: experimenter(),
    device: $('device').value.trim() || null, notes: $('notes').value,
  }), (s) => `Session ${s.id} created for ${s.participant}; this console controls it.`);
  if (!session) return;
  $('participant').value = '';
  $('notes').value = '';
  await loadSessions();
  await openSession(session.id, { control: 'yes' });
  $('setup').open = false;
}

async function openSession(id, { control } = {}) {
  if (!id) return;
  if (id !== state.sessionId) {
    state.session = null;
    state.selected = null;
    state.lastRunning = null;
    form.clear();
  }
  state.sessionId = id;
  history.replaceState(null, '', `#session=${encodeURIComponent(id)}`);
  say($('open-msg'), '');
  let session;
  try {
    session = await api.session(id);
  } catch (e) {
    say($('open-msg'), e.message, 'error');
    return;
  }
  try {
    await fullStudy(session.study_id);
  } catch (e) {
    say($('queue-msg'), `The session's study cannot be read: ${e.message}`, 'error');
  }
  state.session = session;
  $('session-notes').value = session.notes ?? '';
  if (control) state.control = control;
  else {
    const ok = await api.probeControl(id);
    state.control = ok ? 'yes' : api.token(id) ? 'lost' : 'none';
    state.controlDetail = '';
  }
  render();
}

async function takeControl() {
  if (!state.sessionId) return;
  const who = experimenter();
  if (!who) {
    $('experimenter').focus();
    say($('run-msg'), 'Fill in the experimenter (top right) to take control of the session.', 'error');
    return;
  }
  const token = await act($('run-msg'), () => api.takeControl(state.sessionId, who),
    'This console now controls the session.');
  if (token) {
    state.control = 'yes';
    state.controlDetail = '';
    render();
  }
}

// ---- refresh ---------------------------------------------------------------------------------

/** Reload the session and render it; returns the session it read (undefined if it could not),
 * also when a newer refresh overtook this one and that one will render. */
async function refresh() {
  const sid = state.sessionId;
  if (!sid) return undefined;
  const n = ++state.refreshN;
  let session;
  try {
    session = await api.session(sid);
    if (n !== state.refreshN || sid !== state.sessionId) return session;
    state.session = session;
    say($('queue-msg'), '');
  } catch (e) {
    if (n === state.refreshN) say($('queue-msg'), e.message, 'error');
    return undefined;
  }
  if (state.control === 'yes') {
    const ok = await api.probeControl(sid);
    if (ok === false && sid === state.sessionId) {
      state.control = 'lost';
      state.controlDetail = 'another console took control of this session (or the server restarted)';
    }
  }
  render();
  track?.refresh(sid); // psychophysics tasks: the live track (its own fetch; does not hold up the view)
  return session;
}

// ---- rendering -------------------------------------------------------------------------------

function render() {
  renderControl();
  renderQueueCard();
  renderRun();
  renderTrial();
  $('notes-card').hidden = !state.session;
  renderLeaseCard();
}

function renderControl() {
  const box = $('control');
  const s = state.session;
  $('session-title').textContent = s
    ? `${s.participant} · ${s.study_id} · session ${s.id}${s.device ? ` · ${s.device}` : ''} · ${s.status}`
    : 'no session open';
  box.dataset.state = s ? state.control : 'none';
  box.hidden = !s;
  $('take-control').hidden = !s || state.control === 'yes';
  // The session's control and the rig's lease are two things (docs/security.md); the header says
  // both in the same words, and names the button that fixes a missing one.
  const rig = currentLeaseView().you === 'holder';
  $('control-text').textContent = !s ? 'no session open'
    : state.control === 'yes' ? (rig ? 'You control this session'
      : `You control this session, not the rig: press “${BUTTONS.lease}” to run its trials`)
      : state.control === 'lost' ? `Session control lost: ${consoleWords(state.controlDetail) || 'another console took control'}`
        : `View only: press “${BUTTONS.session}” to run it`;
  for (const id of ['start', 'finish', 'abort', 'save-answers', 'retry', 'exclude', 'save-notes']) {
    $(id).title = inControl() ? '' : `press “${BUTTONS.session}” first`;
  }
}

function renderQueueCard() {
  const s = state.session;
  if (!s) {
    fill($('queue'));
    $('queue').dataset.sig = '';
    $('progress').textContent = 'open or create a session to see its trials';
    return;
  }
  if (s.running !== null && s.running !== state.lastRunning) state.selected = s.running; // follow a new trial
  state.lastRunning = s.running;
  if (state.selected === null || !trialBySeq(s, state.selected)) state.selected = s.running ?? s.next ?? null;
  const p = progress(s);
  $('progress').textContent = `${p.done}/${p.total} done · ${p.answered} answered · ${p.aborted} aborted · `
    + `${p.excluded} excluded · ${p.pending} pending`;
  const table = $('queue');
  const before = table.dataset.sig;
  renderQueue(table, queueRows(s), { selected: state.selected, onSelect: (seq) => {
    state.selected = seq;
    render();
  } });
  if (before !== table.dataset.sig) {
    const row = table.querySelector('tr.c-running') ?? table.querySelector('tr.c-next');
    const wrap = table.parentElement;
    if (row && wrap && (row.offsetTop < wrap.scrollTop || row.offsetTop > wrap.scrollTop + wrap.clientHeight - 40)) {
      wrap.scrollTop = Math.max(0, row.offsetTop - 60);
    }
  }
}

function elapsed(t) {
  const start = Date.parse(t.started_utc ?? '');
  return Number.isFinite(start) ? Math.max(0, (Date.now() + api.clockOffsetMs - start) / 1000) : NaN;
}

function renderRun() {
  const s = state.session;
  const running = s && s.running !== null ? trialBySeq(s, s.running) : null;
  const next = s && s.next !== null ? trialBySeq(s, s.next) : null;
  const now = $('run-now');
  // rebuilt only when the trial changes; the running clock ticks in place
  if (!s) fillOnChange(now, 'none', () => 'open or create a session');
  else if (running) {
    const e = elapsed(running);
    const limit = running.duration_s;
    const over = limit && e > limit;
    fillOnChange(now, JSON.stringify(['running', running.seq, running.attempt, trialName(running), running.params]),
      () => [h('div', {}, h('span', { class: 'c-badge', dataset: { status: 'running' } }, 'running'), ' ',
        h('strong', {}, trialName(running))),
      h('div', { class: 'c-muted' }, formatParams(running.params) || 'no trial parameters'),
      h('div', { class: 'c-timer', id: 'run-timer' })]);
    const timer = $('run-timer');
    timer.className = over ? 'c-timer c-over' : 'c-timer';
    timer.textContent = `${fmtClock(e)}${limit ? ` of ${fmtClock(limit)}` : ''}${over ? ' — time is up' : ''}`;
  } else if (next) {
    fillOnChange(now, JSON.stringify(['next', next.seq, trialName(next), next.params]), () => [
      h('div', {}, h('span', { class: 'c-badge', dataset: { status: 'pending' } }, 'next'), ' ',
        h('strong', {}, trialName(next))), h('div', { class: 'c-muted' }, formatParams(next.params) || 'no trial parameters')]);
  } else {
    fillOnChange(now, 'complete', () => 'No pending trial: the session is complete.');
  }
  const canRun = inControl() && !state.busy; // an action on its way: the buttons wait for the server's answer
  $('start').disabled = !canRun || !next || !!running;
  $('start').textContent = next ? `Start #${next.seq}` : 'Start next';
  $('finish').disabled = !canRun || !running;
  $('finish').textContent = running ? `Finish #${running.seq}` : 'Finish';
  $('abort').disabled = !canRun || !running;
  renderPacing(s, canRun);
  const hint = $('finish-hint');
  if (running && running.questions.length) {
    const { drafts } = draftsFor(running);
    const missing = missingAnswers(fieldsFor(running), running.responses, drafts);
    const unsaved = changedAnswers(fieldsFor(running), running.responses, drafts).length;
    say(hint, missing.length ? `Missing before finishing: ${missing.map((f) => `${f.id} (${f.text})`).join('; ')}`
      : `All required answers are in${unsaved ? '; Finish saves the unsaved ones first' : ''}.`,
    missing.length ? 'warn' : 'ok');
  } else {
    say(hint, running ? 'This trial asks no questions.' : '');
  }
}

function renderTrial() {
  const s = state.session;
  const t = s ? trialBySeq(s, state.selected) : null;
  $('answer-actions').hidden = true;
  $('retry-actions').hidden = true;
  $('exclude-actions').hidden = true;
  if (!t) {
    $('trial-title').textContent = 'Trial';
    fillOnChange($('trial-meta'), s ? 'select' : 'none', () => (s ? 'Select a trial in the queue.' : ''));
    $('trial-instructions').hidden = true;
    form.clear();
    return;
  }
  const shown = `${state.sessionId}:${t.seq}:${t.attempt}`;
  if (state.trialShown !== shown) { // another trial: the last one's messages do not apply to it
    state.trialShown = shown;
    for (const id of ['answers-msg', 'trial-msg']) say($(id), '');
  }
  $('trial-title').textContent = trialName(t);
  const study = studyOfSession();
  const task = study?.tasks.find((x) => x.id === t.task);
  const meta = [
    ['status', h('span', { class: 'c-badge', dataset: { status: t.status } }, t.status)],
    ['attempt', String(t.attempt)],
    ['params', formatParams(t.params) || '–'],
    ['scenario', t.scenario],
    t.duration_s ? ['time', `${t.duration_s} s`] : null,
    t.started_utc ? ['started', utcShort(t.started_utc)] : null,
    t.ended_utc ? ['ended', utcShort(t.ended_utc)] : null,
    t.reason ? ['reason', t.reason] : null,
    Object.keys(t.metrics ?? {}).length ? ['metrics', formatAnswers(t.metrics)] : null,
  ].filter(Boolean);
  const changed = study && s.study_hash && study.source_hash !== s.study_hash;
  fillOnChange($('trial-meta'), JSON.stringify([shown, t.status, t.params, t.started_utc, t.ended_utc, t.reason, t.metrics,
    t.scenario, t.duration_s, changed]), () => [h('dl', {}, meta.map(([k, v]) => [h('dt', {}, k), h('dd', {}, v)])),
    changed ? h('p', { class: 'c-warn' },
      'The study file has changed since this session was created; the questions shown are today\'s.') : null]);
  $('trial-instructions').hidden = !task?.instructions;
  $('instructions-text').textContent = task?.instructions?.trim() ?? '';

  const answerable = t.status === 'running' || t.status === 'answered';
  if (t.questions.length) {
    const { key, drafts } = draftsFor(t);
    form.show(key, fieldsFor(t), t.responses, drafts, { readOnly: !answerable });
    $('answer-actions').hidden = !answerable;
    $('save-answers').disabled = !inControl();
  } else {
    form.clear(t.kind === 'training' ? 'Training: free exploration, no questions.' : 'This trial asks no questions.');
  }
  $('retry-actions').hidden = t.status !== 'aborted';
  $('retry').disabled = !inControl();
  $('exclude-actions').hidden = !(t.status === 'answered' || t.status === 'aborted');
  $('exclude').disabled = !inControl();
}

// ---- actions ---------------------------------------------------------------------------------

/** PUT every changed answer of trial `t`; true when all were accepted. Errors go to the fields. */
async function saveAnswers(t, msgEl) {
  const fields = fieldsFor(t);
  const { drafts } = draftsFor(t);
  const changes = changedAnswers(fields, t.responses, drafts);
  let ok = true;
  for (const c of changes) {
    if (c.parsed.error) {
      form.setError(c.field.id, c.parsed.error);
      ok = false;
      continue;
    }
    try {
      await api.answer(state.sessionId, t.seq, c.field.id, c.parsed.value, experimenter() || 'experimenter');
      if (drafts[c.field.id] === c.raw) delete drafts[c.field.id]; // saved: the server's value shows now
      form.setError(c.field.id, '');
    } catch (e) {
      form.setError(c.field.id, e.message);
      if (sessionRefusal(e)) lostControl(e.detail);
      ok = false;
    }
  }
  if (!ok) {
    say(msgEl, 'Some answers were not accepted: see the marked questions (what you typed is kept).', 'error');
    form.focus(changes.find((c) => c.parsed.error || form.rows.get(c.field.id)?.error.textContent)?.field.id);
  }
  return { ok, saved: changes.length };
}

async function onSaveAnswers() {
  const t = trialBySeq(state.session, state.selected);
  if (!t) return;
  say($('answers-msg'), '');
  state.busy++;
  try {
    const { ok, saved } = await saveAnswers(t, $('answers-msg'));
    if (ok) say($('answers-msg'), saved ? `Saved ${saved} answer${saved > 1 ? 's' : ''}.` : 'Nothing to save.', 'ok');
  } finally {
    state.busy--;
    await refresh();
  }
}

// A participant-paced task (the session's `pacing`): its state and progress, Pause and Resume.
const PACING_WORDS = { trial: 'the participant answers', next: 'next trial coming', feedback: 'feedback',
  break: 'break (the participant continues)', paused: 'paused', experimenter: 'waiting for you: Start or Resume' };

function renderPacing(s, canRun) {
  const p = s?.pacing ?? null;
  $('pacing-row').hidden = p === null;
  if (p === null) return;
  const note = p.note ? ` — ${p.note}` : '';
  $('pacing-state').textContent = `Participant-paced: ${p.done}/${p.total} done · ${PACING_WORDS[p.state] ?? p.state}${note}`;
  $('pacing-row').dataset.state = p.state;
  $('pace-pause').disabled = !canRun || p.state === 'paused';
  $('pace-resume').disabled = !canRun || p.state === 'trial';
}

async function onPacing(action) {
  const words = action === 'pause' ? 'Paused: no trial starts until you resume.' : 'Resumed: the next trial follows.';
  await act($('run-msg'), () => api.pacing(state.sessionId, action), words);
}

async function onStart() {
  const seq = state.session?.next;
  if (seq === null || seq === undefined) return;
  const started = await act($('run-msg'), () => api.start(state.sessionId, seq), `Trial #${seq} started.`);
  if (started) state.selected = seq;
}

async function onFinish() {
  const s = state.session;
  const t = s && s.running !== null ? trialBySeq(s, s.running) : null;
  if (!t) return;
  const msg = $('run-msg');
  say(msg, '');
  if (t.questions.length) {
    state.selected = t.seq;
    renderTrial();
    state.busy++;
    let ok;
    try {
      ({ ok } = await saveAnswers(t, msg));
    } finally {
      state.busy--;
    }
    if (!ok) {
      say(msg, 'Not finished: some answers were not accepted (see the form; what you typed is kept).', 'error');
      return;
    }
    // Check against the session read after the save: a periodic refresh may overtake this one,
    // and then state.session would still be the one from before the save.
    const session = await refresh();
    if (!session) {
      say(msg, 'Not finished: the session could not be reloaded to check the answers; try again.', 'error');
      return;
    }
    const fresh = trialBySeq(session, t.seq);
    const missing = missingAnswers(fieldsFor(fresh), fresh.responses, draftsFor(fresh).drafts);
    if (missing.length) {
      say(msg, `Not finished: answer ${missing.map((f) => `${f.id} (${f.text})`).join('; ')} first.`, 'error');
      form.focus(missing[0].id);
      return;
    }
  }
  await act(msg, () => api.finish(state.sessionId, t.seq), `Trial #${t.seq} finished (answered).`);
}

async function onAbort() {
  const seq = state.session?.running;
  if (seq === null || seq === undefined) return;
  const reason = $('abort-reason').value.trim();
  const done = await act($('run-msg'), () => api.abort(state.sessionId, seq, reason), `Trial #${seq} aborted.`);
  if (done) $('abort-reason').value = '';
}

async function onRetry() {
  const seq = state.selected;
  await act($('trial-msg'), () => api.retry(state.sessionId, seq), `Trial #${seq} is back in the queue (pending).`);
}

async function onExclude() {
  const seq = state.selected;
  const reason = $('exclude-reason').value.trim();
  if (!reason) {
    say($('trial-msg'), 'Give a reason for excluding the trial.', 'error');
    $('exclude-reason').focus();
    return;
  }
  const done = await act($('trial-msg'), () => api.exclude(state.sessionId, seq, reason),
    `Trial #${seq} excluded from the analysis.`);
  if (done) $('exclude-reason').value = '';
}

async function onSaveNotes() {
  await act($('notes-msg'), () => api.setNotes(state.sessionId, $('session-notes').value), 'Notes saved.');
}

// ---- access: log-in, identity, the lease, join links, audit ----------------------------------

function showLogin(why) {
  state.loginShown = true;
  $('login').hidden = false;
  say($('login-why'), why || 'This console needs an access token.', why ? 'error' : 'info');
  $('login-token').focus();
}

function renderIdentity() {
  const me = state.identity;
  $('identity').textContent = me ? `${whoText(me)} · ${me.role}${me.site ? ` · site ${me.site}` : ''}` : 'not logged in';
  $('logout').hidden = !store.token;
}

/** Who am I? false when the token is missing or refused (the log-in screen is shown). */
async function loadIdentity() {
  if (!store.token) {
    state.identity = null;
    renderIdentity();
    showLogin('');
    return false;
  }
  try {
    state.identity = await api.me();
  } catch (e) {
    state.identity = null;
    renderIdentity();
    if (e.status !== 401) say($('lease-msg'), e.message, 'error'); // 401: onUnauthorized showed the log-in
    return e.status !== 401;
  }
  renderIdentity();
  return true;
}

async function onLogin(ev) {
  ev.preventDefault();
  const token = $('login-token').value.trim();
  if (!token) return say($('login-msg'), 'Paste a token first.', 'error');
  const before = store.token;
  store.save(token);
  try {
    state.identity = await api.me();
  } catch (e) {
    store.save(before);
    state.identity = null;
    return say($('login-msg'), e.status === 401 ? 'This token is not valid (unknown, expired or revoked).' : e.message,
      'error');
  }
  $('login-token').value = '';
  await loggedIn();
}

async function loggedIn() {
  state.loginShown = false;
  $('login').hidden = true;
  say($('login-msg'), '');
  renderIdentity();
  live?.conn.setToken(() => store.token);
  await Promise.all([loadStudies(), loadSessions(), pollLease(), loadAudit(), devices.start(), scenarioCard.load()]);
}

function onLogout() {
  store.clear();
  state.identity = null;
  state.lease = null;
  renderIdentity();
  renderLeaseCard();
  showLogin('Logged out.');
}

function setLease(snapshot) {
  const running = state.session?.running ?? null;
  const closed = closedWarning(state.lease, snapshot, state.sessionId, running);
  if (closed) state.leaseWarning = closed; // stays until a session is open again or the trial ended
  else if (snapshot?.session || running === null) state.leaseWarning = null;
  state.lease = snapshot;
  renderLeaseCard();
  scheduleRenew();
}

async function pollLease() {
  if (!store.token) return;
  try {
    setLease(await api.lease());
  } catch (e) {
    if (e.status !== 401) say($('lease-msg'), e.message, 'error');
  }
}

function currentLeaseView() {
  return leaseView(state.lease, state.identity, { offsetMs: api.clockOffsetMs });
}

function renderLeaseCard() {
  const view = currentLeaseView();
  if (!state.identity || !state.lease) fill($('lease'), h('div', { class: 'c-muted' }, 'log in to see who controls the rig'));
  else renderLease($('lease'), view, {
    request: onLeaseRequest, release: onLeaseRelease, forceRelease: onForceRelease, handOver: onHandOver,
  }, state.leaseWarning);
  const sum = $('lease-summary');
  sum.textContent = state.lease ? leaseSummary(view) : 'Rig control: unknown';
  renderControl();
  sum.dataset.you = view.you;
  $('join-create').disabled = !view.actions.joinLink;
  $('join-create').title = view.actions.joinLink ? '' : 'hold the control lease first';
  $('join-for').textContent = state.sessionId
    ? `for session ${state.sessionId}${state.session ? ` (${state.session.participant})` : ''}`
    : 'for free exploration (no session open)';
}

let renewTimer = null;
let renewEvery = null;
/** Renew every ttl/4 while holding or queued (a quiet holder loses the lease). */
function scheduleRenew() {
  const { actions } = currentLeaseView();
  const every = actions.renew ? renewIntervalMs(state.lease?.ttl_s) : null;
  if (every === renewEvery) return;
  clearInterval(renewTimer);
  renewTimer = null;
  renewEvery = every;
  if (every) {
    renewTimer = setInterval(async () => {
      try {
        await api.renewLease();
      } catch (e) {
        if (e.status !== 401) await pollLease(); // lost it meanwhile: show who has it now
      }
    }, every);
  }
}

/** A lease or join-link action: its message next to it, then the lease is read again. */
async function leaseAct(fn, okText, msgEl = $('lease-msg')) {
  say(msgEl, '');
  let out;
  try {
    out = await fn();
    say(msgEl, typeof okText === 'function' ? okText(out) : okText, 'ok');
  } catch (e) {
    say(msgEl, consoleWords(e.message ?? String(e)), 'error');
  }
  await pollLease();
  return out;
}

function onLeaseRequest() {
  return leaseAct(() => api.requestLease(), (r) => (r?.status === 'queued'
    ? `Queued: you are #${r.position} (the holder releases it, or it expires when they go quiet).`
    : 'You control the rig.'));
}

function onLeaseRelease() {
  const warning = releaseWarning(state.lease, state.sessionId, state.session?.running ?? null);
  if (warning && !window.confirm(warning)) return undefined;
  return leaseAct(() => api.releaseLease(), 'Released.');
}

function onForceRelease() {
  if (!window.confirm('Take the lease away from its holder? Their running actions on the rig stop.')) return undefined;
  return leaseAct(() => api.forceRelease(), 'Lease released by force.');
}

function onHandOver(tokenId) {
  return leaseAct(() => api.handOver(tokenId), `Handed over to ${tokenId}.`);
}

async function onJoinLink() {
  const link = await leaseAct(() => api.joinLink(state.sessionId ?? null),
    (j) => `Join link for ${j.session} made; this session is now open for its participant.`, $('join-msg'));
  if (!link) return;
  state.join = link;
  $('join-out').hidden = false;
  $('join-url').value = link.url;
  $('join-expires').textContent = `single use · expires ${new Date(link.expires_at * 1000).toLocaleString()}`;
  showQr($('join-qr'), link.qr_svg);
}

/** The server's QR SVG, inline (no script or event attributes survive; the page's CSP forbids data: images). */
function showQr(el, svgText) {
  el.replaceChildren();
  if (!svgText) return;
  const doc = new DOMParser().parseFromString(svgText, 'image/svg+xml');
  const svg = doc.documentElement;
  if (svg.nodeName.toLowerCase() !== 'svg') return;
  for (const bad of svg.querySelectorAll('script, foreignObject')) bad.remove();
  for (const node of [svg, ...svg.querySelectorAll('*')]) {
    for (const a of [...node.attributes]) if (/^on/i.test(a.name) || /href$/i.test(a.name)) node.removeAttribute(a.name);
  }
  if (!svg.getAttribute('viewBox') && svg.getAttribute('width') && svg.getAttribute('height')) {
    svg.setAttribute('viewBox', `0 0 ${parseFloat(svg.getAttribute('width'))} ${parseFloat(svg.getAttribute('height'))}`);
  }
  el.append(document.importNode(svg, true));
}

async function loadAudit() {
  if (!store.token || !$('audit-details').open) return;
  try {
    const rows = await api.audit({ sessionId: $('audit-session').checked ? state.sessionId : null, limit: 100 });
    renderAudit($('audit'), auditRows(rows));
    say($('audit-msg'), '');
  } catch (e) {
    say($('audit-msg'), e.status === 403 ? 'The audit log is for experimenters and admins.' : e.message, 'error');
  }
}

// ---- start -----------------------------------------------------------------------------------

function wsUrl() {
  const q = new URLSearchParams(location.search);
  const scheme = location.protocol === 'https:' ? 'wss:' : 'ws:';
  return q.get('ws') || `${scheme}//${location.host}/ws`;
}

let live = null;
let devices = null; // the devices panel (devices.js)
let scenarioCard = null; // the scenario card (scenario.js)
let track = null; // the psychophysics track card (track.js)

function main() {
  const exp = $('experimenter');
  try {
    exp.value = localStorage.getItem('viestac.console.experimenter') ?? '';
  } catch { /* no storage */ }
  exp.addEventListener('change', () => {
    try {
      localStorage.setItem('viestac.console.experimenter', exp.value.trim());
    } catch { /* no storage */ }
  });
  $('study').addEventListener('change', (e) => selectStudy(e.target.value));
  $('new-session').addEventListener('submit', createSession);
  $('open-session').addEventListener('click', () => openSession($('sessions').value));
  $('sessions').addEventListener('dblclick', () => openSession($('sessions').value));
  $('reload-sessions').addEventListener('click', loadSessions);
  $('take-control').addEventListener('click', takeControl);
  $('start').addEventListener('click', onStart);
  $('finish').addEventListener('click', onFinish);
  $('abort').addEventListener('click', onAbort);
  $('pace-pause').addEventListener('click', () => onPacing('pause'));
  $('pace-resume').addEventListener('click', () => onPacing('resume'));
  $('retry').addEventListener('click', onRetry);
  $('exclude').addEventListener('click', onExclude);
  $('save-answers').addEventListener('click', onSaveAnswers);
  $('save-notes').addEventListener('click', onSaveNotes);
  $('login-form').addEventListener('submit', onLogin);
  $('logout').addEventListener('click', onLogout);
  $('join-create').addEventListener('click', onJoinLink);
  $('audit-details').addEventListener('toggle', loadAudit);
  $('audit-session').addEventListener('change', loadAudit);
  $('audit-reload').addEventListener('click', loadAudit);
  api.onUnauthorized = () => {
    state.identity = null;
    renderIdentity();
    showLogin(store.token ? 'The server refused this token (expired or revoked): log in again.' : '');
  };

  const ws = wsUrl();
  const q = new URLSearchParams(location.search);
  const scene = `index.html?role=observer${q.get('ws') ? `&ws=${encodeURIComponent(ws)}` : ''}`;
  $('scene-frame').src = scene;
  $('scene-link').href = scene;
  const fitFrame = () => {
    const frame = $('scene-frame');
    frame.style.transform = `scale(${frame.parentElement.clientWidth / 640})`;
  };
  new ResizeObserver(fitFrame).observe($('scene-frame').parentElement);
  fitFrame();
  track = new TrackPanel($('track-card'), $('track'),
    (sid) => api.request('GET', `/api/sessions/${encodeURIComponent(sid)}/tracks`));
  live = new LivePanels({ timeline: $('timeline'), side: $('traj-side'), top: $('traj-top') },
    { url: ws, token: () => store.token });
  live.onLease = (l) => { if (state.identity) setLease({ ...l, you: undefined, position: undefined }); };
  live.onStatus = (status, detail) => {
    say($('live-status'), status === 'ready' ? 'live' : status, status === 'ready' ? 'ok' : status === 'failed'
      ? 'error' : 'warn');
    $('live-status').title = detail ?? '';
  };
  // The banner: the server's health and the devices panel's trouble (devices.js), held a moment
  // after it cleared (health.js HOLD_MS).
  let deviceTrouble = [];
  const showBanner = () => renderHealth($('health-banner'), live.stats.health, deviceTrouble);
  $('health-banner')._rerender = showBanner;
  live.onHealth = () => {
    showBanner();
    devices.poll(); // a device change pushed by the server: the panel need not wait for its next poll
  };
  devices = new DevicesCard($('devices-panel'), api, {
    onTrouble: (items) => { deviceTrouble = items; showBanner(); },
    active: () => !state.paused && !state.loginShown && !!store.token,
  });
  scenarioCard = new ScenarioCard($('scenario-panel'), api);
  const onScene = live.conn.onScene;
  live.conn.onScene = (m) => {
    onScene?.(m);
    devices.scenarioChanged();
    if (!state.loginShown && store.token) scenarioCard.refreshRunning();
  };
  live.start();

  const hook = {
    ready: false,
    api,
    state: () => ({ sessionId: state.sessionId, control: state.control, controlDetail: state.controlDetail,
      selected: state.selected, next: state.session?.next ?? null, running: state.session?.running ?? null }),
    live: live.stats,
    health: () => live.stats.health,
    devices: () => devices.view && { rows: devices.view.rows, trouble: devices.view.trouble,
      hostDown: devices.view.hostDown },
    banner: () => ({ hidden: $('health-banner').hidden, text: $('health-banner').innerText }),
    identity: () => state.identity,
    lease: () => ({ ...currentLeaseView(), loginShown: state.loginShown }),
    join: () => state.join && { url: state.join.url, session: state.join.session, qr: !!$('join-qr svg') },
    lanes: () => live.lanes().map((l) => ({ id: l.id, runs: l.runs.length, pulses: l.pulses?.length ?? null,
      text: l.text })),
    trajectory: () => live.trajectory().length,
    refresh,
    pause: (p = true) => { state.paused = p; },
  };
  window.__console = hook;

  setInterval(() => { if (!state.paused && !state.busy && !state.loginShown) refresh(); }, REFRESH_MS);
  setInterval(() => { if (!state.paused && !state.loginShown) pollLease(); }, REFRESH_MS);
  setInterval(() => {
    if (!state.paused && !state.loginShown) {
      loadSessions();
      loadAudit();
    }
  }, SESSIONS_REFRESH_MS);
  setInterval(() => { if (state.session?.running !== null && state.session) renderRun(); }, 500);

  (async () => {
    render();
    try {
      await redeemFragment(store, { kinds: ['login'] }); // a join code is the participant page's
    } catch (e) {
      showLogin(e.message);
    }
    if (!state.loginShown) await loadIdentity();
    renderLeaseCard();
    if (!state.loginShown) {
      await pollLease();
      await Promise.all([devices.start(), scenarioCard.load()]);
      await loadStudies();
      await loadSessions();
    }
    const m = /session=([^&]+)/.exec(location.hash);
    if (m) {
      await openSession(decodeURIComponent(m[1]));
      if (state.session) $('setup').open = false;
    }
    hook.ready = true;
  })();
}

main();
