"""The experiment engine: sessions of a study, driven by the experimenter, on the one rig.

A session is a study's plan for one participant (server/experiment/plan.py), stored as pending
trials. The experimenter moves it on: `start` the next pending trial (the engine switches the
loop to the trial's scenario if needed, sets the trial, and starts recording), `answer` its
questions, `finish` it (answered: needs every required answer), or `abort`, `retry`, `exclude`.
Every change is committed before the call returns (store.py), so the console, a crash and a
restart all see the same queue.

Control: creating a session hands out a control token; every change needs it. A second console
that wants to drive the session takes control explicitly (`take_control`, a new token; the old
one stops working and the hand-over is recorded). Each change also names the trial it is about
(`seq`), so two clicks racing for the same trial cannot both succeed (409 for the second).

Sites: every session belongs to a lab (`site`). Each call takes the caller's
`site` scope: None for the rig's admin (every session), else a site name, and a session of another
site is NotFound (404), as if it did not exist.

Timestamps are the server's: UTC wall-clock from the store's clock, and the loop's tick.

Psychophysics tasks (server/experiment/psychophysics_task.py): when such a trial starts, its
levels are a replay of the task's recorded answers (never state kept in memory, so a restart
resumes at the same procedure state); the presented parameters are stored on the trial before it
runs, `start` returns them as `psy` (Contract C2), `finish` writes `metrics["psy"]` (C3), and once
the procedure has finished the task's remaining reserved trials are excluded ("procedure
finished"). `tracks` is the console's view of every such task (C4).

A loop restart during a trial interrupts it (the recorder sees the new loop's hello): `flush()`,
which the server calls every 0.25 s off the event loop, ends that attempt with its rows up to the
crash and puts the trial back to pending, as a server crash does (docs/data.md "A loop restart
during a trial"); finishing or aborting it in the meantime gets 409 and does the same.
"""

from __future__ import annotations

import secrets
import threading
import uuid
from dataclasses import replace
from pathlib import Path
from typing import Any, Protocol

from server.experiment.participant import participant_code_problem, participant_view
from server.experiment.plan import plan_session
from server.experiment.psychophysics_task import EXCLUDED_REASON, QUESTION_ID, Seeds, conclude, next_trial, track
from server.experiment.recorder import Recorder
from server.experiment.store import Conflict, Store, StoreError, TrialRow
from server.experiment.question import AnswerError
from server.experiment.study import Study, StudyError, load_study

SCENARIO_TRIAL_KINDS = ("trial", "main")  # training and questionnaires set no scenario trial


class ExperimentError(ValueError):
    """A request that cannot be carried out as asked (bad input: 422 in REST)."""


class NotFound(ExperimentError):
    """An unknown study, session or trial (404)."""


class Forbidden(ExperimentError):
    """A change without the session's current control token (403)."""


class HubPort(Protocol):
    """What the engine needs of the hub (server/hub/owner.py HubForWorkers; server/simulate/virtual_hub.py)."""
    scenario_state: dict | None
    scenario_target: dict | None  # what runs once the switches sent land (the loop builds them off the tick)
    listeners: list

    def switch_scenario(self, name: str, params: dict | None = None, seed: int = 0, force: bool = False) -> dict: ...

    def set_trial(self, phase: str | None, params: dict | None = None, index: int = 0,
                  force: bool = False) -> dict | None: ...

    def require_devices(self, scenario: str | None = None, force: bool = False) -> None: ...

    def devices_needed(self, scenario: str | None = None) -> dict[str, tuple[str, ...]]: ...

    def set_recording(self, every_n_ticks: int) -> None: ...


