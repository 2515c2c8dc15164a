"""The assembled system packed for the kernels: every element's data as the
fields of ``kernels.schema.MODEL_SCHEMA`` in two flat arrays.

The joints, drivers and loads are packed by their kernel families, straight
from the model (``pack`` of each module of ``kernels/joints``, for the kinds
its ``ELEMENT_ROWS`` names, and of ``kernels/loads``, for the kinds its
``LOADS`` names); the flexible beams from their shape integrals
(``kernels.beams.ffr.pack``). What several elements share is
built once in a :class:`PackingContext`: the functions of time and of the
state as postfix programs (``dsl.expressions.postfix``), the sliding joints'
lines, the state variables the loads read, the elastic terms of points on
flexible beams. The packed model is what every kernel reads, compiled or
uncompiled.
"""

from __future__ import annotations

import copy

import numpy as np

from ..kernels import UNCOMPILED_ROOT

__all__ = ["PackedModel", "PackingContext"]


class PackedModel:
    """The model's elements as the kernels' packed model data.

    Built once per run from the model's joints, drivers and loads (by their
    kernel families) and the flexible beams; fields as ``MODEL_SCHEMA``
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
        A joint or driver kind no kernel family holds the rows of, or a load
        kind no family holds.
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
        tables = PackingContext(system, K)
        d.update(_joint_fields(system, tables, K.JOINT_FAMILIES))
        d.update(_load_fields(system, tables, K.LOAD_FAMILIES))
        d["swp"] = _switch_fields(system, tables)
        d.update(tables.fields())
        d["mass"] = system.mass_diag.astype(np.float64)
        d["mrig"] = np.zeros(n)
        d["mrig"][system._rigid_cols] = system.mass_diag[system._rigid_cols]
        d.update(K.pack_beams([(b, cols) for s in system.beam_sets
                               for b, cols in zip(s.beams, s.cols)], system.beam_gravity))
        d["Q0"] = Q0
        d["zcol"] = system.state_cols.astype(np.int64)
        d["row_element"] = system.layout.row_element.astype(np.int64)
        d["frow"] = system.layout.frame_rows.astype(np.int64)
        d["n_elements"] = int(system.layout.n_elements)
        self.ints, self.floats = K.pack(d)
        self.n, self.m = n, system.m
        self.bound = K.triplet_bound(self.ints)
        self._views()

    def _views(self):
        """The run state's views into the packed floats (and where they sit,
        for the copies of ``fresh``)."""
        fields = self.K.unpack(self.ints, self.floats)
        start = self.floats.ctypes.data
        self._places = {name: ((fields[name].ctypes.data - start) // 8 if fields[name].size
                               else 0, fields[name].shape) for name in ("kimp", "spar")}
        self._set_views()

    def _view(self, name):
        """Field ``name`` of the packed floats, as a view at its recorded place."""
        at, shape = self._places[name]
        return self.floats[at:at + int(np.prod(shape))].reshape(shape)

    def _set_views(self):
        #: the contacts' impact speeds (k,) [m/s or rad/s]: a view into the packed
        #: floats, the contact state the kernels read, written at events
        self.impact_speed = self._view("kimp")
        #: the springs' held directions (k, 2) (``kernels.loads.spring_damper._free_length``): a view
        #: into the packed floats, written while a step is landed on a pass
        spar = self._view("spar")
        self.spring_held = spar[:, 3:5] if spar.ndim == 2 and spar.shape[1] >= 5 else None

    def fresh(self):
        """A copy with model data of its own (``ints``, ``floats``), equal to
        packing the system again: for one run, whose events write the run
        state (contact impact speeds, springs' held directions) into its
        floats. Copying two arrays instead of packing every element again
        takes microseconds instead of a third of a millisecond on a small
        model, which every ``integrate`` call paid."""
        out = copy.copy(self)
        out.ints, out.floats = self.ints.copy(), self.floats.copy()
        out._set_views()
        return out


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

    def __init__(self, system, kernels=None):
        from ..dsl.expressions import OPCODES
        self.system, self.cmap, self.n = system, system.cmap, system.n
        self.kernels, self._placed = kernels, None
        self.state_op, self.table_op = OPCODES.index("x"), OPCODES.index("table")
        self.code, self.consts, self.prog, self.depth = [], [], [], 1
        self.geo, self.geof, self.geo_row = [], [], {}
        self.var, self.varc, self.var_row = [], [], {}
        self.tbl, self.tbd, self.table_rows = [], [], {}
        self.ecol, self.eshp, self.spans = [], [], {}

    def points(self, refs) -> tuple:
        """(columns (k, 3) of x, y, phi of each point's body, local positions
        (k, 2) [m]) of points (``model.elements.PointRef``)."""
        cols = self.cmap([p.body for p in refs]).astype(np.int64).reshape(-1, 3)
        return cols, np.array([p.local for p in refs], np.float64).reshape(-1, 2)

    def point_columns(self, refs) -> np.ndarray:
        """Columns in q_ext of each point's body (x, y, phi) and of the elastic
        coordinates it moves with on a flexible beam, shape (k, 3 + e), e the
        most any point has, the rest outside q (``points.PointSet.cols``)."""
        from .points import PointSet
        return PointSet(self.cmap, refs).cols.astype(np.int64)

    def placed(self) -> np.ndarray:
        """The positions as placed (``placement.place_bodies``, at the model's
        t_start), extended by the ground's three, shape (n+3,); built once."""
        if self._placed is None:
            from .placement import place_bodies
            t0 = float(self.system.model.settings.get("t_start", 0.0))
            q = place_bodies(self.system, t0, kernels=self.kernels)
            self._placed = np.concatenate([q, np.zeros(3)])
        return self._placed

    def line_columns(self, line) -> list:
        """Columns in q_ext (x, y, phi of the line's body, then of the sliding
        point's) of a sliding joint's line (``model.elements.line_columns``)."""
        from ..model.elements import line_columns
        return line_columns(line, self.cmap)

    def padded(self, per) -> np.ndarray:
        """Per-instance column lists as one array (k, c), c the longest, the
        rest the ground's phi (n + 2, outside q)."""
        width = max((len(c) for c in per), default=0)
        return np.array([list(c) + [self.n + 2] * (width - len(c)) for c in per],
                        np.int64).reshape(len(per), width)

    @staticmethod
    def timed(f) -> bool:
        """Whether f is a function of time (a program), not a constant."""
        return _timed(f)

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
        c, k, dep = postfix(expr, variables=variables, tables=self.table_row)
        start = len(self.code)
        j = 0
        while j < len(c):            # constant indices are local to the program
            if c[j] == 0:
                self.code.extend((0, c[j + 1] + len(self.consts)))
                j += 2
            elif c[j] == self.state_op:   # a state variable: its row follows
                self.code.extend((c[j], c[j + 1]))
                j += 2
            elif c[j] == self.table_op:   # a table: its row and the order follow
                self.code.extend(c[j:j + 3])
                j += 3
            else:
                self.code.append(c[j])
                j += 1
        self.consts.extend(k)
        self.prog.append((start, len(self.code)))
        self.depth = max(self.depth, dep)
        return len(self.prog) - 1

    def value_program(self, f, variables=None) -> int:
        """Index of the program of a load's function f: of time, a constant
        as the program of its value; with ``variables`` (name -> row of
        "var", :meth:`variable_rows`) of the state, its expression whenever
        it has one."""
        from ..dsl.expressions import Num
        if variables is None:
            expr = f.expr if _timed(f) else Num(f.f(0.0))
        else:
            expr = f.expr if f.expr is not None else Num(f.f(0.0))
        return self.program(expr, variables)

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

    def table_row(self, table) -> int:
        """Row of a table (``model.table.Table``) in tbl/tbd, stored once:
        (offset, intervals, extrapolation code), its breakpoints then its
        coefficients, interval by interval (``kernels.programs._table``)."""
        from ..model.table import EXTRAPOLATIONS
        if id(table) not in self.table_rows:
            self.table_rows[id(table)] = len(self.tbl)
            self.tbl.append((len(self.tbd), len(table.x) - 1,
                             EXTRAPOLATIONS.index(table.extrapolation)))
            self.tbd.extend(float(v) for v in table.x)
            self.tbd.extend(float(v) for v in table.c.T.ravel())
        return self.table_rows[id(table)]

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
                   geof=np.array(self.geof, f8).reshape(-1, 6),
                   tbl=np.array(self.tbl, i8).reshape(-1, 3), tbd=np.array(self.tbd, f8))
        if self.ecol:
            out.update(self.spans, ecol=np.array(self.ecol, i8),
                       eshp=np.array(self.eshp, f8).reshape(-1, 2))
        return out


