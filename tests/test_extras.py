"""The optional extras (server/extras.py, pyproject.toml): the rig server runs without them, and a
command that needs one says in one line how to install it."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import pytest

from scenarios.registry import SCENARIOS
from server.extras import EXTRA_MODULES, install_command
from tests.live_server import get_json, start_server, stop_server

ROOT = Path(__file__).resolve().parents[1]
# A distribution whose import name differs from its name, or that brings another one with it.
IMPORTED_AS = {"dask[distributed]": ("dask", "distributed"), "JACK-Client": ("jack",)}

BLOCKER = '''
import sys

BLOCKED = {blocked!r}


class _Missing:
    """Every module of the extras fails to import, as in an install without them."""

    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in BLOCKED:
            raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)
        return None


sys.meta_path.insert(0, _Missing())
'''


def _modules(extra: str, declared: dict) -> set[str]:
    out = set()
    for requirement in declared[extra]:
        name = re.match(r"[A-Za-z0-9_.\-]+(\[[^\]]*\])?", requirement).group(0)
        if name.startswith("viestac["):
            for inner in name[len("viestac["):-1].split(","):
                out |= _modules(inner, declared)
        else:
            out |= set(IMPORTED_AS.get(name, (name.split("[")[0],)))
    return out


def test_the_extras_modules_are_the_packages_pyproject_lists():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    declared = project["optional-dependencies"]
    for extra, modules in EXTRA_MODULES.items():
        assert set(modules) == _modules(extra, declared), extra
    # the test extra brings every other one: the README's `scripts/setup.sh --test` installs everything
    assert set().union(*EXTRA_MODULES.values()) <= _modules("test", declared)
    required = {re.match(r"[A-Za-z0-9_.\-]+", r).group(0) for r in project["dependencies"]}
    assert not required & set().union(*EXTRA_MODULES.values()), "an extra's package is required by the server"


@pytest.fixture
def without_extras(tmp_path, monkeypatch):
    """PYTHONPATH for this test's processes (and theirs): the extras' modules do not import."""
    (tmp_path / "sitecustomize.py").write_text(BLOCKER.format(blocked=sorted(set().union(*EXTRA_MODULES.values()))))
    monkeypatch.setenv("PYTHONPATH", str(tmp_path))
    return tmp_path


def test_the_install_command_installs_this_checkout_with_the_extra_into_this_python():
    assert install_command("analysis") == f"{sys.executable} -m pip install -e '{ROOT}[analysis]'"


@pytest.mark.parametrize("args, line", [
    (["analyze", "nowhere", "--out", "report"], "viestac analyze needs the analysis extra (scipy is missing): "
                                                 + install_command("analysis")),
    (["study", "--power", "--participants", "8", "--out", "power"],
     "viestac study --power needs the power extra (scipy is missing): " + install_command("power")),
    (["bench", "floor", "--seconds", "0"], "viestac bench needs the bench extra (scipy is missing): "
                                            + install_command("bench")),
])
def test_a_command_without_its_extra_says_in_one_line_how_to_install_it(without_extras, args, line):
    result = subprocess.run([sys.executable, "-m", "server.cli", *args], capture_output=True, text=True,
                            timeout=120, cwd=without_extras)
    assert result.returncode == 2
    assert result.stderr == line + "\n" and result.stdout == ""


@pytest.mark.slow
def test_the_rig_server_serves_every_scenario_without_the_extras(without_extras):
    proc, base = start_server("contact-angle", extra=["--rig", "fingertac,ferrovibe,devkit"])
    try:
        for spec in SCENARIOS.values():
            answer = get_json(base + "/api/scenario", "POST", body={"name": spec.id, "params": {}})
            deadline = time.monotonic() + 60
            while get_json(base + "/api/scenario").get("id") != answer["id"]:
                assert time.monotonic() < deadline, f"the loop did not switch to {spec.id}"
                time.sleep(0.05)
        assert get_json(base + "/api/health")["status"] == "ok"
        assert proc.poll() is None
    finally:
        stop_server(proc)


# What a checkout needs to install and serve (no tests, no clients' npm packages, nothing built).
_NOT_THE_CHECKOUT = shutil.ignore_patterns(".git", ".venv", "node_modules", "__pycache__", "*.so", "build",
                                           "*.egg-info", "tests", "clients", ".pytest_cache", ".hypothesis")


@pytest.mark.slow
def test_a_fresh_venv_without_extras_serves_the_rig_and_analyze_says_how_to_get_them(tmp_path, monkeypatch):
    """The checkout pip-installed without extras into a venv of its own (no system site packages;
    packages from pip's cache or the registry), as a lab that only runs a rig would."""
    checkout = tmp_path / "viestac"
    shutil.copytree(ROOT, checkout, ignore=_NOT_THE_CHECKOUT)
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, timeout=120)
    python = str(venv / "bin" / "python")
    install = subprocess.run([python, "-m", "pip", "install", "-q", "--disable-pip-version-check", "-e",
                              str(checkout)], capture_output=True, text=True, timeout=900)
    assert install.returncode == 0, install.stdout + install.stderr
    listed = subprocess.run([python, "-m", "pip", "list", "--format=freeze"], capture_output=True, text=True,
                            check=True).stdout.lower()
    assert not [m for m in set().union(*EXTRA_MODULES.values()) if f"\n{m}==" in f"\n{listed}"]

    monkeypatch.chdir(tmp_path)  # `python -m` imports from the working directory first: not from this checkout
    proc, base = start_server("contact-angle", python=python, timeout_s=120)
    try:
        assert get_json(base + "/api/health")["status"] == "ok"
        assert {d["status"] for d in get_json(base + "/api/devices")["devices"]} == {"connected"}
    finally:
        stop_server(proc)

    analyze = subprocess.run([str(venv / "bin" / "viestac"), "analyze", str(tmp_path / "data"), "--out",
                              str(tmp_path / "report")], capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert analyze.returncode == 2 and analyze.stdout == ""
    assert analyze.stderr == (f"viestac analyze needs the analysis extra (scipy is missing): "
                              f"{python} -m pip install -e '{checkout}[analysis]'\n")
