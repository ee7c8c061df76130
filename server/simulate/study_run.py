"""`viestac study --simulate`: a study file run end to end by synthetic participants on the
virtual clock — the real loop core, the experiment engine and recorder, the device firmware on
a simulated serial line — then the analysis.

Per participant: a fresh virtual rig (hub + devices), a session created by the engine exactly
as the console creates one (so counterbalancing, recording and the trial lifecycle are the
production code), and the participant's behaviour per trial: the positioning agent for
positioning trials (depth by feel), the magnitude-production keys for production trials, every
interval of a psychophysics trial (the stimulus scenario), a short exposure to the stimulus
otherwise; answers come from the observer models (server/synthetic), a psychophysics trial's from
the psychometric participant given the `psy` record the engine's start() returns.
Timestamps are virtual (a fixed epoch plus the virtual time), so the same seed gives the same
database and the same report.
"""

from __future__ import annotations

import gc
import sys
import time
from dataclasses import dataclass, field
from datetime import datetime, timedelta, timezone
from pathlib import Path
from typing import Callable, Mapping

from devices.profiles import profile_by_model
from scenarios import registry
from server import __version__
from server.experiment.engine import Experiment
from server.experiment.plan import PlannedTrial, plan_session
from server.experiment.store import Store
from server.experiment.study import load_study
from server.simulate.agent import AgentParams, GaveUp, PositioningAgent
from server.simulate.virtual_device import VirtualDevice, virtual_device
from server.simulate.virtual_hub import VirtualHub
from server.synthetic.participant import scenario_name
from server.synthetic.rng import derive_rng

EPOCH = datetime(2026, 1, 5, 9, 0, tzinfo=timezone.utc)  # virtual sessions start here, one day apart
RIG = ("fingertac", "ferrovibe")  # the thesis's rig; a study's other task devices join it (rig_for)
EXPOSURE_S = 0.5          # a trial's stimulus is felt this long before the answer
TRAINING_CAP_S = 5.0      # training is free exploration: a few virtual seconds stand for it
RESPONSE_S = 0.3          # a psychophysics answer follows the last interval after this long
STIMULUS_SCENARIO = "stimulus"  # Contract C1: psychophysics trials present this scenario
PSY_QUESTION = "response"       # Contract C2: the generated question a psychophysics trial asks


@dataclass
class SimulationResult:
    data_dir: Path
    sessions: list[str] = field(default_factory=list)
    trials: int = 0
    aborted: list[tuple[str, int, str]] = field(default_factory=list)  # (participant, seq, reason)
    virtual_s: float = 0.0
    wall_s: float = 0.0


class VirtualClock:
    """The store's UTC clock: the session's epoch plus the virtual time of its hub."""

    def __init__(self):
        self.day = 0
        self.hub: VirtualHub | None = None

    def __call__(self) -> str:
        t = self.hub.t_s if self.hub is not None else 0.0
        return (EPOCH + timedelta(days=self.day, seconds=t)).isoformat(timespec="microseconds")


def progress_bar(done: int, total: int, label: str, stream=sys.stderr, width: int = 30, unit: str = "trials") -> None:
    filled = width * done // max(1, total)
    stream.write(f"\r[{'#' * filled}{'-' * (width - filled)}] {done}/{total} {unit} · {label}   ")
    if done == total:
        stream.write("\n")
    stream.flush()


