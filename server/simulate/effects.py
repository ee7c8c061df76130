"""Effect settings of the synthetic participants: `--set KEY=VALUE` of `viestac study`.

A simulated study's participants are the observer models (server/synthetic: the answers) and
the positioning agent (server/simulate/agent.py: movements). A setting changes one parameter:

- `MODEL.FIELD=VALUE`: an observer model's field, e.g. `estimation.b=0.9`,
  `identification.weber=0.2` (ObserverModels.with_overrides, which validates it);
- `agent.FIELD=VALUE`: the positioning agent's, for every device, e.g. `agent.endpoint_noise=0.08`;
- `agent.DEVICE.FIELD=VALUE`: the agent's with one device only (fingertac, ferrovibe): a device
  effect, e.g. `agent.ferrovibe.duration_scale=1.3` makes every movement with the FerroVibe take
  30 % longer, so its positioning trials take longer than the FingerTac's.
- `psychometric=NAME`: the psychophysics observers' population (server/synthetic/psychometric.py
  PRESETS: `default`, or `literature`, the battery's: docs/battery.md); its fields may follow,
  e.g. `psychometric.minimum_db=-30`.

docs/synthetic.md ("Effect settings") lists them. Settings are kept as sorted text pairs, so the
same settings in any order describe the same population (the power store compares them).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Mapping, Sequence

from server.simulate.agent import AgentParams
from server.simulate.study_run import RIG
from server.synthetic import ObserverModels, SyntheticParticipant


@dataclass(frozen=True)
class Population:
    """Who the synthetic participants are: observer models and the agent per device model."""
    models: ObserverModels = field(default_factory=ObserverModels)
    agent: Mapping[str, AgentParams] = field(default_factory=lambda: {m: AgentParams() for m in RIG})
    settings: tuple[tuple[str, str], ...] = ()

    def participant(self, seed: int, index: int) -> SyntheticParticipant:
        return SyntheticParticipant(seed, participant=index, models=self.models)


def parse_settings(pairs: Sequence[str]) -> Population:
    """A Population from KEY=VALUE texts; ValueError naming the bad one."""
    settings: dict[str, str] = {}
    for text in pairs:
        key, sep, value = text.partition("=")
        key, value = key.strip(), value.strip()
        if not sep or not key or not value:
            raise ValueError(f"--set {text!r}: give KEY=VALUE, e.g. agent.ferrovibe.duration_scale=1.3")
        if key in settings:
            raise ValueError(f"--set {key} is given twice")
        settings[key] = value
    return population(settings)


def population(settings: Mapping[str, str]) -> Population:
    models: dict[str, str] = {}
    agent: dict[str, dict[str, float]] = {m: {} for m in RIG}
    fields = {f.name for f in dataclasses.fields(AgentParams)}
    for key, value in settings.items():
        parts = key.split(".")
        if key == "psychometric":  # a named population of psychometric observers (psychometric.PRESETS)
            continue
        if parts[0] != "agent":
            models[key] = value
            continue
        if len(parts) == 2:
            devices, name = RIG, parts[1]
        elif len(parts) == 3 and parts[1] in RIG:
            devices, name = (parts[1],), parts[2]
        else:
            raise ValueError(f"--set {key}: give agent.FIELD or agent.DEVICE.FIELD (devices: {', '.join(RIG)})")
        if name not in fields:
            raise ValueError(f"--set {key}: the agent has no field {name!r} (fields: {', '.join(sorted(fields))})")
        try:
            number = float(value)
        except ValueError:
            raise ValueError(f"--set {key} must be a number, got {value!r}") from None
        for device in devices:
            if name in agent[device] and len(parts) == 2:
                continue  # a device's own setting wins over the one for every device
            agent[device][name] = number
    try:
        params = {device: AgentParams(**changes) for device, changes in agent.items()}
        base = ObserverModels()
        if "psychometric" in settings:
            base = dataclasses.replace(base, psychometric=_psychometric_preset(settings["psychometric"]))
        return Population(base.with_overrides(models), params, tuple(sorted(settings.items())))
    except ValueError as exc:
        raise ValueError(f"--set: {exc}") from None


def _psychometric_preset(name: str):
    from server.synthetic.psychometric import PRESETS

    if name not in PRESETS:
        raise ValueError(f"psychometric={name}: no such population (known: {', '.join(PRESETS)})")
    return PRESETS[name]
