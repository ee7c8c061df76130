// Mouse orbit and zoom of a perspective view, with three's OrbitControls. Orthographic scenes stay
// fixed: their tasks hide depth on purpose, and orbiting would reveal it.
//
// The left button, plain pointer moves and the plain wheel belong to the HIP (input.js), so:
// right-drag orbits around the camera target, middle-drag dollies, Shift+wheel or Ctrl+wheel
// (also a trackpad pinch, which browsers report as Ctrl+wheel) zooms. No panning: the camera
// target stays the orbit centre, and the HIP's depth plane (input.js) goes through it.

import { MOUSE } from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { threeToScene } from './protocol.js';

/** Camera distance factor per zoom wheel notch (< 1: closer). */
export const ZOOM_STEP = 0.9;
/** Zoom limits as factors of the scene camera's distance to its target. */
export const ZOOM_RANGE = Object.freeze({ min: 0.25, max: 4 });

/** Whether a scene camera spec may be orbited. */
export function orbitable(cameraSpec) {
  return cameraSpec?.projection === 'perspective';
}

/** A wheel event meant as zoom rather than HIP depth. */
export function isZoomWheel(e) {
  return Boolean(e.shiftKey || e.ctrlKey);
}

/**
 * Notches of a zoom wheel event: +1 away from the target (wheel down), -1 closer, 0 none.
 * Chrome and Firefox on Windows/Linux turn a Shift+wheel into a horizontal scroll, so deltaX
 * stands in when deltaY is 0.
 */
export function zoomSteps(e) {
  return Math.sign(e.deltaY || e.deltaX || 0);
}

/**
 * OrbitControls without its own wheel handling (the plain wheel is the HIP's depth; ViewOrbit
 * zooms on a modifier wheel) and without touching the canvas's stylesheet cursor.
 */
class WheelFreeOrbitControls extends OrbitControls {
  connect(element) {
    super.connect(element);
    element.removeEventListener('wheel', this._onMouseWheel);
    element.style.cursor = ''; // connect() runs disconnect(), which writes `cursor: auto` inline
  }

  disconnect() {
    super.disconnect();
    this.domElement.style.cursor = '';
  }
}

export class ViewOrbit {
  /**
   * @param {HTMLElement} element  the canvas
   * @param {object} view          a SceneView (camera, cameraSpec, cameraTarget)
   */
  constructor(element, view) {
    this.element = element;
    this.view = view;
    this.controls = null; // OrbitControls of the current scene, null when its view is fixed
    this._onWheel = (e) => this._wheel(e);
    this._onContextMenu = (e) => e.preventDefault(); // the right button orbits, even on fixed views
    element.addEventListener('wheel', this._onWheel, { passive: false });
    element.addEventListener('contextmenu', this._onContextMenu);
  }

  get enabled() {
    return this.controls !== null;
  }

  /** New scene (new camera): drop the old controls, orbit the new camera if it is perspective. */
  attach() {
    this._detach();
    if (!orbitable(this.view.cameraSpec)) return;
    const c = new WheelFreeOrbitControls(this.view.camera, this.element);
    c.mouseButtons = { LEFT: null, MIDDLE: MOUSE.DOLLY, RIGHT: MOUSE.ROTATE };
    c.touches = { ONE: null, TWO: null }; // one finger stays the HIP
    c.enablePan = false;
    c.target = this.view.cameraTarget; // shared: PointerInput's depth plane goes through it
    c.update();
    const dist = c.getDistance();
    c.minDistance = dist * ZOOM_RANGE.min;
    c.maxDistance = dist * ZOOM_RANGE.max;
    // Stay above the target's horizon (the scenes stand on a ground plane), unless the scene's
    // own camera looks from below.
    c.maxPolarAngle = Math.max(Math.PI / 2, c.getPolarAngle());
    c.saveState();
    this.controls = c;
  }

  _detach() {
    this.controls?.dispose();
    this.controls = null;
  }

  /** Whether this wheel event zooms the view (then the HIP depth must ignore it). */
  takesWheel(e) {
    return this.enabled && isZoomWheel(e);
  }

  _wheel(e) {
    if (!this.takesWheel(e)) return;
    e.preventDefault(); // no page zoom on Ctrl+wheel
    this.zoom(zoomSteps(e));
  }

  /** Move the camera `steps` notches away from the target (negative: closer). */
  zoom(steps) {
    if (!this.enabled || steps === 0) return;
    const scale = ZOOM_STEP ** Math.abs(steps);
    if (steps < 0) this.controls.dollyIn(scale);
    else this.controls.dollyOut(scale);
  }

  /** Back to the scene's camera. */
  reset() {
    this.controls?.reset();
  }

  /** {enabled, position, target, distance}, positions in the scene frame. */
  state() {
    const cam = this.view.camera;
    return {
      enabled: this.enabled,
      position: threeToScene(cam.position.toArray()),
      target: threeToScene(this.view.cameraTarget.toArray()),
      distance: cam.position.distanceTo(this.view.cameraTarget),
    };
  }

  dispose() {
    this._detach();
    this.element.removeEventListener('wheel', this._onWheel);
    this.element.removeEventListener('contextmenu', this._onContextMenu);
  }
}
