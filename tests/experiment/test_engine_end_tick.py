"""A trial ends at the last tick it recorded (server/experiment/engine.py `_end`): the hub's newest
state may be a few frames later by the time the engine's thread ends the trial, and an end tick
past the recorded rows would count rows the recording never took (found by the fault bench)."""

from pathlib import Path

from server.experiment.engine import Experiment
from server.experiment.store import Store
from tests.experiment.test_recorder import row, state
from tests.experiment.test_store import clock
from server.ipc.records import ScenarioAnnounce, State

STUDIES = Path(__file__).resolve().parents[2] / "studies"


class RacingHub:
    """A hub whose loop goes on ticking while the engine ends a trial."""

    def __init__(self):
        self.listeners: list = []
        self.scenario_state = self.scenario_target = None
        self.last_state: dict | None = None

    def switch_scenario(self, name, params=None, seed=0, force=False):
        self.scenario_state = self.scenario_target = {"id": name, "params": params or {}, "seed": seed}
        return self.scenario_state

    def require_devices(self, scenario=None, force=False):
        pass

    def devices_needed(self, scenario=None):
        return {}

    def set_recording(self, every_n_ticks):
        pass

    def set_trial(self, phase, params=None, index=0, force=False):
        if self.last_state is not None:  # the end: the loop has ticked on meanwhile, the hub saw later states
            self.last_state = {"tick": self.last_state["tick"] + 40}
            return None
        trial = None if phase is None else {"phase": phase, "params": params or {}, "index": index}
        self.publish(ScenarioAnnounce({"trial": trial, "tick": 100}))
        for tick in range(100, 160, 10):
            self.publish(state(tick, trajectory=[row(tick)]))
        return trial

    def publish(self, record):
        if type(record) is State:
            self.last_state = record.view
        for listener in self.listeners:
            listener(record)


def test_the_end_tick_is_the_last_tick_recorded(tmp_path):
    store = Store(tmp_path / "db.sqlite", clock())
    hub = RacingHub()
    experiment = Experiment(store, hub, studies_dir=STUDIES, software_version="t", config={}, record_every=1)
    session = experiment.create_session(study_id="thesis-2021", participant="P01", experimenter="alice",
                                        device="ferrovibe")
    sid, token = session["id"], session["token"]
    trial = session["trials"][0]
    experiment.start(sid, token, trial["seq"], force=True)
    for question in trial["questions"]:
        experiment.answer(sid, token, trial["seq"], question, 10.0)
    ended = experiment.finish(sid, token, trial["seq"])
    rows = store.samples(trial["id"], ended["attempt"])
    assert ended["started_tick"] == 100 and ended["ended_tick"] == rows[-1]["tick"] == 150
    store.close()
