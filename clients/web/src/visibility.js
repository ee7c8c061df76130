// state.visible: the complete set of visibility overrides, element id (object or overlay) → bool.
// An id absent from the map shows its scene `visible` value. Applied on every state frame, so it
// remembers what it applied last and only touches elements whose visibility changed.

export class Visibility {
  constructor() {
    this.elements = new Map(); // id → {object3d, sceneVisible}
    this.applied = new Map(); // id → override in force
  }

  /** New scene: forget every element and override. */
  clear() {
    this.elements.clear();
    this.applied.clear();
  }

  /** Register one element; it starts with its scene value. */
  add(id, object3d, sceneVisible = true) {
    object3d.visible = sceneVisible;
    this.elements.set(id, { object3d, sceneVisible });
  }

  /** Apply one state's `visible` map (missing = no overrides). Returns the ids it changed. */
  apply(overrides = {}) {
    const changed = [];
    for (const id of this.applied.keys()) {
      if (Object.hasOwn(overrides, id)) continue;
      const el = this.elements.get(id);
      this.applied.delete(id);
      el.object3d.visible = el.sceneVisible;
      changed.push(id);
    }
    for (const [id, shown] of Object.entries(overrides)) {
      if (this.applied.get(id) === shown) continue;
      const el = this.elements.get(id);
      if (!el) continue; // an element this client did not draw (e.g. an unknown shape)
      this.applied.set(id, shown);
      el.object3d.visible = shown;
      changed.push(id);
    }
    return changed;
  }
}
