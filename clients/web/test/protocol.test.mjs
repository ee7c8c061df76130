// Codec, builders, validation and frame conversions (src/protocol.js), checked against the shared
// vectors in tests/vectors/ (repo root) and a few hand-written cases.
import { test, describe } from 'node:test';
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { fileURLToPath } from 'node:url';
import { createHash } from 'node:crypto';
import * as P from '../src/protocol.js';

const VECTORS = new URL('../../../tests/vectors/', import.meta.url);

function loadVectors(name) {
  const path = fileURLToPath(new URL(name, VECTORS));
  try {
    return JSON.parse(readFileSync(path, 'utf8'));
  } catch (e) {
    throw new Error(`cannot read shared vectors ${path}: ${e.message}`);
  }
}

const hex = (bytes) => Buffer.from(bytes).toString('hex');
const unhex = (s) => new Uint8Array(Buffer.from(s, 'hex'));

/** Build a client → server message with the builders, from a vector's message. */
function build(msg) {
  switch (msg.type) {
    case 'hello': return P.hello(msg.role, msg.client, msg.token ?? null);
    case 'tracker': return P.tracker(msg.seq, msg.t, msg.pos, msg.quat ?? null,
      { point: msg.point ?? null, points: msg.points ?? null, ttl: msg.ttl ?? null });
    case 'input': return P.input(msg.key, msg.action, msg.value);
    case 'answer': return P.answer(msg.seq, msg.question, msg.value);
    case 'actuators': return P.actuators(msg.actuators, msg.note ?? '');
    default: throw new Error(`no builder for ${msg.type}`);
  }
}

describe('shared message vectors (tests/vectors/messages.json)', () => {
  const file = loadVectors('messages.json');
  test('file format', () => {
    assert.equal(file.version, 1);
    assert.ok(Array.isArray(file.vectors) && file.vectors.length > 0);
  });
  test('covers overlays, skins, visibility, events and command values', () => {
    const byName = Object.fromEntries(file.vectors.map((v) => [v.name, v.message]));
    const scene = byName['scene-overlays-skin']?.scene;
    assert.ok(scene, 'scene-overlays-skin is missing');
    assert.deepStrictEqual(scene.overlays.map((o) => o.kind).sort(), ['angle_scale', 'label']);
    assert.ok(scene.objects.some((o) => o.material?.skin?.image), 'no skinned object');
    const states = file.vectors.filter((v) => v.message.type === 'state').map((v) => v.message);
    assert.ok(states.some((m) => Object.keys(m.visible ?? {}).length > 0), 'no state with visible overrides');
    assert.ok(states.some((m) => m.events?.length > 0), 'no state with events');
    assert.equal(byName['input-command-value']?.value, -30);
  });
  for (const v of file.vectors) {
    if (v.direction === 'client_to_server') {
      test(`${v.name}: builder encodes byte-exactly`, () => {
        const built = build(v.message);
        assert.deepStrictEqual(built, v.message);
        assert.equal(hex(P.encode(built, 'msgpack')), v.msgpack_hex.toLowerCase());
      });
    }
    test(`${v.name}: decodes to its message and validates`, () => {
      const msg = P.decode(unhex(v.msgpack_hex), 'msgpack');
      assert.deepStrictEqual(msg, v.message);
      assert.equal(P.validate(msg), null);
      // ArrayBuffer input, as a browser WebSocket delivers it
      const bytes = unhex(v.msgpack_hex);
      const ab = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
      assert.deepStrictEqual(P.decode(ab, 'msgpack'), v.message);
    });
    test(`${v.name}: the JS encoder writes the same bytes from the message`, () => {
      // Field order = the vector file's key order; integral numbers as ints (canonical rule).
      assert.equal(hex(P.encode(v.message, 'msgpack')), v.msgpack_hex.toLowerCase());
    });
    test(`${v.name}: JSON round trip`, () => {
      const text = P.encode(v.message, 'json');
      assert.equal(typeof text, 'string');
      assert.deepStrictEqual(P.decode(text, 'json'), v.message);
    });
  }
});

