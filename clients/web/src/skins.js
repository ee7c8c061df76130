// Material skins (objects[].material.skin): an image on this server repeated every
// tile = [tx, ty] scene units. The material's colour stays as a tint, so a light image takes the
// object's colour and an object looks the same before its image has loaded (or if it fails to).

import * as THREE from 'three';

const DEFAULT_TILE = [0.5, 0.5];

// Scene axes along which BoxGeometry's face groups (px, nx, py, ny, pz, nz) run their u and v.
export const BOX_FACE_AXES = [['x', 'z'], ['x', 'z'], ['y', 'x'], ['y', 'x'], ['y', 'z'], ['y', 'z']];
const PLANE_TOP_FACE = 2; // py: the plane's top face (scene +z)

/**
 * Texture repeats for a skinned shape: an array with one [u, v] per geometry group, null for a
 * group left plain; a single entry applies to the whole shape.
 * - plane: the top face only; its u runs along scene y and v along scene x, so the image
 *   repeats every tx along local x and every ty along local y.
 * - box: every face, x → tx, y → ty, and z takes the entry the face's other axis leaves.
 * - round shapes: tx around the circumference, ty along the surface from base to top.
 * - mesh: its UVs are in scene units (scene_view.meshGeometry), so one repeat per tile.
 */
export function skinRepeats(shape, tile = DEFAULT_TILE) {
  const [tx, ty] = tile;
  const r = shape.radius;
  switch (shape.type) {
    case 'plane': {
      const [sx, sy] = shape.size;
      return BOX_FACE_AXES.map((_, i) => (i === PLANE_TOP_FACE ? [sy / ty, sx / tx] : null));
    }
    case 'box': {
      const extent = { x: shape.size[0], y: shape.size[1], z: shape.size[2] };
      return BOX_FACE_AXES.map(([u, v]) => {
        const period = { x: tx, y: ty, z: u === 'x' ? ty : tx };
        return [extent[u] / period[u], extent[v] / period[v]];
      });
    }
    case 'sphere': return [[(2 * Math.PI * r) / tx, (Math.PI * r) / ty]];
    case 'hemisphere': return [[(2 * Math.PI * r) / tx, (Math.PI * r) / 2 / ty]];
    case 'cylinder': return [[(2 * Math.PI * r) / tx, shape.height / ty]];
    case 'cone': return [[(2 * Math.PI * r) / tx, Math.hypot(r, shape.height) / ty]];
    case 'mesh': return [[1 / tx, 1 / ty]];
    default: return [[1, 1]];
  }
}

/**
 * Loads the skin images of one built scene. A texture is put on its material only once its image
 * is there (an unloaded map samples black). cancel() on a rebuild: late images are then dropped.
 */
export class SkinLoader {
  constructor(loader = new THREE.TextureLoader()) {
    this.loader = loader;
    this.pending = 0;
    this.failed = [];
    this.cancelled = false;
  }

  /** Put `url` on `material` once loaded, repeated [u, v] times. */
  apply(material, url, [u, v]) {
    this.pending++;
    this.loader.load(url, (texture) => {
      this.pending--;
      if (this.cancelled) {
        texture.dispose();
        return;
      }
      texture.wrapS = THREE.RepeatWrapping;
      texture.wrapT = THREE.RepeatWrapping;
      texture.repeat.set(u, v);
      texture.colorSpace = THREE.SRGBColorSpace;
      texture.anisotropy = 8; // the texture plane is seen at a grazing angle
      material.map = texture;
      material.needsUpdate = true; // the shader gains the map
    }, undefined, () => {
      this.pending--;
      this.failed.push(url);
      console.warn(`viestac: skin ${url} did not load; drawing the plain colour`);
    });
  }

  cancel() {
    this.cancelled = true;
  }
}

/**
 * The material(s) of one object: a MeshStandardMaterial, or an array per geometry group when
 * only some faces are skinned or faces need different repeats. `skins` loads the images.
 */
export function makeMaterials(spec = {}, shape, skins) {
  const opacity = typeof spec.opacity === 'number' ? Math.min(1, Math.max(0, spec.opacity)) : 1;
  const make = () => new THREE.MeshStandardMaterial({
    color: new THREE.Color(spec.color ?? '#b0b0b0'),
    roughness: 0.75,
    metalness: 0.0,
    transparent: opacity < 1,
    opacity,
  });
  if (!spec.skin) return make();
  const repeats = skinRepeats(shape, spec.skin.tile ?? DEFAULT_TILE);
  const materials = repeats.map((repeat) => {
    const m = make();
    if (repeat) skins.apply(m, spec.skin.image, repeat);
    return m;
  });
  return materials.length === 1 ? materials[0] : materials;
}
