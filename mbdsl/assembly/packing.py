"""The assembled system packed for the kernels: every element's data as the
fields of ``kernels.schema.MODEL_SCHEMA`` in two flat arrays.

The joints and drivers are packed by their kernel families, straight from the
model (``pack`` of each module of ``kernels/joints``, for the kinds its
``ELEMENT_ROWS`` names); the loads from the groups of :mod:`.groups`, which
store their instances as structs of arrays. What several elements share is
built once in a :class:`PackingContext`: the functions of time and of the
state as postfix programs (``dsl.expressions.postfix``), the sliding joints'
lines, the state variables the loads read, the elastic terms of points on
flexible beams. The packed model is what every kernel reads, compiled or
uncompiled.
"""

from __future__ import annotations

import numpy as np

from ..kernels import UNCOMPILED_ROOT
from .groups import (FrictionGroup, PointForceGroup, RotationalSpringGroup, SpringDamperGroup,
                     StateTorqueGroup, TorqueGroup)

__all__ = ["PackedModel", "PackingContext"]


class PackedModel:
    """The model's element groups as the kernels' packed model data.

    Built once per run from the model's joints and drivers (by their kernel
    families) and the system's load groups; fields as ``MODEL_SCHEMA``
    declares them. Constant driver values are folded into the rows'
    offsets, constant torques and gravity into Q0; functions of time
    become postfix programs (``dsl.expressions.postfix``): f and f' of
    drivers, f of torques and point forces.

    Parameters
    ----------
    system : AssembledSystem
        A model the compiled engine accepts (``engine.unsupported``).
    kernels : module
        The kernels the model data are for and the run calls (``K``):
        :mod:`mbdsl.kernels.api` or its uncompiled copy (``kernels.cache``).

    Raises
    ------
    ValueError
        A joint or driver kind no kernel family holds the rows of.
    """

    def __init__(self, system, kernels):
        self.K = K = kernels
        #: True when the kernels are the interpreter's copy (no LAPACK band routines)
        self.uncompiled = K.__name__.startswith(UNCOMPILED_ROOT + ".")
        n = system.n
        Q0 = np.zeros(n + 3)
        if system.gravity_force is not None:
            Q0[:n] += system.gravity_force
        # every field of the schema, empty unless the model has the element
        d = {name: np.zeros((0, columns) if columns else 0,
                            np.int64 if kind == "i" else np.float64)
             for name, kind, columns in K.MODEL_SCHEMA}
        tables = PackingContext(system)
        d.update(_joint_fields(system, tables, K.JOINT_FAMILIES))
        d.update(_force_fields(system, tables))
        if system.contact_group is not None:
            d.update(_contact_fields(system.contact_group, tables.line_row, K))
        d.update(tables.fields())
        d["mass"] = system.mass_diag.astype(np.float64)
        d["mrig"] = np.zeros(n)
        d["mrig"][system._rigid_cols] = system.mass_diag[system._rigid_cols]
        d.update(_beam_fields(system))
        d["Q0"] = Q0
        d["row_element"] = system.layout.row_element.astype(np.int64)
        d["n_elements"] = int(system.layout.n_elements)
        self.ints, self.floats = K.pack(d)
        self.n, self.m = n, system.m
        self.bound = K.triplet_bound(self.ints)
        #: the contacts' impact speeds (k,) [m/s or rad/s]: a view into the packed
        #: floats, the contact state the kernels read, written at events
        self.impact_speed = K.unpack(self.ints, self.floats)["kimp"]
        #: the springs' held directions (k, 2) (``kernels.loads.spring_damper._free_length``): a view
        #: into the packed floats, written while a step is landed on a pass
        spar = K.unpack(self.ints, self.floats)["spar"]
        self.spring_held = spar[:, 3:5] if spar.ndim == 2 and spar.shape[1] >= 5 else None


