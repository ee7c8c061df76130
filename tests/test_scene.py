"""The scene format: round trip, hashing, and clear errors for bad descriptions."""

import pytest

from scenarios.contact_angle import ContactAngle
from server.core.scene import Scene, SceneError


def test_round_trip_and_hash_stability():
    scene = ContactAngle().build_scene()
    again = Scene.from_dict(scene.to_dict())
    assert again.to_dict() == scene.to_dict()
    assert again.hash == scene.hash and len(scene.hash) == 16


BASE = {"name": "s", "objects": [{"id": "a", "shape": {"type": "sphere", "radius": 0.5}}]}


@pytest.mark.parametrize("patch, message", [
    ({"name": ""}, "scene.name"),
    ({"objects": []}, "non-empty"),
    ({"colour": "red"}, "unknown field"),
    ({"objects": [{"id": "a b", "shape": {"type": "sphere", "radius": 1}}]}, "objects[0].id"),
    ({"objects": [{"id": "a", "shape": {"type": "sphere", "radius": -1}}]}, "objects[0] (a)"),
    ({"objects": [{"id": "a", "shape": {"type": "sphere", "radius": 1}, "material": {"color": "blue"}}]}, "color"),
    ({"objects": [{"id": "a", "shape": {"type": "sphere", "radius": 1}}, {"id": "a", "shape": {"type": "sphere", "radius": 1}}]}, "unique"),
    ({"camera": {"projection": "fisheye"}}, "camera.projection"),
    ({"hip": {"radius": float("nan")}}, "hip.radius"),
])
def test_bad_scenes_name_the_field(patch, message):
    with pytest.raises(SceneError) as info:
        Scene.from_dict({**BASE, **patch})
    assert message in str(info.value)


def test_mesh_objects_round_trip_are_drawn_only_and_checked():
    from server.core.scene import Mesh, Scene, SceneError

    tri = {"type": "mesh", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "faces": [[0, 1, 2]]}
    base = {"name": "m", "objects": [{"id": "tri", "shape": tri, "haptic": False}]}
    scene = Scene.from_dict(base)
    assert isinstance(scene.object("tri").shape, Mesh) and scene.bodies() == ()
    assert Scene.from_dict(scene.to_dict()) == scene
    touched = {"name": "m", "objects": [{"id": "tri", "shape": tri}]}
    with pytest.raises(SceneError, match="a mesh is drawn only"):
        Scene.from_dict(touched)
    bad = {"name": "m", "objects": [{"id": "tri", "shape": {**tri, "faces": [[0, 1, 3]]}, "haptic": False}]}
    with pytest.raises(SceneError, match="face indices must be in 0..2"):
        Scene.from_dict(bad)
