// ViESTac wire protocol v1.3: pure codec, message builders, validation and frame conversions.
// No DOM, no WebSocket, no clock: everything here is a function of its arguments, so the same
// module runs in the browser and under `node --test` against tests/vectors/ (docs/protocol.md).
// Every message is declared once, on the server (server/wire/schema.py); schema.js is generated
// from that declaration and this module checks messages against it.

import { encode as msgpackEncode, decode as msgpackDecode } from '@msgpack/msgpack';
import { SCHEMA as DECLARED } from './schema.js';

function deepFreeze(value) {
  if (value !== null && typeof value === 'object') {
    Object.values(value).forEach(deepFreeze);
    Object.freeze(value);
  }
  return value;
}

/** The declaration: {protocol: {v, minor, scene_format}, messages: [{name, direction, fields}], error_codes}. */
export const SCHEMA = deepFreeze(DECLARED);
const DECLARATIONS = Object.fromEntries(SCHEMA.messages.map((m) => [m.name, m]));
const declaredType = (message, field) => DECLARATIONS[message].fields.find((f) => f.name === field).type;
const declares = (message, field) => DECLARATIONS[message]?.fields.some((f) => f.name === field) ?? false;

export const PROTOCOL_VERSION = SCHEMA.protocol.v;
export const PROTOCOL_MINOR = SCHEMA.protocol.minor;
export const SCENE_FORMAT_VERSION = SCHEMA.protocol.scene_format;
export const SUBPROTOCOLS = Object.freeze({ msgpack: 'viestac.v1.msgpack', json: 'viestac.v1.json' });
export const FORMATS = declaredType('welcome', 'format').values;
export const ROLES = declaredType('hello', 'role').values;
export const INPUT_ACTIONS = declaredType('input', 'action').values;
export const MAX_CLIENT_NAME = declaredType('hello', 'client').max_len;
// longest `hello.token` (protocol v1.3; the bound the server enforces)
export const MAX_TOKEN = declares('hello', 'token') ? declaredType('hello', 'token').max_len : 200;
export const MAX_KEY_NAME = declaredType('input', 'key').max_len;
// longest string `input.value`
export const MAX_INPUT_TEXT = declaredType('input', 'value').types.find((t) => t.kind === 'string').max_len;
export const ERROR_CODES = SCHEMA.error_codes;
export const MESSAGE_TYPES = Object.freeze(Object.keys(DECLARATIONS));
export const SHAPE_TYPES = Object.freeze(['sphere', 'box', 'cylinder', 'cone', 'plane', 'hemisphere', 'mesh']);
export const MAX_MESH_VERTICES = 20000;
export const MAX_MESH_FACES = 40000;

/** A problem with a frame or a message. `code` uses the protocol's error codes. */
export class ProtocolError extends Error {
  constructor(code, message) {
    super(message);
    this.name = 'ProtocolError';
    this.code = code;
  }
}

// ---------------------------------------------------------------------------------------------
// Encoding

const textDecoder = new TextDecoder('utf-8', { fatal: true });

/** Throws ProtocolError('non_finite') if any number in `value` is NaN or ±Infinity. */
function assertFinite(value, path = 'message') {
  if (typeof value === 'number') {
    if (!Number.isFinite(value)) throw new ProtocolError('non_finite', `${path} is ${value}`);
  } else if (Array.isArray(value)) {
    value.forEach((v, i) => assertFinite(v, `${path}[${i}]`));
  } else if (value !== null && typeof value === 'object' && !(value instanceof Uint8Array)) {
    for (const [k, v] of Object.entries(value)) assertFinite(v, `${path}.${k}`);
  }
}

/**
 * Encode one message. "msgpack" → Uint8Array (one msgpack map), "json" → string.
 * Field order is the object's insertion order; integral numbers are written as ints
 * (msgpack's smallest int form), the protocol's canonical rule.
 */
export function encode(msg, format = 'msgpack') {
  if (msg === null || typeof msg !== 'object' || Array.isArray(msg)) {
    throw new ProtocolError('bad_message', 'a message must be a map');
  }
  if (typeof msg.type !== 'string') throw new ProtocolError('bad_message', 'a message needs a string "type"');
  assertFinite(msg);
  if (format === 'msgpack') return msgpackEncode(msg);
  if (format === 'json') return JSON.stringify(msg);
  throw new ProtocolError('bad_encoding', `unknown format ${JSON.stringify(format)}`);
}

