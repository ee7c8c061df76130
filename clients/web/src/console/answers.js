// Answers of a trial: the form built from the study's question specs (GET /api/studies/{id}:
// tasks[].questions and end_questions — id, kind likert|number|choice|text, text, low/high,
// integer, labels, choices, required) and the parsing of what was typed, checked as the server
// checks it (server/experiment/study.py, Question.check) so most mistakes never leave the page.
//
// Pure part: questionsFor, fieldFor, rawOf, parseAnswer, missingAnswers. DOM part: AnswerForm,
// which keeps what was typed (drafts) across the console's refreshes: nothing is lost when an
// answer is refused or the queue reloads.

import { h, fill } from './dom.js';

export const TEXT_MAX = 2000; // the server's limit for a free-text answer

/** The question specs a trial asks, in its order; an id the study does not know stays a text field. */
export function questionsFor(study, trial) {
  const task = study?.tasks?.find((t) => t.id === trial?.task);
  const all = [...(task?.questions ?? []), ...(task?.end_questions ?? [])];
  return (trial?.questions ?? []).map((id) => all.find((q) => q.id === id)
    ?? { id, kind: 'text', text: id, required: false, unknown: true });
}

const num = (x) => (x === null || x === undefined || x === '' ? null : Number(x));

/** "1" / "0.5" / "-90": bounds as people write them. */
export function fmtNumber(x) {
  if (typeof x !== 'number' || !Number.isFinite(x)) return String(x);
  return String(Number.isInteger(x) ? x : Number(x.toPrecision(10)));
}

/**
 * The form field of one question: {id, kind, control, text, required, options?, min?, max?, step?,
 * integer}. likert → radio buttons low..high with their anchor labels; number → a number input;
 * choice → one button per choice (values keep their type: 500 stays a number); text → a text area.
 */
export function fieldFor(q) {
  const base = { id: q.id, kind: q.kind, text: q.text ?? q.id, required: q.required !== false, unknown: !!q.unknown };
  switch (q.kind) {
    case 'likert': {
      const low = num(q.low) ?? 1;
      const high = num(q.high) ?? 7;
      const labels = q.labels ?? {};
      const options = [];
      for (let p = low; p <= high; p++) options.push({ value: p, label: String(p), anchor: labels[String(p)] ?? '' });
      return { ...base, control: 'likert', options, min: low, max: high, integer: true };
    }
    case 'number': {
      const integer = !!q.integer;
      return { ...base, control: 'number', min: num(q.low), max: num(q.high), integer, step: integer ? 1 : 'any' };
    }
    case 'choice':
      return { ...base, control: 'choice', options: (q.choices ?? []).map((c) => ({ value: c, label: String(c) })) };
    default:
      return { ...base, control: 'text', kind: 'text' };
  }
}

/** A saved answer as the string an input holds ('' for none). */
export function rawOf(value) {
  if (value === null || value === undefined) return '';
  return typeof value === 'number' ? fmtNumber(value) : String(value);
}

function rangeText(f) {
  if (f.min != null && f.max != null) return ` from ${fmtNumber(f.min)} to ${fmtNumber(f.max)}`;
  if (f.min != null) return ` of at least ${fmtNumber(f.min)}`;
  if (f.max != null) return ` of at most ${fmtNumber(f.max)}`;
  return '';
}

/**
 * What the raw input means for `field`: {value} (ready to send), {empty: true} (nothing typed), or
 * {error: sentence}. Numbers accept a decimal comma; a choice is matched by its label.
 */
