"""Scene: the static description of a virtual environment (MuJoCo's "model").

A Scene is built once (by a scenario, or from a JSON file in the format of docs/protocol.md),
frozen, sent to clients once, and named in every state frame by its hash. Everything that changes
per tick (HIP, proxy, moving object poses, cues) lives in the simulation's state instead.
"""

from __future__ import annotations

import hashlib
import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

from server.core.canonical_json import canonical_json
from server.core.haptics.primitives import Body, Pose, shape_from_dict
from server.core.numbers import is_finite_number
from server.core.tool import DEFAULT_PROXY_RADIUS

_COLOR = re.compile(r"^#[0-9a-fA-F]{6}$")
_ID = re.compile(r"^[A-Za-z0-9_.:-]{1,64}$")
_SKIN_URL = re.compile(r"^/[A-Za-z0-9_/.-]{1,200}\.(png|jpg|jpeg|svg|webp)$")
PROJECTIONS = ("orthographic", "perspective")


class SceneError(ValueError):
    """A scene description that cannot be used; the message names the offending field."""


def _vec(d: dict, key: str, where: str, size: int = 3, default=None) -> tuple[float, ...]:
    value = d.get(key, default)
    if (not isinstance(value, (list, tuple)) or len(value) != size
            or not all(is_finite_number(v) for v in value)):
        raise SceneError(f"{where}.{key} must be an array of {size} finite numbers")
    return tuple(float(v) for v in value)


def _num(d: dict, key: str, where: str, default=None, minimum: float | None = None) -> float:
    value = d.get(key, default)
    if not is_finite_number(value):
        raise SceneError(f"{where}.{key} must be a finite number")
    if minimum is not None and value < minimum:
        raise SceneError(f"{where}.{key} must be >= {minimum}")
    return float(value)


def _color(d: dict, key: str, where: str, default: str) -> str:
    value = d.get(key, default)
    if not isinstance(value, str) or not _COLOR.match(value):
        raise SceneError(f"{where}.{key} must be a colour like '#3a7bd5'")
    return value


def _known(d: dict, allowed: set[str], where: str) -> None:
    unknown = sorted(set(d) - allowed)
    if unknown:
        raise SceneError(f"{where}: unknown field(s) {', '.join(unknown)}; allowed: {', '.join(sorted(allowed))}")


MAX_MESH_VERTICES = 20_000
MAX_MESH_FACES = 40_000


@dataclass(frozen=True)
class Mesh:
    """A display-only triangle mesh (e.g. a hollow tube built with trimesh) for shapes without an
    analytic primitive. Never touched: collision stays on primitives (docs/haptics.md), so an
    object with a mesh shape must have `haptic: false`. Vertices in the object's local frame;
    faces are counter-clockwise seen from outside."""
    vertices: tuple[tuple[float, float, float], ...]
    faces: tuple[tuple[int, int, int], ...]
    type: ClassVar[str] = "mesh"

    def __post_init__(self) -> None:
        n = len(self.vertices)
        if not 3 <= n <= MAX_MESH_VERTICES or not 1 <= len(self.faces) <= MAX_MESH_FACES:
            raise SceneError(f"a mesh needs 3..{MAX_MESH_VERTICES} vertices and 1..{MAX_MESH_FACES} faces")
        if any(not (0 <= i < n) for face in self.faces for i in face):
            raise SceneError(f"mesh face indices must be in 0..{n - 1}")

    @classmethod
    def from_trimesh(cls, mesh) -> Mesh:
        return cls(tuple(tuple(round(float(c), 9) for c in v) for v in mesh.vertices),
                   tuple(tuple(int(i) for i in f) for f in mesh.faces))

    @classmethod
    def from_dict(cls, d: dict, where: str) -> Mesh:
        vertices, faces = d.get("vertices"), d.get("faces")
        if not isinstance(vertices, list) or not isinstance(faces, list):
            raise SceneError(f"{where}: a mesh needs 'vertices' [[x, y, z], ...] and 'faces' [[i, j, k], ...]")
        try:
            v = tuple(_vec({"v": p}, "v", where) for p in vertices)
        except SceneError:
            raise SceneError(f"{where}: mesh vertices must be arrays of 3 finite numbers") from None
        if not all(isinstance(f, list) and len(f) == 3 and all(isinstance(i, int) and not isinstance(i, bool)
                                                                 for i in f) for f in faces):
            raise SceneError(f"{where}: mesh faces must be arrays of 3 integer vertex indices")
        return cls(v, tuple(tuple(f) for f in faces))  # type: ignore[arg-type]

    def to_dict(self) -> dict:
        return {"type": "mesh", "vertices": [list(v) for v in self.vertices], "faces": [list(f) for f in self.faces]}


