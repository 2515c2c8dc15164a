"""Components and libraries: a model's instances flattened into the
declarations of one model, before the check.

A component (``component Link(L = 1 m, m = 1 kg) { body b { ... } }``) is a part
defined once; an instance (``Link upper(L = 0.4)``) copies its declarations
with every name it declares qualified by the instance's path (body ``b`` of
``upper`` is ``upper.b``; in a ``for`` block ``l[i].b``), and its parameters
become parameters of the model named by that path (``upper.L``, which
``--set upper.L=0.5`` overrides). Inside a component the names are its own:
its parameters, its elements, the instances it holds, ``ground``, ``t`` and
``pi``; a name of the model does not leak in. Outside, ``upper.b.B`` names
point B of the instance's body b and ``upper.L`` its parameter.

Flattening is exact: the flat model is the one a user would write by hand
with the qualified names, element for element, in the order of the
statements (an instance's declarations sit where the instance is written:
:class:`~mbdsl.dsl.spec.BlockSpec`), so its results are those of the flat
file bit for bit.

Libraries: ``import "parts.mbd"`` reads a file relative to the importing
file; ``import parts`` reads ``parts.mbd`` from the folders of the
``MBDSL_PATH`` environment variable, then from mbdsl's own library
(``mbdsl/library``). Either form may end in ``as NAME``; the file's
components are then ``NAME.Link`` (NAME defaults to the file's stem). Every
file read is kept with its SHA-256 (:attr:`Flat.sources`), so that a result
file can rebuild its model without the library files.

Diagnostics: E109 (an import that cannot be read, or imports in a cycle),
E110 (a library file that declares something other than components and
imports), E201 (an unknown component, parameter or name inside a component,
with did-you-mean), E202 (a duplicate component or instance), E304 (a
required parameter not given), E305 (a parameter given by position), E307 (a
parameter given in other units than its default's). A diagnostic about a
declaration of a component names the instance's path in its element names
and shows both places: the declaration in the component's file and each
instance that led there (:class:`~mbdsl.errors.ViaSpan`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
import posixpath
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath

from ..errors import Diagnostic, MbdError, ViaSpan
from . import spec as S
from . import units
from .expressions import Call, Cond, Dotted, IndexedName, Name, Num, Binary, Unary, Vec

__all__ = ["flatten", "Flat", "LIBRARY", "search_path", "element_counts"]

#: mbdsl's own library of parts (``import parts``).
LIBRARY = Path(__file__).resolve().parent.parent / "library"

#: Names that are never a component's own.
_GLOBAL = frozenset(("t", "pi"))
#: Heads of references whose next part is a joint: ``reaction.J.fx``, ``lambda.J.0``.
_JOINT_HEADS = frozenset(("reaction", "lambda"))
#: Heads of references that name no element (``energy.total``, ``output.tip``).
_FIXED_HEADS = frozenset(("energy", "output", "state"))


#: Library files parsed in this process, by (file name, SHA-256 of the text):
#: a study or a sweep checks its model many times, and a spec is never changed.
_PARSED: dict = {}


def search_path() -> list[Path]:
    """The folders ``import NAME`` searches, in order: those of ``MBDSL_PATH``
    (separated by the platform's path separator), then mbdsl's library."""
    extra = [Path(p) for p in os.environ.get("MBDSL_PATH", "").split(os.pathsep) if p]
    return extra + [LIBRARY]


@dataclass
class Flat:
    """The result of :func:`flatten`.

    Attributes
    ----------
    spec : ModelSpec
        The model without components, imports or instances.
    diagnostics : list of Diagnostic
        Errors found while flattening (the check adds them to its own).
    sources : dict of str -> (str, str)
        Every imported file: its key (the path as the main file reaches it,
        or ``library:NAME``) -> (text, SHA-256 of the text).
    instances : dict of str -> str
        Each instance's path -> its component's name, in order; an instance
        of a ``for`` block once, its index written ``[...]`` (``l[...]``).
    """

    spec: S.ModelSpec
    diagnostics: list = field(default_factory=list)
    sources: dict = field(default_factory=dict)
    instances: dict = field(default_factory=dict)


# -- names ------------------------------------------------------------------
def qualify(prefix, name):
    """``name`` inside the instance at ``prefix``: a str, or an IndexedName
    where a part of the path is indexed (resolved by the ``for`` expansion).

    ``prefix`` is None (the model itself), a str (``"upper"``) or an
    IndexedName (``l[i]``, with a suffix for the path after the index);
    ``name`` a str or an IndexedName (``s[j]``)."""
    if prefix is None:
        return name
    if isinstance(prefix, str):
        if isinstance(name, str):
            return f"{prefix}.{name}"
        base = (f"{prefix}.{name.base}" if isinstance(name.base, str)
                else qualify(prefix, name.base))
        return IndexedName(base, name.index, name.span, name.suffix)
    if isinstance(name, str):
        return IndexedName(prefix.base, prefix.index, prefix.span, f"{prefix.suffix}.{name}")
    inner = (IndexedName(prefix.base, prefix.index, prefix.span, f"{prefix.suffix}.{name.base}")
             if isinstance(name.base, str) else qualify(prefix, name.base))
    return IndexedName(inner, name.index, name.span, name.suffix)


def _text(name) -> str:
    """A path as the user reads it: ``upper``, ``l[...].b``."""
    return name.text if isinstance(name, IndexedName) else str(name)


def _base(name) -> str | None:
    """The declared name of a plain or indexed declaration (``link`` of ``link[i]``)."""
    if isinstance(name, str):
        return name
    if isinstance(name, IndexedName) and isinstance(name.base, str) and not name.suffix:
        return name.base
    return None


def _did_you_mean(name: str, candidates) -> str:
    """The check's did-you-mean hint (imported here when used: the check's
    package imports this module)."""
    from .check.context import did_you_mean
    return did_you_mean(name, candidates)


def _chain(ref) -> list:
    """``a.b.c`` -> [a, b, c] (a str or IndexedName each)."""
    parts = []
    while isinstance(ref, Dotted):
        parts.append(ref.attr)
        ref = ref.obj
    parts.append(ref)
    return parts[::-1]


# -- the files --------------------------------------------------------------
@dataclass
class _File:
    """One model or library file: its components and its imports' namespaces."""

    spec: S.ModelSpec
    key: str                   # the path as the main file reaches it ("" for the main file)
    folder: Path | None
    components: dict = field(default_factory=dict)        # name -> ComponentSpec
    namespaces: dict = field(default_factory=dict)        # import name -> _File


