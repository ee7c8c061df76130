"""No class in server/hub or server/loop has more than MAX_METHODS methods (issue 33: the hub was
one object of 40 methods; a part with one job stays small). Methods are the functions a class
body defines, properties and their setters included; nested classes are counted on their own."""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("server/hub", "server/loop")
MAX_METHODS = 20


def class_sizes() -> dict[str, int]:
    sizes = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(), str(path))):
                if isinstance(node, ast.ClassDef):
                    methods = [n for n in node.body if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))]
                    sizes[f"{path.relative_to(ROOT)}::{node.name}"] = len(methods)
    return sizes


def test_the_counter_sees_the_classes():
    sizes = class_sizes()
    assert sizes["server/hub/hub.py::Hub"] >= 2 and sizes["server/hub/control.py::ScenarioControl"] >= 10


def test_no_class_in_the_hub_or_the_loop_has_more_than_twenty_methods():
    over = {name: n for name, n in class_sizes().items() if n > MAX_METHODS}
    assert over == {}, f"classes with more than {MAX_METHODS} methods: {over}"