def _switch_fields(system, tables) -> np.ndarray:
    """The kinks of the tables of the state, located as events
    (``model.elements.StateSwitch``): per switch, the program of the table's
    argument u and the row of its kinks' table in tbl/tbd, shape (k, 2)."""
    rows = [(tables.program(s.expr, tables.variable_rows(s)), tables.table_row(s.table))
            for s in system.state_switches or ()]
    return np.array(rows, np.int64).reshape(-1, 2)


def _timed(f) -> bool:
    """Whether f is a function of time (compiled as a program)."""
    return f is not None and not f.constant


def _joint_fields(system, tables, families) -> dict:
    """The joints' and drivers' model data, each family of the model's space
    (``SPACE``, 2 unless a family says 3) packing the elements of the kinds
    its ``ELEMENT_ROWS`` names, in the model's order (joints, then drivers),
    with its rows of lambda.

    Raises
    ------
    ValueError
        An element of a kind no family holds the rows of.
    """
    d = {}
    # (first row of lambda, element) in row order
    elements = list(zip(system.layout.element_start[:-1].tolist(),
                        system.model.constraint_elements))
    held = set()
    space = getattr(system.model, "space", 2)
    for family in families:
        if getattr(family, "SPACE", 2) != space:      # a kind name of both: revolute, distance
            continue
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


def _load_fields(system, tables, families) -> dict:
    """The applied loads' model data, each family packing the model's loads
    of the kinds its ``LOADS`` names, in the model's order.

    Raises
    ------
    ValueError
        A load of a kind no family holds.
    """
    d, held = {}, set()
    forces = system.model.loads
    for family in families:
        mine = [f for f in forces if f.kind in family.LOADS]
        held.update(family.LOADS)
        if mine:
            d.update(family.pack(mine, tables))
    for f in forces:
        if f.kind not in held:
            raise ValueError(f"no kernel family holds the load '{f.name}' ({f.kind}): "
                             "its kind is missing from every LOADS of kernels/loads")
    return d