@dataclass(frozen=True)
class Skin:
    """An image drawn on a surface (e.g. an LMT haptic texture database photo on the texture
    plane), repeated every `tile` scene units along the shape's local x and y."""
    image: str                 # URL path on this server, e.g. "/skins/cork.svg"
    tile: tuple[float, float] = (0.5, 0.5)

    def __post_init__(self) -> None:
        if not _SKIN_URL.match(self.image) or ".." in self.image:
            raise SceneError(f"skin image {self.image!r} must be a path on this server like /skins/cork.svg "
                             "(png, jpg, svg or webp)")
        if not all(is_finite_number(t) and t > 0 for t in self.tile):
            raise SceneError("skin tile must be two numbers > 0")

    @classmethod
    def from_dict(cls, d: Any, where: str) -> Skin:
        if not isinstance(d, dict):
            raise SceneError(f"{where} must be an object with 'image' and 'tile'")
        _known(d, {"image", "tile"}, where)
        image = d.get("image")
        if not isinstance(image, str):
            raise SceneError(f"{where}.image must be a string")
        return cls(image, _vec(d, "tile", where, 2, (0.5, 0.5)))  # type: ignore[arg-type]

    def to_dict(self) -> dict:
        return {"image": self.image, "tile": list(self.tile)}


@dataclass(frozen=True)
class Material:
    color: str = "#8c8c8c"
    opacity: float = 1.0
    stiffness_n_per_m: float = 1000.0  # god-object spring k; notional for trackers (no force device)
    static_friction: float = 0.0
    dynamic_friction: float = 0.0
    skin: Skin | None = None

    @classmethod
    def from_dict(cls, d: dict, where: str) -> Material:
        _known(d, {"color", "opacity", "stiffness_n_per_m", "static_friction", "dynamic_friction", "skin"}, where)
        opacity = _num(d, "opacity", where, 1.0, 0.0)
        if opacity > 1.0:
            raise SceneError(f"{where}.opacity must be in [0, 1]")
        skin = Skin.from_dict(d["skin"], f"{where}.skin") if d.get("skin") is not None else None
        return cls(_color(d, "color", where, cls.color), opacity,
                   _num(d, "stiffness_n_per_m", where, 1000.0, 0.0),
                   _num(d, "static_friction", where, 0.0, 0.0), _num(d, "dynamic_friction", where, 0.0, 0.0), skin)

    def to_dict(self) -> dict:
        d = {"color": self.color, "opacity": self.opacity, "stiffness_n_per_m": self.stiffness_n_per_m,
             "static_friction": self.static_friction, "dynamic_friction": self.dynamic_friction}
        if self.skin is not None:
            d["skin"] = self.skin.to_dict()
        return d


@dataclass(frozen=True)
class AngleScale:
    """A protractor drawn around an arc in the y-z plane (the contact-angle training aid): angle a
    sits at centre + radius·(0, sin a, cos a), so −90 is left, 0 the top and +90 right, as in
    Algorithm 1. Ticks every `minor_deg`, labelled every `major_deg`."""
    id: str
    centre: tuple[float, float, float]
    radius: float
    from_deg: float = -90.0
    to_deg: float = 90.0
    minor_deg: float = 10.0
    major_deg: float = 30.0
    color: str = "#f2f2f2"  # light: clients draw on a dark background
    visible: bool = True
    kind: ClassVar[str] = "angle_scale"

    def to_dict(self) -> dict:
        return {"id": self.id, "kind": self.kind, "centre": list(self.centre), "radius": self.radius,
                "from_deg": self.from_deg, "to_deg": self.to_deg, "minor_deg": self.minor_deg,
                "major_deg": self.major_deg, "color": self.color, "visible": self.visible}

    @classmethod
    def from_dict(cls, d: dict, where: str) -> AngleScale:
        _known(d, {"id", "kind", "centre", "radius", "from_deg", "to_deg", "minor_deg", "major_deg", "color",
                   "visible"}, where)
        scale = cls(d["id"], _vec(d, "centre", where), _num(d, "radius", where, None, 1e-6),  # type: ignore[arg-type]
                    _num(d, "from_deg", where, -90.0), _num(d, "to_deg", where, 90.0),
                    _num(d, "minor_deg", where, 10.0, 0.5), _num(d, "major_deg", where, 30.0, 0.5),
                    _color(d, "color", where, "#f2f2f2"), _flag(d, "visible", where))
        if scale.to_deg <= scale.from_deg:
            raise SceneError(f"{where}: to_deg must be greater than from_deg")
        return scale


