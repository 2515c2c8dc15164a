"""The package's structure: who imports whom, where numba is, how long modules
are, and what the kernel cache's key covers.

Read from the sources with ``ast`` (function-local imports included), so
that a lazy import hidden in a function counts as much as one at the top.
"""

import ast
import re
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
    # a function imported from outside: its name enters the key, not its repr (which
    # holds an address that differs per process: every process would rebuild)
    target.write_text(target.read_text() + "from mbdsl.model.elements import line_columns\n")
    assert _key(tmp_path) == _key(tmp_path)
    step = copy / "integrators" / "compiled" / "newton.py"
    before = _key(tmp_path)
    step.write_text(step.read_text() + "# a change\n")
    assert _key(tmp_path) != before
    # a value the kernels import from outside both packages (numba freezes it into the
    # machine code): a swap of two record places changes the key, a comment there does not
    records = copy / "integrators" / "records.py"
    text = records.read_text()
    before = _key(tmp_path)
    records.write_text(text + "# a comment\n")
    assert _key(tmp_path) == before
    records.write_text(text.replace("LU_VALID, LU_RATE, LU_STEP, LU_C0 = range(4)",
                                    "LU_RATE, LU_VALID, LU_STEP, LU_C0 = range(4)")
                       .replace('LU_FIELDS = ("valid", "rate", "step", "c0")',
                                'LU_FIELDS = ("rate", "valid", "step", "c0")'))
    assert _key(tmp_path) != before


def test_the_records_name_every_place():
    """The named places of the loop's vectors: each field list and its
    constants agree, and a record built by name has the field's value at the
    constant's place."""
    from mbdsl.integrators import records
    groups = {"ST_": records.STATE_FIELDS, "CTL_": records.CONTROL_FIELDS,
              "OPT_": records.OPTION_FIELDS, "LU_": records.LU_FIELDS,
              "LIN_": records.LIN_FIELDS, "LP_": records.LAPACK_FIELDS,
              "CNT_": records.COUNT_FIELDS}
    for prefix, fields in groups.items():
        constants = {k: v for k, v in vars(records).items()
                     if k.startswith(prefix) and isinstance(v, int)}
        assert sorted(constants.values()) == list(range(len(fields)))
        values = {name: float(10 * k + 1) for k, name in enumerate(fields)}
        vec = records.vector(fields, **values)
        for name in fields:
            assert vec[constants[prefix + name.upper()]] == values[name]
    with pytest.raises(ValueError, match="missing or unknown"):
        records.vector(records.LU_FIELDS, valid=1.0, rate=0.5, step=0.0)


def test_no_import_cycle_in_the_package(graph):
    """Function-local imports counted: the language reads an expression's text
    without the model's specs (``dsl/grammar.py``), and the kernel cache loads
    the kernels by a warm-up run it is handed, not one it imports
    (``integrators/warm_up.py``)."""
    g, _ = graph
    cycles = [sorted(c) for c in nx.strongly_connected_components(g) if len(c) > 1]
    assert cycles == []


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


#: The kinds of joint the language has (``dsl/check/tables.JOINT_KINDS``).
JOINT_KIND_NAMES = {"revolute", "fixed", "prismatic", "point_on_line", "distance"}


