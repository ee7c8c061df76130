// Sound for the participant (thesis future work: audio matching the task descriptions): spoken
// instructions with the Web Speech API where the browser has it, and optional contact sounds
// (a short click at each contact onset, WebAudio). Both are off unless asked for: a study's
// participant hears nothing its protocol did not plan (docs/xr.md "In XR: panels, answers, audio").
// A study turns them on in its file (`[audio]`, docs/studies.md), which reaches the page with each
// `ask` (protocol v1.5); the URL's ?audio=speech,contact (either or both) adds to it for demos.
// The decisions are pure (AudioPlan); Speaker and Clicker are thin shells over speechSynthesis and
// AudioContext.

/** Which sounds are on: from the page's `audio` query value ('speech', 'contact', comma-separated). */
export function audioSettings(query) {
  const words = new Set(String(query ?? '').split(',').map((w) => w.trim().toLowerCase()).filter(Boolean));
  return { speech: words.has('speech'), contact: words.has('contact') };
}

/** The sounds on: the page's flag (demos) or the study's `ask.audio` ({speech, contact_sounds}). */
export function mergedSettings(flag, study) {
  return { speech: !!(flag?.speech || study?.speech), contact: !!(flag?.contact || study?.contact_sounds) };
}

/** What to say and when to click, from the page's events. Pure. */
export class AudioPlan {
  constructor(settings) {
    this.flag = settings; // the URL's, fixed for the page
    this.settings = settings;
    this.spoken = null; // the instruction text last spoken
    this.touching = new Set();
  }

  /** The study's audio for the task at hand (an `ask` message's `audio`). */
  setStudy(audio) {
    this.settings = mergedSettings(this.flag, audio);
  }

  /** The instruction text (the HUD) now: the text to speak, or null (unchanged, empty, or off).
   * A count-down ('3', '2', …) is spoken too: it is short. */
  say(text) {
    const t = String(text ?? '').trim();
    if (!this.settings.speech || t === '' || t === this.spoken) return null;
    this.spoken = t;
    return t;
  }

  /** The tools of a state frame: how many contact onsets to click for (0 when off). */
  clicks(tools) {
    const now = new Set((tools ?? []).filter((t) => t.contact && !t.lost).map((t) => t.name));
    const onsets = [...now].filter((n) => !this.touching.has(n)).length;
    this.touching = now;
    return this.settings.contact ? onsets : 0;
  }
}

/** speechSynthesis, where present; a newer instruction interrupts the one being spoken. */
export class Speaker {
  constructor(synth = globalThis.speechSynthesis, Utterance = globalThis.SpeechSynthesisUtterance) {
    this.synth = synth;
    this.Utterance = Utterance;
    this.spoken = [];
  }

  get available() {
    return !!(this.synth && this.Utterance);
  }

  speak(text, lang = document?.documentElement?.lang || 'en') {
    this.spoken.push(text);
    if (!this.available) return;
    this.synth.cancel();
    const u = new this.Utterance(text);
    u.lang = lang;
    this.synth.speak(u);
  }
}

/** A 15 ms click (a decaying 1 kHz tone): audible, short enough not to mask the tactile cue; and the
 * interval marks' tones. */
export class Clicker {
  constructor() {
    this.ctx = null;
    this.count = 0;
    this.tones = 0;
  }

  click() {
    this.count++;
    this._beep(1000, 0.015);
  }

  /** A short tone marking an interval's onset (pacing.js): 100 ms, a different pitch per interval. */
  tone(interval = 1) {
    this.tones++;
    this._beep(interval % 2 === 1 ? 660 : 880, 0.1);
  }

  _beep(hz, seconds) {
    const AC = globalThis.AudioContext ?? globalThis.webkitAudioContext;
    if (!AC) return;
    this.ctx = this.ctx ?? new AC();
    const t = this.ctx.currentTime;
    const osc = this.ctx.createOscillator();
    const gain = this.ctx.createGain();
    osc.frequency.value = hz;
    gain.gain.setValueAtTime(0.3, t);
    gain.gain.exponentialRampToValueAtTime(0.001, t + seconds);
    osc.connect(gain).connect(this.ctx.destination);
    osc.start(t);
    osc.stop(t + seconds + 0.005);
  }
}