@dataclass(frozen=True)
class Label:
    """Text at a scene position, facing the camera (reference names, training labels)."""
    id: str
    pos: tuple[float, float, float]
    text: str
    size: float = 0.12   # letter height, scene units
    color: str = "#f2f2f2"
    visible: bool = True
    kind: ClassVar[str] = "label"

    def to_dict(self) -> dict:
        return {"id": self.id, "kind": self.kind, "pos": list(self.pos), "text": self.text, "size": self.size,
                "color": self.color, "visible": self.visible}

    @classmethod
    def from_dict(cls, d: dict, where: str) -> Label:
        _known(d, {"id", "kind", "pos", "text", "size", "color", "visible"}, where)
        text = d.get("text")
        if not isinstance(text, str) or not 0 < len(text) <= 200:
            raise SceneError(f"{where}.text must be a string of 1..200 characters")
        return cls(d["id"], _vec(d, "pos", where), text, _num(d, "size", where, 0.12, 1e-4),  # type: ignore[arg-type]
                   _color(d, "color", where, "#f2f2f2"), _flag(d, "visible", where))


OVERLAY_KINDS = {cls.kind: cls for cls in (AngleScale, Label)}
Overlay = AngleScale | Label


def _flag(d: dict, key: str, where: str, default: bool = True) -> bool:
    value = d.get(key, default)
    if not isinstance(value, bool):
        raise SceneError(f"{where}.{key} must be true or false")
    return value


def overlay_from_dict(d: Any, where: str) -> Overlay:
    if not isinstance(d, dict):
        raise SceneError(f"{where} must be an object")
    kind = d.get("kind")
    if kind not in OVERLAY_KINDS:
        raise SceneError(f"{where}.kind must be one of {', '.join(OVERLAY_KINDS)}")
    if not isinstance(d.get("id"), str) or not _ID.match(d["id"]):
        raise SceneError(f"{where}.id must be 1-64 characters of letters, digits, _ . : -")
    return OVERLAY_KINDS[kind].from_dict(d, where)


@dataclass(frozen=True)
class SceneObject:
    id: str
    shape: Any  # a shape from server.core.haptics.primitives (local frame)
    pose: Pose = Pose()
    material: Material = Material()
    haptic: bool = True   # False: drawn only (e.g. table legs)
    visible: bool = True  # False: touched only

    def __post_init__(self) -> None:
        if isinstance(self.shape, Mesh) and self.haptic:
            raise SceneError(f"object {self.id!r}: a mesh is drawn only; give it haptic: false and touch "
                             "primitives instead")

    def body(self, pose: Pose | None = None) -> Body:
        m = self.material
        return Body(self.id, self.shape, pose or self.pose, m.stiffness_n_per_m, m.static_friction, m.dynamic_friction)

    def to_dict(self) -> dict:
        return {"id": self.id, "shape": self.shape.to_dict(), "pose": self.pose.to_dict(),
                "material": self.material.to_dict(), "haptic": self.haptic, "visible": self.visible}


@dataclass(frozen=True)
class Camera:
    projection: str = "orthographic"
    position: tuple[float, float, float] = (5.0, 0.0, 0.0)
    target: tuple[float, float, float] = (0.0, 0.0, 0.0)
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    height: float = 2.0    # orthographic: visible height in scene units
    fov_deg: float = 45.0  # perspective: vertical field of view

    def to_dict(self) -> dict:
        d: dict[str, Any] = {"projection": self.projection, "position": list(self.position),
                             "target": list(self.target), "up": list(self.up)}
        if self.projection == "orthographic":
            d["height"] = self.height
        else:
            d["fov_deg"] = self.fov_deg
        return d

    @classmethod
    def from_dict(cls, d: dict) -> Camera:
        _known(d, {"projection", "position", "target", "up", "height", "fov_deg"}, "camera")
        projection = d.get("projection", "orthographic")
        if projection not in PROJECTIONS:
            raise SceneError(f"camera.projection must be one of {', '.join(PROJECTIONS)}")
        return cls(projection, _vec(d, "position", "camera", default=(5, 0, 0)), _vec(d, "target", "camera", default=(0, 0, 0)),
                   _vec(d, "up", "camera", default=(0, 0, 1)), _num(d, "height", "camera", 2.0, 1e-6),
                   _num(d, "fov_deg", "camera", 45.0, 1.0))