describe('shared coordinate vectors (tests/vectors/coordinates.json)', () => {
  const file = loadVectors('coordinates.json');
  const close = (got, want, what) => {
    assert.equal(got.length, want.length, what);
    got.forEach((g, i) => assert.ok(Math.abs(g - want[i]) <= 1e-12, `${what}: got ${got}, want ${want}`));
  };
  test('has points and rotations', () => {
    assert.ok(file.points.length > 0);
    assert.ok(file.rotations.length > 0);
  });
  test('points scene ↔ three', () => {
    for (const p of file.points) {
      close(P.sceneToThree(p.scene), p.three, `sceneToThree(${p.scene})`);
      close(P.threeToScene(p.three), p.scene, `threeToScene(${p.three})`);
    }
  });
  test('rotations scene → three', () => {
    for (const r of file.rotations) {
      close(P.quatSceneToThree(r.scene), r.three, `quatSceneToThree(${r.scene})`);
      close(P.quatThreeToScene(r.three), r.scene, `quatThreeToScene(${r.three})`);
    }
  });
});

describe('builders', () => {
  test('field order and canonical numbers', () => {
    // {type:"tracker", seq:3, t:12.5, pos:[0, 0.25, 1]}: ints stay ints, 12.5 and 0.25 are float64
    const bytes = P.encode(P.tracker(3, 12.5, [0, 0.25, 1]));
    assert.equal(hex(bytes),
      '84' + 'a474797065' + 'a7747261636b6572' + 'a3736571' + '03' + 'a174' + 'cb4029000000000000'
      + 'a3706f73' + '93' + '00' + 'cb3fd0000000000000' + '01');
    assert.deepStrictEqual(Object.keys(P.hello('observer', 'x')), ['type', 'v', 'role', 'client']);
    assert.deepStrictEqual(Object.keys(P.tracker(0, 1, [1, 2, 3], [1, 0, 0, 0])), ['type', 'seq', 't', 'pos', 'quat']);
    assert.deepStrictEqual(Object.keys(P.input('r', 'down')), ['type', 'key', 'action']);
    assert.deepStrictEqual(Object.keys(P.input('tap_angle', 'press', -30)), ['type', 'key', 'action', 'value']);
  });
  test('hello carries the access token only when given, bounded', () => {
    assert.ok(!('token' in P.hello('observer', 'x')));
    assert.ok(!('token' in P.hello('observer', 'x', null)));
    assert.equal(P.hello('operator', 'x', 'tok_-1').token, 'tok_-1');
    assert.equal(P.hello('operator', 'x', 't'.repeat(P.MAX_TOKEN)).token.length, P.MAX_TOKEN);
    assert.throws(() => P.hello('operator', 'x', 't'.repeat(P.MAX_TOKEN + 1)), { code: 'bad_message' });
    assert.throws(() => P.hello('operator', 'x', ''), { code: 'bad_message' });
    assert.throws(() => P.hello('operator', 'x', 42), { code: 'bad_message' });
  });
  test('input value: number, bool or string when given, omitted otherwise', () => {
    assert.ok(!('value' in P.input('release', 'press')));
    assert.ok(!('value' in P.input('release', 'press', null)));
    assert.equal(P.input('scale', 'press', false).value, false);
    assert.equal(P.input('note', 'press', 'x'.repeat(200)).value.length, 200);
    assert.equal(P.input('tap_angle', 'press', 12.5).value, 12.5);
    // {type, key, action, value: -30}: -30 is a negative fixint (0xe2)
    assert.ok(hex(P.encode(P.input('tap_angle', 'press', -30))).endsWith('a576616c7565' + 'e2'));
    assert.throws(() => P.input('tap_angle', 'press', NaN), { code: 'non_finite' });
    assert.throws(() => P.input('tap_angle', 'press', { a: 1 }), { code: 'bad_message' });
    assert.throws(() => P.input('tap_angle', 'press', [1]), { code: 'bad_message' });
    assert.throws(() => P.input('note', 'press', 'x'.repeat(201)), { code: 'bad_message' });
  });
  test('quat is omitted when absent; typed arrays become plain arrays', () => {
    const m = P.tracker(1, 2, new Float64Array([0.5, 1, 2]));
    assert.ok(!('quat' in m));
    assert.deepStrictEqual(m.pos, [0.5, 1, 2]);
  });
  test('rejects bad arguments with protocol codes', () => {
    assert.throws(() => P.hello('admin', 'x'), { code: 'bad_message' });
    assert.throws(() => P.hello('participant', 'x'.repeat(65)), { code: 'bad_message' });
    assert.throws(() => P.tracker(-1, 0, [0, 0, 0]), { code: 'bad_message' });
    assert.throws(() => P.tracker(1.5, 0, [0, 0, 0]), { code: 'bad_message' });
    assert.throws(() => P.tracker(1, 0, [0, 0]), { code: 'bad_message' });
    assert.throws(() => P.tracker(1, 0, [0, NaN, 0]), { code: 'non_finite' });
    assert.throws(() => P.tracker(1, Infinity, [0, 0, 0]), { code: 'non_finite' });
    assert.throws(() => P.input('x'.repeat(33), 'down'), { code: 'bad_message' });
    assert.throws(() => P.input('r', 'hold'), { code: 'bad_message' });
    assert.throws(() => P.encode({ type: 'tracker', pos: [Infinity, 0, 0] }), { code: 'non_finite' });
  });
});