class _Loader:
    """Reads the imports of a model, each file once, and reports cycles."""

    def __init__(self, stored: dict | None, diags: list):
        self.stored = stored or {}
        self.diags = diags
        self.files: dict[str, _File] = {}
        self.sources: dict = {}
        self.reading: list[str] = []

    def error(self, code, message, span, label="", hint=""):
        """Record an error."""
        self.diags.append(Diagnostic("error", code, message, span, label, hint))

    def file(self, spec: S.ModelSpec, key: str, folder: Path | None) -> _File:
        """The components and namespaces of ``spec`` (its imports read)."""
        f = _File(spec, key, folder)
        self.reading.append(key)
        for comp in spec.components:
            if comp.name in f.components:
                self.error("E202", f"duplicate component '{comp.name}'", comp.span,
                           "declared again")
                continue
            f.components[comp.name] = comp
        for imp in spec.imports:
            ns = imp.namespace
            if ns in f.namespaces or ns in f.components:
                self.error("E202", f"'{ns}' is imported twice or is also a component's name",
                           imp.span, "name taken", hint="import it `as` another name")
                continue
            lib = self.read(imp, key, folder)
            if lib is not None:
                f.namespaces[ns] = lib
        self.reading.pop()
        return f

    def read(self, imp: S.ImportSpec, from_key: str, folder: Path | None) -> _File | None:
        """The file an import names, read and parsed once; None after reporting."""
        from .parser import parse_text
        if imp.is_path:
            # the path as the main file reaches it ("" is the main file's own key)
            key = (f"{from_key}/{imp.target}" if from_key.startswith("library:") else
                   posixpath.normpath(str(PurePosixPath(from_key).parent / imp.target)))
            path = (folder or Path.cwd()) / imp.target
            where = f"'{imp.target}' (looked for {path})"
        else:
            key = f"library:{imp.target}"
            found = [d / f"{imp.target}.mbd" for d in search_path()
                     if (d / f"{imp.target}.mbd").is_file()]
            path = found[0] if found else None
            where = (f"'{imp.target}' (looked for {imp.target}.mbd in MBDSL_PATH and in "
                     f"{LIBRARY})")
        if key in self.reading:
            chain = " -> ".join(k or "the model" for k in self.reading[self.reading.index(key):])
            self.error("E109", f"imports form a cycle: {chain} -> {key}", imp.span,
                       "imported again here", hint="a library cannot import a file that "
                       "imports it; move the shared components to a third file")
            return None
        if key in self.files:
            return self.files[key]
        if key in self.stored:
            text = self.stored[key]
        else:
            try:
                if path is None:
                    raise FileNotFoundError("not found")
                text = Path(path).read_text(encoding="utf-8")
            except (OSError, UnicodeDecodeError) as exc:
                self.error("E109", f"cannot read the import {where}: {exc}", imp.span,
                           "not found" if isinstance(exc, FileNotFoundError) else "unreadable",
                           hint="write the path relative to the importing file, or put "
                           "the library's folder on MBDSL_PATH")
                return None
        sha = hashlib.sha256(text.encode()).hexdigest()
        file = str(path) if path is not None else key
        spec = _PARSED.get((file, sha))
        if spec is None:
            try:
                spec = parse_text(text, file)
            except MbdError as err:
                self.diags.extend(err.diagnostics)
                return None
            if len(_PARSED) >= 64:
                _PARSED.pop(next(iter(_PARSED)))
            _PARSED[(file, sha)] = spec
        self.sources[key] = (text, sha)
        for kind in ("parameters", "bodies", "joints", "forces", "drivers", "initials",
                     "settings", "loops", "outputs", "tables", "states", "instances",
                     "ground_points"):
            for item in getattr(spec, kind):
                self.error("E110", f"the library '{key}' declares more than components: "
                           f"a model's {kind[:-1].replace('_', ' ')} belongs in a model file",
                           getattr(item, "span", None) or imp.span, "not a component",
                           hint="a library holds `component` and `import` statements only")
                break
        if spec.gravity is not None:
            self.error("E110", f"the library '{key}' declares gravity", spec.gravity_span,
                       "not a component", hint="declare gravity in the model")
        lib = self.file(spec, key, Path(path).parent if path is not None else None)
        self.files[key] = lib
        return lib


