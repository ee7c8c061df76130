// The scene's touchable primitives as the server sees them: exact signed distance, outward normal
// and closest surface point, the same formulas and tie-breaks as server/core/haptics/primitives.py
// (checked against its output: tests/vectors/surface_points.json). Used by the XR client to draw a
// fingertip on the surface in the frame that reads the pose, before the server's proxy comes back
// (docs/xr.md "Timing"). Pure; scene frame, scene units. Meshes are display only: never touched.

/** [x, y] → rho and the unit radial direction; on the axis the choice +x (as the server). */
function radial(x, y) {
  const rho = Math.sqrt(x * x + y * y);
  return rho > 0 ? [rho, x / rho, y / rho] : [0, 1, 0];
}

function boxEval(qx, qy, qz, x, y, z) {
  if (qx > 0 || qy > 0 || qz > 0) {
    const dx = qx > 0 ? qx : 0;
    const dy = qy > 0 ? qy : 0;
    const dz = qz > 0 ? qz : 0;
    const d = Math.sqrt(dx * dx + dy * dy + dz * dz);
    if (d > 0) return [d, (x >= 0 ? dx : -dx) / d, (y >= 0 ? dy : -dy) / d, (z >= 0 ? dz : -dz) / d];
  }
  if (qz >= qx && qz >= qy) return [qz, 0, 0, z >= 0 ? 1 : -1]; // ties prefer z, then x, then y
  if (qx >= qy) return [qx, x >= 0 ? 1 : -1, 0, 0];
  return [qy, 0, y >= 0 ? 1 : -1, 0];
}

const EVAL = {
  sphere({ radius }, x, y, z) {
    const r2 = x * x + y * y + z * z;
    if (r2 > 0) {
      const r = Math.sqrt(r2);
      return [r - radius, x / r, y / r, z / r];
    }
    return [-radius, 0, 0, 1];
  },
  box({ size }, x, y, z) {
    return boxEval(Math.abs(x) - 0.5 * size[0], Math.abs(y) - 0.5 * size[1], Math.abs(z) - 0.5 * size[2], x, y, z);
  },
  plane({ size }, x, y, z) {
    return boxEval(Math.abs(x) - 0.5 * size[0], Math.abs(y) - 0.5 * size[1], z, x, y, 1);
  },
  cylinder({ radius, height }, x, y, z) {
    const [rho, ux, uy] = radial(x, y);
    const hh = 0.5 * height;
    const u = rho - radius;
    const zc = z - hh;
    const sz = zc >= 0 ? 1 : -1;
    const w = sz * zc - hh;
    if (u > 0 || w > 0) {
      const du = u > 0 ? u : 0;
      const dw = w > 0 ? w : 0;
      const d = Math.sqrt(du * du + dw * dw);
      if (d > 0) {
        const g = du / d;
        return [d, g * ux, g * uy, (sz * dw) / d];
      }
    }
    return w >= u ? [w, 0, 0, sz] : [u, ux, uy, 0];
  },
  cone({ radius: R, height: H }, x, y, z) {
    const L = Math.hypot(R, H);
    const L2 = R * R + H * H;
    const nr = H / L;
    const nz = R / L;
    const [rho, ux, uy] = radial(x, y);
    const sLine = (H * rho + R * z - R * H) / L; // signed distance to the side line
    if (z >= 0 && sLine <= 0) {
      if (z <= -sLine) return [-z, 0, 0, -1];
      if (rho === 0 && z >= H) return [0, 0, 0, 1];
      return [sLine, nr * ux, nr * uy, nz];
    }
    if (z < 0 && rho <= R) return [-z, 0, 0, -1];
    const sn = (R - rho) * R + z * H;
    let dr;
    let dz;
    if (sn <= 0) { // rim
      dr = rho - R;
      dz = z;
    } else if (sn >= L2) { // apex
      dr = rho;
      dz = z - H;
    } else {
      return [sLine, nr * ux, nr * uy, nz];
    }
    const d = Math.sqrt(dr * dr + dz * dz);
    if (d > 0) return [d, (dr / d) * ux, (dr / d) * uy, dz / d];
    return [0, nr * ux, nr * uy, nz];
  },
  hemisphere({ radius: R }, x, y, z) {
    if (z < 0) {
      const rho2 = x * x + y * y;
      if (rho2 <= R * R) return [-z, 0, 0, -1];
      const rho = Math.sqrt(rho2);
      const dr = rho - R;
      const d = Math.sqrt(dr * dr + z * z);
      const g = dr / (d * rho);
      return [d, g * x, g * y, z / d];
    }
    const r = Math.sqrt(x * x + y * y + z * z);
    if (r > R || z > R - r) return [r - R, x / r, y / r, z / r];
    return [-z, 0, 0, -1];
  },
};