describe('decode and validate', () => {
  const state = {
    type: 'state', frame: 1, tick: 17, t: 0.017, scene: 'ab', hip: [0, 0, 1], proxy: [0, 0, 1],
    force: [0, 0, 0], contact: false, contacts: [['hemi', [0, 0, 1], 0.001]], objects: [],
    cues: [{ kind: 'tilt', direction_deg: 90, magnitude_pct: 100 }], hud: '', values: { angle_deg: -12.5 },
    telemetry: { period_p99_us: 1040 },
  };
  test('a complete state is valid, extra fields are ignored', () => {
    assert.equal(P.validate(state), null);
    assert.equal(P.validate({ ...state, future_field: 1 }), null);
  });
  test('visible and events are optional; when present they are checked', () => {
    const withBoth = { ...state, visible: { angle_scale: false, dome: true }, events: [{ tick: 3, t: 0.003, name: 'tap' }] };
    assert.equal(P.validate(withBoth), null);
    assert.match(P.validate({ ...state, visible: { angle_scale: 0 } }).message, /state\.visible/);
    assert.match(P.validate({ ...state, visible: [] }).message, /state\.visible/);
    assert.match(P.validate({ ...state, events: [1] }).message, /state\.events/);
    assert.match(P.validate({ type: 'input', key: 'k', action: 'press', value: { a: 1 } }).message, /input\.value/);
  });
  test('clear errors name the field', () => {
    const { hip, ...noHip } = state;
    assert.match(P.validate(noHip).message, /state\.hip is missing/);
    const e = P.validate({ ...state, proxy: [0, 0] });
    assert.equal(e.code, 'bad_message');
    assert.match(e.message, /state\.proxy must be \[x, y, z\]/);
    assert.equal(P.validate({ ...state, contact: 1 }).code, 'bad_message');
    assert.equal(P.validate({ ...state, t: NaN }).code, 'non_finite');
    assert.equal(P.validate({ type: 'nope' }).code, 'unknown_type');
    assert.equal(P.validate([1, 2]).code, 'bad_message');
    assert.equal(P.validate({ type: 3 }).code, 'bad_message');
  });
  test('frames of the wrong format are bad_encoding', () => {
    assert.throws(() => P.decode('{"type":"state"}', 'msgpack'), { code: 'bad_encoding' });
    assert.throws(() => P.decode(new Uint8Array([0xc1]), 'msgpack'), { code: 'bad_encoding' });
    assert.throws(() => P.decode('{nope', 'json'), { code: 'bad_encoding' });
    assert.throws(() => P.decode(P.encode({ type: 'x' }, 'msgpack'), 'json'), { code: 'bad_encoding' });
    assert.throws(() => P.decode(P.encode([1]), 'msgpack'), { code: 'bad_message' });
    assert.throws(() => P.decode('[1]', 'json'), { code: 'bad_message' });
  });
  test('parse never throws', () => {
    assert.equal(P.parse('garbage', 'json').error.code, 'bad_encoding');
    assert.equal(P.parse(P.encode(state), 'msgpack').error, undefined);
    assert.deepStrictEqual(P.parse(P.encode(state), 'msgpack').msg, state);
  });
  test('scene validation', () => {
    const scene = {
      camera: { projection: 'orthographic', position: [5, 0, 0.35], target: [0, 0, 0.35], up: [0, 0, 1], height: 1.6 },
      hip: { radius: 0.06, proxy_radius: 0.06, color: '#ffd400' },
      objects: [
        { id: 'ground', shape: { type: 'plane', size: [3, 3] }, pose: { pos: [0, 0, 0], quat: [1, 0, 0, 0] } },
        { id: 'dome', shape: { type: 'hemisphere', radius: 0.6 } },
        { id: 'future', shape: { type: 'torus', r: 1 } },
      ],
      hud: { text: '' },
    };
    const msg = { type: 'scene', v: 1, hash: 'ab', scene };
    assert.equal(P.validate(msg), null);
    const bad = structuredClone(msg);
    bad.scene.objects[1].shape.radius = -1;
    assert.match(P.validate(bad).message, /objects\[1\]\.shape\.radius/);
    const dup = structuredClone(msg);
    dup.scene.objects[1].id = 'ground';
    assert.match(P.validate(dup).message, /not unique/);
    const cam = structuredClone(msg);
    cam.scene.camera.projection = 'fisheye';
    assert.match(P.validate(cam).message, /camera\.projection/);
    // A bad mesh costs only its own object (the view skips it), not the whole scene.
    const mesh = structuredClone(msg);
    mesh.scene.objects.push({ id: 'tube', shape: { type: 'mesh', vertices: [[0, 0, 0]], faces: [[0, 1, 2]] }, haptic: false });
    assert.equal(P.validate(mesh), null);
  });
  test('scene overlays and skins', () => {
    const scene = {
      camera: { projection: 'orthographic', position: [5, 0, 0.35], target: [0, 0, 0.35], up: [0, 0, 1], height: 1.6 },
      objects: [{ id: 'plane', shape: { type: 'plane', size: [3, 3] },
        material: { color: '#b89f7a', skin: { image: '/skins/stripes.svg', tile: [0.5, 0.25] } } }],
      overlays: [
        { id: 'angle_scale', kind: 'angle_scale', centre: [0, 0, 0], radius: 0.62 },
        { id: 'name', kind: 'label', pos: [0, -1, 1], text: '1 (softest)', size: 0.12, color: '#1b1b1b', visible: false },
        { id: 'future', kind: 'hologram', beam: 3 },
      ],
    };
    const msg = { type: 'scene', v: 1, hash: 'ab', scene };
    assert.equal(P.validate(msg), null);
    const cases = [
      [(s) => { s.overlays = {}; }, /overlays must be an array/],
      [(s) => { s.overlays[0].id = 'plane'; }, /overlays\[0\]\.id "plane" is not unique/],
      [(s) => { delete s.overlays[0].radius; }, /overlays\[0\]\.radius must be a number > 0/],
      [(s) => { s.overlays[0].to_deg = -90; }, /to_deg must be greater than from_deg/],
      [(s) => { s.overlays[1].text = 5; }, /overlays\[1\]\.text must be a string/],
      [(s) => { s.overlays[1].color = 'red'; }, /overlays\[1\]\.color/],
      [(s) => { s.overlays[1].visible = 'no'; }, /overlays\[1\]\.visible must be a bool/],
      [(s) => { delete s.overlays[2].kind; }, /overlays\[2\]\.kind must be a string/],
      [(s) => { s.objects[0].material.skin.tile = [0.5, 0]; }, /skin tile must be 2 numbers > 0/],
      [(s) => { s.objects[0].material.skin = { tile: [1, 1] }; }, /skin image/],
    ];
    for (const [breakIt, message] of cases) {
      const bad = structuredClone(msg);
      breakIt(bad.scene);
      const e = P.validate(bad);
      assert.ok(e, `expected an error matching ${message}`);
      assert.match(e.message, message);
    }
  });
});

