"""free-v1: free exploration of a scene (the scene file of `viestac serve --scene`, else a
sandbox): no task, no trials, a vibration on each finger whose debounced contact is on."""

import json
from dataclasses import replace

from scenarios import registry
from scenarios.free import FreeExploration, sandbox
from server.config import Settings
from server.core.cues import Vibration
from server.core.scene import Scene
from server.loop.tick import Switch
from server.loop.process import LoopConfig, build_core
from server.loop.simulation import Simulation

WALL = {"name": "wall", "objects": [
    {"id": "wall", "shape": {"type": "box", "size": [0.2, 2, 2]}, "pose": {"pos": [0, 0, 0], "quat": [1, 0, 0, 0]}}]}


def scene_file(tmp_path) -> str:
    path = tmp_path / "wall.json"
    path.write_text(json.dumps(WALL))
    return str(path)


def test_free_v1_is_in_the_registry_and_explores_a_sandbox_without_a_scene():
    assert registry.resolve("free").id == "free-v1"
    scene = registry.create("free").build_scene()
    assert scene == sandbox() and {"sphere", "box", "cylinder"} <= {o.id for o in scene.objects}


def test_a_finger_in_contact_feels_a_vibration_and_nothing_otherwise():
    sim = Simulation(FreeExploration(Scene.from_dict(WALL)))
    sim.set_hip((1.0, 0.0, 0.0))
    assert sim.step().output.cues == ()
    sim.set_hip((0.05, 0.0, 0.0))  # inside the wall: the proxy stays on its face
    touching = sim.step()
    assert touching.contact and touching.output.cues == (Vibration(100.0),)
    assert touching.output.tool_cues == {}


def test_other_fingers_get_their_own_contact_cue():
    sim = Simulation(FreeExploration(Scene.from_dict(WALL)), rig=("right.thumb.tip",))
    sim.set_hip((1.0, 0.0, 0.0))
    sim.offer("t", 1, (0.05, 0.0, 0.0), point="right.thumb.tip")
    out = sim.step().output
    assert out.cues == () and out.tool_cues == {"right.thumb.tip": (Vibration(100.0),)}


def test_settings_with_a_scene_file_alone_run_free_v1_on_that_file(tmp_path):
    path = scene_file(tmp_path)
    settings = Settings(scene_file=path)
    assert settings.scenario == "free-v1"
    core = build_core(settings.loop_config())
    assert core.sim.scenario.id == "free-v1" and core.sim.scene == Scene.load(path)
    assert Settings().scenario == "contact-angle-v1", "no scene file: the default scenario as before"


def test_a_named_scenario_starts_on_the_scene_file_and_a_switch_back_to_free_explores_the_file(tmp_path):
    path = scene_file(tmp_path)
    core = build_core(Settings(scenario="stiffness", scene_file=path).loop_config())
    assert core.sim.scenario.id == "stiffness-v1" and core.sim.scene == Scene.load(path)
    free = core.build(Switch("free-v1", {}, 0))
    assert free.scene == Scene.load(path)
    other = core.build(Switch("texture-v1", {}, 0))
    assert other.scene == other.scenario.build_scene(), "other scenarios switch to their own scene"


def test_a_loop_restarted_into_another_scenario_builds_its_own_scene_not_the_file(tmp_path):
    """What the supervisor does when the loop dies after a switch: the same config, with the
    scenario that ran (server/hub/supervisor.py _spawn), through the process's JSON."""
    path = scene_file(tmp_path)
    config = Settings(scenario="stiffness", scene_file=path).loop_config()
    restarted = LoopConfig.from_json(replace(config, scenario="texture-v1", scenario_params={}).to_json())
    texture = build_core(restarted).sim
    assert texture.scenario.id == "texture-v1" and texture.scene == texture.scenario.build_scene()
    back = build_core(LoopConfig.from_json(replace(config, scenario="stiffness-v1").to_json())).sim
    assert back.scene == Scene.load(path), "the scenario the file was given for gets it again"
    free = build_core(replace(config, scenario="free-v1", scenario_params={})).sim
    assert free.scene == Scene.load(path), "free-v1 explores the file"