def _mentions_the_distance_joint(name, path, modules) -> bool:
    """Whether a module names the distance joint: compares a ``kind`` with
    "distance", keys a table of joint kinds by it, imports its kernels module,
    or names its fields (``kernels.schema``'s DROW, ...) or a class of it."""
    from mbdsl.kernels.joints import distance
    fields = {f.upper() for f in distance.FIELDS}
    family = "mbdsl.kernels.joints.distance"

    def names_kind(node):
        return isinstance(node, ast.Constant) and node.value == "distance" or (
            isinstance(node, (ast.Tuple, ast.List, ast.Set)) and any(names_kind(e)
                                                                     for e in node.elts))

    def is_kind(node):
        return (isinstance(node, ast.Attribute) and node.attr == "kind") or (
            isinstance(node, ast.Name) and node.id == "kind")

    if name != family and any(t == family for t, _ in _imports(name, path, modules)):
        return True
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Compare):
            sides = [node.left, *node.comparators]
            if any(map(is_kind, sides)) and any(map(names_kind, sides)):
                return True
        elif isinstance(node, ast.Dict):
            keys = {k.value for k in node.keys if isinstance(k, ast.Constant)}
            if "distance" in keys and keys <= JOINT_KIND_NAMES:
                return True
        elif isinstance(node, (ast.Name, ast.alias, ast.ClassDef)):
            ident = {ast.Name: "id", ast.alias: "name", ast.ClassDef: "name"}[type(node)]
            text = getattr(node, ident)
            if text in fields or "Distance" in text:
                return True
    return False


def test_element_data_have_one_representation():
    """Between the model's elements and the packed arrays there is no second
    copy of element data: no ``*Group`` class (the joints', loads', contacts'
    and beams' groups are gone; the families pack from the model), and what
    the assembly keeps of the contacts and the beams is their run state and
    where they sit, not their parameters."""
    groups = [f"{path.relative_to(PACKAGE)}:{node.name}" for path in PACKAGE.rglob("*.py")
              for node in ast.walk(ast.parse(path.read_text()))
              if isinstance(node, ast.ClassDef) and node.name.endswith("Group")]
    assert groups == []
    import mbdsl
    from mbdsl.assembly.ffr import BeamSet
    system = mbdsl.assemble(mbdsl.load(PACKAGE.parent / "models" / "slider_crank_clearance.mbd"))
    parameters = {"k", "k_", "n_", "chi", "c_", "mu", "v_reg", "geometry", "damped"}
    assert not parameters & set(vars(system.contact_state))
    assert BeamSet._fields == ("first", "beams", "cols")


def test_the_distance_joint_lives_where_the_architecture_says():
    """docs/architecture.md, "Adding a joint type", names the files a joint kind
    lives in, for the distance joint; the package's modules that name it (by
    the rules of ``_mentions_the_distance_joint``) are exactly those."""
    modules = _modules()
    found = {str(path.relative_to(PACKAGE)) for name, path in modules.items()
             if _mentions_the_distance_joint(name, path, modules)}
    doc = (PACKAGE.parent / "docs" / "architecture.md").read_text()
    line = next(l for l in doc.splitlines() if l.startswith("The distance joint lives in"))
    listed = {p for p in re.findall(r"`([\w/]+\.py)`", line) if not p.startswith("tests/")}
    assert found == listed, (sorted(found), sorted(listed))


def test_the_rules_see_a_joint_kind_dispatch(tmp_path):
    """The rules above are not blind: a branch on the kind, a table of joint
    kinds, an import of the family and a field constant are each seen."""
    modules = {"mbdsl.x": tmp_path / "x.py", "mbdsl.kernels.joints.distance": None}
    for text in ('if joint.kind == "distance":\n    pass\n',
                 'ok = kind in ("fixed", "distance")\n',
                 'T = {"revolute": 2, "distance": 1}\n',
                 'from mbdsl.kernels.joints import distance\n',
                 'from mbdsl.kernels.schema import DLEN\n'):
        (tmp_path / "x.py").write_text(text)
        assert _mentions_the_distance_joint("mbdsl.x", tmp_path / "x.py", modules), text
    (tmp_path / "x.py").write_text('UNITS = {"distance": "m", "speed": "m/s"}\n'
                                   'if ref.attr == "distance":\n    pass\n')
    assert not _mentions_the_distance_joint("mbdsl.x", tmp_path / "x.py", modules)


