"""The package's structure: who imports whom, where numba is, how long modules
are, and what the kernel cache's key covers.

Read from the sources with ``ast`` (function-local imports included), so
that a lazy import hidden in a function counts as much as one at the top.
"""

import ast
import shutil
import subprocess
import sys
from pathlib import Path

import networkx as nx
import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "mbdsl"
#: The packages of numba code: the element kernels and the step kernels.
KERNEL_PACKAGES = ("mbdsl.kernels", "mbdsl.integrators.compiled")


def _modules():
    """{module name: path} of every module of mbdsl."""
    out = {}
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def _imports(name, path, modules):
    """(imported module of mbdsl or None, top-level name) for every import
    statement of a module, anywhere in its body."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[:len(package.split(".")) - node.level + 1]
                stem = ".".join(base + ([node.module] if node.module else []))
            else:
                stem = node.module
            # ``from . import compiled`` imports the submodule; ``from .. import
            # assemble`` the package
            targets = [f"{stem}.{a.name}" if f"{stem}.{a.name}" in modules else stem
                       for a in node.names]
        else:
            continue
        for target in targets:
            top = target.split(".")[0]
            while target and target not in modules:
                target = target.rpartition(".")[0]
            yield (target or None), top


@pytest.fixture(scope="module")
def graph():
    modules = _modules()
    g = nx.DiGraph()
    tops = {}
    for name, path in modules.items():
        g.add_node(name)
        tops[name] = set()
        for target, top in _imports(name, path, modules):
            tops[name].add(top)
            if target is not None and target != name:
                g.add_edge(name, target)
    return g, tops


def _inside(name, packages):
    return any(name == p or name.startswith(p + ".") for p in packages)


def test_the_kernels_and_the_assembly_import_nothing_of_the_integrators(graph):
    """The element kernels and the assembled system sit below the integrators:
    nothing under ``mbdsl/kernels`` or ``mbdsl/assembly`` imports
    ``mbdsl.integrators`` (the assembly evaluates its elements on
    ``kernels.api``, chosen by ``kernels.cache``)."""
    g, _ = graph
    wrong = [(a, b) for a, b in g.edges
             if _inside(a, ("mbdsl.kernels", "mbdsl.assembly"))
             and _inside(b, ("mbdsl.integrators",))]
    assert wrong == []


def test_the_language_imports_nothing_of_the_later_stages(graph):
    """Parsing and checking a model file (``mbdsl.dsl``) reads the model's
    classes and the leaf registry of methods (names, coefficients and their
    ranges), never the assembly, the kernels or the integrators."""
    g, _ = graph
    wrong = [(a, b) for a, b in g.edges if _inside(a, ("mbdsl.dsl",))
             and _inside(b, ("mbdsl.integrators", "mbdsl.assembly", "mbdsl.kernels"))]
    assert wrong == []


def test_only_the_kernel_packages_import_numba(graph):
    """numba (and llvmlite) behind the kernel packages: a model is parsed,
    checked, assembled and written without them."""
    _, tops = graph
    users = sorted(m for m, t in tops.items() if t & {"numba", "llvmlite"})
    assert users and all(_inside(m, KERNEL_PACKAGES) for m in users), users


def test_the_kernel_packages_have_no_import_cycle(graph):
    g, _ = graph
    sub = g.subgraph([m for m in g if _inside(m, KERNEL_PACKAGES)])
    assert list(nx.simple_cycles(sub)) == []


#: Functions allowed over FUNCTION_LINES, each with why.
LONG_FUNCTIONS = {
    # the compiled time loop: its step's state lives in the function's locals; its
    # per-call set-up is in _run_flags and _start_estimate, but moving the step's
    # parts into inlined helpers (predictors, error estimate, acceptance) cost
    # 0.4 us a step (4.60 against 4.20 us on the double pendulum, hht-i3, measured):
    # each helper takes some twenty arrays, and numba counts their references
    "integrators/compiled/loop.py:_run": 125,
}
#: The most lines of code a function of mbdsl has, its docstring not counted: a
#: public function's numpydoc sections (parameters with shapes and units,
#: returns, raises, references) are documentation, not code to read through.
FUNCTION_LINES = 80
MODULE_LINES = 1000


def _code_lines(node) -> int:
    """A function's lines, less its docstring's."""
    lines = node.end_lineno - node.lineno + 1
    first = node.body[0]
    if (isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant)
            and isinstance(first.value.value, str)):
        lines -= first.end_lineno - first.lineno + 1
    return lines


def test_no_module_over_a_thousand_lines_and_no_function_over_eighty():
    """Limits that keep the package readable: no module of mbdsl over 1000
    lines, no function over 80 lines of code (its docstring not counted),
    but for ``LONG_FUNCTIONS``, each at most as long as its entry says."""
    long_modules, long_functions = {}, {}
    for path in PACKAGE.rglob("*.py"):
        text = path.read_text()
        rel = str(path.relative_to(PACKAGE))
        if len(text.splitlines()) > MODULE_LINES:
            long_modules[rel] = len(text.splitlines())
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = _code_lines(node)
                if n > LONG_FUNCTIONS.get(f"{rel}:{node.name}", FUNCTION_LINES):
                    long_functions[f"{rel}:{node.name}"] = n
    assert long_modules == {} and long_functions == {}


def _key(root):
    code = "from mbdsl.integrators.kernel_cache import _key; print(_key()['source'])"
    done = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True,
                          text=True, timeout=120, env={"PYTHONPATH": str(root),
                                                      "PATH": "/usr/bin:/bin"})
    assert done.returncode == 0, done.stderr
    return done.stdout.strip()


def test_the_cache_key_covers_every_kernel_file(tmp_path):
    """numba's cache does not see a change to a kernel of another file (numba
    issue #1833): the marker's key hashes every file of both kernel packages,
    so a change to any one of them, here a comment added to the torques'
    module in a copy of the package, rebuilds."""
    copy = tmp_path / "mbdsl"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc"))
    same = _key(tmp_path)
    assert same == _key(PACKAGE.parent)
    target = copy / "kernels" / "loads" / "torques.py"
    target.write_text(target.read_text() + "# a change\n")
    assert _key(tmp_path) != same
    step = copy / "integrators" / "compiled" / "newton.py"
    before = _key(tmp_path)
    step.write_text(step.read_text() + "# a change\n")
    assert _key(tmp_path) != before


#: The import cycles the package still has, each with why it is there (function-local
#: imports counted). A new cycle, or a module joining one of these, fails the test below.
KNOWN_CYCLES = {
    # the language: the expression parser is built from the grammar the spec's
    # transformer and the units checker share, and each calls back into the others
    frozenset({"mbdsl.dsl.expressions", "mbdsl.dsl.parser", "mbdsl.dsl.spec",
               "mbdsl.dsl.transformer", "mbdsl.dsl.units"}),
    # loading the compiled kernels runs a short simulation (numba loads a function's
    # signatures when it is first called), and the engine and the Python stepper ask
    # for the kernels to be loaded before they step
    frozenset({"mbdsl.integrators.driver", "mbdsl.integrators.engine",
               "mbdsl.integrators.kernel_cache", "mbdsl.integrators.python_stepper"}),
}


def test_no_import_cycle_beyond_the_known_ones(graph):
    g, _ = graph
    cycles = {frozenset(c) for c in nx.strongly_connected_components(g) if len(c) > 1}
    assert cycles <= KNOWN_CYCLES, sorted(sorted(c) for c in cycles - KNOWN_CYCLES)


def test_every_folder_of_the_package_is_a_package():
    """setuptools ships the packages it finds (``pyproject.toml``:
    ``packages.find``), and a folder without ``__init__.py`` is none: a
    source checkout imports it as a namespace package, an installed copy
    lacks it (``mbdsl plot`` would fail after ``pip install .``)."""
    from setuptools import find_packages
    found = set(find_packages(where=str(PACKAGE.parent), include=["mbdsl*"]))
    folders = {".".join(p.parent.relative_to(PACKAGE.parent).parts)
               for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts}
    assert folders <= found, sorted(folders - found)
