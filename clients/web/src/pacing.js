// Participant-paced tasks on the participant's page (docs/studies.md "Participant-paced tasks"):
// what the page says for `ask.pacing` (protocol v1.6), which key answers which choice, and the
// interval marks of a stimulus scenario (state `values.interval` / `stage`). Pure: main.js draws.

/** The `answer` question that ends a break (never a study question: study ids have no colon). */
export const CONTINUE_QUESTION = 'pacing:continue';

/** Keys that answer a two-choice question by its meaning (lower case), besides the digits. */
const WORD_KEYS = { yes: 'y', no: 'n', same: 's', different: 'd' };

/** Keys that end a break. */
export const CONTINUE_KEYS = [' ', 'Enter'];

/**
 * What the page shows for `ask.pacing` (null: the task is not participant-paced):
 * {progress, text, feedback, continue} — `progress` "Trial 3 of 20", `text` a sentence for the
 * state, `feedback` 'correct' | 'wrong' | null, `continue` whether a Continue button shows.
 */
export function pacingView(pacing) {
  if (!pacing) return null;
  const { state, done = 0, total = 0, feedback = null } = pacing;
  const current = state === 'trial' ? done + 1 : done;
  const progress = total > 0 ? `Trial ${Math.min(Math.max(current, 1), total)} of ${total}` : '';
  const text = {
    trial: '',
    next: 'Next trial coming…',
    feedback: feedback === 'correct' ? 'Correct' : feedback === 'wrong' ? 'Wrong' : '',
    break: `Break: ${done} of ${total} done. Rest, then press Continue (Space) when you are ready.`,
    paused: 'Paused by the experimenter.',
    experimenter: 'Waiting for the experimenter to go on.',
  }[state] ?? '';
  return { progress, text, feedback: state === 'feedback' ? feedback : null, continue: state === 'break' };
}

/** The lines an XR panel adds for `ask.pacing` (progress, then the state's sentence). */
export function pacingLines(pacing) {
  const v = pacingView(pacing);
  return v === null ? [] : [v.progress, v.text].filter((t) => t !== '');
}

/** In XR a break's Continue is a one-button choice panel (ray or pinch), sent as the break's `answer`. */
export function continueQuestion(pacing) {
  if (pacing?.state !== 'break') return null;
  return { id: CONTINUE_QUESTION, seq: 0, kind: 'buttons', text: 'Break: pinch Continue when you are ready',
    items: [{ label: 'Continue', value: 1 }] };
}

/** The key that chooses item `i` of a question's items ({label, value}): its digit, 1–9. */
export function keyFor(items, i) {
  return i < 9 ? String(i + 1) : null;
}

/** The word key of an item (y/n, s/d), when the item is a yes/no or same/different answer. */
export function wordKeyFor(item) {
  return WORD_KEYS[String(item.label).trim().toLowerCase()] ?? null;
}

/**
 * The value a key answers for the shown question (xr_panels.js questionOf: buttons or likert), or
 * undefined: digits 1–9 choose the nth choice (the nth Likert point), y/n and s/d the choice
 * labelled yes/no and same/different.
 */
export function answerForKey(question, key) {
  if (!question || typeof key !== 'string') return undefined;
  const items = itemsOf(question);
  if (items.length === 0) return undefined;
  if (/^[1-9]$/.test(key)) {
    const it = items[Number(key) - 1];
    return it === undefined ? undefined : it.value;
  }
  const k = key.toLowerCase();
  const it = items.find((x) => wordKeyFor(x) === k);
  return it === undefined ? undefined : it.value;
}

/** A question's choices as [{label, value}] (a number question has none: it is typed or pointed at). */
export function itemsOf(question) {
  if (question.kind === 'likert') {
    return Array.from({ length: question.high - question.low + 1 }, (_, i) => ({ label: String(question.low + i),
      value: question.low + i }));
  }
  return question.kind === 'buttons' ? question.items : [];
}

/**
 * The interval marks of a state's `values` (the stimulus scenario: `interval` 1..n while one is
 * on, else 0; `n_intervals`; `stage` lead | interval | isi | respond), or null when the scenario
 * shows none: {n, on (1-based, 0 for none), respond}.
 */
export function intervalMarks(values) {
  const n = values?.n_intervals;
  if (!Number.isInteger(n) || n < 1) return null;
  const on = Number.isInteger(values.interval) && values.interval >= 1 && values.interval <= n ? values.interval : 0;
  return { n, on, respond: values.stage === 'respond' };
}

/** Interval onsets across state frames: `update(marks)` is true on the frame an interval comes on. */
export class OnsetWatch {
  constructor() {
    this.on = 0;
  }

  update(marks) {
    const on = marks?.on ?? 0;
    const onset = on > 0 && on !== this.on;
    this.on = on;
    return onset;
  }
}
