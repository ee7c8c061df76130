// Orbit and zoom of perspective views (src/orbit.js) with three's OrbitControls, driven by fake
// pointer and wheel events on a fake canvas: no browser, no WebGL.
import { test, describe } from 'node:test';
import assert from 'node:assert/strict';
import { ViewOrbit, orbitable, isZoomWheel, zoomSteps, ZOOM_STEP, ZOOM_RANGE } from '../src/orbit.js';
import { PointerInput } from '../src/input.js';
import { makeCamera } from '../src/scene_view.js';

const W = 1024;
const H = 768;
const PERSPECTIVE = { projection: 'perspective', position: [3.2, 0, 2], target: [0, 0, 0], up: [0, 0, 1], fov_deg: 45 };
const ORTHO = { projection: 'orthographic', position: [5, 0, 0.35], target: [0, 0, 0.35], up: [0, 0, 1], height: 1.6 };

/** An EventTarget that counts its live listeners, so tests can see what was left attached. */
function counted(target) {
  const live = new Map(); // listener → Set of "type:capture"
  const key = (type, opts) => `${type}:${Boolean(typeof opts === 'boolean' ? opts : opts?.capture)}`;
  const add = target.addEventListener.bind(target);
  const remove = target.removeEventListener.bind(target);
  target.addEventListener = (type, fn, opts) => {
    add(type, fn, opts);
    if (!live.has(fn)) live.set(fn, new Set());
    live.get(fn).add(key(type, opts));
  };
  target.removeEventListener = (type, fn, opts) => {
    remove(type, fn, opts);
    live.get(fn)?.delete(key(type, opts));
  };
  Object.defineProperty(target, 'listeners', { get: () => [...live.values()].reduce((n, s) => n + s.size, 0) });
  return target;
}

function fakeCanvas() {
  const element = counted(new EventTarget());
  element.ownerDocument = counted(new EventTarget());
  element.style = { cursor: '' };
  element.clientWidth = W;
  element.clientHeight = H;
  element.getBoundingClientRect = () => ({ left: 0, top: 0, width: W, height: H });
  element.setPointerCapture = () => {};
  element.releasePointerCapture = () => {};
  return element;
}

/** A SceneView stand-in: what ViewOrbit and PointerInput read, rebuilt per scene like build(). */
function fakeView(cam) {
  const view = { built: true };
  view.load = (spec) => {
    const { camera, target } = makeCamera(spec, W / H);
    view.camera = camera;
    view.cameraSpec = spec;
    view.cameraTarget = target;
  };
  view.load(cam);
  return view;
}

function setup(cam = PERSPECTIVE) {
  const element = fakeCanvas();
  const view = fakeView(cam);
  const orbit = new ViewOrbit(element, view);
  orbit.attach();
  const event = (type, props, on = element) => {
    const e = Object.assign(new Event(type, { cancelable: true }), props);
    on.dispatchEvent(e);
    return e;
  };
  // Pointer moves and the release go to the document while a button is held, as in a browser.
  const drag = (button, dx, dy, from = [W / 2, H / 2]) => {
    const base = { pointerId: 1, pointerType: 'mouse', button };
    event('pointerdown', { ...base, clientX: from[0], clientY: from[1] });
    for (let i = 1; i <= 4; i++) {
      event('pointermove', { ...base, clientX: from[0] + (dx * i) / 4, clientY: from[1] + (dy * i) / 4 },
        element.ownerDocument);
    }
    event('pointerup', { ...base, clientX: from[0] + dx, clientY: from[1] + dy }, element.ownerDocument);
  };
  const wheel = (deltaY, mods = {}) => event('wheel', { deltaY, deltaX: 0, clientX: W / 2, clientY: H / 2, ...mods });
  return { element, view, orbit, drag, wheel, event };
}

const near = (got, want, eps = 1e-9) => {
  got.forEach((g, i) => assert.ok(Math.abs(g - want[i]) < eps, `got ${got}, want ${want}`));
};
const moved = (a, b) => Math.hypot(...a.map((v, i) => v - b[i]));

describe('which views orbit and which wheel events zoom', () => {
  test('perspective cameras orbit, orthographic ones stay fixed', () => {
    assert.equal(orbitable(PERSPECTIVE), true);
    assert.equal(orbitable(ORTHO), false);
    assert.equal(orbitable(null), false);
  });

  test('Shift or Ctrl makes the wheel zoom; the plain wheel is the HIP depth', () => {
    assert.equal(isZoomWheel({ shiftKey: true }), true);
    assert.equal(isZoomWheel({ ctrlKey: true }), true);
    assert.equal(isZoomWheel({ altKey: true }), false);
    assert.equal(isZoomWheel({}), false);
  });

  test('zoom notches: wheel down = away; a Shift+wheel turned horizontal still counts', () => {
    assert.equal(zoomSteps({ deltaY: 120, deltaX: 0 }), 1);
    assert.equal(zoomSteps({ deltaY: -3, deltaX: 0 }), -1);
    assert.equal(zoomSteps({ deltaY: 0, deltaX: -100 }), -1);
    assert.equal(zoomSteps({ deltaY: 0, deltaX: 0 }), 0);
  });
});