class PackingContext:
    """What the element families pack with, and the model data several
    elements share: the postfix programs of the functions of time and of the
    state (``dsl.expressions.postfix``; fields code, consts, prog, stack), the
    sliding joints' lines (geo, geof; ``model.elements.line_distance``), the
    state variables the loads read (var, varc, xval), each entry stored once
    however many elements use it, and the elastic terms of points on flexible
    beams (ecol, eshp, and each family's spans into them).

    Attributes
    ----------
    cmap : CoordinateMap
        The model's body columns.
    n : int
        The number of coordinates (the ground's columns are n..n+2).
    """

    def __init__(self, system):
        from ..dsl.expressions import OPCODES
        self.system, self.cmap, self.n = system, system.cmap, system.n
        self.state_op = OPCODES.index("x")
        self.code, self.consts, self.prog, self.depth = [], [], [], 1
        self.geo, self.geof, self.geo_row = [], [], {}
        self.var, self.varc, self.var_row = [], [], {}
        self.ecol, self.eshp, self.spans = [], [], {}

    def points(self, refs) -> tuple:
        """(columns (k, 3) of x, y, phi of each point's body, local positions
        (k, 2) [m]) of points (``model.elements.PointRef``)."""
        cols = self.cmap([p.body for p in refs]).astype(np.int64).reshape(-1, 3)
        return cols, np.array([p.local for p in refs], np.float64).reshape(-1, 2)

    def joint_points(self, field: str, joints) -> tuple:
        """(columns, local positions) of the joints' first points, then of
        their second (as :meth:`points`), their elastic terms stored with the
        spans as ``field`` (:meth:`elastic_spans`)."""
        first, second = [j.first for j in joints], [j.second for j in joints]
        self.elastic_spans(field, first, second)
        return self.points(first) + self.points(second)

    def elastic_spans(self, field: str, *points) -> None:
        """Store the elastic terms (column, S_k) of each instance's points (one
        list of ``PointRef`` per point of the element) and their spans as
        ``field``: per instance (first, end) of each point's terms. The spans
        enter the model data only when some point is on a flexible beam."""
        n, rows = self.n, []
        for instance in zip(*points):
            span = []
            for p in instance:
                start = len(self.ecol)
                for j, col in enumerate(p.elastic_columns):
                    if col < n:
                        self.ecol.append(int(col))
                        self.eshp.append(p.elastic_shape[:, j])
                span += [start, len(self.ecol)]
            rows.append(span)
        self.spans[field] = np.array(rows, np.int64).reshape(-1, 2 * len(points))

    def program(self, expr, variables=None) -> int:
        """Index of a new program for expr (a function of t and, with
        ``variables`` (name -> row of "var"), of the state)."""
        from ..dsl.expressions import postfix
        c, k, dep = postfix(expr, variables=variables)
        start = len(self.code)
        j = 0
        while j < len(c):            # constant indices are local to the program
            if c[j] == 0:
                self.code.extend((0, c[j + 1] + len(self.consts)))
                j += 2
            elif c[j] == self.state_op:   # a state variable: its row follows
                self.code.extend((c[j], c[j + 1]))
                j += 2
            else:
                self.code.append(c[j])
                j += 1
        self.consts.extend(k)
        self.prog.append((start, len(self.code)))
        self.depth = max(self.depth, dep)
        return len(self.prog) - 1

    def programs(self, f) -> tuple:
        """(f, f', f'') programs of a function of time f, or (-1, -1, -1) (none,
        or a constant: the caller folds it into an offset)."""
        from ..dsl.expressions import diff
        if not _timed(f):
            return (-1, -1, -1)
        return (self.program(f.expr), self.program(diff(f.expr)),
                self.program(diff(diff(f.expr))))

    def driver_programs(self, f) -> tuple:
        """(f, f', f'') programs of a driver's function f; a constant as the
        program of its value and no derivatives; (-1, -1, -1) for none."""
        from ..dsl.expressions import Num, diff
        if f is None:
            return (-1, -1, -1)
        if f.expr is None:
            return (self.program(Num(f.f(0.0))), -1, -1)
        return (self.program(f.expr), self.program(diff(f.expr)),
                self.program(diff(diff(f.expr))))

    def line_row(self, line) -> int:
        """Row of a sliding joint's line in geo/geof (shared by every use)."""
        from ..model.elements import line_columns
        if line not in self.geo_row:
            self.geo_row[line] = len(self.geo)
            self.geo.append(line_columns(line, self.system.cmap))
            self.geof.append([*line[1], *line[3], *line[4]])
        return self.geo_row[line]

    def variable_rows(self, f) -> dict:
        """{name: row of "var"} of the state variables a load f reads."""
        n, names = self.system.n, {}
        for v in getattr(f, "variables", ()):
            if v.line is not None:
                key = (v.level, "line", v.line)
                row = (v.level, n + 2, n + 2, self.line_row(v.line))
                coefs = [0.0, 0.0]
            else:
                cols = (v.columns(self.system.cmap) + [n + 2] * (2 - len(v.terms)))
                coefs = [c for _, _, c in v.terms] + [0.0] * (2 - len(v.terms))
                key = (v.level, *cols, *coefs)
                row = (v.level, *cols, -1)
            if key not in self.var_row:
                self.var_row[key] = len(self.var)
                self.var.append(row)
                self.varc.append(coefs)
            names[v.name] = self.var_row[key]
        return names

    def fields(self) -> dict:
        """The shared tables as model data fields (the elastic terms and their
        spans only when some point is on a flexible beam)."""
        i8, f8 = np.int64, np.float64
        out = dict(code=np.array(self.code, i8), consts=np.array(self.consts, f8),
                   prog=np.array(self.prog, i8).reshape(-1, 2), stack=np.zeros(self.depth),
                   var=np.array(self.var, i8).reshape(-1, 4),
                   varc=np.array(self.varc, f8).reshape(-1, 2), xval=np.zeros(len(self.var)),
                   geo=np.array(self.geo, i8).reshape(-1, 6),
                   geof=np.array(self.geof, f8).reshape(-1, 6))
        if self.ecol:
            out.update(self.spans, ecol=np.array(self.ecol, i8),
                       eshp=np.array(self.eshp, f8).reshape(-1, 2))
        return out