def _lookup(f: _File, name: str):
    """(ComponentSpec, the file it is in) for ``Link`` or ``parts.Link``, or None."""
    if "." in name:
        ns, _, comp = name.partition(".")
        lib = f.namespaces.get(ns)
        return (lib.components[comp], lib) if lib and comp in lib.components else None
    return (f.components[name], f) if name in f.components else None


def _known_components(f: _File) -> list[str]:
    return list(f.components) + [f"{ns}.{c}" for ns, lib in f.namespaces.items()
                                 for c in lib.components]


# -- a scope: the model, or one instance of a component -----------------------
@dataclass
class _Scope:
    """What names mean where a declaration is written."""

    prefix: object                       # None (the model), str or IndexedName
    file: _File
    params: frozenset = frozenset()      # the component's parameters and local ones
    elements: frozenset = frozenset()    # the names it declares (bases of indexed ones)
    grounds: frozenset = frozenset()     # its ground points
    instances: dict = field(default_factory=dict)   # base name -> (ComponentSpec, _File)
    loops: dict = field(default_factory=dict)       # loop variable -> its name in the flat model
    via: tuple = ()
    component: str | None = None

    @property
    def inside(self) -> bool:
        """Whether this is a component's scope (names are qualified)."""
        return self.prefix is not None


def _declared(items) -> tuple:
    """(element names, ground point names, instance name -> component) of a
    component's declarations, ``for`` blocks included (bases of indexed names)."""
    elements, grounds, instances = set(), set(), {}
    for it in items:
        if isinstance(it, S.ForSpec):
            e, g, i = _declared(it.items)
            elements |= e
            grounds |= g
            instances.update(i)
        elif isinstance(it, S.GroundSpec):
            grounds |= {_base(p.name) for p in it.points}
        elif isinstance(it, S.InstanceSpec):
            instances[_base(it.name)] = it
        elif isinstance(it, (S.BodySpec, S.BeamSpec, S.JointSpec, S.ForceSpec, S.DriverSpec,
                             S.OutputSpec, S.ParameterSpec)):
            elements.add(_base(it.name))
    return elements, grounds, instances


