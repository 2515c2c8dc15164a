"""Pass 2, ``for`` blocks: every indexed declaration flattened into concrete ones,
in source order, in work linear in the number of instances.

Each declaration of a block is compiled once per set of loop variables into a
builder that copies only the parts that read them (``instantiate``).
The blocks of component instances (:class:`~mbdsl.dsl.spec.BlockSpec`) are
expanded in their instance's place, and the parameters of instances in ``for``
blocks evaluated (``l[3].L``). Diagnostics: E202 (a loop variable hiding a name,
a parameter given twice), E301 (non-integer bounds or indices), E303 (more than
``MAX_REPEAT`` instances), E201 (a ``--set`` of no parameter: reported here,
after the instances' parameters are known) and the expression errors of bounds
and indices.
"""

from __future__ import annotations

from collections import ChainMap
from functools import partial
import dataclasses

from ...errors import Span
from ..expressions import Dotted, evaluate, ExprError, IndexedName, Name, Num
from ..spec import BlockSpec, ForSpec, GroundSpec, ParameterSpec
from .context import did_you_mean
from .parameters import apply_override, set_parameter
from .tables import MAX_REPEAT


_KINDS = ("bodies", "joints", "forces", "drivers", "initials")


def _scan(c, obj):
    """(whether ``obj`` holds an indexed name, the plain names it holds),
    remembered per object: a declaration's parts that hold neither an
    indexed name nor a loop variable are shared by every copy a ``for``
    block makes, not copied again (:meth:`instantiate`)."""
    memo = c.scanned
    hit = memo.get(id(obj))
    if hit is not None and hit[0] is obj:
        return hit[1], hit[2]
    if isinstance(obj, Name):
        out = (False, frozenset((obj.name,)))
    elif isinstance(obj, IndexedName):
        out = (True, frozenset())
    elif isinstance(obj, (str, int, float, bool, type(None), Span)):
        out = (False, frozenset())
    else:
        fields = None
        if isinstance(obj, tuple):
            parts = obj
        elif dataclasses.is_dataclass(obj) and not isinstance(obj, type):
            fields = [f.name for f in dataclasses.fields(obj)]
            parts = tuple(getattr(obj, f) for f in fields)
        else:
            parts = ()
        indexed, names, varying = False, frozenset(), []
        for k, x in enumerate(parts):
            i, n = _scan(c, x)
            indexed, names = indexed or i, names | n if n else names
            if fields is not None and (i or n or fields[k] == "name"):
                varying.append((fields[k], i, n))
        out = (indexed, names)
        if fields is not None:        # the fields a copy may change (:meth:`instantiate`)
            c.varying[id(obj)] = varying
    memo[id(obj)] = (obj, *out)
    return out


def instantiate(c, obj, env, span=None):
    """A copy of a spec or expression with the loop variables in env
    substituted and every indexed name resolved; None after reporting.
    Parts that hold neither are the original objects (specs are not
    changed after parsing).

    Each declaration of a ``for`` block is compiled once per set of loop
    variables into a builder (:meth:`_builder`) that copies only the
    parts that read them: a block repeated 100 000 times costs one
    name resolution and one shallow copy per changed part, not a walk of
    the whole declaration."""
    build = _builder(c, obj, frozenset(env))
    return obj if build is None else build(env, span)


def _builder(c, obj, keys: frozenset):
    """A function (env, span) -> the instance of ``obj`` (or None after
    reporting) for loop variables ``keys``; None when ``obj`` reads none
    of them and holds no indexed name (the instance is ``obj``)."""
    memo = c.builders
    hit = memo.get((id(obj), keys))
    if hit is not None and hit[0] is obj:
        return hit[1]
    indexed, names = _scan(c, obj)
    build = None if not indexed and names.isdisjoint(keys) else _compile(c, obj, keys)
    memo[(id(obj), keys)] = (obj, build)
    return build


def _compile(c, obj, keys):
    """The builder of :meth:`_builder` for an ``obj`` that needs one: a
    loop variable becomes its number, an indexed name its resolved name
    (``link[3]``; in a reference ``link[i].B`` the element's name as a
    string), a tuple and any other spec or expression node a copy with its
    changed parts built. Each builder takes (env, span) and returns the
    instance, or None after reporting."""
    sub = partial(_builder, c)

    def part(x):
        """A child's builder, or a constant function for a shared child."""
        b = sub(x, keys)
        return b if b is not None else (lambda env, span, x=x: x)
    resolve = c.resolve_name
    if isinstance(obj, Name):
        return lambda env, span: Num(float(env[obj.name]), obj.span)
    if isinstance(obj, IndexedName):
        def build(env, span):
            """The Name of the resolved ``base[index]``."""
            name = resolve(obj, env, span)
            return None if name is None else Name(name, obj.span)
        return build
    if isinstance(obj, Dotted) and not isinstance(obj.obj, Dotted):    # link[i].B, ground.P[i]
        def build(env, span):
            """The reference with its element's and point's names resolved."""
            where = obj.span or span
            name, attr = resolve(obj.obj, env, where), resolve(obj.attr, env, where)
            return None if name is None or attr is None else Dotted(name, attr, obj.span)
        return build
    if isinstance(obj, tuple):
        items = [part(x) for x in obj]

        def build(env, span):
            """The tuple of its items' instances."""
            out = tuple(b(env, span) for b in items)
            return None if any(x is None for x in out) else out
        return build
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        own = getattr(obj, "span", None)
        fields = []
        for field, f_indexed, f_names in c.varying[id(obj)]:   # (_scan)
            if field == "name":
                fields.append((field, None))
            elif f_indexed or not f_names.isdisjoint(keys):
                fields.append((field, part(getattr(obj, field))))

        cls, state = type(obj), obj.__dict__

        def build(env, span):
            """A shallow copy with the changed fields built."""
            span = own or span
            # a shallow copy with the changed fields (the specs' __post_init__
            # only normalises what they were given, which the parts already are;
            # copy.copy's protocol cost three times as much)
            new_obj = object.__new__(cls)
            new_obj.__dict__.update(state)
            for field, b in fields:
                value = (resolve(getattr(obj, field), env, span) if b is None
                         else b(env, span))
                if value is None:
                    return None
                object.__setattr__(new_obj, field, value)
            return new_obj
        return build
    return None


