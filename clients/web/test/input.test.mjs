// Pointer → scene position, depth control, coalescing and key forwarding (src/input.js).
import { test, describe } from 'node:test';
import assert from 'node:assert/strict';
import { PointerInput, KeyForwarder, DEPTH_KEYS, VIEW_RESET_KEY, localKeys } from '../src/input.js';
import { makeCamera } from '../src/scene_view.js';

const W = 1024;
const H = 768;
const ORTHO = { projection: 'orthographic', position: [5, 0, 0.35], target: [0, 0, 0.35], up: [0, 0, 1], height: 1.6 };

function setup(cam = ORTHO, opts = {}) {
  const element = new EventTarget();
  element.getBoundingClientRect = () => ({ left: 0, top: 0, width: W, height: H });
  const { camera, target } = makeCamera(cam, W / H);
  const view = { camera, cameraTarget: target, built: true };
  const input = new PointerInput({ element, view, ...opts });
  const move = (x, y, buttons = 0) =>
    element.dispatchEvent(Object.assign(new Event('pointermove'), { clientX: x, clientY: y, buttons }));
  const wheel = (deltaY) => element.dispatchEvent(Object.assign(new Event('wheel', { cancelable: true }), { deltaY }));
  return { element, input, move, wheel };
}

const near = (got, want, eps = 1e-9) => {
  got.forEach((g, i) => assert.ok(Math.abs(g - want[i]) < eps, `got ${got}, want ${want}`));
};

describe('PointerInput (orthographic camera at +x looking at the target)', () => {
  test('no pointer yet → nothing to send', () => {
    const { input } = setup();
    assert.equal(input.peek(), null);
  });

  test('the HIP holds still while the right or middle button turns the view, until the pointer moves', () => {
    const { input, move } = setup();
    move(W / 2, H / 2);
    input.commit(input.peek());
    move(W / 2 + 96, H / 2, 2); // right-drag: orbiting
    assert.equal(input.peek(), null);
    move(W / 2 + 150, H / 2, 4); // middle-drag: zooming
    assert.equal(input.peek(), null);
    move(W / 2 + 96, H / 2); // released and moved: the HIP follows again
    near(input.peek(), [0, 0.2, 0.35]);
  });

  test('canvas centre maps to the camera target; right = +y, up = +z', () => {
    const { input, move } = setup();
    move(W / 2, H / 2);
    near(input.position(), [0, 0, 0.35]);
    move(W / 2 + 96, H / 2); // 96 px = 0.2 scene units (768 px ↔ 1.6)
    near(input.position(), [0, 0.2, 0.35]);
    move(W / 2, H / 2 - 192);
    near(input.position(), [0, 0, 0.75]);
  });

  test('wheel and depth keys move along the view axis by depthStep, clamped', () => {
    const { input, move, wheel } = setup(ORTHO, { depthStep: 0.05, depthRange: 0.1 });
    move(W / 2, H / 2);
    wheel(+100); // toward the viewer = scene +x
    near(input.position(), [0.05, 0, 0.35]);
    wheel(-100);
    wheel(-100);
    near(input.position(), [-0.05, 0, 0.35]);
    for (let i = 0; i < 10; i++) input.changeDepth(DEPTH_KEYS.PageUp);
    near(input.position(), [-0.1, 0, 0.35]);
    input.reset();
    near(input.position(), [0, 0, 0.35]);
  });

  test('coalescing: peek returns a position only when it changed since commit', () => {
    const { input, move } = setup();
    move(600, 300);
    const p = input.peek();
    assert.ok(p);
    input.commit(p);
    assert.equal(input.peek(), null);
    move(600, 300);
    assert.equal(input.peek(), null, 'same position is not re-sent');
    move(601, 300);
    assert.ok(input.peek());
  });

  test('perspective camera: centre ray hits the target plane; depth stays in front of the camera', () => {
    const cam = { projection: 'perspective', position: [2, 0, 1], target: [0, 0, 1], up: [0, 0, 1], fov_deg: 50 };
    const { input, move } = setup(cam, { depthRange: 5, depthStep: 1 });
    move(W / 2, H / 2);
    near(input.position(), [0, 0, 1]);
    for (let i = 0; i < 10; i++) input.changeDepth(+1);
    assert.ok(input.depth < 2, `depth ${input.depth} must stay in front of the camera`);
    move(W, H / 2);
    assert.ok(input.position()[1] > 0);
  });
});

describe('KeyForwarder', () => {
  function keys(consume = {}) {
    const target = new EventTarget();
    const sent = [];
    const kf = new KeyForwarder(target, (k, a) => sent.push([k, a]), { consume });
    const key = (type, k, extra = {}) => {
      const ev = new Event(type, { cancelable: true });
      for (const [name, value] of Object.entries({ key: k, ...extra })) Object.defineProperty(ev, name, { value });
      target.dispatchEvent(ev);
    };
    return { target, sent, kf, key };
  }

  test('down/up pairs, no auto-repeat', () => {
    const { sent, key } = keys();
    key('keydown', 'r');
    key('keydown', 'r', { repeat: true });
    key('keyup', 'r');
    key('keydown', 'ArrowUp');
    key('keyup', 'ArrowUp');
    assert.deepStrictEqual(sent, [['r', 'down'], ['r', 'up'], ['ArrowUp', 'down'], ['ArrowUp', 'up']]);
  });

  test('typing in a form field is not forwarded', () => {
    const { sent, key } = keys();
    key('keydown', 'a', { target: { tagName: 'INPUT' } });
    assert.deepStrictEqual(sent, []);
  });

  test('Enter and Space on a focused button are the button\'s; Tab moves the focus (issue 34: keyboard)', () => {
    const { sent, key } = keys();
    for (const tagName of ['BUTTON', 'A', 'SUMMARY']) {
      const ev = { target: { tagName } };
      key('keydown', ' ', ev);
      key('keydown', 'Enter', ev);
    }
    key('keydown', 'Tab');
    key('keyup', 'Tab');
    assert.deepStrictEqual(sent, []);
  });

  test('consumed keys run their handler and send nothing', () => {
    let depth = 0;
    const { sent, key } = keys({ PageUp: () => depth--, PageDown: () => depth++ });
    key('keydown', 'PageDown');
    key('keydown', 'PageDown', { repeat: true });
    key('keyup', 'PageDown');
    assert.equal(depth, 2);
    assert.deepStrictEqual(sent, []);
  });

  test('the view reset key (Home) and the depth keys stay in the page', () => {
    const calls = [];
    const consume = localKeys({ changeDepth: (steps) => calls.push(['depth', steps]), resetView: () => calls.push(['reset']) });
    assert.equal(VIEW_RESET_KEY, 'Home');
    const { sent, key } = keys(consume);
    key('keydown', 'Home');
    key('keyup', 'Home');
    key('keydown', 'PageUp');
    key('keydown', 'End'); // not ours: forwarded
    assert.deepStrictEqual(calls, [['reset'], ['depth', DEPTH_KEYS.PageUp]]);
    assert.deepStrictEqual(sent, [['End', 'down']]);
  });

  test('keys held on blur are released', () => {
    const { sent, key, target } = keys();
    key('keydown', ' ');
    target.dispatchEvent(new Event('blur'));
    key('keyup', ' ');
    assert.deepStrictEqual(sent, [[' ', 'down'], [' ', 'up']]);
  });
});
