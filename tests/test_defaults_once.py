"""The server's defaults are defined once and every layer takes them from there: the state cadence
(server/loop/cadence.py), the contact gate's band and dwell (contact_gate.py), the scenario run
when none is named (scenarios/registry.py)."""

import inspect

from scenarios.registry import DEFAULT_SCENARIO, resolve
from server.cli import build_parser
from server.config import Settings
from server.core.haptics.contact_gate import BAND, MIN_DWELL_S, ReferenceContactGate
from server.loop.cadence import STATE_HZ
from server.loop.tick import Loop
from server.loop.process import LoopConfig
from server.simulate.virtual_hub import VirtualHub


def _default(fn, name):
    return inspect.signature(fn).parameters[name].default


def test_every_layer_uses_the_one_state_cadence():
    serve = build_parser().parse_args(["serve"])
    assert serve.state_hz == Settings().state_hz == LoopConfig().state_hz == STATE_HZ == 60.0
    assert _default(Loop.__init__, "state_hz") == _default(VirtualHub.__init__, "state_hz") == STATE_HZ


def test_every_layer_uses_the_one_gate_band_and_dwell():
    serve = build_parser().parse_args(["serve"])
    gate = ReferenceContactGate()
    assert serve.gate_band == Settings().gate_band == LoopConfig().gate_band == gate.band == BAND == 0.002
    assert serve.gate_dwell_ms / 1000.0 == Settings().gate_dwell_s == MIN_DWELL_S == 0.030
    assert LoopConfig().gate_min_on_s == LoopConfig().gate_min_off_s == gate.min_on_s == gate.min_off_s == MIN_DWELL_S


def test_every_layer_starts_the_one_default_scenario():
    assert Settings().scenario == resolve(DEFAULT_SCENARIO).id == "contact-angle-v1"
    assert LoopConfig().scenario == _default(VirtualHub.__init__, "scenario") == DEFAULT_SCENARIO