describe('frames', () => {
  test('three ↔ scene are inverse permutations', () => {
    const p = [0.1, -2, 3.5];
    assert.deepStrictEqual(P.sceneToThree(p), [-2, 3.5, 0.1]);
    assert.deepStrictEqual(P.threeToScene(P.sceneToThree(p)), p);
    const q = [0.5, 0.1, 0.2, 0.3];
    assert.deepStrictEqual(P.quatSceneToThree(q), [0.5, 0.2, 0.3, 0.1]);
    assert.deepStrictEqual(P.quatThreeToScene(P.quatSceneToThree(q)), q);
  });
});

describe('shared invalid frames (tests/vectors/invalid.json): the client classifies them as the server does', () => {
  const file = loadVectors('invalid.json');
  for (const f of file.frames) {
    test(`${f.name} → ${f.code}`, () => {
      const { error } = P.parse(unhex(f.msgpack_hex), 'msgpack');
      assert.ok(error, 'expected an error');
      assert.equal(error.code, f.code, error.message);
    });
  }
});

// ---------------------------------------------------------------------------------------------
// Protocol v1.1: the declaration (schema.js, generated from server/wire/schema.py), both
// encodings of every vector, frames receivers accept or refuse, and the scene hash.

const messageFile = loadVectors('messages.json');
const invalidFile = loadVectors('invalid.json');

