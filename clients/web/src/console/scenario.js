// The console's scenario card: the scenarios this server can run (GET /api/scenarios), each
// parameter as a form control with its declared range or choices, and a switch (POST
// /api/scenario). A refusal is shown next to the button, in the console's words (words.js).
//
// Pure (paramControl's spec, readParams) plus the ScenarioCard shell, so the parsing is tested
// under node.

import { fill, h, say } from './dom.js';
import { consoleWords } from './words.js';

/** How one declared parameter (server/core/scenario.py describe) is edited: {tag, attrs, options}. */
export function controlSpec(p, value) {
  const v = value === undefined ? p.default : value;
  if (p.kind === 'choice') {
    return { tag: 'select', options: [...(p.optional ? [{ value: '', text: '(none)' }] : []),
      ...(p.choices ?? []).map((c) => ({ value: JSON.stringify(c), text: String(c), selected: c === v }))] };
  }
  if (p.kind === 'bool') return { tag: 'input', attrs: { type: 'checkbox', checked: !!v } };
  if (p.kind === 'number' || p.kind === 'int') {
    return { tag: 'input', attrs: { type: 'number', step: p.kind === 'int' ? '1' : 'any', min: p.low ?? null,
      max: p.high ?? null, value: v == null ? '' : String(v), placeholder: p.optional ? 'none' : '' } };
  }
  return { tag: 'input', attrs: { type: 'text', value: v == null ? '' : String(v), placeholder: p.optional ? 'none' : '' } };
}

/** The declared range in words, e.g. "0 – 100 %". */
export function rangeText(p) {
  const unit = p.unit ? ` ${p.unit}` : '';
  if (p.kind === 'choice') return `one of ${(p.choices ?? []).join(', ')}${unit}`;
  if (p.low != null && p.high != null) return `${p.low} – ${p.high}${unit}`;
  return unit.trim();
}

/** The params to send from raw inputs {name: string | boolean}: {params} or {error: {name, text}}. */
export function readParams(decl, raw) {
  const params = {};
  for (const p of decl) {
    const r = raw[p.name];
    if (p.kind === 'bool') {
      params[p.name] = !!r;
      continue;
    }
    if (r === '' || r == null) {
      if (p.optional) continue;
      if (p.kind === 'text') {
        params[p.name] = '';
        continue;
      }
      return { error: { name: p.name, text: `${p.name}: give a value (${rangeText(p)})` } };
    }
    if (p.kind === 'choice') {
      params[p.name] = JSON.parse(r);
    } else if (p.kind === 'number' || p.kind === 'int') {
      const n = Number(r);
      if (!Number.isFinite(n) || (p.kind === 'int' && !Number.isInteger(n))) {
        return { error: { name: p.name, text: `${p.name}: ${p.kind === 'int' ? 'a whole number' : 'a number'} is needed` } };
      }
      if ((p.low != null && n < p.low) || (p.high != null && n > p.high)) {
        return { error: { name: p.name, text: `${p.name}: ${n} is outside ${rangeText(p)}` } };
      }
      params[p.name] = n;
    } else params[p.name] = String(r);
  }
  return { params };
}

export class ScenarioCard {
  /** `el`: the card's body; `api`: api.js Api. The server decides who may switch (the lease). */
  constructor(el, api) {
    this.el = el;
    this.api = api;
    this.list = [];
    this.running = null;
    this.chosen = null;
    this.inputs = new Map();
  }

  async load() {
    try {
      [this.list, this.running] = await Promise.all([this.api.request('GET', '/api/scenarios'),
        this.api.request('GET', '/api/scenario').catch(() => null)]);
    } catch (e) {
      if (e?.status !== 401) fill(this.el, h('div', { class: 'c-msg', dataset: { kind: 'error' } }, consoleWords(e.message)));
      return;
    }
    if (!this.chosen || !this.list.some((s) => s.id === this.chosen)) this.chosen = this.running?.id ?? this.list[0]?.id;
    this.render();
  }

  /** The running scenario changed (a `scene` message): show it. */
  async refreshRunning() {
    try {
      this.running = await this.api.request('GET', '/api/scenario');
    } catch { return; }
    const line = this.el.querySelector('#scenario-running');
    if (line) line.textContent = this.runningText();
  }

  runningText() {
    return this.running ? `Running: ${this.running.info?.title ?? this.running.id} (${this.running.id})` : 'Running: unknown';
  }

  render() {
    const s = this.list.find((x) => x.id === this.chosen);
    this.inputs = new Map();
    const values = s && this.running?.id === s.id ? this.running.params ?? {} : {};
    const rows = (s?.params ?? []).map((p) => {
      const spec = controlSpec(p, values[p.name]);
      const id = `scenario-param-${p.name}`;
      const input = spec.tag === 'select'
        ? h('select', { id }, spec.options.map((o) => h('option', { value: o.value, selected: o.selected }, o.text)))
        : h('input', { id, ...spec.attrs });
      this.inputs.set(p.name, input);
      return h('div', { class: 'c-field' }, h('label', { for: id }, p.name, p.unit ? ` (${p.unit})` : ''), input,
        h('small', { class: 'c-muted' }, [p.doc, rangeText(p)].filter(Boolean).join(' · ')));
    });
    const cap = s?.capability;
    fill(this.el,
      h('div', { id: 'scenario-running', class: 'c-muted' }, this.runningText()),
      h('div', { class: 'c-field' }, h('label', { for: 'scenario-choice' }, 'Scenario'),
        h('select', { id: 'scenario-choice', onchange: (e) => { this.chosen = e.target.value; this.render(); } },
          this.list.map((x) => h('option', { value: x.id, selected: x.id === this.chosen }, `${x.title} (${x.id})`)))),
      cap ? h('div', { class: 'c-msg', dataset: { kind: cap.ok ? 'ok' : 'error' } }, cap.message) : null,
      h('form', { id: 'scenario-form', class: 'c-form', novalidate: true, onsubmit: (e) => { e.preventDefault(); this.switch(); } },
        rows.length ? rows : h('div', { class: 'c-muted' }, 'This scenario has no parameters.'),
        h('div', { class: 'c-actions' }, h('button', { id: 'scenario-switch', type: 'submit', class: 'c-primary' },
          'Switch scenario'))),
      h('div', { id: 'scenario-msg', class: 'c-msg', role: 'alert' }));
  }

  raw() {
    const out = {};
    for (const [name, input] of this.inputs) out[name] = input.type === 'checkbox' ? input.checked : input.value;
    return out;
  }

  async switch() {
    const msg = this.el.querySelector('#scenario-msg');
    const s = this.list.find((x) => x.id === this.chosen);
    if (!s) return;
    const read = readParams(s.params ?? [], this.raw());
    if (read.error) {
      say(msg, `Not switched: ${read.error.text}.`, 'error');
      this.inputs.get(read.error.name)?.focus();
      return;
    }
    say(msg, '');
    try {
      await this.api.request('POST', '/api/scenario', { body: { name: s.id, params: read.params } });
      say(msg, `Switched to ${s.title}.`, 'ok');
      await this.refreshRunning();
    } catch (e) {
      say(msg, `Not switched: ${consoleWords(e.message)}`, 'error');
    }
  }
}