def simulate_study(study_path: str | Path, *, participants: int, seed: int, out_dir: str | Path,
                   make_participant: Callable[[int, int], object],
                   progress: Callable[[int, int, str], None] | None = None,
                   agent_params: AgentParams | Mapping[str, AgentParams] = AgentParams(),  # noqa: B008 (frozen)
                   settings: tuple[tuple[str, str], ...] = (), workers: int = 1,
                   on_cpu_free: Callable[[], None] | None = None) -> SimulationResult:
    """Run `participants` synthetic sessions of the study into OUT/data/viestac.sqlite.

    make_participant(seed, index) → an object with answer(trial, question) and
    produce_level(target_level) (server/synthetic). agent_params: the positioning agent's, or
    one per device model (a device effect, server/simulate/effects.py); a model not in the
    mapping gets the defaults. settings: the effect settings these stand for (effects.py), recorded
    in every session's config so the data say which population produced them.

    workers > 1: the participants run in that many processes, each into a database of its own,
    appended to the study's in participant order (Store.append_database): the same rows as one
    process writes (a participant's run depends on the seed and its index alone). `on_cpu_free`
    is called once, in this thread, when fewer participants are left than workers (a worker has
    nothing more to do), so the caller can use that CPU (`viestac study` loads the analysis)."""
    study_path = Path(study_path)
    study = load_study(study_path)
    out = Path(out_dir)
    result = SimulationResult(out / "data")
    db = result.data_dir / "viestac.sqlite"
    if db.exists():
        raise FileExistsError(f"{db} exists: simulate into an empty directory")
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    clock = VirtualClock()
    store = Store(db, clock)
    config = {"simulated": True, "seed": seed, "rig": list(rig_for(study)), "tick_hz": 1000}
    if settings:  # only then: without settings the config is what it always was
        config["settings"] = [list(pair) for pair in settings]
    run = _Run(study_path, seed, config, make_participant, agent_params)
    started = time.perf_counter()
    total = participants * len(plan_session(study, 0))  # every participant's plan is as long
    done = 0

    def trial_done(participant: str) -> None:
        nonlocal done
        done += 1
        if progress:
            progress(done, total, f"{participant} · {time.perf_counter() - started:.0f} s")

    try:
        if workers == 1 or participants == 1:
            parts = (_participant(run, study, store, clock, index, trial_done) for index in range(participants))
        else:
            parts = _in_processes(run, participants, workers, result.data_dir, store, trial_done, on_cpu_free)
        for sid, trials, aborted, virtual_s in parts:  # in participant order
            result.sessions.append(sid)
            result.trials += trials
            result.aborted.extend(aborted)
            result.virtual_s += virtual_s
    finally:
        store.close()
    result.wall_s = time.perf_counter() - started
    return result


@dataclass(frozen=True)
class _Run:
    """What every participant's session needs besides its index (sent to worker processes)."""
    study_path: Path
    seed: int
    config: dict
    make_participant: Callable[[int, int], object]
    agent_params: AgentParams | Mapping[str, AgentParams]


def _participant(run: _Run, study, store: Store, clock: VirtualClock, index: int,
                 trial_done: Callable[[str], None]) -> tuple[str, int, list, float]:
    """One participant's session on a fresh virtual rig: (session id, trials, aborted, virtual s)."""
    rig = tuple(run.config["rig"])
    devices = {model: virtual_device(model, profile_by_model(model)) for model in rig}
    hub = VirtualHub(devices, seed=run.seed)
    clock.hub, clock.day = hub, index
    experiment = Experiment(store, hub, studies_dir=run.study_path.parent, software_version=__version__,
                            config=run.config, record_every=10)
    session = experiment.create_session(study_id=study.id, participant=f"SIM{index:02d}",
                                        experimenter="simulator", device="+".join(rig),
                                        participant_index=index)
    person = run.make_participant(run.seed, index)
    sid, token = session["id"], session["token"]
    trials, aborted = 0, []
    for trial in session["trials"]:
        if store.trial_at(sid, trial["seq"]).status != "pending":  # a finished procedure's reserved trials
            trial_done(session["participant"])
            continue
        started = experiment.start(sid, token, trial["seq"])
        psy = psychophysics_record(started)
        motor = derive_rng("motor", run.seed, index, trial["seq"])
        reason = _perform(hub, devices, trial, person, run.agent_params, motor)
        if reason:
            experiment.abort(sid, token, trial["seq"], reason)
            aborted.append((session["participant"], trial["seq"], reason))
        else:
            planned = PlannedTrial(**{k: trial[k] for k in PlannedTrial.__dataclass_fields__})
            task = study.task(trial["task"])
            for q in trial["questions"]:
                if psy is not None and q == PSY_QUESTION:
                    value = person.answer_psychophysics(started, psy, q, stimulus_of(started))
                else:
                    value = person.answer(planned, task.question(q))
                experiment.answer(sid, token, trial["seq"], q, value, "synthetic participant")
            experiment.finish(sid, token, trial["seq"])
        trials += 1
        trial_done(session["participant"])
    hub.listeners.clear()
    return sid, trials, aborted, hub.t_s


