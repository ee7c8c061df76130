// Tiny DOM helpers for the console (no framework). Only touch `document` when called, so the
// modules that import this one still load under node for their pure parts.

const PROPS = new Set(['value', 'checked', 'disabled', 'hidden', 'open', 'selected', 'textContent']);

/**
 * h('button', {class: 'x', onclick: fn, disabled: true}, 'text', child, [more]) → element.
 * `on*` attributes become listeners, `dataset` a map of data-*, PROPS are set as properties,
 * null/false attributes and children are skipped.
 */
export function h(tag, attrs = {}, ...children) {
  const el = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs ?? {})) {
    if (v == null || v === false) continue;
    if (k === 'class') el.className = v;
    else if (k === 'dataset') Object.assign(el.dataset, v);
    else if (k.startsWith('on') && typeof v === 'function') el.addEventListener(k.slice(2), v);
    else if (PROPS.has(k)) el[k] = v;
    else el.setAttribute(k, v === true ? '' : String(v));
  }
  append(el, children);
  return el;
}

function append(el, children) {
  for (const c of children.flat(Infinity)) {
    if (c == null || c === false) continue;
    el.append(typeof c === 'object' ? c : String(c));
  }
}

/** Replace every child of `el`. */
export function fill(el, ...children) {
  el.replaceChildren();
  append(el, children);
  return el;
}

/** Show a message in a status element: kind 'error' | 'ok' | 'info' | '' (clears). */
export function say(el, text, kind = 'info') {
  if (!el) return;
  el.textContent = text ?? '';
  el.dataset.kind = text ? kind : '';
}

/**
 * fill(el, ...build()) only when `sig` (what the content says) differs from what `el` shows: a
 * periodically refreshed part is not rebuilt under the user's pointer. True when it was rebuilt.
 */
export function fillOnChange(el, sig, build) {
  if (el.dataset.sig === sig) return false;
  el.dataset.sig = sig;
  fill(el, ...[build()].flat());
  return true;
}