describe('the declaration drives the checks (src/schema.js)', () => {
  test('every message type is declared and has vectors of its direction', () => {
    assert.deepStrictEqual([...P.MESSAGE_TYPES], ['hello', 'tracker', 'input', 'answer', 'actuators', 'welcome', 'scene', 'state', 'error', 'health', 'lease', 'ask']);
    for (const m of P.SCHEMA.messages) {
      const vectors = messageFile.vectors.filter((v) => v.type === m.name);
      assert.ok(vectors.length > 0, `no vector for ${m.name}`);
      vectors.forEach((v) => assert.equal(v.direction, m.direction, v.name));
      for (const f of m.fields) assert.ok(vectors.some((v) => f.name in v.message), `no vector has ${m.name}.${f.name}`);
    }
    assert.equal(P.PROTOCOL_MINOR, 6);  // v1.6 (was 5)
  });
  test('constants come from the declaration', () => {
    assert.deepStrictEqual([...P.ROLES], ['participant', 'operator', 'observer']);
    assert.equal(P.MAX_CLIENT_NAME, 64);
    assert.equal(P.MAX_INPUT_TEXT, 200);
    assert.ok(P.ERROR_CODES.includes('unsupported_version'));
    assert.ok(Object.isFrozen(P.SCHEMA.messages[0].fields[0].type));
  });
  test('integer fields: integral values within 2^53, as the server', () => {
    const t = { kind: 'int', min: 0, doc: 'int ≥ 0' };
    assert.ok(P.fits(3, t) && P.fits(Number.MAX_SAFE_INTEGER, t));
    assert.ok(!P.fits(2.5, t) && !P.fits(2 ** 53, t) && !P.fits(-1, t) && !P.fits(true, t) && !P.fits('3', t));
  });
  test('tracker quaternions: norm in [0.5, 2], else bad_message', () => {
    assert.deepStrictEqual(P.tracker(1, 0, [0, 0, 0], [0, 0, 0, 2]).quat, [0, 0, 0, 2]);
    assert.throws(() => P.tracker(1, 0, [0, 0, 0], [0, 0, 0, 0]), { code: 'bad_message' });
    assert.throws(() => P.tracker(1, 0, [0, 0, 0], [0, 0, 3, 0]), { code: 'bad_message' });
    assert.throws(() => P.hello('observer', '😀'.repeat(65)), { code: 'bad_message' });
    assert.equal(P.hello('observer', '😀'.repeat(64)).client.length, 128); // 64 code points
  });
  test('v1.1 state fields are checked when present', () => {
    const state = messageFile.vectors.find((v) => v.name === 'state-in-contact').message;
    assert.equal(P.validate(state), null);
    assert.match(P.validate({ ...state, driver: [7] }).message, /state\.driver/);
    assert.match(P.validate({ ...state, stiffness: { dome: -1 } }).message, /state\.stiffness/);
    assert.match(P.validate({ ...state, haptic: { dome: 1 } }).message, /state\.haptic/);
    assert.match(P.validate({ ...state, scales: { dome: [1, 1] } }).message, /state\.scales/);
    assert.equal(P.validate({ ...state, driver: null }), null);
    assert.equal(P.validate({ ...state, driver: ['udp:127.0.0.1:9', 0] }), null);
  });
});

