// three.js view of a ViESTac scene: builds meshes and overlays from a `scene` message and applies
// `state` frames (every tool's HIP and proxy, the tracked hand, moved objects, visibility). It
// draws what the server says and decides nothing.
//
// Frames: the wire is in the scene frame (x toward the viewer, y right, z up); three.js is
// (X right, Y up, Z toward the viewer). Poses go through protocol.sceneToThree/quatSceneToThree.
// Because that conversion is a rotation, each shape's local axes map the same way: a shape's
// local +z (cylinder/cone axis, plane normal, dome) is three's local +Y, local x is +Z, y is +X.

import * as THREE from 'three';
import { sceneToThree, quatSceneToThree, SHAPE_TYPES, checkMesh } from './protocol.js';
import { buildOverlay } from './overlays.js';
import { makeMaterials, SkinLoader } from './skins.js';
import { Visibility } from './visibility.js';
import { ToolMarker, HandView, toolsOf, toolColor, PROXY_COLOR } from './tools_view.js';
import { PRIMARY_POINT } from './hand.js';

const SEGMENTS = 64;
const DEFAULT_HIP = { radius: 0.06, color: '#ffd400' };
const PROXY_SCALE = 0.5; // a point proxy (proxy_radius 0) is drawn at half the HIP radius
const HIP_RENDER_ORDER = 3; // after the overlays (overlays.RENDER_ORDER), which skip the depth test

/** Thickness of the slab drawn for a `plane` shape (its top face is at local z = 0). */
export function planeThickness(size) {
  return Math.min(0.05, 0.02 * Math.min(size[0], size[1]));
}

// Per dominant axis of a mesh face's scene normal: the scene axes its u and v run along. u takes
// the skin's tx period and v its ty, as on a box face (skins.BOX_FACE_AXES).
const MESH_UV_AXES = [[2, 1], [0, 2], [0, 1]];

/**
 * Geometry of a `mesh` shape (data already passed protocol.checkMesh) in three.js axes.
 * Non-indexed, so computeVertexNormals gives every triangle its own normal: flat shading keeps a
 * tube's edges hard. The scene → three axis permutation is a rotation, so the counter-clockwise
 * winding (outward normals) carries over. UVs are box-projected in scene units for skins.
 */
export function meshGeometry({ vertices, faces }) {
  const positions = new Float32Array(faces.length * 9);
  const uvs = new Float32Array(faces.length * 6);
  const e1 = new THREE.Vector3();
  const e2 = new THREE.Vector3();
  faces.forEach((face, k) => {
    const [a, b, c] = face.map((i) => vertices[i]);
    e1.set(b[0] - a[0], b[1] - a[1], b[2] - a[2]);
    e2.set(c[0] - a[0], c[1] - a[1], c[2] - a[2]);
    const n = e1.cross(e2).toArray().map(Math.abs);
    const [u, v] = MESH_UV_AXES[n.indexOf(Math.max(...n))];
    [a, b, c].forEach((p, j) => {
      positions.set(sceneToThree(p), k * 9 + j * 3);
      uvs.set([p[u], p[v]], k * 6 + j * 2);
    });
  });
  const g = new THREE.BufferGeometry();
  g.setAttribute('position', new THREE.BufferAttribute(positions, 3));
  g.setAttribute('uv', new THREE.BufferAttribute(uvs, 2));
  g.computeVertexNormals();
  return g;
}

/**
 * Mesh(es) for one shape, in the shape's local frame expressed in three.js axes.
 * Returns null for a shape type this client does not know (a newer server may send some).
 */
