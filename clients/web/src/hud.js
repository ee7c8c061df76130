// DOM overlay: scenario HUD text, connection status and a telemetry line. Desktop only (DOM
// labels do not show inside an immersive WebXR session; that client draws into the scene).

function fmtUs(us) {
  return typeof us === 'number' ? `${(us / 1000).toFixed(2)} ms` : '–';
}

export class Hud {
  /** @param {{hud: HTMLElement, status: HTMLElement, telemetry: HTMLElement, values?: HTMLElement}} els */
  constructor(els, { showValues = false } = {}) {
    this.els = els;
    this.showValues = showValues;
    this._text = null;
    this._values = null;
  }

  setText(text) {
    if (text === this._text) return;
    this._text = text;
    this.els.hud.textContent = text;
    this.els.hud.hidden = text === '';
  }

  setStatus(text, kind = 'info') {
    this.els.status.textContent = text;
    this.els.status.dataset.kind = kind;
  }

  /** Telemetry line: the server loop's p99 period and overruns, our fps and state rate. */
  setTelemetry({ telemetry = {}, fps = 0, stateHz = 0 } = {}) {
    const parts = [
      `loop p99 ${fmtUs(telemetry.period_p99_us)}`,
      `overruns ${telemetry.overruns ?? '–'}`,
      `state ${stateHz.toFixed(0)} Hz`,
      `${fps.toFixed(0)} fps`,
    ];
    if (telemetry.rt === false) parts.push('not real-time');
    this.els.telemetry.textContent = parts.join(' · ');
  }

  /** Scenario values (operators/observers only: they may give away the answer to a participant). */
  setValues(values) {
    if (!this.showValues || !this.els.values) return;
    const text = Object.entries(values ?? {})
      .map(([k, v]) => `${k} ${typeof v === 'number' ? +v.toFixed(3) : JSON.stringify(v)}`)
      .join(' · ');
    if (text === this._values) return;
    this._values = text;
    this.els.values.textContent = text;
  }
}
