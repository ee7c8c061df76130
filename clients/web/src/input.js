// Desktop input: the pointer drives the HIP, the wheel and PageUp/PageDown its depth, Home resets
// an orbited view (orbit.js), every other key becomes an `input` message. Pointer samples are
// coalesced: the render loop takes at most one per animation frame, and only when the position
// changed.

import * as THREE from 'three';
import { threeToScene } from './protocol.js';

const VIEW_BUTTONS = 2 | 4; // PointerEvent.buttons: right | middle

export const DEPTH_KEYS = Object.freeze({ PageUp: -1, PageDown: +1 });
/** Restores the scene's camera after orbiting; client-side only, never sent to the server. */
export const VIEW_RESET_KEY = 'Home';

/**
 * The keys this page handles itself (KeyForwarder's `consume`): depth keys and the view reset.
 * @param {{changeDepth: (steps: number) => void, resetView: () => void}} handlers
 */
export function localKeys({ changeDepth, resetView }) {
  const keys = Object.fromEntries(Object.entries(DEPTH_KEYS).map(([k, dir]) => [k, () => changeDepth(dir)]));
  keys[VIEW_RESET_KEY] = () => resetView();
  return keys;
}

/**
 * Pointer → scene position. The HIP lies on the plane perpendicular to the camera's view
 * direction through the "depth point" = camera target moved `depth` toward the viewer.
 * Wheel down / PageDown bring it toward the viewer (+depth), wheel up / PageUp push it away.
 */
export class PointerInput {
  /**
   * @param {object} opts
   * @param {HTMLElement} opts.element     the canvas
   * @param {object} opts.view             a SceneView (camera, cameraTarget)
   * @param {number} [opts.depthStep]      scene units per wheel notch / key press (0.02)
   * @param {number} [opts.depthRange]     |depth| limit in scene units (1.5)
   * @param {(e: WheelEvent) => boolean} [opts.ignoreWheel]  wheel events that belong to someone
   *                                       else (the orbit's zoom) and leave the depth alone
   */
  constructor({ element, view, depthStep = 0.02, depthRange = 1.5, ignoreWheel = () => false }) {
    this.element = element;
    this.view = view;
    this.ignoreWheel = ignoreWheel;
    this.depthStep = depthStep;
    this.depthRange = depthRange;
    this.depth = 0;
    this.ndc = null; // last pointer position in normalised device coordinates
    this.lastSent = null; // scene position last handed out by commit()
    this.raycaster = new THREE.Raycaster();
    this._plane = new THREE.Plane();
    this._point = new THREE.Vector3();
    this._dir = new THREE.Vector3();
    this._hit = new THREE.Vector3();

    this._onPointer = (e) => this._pointer(e);
    this._onWheel = (e) => this._wheel(e);
    element.addEventListener('pointermove', this._onPointer);
    element.addEventListener('pointerdown', this._onPointer);
    element.addEventListener('wheel', this._onWheel, { passive: false });
  }

  dispose() {
    this.element.removeEventListener('pointermove', this._onPointer);
    this.element.removeEventListener('pointerdown', this._onPointer);
    this.element.removeEventListener('wheel', this._onWheel);
  }

  /** New scene: depth back to the camera target's plane. */
  reset() {
    this.depth = 0;
    this.lastSent = null;
  }

  _pointer(e) {
    // The right and middle buttons turn the view (orbit.js): the HIP stays put meanwhile, and
    // after the release until the pointer moves again, so orbiting never drags a grasped object.
    this.viewHeld = ((e.buttons ?? 0) & VIEW_BUTTONS) !== 0;
    if (this.viewHeld) return;
    const rect = this.element.getBoundingClientRect();
    if (rect.width === 0 || rect.height === 0) return;
    this.ndc = new THREE.Vector2(
      ((e.clientX - rect.left) / rect.width) * 2 - 1,
      -((e.clientY - rect.top) / rect.height) * 2 + 1,
    );
  }

  _wheel(e) {
    if (this.ignoreWheel(e)) return;
    e.preventDefault();
    if (e.deltaY === 0) return;
    this.changeDepth(Math.sign(e.deltaY));
  }