def rig_for(study) -> tuple[str, ...]:
    """The simulated rig of a study: the thesis's devices, then every other device model its tasks
    name (a battery for the devkit or an audio tactor runs on that device), in file order."""
    extra = [t.device for t in study.tasks if t.device and t.device not in RIG]
    return RIG + tuple(dict.fromkeys(extra))


def psychophysics_record(started: dict) -> dict | None:
    """The `psy` of a started stimulus-scenario trial (Contract C2: the engine's start() returns
    the level, design, target … the participant answers to), or None for any other trial. A main
    trial of the stimulus scenario without it is refused: the simulator never guesses a level."""
    if scenario_name(started["scenario"]) != STIMULUS_SCENARIO or PSY_QUESTION not in started.get("questions", ()):
        return None
    psy = started.get("psy")
    if psy is None and started.get("kind") == "main":
        raise RuntimeError(f"trial {started['seq']} of task {started['task']!r} (scenario {started['scenario']}) "
                           "started without a 'psy' record: the experiment engine does not implement "
                           "psychophysics Contract C2 (Experiment.start() returns the trial with "
                           "'psy': design, level, reference, target, signal, stimulus_index, choices)")
    return psy


def stimulus_of(trial: Mapping) -> dict:
    """The fixed stimulus of a psychophysics trial: its scenario params and trial params, with
    the carrier the device plays when the file gives none (C1: None = the device's own carrier)."""
    stimulus = {**(trial.get("scenario_params") or {}), **(trial.get("params") or {})}
    if stimulus.get("carrier_hz") is None and trial.get("device"):
        try:
            carrier = profile_by_model(trial["device"]).carrier_hz
        except (KeyError, ValueError):
            carrier = 0
        if carrier:
            stimulus["carrier_hz"] = float(carrier)
    return stimulus


def _stimulus_s(trial: dict) -> float:
    """How long a stimulus-scenario trial presents (Contract C1): lead, the intervals and the
    inter-stimulus gaps between them, in seconds."""
    params = {**(trial.get("scenario_params") or {}), **(trial.get("params") or {})}
    n = int(params.get("n_intervals") or 1)
    duration = float(params.get("duration_ms") or 500.0)
    driven = params.get("parameter") == "duration_ms"
    lengths = [float(params[f"level_{k}"]) if driven and params.get(f"level_{k}") is not None else duration
               for k in range(1, n + 1)]
    isi, lead = float(params.get("isi_ms") or 500.0), float(params.get("lead_ms") or 500.0)
    return (lead + sum(lengths) + isi * (n - 1)) / 1000.0


_worker: tuple | None = None  # a worker process's (_Run, progress queue: one participant code per trial done)


def _worker_init(run: _Run, queue) -> None:
    """Forked, the worker inherits `run` as it is (never pickled: models hold mapping proxies)."""
    global _worker
    _worker = (run, queue)
    # The inherited heap is never garbage here: out of the collector's walks. A participant makes
    # millions of short-lived records; collecting the young ones every 20 000 allocations instead
    # of 700 saves ~4 % of its CPU time (reference counting frees them anyway).
    gc.freeze()
    gc.set_threshold(20_000, 50, 100)


def _participant_into(index: int, path: Path) -> tuple[str, int, list, float]:
    """A worker process: one participant into a database of its own at `path`."""
    run, queue = _worker
    clock = VirtualClock()
    store = Store(path, clock)
    store.db.execute("PRAGMA synchronous=OFF")  # a scratch file: appended, then deleted
    try:
        return _participant(run, load_study(run.study_path), store, clock, index, queue.put)
    finally:
        store.close()


