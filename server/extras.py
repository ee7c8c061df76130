"""The optional extras (pyproject.toml [project.optional-dependencies]) as the commands that need
one see them: the modules each extra brings, and the one line that says how to install it.

`viestac serve` with the simulated rig needs none of them; `viestac analyze` needs `analysis`,
`viestac study --power` needs `power`, `viestac bench` needs `bench`, a rig with an audio tactor needs `audio`. tests/test_extras.py checks
that these modules are the packages pyproject.toml lists.
"""

from __future__ import annotations

import importlib
import sys
from pathlib import Path

_ANALYSIS = ("scipy", "pingouin", "statsmodels", "pandas", "matplotlib")
EXTRA_MODULES: dict[str, tuple[str, ...]] = {
    "analysis": _ANALYSIS,
    "power": (*_ANALYSIS, "dask", "distributed"),  # the power table is analysed as `viestac analyze` does
    "bench": ("scipy", "matplotlib"),               # quantile intervals, the sweeps' charts
    "audio": ("sounddevice", "jack"),               # audio-interface tactors; JACK captures in the tests
}

_CHECKOUT = Path(__file__).resolve().parents[1]  # an editable install's checkout (pyproject.toml there)


def install_command(extra: str) -> str:
    """The pip command that installs `extra` into the Python that runs this."""
    target = f"-e '{_CHECKOUT}[{extra}]'" if (_CHECKOUT / "pyproject.toml").exists() else f"'viestac[{extra}]'"
    return f"{sys.executable} -m pip install {target}"


def missing(extra: str) -> str | None:
    """The first module of `extra` that does not import, or None when the extra is installed."""
    for name in EXTRA_MODULES[extra]:
        try:
            importlib.import_module(name)
        except ImportError:
            return name
    return None


def needs(command: str, extra: str) -> str | None:
    """The one line saying that `command` needs `extra` and how to install it; None when it is there."""
    module = missing(extra)
    if module is None:
        return None
    return f"{command} needs the {extra} extra ({module} is missing): {install_command(extra)}"