describe('both encodings of every vector (tests/vectors/messages.json)', () => {
  for (const v of messageFile.vectors) {
    test(`${v.name}: the JSON text decodes to the message and the encoder writes it`, () => {
      assert.deepStrictEqual(P.decode(v.json, 'json'), v.message);
      assert.equal(P.encode(v.message, 'json'), v.json);
    });
  }
});

const close = (got, want) => {
  if (typeof want === 'number') return typeof got === 'number' && Math.abs(got - want) <= 1e-12;
  if (Array.isArray(want)) return Array.isArray(got) && got.length === want.length && want.every((w, i) => close(got[i], w));
  return got === want;
};

describe('frames receivers accept although no canonical encoder writes them (messages.json "received")', () => {
  for (const r of messageFile.received) {
    test(`${r.name}: valid in both encodings, understood as expected`, () => {
      for (const msg of [P.decode(unhex(r.msgpack_hex), 'msgpack'), P.decode(r.json, 'json')]) {
        assert.equal(P.validate(msg), null);
        const declared = P.SCHEMA.messages.find((m) => m.name === r.type);
        for (const { name, type, default: absent } of declared.fields) {
          if (!(name in r.expect)) continue;
          let got = msg[name] ?? absent; // an absent or null optional field is its declared default
          if (type.kind === 'quat') got = got.map((c) => c / Math.hypot(...got)); // what the server does
          assert.ok(close(got, r.expect[name]) || JSON.stringify(got) === JSON.stringify(r.expect[name]),
            `${r.name}.${name}: ${JSON.stringify(got)} vs ${JSON.stringify(r.expect[name])}`);
        }
      }
    });
  }
});

describe('refused frames (tests/vectors/invalid.json), both encodings and both directions', () => {
  for (const f of [...invalidFile.frames, ...invalidFile.server_frames]) {
    test(`${f.name} → ${f.code}`, () => {
      const encodings = [['msgpack', unhex(f.msgpack_hex)]];
      if (f.json !== null) encodings.push(['json', f.json]);
      for (const [format, data] of encodings) {
        const { error } = P.parse(data, format);
        assert.ok(error, `${format}: expected an error`);
        assert.equal(error.code, f.code, `${format}: ${error.message}`);
      }
    });
  }
});

describe('scene hash (tests/vectors/scene_hash.json, docs/protocol.md "Scene hash")', () => {
  const sceneHash = (scene) => createHash('sha256').update(P.canonicalJson(scene), 'utf8').digest('hex').slice(0, 16);
  const file = loadVectors('scene_hash.json');
  for (const c of file.cases) {
    test(`${c.name}: canonical text and hash`, () => {
      assert.equal(P.canonicalJson(c.value), c.canonical);
      assert.equal(sceneHash(c.value), c.hash);
    });
  }
  test('numbers are spelt as RFC 8785 says', () => {
    for (const { bits, canonical } of file.numbers) {
      const view = new DataView(new ArrayBuffer(8));
      view.setBigUint64(0, BigInt(`0x${bits}`));
      assert.equal(P.canonicalJson(view.getFloat64(0)), canonical, bits);
    }
  });
  test('every scene message carries the hash of its scene, in both encodings', () => {
    for (const v of messageFile.vectors.filter((x) => x.type === 'scene')) {
      assert.equal(sceneHash(P.decode(unhex(v.msgpack_hex), 'msgpack').scene), v.message.hash, v.name);
      assert.equal(sceneHash(P.decode(v.json, 'json').scene), v.message.hash, v.name);
    }
  });
});
