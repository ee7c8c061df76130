// Operator panel: the running scenario's experimenter commands (GET /api/scenario, info.controls),
// one button each, with an input when the command carries a value. A press goes out as an
// `input` message with action "press" and the value. Shown only on operator pages.
//
// The pure part (which controls, which input, checking a value) works without a DOM.

const MAX_TEXT = 200; // the server's limit for a string value

/** The HTTP origin serving the API next to a WebSocket URL: ws://h:p/ws → http://h:p. */
export function httpBase(wsUrl) {
  const u = new URL(wsUrl);
  u.protocol = u.protocol === 'wss:' ? 'https:' : 'http:';
  return u.origin;
}

/**
 * The input for a value spec {kind, default, low, high, choices, unit}: {type: 'number' |
 * 'select' | 'checkbox' | 'text', initial, min?, max?, step?, options?, unit}.
 * A select's option values are indices into `choices` (choices may be numbers).
 */
export function inputFor(spec) {
  const unit = spec.unit ?? '';
  switch (spec.kind) {
    case 'number':
    case 'int': {
      const initial = spec.default ?? spec.low ?? 0;
      const out = { type: 'number', initial, unit, step: spec.kind === 'int' ? 1 : 'any' };
      if (spec.low != null) out.min = spec.low;
      if (spec.high != null) out.max = spec.high;
      return out;
    }
    case 'choice': {
      const choices = spec.choices ?? [];
      const options = choices.map((c, i) => ({ value: String(i), label: `${c}${unit ? ` ${unit}` : ''}` }));
      const at = choices.indexOf(spec.default);
      return { type: 'select', initial: String(at >= 0 ? at : 0), options, unit: '' };
    }
    case 'bool':
      return { type: 'checkbox', initial: spec.default === true, unit };
    default:
      return { type: 'text', initial: spec.default ?? '', unit };
  }
}

/**
 * The panel rows for a scenario: controls that only an operator may send or that carry a value
 * (plain participant keys are typed on the keyboard). [{key, doc, who, value, input}], input
 * null for a bare command.
 */
export function panelControls(scenario) {
  const controls = scenario?.info?.controls ?? [];
  return controls
    .filter((c) => c.who === 'operator' || c.value)
    .map((c) => ({ key: c.key, doc: c.doc ?? '', who: c.who, value: c.value ?? null,
      input: c.value ? inputFor(c.value) : null }));
}

/**
 * Check a raw input reading against a value spec, as the server will. `raw` is the input's
 * string (number, text, select index) or boolean (checkbox). Returns {value} or {error}.
 */
export function parseValue(spec, raw) {
  const name = spec.name ?? 'value';
  switch (spec.kind) {
    case 'number':
    case 'int': {
      const v = typeof raw === 'number' ? raw : String(raw).trim() === '' ? NaN : Number(raw);
      if (!Number.isFinite(v)) return { error: `${name} must be a number` };
      if (spec.kind === 'int' && !Number.isInteger(v)) return { error: `${name} must be a whole number` };
      if ((spec.low != null && v < spec.low) || (spec.high != null && v > spec.high)) {
        return { error: `${name} must be in [${spec.low ?? '-∞'}, ${spec.high ?? '∞'}]${spec.unit ? ` ${spec.unit}` : ''}` };
      }
      return { value: v };
    }
    case 'choice': {
      const choices = spec.choices ?? [];
      const i = Number(raw);
      if (!Number.isInteger(i) || i < 0 || i >= choices.length) return { error: `${name}: pick one of the choices` };
      return { value: choices[i] };
    }
    case 'bool':
      return typeof raw === 'boolean' ? { value: raw } : { error: `${name} must be true or false` };
    default: {
      const v = String(raw);
      return v.length <= MAX_TEXT ? { value: v } : { error: `${name} must be at most ${MAX_TEXT} characters` };
    }
  }
}

/**
 * The panel itself: title, scenario id and trial, the capability warning if any, a row per command
 * with a value, one row of bare command buttons, a status line.
 */
export class OperatorPanel {
  /**
   * @param {HTMLElement} root                      an empty, hidden container
   * @param {(key: string, value: any) => boolean} send  sends an `input` press; false if not sent
   * @param {() => void} refresh                    fetches the scenario again (a trial started
   *                                                 or ended: no new scene says so)
   */
  constructor(root, send, refresh) {
    this.root = root;
    this.send = send;
    this.refresh = refresh;
    this.rows = [];
  }