describe('ViewOrbit on a perspective scene', () => {
  test('attaching keeps the scene camera where it was, looking at the target', () => {
    const { view, orbit } = setup();
    const s = orbit.state();
    assert.equal(s.enabled, true);
    near(s.position, PERSPECTIVE.position);
    near(s.target, PERSPECTIVE.target);
    assert.equal(orbit.controls.target, view.cameraTarget, 'the orbit centre is the view target itself');
  });

  test('right-drag orbits around the target at the same distance', () => {
    const { orbit, drag } = setup();
    const before = orbit.state();
    drag(2, 150, 40);
    const after = orbit.state();
    assert.ok(moved(after.position, before.position) > 0.5, `${before.position} → ${after.position}`);
    near(after.target, before.target);
    assert.ok(Math.abs(after.distance - before.distance) < 1e-9);
  });

  test('left-drag leaves the camera to the HIP', () => {
    const { orbit, drag } = setup();
    drag(0, 150, 40);
    near(orbit.state().position, PERSPECTIVE.position);
  });

  test('middle-drag dollies along the view axis', () => {
    const { orbit, drag } = setup();
    const before = orbit.state();
    drag(1, 0, -200); // up = closer, as in OrbitControls
    const after = orbit.state();
    assert.ok(after.distance < before.distance - 0.1, `${before.distance} → ${after.distance}`);
    near(after.target, before.target);
  });

  test('Shift+wheel zooms one step per notch within the range; the plain wheel does not', () => {
    const { orbit, wheel } = setup();
    const d0 = orbit.state().distance;
    const plain = wheel(100);
    assert.equal(orbit.state().distance, d0);
    assert.equal(plain.defaultPrevented, false, 'the plain wheel is left to PointerInput');
    const zoom = wheel(-100, { shiftKey: true });
    assert.ok(zoom.defaultPrevented);
    assert.ok(Math.abs(orbit.state().distance - d0 * ZOOM_STEP) < 1e-9);
    wheel(0, { shiftKey: true, deltaX: 100 }); // Shift+wheel as Chrome on Linux reports it
    assert.ok(Math.abs(orbit.state().distance - d0) < 1e-9);
    for (let i = 0; i < 40; i++) wheel(100, { ctrlKey: true });
    assert.ok(Math.abs(orbit.state().distance - d0 * ZOOM_RANGE.max) < 1e-9);
  });

  test('reset restores the scene camera', () => {
    const { orbit, drag, wheel } = setup();
    drag(2, 200, 60);
    wheel(-100, { shiftKey: true });
    orbit.reset();
    near(orbit.state().position, PERSPECTIVE.position, 1e-9);
    near(orbit.state().target, PERSPECTIVE.target);
  });

  test('the context menu is suppressed and the stylesheet cursor is left alone', () => {
    const { element, event } = setup();
    assert.equal(event('contextmenu', {}).defaultPrevented, true);
    assert.equal(element.style.cursor, '');
  });

  test('the HIP plane follows the orbited view and a Shift+wheel leaves the depth alone', () => {
    const { element, view, orbit, drag, wheel, event } = setup();
    const pointer = new PointerInput({ element, view, ignoreWheel: (e) => orbit.takesWheel(e) });
    event('pointermove', { clientX: W / 2, clientY: H / 2 });
    near(pointer.position(), PERSPECTIVE.target, 1e-9);
    wheel(100);
    assert.ok(pointer.depth > 0, 'the plain wheel still moves the depth');
    pointer.reset();
    wheel(100, { shiftKey: true });
    assert.equal(pointer.depth, 0);
    drag(2, 150, 40);
    event('pointermove', { clientX: W / 2, clientY: H / 2 });
    near(pointer.position(), PERSPECTIVE.target, 1e-9); // the centre still hits the target
    event('pointermove', { clientX: W / 2 + 100, clientY: H / 2 });
    const right = pointer.position();
    const dist = orbit.state().distance;
    for (let i = 0; i < 80; i++) pointer.changeDepth(+1); // as close to the camera as it goes
    for (let i = 0; i < 20; i++) wheel(-100, { shiftKey: true }); // then zoom in past it
    assert.ok(orbit.state().distance < dist);
    assert.ok(pointer.position() !== null && moved(pointer.position(), right) > 0, 'the plane stays in front');
  });
});

describe('ViewOrbit across scenes', () => {
  test('an orthographic scene stays fixed: right-drag and Shift+wheel change nothing', () => {
    const { orbit, drag, wheel, event } = setup(ORTHO);
    assert.equal(orbit.state().enabled, false);
    drag(2, 150, 40);
    drag(1, 0, -200);
    const zoom = wheel(-100, { shiftKey: true });
    assert.equal(zoom.defaultPrevented, false, 'a fixed view leaves the wheel to the HIP depth');
    near(orbit.state().position, ORTHO.position);
    assert.equal(orbit.takesWheel({ shiftKey: true }), false);
    assert.equal(event('contextmenu', {}).defaultPrevented, true);
  });

  test('a new scene re-creates the controls for its camera and leaks no listeners', () => {
    const { element, view, orbit, drag } = setup(ORTHO);
    const fixed = [element.listeners, element.ownerDocument.listeners];
    view.load(PERSPECTIVE);
    orbit.attach();
    const first = orbit.controls;
    assert.ok(first && first.object === view.camera);
    drag(2, 100, 0);
    view.load({ ...PERSPECTIVE, position: [0, -3, 1] });
    orbit.attach();
    assert.notEqual(orbit.controls, first);
    assert.equal(orbit.controls.object, view.camera);
    near(orbit.state().position, [0, -3, 1], 1e-9);
    view.load(ORTHO);
    orbit.attach();
    assert.equal(orbit.enabled, false);
    assert.deepEqual([element.listeners, element.ownerDocument.listeners], fixed);
    orbit.dispose();
    assert.deepEqual([element.listeners, element.ownerDocument.listeners], [0, 0]);
    assert.equal(element.style.cursor, '');
  });
});
