"""Without the compiled core the server runs the Python reference, and says so."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

PROBE = """
import sys, warnings
sys.modules["server.core.haptics._chaptics"] = None  # as if the extension was never built
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    from server.core.haptics import compiled, contact_gate, god_object
from server.core.haptics.primitives import Body, Plane
assert not compiled.COMPILED and compiled.chaptics is None
assert god_object.GodObject is god_object.ReferenceGodObject
assert contact_gate.ContactGate is contact_gate.ReferenceContactGate
assert [str(w.message) for w in caught if issubclass(w.category, RuntimeWarning)
        and "not built" in str(w.message)], [str(w.message) for w in caught]
step = god_object.GodObject(0.0).step([Body("g", Plane((2.0, 2.0)))], (0.0, 0.0, -0.01))
assert step.proxy == (0.0, 0.0, 0.0) and step.contacts
print("reference")
"""


def test_a_missing_extension_falls_back_to_the_reference_with_a_warning():
    out = subprocess.run([sys.executable, "-c", PROBE], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "reference"