/** The shape types that are touched (docs/protocol.md "Scene format"; `mesh` is display only). */
export const PRIMITIVES = Object.keys(EVAL);

/** Row-major rotation of a unit quaternion [w, x, y, z], or null for the identity (as Pose). */
export function rotationOf(quat = [1, 0, 0, 0]) {
  let [w, x, y, z] = quat;
  const n = Math.hypot(w, x, y, z);
  if (Math.abs(n - 1) > 1e-12) [w, x, y, z] = [w / n, x / n, y / n, z / n];
  if (x === 0 && y === 0 && z === 0) return null;
  const k = 2 / (w * w + x * x + y * y + z * z);
  return [1 - k * (y * y + z * z), k * (x * y - w * z), k * (x * z + w * y),
    k * (x * y + w * z), 1 - k * (x * x + z * z), k * (y * z - w * x),
    k * (x * z - w * y), k * (y * z + w * x), 1 - k * (x * x + y * y)];
}

/** A touchable body: {id, shape, pos, m} (m: rotationOf(quat)); null for a shape that is not a primitive. */
export function body(id, shape, pose = {}) {
  if (!shape || !Object.hasOwn(EVAL, shape.type)) return null;
  return { id, shape, pos: pose.pos ?? [0, 0, 0], m: rotationOf(pose.quat) };
}

/** [sd, nx, ny, nz] of a body at scene point p: exact signed distance (< 0 inside) and the
 * outward normal, both in the scene frame. */
export function evalBody(b, p) {
  const x = p[0] - b.pos[0];
  const y = p[1] - b.pos[1];
  const z = p[2] - b.pos[2];
  const m = b.m;
  const ev = EVAL[b.shape.type];
  if (!m) return ev(b.shape, x, y, z);
  const [s, a, c, d] = ev(b.shape, m[0] * x + m[3] * y + m[6] * z, m[1] * x + m[4] * y + m[7] * z, m[2] * x + m[5] * y + m[8] * z);
  return [s, m[0] * a + m[1] * c + m[2] * d, m[3] * a + m[4] * c + m[5] * d, m[6] * a + m[7] * c + m[8] * d];
}

/** The closest point of the body's surface offset outward by `offset` (0: the surface itself):
 * p moved along the normal by offset − sd (exact SDF: the same point from inside and outside). */
export function closestPoint(b, p, offset = 0) {
  const [s, nx, ny, nz] = evalBody(b, p);
  const k = offset - s;
  return [p[0] + k * nx, p[1] + k * ny, p[2] + k * nz];
}

/**
 * The touchable bodies of a scene as a state frame leaves them: the scene's objects with
 * `haptic` true (state.haptic overrides it), primitives only, at their scene pose or the pose
 * state.objects gives (docs/protocol.md "What changes at run time"). state.scales is drawing only.
 */
export function touchableBodies(sceneSpec, state = {}) {
  const moved = new Map((state.objects ?? []).map(([id, pos, quat]) => [id, { pos, quat }]));
  const haptic = state.haptic ?? {};
  const out = [];
  for (const o of sceneSpec?.objects ?? []) {
    const touched = Object.hasOwn(haptic, o.id) ? haptic[o.id] : o.haptic !== false;
    if (!touched) continue;
    const b = body(o.id, o.shape, moved.get(o.id) ?? o.pose ?? {});
    if (b) out.push(b);
  }
  return out;
}

/**
 * Where a proxy of radius `radius` would rest for a tracked point `p` that is inside some body's
 * offset surface (sd < radius), or null when p is free: p pushed out of the deepest body onto
 * its offset surface, repeated (a few passes) when that lands inside another. A display-only
 * guess of the server's god-object (which also remembers where the finger came from and has
 * friction): the server's proxy replaces it when its state comes.
 * Returns {pos, id} (id: the body it rests on).
 */
export function predictProxy(bodies, p, radius = 0, passes = 4) {
  let q = p;
  let id = null;
  for (let i = 0; i < passes; i++) {
    let worst = null;
    for (const b of bodies) {
      const ev = evalBody(b, q);
      const pen = ev[0] - radius;
      if (pen < 0 && (!worst || pen < worst.pen)) worst = { b, ev, pen };
    }
    if (!worst) break;
    const [, nx, ny, nz] = worst.ev;
    q = [q[0] - worst.pen * nx, q[1] - worst.pen * ny, q[2] - worst.pen * nz];
    id = worst.b.id;
  }
  return id === null ? null : { pos: q, id };
}
