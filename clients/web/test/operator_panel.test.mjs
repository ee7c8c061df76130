// Operator panel, pure part (src/operator_panel.js): which controls, which inputs, value checks.
import { test, describe } from 'node:test';
import assert from 'node:assert/strict';
import { httpBase, inputFor, panelControls, parseValue } from '../src/operator_panel.js';

// The shape of GET /api/scenario (contact-angle-v1, trimmed), plus a participant key with a value.
const SCENARIO = {
  id: 'contact-angle-v1',
  params: { magnitude_pct: 100 },
  seed: 0,
  trial: null,
  info: {
    id: 'contact-angle-v1',
    title: 'Contact angle (hemisphere, Algorithm 1)',
    controls: [
      { key: 'tap_angle', doc: 'place the HIP on the arc', who: 'operator',
        value: { name: 'angle_deg', kind: 'number', doc: 'contact angle', default: 0, low: -90, high: 90, unit: 'deg' } },
      { key: 'release', doc: 'release a held tap', who: 'operator', value: null },
      { key: 'scale', doc: 'show or hide the angle scale', who: 'operator',
        value: { name: 'shown', kind: 'bool', doc: 'true shows the scale', default: true } },
      { key: 'r', doc: 'reset', who: 'participant', value: null },
      { key: 'answer', doc: 'rate', who: 'participant',
        value: { name: 'rating', kind: 'int', doc: '7-point', default: 4, low: 1, high: 7 } },
    ],
  },
  capability: { ok: true, message: '' },
};

const TEXTURE = { name: 'period_us', kind: 'choice', doc: 'period', default: 4000, choices: [2000, 3000, 4000], unit: 'us' };

describe('panel controls', () => {
  test('operator commands and anything carrying a value; plain participant keys are left out', () => {
    const rows = panelControls(SCENARIO);
    assert.deepStrictEqual(rows.map((r) => r.key), ['tap_angle', 'release', 'scale', 'answer']);
    assert.equal(rows[1].input, null);
    assert.deepStrictEqual(rows[0].input, { type: 'number', initial: 0, unit: 'deg', step: 'any', min: -90, max: 90 });
    assert.deepStrictEqual(rows[2].input, { type: 'checkbox', initial: true, unit: '' });
    assert.equal(rows[3].input.step, 1);
  });

  test('no scenario info: no rows', () => {
    assert.deepStrictEqual(panelControls({}), []);
    assert.deepStrictEqual(panelControls(null), []);
  });

  test('choice: a select over indices, starting at the default', () => {
    const input = inputFor(TEXTURE);
    assert.equal(input.type, 'select');
    assert.equal(input.initial, '2');
    assert.deepStrictEqual(input.options.map((o) => o.label), ['2000 us', '3000 us', '4000 us']);
    assert.deepStrictEqual(inputFor({ kind: 'text', default: 'x' }), { type: 'text', initial: 'x', unit: '' });
  });
});

describe('value checks (as the server does them)', () => {
  const angle = SCENARIO.info.controls[0].value;
  test('numbers in range', () => {
    assert.deepStrictEqual(parseValue(angle, '-30'), { value: -30 });
    assert.deepStrictEqual(parseValue(angle, ' 12.5 '), { value: 12.5 });
    assert.deepStrictEqual(parseValue(angle, 90), { value: 90 });
    assert.match(parseValue(angle, '91').error, /angle_deg must be in \[-90, 90\] deg/);
    assert.match(parseValue(angle, '').error, /must be a number/);
    assert.match(parseValue(angle, 'abc').error, /must be a number/);
  });
  test('ints are whole', () => {
    const rating = SCENARIO.info.controls[4].value;
    assert.deepStrictEqual(parseValue(rating, '7'), { value: 7 });
    assert.match(parseValue(rating, '2.5').error, /whole number/);
  });
  test('choices map back to the choice (numbers stay numbers)', () => {
    assert.deepStrictEqual(parseValue(TEXTURE, '0'), { value: 2000 });
    assert.ok(parseValue(TEXTURE, '3').error);
  });
  test('bools and text', () => {
    const shown = SCENARIO.info.controls[2].value;
    assert.deepStrictEqual(parseValue(shown, false), { value: false });
    assert.ok(parseValue(shown, 'false').error);
    assert.deepStrictEqual(parseValue({ kind: 'text' }, 'note'), { value: 'note' });
    assert.ok(parseValue({ kind: 'text' }, 'x'.repeat(201)).error);
  });
});

test('the API lives next to the WebSocket', () => {
  assert.equal(httpBase('ws://127.0.0.1:8765/ws'), 'http://127.0.0.1:8765');
  assert.equal(httpBase('wss://lab.example/ws'), 'https://lab.example');
});