  /** Keys of the rows on show (for tests and the page hook). */
  keys() {
    return this.rows.map((r) => r.key);
  }

  _el(tag, cls, text) {
    const e = this.root.ownerDocument.createElement(tag);
    if (cls) e.className = cls;
    if (text !== undefined) e.textContent = text;
    return e;
  }

  _title(text) {
    const title = this._el('div', 'panel-title');
    title.append(this._el('span', null, text));
    const again = this._el('button', 'panel-refresh', '↻');
    again.type = 'button';
    again.title = 'fetch the scenario again';
    again.addEventListener('click', () => {
      again.blur();
      this.refresh();
    });
    title.append(again);
    return title;
  }

  /** Show the controls of a GET /api/scenario answer. */
  show(scenario) {
    this.rows = panelControls(scenario);
    const trial = scenario.trial ? ` · ${scenario.trial.phase} ${scenario.trial.index + 1}` : '';
    const parts = [this._title(scenario.info?.title ?? scenario.id ?? 'scenario'),
      this._el('div', 'panel-sub', `${scenario.id ?? ''}${trial}`)];
    if (scenario.capability && scenario.capability.ok === false) parts.push(this._warning(scenario.capability.message));
    const status = this._el('div', 'panel-status', '');
    // Commands with a value get a row each; bare commands share one wrapping row of buttons.
    const bare = this._el('div', 'panel-keys');
    for (const row of this.rows) {
      if (row.input) parts.push(this._row(row, status));
      else bare.append(this._button(row, () => undefined, status));
    }
    if (bare.childElementCount > 0) parts.push(bare);
    if (this.rows.length === 0) parts.push(this._el('div', 'panel-sub', 'no operator commands'));
    parts.push(status);
    this.root.replaceChildren(...parts);
    this.root.hidden = false;
  }

  /** A long capability message: its first sentence, the rest on demand. */
  _warning(message) {
    const cut = message.indexOf('. ');
    if (cut < 0) return this._el('div', 'panel-warn', message);
    const details = this._el('details', 'panel-warn');
    details.append(this._el('summary', null, message.slice(0, cut + 1)), message.slice(cut + 2));
    return details;
  }

  /** The scenario could not be fetched: say so, keep the refresh button. */
  showError(message) {
    this.rows = [];
    this.root.replaceChildren(this._title('scenario'), this._el('div', 'panel-warn', message));
    this.root.hidden = false;
  }

  _row(row, status) {
    const line = this._el('div', 'panel-row');
    const { field, reader } = this._field(row.input);
    field.title = row.value.doc ?? '';
    field.dataset.key = row.key;
    line.append(this._button(row, reader, status), field);
    if (row.input.unit) line.append(this._el('span', 'panel-unit', row.input.unit));
    return line;
  }

  /** The button sending `row`'s command, with the value `read()` gives once it passes the checks. */
  _button(row, read, status) {
    const button = this._el('button', null, row.key);
    button.type = 'button';
    button.title = row.doc;
    button.dataset.key = row.key;
    button.addEventListener('click', () => {
      button.blur(); // keys go back to the scene, not to this button
      let value;
      if (row.input) {
        const parsed = parseValue(row.value, read());
        if (parsed.error) {
          status.textContent = parsed.error;
          status.dataset.kind = 'error';
          return;
        }
        value = parsed.value;
      }
      const sent = this.send(row.key, value);
      status.textContent = sent ? `sent ${row.key}${value === undefined ? '' : ` ${value}`}` : 'not connected';
      status.dataset.kind = sent ? 'ok' : 'error';
    });
    return button;
  }

  _field(input) {
    if (input.type === 'select') {
      const field = this._el('select');
      for (const o of input.options) {
        const opt = this._el('option', null, o.label);
        opt.value = o.value;
        field.append(opt);
      }
      field.value = input.initial;
      return { field, reader: () => field.value };
    }
    const field = this._el('input');
    if (input.type === 'checkbox') {
      field.type = 'checkbox';
      field.checked = input.initial;
      return { field, reader: () => field.checked };
    }
    field.type = input.type;
    if (input.type === 'number') {
      field.step = String(input.step);
      if (input.min !== undefined) field.min = String(input.min);
      if (input.max !== undefined) field.max = String(input.max);
    } else {
      field.maxLength = MAX_TEXT;
    }
    field.value = String(input.initial);
    return { field, reader: () => field.value };
  }
}