function toBytes(data) {
  if (data instanceof Uint8Array) return data;
  if (data instanceof ArrayBuffer) return new Uint8Array(data);
  if (ArrayBuffer.isView(data)) return new Uint8Array(data.buffer, data.byteOffset, data.byteLength);
  return null;
}

/**
 * Decode one frame into a message map. Throws ProtocolError('bad_encoding') when the frame is
 * not of the connection's format (binary msgpack vs text JSON) or does not parse, and
 * ProtocolError('bad_message') when it is not a map with a string `type`.
 */
export function decode(data, format = 'msgpack') {
  let msg;
  if (format === 'msgpack') {
    const bytes = toBytes(data);
    if (bytes === null) throw new ProtocolError('bad_encoding', 'expected a binary msgpack frame, got text');
    try {
      msg = msgpackDecode(bytes);
    } catch (err) {
      throw new ProtocolError('bad_encoding', `not msgpack: ${err.message}`);
    }
  } else if (format === 'json') {
    let text = data;
    if (typeof text !== 'string') {
      const bytes = toBytes(data);
      if (bytes === null) throw new ProtocolError('bad_encoding', 'expected a text JSON frame');
      try {
        text = textDecoder.decode(bytes);
      } catch {
        throw new ProtocolError('bad_encoding', 'JSON frame is not UTF-8');
      }
    }
    try {
      msg = JSON.parse(text);
    } catch (err) {
      throw new ProtocolError('bad_encoding', `not JSON: ${err.message}`);
    }
  } else {
    throw new ProtocolError('bad_encoding', `unknown format ${JSON.stringify(format)}`);
  }
  if (msg === null || typeof msg !== 'object' || Array.isArray(msg) || msg instanceof Uint8Array) {
    throw new ProtocolError('bad_message', 'a message must be a map');
  }
  if (typeof msg.type !== 'string') throw new ProtocolError('bad_message', 'a message needs a string "type"');
  return msg;
}

// ---------------------------------------------------------------------------------------------
// Builders (client → server). Field order is the declared order (docs/protocol.md).

function vec(v, n, what) {
  if (v == null || typeof v[Symbol.iterator] !== 'function') {
    throw new ProtocolError('bad_message', `${what} must be an array of ${n} numbers`);
  }
  const out = Array.from(v, Number);
  if (out.length !== n) throw new ProtocolError('bad_message', `${what} must have ${n} numbers, has ${out.length}`);
  out.forEach((x, i) => {
    if (!Number.isFinite(x)) throw new ProtocolError('non_finite', `${what}[${i}] is ${x}`);
  });
  return out;
}

/** Throws ProtocolError('bad_message') unless `value` fits the declared type of `message.field`. */
function checked(message, field, value) {
  const type = declaredType(message, field);
  if (!fits(value, type)) {
    throw new ProtocolError('bad_message', `${field} must be ${plain(type.doc)}, got ${describe(value)}`);
  }
  return value;
}

/**
 * `hello`: the first message of a connection. `token` (the page's access token, docs/security.md)
 * is sent only when given; it never goes into a URL.
 */
export function hello(role = 'participant', client = 'viestac-web/0.1', token = null) {
  const msg = {
    type: 'hello', v: PROTOCOL_VERSION, role: checked('hello', 'role', role), client: checked('hello', 'client', client),
  };
  if (token != null) {
    if (typeof token !== 'string' || !token || token.length > MAX_TOKEN) {
      throw new ProtocolError('bad_message', `token must be a string of 1 to ${MAX_TOKEN} characters`);
    }
    msg.token = token;
  }
  return msg;
}

/**
 * `tracker`: one HIP sample, scene frame. `quat` ([w,x,y,z], norm in [0.5, 2]; the server
 * normalises it) is optional and omitted when null. v1.4: `point` (the point `pos` is, e.g.
 * 'right.thumb.tip'), `points` (more points of the sample: name → [x,y,z]) and `ttl` (ms the
 * sample is good for), each sent only when given.
 */
export function tracker(seq, tMs, pos, quat = null, { point = null, points = null, ttl = null } = {}) {
  checked('tracker', 'seq', seq);
  if (typeof tMs !== 'number' || !Number.isFinite(tMs)) throw new ProtocolError('non_finite', 't must be a finite number');
  const msg = { type: 'tracker', seq, t: tMs, pos: vec(pos, 3, 'pos') };
  if (quat != null) msg.quat = checked('tracker', 'quat', vec(quat, 4, 'quat'));
  if (point != null) msg.point = checked('tracker', 'point', point);
  if (points != null) {
    msg.points = checked('tracker', 'points',
      Object.fromEntries(Object.entries(points).map(([name, p]) => [name, vec(p, 3, `points.${name}`)])));
  }
  if (ttl != null) msg.ttl = checked('tracker', 'ttl', ttl);
  return msg;
}