def _in_processes(run: _Run, participants: int, workers: int, data_dir: Path, store: Store,
                  trial_done: Callable[[str], None], on_cpu_free: Callable[[], None] | None = None):
    """Participants in `workers` processes; yields their results in participant order, each
    appended to `store` first. Forked workers: the parent's modules are loaded already."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    for task in load_study(run.study_path).tasks:  # a first scene build loads meshes and trimesh (~0.4 s):
        registry.create(task.scenario, **task.params).build_scene()  # once here, and every worker has it
    context = multiprocessing.get_context("fork")
    queue = context.Queue()
    parts = data_dir / "parts"
    parts.mkdir(exist_ok=True)
    with ProcessPoolExecutor(workers, mp_context=context, initializer=_worker_init, initargs=(run, queue)) as pool:
        futures = [pool.submit(_participant_into, index, parts / f"{index:04d}.sqlite")
                   for index in range(participants)]
        try:
            for index, future in enumerate(futures):
                while not future.done():
                    _drain(queue, trial_done, timeout=0.1)
                summary = future.result()
                _drain(queue, trial_done)
                if on_cpu_free is not None and participants - index - 1 < workers:  # a worker is idle now
                    on_cpu_free()
                    on_cpu_free = None
                path = parts / f"{index:04d}.sqlite"
                store.append_database(path)
                for leftover in parts.glob(f"{path.name}*"):
                    leftover.unlink()
                yield summary
        finally:
            for future in futures:
                future.cancel()
    _drain(queue, trial_done)
    parts.rmdir()


def _drain(queue, trial_done: Callable[[str], None], timeout: float | None = None) -> None:
    import queue as queues

    try:
        trial_done(queue.get(timeout=timeout) if timeout else queue.get_nowait())
        while True:
            trial_done(queue.get_nowait())
    except queues.Empty:
        pass


def _perform(hub: VirtualHub, devices: dict[str, VirtualDevice], trial: dict, person,
             agent_params: AgentParams | Mapping[str, AgentParams], motor) -> str:
    """What the participant does during the trial; a reason if it could not be completed."""
    params, kind = trial["params"], trial["kind"]
    if kind == "training":
        hub.advance_s(min(trial["duration_s"] or TRAINING_CAP_S, TRAINING_CAP_S))
        return ""
    if trial["scenario"] == "positioning-v1" and kind in ("trial", "main"):
        cue = params.get("cue") or trial["scenario_params"].get("cue")
        # the task's own device feels the guidance (a battery's devkit or audio tactor); 3-DoF is the FerroVibe's
        own = devices.get(trial.get("device") or "") if cue != "3dof" else None
        device = own or devices["ferrovibe" if cue == "3dof" else "fingertac"]
        if isinstance(agent_params, Mapping):
            agent_params = agent_params.get(device.name, AgentParams())
        try:
            PositioningAgent(hub, device.feel, agent_params, motor).run_trial(params["object"], cue)
        except GaveUp as exc:
            return f"synthetic participant gave up: {exc}"
        return ""
    if params.get("mode") == "production":
        produced = int(person.produce_level(params["level"], seq=trial["seq"]))
        hub.command("r")                       # the experimenter starts recording
        hub.advance_s(EXPOSURE_S)
        key = "ArrowUp" if produced > params["start_level"] else "ArrowDown"
        for _ in range(abs(produced - params["start_level"])):
            hub.command(key, "down")
            hub.advance_s(0.2)
        hub.command("r")                       # ... and stops it: the scenario reports the result
        hub.advance_s(0.05)
        return ""
    if scenario_name(trial["scenario"]) == STIMULUS_SCENARIO and kind in ("trial", "main"):
        hub.advance_s(_stimulus_s(trial) + RESPONSE_S)  # every interval is presented, then the answer
        return ""
    hub.advance_s(EXPOSURE_S)
    return ""
