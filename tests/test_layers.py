"""Every module and package under server/ sits in a layer of the import contract (pyproject.toml
[tool.importlinter]), so lint-imports checks what it may import: a module in no layer may import
anything, and nothing says so."""

import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _layered() -> set[str]:
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]
    layers = next(c for c in config["contracts"] if c["type"] == "layers")["layers"]
    return {name.strip() for line in layers for name in line.split("|")}


def _top_level(package: str) -> set[str]:
    names = set()
    for path in (ROOT / package).iterdir():
        if path.suffix == ".py" and path.stem != "__init__":
            names.add(f"{package}.{path.stem}")
        elif path.is_dir() and (path / "__init__.py").is_file():
            names.add(f"{package}.{path.name}")
    return names


def test_every_server_module_is_in_a_layer():
    layered = _layered()
    missing = sorted(_top_level("server") - layered)
    assert not missing, f"in no layer of pyproject.toml's layers contract: {', '.join(missing)}"


def test_the_other_root_packages_are_layers_whole():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]
    layered = _layered()
    for root in config["root_packages"]:
        if root != "server":
            assert root in layered, f"root package {root} is in no layer"