/**
 * `input`: a key (DOM KeyboardEvent.key) or command name going down/up or pressed. `value` (a
 * number, boolean or string: a command's argument) is sent only when given (not undefined/null).
 */
export function input(key, action, value = undefined) {
  const msg = { type: 'input', key: checked('input', 'key', key), action: checked('input', 'action', action) };
  if (value == null) return msg;
  if (typeof value === 'number' && !Number.isFinite(value)) throw new ProtocolError('non_finite', `value is ${value}`);
  msg.value = checked('input', 'value', value);
  return msg;
}

/** v1.5: a participant's answer to a question of its session's running trial (`ask`). */
export function answer(seq, question, value) {
  if (typeof value === 'number' && !Number.isFinite(value)) throw new ProtocolError('non_finite', `value is ${value}`);
  return { type: 'answer', seq: checked('answer', 'seq', seq), question: checked('answer', 'question', question),
    value: checked('answer', 'value', value) };
}

/** v1.6: the actuators a page can drive, `[[kind, hand], ...]`; `[]` with a `note` saying why none. */
export function actuators(list, note = '') {
  const msg = { type: 'actuators', actuators: checked('actuators', 'actuators', list) };
  if (note) msg.note = checked('actuators', 'note', note);
  return msg;
}

// ---------------------------------------------------------------------------------------------
// Validation against the declaration. Fields not declared are ignored (minor protocol
// additions); an optional field may be absent or null. The kinds are those of
// server/wire/schema.py, checked as server/wire/check.py does, so both answer with the same codes.

const isNum = (x) => typeof x === 'number' && Number.isFinite(x);
const isStr = (x) => typeof x === 'string';
const isBool = (x) => typeof x === 'boolean';
const isMap = (x) => x !== null && typeof x === 'object' && !Array.isArray(x) && !(x instanceof Uint8Array);
const isVec = (n) => (x) => Array.isArray(x) && x.length === n && x.every(isNum);
const isVec3 = isVec(3);
const isQuat = isVec(4);
const plain = (doc) => doc.replaceAll('`', '').replaceAll('\\|', '|');
const codePoints = (s) => [...s].length; // lengths are in Unicode code points, as in Python

function inBounds(x, t) {
  if (t.min !== undefined && (t.min_exclusive ? x <= t.min : x < t.min)) return false;
  return t.max === undefined || x <= t.max;
}

const KINDS = {
  int: (x, t) => Number.isSafeInteger(x) && inBounds(x, t),
  number: (x, t) => isNum(x) && inBounds(x, t),
  bool: (x) => isBool(x),
  null: (x) => x === null,
  string: (x, t) => isStr(x) && codePoints(x) >= (t.min_len ?? 0) && codePoints(x) <= (t.max_len ?? Infinity),
  enum: (x, t) => t.values.includes(x),
  const: (x, t) => x === t.value,
  vec: (x, t) => isVec(t.size)(x) && x.every((v) => inBounds(v, t)),
  quat: (x, t) => isQuat(x) && Math.hypot(...x) >= t.norm[0] && Math.hypot(...x) <= t.norm[1],
  array: (x, t) => Array.isArray(x) && x.every((item) => fits(item, t.items)),
  tuple: (x, t) => Array.isArray(x) && x.length === t.items.length && x.every((item, i) => fits(item, t.items[i])),
  map: (x, t) => isMap(x) && (t.keys === undefined || Object.keys(x).every((k) => fits(k, t.keys)))
    && (t.values === undefined || Object.values(x).every((v) => fits(v, t.values))),
  any_of: (x, t) => t.types.some((option) => fits(x, option)),
};

/**
 * A finite number beyond the protocol's bounds, as server/wire/check.py answers `out_of_range`:
 * an integral number outside ±(2^53 − 1) in an int field, or a number (a vector's component)
 * beyond the type's `max_abs` (a tracker position outside the workspace). Checked at the top level
 * of a field and in a map's values (`tracker.points`); a value of the wrong shape is left to `fits`
 * (bad_message).
 */
