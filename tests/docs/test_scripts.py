"""The scripts shipped beside the docs (``examples/``, ``docs/**/*.py``) read
mbdsl's API as it is: every ``from mbdsl... import name`` of theirs names a
module and a name that exist (a script is run by hand, so a module that
moved would otherwise break it unnoticed)."""

import ast
import importlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = sorted(list((ROOT / "examples").glob("*.py")) + list((ROOT / "docs").rglob("*.py")))


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: str(p.relative_to(ROOT)))
def test_a_shipped_script_imports_what_exists(script):
    tree = ast.parse(script.read_text())
    found = 0
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == "mbdsl":
            module = importlib.import_module(node.module)
            for alias in node.names:
                assert hasattr(module, alias.name) or importlib.util.find_spec(
                    f"{node.module}.{alias.name}") is not None, (node.module, alias.name)
                found += 1
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == "mbdsl":
                    importlib.import_module(alias.name)
                    found += 1
    assert found or "mbdsl" in script.read_text(), f"{script.name} does not use mbdsl"