class _Flattener:
    """Copies declarations from their scope into the flat model."""

    def __init__(self, diags: list):
        self.diags = diags
        self.instances: dict[str, str] = {}
        self._names: dict = {}

    def names(self, comp: S.ComponentSpec) -> tuple:
        """(parameters, elements, ground points, instance name -> InstanceSpec)
        a component declares, walked once per component (every reference
        through an instance of it reads them)."""
        hit = self._names.get(id(comp))
        if hit is None or hit[0] is not comp:
            elements, grounds, subs = _declared(comp.items)
            params = frozenset({p.name for p in comp.parameters} | {
                it.name for it in comp.items if isinstance(it, S.ParameterSpec)})
            hit = self._names[id(comp)] = (comp, params, frozenset(elements),
                                           frozenset(grounds), subs)
        return hit[1:]

    def error(self, code, message, span, label="", hint=""):
        """Record an error."""
        self.diags.append(Diagnostic("error", code, message, span, label, hint))

    # -- expressions -------------------------------------------------------
    def span(self, sp, scope):
        """The span with the instances that led to it (:class:`ViaSpan`)."""
        if sp is None or not scope.via:
            return sp
        return ViaSpan(sp.file, sp.line, sp.column, sp.end_line, sp.end_column,
                       via=scope.via + getattr(sp, "via", ()))

    def expr(self, e, scope, word=False):
        """An expression (or vector, or reference) of ``scope`` in the flat
        model. ``word``: a keyword argument's whole value, where a bare name
        is an option's word (``frame = body``) rather than a parameter."""
        if e is None or not (scope.inside or _has_ref(e)):
            return e
        if isinstance(e, Num):
            return dataclasses.replace(e, span=self.span(e.span, scope))
        if isinstance(e, Name):
            return self.name(e, scope, word)
        if isinstance(e, IndexedName):
            if not scope.inside:
                return e
            return self._indexed(qualify(scope.prefix, self._index(e, scope)), e, scope)
        if isinstance(e, Dotted):
            return self.ref(e, scope)
        if isinstance(e, Vec):
            return Vec(self.expr(e.x, scope), self.expr(e.y, scope), self.span(e.span, scope),
                       None if e.z is None else self.expr(e.z, scope))
        if isinstance(e, Unary):
            return Unary(e.op, self.expr(e.operand, scope), self.span(e.span, scope))
        if isinstance(e, Binary):
            return Binary(e.op, self.expr(e.left, scope), self.expr(e.right, scope),
                          self.span(e.span, scope))
        if isinstance(e, Call):
            return Call(e.func, self.expr(e.arg, scope), self.span(e.span, scope))
        if isinstance(e, Cond):
            return Cond(self.expr(e.test, scope), self.expr(e.then, scope),
                        self.expr(e.other, scope), self.span(e.span, scope))
        return e

    def _indexed(self, q, e, scope):
        """An indexed name's qualified form with the span of ``e``."""
        return dataclasses.replace(q, span=self.span(e.span, scope)) \
            if isinstance(q, IndexedName) else Name(q, self.span(e.span, scope))

    def _index(self, e: IndexedName, scope):
        """``e`` with its index expression in the flat model."""
        base = self._index(e.base, scope) if isinstance(e.base, IndexedName) else e.base
        return IndexedName(base, self.expr(e.index, scope), self.span(e.span, scope), e.suffix)

    def name(self, e: Name, scope, word=False):
        """A bare name: a loop variable, a parameter, an element (a coupler's
        joint), ``t``/``pi``, or an option's word."""
        sp = self.span(e.span, scope)
        if not scope.inside or e.name in _GLOBAL:
            return Name(e.name, sp) if sp is not e.span else e
        if e.name in scope.loops:
            return Name(scope.loops[e.name], sp)
        if e.name in scope.params or e.name in scope.elements:
            q = qualify(scope.prefix, e.name)
            return Name(q, sp) if isinstance(q, str) else dataclasses.replace(q, span=sp)
        if not word:
            self.error("E201", f"unknown name '{e.name}' in component {scope.component}",
                       sp, "not a parameter of the component",
                       hint=_did_you_mean(e.name, scope.params | scope.elements) or
                       "inside a component, names are its parameters and its own elements; "
                       "pass a value of the model as a parameter")
        return Name(e.name, sp)

    def ref(self, e: Dotted, scope):
        """``a.b.c``: an instance's path collapsed into its element's name
        (``upper.b.B`` -> point B of ``upper.b``), a name of a component
        qualified, ``reaction.J.fx`` through its joint."""
        parts = [self._index(p, scope) if isinstance(p, IndexedName) else p
                 for p in _chain(e)]
        sp = self.span(e.span, scope)
        head = parts[0]
        if head == "ground" and len(parts) >= 2:
            if len(parts) >= 3 and _base(parts[1]) in scope.instances:   # ground.fb.O
                return _rebuild(["ground"] + self._path(parts[1:], scope, sp), sp)
            if scope.inside and _base(parts[1]) in scope.grounds:
                parts[1] = qualify(scope.prefix, parts[1])
            return _rebuild(parts, sp)
        if head in _JOINT_HEADS and len(parts) >= 3:
            inner = self._path(parts[1:], scope, sp)
            return _rebuild([head] + inner, sp)
        if head in _FIXED_HEADS:
            return _rebuild(parts, sp)
        out = self._path(parts, scope, sp)
        if len(out) > 1:
            return _rebuild(out, sp)
        return Name(out[0], sp) if isinstance(out[0], str) else out[0]

    def _path(self, parts, scope, sp):
        """The parts of a reference with the leading instances' path folded
        into the element's name; a component parameter alone -> [Name]."""
        head = parts[0]
        comp = None
        if (isinstance(head, str) and len(parts) >= 3 and head not in scope.instances
                and head not in scope.elements):
            hint = _did_you_mean(head, scope.instances)
            if hint:                      # a misspelt instance (not a body's point field)
                self.error("E201", f"unknown instance '{head}' in '{_rebuild(parts, sp).text}'",
                           sp, "no instance with this name", hint=hint)
        if _base(head) in scope.instances and len(parts) >= 2:
            name = qualify(scope.prefix, head)
            comp, lib = scope.instances[_base(head)]
            i = 1
            while True:
                sub_inst = self.names(comp)[3]
                nxt = parts[i]
                if i + 1 < len(parts) and _base(nxt) in sub_inst:
                    inst = sub_inst[_base(nxt)]
                    found = _lookup(lib, inst.component)
                    if found is None:
                        break
                    name = qualify(name, nxt)
                    comp, lib = found
                    i += 1
                    continue
                break
            params, elements = self.names(comp)[:2]
            if i == len(parts) - 1 and isinstance(parts[i], str) and parts[i] in params:
                q = qualify(name, parts[i])
                return [Name(q, sp) if isinstance(q, str) else dataclasses.replace(q, span=sp)]
            if i == len(parts) - 1 and _base(parts[i]) not in elements:
                self.error("E201", f"'{_rebuild(parts, sp).text}': {comp.name} has no "
                           f"parameter '{_text(parts[i])}'", sp, "not a parameter",
                           hint=_did_you_mean(_text(parts[i]), params | elements) or
                           f"its parameters are {', '.join(sorted(params)) or '(none)'}; "
                           "an element's value needs its field (`b.phi`)")
                return parts
            return [qualify(name, parts[i])] + parts[i + 1:]
        if scope.inside and head not in ("ground",):
            if isinstance(head, str) and head in scope.params and len(parts) == 1:
                return [Name(qualify(scope.prefix, head), sp)]
            return [qualify(scope.prefix, head)] + parts[1:]
        return parts

    # -- declarations --------------------------------------------------------
    def args(self, args, scope, elements=True):
        """Joint and force arguments: a keyword's bare word stays a word; a
        positional bare name is an element (a coupler's joint) or a word."""
        out = []
        for a in args:
            value = self.expr(a.value, scope, word=True)
            out.append(S.ArgSpec(value, a.keyword, self.span(a.span, scope)))
        return tuple(out)

    def items(self, items, scope, out):
        """Append the flat declarations of ``items`` (written in ``scope``) to
        ``out``: a dict of lists by kind (``params``, ``outputs``, ``block``)."""
        for it in items:
            self.item(it, scope, out)

    def item(self, it, scope, out):
        """One declaration of ``scope`` into ``out`` (see :meth:`items`)."""
        sp = self.span(getattr(it, "span", None), scope)
        q = (lambda n: qualify(scope.prefix, self._index(n, scope) if isinstance(n, IndexedName)
                               else n))
        if isinstance(it, S.InstanceSpec):
            self.instance(it, scope, out)
        elif isinstance(it, S.ParameterSpec):
            p = S.ParameterSpec(q(it.name), self.expr(it.value, scope), sp)
            (out["params"] if isinstance(p.name, str) else out["block"]).append(p)
        elif isinstance(it, S.OutputSpec):
            name = q(it.name)
            if not isinstance(name, str):
                self.error("E305", f"an output of component {scope.component} in an indexed "
                           f"instance '{_text(name)}': outputs of instances in `for` blocks are "
                           "not supported", sp, "output of an indexed instance",
                           hint="declare the output in the model, reading the instance's path")
                return
            out["outputs"].append(S.OutputSpec(name, self.expr(it.value, scope), sp))
        elif isinstance(it, S.ForSpec):
            self.loop(it, scope, sp, out)
        elif isinstance(it, S.GroundSpec):
            out["block"].append(S.GroundSpec(tuple(
                S.PointSpec(q(p.name), self.expr(p.position, scope), self.span(p.span, scope))
                for p in it.points), sp))
        elif isinstance(it, (S.BodySpec, S.BeamSpec)):
            props = tuple(S.PropertySpec(p.name, self.expr(p.value, scope),
                                         self.span(p.span, scope)) for p in it.properties)
            if isinstance(it, S.BeamSpec):
                points = tuple(S.BeamPointSpec(p.name, self.expr(p.at, scope),
                                               self.span(p.span, scope)) for p in it.points)
                out["block"].append(dataclasses.replace(
                    it, name=q(it.name), properties=props, points=points, span=sp,
                    frame_span=self.span(it.frame_span, scope)))
                return
            points = tuple(S.PointSpec(p.name, self.expr(p.position, scope),
                                       self.span(p.span, scope)) for p in it.points)
            shapes = tuple(S.ShapeSpec(s.kind, tuple(
                S.ArgSpec(self.expr(a.value, scope, word=True), a.keyword,
                          self.span(a.span, scope)) for a in s.args),
                self.span(s.span, scope), self.span(s.kind_span, scope)) for s in it.shapes)
            out["block"].append(dataclasses.replace(it, name=q(it.name), properties=props,
                                                    points=points, shapes=shapes, span=sp))
        elif isinstance(it, (S.JointSpec, S.ForceSpec)):
            out["block"].append(type(it)(q(it.name), it.kind, self.args(it.args, scope),
                                         span=sp, kind_span=self.span(it.kind_span, scope)))
        elif isinstance(it, S.DriverSpec):
            out["block"].append(S.DriverSpec(q(it.name), self.expr(it.target, scope),
                                             self.expr(it.value, scope), sp))
        elif isinstance(it, S.InitialSpec):
            out["block"].append(S.InitialSpec(self.expr(it.target, scope),
                                              self.expr(it.value, scope), it.guess, sp))
        else:
            what = type(it).__name__.replace("Spec", "").lower()
            self.error("E110", f"component {scope.component} declares a {what}, which a "
                       "component cannot hold", sp, "not allowed in a component",
                       hint="declare it in the model")

    def loop(self, it: S.ForSpec, scope, sp, out):
        """A ``for`` block of ``scope``: its variable renamed where it would
        hide an outer one, its declarations in the flat model's block."""
        var = it.var
        if scope.inside:
            taken = set(scope.loops.values())
            while var in taken:
                var = var + "_"
        inner = dataclasses.replace(scope, loops={**scope.loops, it.var: var}) \
            if scope.inside else scope
        sub = {"params": [], "outputs": [], "block": []}
        self.items(it.items, inner, sub)
        if sub["outputs"]:
            self.error("E305", "an output inside a `for` block", sp, "not supported",
                       hint="declare one output per instance, or read the instances in one")
        out["params"].extend(sub["params"])
        out["block"].append(S.ForSpec(var, self.expr(it.start, scope), self.expr(it.end, scope),
                                      tuple(sub["block"]), sp))

    def instance(self, inst: S.InstanceSpec, scope, out):
        """Append the flat declarations of one instance (see :meth:`items`)."""
        sp = self.span(inst.span, scope)
        found = _lookup(scope.file, inst.component)
        if found is None:
            self.error("E201", f"unknown component '{inst.component}'",
                       self.span(inst.component_span, scope), "no such component",
                       hint=_did_you_mean(inst.component, _known_components(scope.file)) or
                       "define it with `component`, or import the library that has it")
            return
        comp, lib = found
        name = self._index(inst.name, scope) if isinstance(inst.name, IndexedName) else inst.name
        path = qualify(scope.prefix, name)
        self.instances.setdefault(_text(path), inst.component)
        if len(scope.via) > 20:
            self.error("E109", f"component {comp.name} holds itself (through '{_text(path)}')",
                       sp, "instances nest without end")
            return
        params, elements, grounds, subs = self.names(comp)
        child = _Scope(path, lib, params, elements, grounds, {}, {}, scope.via + (
                           (inst.span, f"in '{_text(path)}', an instance of {comp.name}"),),
                       comp.name)
        for base, sub in subs.items():
            hit = _lookup(lib, sub.component)
            if hit is not None:
                child.instances[base] = hit
        given = {}
        for a in inst.args:
            if a.keyword is None:
                self.error("E305", f"instance '{_text(path)}' of {comp.name}: parameters are "
                           "given by name", self.span(a.span, scope), "a value without a name",
                           hint=f"write {comp.parameters[0].name if comp.parameters else 'P'}"
                           " = value")
            elif a.keyword not in {p.name for p in comp.parameters}:
                self.error("E201", f"component {comp.name} has no parameter '{a.keyword}'",
                           self.span(a.span, scope), "no such parameter",
                           hint=_did_you_mean(a.keyword, [p.name for p in comp.parameters]) or
                           f"its parameters are {', '.join(p.name for p in comp.parameters)}")
            else:
                given[a.keyword] = a
        for p in comp.parameters:
            if p.name in given:
                a = given[p.name]
                value = self.expr(a.value, scope)
                self._units(comp, p, value, a, path, scope)
            elif p.default is not None:
                value = self.expr(p.default, child)
            else:
                self.error("E304", f"instance '{_text(path)}' of {comp.name} does not give the "
                           f"parameter '{p.name}', which has no default", sp,
                           f"needs {p.name} = ...", hint=f"write {inst.component} "
                           f"{_text(name)}({p.name} = ...)")
                continue
            param = S.ParameterSpec(qualify(path, p.name), value, self.span(p.span, child))
            (out["params"] if isinstance(param.name, str) else out["block"]).append(param)
        if isinstance(path, str):
            block = {"params": out["params"], "outputs": out["outputs"], "block": []}
            self.items(comp.items, child, block)
            out["block"].append(S.BlockSpec(tuple(block["block"]), sp))
        else:
            self.items(comp.items, child, out)

    def _units(self, comp, p, value, a, path, scope):
        """E307 where a given value's units differ from the default's."""
        if p.default is None:
            return
        try:
            want = units.dimension(p.default, {})
            got = units.dimension(value, {})
        except units.DimensionError:
            return
        if want is not None and got is not None and want != got:
            self.error("E307", f"instance '{_text(path)}' of {comp.name}: '{p.name}' is "
                       f"{units.describe(want)} (its default), given {units.describe(got)}",
                       self.span(a.span, scope), f"not {units.describe(want)}",
                       hint="give the value in units of the default's kind, or as a plain "
                       "SI number")


