// three.js glue of the XR view: text panels that face the user (instructions, count-downs, the
// participant's answer choices) and the locally tracked hand. What they show is decided by the
// pure modules (xr_panels.js, xr_hands.js); here it is only drawn.

import * as THREE from 'three';
import { HandView } from './tools_view.js';
import { facingYaw } from './xr_panels.js';

const PX_PER_M = 2048;

/** A flat panel with text lines (and optionally a row of buttons), drawn on a canvas texture. */
export class TextPanel {
  constructor({ widthM = 0.5, heightM = 0.16, name = 'panel' } = {}) {
    this.widthM = widthM;
    this.heightM = heightM;
    this.canvas = document.createElement('canvas');
    this.canvas.width = Math.round(widthM * PX_PER_M);
    this.canvas.height = Math.round(heightM * PX_PER_M);
    this.texture = new THREE.CanvasTexture(this.canvas);
    this.texture.colorSpace = THREE.SRGBColorSpace;
    this.mesh = new THREE.Mesh(new THREE.PlaneGeometry(widthM, heightM),
      new THREE.MeshBasicMaterial({ map: this.texture, transparent: true, depthTest: false }));
    this.mesh.renderOrder = 20; // over the scene: a panel is never hidden behind an object
    this.mesh.name = name;
    this.key = null;
    this.lines = [];
    this.buttons = [];
  }

  /** Redraw when the lines or buttons ({label, u0, u1, selected}) changed. */
  show(lines, buttons = []) {
    const key = JSON.stringify([lines, buttons.map((b) => [b.label, b.selected, b.anchor ?? ''])]);
    this.mesh.visible = lines.length > 0 || buttons.length > 0;
    if (key === this.key) return;
    this.key = key;
    this.lines = lines;
    this.buttons = buttons;
    const g = this.canvas.getContext('2d');
    const { width: w, height: h } = this.canvas;
    g.clearRect(0, 0, w, h);
    g.fillStyle = 'rgba(20, 24, 30, 0.82)';
    g.fillRect(0, 0, w, h);
    const textH = buttons.length ? h * 0.5 : h;
    const size = Math.min(72, (textH * 0.8) / Math.max(1, lines.length));
    g.font = `${Math.round(size)}px sans-serif`;
    g.fillStyle = '#ffffff';
    g.textAlign = 'center';
    g.textBaseline = 'middle';
    lines.forEach((t, i) => g.fillText(t, w / 2, (textH * (i + 0.5)) / lines.length, w * 0.95));
    for (const b of buttons) {
      const x0 = b.u0 * w + 6;
      const bw = (b.u1 - b.u0) * w - 12;
      g.fillStyle = b.selected ? '#ffd400' : '#3a4250';
      g.fillRect(x0, textH + 6, bw, h - textH - 12);
      g.fillStyle = b.selected ? '#000000' : '#ffffff';
      g.font = `${Math.round((h - textH) * 0.4)}px sans-serif`;
      g.fillText(b.label, x0 + bw / 2, textH + (h - textH) / 2, bw);
    }
    this.texture.needsUpdate = true;
  }

  /** Stand at `pos` (XR metres), turned toward `head`. */
  place(pos, head) {
    this.mesh.position.fromArray(pos);
    this.mesh.rotation.set(0, facingYaw(pos, head), 0);
  }

  /** Where a ray (THREE.Ray, XR frame) hits the panel: {u, v} in 0..1 (u left → right), or null. */
  hit(ray) {
    this.mesh.updateMatrixWorld();
    const inv = this.mesh.matrixWorld.clone().invert();
    const local = ray.clone().applyMatrix4(inv);
    const plane = new THREE.Plane(new THREE.Vector3(0, 0, 1), 0);
    const p = local.intersectPlane(plane, new THREE.Vector3());
    if (!p) return null;
    const u = p.x / this.widthM + 0.5;
    const v = 0.5 - p.y / this.heightM;
    return u >= 0 && u <= 1 && v >= 0 && v <= 1 ? { u, v } : null;
  }

  dispose() {
    this.texture.dispose();
    this.mesh.geometry.dispose();
    this.mesh.material.dispose();
  }
}

/** The hand tracked by this headset, drawn from this frame's joints (scene frame, under the
 * view's placed root), with held fingertips at their proxies. The tracked fingertips are
 * highlighted in their tool's colour (larger spheres). */
export class XrHand {
  constructor(root, radiusM) {
    this.view = new HandView();
    this.radiusM = radiusM;
    this.view.setRadius(radiusM);
    this.view.group.name = 'xr-hand';
    root.add(this.view.group);
    this.tips = new Map(); // tool name → highlight sphere
    this.root = root;
    this.radius = radiusM;
  }

  /** The root's metres per scene unit: the hand keeps its size in metres. */
  setScale(scaleMPerUnit) {
    this.radius = this.radiusM / scaleMPerUnit;
    this.view.setRadius(this.radius);
  }

  update(points, tools, toolColor) {
    this.view.update(points, []);
    const names = new Set();
    for (const t of tools ?? []) {
      const p = points[t.name];
      if (!p) continue;
      names.add(t.name);
      let m = this.tips.get(t.name);
      if (!m) {
        m = new THREE.Mesh(new THREE.SphereGeometry(1, 16, 8), new THREE.MeshStandardMaterial({ roughness: 0.4 }));
        this.root.add(m);
        this.tips.set(t.name, m);
      }
      m.material.color.set(toolColor(t.name));
      m.material.emissive.set(t.contact ? toolColor(t.name) : '#000000');
      m.material.emissiveIntensity = t.contact ? 0.4 : 0;
      m.scale.setScalar(this.radius * 0.45);
      m.position.set(p[1], p[2], p[0]); // protocol.sceneToThree
      m.visible = true;
    }
    for (const [name, m] of this.tips) if (!names.has(name)) m.visible = false;
  }

  setVisible(v) {
    this.view.group.visible = v;
    for (const m of this.tips.values()) m.visible = m.visible && v;
  }

  dispose() {
    this.root.remove(this.view.group);
    for (const m of this.tips.values()) {
      this.root.remove(m);
      m.geometry.dispose();
      m.material.dispose();
    }
    this.view.dispose();
  }
}