class Experiment:
    def __init__(self, store: Store, hub: HubPort, *, studies_dir: Path, software_version: str, config: dict,
                 record_every: int = 10, force_scenarios: bool = False):
        self.store = store
        self.hub = hub
        self.studies_dir = Path(studies_dir)
        self.software_version = software_version
        self.config = config
        self.record_every = record_every
        self.force_scenarios = force_scenarios
        self.recorder = Recorder(store)
        hub.listeners.append(self.recorder.on_record)
        self._tokens: dict[str, str] = {}
        self._holders: dict[str, tuple[str, str]] = {}  # session → (experimenter, since UTC) of the token
        self._studies: dict[Path, tuple] = {}  # path → (mtime_ns, Study | None, StudyError | None)
        self._lock = threading.Lock()  # one change at a time: REST handlers run in a thread pool
        # called with a session id after each change a participant's page shows (a trial started or
        # ended, an answer recorded), outside the lock, on the caller's thread (server/api/participant_answers.py)
        self.on_change = lambda session_id: None

    # -- studies ----------------------------------------------------------------------------
    def _load(self, path: Path) -> Study:
        """A study file, parsed once per version of the file (answers look their question up)."""
        stamp = path.stat().st_mtime_ns
        cached = self._studies.get(path)
        if cached is None or cached[0] != stamp:
            try:
                cached = (stamp, load_study(path), None)
            except StudyError as exc:
                cached = (stamp, None, exc)
            self._studies[path] = cached
        if cached[2] is not None:
            raise cached[2]
        return cached[1]

    def studies(self) -> list[dict]:
        """Every study file in the studies directory; a broken one is listed with its error."""
        out = []
        for path in sorted(self.studies_dir.glob("*.toml")):
            try:
                study = self._load(path)
                out.append({"file": path.name, "id": study.id, "title": study.title,
                            "participants": study.participants, "tasks": [t.id for t in study.tasks]})
            except StudyError as exc:
                out.append({"file": path.name, "error": str(exc)})
        return out

    def study(self, study_id: str) -> Study:
        for path in sorted(self.studies_dir.glob("*.toml")):
            try:
                study = self._load(path)
            except StudyError:
                continue
            if study.id == study_id or path.stem == study_id:
                return study
        raise NotFound(f"unknown study {study_id!r} (studies in {self.studies_dir}: "
                       f"{', '.join(s.get('id', s['file']) for s in self.studies()) or 'none'})")

    # -- sessions ---------------------------------------------------------------------------
    def create_session(self, *, study_id: str, participant: str, experimenter: str, device: str | None = None,
                       notes: str = "", participant_index: int | None = None, site: str | None = None) -> dict:
        """A new session with its plan; returns it with the control token."""
        if (problem := participant_code_problem(participant)) is not None:
            raise ExperimentError(problem)
        if not experimenter or len(experimenter) > 64:
            raise ExperimentError("experimenter must be 1-64 characters")
        study = self.study(study_id)
        with self._lock:
            if participant_index is None:  # the next row of the counterbalancing
                participant_index = sum(1 for s in self.store.sessions() if s["study_id"] == study.id)
            if participant_index < 0:
                raise ExperimentError("participant_index must be >= 0")
            plan = [p.to_dict() for p in plan_session(study, participant_index)]
            session_id = uuid.uuid4().hex[:12]
            try:
                self.store.create_session(
                    session_id=session_id, study_id=study.id, study_title=study.title, study_hash=study.source_hash,
                    study_text=self._study_text(study), participant=participant,
                    participant_index=participant_index, device=device, experimenter=experimenter, notes=notes,
                    software_version=self.software_version, config=self.config, plan=plan, site=site)
            except Conflict as exc:
                raise ExperimentError(str(exc)) from None
            token = self._tokens[session_id] = secrets.token_urlsafe(16)
            self._holders[session_id] = (experimenter, self.store.utc())
        return {**self.session(session_id), "token": token}

    def _study_text(self, study: Study) -> str:
        """The file text of the study (stored with the session: what exactly ran)."""
        for path, (_, loaded, _) in self._studies.items():
            if loaded is not None and loaded.source_hash == study.source_hash:
                return path.read_text()
        return ""

    def session(self, session_id: str, site: str | None = None) -> dict:
        """The session with its queue: every trial with its status and answers."""
        session = self._visible(session_id, site)
        trials = self.store.trials(session_id)
        session.pop("study_text", None)
        off = self.store.devices_off(session_id)  # (trial id, attempt) → devices that were off (recorder events)
        queue = [{**t.to_dict(), "responses": self.store.responses(t.id), "device_off": off.get((t.id, t.attempt), [])}
                 for t in trials]
        nxt = next((t for t in trials if t.status == "pending"), None)
        running = next((t for t in trials if t.status == "running"), None)
        return {**session, "trials": queue, "next": None if nxt is None else nxt.seq,
                "running": None if running is None else running.seq, "controlled": session_id in self._tokens,
                "now_utc": self.store.utc()}

    def _visible(self, session_id: str, site: str | None) -> dict:
        """The session's row, if the caller's `site` scope may see it (NotFound otherwise)."""
        try:
            session = self.store.session(session_id)
        except StoreError as exc:
            raise NotFound(str(exc)) from None
        if site is not None and session.get("site") != site:
            raise NotFound(f"unknown session {session_id!r}")  # another lab's: not seen to exist
        return session

    def _check_site(self, session_id: str, site: str | None) -> None:
        """A change by a lab's experimenter: only to its own lab's sessions. The admin (None) is
        not checked here, so a change without the control token stays a 403 for it."""
        if site is not None:
            self._visible(session_id, site)

    def site_of(self, session_id: str) -> str | None:
        """The lab a session belongs to (NotFound for an unknown one)."""
        return self._visible(session_id, None).get("site")

    def recording(self) -> str | None:
        """The session whose trial is being recorded right now, or None (the rig is then free)."""
        active = self.recorder.active
        return None if active is None else active.session_id

    def control(self, session_id: str, token: str | None, site: str | None = None) -> dict:
        """Who controls the session, and whether `token` is the current one (read-only)."""
        self._visible(session_id, site)
        current = self._tokens.get(session_id)
        experimenter, since = self._holders.get(session_id, (None, None))
        return {"controlled": current is not None, "experimenter": experimenter, "since": since,
                "yours": bool(current and token and secrets.compare_digest(token, current))}

    def control_token(self, session_id: str) -> str | None:
        """The session's current control token, or None: the pacer (server/api/paced_sessions.py) moves a
        participant-paced task on for the console that holds it, and only while one does."""
        return self._tokens.get(session_id)

    def sessions(self, site: str | None = None) -> list[dict]:
        return self.store.sessions(site)

    def take_control(self, session_id: str, experimenter: str, site: str | None = None) -> str:
        """A new control token for this console; the previous one stops working."""
        self._visible(session_id, site)
        with self._lock:
            token = self._tokens[session_id] = secrets.token_urlsafe(16)
            self._holders[session_id] = (experimenter, self.store.utc())
        self.store.add_events([(session_id, None, None, None, "control", {"experimenter": experimenter})])
        return token

    def _check_token(self, session_id: str, token: str | None) -> None:
        current = self._tokens.get(session_id)
        if current is None:
            raise Forbidden(f"session {session_id} has no controlling console; take control first")
        if not token or not secrets.compare_digest(token, current):
            raise Forbidden("this console does not control the session (another took control); take control again "
                            "to drive it")

    def _trial(self, session_id: str, seq: int) -> TrialRow:
        trial = self.store.trial_at(session_id, seq)
        if trial is None:
            raise NotFound(f"session {session_id} has no trial {seq}")
        return trial

    # -- the recorder's rows and interruptions ------------------------------------------------
    def flush(self) -> TrialRow | None:
        """Write the running trial's rows; end an attempt a loop restart interrupted (returns it)."""
        self.recorder.flush()
        active = self.recorder.active
        if active is None or active.interrupted is None:
            return None
        with self._lock:
            ended = self._interrupted()
        if ended is not None:
            self.on_change(ended.session_id)
        return ended

    def _interrupted(self) -> TrialRow | None:
        """The recorded attempt could not go on (the recorder says why): rows to disk, trial pending."""
        active = self.recorder.active
        if active is None or active.interrupted is None:
            return None
        self.recorder.end()
        self.hub.set_recording(0)
        try:
            return self.store.interrupt(active.trial_id, active.interrupted, active.last_tick)
        except Conflict:  # ended meanwhile by other means: nothing left to interrupt
            return None

    # -- the lifecycle ------------------------------------------------------------------------
    def start(self, session_id: str, token: str | None, seq: int, force: bool = False, *,
              site: str | None = None) -> dict:
        """Start trial `seq`, which must be the session's next pending trial. A trial that presents
        the scenario is refused (DeviceMissing, 409) when a device it needs is not connected,
        unless `force` (or the server runs with --force)."""
        with self._lock:
            self._check_site(session_id, site)
            self._check_token(session_id, token)
            trial = self._trial(session_id, seq)
            nxt = self.store.next_pending(session_id)
            if nxt is None or nxt.seq != seq:
                where = "no trial is pending" if nxt is None else f"the next pending trial is {nxt.seq}"
                raise Conflict(f"trial {seq} is {trial.status}; {where}")
            running = self.store.running()
            if running is not None:
                raise Conflict(f"trial {running.seq} of session {running.session_id} is still running")
            psy = self._psy_next(trial)
            if psy is not None:  # the levels the procedure chose, presented as C1 trial params
                trial = replace(trial, params=psy["params"], scenario_params=psy["scenario_params"])
            self._prepare_loop(trial, force)
            if trial.kind != "questionnaire":  # checked before anything is recorded: a refusal changes nothing
                self.hub.require_devices(trial.scenario, force or self.force_scenarios)
            # which devices the trial needs: the recorder flags it while none that shows a dimension is connected
            needs = self.hub.devices_needed(trial.scenario) if trial.kind != "questionnaire" else {}
            if psy is not None:
                self.store.present(trial.id, trial.params, trial.scenario_params)
            started = self.store.transition(trial.id, "running", expect="pending")
            self.recorder.begin(session_id, started.id, started.attempt, self._trial_phase(started), started.index,
                                needs=needs)
            self.hub.set_recording(self.record_every)
            self._set_trial(started)
        self.on_change(session_id)
        return {**started.to_dict(), "psy": psy["psy"]} if psy is not None else started.to_dict()

    # -- psychophysics tasks -------------------------------------------------------------------
    def _psy_context(self, trial: TrialRow):
        """(task's PsyTask, its Seeds, its answered main trials' C3 records) for a trial of a
        psychophysics task that presents a stimulus, else None."""
        if trial.kind not in SCENARIO_TRIAL_KINDS:
            return None
        session = self.store.session(trial.session_id)
        study = self.study(session["study_id"])
        psy = study.task(trial.task).psychophysics
        if psy is None:
            return None
        seeds = Seeds(study.seed, session["participant_index"], trial.task)
        return psy, seeds, self._psy_answered(trial.session_id, trial.task)

    def _psy_answered(self, session_id: str, task_id: str) -> list[dict]:
        """The C3 records of a task's main trials that were answered (excluded afterwards too: the
        track is what the participant went through), in session order."""
        return [t.metrics["psy"] for t in self.store.trials(session_id)
                if t.task == task_id and t.kind == "main" and "psy" in t.metrics]

    def _psy_next(self, trial: TrialRow) -> dict | None:
        context = self._psy_context(trial)
        if context is None:
            return None
        psy, seeds, answered = context
        nxt = next_trial(psy, seeds, answered, trial.kind, trial.index, trial.scenario_params)
        if nxt is None:  # finished before this trial (a crash between the last answer and the exclusions)
            self._skip_rest(trial.session_id, trial.task)
            raise Conflict(f"trial {trial.seq}: the task's procedure has finished; its remaining trials are excluded")
        return nxt

    def _psy_finish(self, trial: TrialRow, answer: Any) -> tuple[dict | None, bool]:
        """The finished trial's C3 record and whether the procedure has finished with it."""
        context = self._psy_context(trial)
        if context is None:
            return None, False
        psy, seeds, answered = context
        procedure = track(psy, seeds, answered) if trial.kind == "main" else None  # replayed once, moved on by the answer
        presented = next_trial(psy, seeds, answered, trial.kind, trial.index, trial.scenario_params, procedure)
        return conclude(psy, seeds, answered, presented["psy"], answer, trial.kind, procedure)

    def _skip_rest(self, session_id: str, task_id: str) -> None:
        for t in self.store.trials(session_id):
            if t.task == task_id and t.kind == "main" and t.status == "pending":
                self.store.skip(t.id, EXCLUDED_REASON)
        if self.store.next_pending(session_id) is None:
            self.store.set_session_status(session_id, "completed")

    def tracks(self, session_id: str, site: str | None = None) -> dict:
        """Every psychophysics task of the session with its track so far (Contract C4)."""
        session = self._visible(session_id, site)
        study = self.study(session["study_id"])
        trials = self.store.trials(session_id)
        out = []
        for task_id in dict.fromkeys(t.task for t in trials):
            psy = study.task(task_id).psychophysics
            if psy is None:
                continue
            done = [t for t in trials if t.task == task_id and t.kind == "main" and "psy" in t.metrics]
            procedure = track(psy, Seeds(study.seed, session["participant_index"], task_id),
                              [t.metrics["psy"] for t in done])
            names = list(psy.conditions) or ["main"]
            conditions = []
            for name in names:
                sub = procedure.procedures[name] if psy.conditions else procedure
                rows = [{"seq": t.seq, "level": t.metrics["psy"]["level"], "answer": t.metrics["psy"]["answer"],
                         "correct": t.metrics["psy"]["correct"], "reversal": t.metrics["psy"]["reversal"]}
                        for t in done if (t.metrics["psy"]["condition"] or "main") == name]
                estimate = sub.estimate()
                conditions.append({"name": name, "finished": bool(sub.finished),
                                   "estimate": estimate if estimate is None or isinstance(estimate, dict)
                                   else float(estimate), "trials": rows})
            out.append({"task": task_id, "design": psy.design.name, "parameter": psy.parameter, "unit": psy.unit,
                        "procedure": psy.procedure_kind, "finished": bool(procedure.finished),
                        "conditions": conditions})
        return {"session": session_id, "tasks": out}

    def _prepare_loop(self, trial: TrialRow, force: bool = False) -> None:
        state = self.hub.scenario_target or {}
        if state.get("id") != trial.scenario or state.get("params") != trial.scenario_params:
            self.hub.switch_scenario(trial.scenario, dict(trial.scenario_params), self._seed(trial),
                                     force=self.force_scenarios or force)

    def _seed(self, trial: TrialRow) -> int:
        session = self.store.session(trial.session_id)
        return session["participant_index"]  # the scenario's own random choices differ per participant

    @staticmethod
    def _trial_phase(trial: TrialRow) -> str | None:
        """The scenario trial phase of a planned item, or None: trial-phase and main trials, and
        training items that present something (the texture task's reference extremes), are
        scenario trials; plain training is free exploration, a questionnaire leaves the scene be."""
        if trial.kind in SCENARIO_TRIAL_KINDS or (trial.kind == "training" and trial.params):
            return trial.kind
        return None

    def _set_trial(self, trial: TrialRow) -> None:
        phase = self._trial_phase(trial)
        if phase is None:
            self.hub.set_trial(None)
        else:
            self.hub.set_trial(phase, dict(trial.params), trial.index, force=True)  # devices checked in start

    def answer(self, session_id: str, token: str | None, seq: int, question: str, value: Any,
               entered_by: str, *, site: str | None = None) -> dict:
        """Record one answer of a running or answered trial (checked against its question)."""
        with self._lock:
            self._check_site(session_id, site)
            self._check_token(session_id, token)
            trial = self._trial(session_id, seq)
            if trial.status not in ("running", "answered"):
                raise Conflict(f"trial {seq} is {trial.status}; answers go to a running or answered trial")
            if trial.status == "answered" and question == QUESTION_ID and "psy" in trial.metrics:
                raise Conflict(f"trial {seq}: its answer chose the procedure's next level; it cannot change now")
            value = self._record(trial, question, value, entered_by)
        self.on_change(session_id)
        return {"seq": seq, "question": question, "value": value}

    def _record(self, trial: TrialRow, question: str, value: Any, entered_by: str,
                unasked: type[ExperimentError] = ExperimentError) -> Any:
        """Check one answer against its question and store it (the caller holds the lock)."""
        if question not in trial.questions:
            raise unasked(f"trial {trial.seq} asks {', '.join(trial.questions) or 'no questions'}; not {question!r}")
        q = self._question(trial, question)
        try:
            value = q.check(value)
        except AnswerError as exc:
            raise ExperimentError(str(exc)) from None
        self.store.put_response(trial.id, question, value, entered_by)
        return value

    def _question(self, trial: TrialRow, question: str):
        return self.study(self.store.session(trial.session_id)["study_id"]).task(trial.task).question(question)

    def participant_answer(self, session_id: str, seq: int, question: str, value: Any) -> dict:
        """A participant's own answer (protocol `answer`): the session is the participant token's,
        so no control token; only while trial `seq` runs, and only to a question the study marks
        `answered_by = "participant"` (Forbidden otherwise). Checked and stored as `answer` does,
        with entered_by "participant"."""
        with self._lock:
            trial = self._trial(session_id, seq)
            if trial.status != "running":
                raise Conflict(f"trial {seq} is {trial.status}; a participant answers while its trial runs")
            if question in trial.questions and self._question(trial, question).answered_by != "participant":
                raise Forbidden(f"question {question!r} is answered by the experimenter")
            value = self._record(trial, question, value, "participant", unasked=Conflict)
        self.on_change(session_id)
        return {"seq": seq, "question": question, "value": value}

    def participant_view(self, session_id: str) -> dict:
        """What the session's participant is asked now (protocol `ask`; participant.py)."""
        session = self._visible(session_id, None)
        trials = self.store.trials(session_id)
        running = next((t for t in trials if t.status == "running"), None)
        try:
            study = self.study(session["study_id"])
        except NotFound:
            study = None
        return participant_view(session_id, study, trials, self.store.responses(running.id) if running else {})

    def finish(self, session_id: str, token: str | None, seq: int, *, site: str | None = None) -> dict:
        """The running trial is done: answered (every required question has its answer)."""
        with self._lock:
            self._check_site(session_id, site)
            self._check_token(session_id, token)
            trial = self._running(session_id, seq)
            study = self.study(self.store.session(session_id)["study_id"])
            answers = self.store.responses(trial.id)
            task = study.task(trial.task)
            missing = [q for q in trial.questions if task.question(q).required and q not in answers]
            if missing:
                raise Conflict(f"trial {seq} still needs an answer to {', '.join(missing)}")
            record, finished = self._psy_finish(trial, answers.get(QUESTION_ID))
            ended = self._end(trial, "answered", extra={"psy": record} if record is not None else None)
            if finished:  # the procedure stopped: its reserved trials left will not run
                self._skip_rest(session_id, trial.task)
        self.on_change(session_id)
        return ended

    def abort(self, session_id: str, token: str | None, seq: int, reason: str = "", *,
              site: str | None = None) -> dict:
        with self._lock:
            self._check_site(session_id, site)
            self._check_token(session_id, token)
            ended = self._end(self._running(session_id, seq), "aborted", reason)
        self.on_change(session_id)
        return ended

    def _running(self, session_id: str, seq: int) -> TrialRow:
        trial = self._trial(session_id, seq)
        if trial.status != "running":
            raise Conflict(f"trial {seq} is {trial.status}, not running")
        return trial

    def _end(self, trial: TrialRow, status: str, reason: str = "", extra: dict | None = None) -> dict:
        active = self.recorder.active
        if active is not None and active.interrupted is not None and active.trial_id == trial.id:
            self._interrupted()
            raise Conflict(f"trial {trial.seq} was interrupted ({active.interrupted}); it is pending again and "
                           f"runs as a new attempt when started")
        recorded = self.recorder.end()  # every row of the trial is on disk before it changes state
        self.hub.set_recording(0)
        self.hub.set_trial(None)
        mine = recorded is not None and recorded.trial_id == trial.id
        # the trial ends at the last tick it recorded: state records go on arriving while this
        # thread ends it, and a later tick would claim rows the recording never took
        last_tick = recorded.last_tick if mine and recorded.last_tick is not None else self._last_tick()
        metrics = {**(recorded.metrics if mine else {}), **(extra or {})}
        ended = self.store.transition(trial.id, status, expect="running", metrics=metrics,
                                      reason=reason, tick=last_tick,
                                      first_tick=recorded.first_tick if mine else None)
        if self.store.next_pending(trial.session_id) is None:
            self.store.set_session_status(trial.session_id, "completed")
        return ended.to_dict()

    def _last_tick(self) -> int | None:
        state = getattr(self.hub, "last_state", None)
        return None if state is None else state.get("tick")

    def exclude(self, session_id: str, token: str | None, seq: int, reason: str, *,
                site: str | None = None) -> dict:
        if not reason:
            raise ExperimentError("an exclusion needs a reason")
        with self._lock:
            self._check_site(session_id, site)
            self._check_token(session_id, token)
            trial = self._trial(session_id, seq)
            return self.store.transition(trial.id, "excluded", reason=reason).to_dict()

    def retry(self, session_id: str, token: str | None, seq: int, *, site: str | None = None) -> dict:
        """An aborted trial back to pending: it runs again (a new attempt) when it is next."""
        with self._lock:
            self._check_site(session_id, site)
            self._check_token(session_id, token)
            trial = self._trial(session_id, seq)
            if trial.status != "aborted":
                raise Conflict(f"trial {seq} is {trial.status}; only an aborted trial can be retried")
            self.store.set_session_status(session_id, "open")
            retried = self.store.transition(trial.id, "pending", expect="aborted", reason="retry").to_dict()
        self.on_change(session_id)
        return retried

    def set_notes(self, session_id: str, token: str | None, notes: str, *, site: str | None = None) -> None:
        with self._lock:
            self._check_site(session_id, site)
            self._check_token(session_id, token)
            self.store.set_notes(session_id, notes)