def _has_ref(e) -> bool:
    """Whether an expression holds a reference (a Dotted) anywhere: only
    those change at the model's level (an instance's path folded)."""
    if isinstance(e, Dotted):
        return True
    if isinstance(e, (Num, Name, IndexedName)) or e is None:
        return False
    if isinstance(e, Vec):
        return _has_ref(e.x) or _has_ref(e.y) or _has_ref(e.z)
    if isinstance(e, Unary):
        return _has_ref(e.operand)
    if isinstance(e, Call):
        return _has_ref(e.arg)
    if isinstance(e, Binary):
        return _has_ref(e.left) or _has_ref(e.right)
    if isinstance(e, Cond):
        return _has_ref(e.test) or _has_ref(e.then) or _has_ref(e.other)
    return False


def _rebuild(parts, span):
    """[a, b, c] -> Dotted(Dotted(a, b), c)."""
    out = parts[0]
    for p in parts[1:]:
        out = Dotted(out, p, span)
    return out


def flatten(spec: S.ModelSpec, stored: dict | None = None) -> Flat:
    """The model without components: every instance's declarations copied
    in, named by its path.

    Parameters
    ----------
    spec : ModelSpec
        As parsed (or built in Python).
    stored : dict of str -> str, optional
        Imported files' texts by key (a result file's stored sources), read
        instead of the files.

    Returns
    -------
    Flat
        The flat spec, the diagnostics and the imported sources. A model
        without components or imports is returned as it is.
    """
    if not (spec.instances or spec.imports or spec.components or _loops_instances(spec.loops)):
        return Flat(spec)
    diags: list = []
    loader = _Loader(stored, diags)
    main_file = Path(spec.file) if spec.file and not spec.file.startswith("<") else None
    top = loader.file(spec, "", main_file.parent if main_file else None)
    fl = _Flattener(diags)
    elements, grounds, subs = _declared(list(spec.bodies) + list(spec.joints) + list(
        spec.forces) + list(spec.drivers) + list(spec.instances) + list(spec.loops))
    scope = _Scope(None, top, elements=frozenset(elements), instances={})
    seen = {}
    for inst in list(spec.instances) + [i for _, i in _loop_instances(spec.loops)]:
        base = _base(inst.name)
        if base in seen and seen[base] is not inst:
            fl.error("E202", f"duplicate instance '{base}'", inst.span, "declared again")
        seen[base] = inst
        if base in elements:
            fl.error("E202", f"'{base}' names both an instance and an element", inst.span,
                     "name taken")
    for base, inst in subs.items():
        hit = _lookup(top, inst.component)
        if hit is not None:
            scope.instances[base] = hit
    out = {"params": [], "outputs": [], "block": []}
    for inst in spec.instances:
        fl.instance(inst, scope, out)
    loops = []
    for lp in spec.loops:
        sub = {"params": [], "outputs": [], "block": []}
        fl.loop(lp, scope, lp.span, sub)
        out["params"].extend(sub["params"])
        loops.append(sub["block"][0])
    refs = {kind: tuple(_top_item(fl, it, scope) for it in getattr(spec, kind))
            for kind in ("bodies", "joints", "forces", "drivers", "initials", "outputs")}
    flat = dataclasses.replace(
        spec, parameters=tuple(spec.parameters) + tuple(out["params"]),
        outputs=refs["outputs"] + tuple(out["outputs"]),
        loops=tuple(loops) + tuple(out["block"]), imports=(), components=(), instances=(),
        **{k: v for k, v in refs.items() if k != "outputs"})
    return Flat(flat, diags, loader.sources, fl.instances)


