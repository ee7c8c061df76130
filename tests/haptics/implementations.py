"""The two implementations of the haptic core every god-object and gate test runs against: the
Python reference and the compiled core (skipped, with the reason, when the extension is not built)."""

from __future__ import annotations

import pytest

from server.core.haptics import contact_gate, god_object
from server.core.haptics.compiled import COMPILED

NOT_BUILT = "the compiled haptic core is not built (pip install -e .)"

GOD_OBJECTS = [pytest.param(god_object.ReferenceGodObject, id="reference"),
               pytest.param(getattr(god_object, "CompiledGodObject", None), id="compiled",
                            marks=pytest.mark.skipif(not COMPILED, reason=NOT_BUILT))]
GATES = [pytest.param(contact_gate.ReferenceContactGate, id="reference"),
         pytest.param(contact_gate.ContactGate, id="compiled",
                      marks=pytest.mark.skipif(not COMPILED, reason=NOT_BUILT))]