export function buildShape(shape, material) {
  switch (shape.type) {
    case 'sphere':
      return new THREE.Mesh(new THREE.SphereGeometry(shape.radius, SEGMENTS, SEGMENTS / 2), material);
    case 'box': {
      const [sx, sy, sz] = shape.size; // scene x,y,z → three Z,X,Y
      return new THREE.Mesh(new THREE.BoxGeometry(sy, sz, sx), material);
    }
    case 'cylinder': {
      const g = new THREE.CylinderGeometry(shape.radius, shape.radius, shape.height, SEGMENTS);
      g.translate(0, shape.height / 2, 0); // base disc at local z = 0
      return new THREE.Mesh(g, material);
    }
    case 'cone': {
      const g = new THREE.ConeGeometry(shape.radius, shape.height, SEGMENTS);
      g.translate(0, shape.height / 2, 0); // base at z = 0, apex at z = height
      return new THREE.Mesh(g, material);
    }
    case 'plane': {
      const [sx, sy] = shape.size;
      const t = planeThickness(shape.size);
      const g = new THREE.BoxGeometry(sy, t, sx);
      g.translate(0, -t / 2, 0); // top face at z = 0, solid below
      return new THREE.Mesh(g, material);
    }
    case 'hemisphere': {
      const group = new THREE.Group();
      const dome = new THREE.SphereGeometry(shape.radius, SEGMENTS, SEGMENTS / 2, 0, Math.PI * 2, 0, Math.PI / 2);
      const base = new THREE.CircleGeometry(shape.radius, SEGMENTS);
      base.rotateX(Math.PI / 2); // face down (-Y = scene -z)
      group.add(new THREE.Mesh(dome, material), new THREE.Mesh(base, material));
      return group;
    }
    case 'mesh':
      return new THREE.Mesh(meshGeometry(shape), material);
    default:
      return null;
  }
}

/** Free the GPU resources under `root`: geometries, materials (or arrays of them) and their maps. */
function disposeTree(root) {
  root.traverse((o) => {
    if (o.geometry && !o.isSprite) o.geometry.dispose(); // all sprites share three's one quad
    for (const m of [o.material ?? []].flat()) {
      if (m.map) m.map.dispose();
      m.dispose();
    }
  });
}

/**
 * A three.js camera from the scene's camera spec (scene frame) for a viewport aspect ratio.
 * Orthographic: `height` is the visible height, left/right follow the aspect.
 * Returns {camera, target} with target in three.js coordinates.
 */
export function makeCamera(cam, aspect) {
  const pos = new THREE.Vector3(...sceneToThree(cam.position));
  const target = new THREE.Vector3(...sceneToThree(cam.target));
  const dist = Math.max(pos.distanceTo(target), 1e-3);
  let camera;
  if (cam.projection === 'perspective') {
    camera = new THREE.PerspectiveCamera(cam.fov_deg, aspect, Math.min(0.01, dist / 100), dist * 100);
  } else {
    const h = cam.height / 2;
    camera = new THREE.OrthographicCamera(-h * aspect, h * aspect, h, -h, 0.01, dist * 20 + 10);
  }
  camera.up.set(...sceneToThree(cam.up));
  camera.position.copy(pos);
  camera.lookAt(target);
  camera.updateMatrixWorld();
  return { camera, target };
}

/**
 * Visible height of an orthographic view: the scene's `height`, grown when a viewport narrower
 * than the scene was laid out for would cut drawn things off at the sides. `halfWidth` is their
 * extent either side of the camera target, across the view.
 */
export function orthoHeight(height, aspect, halfWidth, margin = 1.05) {
  return Math.max(height, (2 * halfWidth * margin) / aspect);
}

/**
 * How far `objects` reach either side of the camera target, across the view (along the camera's
 * right axis), from their world bounding boxes.
 */
export function halfWidthAcross(objects, camera, target) {
  const right = new THREE.Vector3(1, 0, 0).applyQuaternion(camera.quaternion);
  const box = new THREE.Box3();
  const corner = new THREE.Vector3();
  let half = 0;
  for (const obj of objects) {
    obj.updateMatrixWorld(true);
    box.setFromObject(obj);
    if (box.isEmpty()) continue;
    for (let i = 0; i < 8; i++) {
      corner.set(i & 1 ? box.max.x : box.min.x, i & 2 ? box.max.y : box.min.y, i & 4 ? box.max.z : box.min.z);
      half = Math.max(half, Math.abs(corner.sub(target).dot(right)));
    }
  }
  return half;
}