function outOfRange(x, t) {
  if (t.kind === 'int') return Number.isInteger(x) && !Number.isSafeInteger(x);
  if (t.kind === 'map' && t.values !== undefined) return isMap(x) && Object.values(x).some((v) => outOfRange(v, t.values));
  if (t.max_abs === undefined) return false;
  if (t.kind === 'number') return isNum(x) && Math.abs(x) > t.max_abs;
  if (t.kind === 'vec') return isVec(t.size)(x) && x.some((v) => Math.abs(v) > t.max_abs);
  return false;
}

/** Does `value` fit the declared type `type` (server/wire/schema.py)? */
export function fits(value, type) {
  const kind = KINDS[type.kind];
  if (!kind) throw new Error(`schema.js declares an unknown kind ${JSON.stringify(type.kind)}`);
  return kind(value, type);
}

/** Is there any NaN/Infinity inside? (msgpack can carry them; JSON cannot.) */
function findNonFinite(value, path) {
  if (typeof value === 'number') return Number.isFinite(value) ? null : path;
  if (Array.isArray(value)) {
    for (let i = 0; i < value.length; i++) {
      const p = findNonFinite(value[i], `${path}[${i}]`);
      if (p) return p;
    }
  } else if (isMap(value)) {
    for (const [k, v] of Object.entries(value)) {
      const p = findNonFinite(v, `${path}.${k}`);
      if (p) return p;
    }
  }
  return null;
}

/**
 * Check a decoded message against its declaration. Returns null when it is valid, otherwise a
 * ProtocolError (not thrown) whose message names the field and what was expected.
 * Unknown fields are ignored; an unknown `type` gives code 'unknown_type' (receivers may ignore
 * such messages: new message types are a minor protocol addition).
 */
export function validate(msg) {
  if (!isMap(msg)) return new ProtocolError('bad_message', 'a message must be a map');
  if (!isStr(msg.type)) return new ProtocolError('bad_message', 'a message needs a string "type"');
  const bad = findNonFinite(msg, msg.type);
  if (bad) return new ProtocolError('non_finite', `${bad} is not a finite number`);
  const declaration = DECLARATIONS[msg.type];
  if (!declaration) return new ProtocolError('unknown_type', `unknown message type ${JSON.stringify(msg.type)}`);
  for (const { name, type, required } of declaration.fields.slice(1)) {
    const value = msg[name];
    if (value === undefined || (value === null && !required)) {
      if (!required) continue;
      return new ProtocolError('bad_message', `${msg.type}.${name} is missing (expected ${plain(type.doc)})`);
    }
    if (outOfRange(value, type)) {
      return new ProtocolError('out_of_range', `${msg.type}.${name} is beyond the protocol's bounds, got ${describe(value)}`);
    }
    if (!fits(value, type)) {
      return new ProtocolError('bad_message', `${msg.type}.${name} must be ${plain(type.doc)}, got ${describe(value)}`);
    }
  }
  if (msg.type === 'scene') return validateScene(msg.scene, 'scene.scene');
  return null;
}

/**
 * RFC 8785 canonical JSON of a decoded value (keys sorted by UTF-16 code units, no whitespace,
 * JSON.stringify's numbers and strings). The scene hash is the first 16 hex digits of the
 * SHA-256 of the UTF-8 bytes of canonicalJson(scene) (docs/protocol.md, "Scene hash").
 */
export function canonicalJson(value) {
  if (Array.isArray(value)) return `[${value.map(canonicalJson).join(',')}]`;
  if (isMap(value)) {
    const keys = Object.keys(value).sort();
    return `{${keys.map((k) => `${JSON.stringify(k)}:${canonicalJson(value[k])}`).join(',')}}`;
  }
  if (typeof value === 'number' && !Number.isFinite(value)) {
    throw new ProtocolError('non_finite', `${value} has no JSON form`);
  }
  return JSON.stringify(value);
}

function describe(x) {
  let s;
  try {
    s = JSON.stringify(x);
  } catch {
    s = String(x);
  }
  if (s === undefined) s = String(x);
  return s.length > 60 ? `${s.slice(0, 57)}...` : s;
}

const SHAPE_FIELDS = {
  sphere: { radius: 'pos' },
  box: { size: 3 },
  cylinder: { radius: 'pos', height: 'pos' },
  cone: { radius: 'pos', height: 'pos' },
  plane: { size: 2 },
  hemisphere: { radius: 'pos' },
};

