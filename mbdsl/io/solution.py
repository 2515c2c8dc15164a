"""The result of a simulation: time histories, derived quantities, statistics.

Shapes: N stored time points, n coordinates, m constraint equations.
"""

from __future__ import annotations

import numpy as np

from .derived import DERIVED_NAMES, derived_columns, result_columns, rotation_columns
from .rows import (STAT_NAMES, Extent, RunStats, StepStats, FileArrays, RowArray,
                   RowStore)

__all__ = ["Solution"]

#: The codes of the guard's checks (:mod:`mbdsl.guard`), named in the summary's first line.
GUARD_CODES = ("W602", "W603", "W604")


def _optional(module: str, method: str):
    """An optional library (pandas, xarray: the core does without them), or
    ImportError saying which method of Solution needs it."""
    import importlib
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise ImportError(f"Solution.{method} needs {module} (pip install {module})") from exc


class Solution:
    """Time histories of a run, and everything derived from them.

    Attributes
    ----------
    t : ndarray, shape (N,) [s]
    q, v, a : ndarray, shape (N, n)
    lam : ndarray, shape (N, m)
        Lagrange multipliers (sign convention ``M a + Phi_q^T lambda = Q``).
    extras : dict of str -> ndarray, shape (N, m)
        The method's further multipliers: ``mu`` (NSTIFF-SI2, HHT-SI2),
        ``psi1`` (HHT-ADD).
    status : {"completed", "failed", "interrupted", "running"}
    message : str
        Why the run stopped.
    diagnostics : list of Diagnostic
        For a failed run, what went wrong in the model's words.
    stats : dict of str -> ndarray, shape (N,)
        Per step: ``iterations``, ``residuals``, ``jacobians``,
        ``factorizations``, ``h``.
    stats_total : RunStats
    wall_time : float [s]
        The time loop's wall time (``timings["integration"]``).
    timings : dict of str -> float [s]
        Where the time went: ``setup`` (reading the model, assembly,
        consistent initial conditions), ``kernels`` (loading the compiled
        kernels, or compiling them once per machine), ``integration`` (the
        time loop, output excluded) and ``output`` (derived columns and the
        file written as the run went).
    engine, linear_solver : str
        What ran: "compiled", "uncompiled" or "numpy"; "dense", "banded" or
        "sparse".
    method_name : str
    method_parameters : dict
    h, t_end : float [s]
        Nominal step size and requested end time.
    initial : InitialState
    last_state : StepState or None
        The run's last accepted state with the method's carried values
        (``extra``: its extra multipliers, generalized-alpha's auxiliary
        acceleration ``aux``), to continue it exactly
        (``InitialState.method_state``).
    """

    #: Phases of a run's wall time (``timings``), in the order they happen.
    TIMING_NAMES = ("setup", "kernels", "integration", "output")

    #: Per-step Newton statistics, stored and written in this order.
    STAT_NAMES = STAT_NAMES

    t = RowArray("t")
    q = RowArray("q")
    v = RowArray("v")
    a = RowArray("a")
    lam = RowArray("lambda")

    def __init__(self, system, method, h, t_end, initial):
        self.system = system
        self.model = system.model
        self.method_name = method.name
        self.method_parameters = method.parameters()
        #: the constraint formulation (``Method.formulated``)
        self.formulation = getattr(method, "formulation", "lagrange")
        #: error-controlled steps (``integrators.adaptive.StepControl``), or None:
        #: fixed steps of h
        self.control = None
        # stored per step (the method's extras) and added on output (``output_extras``)
        self._stored_extras = tuple(method.extras)
        self.extra_names = self._stored_extras + tuple(getattr(method, "output_extras", ()))
        self._output_rows = getattr(method, "output_rows", None)
        self.h, self.t_end = float(h), float(t_end)
        self.initial = initial
        self.status, self.message, self.diagnostics = "running", "", []
        self.wall_time = 0.0
        self.timings = dict.fromkeys(self.TIMING_NAMES, 0.0)
        self.engine, self.linear_solver = "numpy", "dense"
        #: Why the compiled engine did not run a model ``engine="auto"`` chose
        #: the numpy engine for (``engine.unsupported``), or None.
        self.engine_note = None
        #: (t [s], steps, their integration time [s]) where a run of the
        #: uncompiled kernels went on compiled, their background build done
        #: (``driver.KernelUpgrade``), or None.
        self.compiled_from = None
        self.stats_total = RunStats()
        self._rows = RowStore(system.n, system.m, self._stored_extras)
        #: The result file the rows are read from (``attach_file``), or None: held.
        self._file_rows = None
        #: The columns a result file written with some columns only holds
        #: (``from_arrays``; :attr:`columns`), or None: every column.
        self.written = None
        self._extents = None          # the streamed chunks' Extent per derived column
        self.last_state = None
        self.energy_start, self.energy_end = None, {}
        #: Contact and limit events: (t [s], gap name, "closed" or "opened",
        #: approach speed [m/s or rad/s]) in time order.
        self.events = []
        #: The contact state changes behind them, (t, gap index, impact speed;
        #: 0 for an opening), for the dissipated energy (``ContactState.speeds_at``).
        self.contact_log = []
        #: Steps retaken to end on an event (``integrators.events``).
        self.event_cuts = 0
        #: Rows at requested times (``integrators.dense``), not one per step.
        self.dense = False
        #: energy.work and energy.dissipated integrated over the steps (dense
        #: output: name -> (N,) [J]), or None: integrated over the rows.
        self.flows = None

    # -- building ---------------------------------------------------------------------
    def append(self, state, stats: StepStats) -> None:
        """Record an accepted step (``StepState``) and its Newton statistics."""
        self._rows.append(state, stats)
        tot = self.stats_total
        if stats.h > 0:
            tot.steps += stats.steps
        tot.iterations += stats.iterations
        tot.residuals += stats.residuals
        tot.jacobians += stats.jacobians
        tot.factorizations += stats.factorizations
        tot.multipliers_stalled += int(stats.multipliers_stalled)

    def dense_output(self) -> None:
        """Rows at requested times (``integrators.dense``): the rows carry the
        energy integrals over the steps, before any row but the initial one."""
        self._rows = RowStore(self.system.n, self.system.m, self._stored_extras, flows=True)
        self.dense = True

    def append_block(self, t, q, v, a, lam, extras: dict, counts, h: float,
                     totals: bool = True, flows: dict | None = None) -> None:
        """Record k rows at once (the compiled loop's output); the arrays are kept.

        Parameters
        ----------
        t : ndarray, shape (k,) [s]
        q, v, a : ndarray, shape (k, n)
        lam : ndarray, shape (k, m)
        extras : dict of str -> ndarray, shape (k, m)
            One entry per name of ``extra_names``.
        counts : ndarray of int, shape (k, 6)
            Per row: iterations, residuals, jacobians, factorizations, steps
            accepted at the round-off floor, steps (``StepStats``).
        h : float or ndarray, shape (k,) [s]
            The step size of these rows (one per row with error-controlled
            steps); 0 for a row that records no new step.
        totals : bool
            Add the counts to ``stats_total`` (False: the caller did, per
            step: dense output).
        flows : dict of str -> ndarray, shape (k,) [J], optional
            ``energy.work`` and ``energy.dissipated`` at the rows, integrated
            over the steps (dense output; ``dense_output`` first).
        """
        k = len(t)
        seg = {"t": t, "q": q, "v": v, "a": a, "lam": lam, "iterations": counts[:, 0],
               "residuals": counts[:, 1], "jacobians": counts[:, 2],
               "factorizations": counts[:, 3],
               "h": np.full(k, float(h)) if np.ndim(h) == 0 else np.asarray(h, float)}
        seg.update({x: extras[x] for x in self._stored_extras})
        if self._rows.flow_names:
            seg.update({x: np.asarray(flows[x], dtype=float) for x in self._rows.flow_names})
        self._rows.extend(seg)
        if totals:
            self.add_totals(counts, h)

    def add_totals(self, counts, h) -> None:
        """Add steps' Newton counts (k, 6) (as in :meth:`append_block`) taken
        with step sizes h [s] to :attr:`stats_total` (steps only where every
        h > 0: a row that records no new step counts none)."""
        tot, sums = self.stats_total, counts.sum(axis=0)
        if np.all(np.asarray(h) > 0):
            tot.steps += int(sums[5])
        tot.iterations += int(sums[0])
        tot.residuals += int(sums[1])
        tot.jacobians += int(sums[2])
        tot.factorizations += int(sums[3])
        tot.multipliers_stalled += int(sums[4])

    def amend_last(self, t: float | None = None, a=None, lam=None,
                   extras: dict | None = None, v=None) -> None:
        """Overwrite the last recorded row: its time t [s] (a segment of the
        compiled loop that ends exactly on a switch of a function of time),
        and the state a restart just past a switch puts there: v (n,) taken
        onto the velocity constraint, a (n,), lam (m,), and the method's
        extra multipliers (``extras``: name -> (m,); those this solution
        does not store are left out).

        Raises
        ------
        IndexError
            No row recorded yet.
        """
        if not self.n_rows:
            raise IndexError("no row recorded yet")
        values = {} if t is None else {"t": float(t)}
        if v is not None:
            values["v"] = np.array(v, dtype=float)
        if a is not None:
            values["a"] = np.array(a, dtype=float)
        if lam is not None:
            values["lam"] = np.array(lam, dtype=float)
        values.update({k: np.array(x, dtype=float) for k, x in (extras or {}).items()
                       if k in self._stored_extras})
        self._rows.set_last(**values)

    @property
    def n_rows(self) -> int:
        """Rows recorded so far (a finished run's rows)."""
        if self._file_rows is not None:
            return self._file_rows.n
        held = self.__dict__.get("_held_t")        # stacked or given (``from_arrays``)
        return len(held) if held is not None else len(self._rows)

    @property
    def last_t(self) -> float:
        """The time of the last row recorded so far [s] (NaN before any)."""
        if self._file_rows is not None:
            return float(self.t[-1]) if self.n_rows else float("nan")
        return float(self._rows.last()["t"][0]) if self.n_rows else float("nan")

    def release_rows(self, upto: int) -> None:
        """Let go of the rows before ``upto`` (as far as whole blocks of rows
        allow): a stream wrote them to its file, which holds them from now on
        (``stream.RowStream`` with ``releases_rows``; :meth:`attach_file` at
        the end). A run of millions of steps then holds a few blocks."""
        self._rows.release(upto)

    def attach_file(self, source, extents: dict | None = None) -> None:
        """End a run whose rows went to a result file as it streamed: the rows
        still held go, and ``t``, ``q``, ``v``, ``a``, ``lam``, ``extras``,
        ``stats`` and the derived columns are read from ``source`` when first
        asked for (one column at a time by :meth:`column`); the summary and
        the checks of :mod:`mbdsl.guard` read the derived columns' ``extents``
        (name -> :class:`Extent`, merged over the chunks written) and the
        columns they need one at a time, so that a long run's report does not
        hold its rows in memory again.

        Parameters
        ----------
        source : hdf5.FileRows
            ``n`` (rows), ``read(dataset, j=None)`` and ``derived`` (column
            name -> (dataset, column index)).
        extents : dict of str -> Extent, optional
        """
        for attr in ("t", "q", "v", "a", "lam"):
            self.__dict__.pop("_held_" + attr, None)
        self._rows = RowStore(self.system.n, self.system.m, self._stored_extras)
        self._file_rows = source
        self.extras = FileArrays(source, {x: (f"extras/{x}", None) for x in self.extra_names})
        self.stats = FileArrays(source, {k: (f"newton/{k}", None) for k in self.STAT_NAMES})
        self.flows = None             # energy.work and energy.dissipated: derived columns
        self._derived = FileArrays(source, source.derived)
        self._extents = dict(extents or {})
        self._warnings = None

    def extent(self, name: str) -> Extent:
        """The :class:`Extent` of one column (:meth:`column`'s names): kept
        from the chunks a streamed run wrote, else computed from the column.

        Raises
        ------
        KeyError
            For an unknown column (as :meth:`column`).
        """
        kept = (self._extents or {}).get(name)
        return kept if kept is not None else Extent.of(self.column(name))

    def _field(self, attr: str, j) -> np.ndarray:
        """Column j (an index, or a list of increasing indices) of the row
        array ``attr`` ("q", "v", "a", "lam"): read alone from the result
        file when the array is not held."""
        if self._file_rows is not None and not type(self).__dict__[attr].held(self):
            return self._file_rows.read(type(self).__dict__[attr].dataset, j)
        if np.ndim(j) and len(j) and list(j) == list(range(j[0], j[-1] + 1)):
            return getattr(self, attr)[:, j[0]:j[-1] + 1]      # a view
        return getattr(self, attr)[:, j]

    def multipliers(self, j0: int, j1: int) -> np.ndarray:
        """Columns j0..j1-1 of :attr:`lam`, shape (N, j1 - j0): read alone
        from the result file when the run's rows are there (a long run
        streamed to HDF5), else a view."""
        return self._field("lam", list(range(j0, j1)))

    def rows(self, i0: int, i1: int) -> dict:
        """Rows i0..i1-1 recorded so far, as arrays ("t", "q", "v", "a",
        "lam", the extra names and the ``STAT_NAMES``), with the method's
        output multipliers and accelerations (``Method.output_rows``)."""
        d = self._rows.get(i0, i1)
        if self._output_rows is not None and len(d["t"]):
            lam, a, extras = self._output_rows(self.system, d["t"], d["q"], d["v"], d["a"],
                                               d["lam"], {x: d[x] for x in self._stored_extras})
            d.update(extras)
            d["lam"], d["a"] = lam, a
        return d

    #: A beam's elastic displacement, as a fraction of its length, above which
    #: :meth:`run_warnings` says the linear floating-frame model has left its range.
    DEFLECTION_LIMIT = 0.1

    def run_warnings(self) -> list:
        """Warnings about the computed motion (not its start), from the stored rows.

        W404: a flexible beam whose elastic displacement (the largest
        |S(x) q_f| over its nodes, in its floating frame) passes
        ``DEFLECTION_LIMIT`` of its length: the linear elasticity of the
        floating frame of reference (small deflections, no geometric
        stiffening) is not valid there, and a rotating beam may be going
        unstable. Once per beam, at the first stored time it happens.

        Returns
        -------
        list of Diagnostic
        """
        from ..errors import Diagnostic
        out = []
        if self.n_rows == 0:
            return out
        for beam in self.model.flexible_bodies:
            arcs = np.linspace(0.0, beam.length, beam.elements + 1)
            S = beam.mesh.shape(arcs)                              # (k, 2, nf)
            qf = self._field("q", list(beam.elastic_columns()))
            size = np.empty(len(qf))
            for i in range(0, len(qf), 1 << 16):                  # (rows, k, 2) in blocks
                disp = np.einsum("kif,Nf->Nki", S, qf[i:i + (1 << 16)])
                size[i:i + len(disp)] = np.max(np.hypot(disp[..., 0], disp[..., 1]), axis=1)
            over = np.flatnonzero(size > self.DEFLECTION_LIMIT * beam.length)
            if len(over) == 0:
                continue
            i, worst = int(over[0]), int(np.argmax(size))
            out.append(Diagnostic(
                "warning", "W404",
                f"flexible beam '{beam.name}' deflects by {size[i]:.3g} m at t = {self.t[i]:.6g} s, "
                f"more than {100 * self.DEFLECTION_LIMIT:g} % of its {beam.length:g} m length "
                f"(largest {size[worst]:.3g} m at t = {self.t[worst]:.6g} s): the floating frame's "
                "linear elasticity is not valid at such deflections", beam.span,
                "deflects too far",
                hint="a beam spinning faster than its first bending frequency softens without "
                "geometric stiffening; check E, the second moment and the loads, or use more "
                "bodies"))
        return out

    def finalize(self) -> None:
        """Stack the recorded steps into arrays (the rows' one copy: the row
        store keeps the stacked arrays, not the run's segments)."""
        self._rows.stack()
        d = self.rows(0, len(self._rows))
        self.t, self.q, self.v, self.a, self.lam = d["t"], d["q"], d["v"], d["a"], d["lam"]
        self.extras = {x: d[x] for x in self.extra_names}
        self.stats = {k: d[k] for k in self.STAT_NAMES}
        self.flows = ({k: d[k] for k in self._rows.flow_names}
                      if self._rows.flow_names else None)
        self._derived = None
        self._warnings = None

    @property
    def warnings(self) -> list:
        """What the run's own rows say is wrong with it (a finished run).

        :meth:`run_warnings` (W404, a beam beyond small deflections) and the
        checks of :mod:`mbdsl.guard`: W602 an energy balance off by more than
        1 % of the energy exchanged, W603 error-controlled steps collapsed by
        six orders of magnitude, W604 reactions alternating step by step.
        Computed once (they read the derived columns).

        Returns
        -------
        list of Diagnostic
        """
        if getattr(self, "_warnings", None) is None:
            from ..guard import run_checks
            self._warnings = self.run_warnings() + run_checks(self)
        return self._warnings

    @classmethod
    def from_arrays(cls, system, *, method_name: str, method_parameters: dict,
                    extra_names, h: float, t_end: float, t, q, v, a, lam, extras: dict,
                    stats: dict, stats_total: RunStats, status: str, message: str,
                    wall_time: float = 0.0, derived: dict | None = None,
                    timings: dict | None = None, engine: str = "numpy",
                    linear_solver: str = "dense", events=(), event_cuts: int = 0,
                    warnings=None, flows: dict | None = None,
                    dense: bool = False, written=None) -> "Solution":
        """A Solution from stored arrays (``mbdsl.load_solution``).

        Parameters
        ----------
        system : AssembledSystem
            Rebuilt from the stored model source.
        t : ndarray, shape (N,)
        q, v, a : ndarray, shape (N, n)
        lam : ndarray, shape (N, m)
        extras : dict of str -> ndarray, shape (N, m)
        stats : dict of str -> ndarray, shape (N,)
            Keys :attr:`STAT_NAMES`.
        derived : dict of str -> ndarray, shape (N,), optional
            Stored derived columns (energies, constraint norms, reactions);
            recomputed from q, v, lambda when absent.
        timings : dict of str -> float [s], optional
        engine, linear_solver : str
        events : sequence of (t [s], gap, "closed" or "opened", speed)
            The contact and limit events of the run (:attr:`events`).
        event_cuts : int
            Steps retaken to land on them.
        warnings : sequence of (code, message), optional
            The run's stored :attr:`warnings`; None: computed from the rows.
        flows : dict of str -> ndarray, shape (N,) [J], optional
            ``energy.work`` and ``energy.dissipated`` integrated over the
            steps of a run with rows at requested times (:attr:`flows`).
        dense : bool
            The rows are at requested times (:attr:`dense`), not one per step.
        written : sequence of str, optional
            The columns of a file written with some columns only (the
            arrays hold NaN elsewhere; :attr:`columns` and :meth:`column`
            give those alone).

        Returns
        -------
        Solution
            ``initial`` is None: a loaded run has no initial-state report.
        """
        self = cls.__new__(cls)
        self.system, self.model = system, system.model
        self.method_name, self.method_parameters = method_name, dict(method_parameters)
        self.extra_names = self._stored_extras = tuple(extra_names)
        self._output_rows = None
        self.h, self.t_end, self.initial = float(h), float(t_end), None
        self.status, self.message, self.diagnostics = status, message, []
        self.wall_time, self.stats_total = float(wall_time), stats_total
        self.timings = dict.fromkeys(cls.TIMING_NAMES, 0.0)
        self.timings.update(timings or {})
        self.engine, self.linear_solver = engine, linear_solver
        self.events, self.event_cuts = [tuple(e) for e in events], int(event_cuts)
        self.contact_log, self.engine_note, self.control = [], None, None
        self.compiled_from = None
        self.flows = None if flows is None else {k: np.asarray(x, dtype=float)
                                                 for k, x in flows.items()}
        self.dense = bool(dense) or self.flows is not None
        from ..errors import Diagnostic
        self._warnings = (None if warnings is None else
                          [Diagnostic("warning", c, m) for c, m in warnings])
        self._rows = RowStore(system.n, system.m, self.extra_names)
        self._file_rows, self._extents = None, None
        self.written = None if written is None else list(written)
        self._written_set = set(self.written or ())
        n, m = system.n, system.m
        self.t = np.asarray(t, dtype=float)
        N = len(self.t)
        self.q, self.v, self.a = (np.asarray(x, dtype=float).reshape(N, n) for x in (q, v, a))
        self.lam = np.asarray(lam, dtype=float).reshape(N, m)
        self.extras = {x: np.asarray(extras[x], dtype=float).reshape(N, m) for x in self.extra_names}
        self.stats = {k: np.asarray(stats[k]) for k in self.STAT_NAMES}
        self._derived = dict(derived) if derived else None
        self.last_state = None
        self.energy_start, self.energy_end = None, {}
        return self

    @property
    def completed(self) -> bool:
        """True when the run reached t_end."""
        return self.status == "completed"

    # -- derived quantities -------------------------------------------------------------
    def adopt_derived(self, derived: dict) -> None:
        """Take the derived columns a stream computed chunk by chunk while it
        wrote this run's rows (``stream.RowStream``), so that the summary
        does not compute them again; a no-op when this Solution has its own.

        Parameters
        ----------
        derived : dict of str -> ndarray, shape (N,)
            Every derived column (``DERIVED_NAMES``, reactions, outputs) over
            all N rows, in order.
        """
        if self._derived is None:
            self._derived = dict(derived)

    def _compute_derived(self):
        if self._derived is not None:
            return self._derived
        self._derived = derived_columns(self.system, self.t, self.q, self.v, self.lam,
                                        start=getattr(self, "energy_start", None),
                                        end=self.energy_end, a=self.a,
                                        contact_log=getattr(self, "contact_log", None),
                                        flows=getattr(self, "flows", None))
        return self._derived

    @property
    def columns(self) -> list[str]:
        """Names of every output column, in CSV order (of a result file
        written with some columns only, ``mbdsl simulate --columns``: those)."""
        if self.written is not None:
            return list(self.written)
        return result_columns(self.system, self.extra_names)

    def column_units(self) -> dict[str, str]:
        """The SI unit of every column (``""``: none, or a mix such as the
        constraint residual norms and a flexible beam's nodal coordinates).

        A multiplier has the unit of the load its row carries: N for a row
        that holds a point (revolute, fixed, point_on_line, distance; a driven
        x, y or joint distance), N m for a row that holds an angle (a fixed or
        prismatic joint's third or second row; a driven phi or joint angle).
        Outputs carry the unit their expression determines, if it does.
        Computed once per run (the model's, not the rows'): a copy is returned.
        """
        held = self.__dict__.get("_column_units")
        if held is not None:
            return dict(held)
        from ..dsl import units
        from ..model.elements import multiplier_unit
        lam = {f"lambda.{e.name}.{k}": multiplier_unit(e, k)
               for e in self.model.constraint_elements
               for k in range(getattr(e, "rows", 1))}
        outputs = {f"output.{o.name}": getattr(o, "unit", "") for o in self.model.outputs}
        out = {}
        for name in self.columns:
            if name in lam:
                out[name] = lam[name]
            elif name in outputs:
                out[name] = outputs[name]
            else:
                out[name] = units.column_unit(name)
        self._column_units = out
        return dict(out)

    #: Derived columns every model has, in CSV order.
    DERIVED_NAMES = DERIVED_NAMES

    def _beam_column(self, name: str):
        """A flexible beam's column computed from q, or None for another name."""
        head, _, tail = name.rpartition(".")
        if tail != "deflection_mid":
            return None
        for b in self.model.flexible_bodies:
            if b.name == head:
                return b.mesh.deflection_mid(self._field("q", list(b.elastic_columns())))
        return None

    def _spatial_column(self, name: str):
        """A spatial body's Euler parameters, z-y'-x'' angles or body-axis
        angular velocity (``derived.spatial_columns``) computed from q and v, for a result whose
        derived columns were read from its file without them; else None."""
        head, _, tail = name.rpartition(".")
        if tail not in ("e0", "e1", "e2", "e3", "yaw", "pitch", "roll", "wx", "wy", "wz"):
            return None
        for i, col in self.system.cmap.spatial.items():
            if self.model.bodies[i].name == head and self.system.cmap.spatial_width[i] == 12:
                cols = list(range(col + 3, col + 12))           # the directors
                return rotation_columns(head, self._field("q", cols),
                                        self._field("v", cols))[name]
        return None

    def derived(self) -> dict:
        """Energies, constraint norms and joint reactions: name -> ndarray, shape (N,)."""
        return dict(self._compute_derived())

    def column(self, name: str) -> np.ndarray:
        """One column by name, shape (N,).

        Raises
        ------
        KeyError
            With the closest names, for an unknown column.
        """
        if name == "t":
            return self.t
        if self.written is not None and name not in self._written_set:
            import difflib
            close = difflib.get_close_matches(name, self.written, n=3)
            raise KeyError(f"no column '{name}' in this result: its file was written with "
                           f"some columns only ({len(self.written)}: mbdsl simulate --columns)"
                           + (f"; did you mean {', '.join(close)}?" if close else ""))
        lay = self.system.layout
        index = self.__dict__.get("_column_index")
        if index is None:   # name -> (row array, column): a lookup per column, not a list search
            index = self._column_index = {
                c: (attr, i) for attr, names in (("q", lay.coordinates), ("v", lay.velocities),
                                                 ("a", lay.accelerations),
                                                 ("lam", lay.multiplier_names()))
                for i, c in enumerate(names)}
            self._extra_rows = {f"{a}.{b}": i for i, (a, b) in enumerate(lay.rows)}
        where = index.get(name)
        if where is not None and where[0] != "lam":
            return self._field(*where)
        if name.startswith("newton.") and name[7:] in self.STAT_NAMES[:-1]:
            return self.stats[name[7:]]
        if name == "step.h":
            return self.stats["h"]
        derived = self._compute_derived()
        if name in derived:
            return derived[name]
        beam = self._beam_column(name)
        if beam is not None:
            return beam
        turning = self._spatial_column(name)
        if turning is not None:
            return turning
        if where is not None:                       # a multiplier
            return self._field(*where)
        head, _, rest = name.partition(".")
        if head in self.extras:
            j = self._extra_rows.get(rest)
            if j is not None:
                x = self.extras
                return x.column(head, j) if isinstance(x, FileArrays) else x[head][:, j]
        import difflib
        close = difflib.get_close_matches(name, self.columns, n=3)
        raise KeyError(f"no column '{name}'" + (f"; did you mean {', '.join(close)}?" if close else ""))

    def table(self, names=None) -> tuple[list[str], np.ndarray]:
        """(column names, values of shape (N, number of columns)): every
        column (:attr:`columns`), or those of ``names``.

        Raises
        ------
        KeyError
            An unknown name (as :meth:`column`).
        """
        names = self.columns if names is None else list(names)
        return names, np.column_stack([self.column(c) for c in names])

    def run_attributes(self) -> dict:
        """What a table of this run carries besides its numbers: the model,
        method and its coefficients, status, tolerance, whether the rows are
        at requested times, the events and the run's totals (str, float or
        list values: attributes of a DataFrame or an xarray Dataset)."""
        from dataclasses import asdict
        out = {"model": self.model.name, "method": self.method_name,
               "formulation": getattr(self, "formulation", "lagrange"),
               "status": self.status, "message": self.message, "h": self.h,
               "t_end": self.t_end,
               "rows": "at requested times" if getattr(self, "dense", False) else "steps",
               "events": [list(e) for e in self.events],
               "stats_total": asdict(self.stats_total)}
        out.update({f"method.{k}": float(v) for k, v in self.method_parameters.items()})
        control = getattr(self, "control", None)
        if control is not None:
            out.update({"rtol": control.rtol, "atol": control.atol})
        return out

    def to_dataframe(self):
        """Every column as a pandas DataFrame indexed by t (pandas is optional).

        ``df.attrs["units"]`` maps each column (and "t") to its SI unit
        (:meth:`column_units`; "" for none or a mix); the other attrs are
        :meth:`run_attributes`.

        Raises
        ------
        ImportError
            When pandas is not installed, saying so.
        """
        pd = _optional("pandas", "to_dataframe")
        names, values = self.table()
        df = pd.DataFrame(values[:, 1:], index=pd.Index(values[:, 0], name="t"),
                          columns=names[1:])
        df.attrs.update(self.run_attributes())
        df.attrs["units"] = self.column_units()
        return df

    def to_xarray(self):
        """Every column as an xarray Dataset on the coordinate t (xarray is optional).

        Each column is a variable of dimension ``t`` named as in the CSV,
        with its SI unit in ``attrs["units"]``. The rigid bodies' coordinates
        are also stacked on a ``body`` dimension: variables ``x``, ``y``,
        ``phi``, ``vx``, ``vy``, ``omega`` of shape (N, bodies) (particles,
        which have no angle, and beams' elastic coordinates stay columns).
        The Dataset's attrs are :meth:`run_attributes` (the events as a JSON
        string, as netCDF takes no nested lists).

        Returns
        -------
        xarray.Dataset

        Raises
        ------
        ImportError
            When xarray is not installed, saying so.
        """
        xr = _optional("xarray", "to_xarray")
        import json
        names, values = self.table()
        units = self.column_units()
        data = {name: ("t", values[:, i], {"units": units.get(name, "")})
                for i, name in enumerate(names) if name != "t"}
        coords = set(self.system.layout.coordinates)
        bodies = [b.name for b in self.model.bodies
                  if {f"{b.name}.x", f"{b.name}.y", f"{b.name}.phi"} <= coords]
        stacked = (("x", "m"), ("y", "m"), ("phi", "rad"), ("vx", "m/s"), ("vy", "m/s"),
                   ("omega", "rad/s"))
        if bodies:
            for field, unit in stacked:
                data[field] = (("t", "body"),
                               np.column_stack([self.column(f"{b}.{field}") for b in bodies]),
                               {"units": unit})
        attrs = self.run_attributes()
        attrs["events"] = json.dumps(attrs["events"])
        attrs["stats_total"] = json.dumps(attrs["stats_total"])
        coordinates = {"t": ("t", values[:, 0], {"units": "s"})}
        if bodies:
            coordinates["body"] = ("body", bodies)
        return xr.Dataset(data, coords=coordinates, attrs=attrs)

    def _steps_summary(self, steps: int) -> str:
        """The end of the summary's line of steps: the time per step, of each
        engine apart when the run went on compiled after uncompiled steps
        (``compiled_from``): a mean over both would be neither's."""
        switch = getattr(self, "compiled_from", None)
        if not steps:
            return f"): no step recorded in {self.wall_time:.3g} s"
        if not switch:
            return f"): {1e6 * self.wall_time / steps:.1f} us/step"
        t, before, seconds = switch
        head = f"; uncompiled for the first {before} steps"
        if before:
            head += f" ({1e6 * seconds / before:.1f} us/step)"
        head += f", to t = {t:.6g} s, while the kernels were built"
        after = steps - before
        if after <= 0:
            return head + "): no compiled step"
        return head + f"): {1e6 * max(self.wall_time - seconds, 0.0) / after:.1f} us/step compiled"

    def summary(self) -> str:
        """A one-screen summary of the run."""
        tot = self.stats_total
        steps = max(tot.steps, 1)
        ext = self.extent             # first/last/largest of a column: a long run's are kept
        e, bal = ext("energy.total"), ext("energy.balance")
        lines = [
            f"model {self.model.name}: {self.method_name} "
            + ", ".join(f"{k}={v:g}" for k, v in self.method_parameters.items())
            + (", augmented Lagrangian formulation (where Phi_q loses rank only "
               "Phi_q^T lambda is unique)"
               if getattr(self, "formulation", "lagrange") == "augmented" else "")
            + (f", h = {self.h:g} s" if self.control is None else
               f", error-controlled steps (rtol {self.control.rtol:g}, atol "
               f"{self.control.atol:g}; h from {np.min(self.stats['h'][1:], initial=self.h):.3g} "
               f"to {np.max(self.stats['h'][1:], initial=self.h):.3g} s)")
            + f", t = {self.t[0]:g} .. {self.t[-1]:g} s ({self.status}"
            + "".join(f"; {w.code}: {w.message.split(':')[0]}" for w in self.warnings
                      if w.code in GUARD_CODES) + ")",
            f"  steps {tot.steps} (rejected {tot.rejected}) on the {self.engine} engine "
            f"({self.linear_solver} linear solver"
            + (f"; not compiled: {self.engine_note}" if getattr(self, "engine_note", None) else "")
            + self._steps_summary(tot.steps),
            "  wall time: " + ", ".join(f"{k} {v:.3f} s" for k, v in self.timings.items()),
            f"  Newton: {tot.iterations / steps:.2f} iterations/step, {tot.jacobians} Jacobians, "
            f"{tot.factorizations} factorizations, {tot.residuals} residuals"
            + (f"; {tot.multipliers_stalled} steps with multipliers at round-off"
               if tot.multipliers_stalled else ""),
            f"  max |Phi| = {ext('constraint.position').max:.2e}, "
            f"max |Phi_q v + Phi_t| = {ext('constraint.velocity').max:.2e}",
            f"  energy: {e.first:.6g} J -> {e.last:.6g} J (change {e.last - e.first:+.3e} J; "
            f"work {ext('energy.work').last:+.4g} J, dissipated "
            f"{ext('energy.dissipated').last:.4g} J; balance max {bal.absmax:.2e} J)",
        ]
        if self.events or getattr(self.system, "contact_state", None) is not None:
            words = {"closed": "closed", "opened": "opened",
                     "passed": "springs through zero length", "switched": "function switches"}
            counts = {k: sum(1 for e in self.events if e[2] == k) for k in words}
            contacts = getattr(self.system, "contact_state", None) is not None
            lines.append(f"  events: {len(self.events)} ("
                         + ", ".join(f"{n} {words[k]}" for k, n in counts.items()
                                     if n or (contacts and k in ("closed", "opened")))
                         + (f"; last: {self.events[-1][1]} {self.events[-1][2]} at t = "
                            f"{self.events[-1][0]:.6g} s" if self.events else "")
                         + f"); {self.event_cuts} steps retaken to land on them")
        if self.status != "completed":
            lines.append(f"  stopped: {self.message}")
        for w in self.warnings:
            if w.code in GUARD_CODES:
                lines.append(f"  warning {w.code}: {w.message}")
        return "\n".join(lines)
