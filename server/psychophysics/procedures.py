"""Every procedure, parsed from a plain dict by its `kind`, started from a seed, replayed from
answers. The next stimulus is a pure function of (spec, seed, answers so far):

    next_level(spec, answers, seed)  ==  replay(spec, answers, seed).level

so a session that crashed resumes exactly from its recorded answers, and a simulated study runs
the same code. Each running procedure has `level` (or `stimulus`), `update(answer)`, `finished`,
`estimate()` and `record()` (the state after the last trial as plain data, to be recorded).
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

from server.core.did_you_mean import did_you_mean
from server.psychophysics.constant import ConstantSpec, ConstantStimuli
from server.psychophysics.interleave import Interleaved, InterleavedSpec
from server.psychophysics.questplus import QuestPlusSpec, quest_plus
from server.psychophysics.spec import Fields, SpecError
from server.psychophysics.staircase import Staircase, StaircaseSpec

# kind → (parse, start)
PROCEDURES = {
    "constant": (ConstantSpec.parse, ConstantStimuli),
    "up-down": (StaircaseSpec.parse, Staircase),
    "weighted-up-down": (StaircaseSpec.parse, Staircase),
    "quest-plus": (QuestPlusSpec.parse, quest_plus),
}


def parse_procedure(table: Mapping[str, Any], where: str = "procedure"):
    """A spec from a plain dict; SpecError names the field (and suggests the kind or field meant)."""
    if not isinstance(table, Mapping):
        raise SpecError(f"{where}: expected a table, got {type(table).__name__}")
    kind = table.get("kind")
    if kind is None:
        raise SpecError(f"{where}: kind: missing (required){did_you_mean('', [*PROCEDURES, 'interleaved'])}")
    if kind == "interleaved":
        f = Fields(table, where)
        f.choice("kind", ("interleaved",))
        conditions = f.table_of("conditions")
        f.done()
        if not conditions:
            raise f.error("conditions", "needs at least one condition")
        return InterleavedSpec(tuple((str(name), parse_procedure(sub, f'{where}: condition "{name}"'))
                                     for name, sub in conditions.items()))
    if kind not in PROCEDURES:
        raise SpecError(f"{where}: kind: unknown procedure {kind!r}{did_you_mean(str(kind), [*PROCEDURES, 'interleaved'])}")
    return PROCEDURES[kind][0](table, where)


def start(spec, seed=0):
    """A fresh running procedure."""
    if isinstance(spec, InterleavedSpec):
        return Interleaved(spec, seed, start=start)
    return PROCEDURES[spec.kind][1](spec, seed)


def replay(spec, answers: Sequence, seed=0):
    """The procedure after these answers, each to the stimulus it chose."""
    procedure = start(spec, seed)
    for answer in answers:
        procedure.update(answer)
    return procedure


def next_level(spec, answers: Sequence, seed=0):
    """The next stimulus's level after these answers (None: the procedure has finished)."""
    return replay(spec, answers, seed).level