/**
 * Check a scene description (the `scene` field of a `scene` message). Returns null or a
 * ProtocolError. Shapes of a type this client does not know are allowed (a newer server may
 * add some); the view skips them.
 */
export function validateScene(scene, path = 'scene') {
  const err = (m) => new ProtocolError('bad_message', `${path}${m}`);
  if (!isMap(scene)) return err(' must be a map');
  const cam = scene.camera;
  if (!isMap(cam)) return err('.camera must be a map');
  for (const f of ['position', 'target', 'up']) {
    if (!isVec3(cam[f])) return err(`.camera.${f} must be [x, y, z]`);
  }
  if (cam.projection === 'orthographic') {
    if (!(isNum(cam.height) && cam.height > 0)) return err('.camera.height must be a number > 0');
  } else if (cam.projection === 'perspective') {
    if (!(isNum(cam.fov_deg) && cam.fov_deg > 0 && cam.fov_deg < 180)) return err('.camera.fov_deg must be in (0, 180)');
  } else {
    return err('.camera.projection must be "orthographic" or "perspective"');
  }
  if (scene.hip !== undefined) {
    if (!isMap(scene.hip)) return err('.hip must be a map');
    if (scene.hip.radius !== undefined && !(isNum(scene.hip.radius) && scene.hip.radius >= 0)) {
      return err('.hip.radius must be a number >= 0');
    }
    if (scene.hip.color !== undefined && !isStr(scene.hip.color)) return err('.hip.color must be a string');
  }
  if (!Array.isArray(scene.objects)) return err('.objects must be an array');
  const ids = new Set();
  for (let i = 0; i < scene.objects.length; i++) {
    const o = scene.objects[i];
    const p = `.objects[${i}]`;
    if (!isMap(o)) return err(`${p} must be a map`);
    if (!isStr(o.id) || o.id === '') return err(`${p}.id must be a non-empty string`);
    if (ids.has(o.id)) return err(`${p}.id ${JSON.stringify(o.id)} is not unique`);
    ids.add(o.id);
    if (!isMap(o.shape) || !isStr(o.shape.type)) return err(`${p}.shape.type must be a string`);
    const fields = SHAPE_FIELDS[o.shape.type];
    for (const [f, kind] of Object.entries(fields || {})) {
      const v = o.shape[f];
      if (kind === 'pos' && !(isNum(v) && v > 0)) return err(`${p}.shape.${f} must be a number > 0`);
      if (typeof kind === 'number' && !(isVec(kind)(v) && v.every((x) => x > 0))) {
        return err(`${p}.shape.${f} must be ${kind} numbers > 0`);
      }
    }
    if (o.pose !== undefined) {
      if (!isMap(o.pose) || !isVec3(o.pose.pos) || !isQuat(o.pose.quat)) {
        return err(`${p}.pose must be {pos: [x,y,z], quat: [w,x,y,z]}`);
      }
    }
    if (o.material !== undefined) {
      if (!isMap(o.material)) return err(`${p}.material must be a map`);
      const skinErr = checkSkin(o.material.skin);
      if (skinErr) return err(`${p}.material.skin ${skinErr}`);
    }
    if (o.visible !== undefined && !isBool(o.visible)) return err(`${p}.visible must be a bool`);
  }
  if (scene.overlays !== undefined) {
    if (!Array.isArray(scene.overlays)) return err('.overlays must be an array');
    for (let i = 0; i < scene.overlays.length; i++) {
      const o = scene.overlays[i];
      const p = `.overlays[${i}]`;
      if (!isMap(o)) return err(`${p} must be a map`);
      // Objects and overlays share one id space: state.visible names either.
      if (!isStr(o.id) || o.id === '') return err(`${p}.id must be a non-empty string`);
      if (ids.has(o.id)) return err(`${p}.id ${JSON.stringify(o.id)} is not unique`);
      ids.add(o.id);
      if (!isStr(o.kind)) return err(`${p}.kind must be a string`);
      if (o.visible !== undefined && !isBool(o.visible)) return err(`${p}.visible must be a bool`);
      const fieldErr = checkFields(o, OVERLAY_FIELDS[o.kind] ?? {});
      if (fieldErr) return err(`${p}.${fieldErr}`);
      if (o.kind === 'angle_scale' && (o.to_deg ?? 90) <= (o.from_deg ?? -90)) {
        return err(`${p}.to_deg must be greater than from_deg`);
      }
    }
  }
  return null;
}

