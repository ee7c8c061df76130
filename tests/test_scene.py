"""The scene format: round trip, hashing, and clear errors for bad descriptions."""

import pytest

from scenarios.contact_angle import ContactAngle
from server.scene import Scene, SceneError


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