def _top_item(fl, it, scope):
    """A declaration of the model itself, its references to instances folded."""
    out = {"params": [], "outputs": [], "block": []}
    fl.item(it, scope, out)
    got = out["block"] or out["outputs"]
    return got[0] if got else it


def _loop_instances(loops):
    """(for block, instance) of every instance inside the model's ``for`` blocks."""
    for lp in loops:
        for it in lp.items:
            if isinstance(it, S.InstanceSpec):
                yield lp, it
            elif isinstance(it, S.ForSpec):
                yield from _loop_instances((it,))


def _loops_instances(loops) -> bool:
    return any(True for _ in _loop_instances(loops))


def element_counts(model) -> list:
    """The flattened model's elements by instance, for ``mbdsl check``.

    Parameters
    ----------
    model : mbdsl.Model
        A checked model (``model.instances``: path -> component).

    Returns
    -------
    list of (str, str, dict)
        Per instance, in order: its path (``l[...]`` for the instances of a
        ``for`` block, counted together), its component, and the number of
        its bodies, joints, forces and drivers (those of the instances it
        holds included).
    """
    import re
    kinds = {"bodies": model.bodies, "joints": model.joints, "forces": model.forces,
             "drivers": model.drivers}
    out = []
    for path, comp in model.instances.items():
        pattern = re.compile(re.escape(path).replace(re.escape("[...]"), r"\[-?\d+\]") + r"\.")
        counts = {k: sum(1 for e in v if pattern.match(getattr(e, "name", ""))) for k, v in
                  kinds.items()}
        out.append((path, comp, counts))
    return out