const isPos = (x) => isNum(x) && x > 0;
const isColor = (x) => isStr(x) && /^#[0-9a-fA-F]{6}$/.test(x);

// Per overlay kind: field → [checker, expected, optional]. Kinds this client does not know are
// allowed (a newer server may add some); the view skips them.
const OVERLAY_FIELDS = {
  angle_scale: {
    centre: [isVec3, '[x, y, z]'],
    radius: [isPos, 'a number > 0'],
    from_deg: [isNum, 'a number', true],
    to_deg: [isNum, 'a number', true],
    minor_deg: [isPos, 'a number > 0', true],
    major_deg: [isPos, 'a number > 0', true],
    color: [isColor, '"#rrggbb"', true],
  },
  label: {
    pos: [isVec3, '[x, y, z]'],
    text: [isStr, 'a string'],
    size: [isPos, 'a number > 0', true],
    color: [isColor, '"#rrggbb"', true],
  },
};

/** The first field of `obj` that breaks `fields`, as "name must be ...", or null. */
function checkFields(obj, fields) {
  for (const [f, [fn, expected, optional]] of Object.entries(fields)) {
    if (obj[f] === undefined && optional) continue;
    if (!fn(obj[f])) return `${f} must be ${expected}`;
  }
  return null;
}

function checkSkin(skin) {
  if (skin === undefined || skin === null) return null;
  if (!isMap(skin)) return 'must be a map';
  if (!isStr(skin.image) || skin.image === '') return 'image must be a URL string';
  if (skin.tile !== undefined && !(isVec(2)(skin.tile) && skin.tile.every((t) => t > 0))) {
    return 'tile must be 2 numbers > 0';
  }
  return null;
}

/**
 * What is wrong with a `mesh` shape's data, as a sentence, or null. validateScene leaves meshes
 * alone so that one bad mesh costs only its own object: the view checks each one with this.
 */
export function checkMesh(shape) {
  const { vertices, faces } = shape;
  if (!Array.isArray(vertices) || vertices.length < 3 || vertices.length > MAX_MESH_VERTICES) {
    return `vertices must be an array of 3..${MAX_MESH_VERTICES} [x, y, z]`;
  }
  const badVertex = vertices.findIndex((v) => !isVec3(v));
  if (badVertex >= 0) return `vertices[${badVertex}] must be [x, y, z], got ${describe(vertices[badVertex])}`;
  if (!Array.isArray(faces) || faces.length < 1 || faces.length > MAX_MESH_FACES) {
    return `faces must be an array of 1..${MAX_MESH_FACES} [i, j, k]`;
  }
  const n = vertices.length;
  const badFace = faces.findIndex((f) => !(Array.isArray(f) && f.length === 3
    && f.every((i) => Number.isInteger(i) && i >= 0 && i < n)));
  if (badFace >= 0) {
    return `faces[${badFace}] must be 3 vertex indices in 0..${n - 1}, got ${describe(faces[badFace])}`;
  }
  return null;
}

/** Decode and validate: returns {msg} or {error: ProtocolError}; never throws. */
export function parse(data, format = 'msgpack') {
  let msg;
  try {
    msg = decode(data, format);
  } catch (e) {
    return { error: e instanceof ProtocolError ? e : new ProtocolError('bad_encoding', String(e)) };
  }
  const error = validate(msg);
  return error ? { msg, error } : { msg };
}

// ---------------------------------------------------------------------------------------------
// Frames. Scene (CHAI3D): x toward the viewer, y right, z up. three.js: X right, Y up, Z toward
// the viewer. A cyclic axis permutation, so handedness is kept and quaternions permute the same way.

/** Scene position [x, y, z] → three.js [X, Y, Z] = [y, z, x]. */
export function sceneToThree(p) {
  return [p[1], p[2], p[0]];
}

/** three.js position [X, Y, Z] → scene [x, y, z] = [Z, X, Y]. */
export function threeToScene(p) {
  return [p[2], p[0], p[1]];
}

/** Scene quaternion [w, x, y, z] → three.js [w, X, Y, Z] = [w, y, z, x]. */
export function quatSceneToThree(q) {
  return [q[0], q[2], q[3], q[1]];
}

/** three.js quaternion [w, X, Y, Z] → scene [w, x, y, z] = [w, Z, X, Y]. */
export function quatThreeToScene(q) {
  return [q[0], q[3], q[1], q[2]];
}