function setPose(obj, pos, quat) {
  obj.position.fromArray(sceneToThree(pos));
  const [w, x, y, z] = quatSceneToThree(quat);
  obj.quaternion.set(x, y, z, w).normalize();
}

/**
 * The posed three.js object of one scene object, or null (with a console warning naming it) when
 * this client cannot draw it: an unknown shape type, or mesh data that does not hold together.
 */
export function buildObject(o, skins) {
  if (!SHAPE_TYPES.includes(o.shape.type)) {
    console.warn(`viestac: shape type ${o.shape.type} of ${o.id} is not supported; not drawn`);
    return null;
  }
  const problem = o.shape.type === 'mesh' ? checkMesh(o.shape) : null;
  if (problem) {
    console.warn(`viestac: mesh of ${o.id} is invalid (${problem}); not drawn`);
    return null;
  }
  const obj = buildShape(o.shape, makeMaterials(o.material, o.shape, skins));
  obj.name = o.id;
  const pose = o.pose ?? { pos: [0, 0, 0], quat: [1, 0, 0, 0] };
  setPose(obj, pose.pos, pose.quat);
  return obj;
}

export class SceneView {
  /** @param {HTMLCanvasElement} canvas */
  constructor(canvas) {
    this.canvas = canvas;
    this.renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(globalThis.devicePixelRatio || 1);
    this.renderer.setClearColor(new THREE.Color('#1e2228'));
    this.scene = new THREE.Scene();
    this.camera = new THREE.OrthographicCamera(-1, 1, 1, -1, 0.01, 100);
    this.cameraSpec = null;
    this.contentHalfWidth = 0; // see orthoHeight
    this.cameraTarget = new THREE.Vector3(); // three frame
    this.objects = new Map(); // id → {object3d, spec}
    this.overlays = new Map(); // id → {object3d, spec}
    this.visibility = new Visibility();
    this.skins = new SkinLoader();
    this.world = new THREE.Group(); // scene objects and overlays; rebuilt on each scene message
    this.hash = null;
    this.sceneSpec = null;
    this.built = false;

    // Lights: soft fill from above plus a key light from the viewer's upper right.
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x404040, 1.6));
    this.keyLight = new THREE.DirectionalLight(0xffffff, 2.0);
    this.scene.add(this.keyLight, this.keyLight.target);
    // Everything in scene coordinates hangs off `root`: identity on the desktop; in WebXR it
    // carries the placement (table height, origin, yaw, metres per scene unit: xr_placement.js).
    this.root = new THREE.Group();
    this.scene.add(this.root);
    this.root.add(this.world);

    // One marker (HIP, proxy) per tool, made when a state frame first names the tool; the
    // primary one always exists (`hip`/`proxy` of the scene graph).
    this.hipSpec = { ...DEFAULT_HIP };
    this.tools = new Map(); // name → ToolMarker
    this.toolOrder = []; // the last frame's tools, primary first
    this.hand = new HandView();
    this.root.add(this.hand.group);
    this._marker(PRIMARY_POINT);
    this.resize();
  }

  /** Build (or rebuild) everything from a `scene` message's `scene` map. */
  build(spec, hash = null) {
    for (const child of [...this.world.children]) {
      this.world.remove(child);
      disposeTree(child);
    }
    this.objects.clear();
    this.overlays.clear();
    this.visibility.clear();
    this.skins.cancel(); // images of the old scene still loading are dropped
    this.skins = new SkinLoader();
    this.sceneSpec = spec;
    this.hash = hash;

    for (const o of spec.objects) {
      const obj = buildObject(o, this.skins);
      if (obj === null) continue;
      this.world.add(obj);
      this.objects.set(o.id, { object3d: obj, spec: o });
      this.visibility.add(o.id, obj, o.visible !== false);
    }
    for (const o of spec.overlays ?? []) {
      const obj = buildOverlay(o);
      if (obj === null) {
        console.warn(`viestac: overlay kind ${o.kind} of ${o.id} is not supported; not drawn`);
        continue;
      }
      obj.name = o.id;
      this.world.add(obj);
      this.overlays.set(o.id, { object3d: obj, spec: o });
      this.visibility.add(o.id, obj, o.visible !== false);
    }

    this.hipSpec = { ...DEFAULT_HIP, ...(spec.hip ?? {}) };
    for (const marker of this.tools.values()) this._style(marker);
    this.hand.setRadius(this._hipRadius());

    this._setCamera(spec.camera);
    // Ground planes are meant to run off-screen; everything else should stay in view.
    const fitted = [...this.objects.values()].filter(({ spec: o }) => o.shape.type !== 'plane')
      .concat([...this.overlays.values()]).map((e) => e.object3d);
    this.contentHalfWidth = halfWidthAcross(fitted, this.camera, this.cameraTarget);
    this.built = true;
  }

  _hipRadius() {
    return this.hipSpec.radius > 0 ? this.hipSpec.radius : DEFAULT_HIP.radius;
  }

  /** Size and colour a tool marker from the scene's `hip` spec. The proxy is the centre of a
   * sphere of proxy_radius resting on the surface: drawn at that radius it touches the surface;
   * a point proxy gets a small marker. */
  _style(marker) {
    const r = this._hipRadius();
    const pr = this.hipSpec.proxy_radius > 0 ? this.hipSpec.proxy_radius : r * PROXY_SCALE;
    marker.style(r, pr, toolColor(marker.name, this.hipSpec.color));
  }

  /** The marker of tool `name`, made (and added to the scene) the first time. */
  _marker(name) {
    let marker = this.tools.get(name);
    if (!marker) {
      marker = new ToolMarker(name);
      marker.hip.renderOrder = HIP_RENDER_ORDER;
      marker.proxy.renderOrder = HIP_RENDER_ORDER;
      this._style(marker);
      this.root.add(marker.hip, marker.proxy);
      this.tools.set(name, marker);
    }
    return marker;
  }

  /** The primary tool's HIP and proxy meshes (the HIP of a one-finger rig). */
  get hip() {
    return this.tools.get(this.toolOrder[0] ?? PRIMARY_POINT).hip;
  }

  get proxy() {
    return this.tools.get(this.toolOrder[0] ?? PRIMARY_POINT).proxy;
  }

  _setCamera(cam) {
    this.cameraSpec = cam;
    const { camera, target } = makeCamera(cam, this._aspect());
    this.camera = camera;
    this.cameraTarget.copy(target);
    const pos = camera.position;
    // Key light from the viewer's upper right, whatever the camera direction.
    const right = new THREE.Vector3(1, 0, 0).applyQuaternion(this.camera.quaternion);
    const up = new THREE.Vector3(0, 1, 0).applyQuaternion(this.camera.quaternion);
    const back = pos.clone().sub(target).normalize();
    this.keyLight.position.copy(target).addScaledVector(back, 4).addScaledVector(right, 2.5).addScaledVector(up, 3);
    this.keyLight.target.position.copy(target);
    this.keyLight.target.updateMatrixWorld();
  }

  _aspect() {
    const w = this.canvas.clientWidth || this.canvas.width || 1;
    const h = this.canvas.clientHeight || this.canvas.height || 1;
    return w / h;
  }

  /** Match the drawing buffer to the canvas's CSS size and the camera to its aspect. */
  resize() {
    const w = Math.max(1, this.canvas.clientWidth);
    const h = Math.max(1, this.canvas.clientHeight);
    this.renderer.setSize(w, h, false);
    const aspect = w / h;
    if (this.camera.isOrthographicCamera) {
      const half = orthoHeight(this.cameraSpec?.height ?? 2, aspect, this.contentHalfWidth) / 2;
      this.camera.top = half;
      this.camera.bottom = -half;
      this.camera.left = -half * aspect;
      this.camera.right = half * aspect;
    } else {
      this.camera.aspect = aspect;
    }
    this.camera.updateProjectionMatrix();
  }

  /** Apply one `state` frame: every tool, the tracked hand, poses of moved objects, visibility
   * overrides. A tool the frame no longer lists is hidden (its marker is kept for when it returns). */
  applyState(state) {
    const tools = toolsOf(state);
    this.toolOrder = tools.map((t) => t.name);
    for (const tool of tools) this._marker(tool.name).update(tool);
    for (const [name, marker] of this.tools) {
      if (!this.toolOrder.includes(name)) marker.hip.visible = marker.proxy.visible = false;
    }
    this.hand.update(state.points ?? {}, tools);
    for (const [id, pos, quat] of state.objects ?? []) {
      const entry = this.objects.get(id);
      if (entry) setPose(entry.object3d, pos, quat);
    }
    this.visibility.apply(state.visible);
    this.applyScales(state.scales ?? {});
  }

  /** state.scales: the complete set of scaled objects (id → [sx, sy, sz], scene axes); an object
   * no longer listed is back at its scene size. */
  applyScales(scales) {
    for (const id of this.scaled ?? []) {
      if (!Object.hasOwn(scales, id)) this.objects.get(id)?.object3d.scale.set(1, 1, 1);
    }
    this.scaled = Object.keys(scales);
    for (const [id, s] of Object.entries(scales)) {
      this.objects.get(id)?.object3d.scale.fromArray(sceneToThree(s)); // a scale permutes like a position
    }
  }

  render() {
    this.renderer.render(this.scene, this.camera);
  }

  /**
   * Scene objects, overlays, HIP and proxy: {id, type, visible, position and scale (three), color, and
   * shape + skin (objects) | kind + labels [{text, position (three)}] (overlays, type "overlay") |
   * radius (HIP, proxy)}.
   */
  sceneGraph() {
    const out = [];
    for (const [id, { object3d, spec }] of this.objects) {
      out.push({
        id,
        type: spec.shape.type,
        visible: object3d.visible,
        position: object3d.position.toArray(),
        scale: object3d.scale.toArray(),
        color: spec.material?.color ?? null,
        shape: spec.shape,
        skin: spec.material?.skin?.image ?? null,
      });
    }
    for (const [id, { object3d, spec }] of this.overlays) {
      out.push({ id, type: 'overlay', kind: spec.kind, visible: object3d.visible,
        position: sceneToThree(spec.centre ?? spec.pos), color: spec.color ?? null, labels: object3d.userData.labels });
    }
    // The primary tool is `hip`/`proxy` (as before several tools); every other is `hip:NAME`/`proxy:NAME`.
    const order = this.toolOrder.length ? this.toolOrder : [PRIMARY_POINT]; // before the first state frame
    order.forEach((name, i) => {
      const m = this.tools.get(name);
      const suffix = i === 0 ? '' : `:${name}`;
      out.push({ id: `hip${suffix}`, type: 'hip', tool: name, visible: m.hip.visible, position: m.hip.position.toArray(),
        color: m.color, radius: m.hip.scale.x, contact: m.contact, lost: m.lost });
      out.push({ id: `proxy${suffix}`, type: 'proxy', tool: name, visible: m.proxy.visible,
        position: m.proxy.position.toArray(), color: PROXY_COLOR, radius: m.proxy.scale.x });
    });
    return out;
  }

  /** The tracked hand as drawn: {visible, joints: [name], bones: [[from, to]]}. */
  handGraph() {
    const { joints, bones } = this.hand.last;
    return { visible: joints.length > 0, joints: joints.map(([n]) => n), bones: bones.map(([a, b]) => [a, b]) };
  }

  /** CSS pixel position (relative to the viewport) of a scene-frame point. */
  screenPosition(scenePos) {
    const v = new THREE.Vector3(...sceneToThree(scenePos)).project(this.camera);
    const rect = this.canvas.getBoundingClientRect();
    return { x: rect.left + (v.x + 1) / 2 * rect.width, y: rect.top + (1 - v.y) / 2 * rect.height };
  }

  /** "vendor renderer" of the WebGL context, unmasked where the browser allows. */
  rendererInfo() {
    const gl = this.renderer.getContext();
    const ext = gl.getExtension('WEBGL_debug_renderer_info');
    const renderer = gl.getParameter(ext ? ext.UNMASKED_RENDERER_WEBGL : gl.RENDERER);
    const version = gl.getParameter(gl.VERSION);
    return `${renderer} | ${version}`;
  }
}
