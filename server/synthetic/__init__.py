"""Synthetic participants: seeded observer models that answer a study's questions like a
participant of the thesis's study would (docs/synthetic.md).

    from server.synthetic import SyntheticParticipant, ObserverModels

    p = SyntheticParticipant(seed=1, participant=0)               # thesis-like defaults
    p.answer(planned_trial, question)                             # a value Question.check accepts
    p.produce_level(7, seq=planned_trial.seq)                     # magnitude production
    SyntheticParticipant(1, 0, ObserverModels().with_overrides({"identification.weber": 0.0}))
"""

from server.synthetic.models import (AngleEstimation, ForcedChoice, FrequencyIdentification, LikertRatings,
                                     ObserverModels, PowerLaw, TextureComparison)
from server.synthetic.participant import SyntheticParticipant
from server.synthetic.rng import derive_rng

__all__ = ["AngleEstimation", "ForcedChoice", "FrequencyIdentification", "LikertRatings", "ObserverModels",
           "PowerLaw", "SyntheticParticipant", "TextureComparison", "derive_rng"]
