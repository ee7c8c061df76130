// Every tool of a state frame (a tracked finger: its HIP, its god-object proxy, contact, lost)
// and the tracked hand, as three.js objects. The view draws what the server says: which tools
// exist, where they are and whether they touch something all come from `state.tools`,
// `state.points` and `state.tracking` (docs/protocol.md).

import * as THREE from 'three';
import { sceneToThree } from './protocol.js';
import { PRIMARY_POINT, handFrame, toolColor } from './hand.js';

export { toolColor }; // the colour scheme lives with the names (hand.js), so the console shares it without three.js

export const FREE_PROXY_COLOR = '#8a8f98'; // a proxy apart from its HIP without (debounced) contact
export const LOST_OPACITY = 0.25; // a lost tool fades: it renders nothing until its source returns
export const PROXY_COLOR = '#ff2d55';
const SAME_POINT = 1e-6; // proxy within this distance of the HIP is hidden
const JOINT_RADIUS_SCALE = 0.35; // hand joints relative to the HIP radius
const BONE_RADIUS_SCALE = 0.18;
const HAND_COLOR = '#e0c8b0';

/**
 * The tools of a state frame, primary first: `state.tools` when the server sends it (protocol
 * v1.4), else the one primary tool from `hip`/`proxy`/`contact` (an older server).
 */
export function toolsOf(state) {
  if (Array.isArray(state.tools) && state.tools.length > 0) {
    return state.tools.map((t) => ({ name: t.name, hip: t.hip, proxy: t.proxy, contact: !!t.contact, lost: !!t.lost }));
  }
  return [{ name: PRIMARY_POINT, hip: state.hip, proxy: state.proxy, contact: !!state.contact, lost: false }];
}

/** The sources lost right now (state.tracking.lost), [] when none or an older server. */
export function lostSources(state) {
  const lost = state?.tracking?.lost;
  return Array.isArray(lost) ? lost.filter((s) => typeof s === 'string' || typeof s === 'number') : [];
}

const distance = (a, b) => Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);

/**
 * One tool's HIP sphere (with a faint ghost drawn over everything, so the finger shows while it
 * is inside an object) and its proxy sphere.
 */
export class ToolMarker {
  constructor(name) {
    this.name = name;
    this.hip = new THREE.Mesh(new THREE.SphereGeometry(1, 32, 16), new THREE.MeshStandardMaterial({ roughness: 0.5 }));
    this.ghost = new THREE.Mesh(this.hip.geometry,
      new THREE.MeshBasicMaterial({ transparent: true, opacity: 0.4, depthTest: false, depthWrite: false }));
    this.ghost.renderOrder = 10;
    this.hip.add(this.ghost);
    this.proxy = new THREE.Mesh(new THREE.SphereGeometry(1, 24, 12),
      new THREE.MeshStandardMaterial({ color: new THREE.Color(PROXY_COLOR), roughness: 0.4 }));
    this.hip.visible = false;
    this.proxy.visible = false;
    this.contact = false;
    this.lost = false;
  }

  /** Size and colour from the scene's `hip` spec (radius, proxy radius already resolved). */
  style(radius, proxyRadius, color) {
    this.hip.scale.setScalar(radius);
    this.proxy.scale.setScalar(proxyRadius);
    this.hip.material.color.set(color);
    this.ghost.material.color.set(color);
    this.color = color;
  }

  /** Apply one tool of a state frame. */
  update(tool) {
    this.hip.position.fromArray(sceneToThree(tool.hip));
    this.proxy.position.fromArray(sceneToThree(tool.proxy));
    this.hip.visible = true;
    this.proxy.visible = !tool.lost && distance(tool.proxy, tool.hip) > SAME_POINT;
    this.contact = tool.contact && !tool.lost;
    this.lost = tool.lost;
    // Contact: the proxy takes the contact colour and the HIP glows in its own colour (a glow of
    // another hue would wash out the finger's colour, which tells the fingers apart).
    this.proxy.material.color.set(this.contact ? PROXY_COLOR : FREE_PROXY_COLOR);
    this.hip.material.emissive.set(this.contact ? this.color ?? '#000000' : '#000000');
    this.hip.material.emissiveIntensity = this.contact ? 0.35 : 0;
    if (this.hip.material.transparent !== tool.lost) {
      this.hip.material.transparent = tool.lost;
      this.hip.material.needsUpdate = true; // three.js compiles transparency into the shader program
    }
    this.hip.material.opacity = tool.lost ? LOST_OPACITY : 1;
    this.ghost.visible = !tool.lost;
  }

  dispose() {
    this.hip.geometry.dispose();
    this.proxy.geometry.dispose();
    for (const m of [this.hip.material, this.ghost.material, this.proxy.material]) m.dispose();
  }
}

/** Joint spheres and bone cylinders of the tracked hands, rebuilt in place each frame. */
export class HandView {
  constructor() {
    this.group = new THREE.Group();
    this.group.name = 'hand';
    this.material = new THREE.MeshStandardMaterial({ color: new THREE.Color(HAND_COLOR), roughness: 0.6,
      transparent: true, opacity: 0.85 });
    this.jointGeometry = new THREE.SphereGeometry(1, 12, 8);
    this.boneGeometry = new THREE.CylinderGeometry(1, 1, 1, 8); // unit height along +Y, centred
    this.joints = [];
    this.bones = [];
    this.radius = 0.06;
    this.last = { joints: [], bones: [] };
  }

  setRadius(hipRadius) {
    this.radius = hipRadius;
  }

  _pool(list, geometry, n) {
    while (list.length < n) {
      const m = new THREE.Mesh(geometry, this.material);
      this.group.add(m);
      list.push(m);
    }
    list.forEach((m, i) => { m.visible = i < n; });
  }

  /** Draw the hands of `points` (state.points) with the tools' fingertips. */
  update(points, tools) {
    const frame = handFrame(points, tools);
    this.last = frame;
    this._pool(this.joints, this.jointGeometry, frame.joints.length);
    this._pool(this.bones, this.boneGeometry, frame.bones.length);
    const jr = this.radius * JOINT_RADIUS_SCALE;
    frame.joints.forEach(([, p], i) => {
      this.joints[i].position.fromArray(sceneToThree(p));
      this.joints[i].scale.setScalar(jr);
    });
    const a = new THREE.Vector3();
    const b = new THREE.Vector3();
    const up = new THREE.Vector3(0, 1, 0);
    frame.bones.forEach(([, , pa, pb], i) => {
      const m = this.bones[i];
      a.fromArray(sceneToThree(pa));
      b.fromArray(sceneToThree(pb));
      const length = a.distanceTo(b);
      m.position.copy(a).add(b).multiplyScalar(0.5);
      m.scale.set(this.radius * BONE_RADIUS_SCALE, Math.max(length, 1e-9), this.radius * BONE_RADIUS_SCALE);
      if (length > 0) m.quaternion.setFromUnitVectors(up, b.clone().sub(a).divideScalar(length));
    });
  }

  dispose() {
    this.jointGeometry.dispose();
    this.boneGeometry.dispose();
    this.material.dispose();
  }
}