def _timed(f) -> bool:
    """Whether f is a function of time (compiled as a program)."""
    return f is not None and not f.constant


def _joint_fields(system, tables, families) -> dict:
    """The joints' and drivers' model data, each family packing the elements of
    the kinds its ``ELEMENT_ROWS`` names, in the model's order (joints, then
    drivers), with its rows of lambda.

    Raises
    ------
    ValueError
        An element of a kind no family holds the rows of.
    """
    d = {}
    elements = system.constraint_elements
    held = set()
    for family in families:
        mine = [(row + family.ELEMENT_ROWS[e.kind], e) for row, e in elements
                if e.kind in family.ELEMENT_ROWS]
        held.update(family.ELEMENT_ROWS)
        if mine:
            d.update(family.pack(mine, tables))
    for _, e in elements:
        if e.kind not in held:
            raise ValueError(f"no kernel family holds the rows of '{e.name}' ({e.kind}): "
                             "its kind is missing from every ELEMENT_ROWS of kernels/joints")
    return d


def _force_fields(system, tables) -> dict:
    """The applied loads' model data: spring-dampers, rotational
    spring-dampers, torques (programs of time, constant or not), loads of
    the state, friction in joints and point forces."""
    from ..dsl.expressions import Num
    i8, f8 = np.int64, np.float64
    n = system.n
    d = {}
    tcol, tfn, stq, sdv = [], [], [], []
    for g in system.force_groups:
        if isinstance(g, SpringDamperGroup):
            d.update(scol1=g.pair.P1.cols[:, :3].astype(i8), ss1=g.pair.P1.s.astype(f8),
                     scol2=g.pair.P2.cols[:, :3].astype(i8), ss2=g.pair.P2.s.astype(f8),
                     spar=np.column_stack([g.k, g.c, g.l0, g.held]).astype(f8))
            tables.elastic_spans("sel", g.pair.P1.refs, g.pair.P2.refs)
        elif isinstance(g, RotationalSpringGroup):
            d.update(rcol=g.cols.astype(i8),
                     rpar=np.stack([g.k, g.c, g.angle], axis=1).astype(f8))
        elif isinstance(g, TorqueGroup):
            # a constant torque too is a (constant) program, not a term of Q0:
            # the power it puts in is that of the loads of ``kernels.system._inputs_add``
            for col, f in zip(g.cols[:, 0], g.functions):
                tcol.append(col)
                tfn.append(tables.program(f.expr if _timed(f) else Num(f.f(0.0))))
        elif isinstance(g, StateTorqueGroup):
            for i, (f, line) in enumerate(zip(g.functions, g.lines)):
                names = tables.variable_rows(f)
                expr = f.expr if f.expr is not None else Num(f.f(0.0))
                if line is None:
                    a, b = (int(g.cols[i, j]) for j in g.targets[i])
                    stq.append((tables.program(expr, names), a, b, -1))
                else:
                    stq.append((tables.program(expr, names), n + 2, n + 2,
                                tables.line_row(line)))
                for v, ge in zip(getattr(f, "variables", ()), getattr(f, "grad_exprs", ())):
                    sdv.append((len(stq) - 1, names[v.name], tables.program(ge, names)))
        elif isinstance(g, FrictionGroup):
            fri = []
            for i, line in enumerate(g.lines):
                rows = [int(r) for r in g.rows[i]]
                if line is None:
                    fri.append((int(g.cols[i, 0]), int(g.cols[i, 1]), -1, rows[0], len(rows)))
                else:
                    fri.append((n + 2, n + 2, tables.line_row(line), rows[0], len(rows)))
            d.update(fri=np.array(fri, i8).reshape(-1, 5), frp=g.params.astype(f8))
        elif isinstance(g, PointForceGroup):
            tables.elastic_spans("fel", g.points.refs)
            d.update(fcol=g.points.cols[:, :3].astype(i8), fs=g.points.s.astype(f8),
                     fF=np.array([[0.0 if _timed(fx) else fx.f(0.0),
                                   0.0 if _timed(fy) else fy.f(0.0)]
                                  for fx, fy in zip(g.fx, g.fy)], dtype=f8).reshape(-1, 2),
                     ffn=np.array([(tables.program(fx.expr) if _timed(fx) else -1,
                                    tables.program(fy.expr) if _timed(fy) else -1)
                                   for fx, fy in zip(g.fx, g.fy)], dtype=i8).reshape(-1, 2))
    d.update(tcol=np.array(tcol, i8), tfn=np.array(tfn, i8), stq=np.array(stq, i8).reshape(-1, 4),
             sdv=np.array(sdv, i8).reshape(-1, 3))
    return d


