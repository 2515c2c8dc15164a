"""Model specifications back to the language: the text of a :class:`ModelSpec`.

A model built from Python (``ModelSpec``, ``mbdsl.from_spec``) has no file;
its text, written here, is what the result files store as the model's source,
so that ``mbdsl.load_solution``, ``mbdsl plot`` and ``mbdsl animate`` rebuild
it exactly as they rebuild a model read from a file. Parsing the text gives
the same specification (numbers are written with repr, which round-trips
every float), hence the same model.
"""

from __future__ import annotations

import math

from .expressions import Binary, Call, Cond, Dotted, IndexedName, Name, Num, TableCall, Unary, Vec

__all__ = ["expr_text", "spec_text"]

#: Binding strength of the operators (the grammar's precedence, ``mbd.lark`` sec. 3).
_PREC = {"<": 0, ">": 0, "<=": 0, ">=": 0, "+": 1, "-": 1, "*": 2, "/": 2, "^": 4}
_UNARY, _ATOM = 3, 5


def _number(v: float) -> str:
    if math.isnan(v):
        return "(0/0)"
    if math.isinf(v):
        return "1e999" if v > 0 else "(-1e999)"
    if v == int(v) and abs(v) < 1e15:
        text = str(int(v))
    else:
        text = repr(float(v))
    return text if not text.startswith("-") else f"({text})"


def _prec(e) -> int:
    if isinstance(e, Binary):
        return _PREC.get(e.op, _ATOM)          # min, max: written as calls
    if isinstance(e, Unary):
        return _UNARY
    if isinstance(e, Num) and (e.value < 0 or math.isinf(e.value)):
        return _ATOM           # written in parentheses already
    return _ATOM


def _name(x) -> str:
    if isinstance(x, Dotted):
        return expr_text(x)
    if isinstance(x, IndexedName):
        return f"{_name(x.base)}[{expr_text(x.index)}]{x.suffix}"
    return str(x)


def expr_text(e) -> str:
    """An expression, vector or reference as the language writes it.

    Parentheses are written where the grammar's precedence needs them (``^``
    binds tighter than unary minus and is right-associative; its left operand
    is an atom).

    Raises
    ------
    TypeError
        Not an expression node.
    """
    if isinstance(e, Num):
        return f"{e.written} {e.unit}" if e.unit is not None else _number(e.value)
    if isinstance(e, Name):
        return e.name
    if isinstance(e, IndexedName):
        return _name(e)
    if isinstance(e, Dotted):
        return f"{_name(e.obj)}.{_name(e.attr)}"
    if isinstance(e, Vec):
        z = "" if e.z is None else f", {expr_text(e.z)}"
        return f"({expr_text(e.x)}, {expr_text(e.y)}{z})"
    if isinstance(e, Call) and e.func == "axis_angle" and isinstance(e.arg, Vec):
        axis = e.arg.x                   # axis_angle(x, y, z, angle): ((x, y, z), angle)
        return (f"axis_angle({expr_text(axis.x)}, {expr_text(axis.y)}, {expr_text(axis.z)}, "
                f"{expr_text(e.arg.y)})")
    if isinstance(e, Call):          # zyx(yaw, pitch, roll) holds its arguments as a Vec
        return (f"{e.func}{expr_text(e.arg)}" if isinstance(e.arg, Vec)
                else f"{e.func}({expr_text(e.arg)})")
    if isinstance(e, TableCall):           # a derivative (from diff) as name', name'', ...
        return f"{e.table.name}{chr(39) * e.order}({expr_text(e.arg)})"
    if isinstance(e, Cond):
        return f"if({expr_text(e.test)}, {expr_text(e.then)}, {expr_text(e.other)})"
    if isinstance(e, Unary):
        inner = expr_text(e.operand)
        return f"-({inner})" if _prec(e.operand) < _UNARY else f"-{inner}"
    if isinstance(e, Binary) and e.op in ("min", "max"):
        return f"{e.op}({expr_text(e.left)}, {expr_text(e.right)})"
    if isinstance(e, Binary):
        p = _PREC[e.op]
        left, right = expr_text(e.left), expr_text(e.right)
        if e.op in "*/^" and isinstance(e.left, Num) and e.left.unit is not None:
            left = f"({left})"          # 15 cm*m would read as one unit, cm*m
        if e.op == "^":
            if _prec(e.left) < _ATOM:                  # the left operand of ^ is an atom
                left = f"({left})"
            if _prec(e.right) < _UNARY:                # the right one a unary
                right = f"({right})"
        else:
            if _prec(e.left) < p:
                left = f"({left})"
            if _prec(e.right) <= p:          # the tree as built, not a re-association
                right = f"({right})"
        return f"{left} {e.op} {right}" if p <= 1 else f"{left}{e.op}{right}"
    raise TypeError(f"not an expression: {e!r}")


def _args(args) -> str:
    return ", ".join(expr_text(a.value) if a.keyword is None
                     else f"{a.keyword} = {expr_text(a.value)}" for a in args)