@dataclass(frozen=True)
class Scene:
    name: str
    objects: tuple[SceneObject, ...]
    camera: Camera = Camera()
    hip_radius: float = 0.06    # drawn HIP sphere (thesis §4.2.4)
    proxy_radius: float = DEFAULT_PROXY_RADIUS  # god-object contact radius; 0 = point proxy
    hip_color: str = "#ffd400"
    hud_text: str = ""
    overlays: tuple[Overlay, ...] = ()  # drawn aids (angle scale, labels); no collision
    _hash: str = field(default="", init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        ids = [o.id for o in self.objects] + [o.id for o in self.overlays]
        if len(set(ids)) != len(ids):
            raise SceneError("object and overlay ids must be unique")
        # Over the wire form (canonical numbers, RFC 8785 text), so that a client can recompute it
        # from the scene it received: docs/protocol.md, "Scene hash".
        canonical = canonical_json(self.to_dict())
        object.__setattr__(self, "_hash", hashlib.sha256(canonical.encode("utf-8")).hexdigest()[:16])

    @property
    def hash(self) -> str:
        return self._hash

    def bodies(self) -> tuple[Body, ...]:
        """The haptic bodies at their scene poses (static scenes use these every tick)."""
        return tuple(o.body() for o in self.objects if o.haptic)

    def object(self, object_id: str) -> SceneObject:
        for o in self.objects:
            if o.id == object_id:
                return o
        raise KeyError(object_id)

    def has_id(self, element_id: str) -> bool:
        return any(o.id == element_id for o in self.objects) or any(o.id == element_id for o in self.overlays)

    def to_dict(self) -> dict:
        d = {"name": self.name, "camera": self.camera.to_dict(),
             "hip": {"radius": self.hip_radius, "proxy_radius": self.proxy_radius, "color": self.hip_color},
             "objects": [o.to_dict() for o in self.objects], "hud": {"text": self.hud_text}}
        if self.overlays:
            d["overlays"] = [o.to_dict() for o in self.overlays]
        return d

    @classmethod
    def from_dict(cls, d: Any) -> Scene:
        if not isinstance(d, dict):
            raise SceneError("a scene must be a JSON object")
        _known(d, {"name", "camera", "hip", "objects", "hud", "overlays"}, "scene")
        name = d.get("name")
        if not isinstance(name, str) or not name:
            raise SceneError("scene.name must be a non-empty string")
        hip = d.get("hip", {})
        if not isinstance(hip, dict):
            raise SceneError("scene.hip must be an object")
        _known(hip, {"radius", "proxy_radius", "color"}, "hip")
        raw_objects = d.get("objects")
        if not isinstance(raw_objects, list) or not raw_objects:
            raise SceneError("scene.objects must be a non-empty array")
        objects = []
        for i, o in enumerate(raw_objects):
            where = f"objects[{i}]"
            if not isinstance(o, dict):
                raise SceneError(f"{where} must be an object")
            _known(o, {"id", "shape", "pose", "material", "haptic", "visible"}, where)
            oid = o.get("id")
            if not isinstance(oid, str) or not _ID.match(oid):
                raise SceneError(f"{where}.id must be 1-64 characters of letters, digits, _ . : -")
            try:
                raw_shape = o.get("shape")
                if isinstance(raw_shape, dict) and raw_shape.get("type") == "mesh":
                    shape = Mesh.from_dict(raw_shape, f"{where}.shape")
                else:
                    shape = shape_from_dict(raw_shape)
                pose = Pose.from_dict(o.get("pose", {"pos": [0, 0, 0], "quat": [1, 0, 0, 0]}))
            except (ValueError, TypeError, KeyError) as exc:
                raise SceneError(f"{where} ({oid}): {exc}") from None
            for flag in ("haptic", "visible"):
                if not isinstance(o.get(flag, True), bool):
                    raise SceneError(f"{where}.{flag} must be true or false")
            objects.append(SceneObject(oid, shape, pose, Material.from_dict(o.get("material", {}), f"{where}.material"),
                                       o.get("haptic", True), o.get("visible", True)))
        hud = d.get("hud", {})
        if not isinstance(hud, dict) or not isinstance(hud.get("text", ""), str):
            raise SceneError("scene.hud must be an object with a string 'text'")
        raw_overlays = d.get("overlays", [])
        if not isinstance(raw_overlays, list):
            raise SceneError("scene.overlays must be an array")
        overlays = tuple(overlay_from_dict(o, f"overlays[{i}]") for i, o in enumerate(raw_overlays))
        return cls(name, tuple(objects), Camera.from_dict(d.get("camera", {})),
                   _num(hip, "radius", "hip", 0.06, 0.0), _num(hip, "proxy_radius", "hip", DEFAULT_PROXY_RADIUS, 0.0),
                   _color(hip, "color", "hip", "#ffd400"), hud.get("text", ""), overlays)

    @classmethod
    def load(cls, path: str | Path) -> Scene:
        try:
            data = json.loads(Path(path).read_text())
        except json.JSONDecodeError as exc:
            raise SceneError(f"{path}: not valid JSON ({exc})") from None
        return cls.from_dict(data)