def test_the_locked_angle_rows_agree():
    """The model's joints that lock an angle (reaction units, couples) are the
    ones whose angle row the linear-rows family packs, at the same row."""
    from mbdsl.kernels.joints import linear_rows
    from mbdsl.model.elements import ANGLE_ROWS
    joints = {k: r for k, r in linear_rows.ELEMENT_ROWS.items() if k in JOINT_KIND_NAMES}
    assert joints == ANGLE_ROWS


def test_the_engine_version_is_read_once_per_process(monkeypatch):
    """Every assembled system asks whether the kernels are built, which needs
    the engine's version (``kernels.cache.source_digest``): the kernel sources
    are read and hashed once per process (each system paid 3.4 ms for it, a
    sweep once per point), not once per system."""
    import mbdsl
    from mbdsl.kernels import cache
    digest = cache.source_digest()

    def read_again():
        raise AssertionError("the kernel sources were read again")
    monkeypatch.setattr(cache, "kernel_sources", read_again)
    system = mbdsl.assemble(mbdsl.load(PACKAGE.parent / "models" / "double_pendulum.mbd"))
    system.kernel_model()
    mbdsl.consistent_initial_state(system)
    assert cache.source_digest() == digest


def _decorated(decorator):
    """{function name: (path, node)} of every kernel function with a decorator."""
    out = {}
    for path in PACKAGE.rglob("*.py"):
        for node in ast.parse(path.read_text()).body:
            if isinstance(node, ast.FunctionDef) and any(
                    getattr(d, "id", None) == decorator for d in node.decorator_list):
                out.setdefault(node.name, []).append((path, node))
    return out


def _returns_arrays(node):
    """Whether a kernel's source may return an array: a return of a
    subscript (a view), of a name bound to a numpy allocation or a view, or
    a tuple holding one. (A parameter returned as it came is not caught: by
    the kernels' convention that is a count, as ``p`` of the emitters.)"""
    views = set()

    def allocation(v):
        if isinstance(v, ast.Tuple):
            return any(allocation(e) for e in v.elts)
        return isinstance(v, ast.Subscript) or (
            isinstance(v, ast.Call) and isinstance(v.func, ast.Attribute)
            and getattr(v.func.value, "id", None) == "np")
    for a in ast.walk(node):
        if isinstance(a, ast.Assign) and allocation(a.value):
            for t in a.targets:
                views |= {n.id for n in ast.walk(t) if isinstance(n, ast.Name)}

    def array_like(v):
        if isinstance(v, ast.Tuple):
            return any(array_like(e) for e in v.elts)
        if isinstance(v, ast.Subscript):
            return True
        if isinstance(v, ast.Call) and isinstance(v.func, ast.Attribute):
            return getattr(v.func.value, "id", None) == "np"
        return isinstance(v, ast.Name) and v.id in views
    return any(isinstance(r, ast.Return) and r.value is not None and array_like(r.value)
               for r in ast.walk(node))


def test_kernels_without_reference_counts_hold_only_their_callers_arrays():
    """The kernels compiled without numba's reference counting (``_hot``,
    ``kernels/jit.py``) only read and write arrays their callers own: none
    returns an array or a view of one (its caller would drop a reference it
    never took and free the array early), and none calls a kernel that may
    return one (that array would never be freed). numba itself refuses an
    allocation in them. Read from the sources; the kernels this covers are
    the Newton iteration's."""
    hot, jit = _decorated("_hot"), _decorated("_jit")
    assert {"_residual", "_jacobian_triplets", "_solve", "_newton", "_state"} <= set(hot)
    returning = {name for name, places in jit.items()
                 if any(_returns_arrays(node) for _, node in places)}
    assert {"_workspace", "_event_scratch", "_start_estimate"} <= returning   # the check sees them
    for name, places in hot.items():
        for path, node in places:
            assert not _returns_arrays(node), f"{path.name}: {name} returns an array"
            called = {c.func.id for c in ast.walk(node)
                      if isinstance(c, ast.Call) and isinstance(c.func, ast.Name)}
            assert not called & returning, (path.name, name, called & returning)