def _contact_fields(group, line_row, K) -> dict:
    """The kernels' fields of the contacts and joint limits (``ContactGroup``,
    one instance per gap; ``compiled``'s contact section): kind and line row,
    columns, (offset, sign, s1, s2, n0, r, K, n, chi, mu, v_reg), impact
    speeds. ``line_row(line)``: the row of a sliding line in GEO; ``K``:
    the kernels (their gap kinds)."""
    kgi, kpar = [], []
    for i, (geometry, data) in enumerate(group.geometry):
        s1 = s2 = n0 = (0.0, 0.0)
        r, row = 0.0, -1
        if geometry == "line":          # (body L, s_L, body P, s_P, n0, r)
            kind, row, off, sign = K.GAP_LINE, line_row(tuple(data[:5])), data[5], 1.0
            s1, s2, n0, r = data[1], data[3], data[4], data[5]
        elif geometry == "slide":       # (body L, s_L, body P, s_P, u0, bound, sign)
            kind, row, off, sign = K.GAP_SLIDE, line_row(tuple(data[:5])), data[5], data[6]
        elif geometry == "angle":       # (body 1, None, body 2, None, bound, sign)
            kind, off, sign = K.GAP_ANGLE, data[4], data[5]
        elif geometry == "circle":      # (body C, s_C, body P, s_P, clearance, r)
            kind, off, sign = K.GAP_CIRCLE, data[4], 1.0
            s1, s2, r = data[1], data[3], data[5]
        else:                           # pragma: no cover (model.contact lists four)
            raise ValueError(f"no kernel for the gap geometry {geometry!r}")
        kgi.append((kind, row))
        kpar.append((off, sign, *s1, *s2, *n0, r, group.k_[i], group.n_[i], group.chi[i],
                     group.mu[i], group.v_reg[i]))
    return {"kgi": np.array(kgi, np.int64).reshape(-1, 2),
            "kcol": group.cols.astype(np.int64).reshape(-1, 6),
            "kpar": np.array(kpar, np.float64).reshape(-1, 14),
            "kimp": group.impact_speed.astype(np.float64)}