export function parseAnswer(field, raw) {
  const text = raw === null || raw === undefined ? '' : String(raw);
  if (field.control === 'text') {
    if (!text.trim()) return { empty: true };
    if (text.length > TEXT_MAX) return { error: `${field.id}: at most ${TEXT_MAX} characters (has ${text.length})` };
    return { value: text };
  }
  const s = text.trim();
  if (!s) return { empty: true };
  if (field.control === 'choice') {
    const opt = field.options.find((o) => o.label === s || String(o.value) === s);
    if (!opt) return { error: `${field.id} must be one of ${field.options.map((o) => o.label).join(', ')}` };
    return { value: opt.value };
  }
  const n = Number(s.replace(',', '.'));
  const whole = field.control === 'likert' || field.integer;
  const fits = Number.isFinite(n) && (!whole || Number.isInteger(n))
    && (field.min == null || n >= field.min) && (field.max == null || n <= field.max);
  if (!fits) return { error: `${field.id} must be ${whole ? 'a whole number' : 'a number'}${rangeText(field)}, not "${s}"` };
  return { value: n };
}

/**
 * The required fields still without an answer: neither saved on the server nor typed in a form
 * that parses. `saved` = the trial's responses, `drafts` = {question id: raw input}.
 */
export function missingAnswers(fields, saved = {}, drafts = {}) {
  return fields.filter((f) => {
    if (!f.required) return false;
    if (f.id in drafts) return !('value' in parseAnswer(f, drafts[f.id]));
    return saved[f.id] === null || saved[f.id] === undefined;
  });
}

/**
 * The drafts that differ from what is saved: [{field, raw, parsed}] — what "save" must send.
 * A draft cleared to nothing is left out (the API has no "delete answer").
 */
export function changedAnswers(fields, saved = {}, drafts = {}) {
  const out = [];
  for (const f of fields) {
    if (!(f.id in drafts)) continue;
    const raw = drafts[f.id];
    const parsed = parseAnswer(f, raw);
    if (parsed.empty) continue;
    if ('value' in parsed && rawOf(saved[f.id]) === rawOf(parsed.value) && saved[f.id] !== undefined) continue;
    out.push({ field: f, raw, parsed });
  }
  return out;
}

// ---- DOM -----------------------------------------------------------------------------------

/**
 * The answer form of one trial. `show(key, fields, saved, drafts)` rebuilds the inputs only when
 * the trial (key: seq and attempt) or its questions change; otherwise it updates the "saved"
 * marks and leaves what is being typed alone. `drafts` is the caller's {question id: raw} map,
 * written on every keystroke, so it outlives the form.
 */
export class AnswerForm {
  constructor(container, { onInput = () => {} } = {}) {
    this.el = container;
    this.onInput = onInput;
    this.key = null;
    this.fields = [];
    this.rows = new Map(); // id → {row, status, error, inputs}
    this.drafts = {};
  }

  show(key, fields, saved = {}, drafts = {}, { readOnly = false } = {}) {
    const sig = `${key}|${readOnly}|${JSON.stringify(fields)}`;
    this.drafts = drafts;
    if (sig !== this.sig) {
      this.sig = sig;
      this.key = key;
      this.fields = fields;
      this._build(readOnly, saved);
    }
    this._marks(saved);
  }

  clear(message = '') {
    this.sig = null;
    this.key = null;
    this.fields = [];
    this.rows.clear();
    fill(this.el, message ? h('p', { class: 'c-muted' }, message) : null);
  }

  setError(id, text) {
    const r = this.rows.get(id);
    if (!r) return;
    r.error.textContent = text ?? '';
    r.row.classList.toggle('c-invalid', !!text);
  }

  focus(id) {
    const r = this.rows.get(id);
    r?.inputs[0]?.focus();
    r?.row.scrollIntoView?.({ block: 'nearest' });
  }

  _raw(f, saved) {
    return f.id in this.drafts ? this.drafts[f.id] : rawOf(saved[f.id]);
  }

  _changed(f, raw) {
    this.drafts[f.id] = raw;
    this.setError(f.id, '');
    this.onInput(f, raw);
    this._marks(this.saved ?? {});
  }

  _build(readOnly, saved) {
    this.rows.clear();
    fill(this.el, this.fields.map((f, i) => this._row(f, i, readOnly, saved)));
  }