  /** Move the depth by `steps` steps (positive = toward the viewer), clamped. */
  changeDepth(steps) {
    const limit = this._depthLimit();
    this.depth = Math.min(limit, Math.max(-this.depthRange, this.depth + steps * this.depthStep));
  }

  _depthLimit() {
    const cam = this.view.camera;
    if (!cam.isPerspectiveCamera) return this.depthRange;
    // A perspective camera must keep the plane in front of it.
    const dist = cam.position.distanceTo(this.view.cameraTarget);
    return Math.min(this.depthRange, dist - 2 * cam.near);
  }

  /** Scene position under the pointer at the current depth, or null (no pointer yet). */
  position() {
    if (this.ndc === null || !this.view.built) return null;
    const cam = this.view.camera;
    cam.updateMatrixWorld();
    cam.getWorldDirection(this._dir); // unit, pointing away from the viewer
    // A zoomed-in camera may now be closer than the depth set before: keep the plane in front.
    const depth = Math.min(this.depth, this._depthLimit());
    this._point.copy(this.view.cameraTarget).addScaledVector(this._dir, -depth);
    this._plane.setFromNormalAndCoplanarPoint(this._dir, this._point);
    this.raycaster.setFromCamera(this.ndc, cam);
    if (this.raycaster.ray.intersectPlane(this._plane, this._hit) === null) return null;
    return threeToScene(this._hit.toArray());
  }

  /** The position to send this frame, or null when nothing changed since the last commit(). */
  peek() {
    if (this.viewHeld) return null;
    const p = this.position();
    if (p === null) return null;
    const last = this.lastSent;
    if (last && last[0] === p[0] && last[1] === p[1] && last[2] === p[2]) return null;
    return p;
  }

  /** Record that `p` went out. */
  commit(p) {
    this.lastSent = p;
  }
}

function isFormField(target) {
  if (!target || typeof target !== 'object') return false;
  if (target.isContentEditable) return true;
  const tag = (target.tagName || '').toUpperCase();
  // a focused button or link owns its Enter / Space (the answer buttons: keyboard users answer so)
  return tag === 'INPUT' || tag === 'TEXTAREA' || tag === 'SELECT' || tag === 'BUTTON' || tag === 'A'
    || tag === 'SUMMARY';
}

/**
 * Keys → `input` messages ("down"/"up"), except while typing in a form field and except the keys
 * in `consume` (handled locally, e.g. PageUp/PageDown for depth). Auto-repeat is not re-sent;
 * keys still held when the window loses focus are released.
 */
export class KeyForwarder {
  /**
   * @param {EventTarget} target                 usually window
   * @param {(key: string, action: string) => void} send
   * @param {object} [opts]
   * @param {Record<string, Function>} [opts.consume]  key → local handler (no message sent)
   */
  constructor(target, send, { consume = {} } = {}) {
    this.target = target;
    this.send = send;
    this.consume = consume;
    this.held = new Set();
    this._down = (e) => this._key(e, 'down');
    this._up = (e) => this._key(e, 'up');
    this._blur = () => this.releaseAll();
    target.addEventListener('keydown', this._down);
    target.addEventListener('keyup', this._up);
    target.addEventListener('blur', this._blur);
  }

  dispose() {
    this.target.removeEventListener('keydown', this._down);
    this.target.removeEventListener('keyup', this._up);
    this.target.removeEventListener('blur', this._blur);
  }

  _key(e, action) {
    if (isFormField(e.target)) return;
    const key = e.key;
    if (!key || key.length > 32 || key === 'Tab') return; // Tab moves the focus, it is no scenario key
    if (key in this.consume) {
      if (action === 'down') {
        e.preventDefault();
        this.consume[key](e);
      }
      return;
    }
    if (action === 'down') {
      if (e.repeat || this.held.has(key)) return;
      this.held.add(key);
    } else if (!this.held.delete(key)) {
      return; // its "down" was not sent (e.g. pressed while typing in a field)
    }
    if (key === ' ' || key.startsWith('Arrow')) e.preventDefault(); // no page scrolling
    this.send(key, action);
  }

  releaseAll() {
    for (const key of this.held) this.send(key, 'up');
    this.held.clear();
  }
}