def _beam_fields(system) -> dict:
    """The flexible beams' model data (``compiled``, "Flexible beams"): per
    beam (first entry in bcol, nf, first float in bdat, elements with
    geometric stiffening, first entry in bdof, elastic coordinates per
    element), its columns, its shape integrals, each element's strain data
    on its own elastic coordinates, and gravity."""
    beam, bcol, bdat, bdof, grav = [], [], [], [], np.zeros(0)
    for g in system.flexible_groups:
        if g.gravity is not None:
            grav = np.asarray(g.gravity, dtype=float)
        for k in range(len(g.beams)):
            ne = int(g.Bu.shape[1]) if g.stiffening[k] else 0
            start = sum(len(x) for x in bdat)
            parts = [np.atleast_1d(g.m[k]), g.s0[k], np.atleast_1d(g.I0[k]), g.S_bar[k].ravel(),
                     g.a_u[k], g.a_I[k], g.M_ff[k].ravel(), g.S_tilde[k].ravel(), g.K[k].ravel()]
            dofs = []
            if ne:            # each element's coordinates: where its Bu or G is nonzero
                Bu, G = g.Bu[k], g.G[k]
                dofs = [np.flatnonzero((Bu[e] != 0) | (np.abs(G[e]).sum(0) != 0)
                                       | (np.abs(G[e]).sum(1) != 0)) for e in range(ne)]
            dm = max((len(d) for d in dofs), default=0)
            beam.append((len(bcol), g.nf, start, ne, len(bdof), dm))
            bcol.extend(int(c) for c in g.cols[k])
            if ne:
                idx = np.zeros((ne, dm), np.int64)
                Bu_e, G_e = np.zeros((ne, dm)), np.zeros((ne, dm, dm))
                for e, d in enumerate(dofs):
                    idx[e, :len(d)] = d
                    Bu_e[e, :len(d)] = Bu[e, d]
                    G_e[e, :len(d), :len(d)] = G[e][np.ix_(d, d)]
                parts += [g.kEA[k], Bu_e.ravel(), G_e.ravel()]
                bdof.extend(int(x) for x in idx.ravel())
            bdat.append(np.concatenate([np.asarray(x, dtype=float).ravel() for x in parts]))
    return {"beam": np.array(beam, np.int64).reshape(-1, 6),
            "bcol": np.array(bcol, np.int64), "bdof": np.array(bdof, np.int64),
            "bdat": np.concatenate(bdat) if bdat else np.zeros(0), "grav": grav}