def expand_loops(c):
    """Flatten for blocks (and the blocks of component instances) into
    concrete declarations, in source order.

    Each declaration is ordered by its place: a declaration of the model by
    its own line and column; one of a ``for`` block by its line and column,
    then its loop values; one of a component's instance by the instance's
    place, then its own in the component (:class:`~mbdsl.dsl.spec.BlockSpec`).
    A parameter of an instance inside a ``for`` block (``l[3].L``) is
    evaluated here, in order, with its ``--set`` override."""
    keyed = {k: [] for k in _KINDS + ("ground_points",)}
    buckets = {"BodySpec": "bodies", "BeamSpec": "bodies", "JointSpec": "joints",
               "ForceSpec": "forces", "DriverSpec": "drivers", "InitialSpec": "initials"}

    def _key(item, anchor, iteration):
        sp = getattr(item, "span", None)
        return anchor + ((sp.line, sp.column) if sp else (0, 0),), iteration

    def _add(item, env, iteration, anchor=()):
        if isinstance(item, GroundSpec):           # ground points of a for block
            for p in item.points:
                inst = instantiate(c, p, env)
                if inst is not None:
                    keyed["ground_points"].append((_key(p, anchor, iteration), inst))
            return
        if isinstance(item, ParameterSpec):        # of an instance in a for block
            inst = instantiate(c, item, env)
            if inst is not None:
                _parameter(c, inst)
            return
        if isinstance(item, BlockSpec):
            _block(item, env, iteration, anchor)
            return
        inst = instantiate(c, item, env)
        if inst is not None:
            keyed[buckets[type(item).__name__]].append((_key(item, anchor, iteration), inst))

    def _block(block, env, iteration, anchor):
        inner = _key(block, anchor, ())[0]
        for item in block.items:
            if isinstance(item, ForSpec):
                _loop(item, env, iteration, inner)
            else:
                _add(item, env, iteration, inner)

    def _loop(spec: ForSpec, env, iteration, anchor=()):
        for value in _values(c, spec, env):
            inner = {**env, spec.var: value}
            for item in spec.items:
                if isinstance(item, ForSpec):
                    _loop(item, inner, iteration + (value,), anchor)
                else:
                    _add(item, inner, iteration + (value,), anchor)

    for kind in _KINDS:
        for item in getattr(c.spec, kind):
            _add(item, {}, ())
    for p in c.spec.ground_points:              # indexed names resolve here too
        inst = instantiate(c, p, {})
        if inst is not None:
            keyed["ground_points"].append((_key(p, (), ()), inst))
    for spec in c.spec.loops:
        if isinstance(spec, BlockSpec):
            _block(spec, {}, (), ())
        else:
            _loop(spec, {}, ())
    for name in list(c.overrides):              # those no parameter took (check_parameters)
        c.error("E201", f"--set {name}: the model has no parameter '{name}'", None,
                hint=did_you_mean(name, c.params) or
                f"its parameters are {', '.join(c.params) or '(none)'}")
    c.overrides.clear()
    c.items = {k: [inst for _, inst in sorted(v, key=lambda kv: kv[0])]
               for k, v in keyed.items()}


def _values(c, spec: ForSpec, env) -> range:
    """The values of a ``for`` block's variable (empty after reporting)."""
    if spec.var in c.params or spec.var in ("t", "pi") or spec.var in env:
        c.error("E202", f"the loop variable '{spec.var}' hides a parameter or an "
                "outer loop variable", spec.span, "choose another name")
        return range(0)
    try:
        ctx = ChainMap(env, c.params)
        lo = evaluate(instantiate(c, spec.start, env, spec.span), ctx)
        hi = evaluate(instantiate(c, spec.end, env, spec.span), ctx)
    except (ExprError, TypeError) as err:
        if isinstance(err, ExprError):
            c.expr_error(err, spec.span, f"bounds of 'for {spec.var}'")
        return range(0)
    if lo != int(lo) or hi != int(hi):
        c.error("E301", f"the bounds of 'for {spec.var}' must be integers, got "
                f"{lo:g}..{hi:g}", spec.span, "not integers")
        return range(0)
    count = int(hi) - int(lo) + 1
    if count > MAX_REPEAT:
        c.error("E303", f"'for {spec.var}' would repeat {count} times, more than "
                f"{MAX_REPEAT}", spec.span, "too many repetitions")
        return range(0)
    return range(int(lo), int(hi) + 1)


def _parameter(c, p):
    """A parameter of an instance inside a ``for`` block (``l[3].L``), evaluated
    when its block is expanded, before the declarations that read it."""
    if p.name in c.params:
        c.error("E202", f"duplicate parameter '{p.name}'", p.span, "declared again")
        return
    if p.name in c.overrides:
        apply_override(c, p.name, c.overrides.pop(p.name))
        return
    set_parameter(c, p)