  _row(f, i, readOnly, saved) {
    const raw = this._raw(f, saved);
    const name = `q-${this.key}-${f.id}`.replace(/[^\w-]/g, '_');
    const inputs = [];
    let control;
    if (f.control === 'likert') {
      control = h('div', { class: 'c-likert', role: 'radiogroup', 'aria-label': f.text },
        f.options.map((o) => {
          const input = h('input', { type: 'radio', name, value: String(o.value), checked: raw === String(o.value),
            disabled: readOnly, onchange: () => this._changed(f, input.value) });
          inputs.push(input);
          return h('label', { class: 'c-likert-point', title: o.anchor || null },
            input, h('span', { class: 'c-likert-num' }, o.label), h('span', { class: 'c-anchor' }, o.anchor));
        }));
    } else if (f.control === 'choice') {
      control = h('div', { class: 'c-choices', role: 'radiogroup', 'aria-label': f.text },
        f.options.map((o) => {
          const input = h('input', { type: 'radio', name, value: o.label, checked: raw === o.label,
            disabled: readOnly, onchange: () => this._changed(f, input.value) });
          inputs.push(input);
          return h('label', { class: 'c-choice' }, input, h('span', {}, o.label));
        }));
    } else if (f.control === 'number') {
      const input = h('input', { type: 'number', name, value: raw, step: f.step, min: f.min ?? null,
        max: f.max ?? null, disabled: readOnly, inputmode: 'decimal', 'aria-label': f.text,
        oninput: () => this._changed(f, input.value) });
      inputs.push(input);
      const hint = f.min != null || f.max != null ? `${rangeText(f).trim()}${f.integer ? ', whole' : ''}` : '';
      control = h('div', { class: 'c-number' }, input, hint ? h('span', { class: 'c-muted' }, hint) : null);
    } else {
      const input = h('textarea', { name, rows: 2, maxlength: TEXT_MAX, value: raw, disabled: readOnly,
        'aria-label': f.text,
        oninput: () => this._changed(f, input.value) });
      inputs.push(input);
      control = input;
    }
    const status = h('span', { class: 'c-saved' });
    const error = h('div', { class: 'c-field-error', role: 'alert' });
    const row = h('fieldset', { class: 'c-question', dataset: { question: f.id, control: f.control } },
      h('legend', {}, h('span', { class: 'c-qid' }, f.id), ' ', f.text,
        f.required ? h('span', { class: 'c-required', title: 'required' }, ' *') : h('span', { class: 'c-muted' }, ' (optional)')),
      control, h('div', { class: 'c-question-foot' }, status, error));
    this.rows.set(f.id, { row, status, error, inputs });
    if (i === 0) row.dataset.first = '';
    return row;
  }

  _marks(saved) {
    this.saved = saved;
    for (const f of this.fields) {
      const r = this.rows.get(f.id);
      if (!r) continue;
      const has = saved[f.id] !== undefined && saved[f.id] !== null;
      const draft = this.drafts[f.id];
      const dirty = draft !== undefined && draft !== rawOf(saved[f.id]);
      r.status.textContent = dirty ? (has ? `not saved (saved: ${rawOf(saved[f.id])})` : 'not saved')
        : has ? `saved: ${rawOf(saved[f.id])}` : '';
      r.status.dataset.kind = dirty ? 'dirty' : has ? 'ok' : '';
      r.row.classList.toggle('c-dirty', dirty);
      // a saved value the user has not touched follows the server (e.g. corrected elsewhere)
      if (!dirty && draft === undefined) this._setInputs(f, r, rawOf(saved[f.id]));
    }
  }

  _setInputs(f, r, raw) {
    if (f.control === 'likert' || f.control === 'choice') {
      for (const i of r.inputs) i.checked = i.value === raw;
    } else if (document.activeElement !== r.inputs[0]) {
      r.inputs[0].value = raw;
    }
  }
}