def _item(it, indent: str) -> list[str]:
    """The lines of one declaration (body, beam, joint, force, driver,
    initial, for block)."""
    from . import spec as S
    if isinstance(it, S.BodySpec):
        parts = [f"{p.name} {expr_text(p.value)}" for p in it.properties]
        parts += [f"{_point_word(p)} {_name(p.name)} {expr_text(p.position)}"
                  for p in it.points]
        parts += [f"shape {s.kind}({_args(s.args)})" for s in it.shapes]
        kind = "particle" if it.particle else "body"
        return [f"{indent}{kind} {_name(it.name)} {{ {'; '.join(parts)} }}"]
    if isinstance(it, S.BeamSpec):
        parts = [f"{p.name} {expr_text(p.value)}" for p in it.properties]
        if it.frame is not None:
            parts.append(f"frame {it.frame}")
        parts += [f"point {p.name} at {expr_text(p.at)}" for p in it.points]
        return [f"{indent}flexible_beam {_name(it.name)} {{ {'; '.join(parts)} }}"]
    if isinstance(it, S.JointSpec):
        return [f"{indent}joint {_name(it.name)}: {it.kind}({_args(it.args)})"]
    if isinstance(it, S.ForceSpec):
        return [f"{indent}force {_name(it.name)}: {it.kind}({_args(it.args)})"]
    if isinstance(it, S.DriverSpec):
        return [f"{indent}driver {_name(it.name)}: {expr_text(it.target)} = "
                f"{expr_text(it.value)}"]
    if isinstance(it, S.InitialSpec):
        word = "guess" if it.guess else "initial"
        return [f"{indent}{word} {expr_text(it.target)} = {expr_text(it.value)}"]
    if isinstance(it, S.GroundSpec):
        pts = "; ".join(f"{_point_word(p)} {_name(p.name)} {expr_text(p.position)}"
                        for p in it.points)
        return [f"{indent}ground {{ {pts} }}"]
    if isinstance(it, S.ForSpec):
        return _block(f"for {it.var} in {expr_text(it.start)}..{expr_text(it.end)}", it.items,
                      indent)
    if isinstance(it, S.InstanceSpec):
        return [f"{indent}{it.component} {_name(it.name)}({_args(it.args)})"]
    if isinstance(it, S.ParameterSpec):
        return [f"{indent}parameter {it.name} = {expr_text(it.value)}"]
    if isinstance(it, S.OutputSpec):
        return [f"{indent}output {it.name} = {expr_text(it.value)}"]
    if isinstance(it, S.ComponentSpec):
        params = ", ".join(p.name if p.default is None else f"{p.name} = {expr_text(p.default)}"
                           for p in it.parameters)
        return _block(f"component {it.name}({params})", it.items, indent)
    raise TypeError(f"not a declaration: {it!r}")


def _block(header: str, items, indent: str) -> list[str]:
    """``header { items }`` over several lines (a for block, a component)."""
    lines = [f"{indent}{header} {{"]
    for sub in items:
        lines += _item(sub, indent + "  ")
    return lines + [f"{indent}}}"]


def spec_text(spec) -> str:
    """The model file of a :class:`~mbdsl.dsl.spec.ModelSpec`.

    Declarations are written grouped by kind (imports, components, parameters,
    tables, gravity, ground points, bodies, joints, forces, drivers, initial
    lines, repeated blocks, instances, first-order states, the simulate
    section), the order in which a model built in Python takes them: the
    text rebuilds the same model, coordinates in the same order.
    """
    header = "library" if spec.library else "model"
    lines = [f"{header} {spec.name}   # written by mbdsl from a model built in Python", ""]
    for imp in spec.imports:
        target = f'"{imp.target}"' if imp.is_path else imp.target
        lines.append(f"import {target}" + (f" as {imp.alias}" if imp.alias else ""))
    for comp in spec.components:
        lines += _item(comp, "")
    lines += [f"parameter {p.name} = {expr_text(p.value)}" for p in spec.parameters]
    for tb in spec.tables:
        source = (f'"{tb.path}"' if tb.path is not None
                  else "[" + ", ".join(expr_text(v) for v in tb.points) + "]")
        options = "".join(f", {_args([a])}" for a in tb.args)
        lines.append(f"table {tb.name}({tb.argument}) = {source}{options}")
    if getattr(spec, "space", 2) == 3:
        lines.append("space 3d")
    if spec.gravity is not None:
        lines.append(f"gravity {expr_text(spec.gravity)}")
    if spec.ground_points:
        pts = "; ".join(f"{_point_word(p)} {_name(p.name)} {expr_text(p.position)}"
                        for p in spec.ground_points)
        lines.append(f"ground {{ {pts} }}")
    # instances after the blocks: a model built in Python orders its coordinates
    # so (``check.loops.expand_loops``), and its text must rebuild the same model
    for group in (spec.bodies, spec.joints, spec.forces, spec.drivers, spec.initials,
                  spec.loops, spec.instances):
        for it in group:
            lines += _item(it, "")
    for st in spec.states:
        props = "; ".join(f"{p.name} {expr_text(p.value)}" if p.name == "initial"
                          else f"{p.name} = {expr_text(p.value)}" for p in st.properties)
        lines.append(f"state {st.name} {{ {props} }}")
    if spec.static:
        lines.append("initial static")
    lines += [f"output {o.name} = {expr_text(o.value)}" for o in spec.outputs]
    if spec.settings:
        parts = [f"method {s.value}" if s.name == "method" else f"{s.name} {expr_text(s.value)}"
                 for s in spec.settings]
        lines.append(f"simulate {{ {'; '.join(parts)} }}")
    return "\n".join(lines) + "\n"


def _point_word(p) -> str:
    """``point`` or ``axis`` (a spatial body's direction, ``PointSpec.axis``)."""
    return "axis" if getattr(p, "axis", False) else "point"
