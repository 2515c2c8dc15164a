"""The assembled equations of motion of a planar multibody model.

    M(q) a + Phi_q(q,t)^T lambda = Q(t, q, v)      (n equations)
    Phi(q, t) = 0                                 (m equations)

with every derivative an implicit integrator needs, all analytic:
Phi_q, Phi_t, Phi_tt, Phi_qt, gamma = -(Phi_q v)_q v - 2 Phi_qt v - Phi_tt,
Q_q, Q_v, (Phi_q^T lambda)_q, (Phi_q v)_q and (M a)_q.

Notation for the whole package: n generalized coordinates (3 per rigid body:
x, y, phi of the centre of mass; 3 per flexible beam for its floating frame,
plus its elastic coordinates, stored after those of all bodies), m
constraint equations (joint rows in
declaration order, then driver rows). Sign convention:
``M a + Phi_q^T lambda = Q``, so lambda is the negative of the constraint
force in the joint's row direction. SI units.

Every matrix term also exists as values on a sparsity pattern fixed by the
model (``pattern_*`` attributes and ``*_values`` methods), which is what the
Newton matrices are assembled from (``assembly/sparse.py``); the dense
``Phi_q``, ``PhiqT_lam_q``, ... are built from the same patterns. Residuals use
the matrix-free products ``PhiqT_times`` and ``Phiq_times``.

The physics of every element (joints, drivers, applied loads, contacts,
flexible beams) is evaluated by the kernels of ``mbdsl/kernels``,
its one implementation, through :meth:`AssembledSystem.kernel_model`; the
kernels' joint and load families pack the joints, drivers and loads from the
model, the groups of ``contact.py`` and ``ffr.py`` hold the contacts' state and
the flexible beams' shape integrals. The constraint patterns are the kernels'
triplets; the loads' patterns are the pairs of the columns each instance's
derivatives may fill (the families' ``pattern``).

Only what the model declares is built and evaluated: a model without gravity
has no gravity vector, a model without springs no spring data, and the
force derivatives are ``None`` when no declared force depends on q or v.

The :class:`AssembledSystem` never changes once built (model/data split):
per-step values live in the integrators' state. What it derives on first use
(the kernels' packed model data, the constraint patterns) is a cache of
things fixed by the model.
"""

from __future__ import annotations

import operator

import numpy as np

from ..gcpause import paused
from ..model.contact import GAP_WIDTH, Contact
from ..model.elements import Model
from . import ffr
from .layout import Layout

__all__ = ["AssembledSystem", "assemble"]

_mass, _inertia = operator.attrgetter("mass"), operator.attrgetter("inertia")


class AssembledSystem:
    """Equations of motion, constraints and their derivatives for a Model.

    Parameters
    ----------
    model : Model

    Attributes
    ----------
    n, m : int
        Numbers of coordinates and of constraint equations.
    layout : Layout
        Maps coordinates and constraint rows back to bodies and joints.
    mass_is_constant : bool
        True for rigid bodies only: (M a)_q = 0 and M is diagonal. False
        with a flexible beam: M(q) has a dense block per beam.
    mass_diag : ndarray, shape (n,)
        The diagonal of M for rigid bodies; for a flexible beam the
        diagonal of its undeformed mass matrix (m, m, I0, diag M_ff), used
        only to scale multipliers and tolerances.
    beam_sets : list of BeamSet
        Where the flexible beams sit, by their number of elastic coordinates
        (:func:`~.ffr.beam_sets`); empty without flexible beams.
    beam_gravity : ndarray, shape (2,), or None
        Gravity the beams' kernels apply [m/s^2]; None without gravity.
    """

    def __init__(self, model: Model):
        self.model = model
        self.layout = Layout(model)
        n = self.n = model.n_coordinates
        self.m = model.n_constraints
        self.nx = n + 3                      # extended: ground coordinates at n..n+2
        mass = np.zeros(n)
        cmap = self.cmap = model.coordinate_map
        kinds, bodies = model.body_kinds, model.bodies
        #: each body's mass [kg], shape (n_bodies,)
        self.body_mass = np.fromiter(map(_mass, bodies), dtype=float, count=len(bodies))
        planar = kinds.code_in(kinds.space == 2)
        # a particle's phi is the ground's dummy n+2, outside q: dropped
        mass[cmap.table[planar, :2]] = self.body_mass[planar, None]
        own = planar[cmap.table[planar, 2] < n]
        mass[cmap.table[own, 2]] = np.fromiter(
            map(_inertia, bodies if len(own) == len(bodies) else [bodies[i] for i in own]),
            dtype=float, count=len(own))
        for i, col in cmap.spatial.items():          # m, m, m, Jbar_k (``model.spatial``)
            mass[col:col + cmap.spatial_width[i]] = model.bodies[i].mass_diagonal
        self.beam_gravity = model.gravity if model.gravity is not None \
            and np.any(model.gravity != 0.0) else None
        self.beam_sets = ffr.beam_sets(cmap, model.flexible_bodies)
        rigid = np.ones(n, dtype=bool)
        for s in self.beam_sets:
            mass[s.cols] = [b.mass_diagonal for b in s.beams]
            rigid[s.cols.ravel()] = False
        self._kernel_models, self._kernels_built = {}, None    # {compiled: PackedModel}
        # a first-order state's integral: unit mass under its rate (``FirstOrderState``)
        mass[list(cmap.states)] = 1.0
        self.mass_diag = mass
        self._rigid_cols = np.flatnonzero(rigid)
        #: the columns of the first-order states (integrals in q, values in v): no
        #: kinetic energy, their rates no power (``kinetic_energy``, ``kernels.system._power``)
        self.state_cols = np.array(list(cmap.states), dtype=np.intp)
        self.mass_is_constant = not self.beam_sets
        self._build_constraints(model)
        self._build_forces(model)

    # -- build ------------------------------------------------------------------
    def _build_constraints(self, model):
        """The joints, drivers and couplers: each element's first row of lambda
        (joints in declaration order, then drivers, then couplers). Their rows' data are packed from the
        model by the kernels' joint families (``packing.PackedModel``); their
        sparsity patterns are the kernels' triplets, read once, on first use
        (``_constraint_pattern``)."""
        lay = self.layout
        #: joint name -> its first row of lambda (a mapping)
        self.joint_rows = lay.first_rows(len(model.joints))
        assert lay.element_start[-1] == self.m
        #: the drivers' functions of time f(t) (rows q_c - f, phi2 - phi1 - f, s - f)
        self.driver_functions = [d.function for d in model.drivers]
        self._patterns = {}

    def _build_forces(self, model):
        """The applied loads: gravity's constant Q, what the loads keep
        (:meth:`_load_groups`) and the mass matrix's pattern; the patterns of
        the loads' derivatives are built on first use (:meth:`_load_patterns`)."""
        n, cmap = self.n, self.cmap
        self.gravity_force = None
        if model.gravity is not None and np.any(model.gravity != 0.0):
            Qg = np.zeros(n)
            kinds = model.body_kinds
            own = kinds.code_in(~kinds.flexible)             # beams: in their own group
            with np.errstate(over="ignore"):                 # an overflow is E506 at the start
                Qg[cmap.table[own, :len(model.gravity)]] = \
                    self.body_mass[own, None] * model.gravity
            self.gravity_force = Qg
        self._load_groups(model)
        rc = self._rigid_cols
        #: (rows, cols) of the diagonal of (n, n)
        self.pattern_diagonal = (np.arange(self.n), np.arange(self.n))
        blocks = [ffr.mass_pattern(s) for s in self.beam_sets]
        self.pattern_mass = _concat_pattern([rc] + [p[0] for p in blocks],
                                            [rc] + [p[1] for p in blocks])

    def _load_groups(self, model):
        """What the loads keep beyond the model: the contacts' run state
        (:class:`~.contact.ContactState`), the springs' held directions;
        the loads' data themselves are packed from the model by the kernels'
        load families (``kernels/loads``, ``packing.PackedModel``)."""
        forces = model.loads
        #: The friction elements, in the model's order: their loads read
        #: lambda, Q(t, q, v, lambda).
        self.frictions = [f for f in forces if f.kind == "friction"]
        springs = [f for f in forces if f.kind == "spring"]
        #: The number of spring-dampers (``spring_separations``).
        self.spring_count = len(springs)
        #: The direction each spring holds while a step is landed on a pass of
        #: its points (``kernels.loads.spring_damper._free_length``), (k, 2);
        #: zeros: none held, the physical law. Written by the event locator.
        self.spring_held = np.zeros((len(springs), 2))
        #: Spring-dampers with a free length whose force direction flips when
        #: their two points pass each other (events): [(index, name)], or None.
        self.flipping_springs = [(i, s.name) for i, s in enumerate(springs)
                                 if s.length > 0.0] or None
        #: The functions of time and of the state the loads read (torques,
        #: forces in joints, point forces), in the model's order.
        self.load_functions = [fn for f in forces for fn in getattr(f, "functions", ())]
        #: The kinks of the tables of the state the loads read
        #: (``model.elements.StateSwitch``), each call once, located as events
        #: (``integrators.events.EventLocator``), or None.
        switches = {}
        for fn in self.load_functions:
            for s in getattr(fn, "switches", ()):
                switches.setdefault(s.text, s)
        self.state_switches = list(switches.values()) or None
        #: Whether any load or flexible beam adds to Q beyond gravity.
        self.has_loads = bool(forces) or bool(self.beam_sets)
        from .contact import ContactState
        contacts = [f for f in forces if isinstance(f, Contact)]
        #: The contacts' and joint limits' run state (per gap: its impact speed, the
        #: log of closings and openings; with events), or None.
        self.contact_state = ContactState(self.cmap, contacts) if contacts else None
        if contacts:
            self.contact_state.bind(self.contact_gaps)
        self._load_pattern = None

    def _load_patterns(self):
        """The patterns (row, column) of Q_lambda (friction), of Q_q and Q_v
        and whether each exists, from the load families' ``pattern`` (the
        columns each instance's derivatives may fill: every pair of them is in
        the pattern) and the flexible beams' columns; built on first use, with
        the kernels this process calls (:meth:`kernel_model`)."""
        if self._load_pattern is not None:
            return self._load_pattern
        from .packing import PackingContext
        n, forces = self.n, self.model.loads
        tables = PackingContext(self)
        blocks, damped, fr, fc = [], False, [], []
        for family in self.kernel_model().K.LOAD_FAMILIES:
            items = [f for f in forces if f.kind in family.LOADS]
            found = family.pattern(items, tables) if items else None
            if found is not None:
                blocks.append(found[0])
                damped = damped or found[1]
            if items and hasattr(family, "multiplier_pattern"):
                for cols, rows in zip(*family.multiplier_pattern(items, tables)):
                    r, c = np.repeat(cols, len(rows)), np.tile(rows, len(cols))
                    fr.append(r[r < n])
                    fc.append(c[r < n])
        blocks += [s.cols for s in self.beam_sets]
        damped = damped or bool(self.beam_sets)   # the quadratic velocity vector
        pr, pc = [], []
        for cols in blocks:
            ci = np.broadcast_to(cols[:, :, None], (len(cols),) + (cols.shape[1],) * 2)
            cj = np.broadcast_to(cols[:, None, :], ci.shape)
            mask = (ci < n) & (cj < n)
            pr.append(ci[mask])
            pc.append(cj[mask])
        self._load_pattern = {
            "force": _unique_pattern(pr, pc, n), "has_Q_q": bool(blocks),
            "has_Q_v": damped, "force_lam": _unique_pattern(fr, fc, self.m) if fr else None}
        return self._load_pattern

    @property
    def pattern_force(self):
        """(rows, cols) of Q_q and Q_v in (n, n), unique pairs sorted."""
        return self._load_patterns()["force"]

    @property
    def pattern_force_lam(self):
        """(rows of Q, rows of lambda) of Q_lambda (friction), unique pairs
        sorted; None without friction."""
        return self._load_patterns()["force_lam"]

    @property
    def has_Q_q(self) -> bool:
        """Whether a declared load depends on q (every load but torques of time)."""
        return self._load_patterns()["has_Q_q"]

    @property
    def has_Q_v(self) -> bool:
        """Whether a declared load depends on v (a damper, friction, a rate a
        load reads, a contact's damping, a flexible beam)."""
        return self._load_patterns()["has_Q_v"]

    # -- kernels ------------------------------------------------------------------
    #: Which kernels evaluate this system outside the compiled loop: "auto" (see
    #: :meth:`kernel_model`) or "uncompiled" (the uncompiled engine's runs: nothing
    #: compiled is imported).
    kernels = "auto"

    def kernel_model(self):
        """The model data packed for the element kernels (``packing.PackedModel``
        on ``kernels.api``), on the kernels this process can call without
        compiling: the compiled ones once it has loaded them or the machine's
        cache holds them (``kernels.cache``), else their uncompiled copy (always with
        ``kernels = "uncompiled"``). Built once per kind and kept; the joints,
        drivers and flexible beams, whose physics the kernels alone evaluate,
        call them through it."""
        from ..kernels import cache
        compiled = False
        if self.kernels != "uncompiled":
            if True in self._kernel_models:
                return self._kernel_models[True]
            if self._kernels_built is None:              # the marker: read once per system
                self._kernels_built = cache.kernels_ready()
            compiled = cache.loaded() or self._kernels_built
        cm = self._kernel_models.get(compiled)
        if cm is None:
            from .packing import PackedModel
            cm = self._kernel_models[compiled] = PackedModel(
                self, cache.element_kernels(uncompiled=not compiled))
        return cm

    def __getstate__(self):
        """Pickled without the kernel models (they hold a module)."""
        state = self.__dict__.copy()
        state["_kernel_models"], state["_kernels_built"] = {}, None
        state.pop("_run_models", None)
        return state

    # -- helpers ------------------------------------------------------------------
    def _ext(self, x):
        """x (..., n) -> (..., n + 3) with the ground's three zero coordinates."""
        out = np.zeros(np.shape(x)[:-1] + (self.nx,))
        out[..., : self.n] = x
        return out

    @staticmethod
    def _dense(pattern, vals, shape) -> np.ndarray:
        rows, cols = pattern
        flat = rows.astype(np.int64) * shape[1] + cols
        return np.bincount(flat, weights=vals, minlength=shape[0] * shape[1]).reshape(shape)

    # -- mass -----------------------------------------------------------------------
    def _beam_mass_blocks(self, q) -> list:
        """M(q) of the beams of each :class:`~.ffr.BeamSet`, shapes (k, c, c)."""
        if not self.beam_sets:
            return []
        cm = self.kernel_model()
        return [ffr.mass_blocks(cm, s, q) for s in self.beam_sets]

    def mass_matrix(self, q=None) -> np.ndarray:
        """M(q) as a dense array, shape (n, n) [kg, kg m, kg m^2], built on request.

        For dense solves off the hot path (initial conditions of small models,
        the index-1 reference); the integrators use ``mass_values`` and
        ``mass_times``.
        """
        if self.mass_is_constant:
            return np.diag(self.mass_diag)
        return self._dense(self.pattern_mass, self.mass_values(q), (self.n, self.n))

    def mass_values(self, q=None) -> np.ndarray:
        """Values of M(q) on ``pattern_mass``: the diagonal of the rigid bodies,
        then the dense block of every flexible beam, shape (nnz,)."""
        if self.mass_is_constant:
            return self.mass_diag
        return np.concatenate([self.mass_diag[self._rigid_cols]]
                              + [b.ravel() for b in self._beam_mass_blocks(q)])

    def mass_sparse(self, q=None):
        """M(q) as a scipy.sparse CSC matrix, shape (n, n)."""
        import scipy.sparse
        return scipy.sparse.csc_matrix((self.mass_values(q), self.pattern_mass),
                                       shape=(self.n, self.n))

    def mass_times(self, q, a) -> np.ndarray:
        """M(q) a, shape (n,)."""
        out = self.mass_diag * a
        for s, M in zip(self.beam_sets, self._beam_mass_blocks(q)):
            out[s.cols] = np.einsum("kij,kj->ki", M, a[s.cols])
        return out

    def mass_solve(self, q, X) -> np.ndarray:
        """M(q)^{-1} X for X of shape (n,) or (n, k): a division for rigid
        bodies, a dense solve per flexible beam block."""
        X = np.asarray(X, dtype=float)
        out = X / (self.mass_diag if X.ndim == 1 else self.mass_diag[:, None])
        for s, M in zip(self.beam_sets, self._beam_mass_blocks(q)):
            rhs = X[s.cols] if X.ndim == 2 else X[s.cols][..., None]
            sol = np.linalg.solve(M, rhs)
            out[s.cols] = sol if X.ndim == 2 else sol[..., 0]
        return out

    def Ma_q_values(self, q, a):
        """Values of (M(q) a)_q on ``pattern_mass`` (zero on the rigid
        diagonal), or None when M is constant (rigid bodies only)."""
        if self.mass_is_constant:
            return None
        return np.concatenate([np.zeros(len(self._rigid_cols))]
                              + [ffr.Ma_q(self.kernel_model(), s, q, a).ravel()
                                 for s in self.beam_sets])

    def Ma_q(self, q, a):
        """(M(q) a)_q, shape (n, n), or None when M is constant (rigid bodies)."""
        vals = self.Ma_q_values(q, a)
        return None if vals is None else self._dense(self.pattern_mass, vals, (self.n, self.n))

    def multiplier_mobility(self, q, t=0.0) -> np.ndarray:
        """Largest acceleration a unit multiplier of each row causes, shape (m,).

        max over the element's rows k and columns j of |Phi_q[k, j]| / M_jj
        [1/kg, or rad/(s^2 N) for rotations], the same for every row of one
        joint or driver (a single row can vanish at a particular angle).
        Converts multipliers to velocity changes in the Newton test: on
        Andrews' mechanism a multiplier moves a rotation (lever arm / I ~ 3e4)
        far more than a translation (1/m ~ 30).
        """
        rows, cols = self.pattern_Phi_q
        # a column without mass (a spatial body's director of a flat plate or a thin rod,
        # ``model.spatial``) is moved by no multiplier's force alone: left out
        mass = self.mass_diag[cols]
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.where(mass > 0.0, np.abs(self.Phi_q_values(q, t)) / mass, 0.0)
        element = self.layout.row_element            # constraint row -> element number
        per_element = np.zeros(self.layout.n_elements)
        np.maximum.at(per_element, element[rows], ratio)
        return per_element[element]

    # -- forces -------------------------------------------------------------------------
    # Evaluated by the kernels (``kernels.system.elements``), the one implementation of the
    # applied loads (gravity, spring-dampers, torques, point forces, loads of the
    # state, friction, contacts, flexible beams).
    _EMPTY_I, _EMPTY_1, _EMPTY_F = np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 0))

    def _needs(self, lam):
        if lam is None and self.frictions:
            raise ValueError("the model has friction: its forces need the multipliers lambda")

    def _elements(self, what, rows, t, vx, y, out, slip=None, speeds=None, R=None, C=None,
                  V=None):
        """``kernels.system.elements`` at the rows (N, nx) (joints and drivers:
        ``what`` a C_*; applied loads: an L_*), one argument type per slot:
        t (N,), vx (N, nx) and y (N, m or nx) zeros when not given, slip (k,)
        and speeds (N, k) empty, unused outputs empty arrays. The contacts'
        impact speeds in force are the contacts' run state's (``contact_state``)."""
        cm = self.kernel_model()
        if self.contact_state is not None:
            cm.impact_speed[:] = self.contact_state.impact_speed
        if self.flipping_springs is not None:    # the held directions (landing on a pass)
            cm.spring_held[:] = self.spring_held
        N = len(rows)
        # fresh, writable copies (numba types a read-only view, as np.broadcast_to
        # gives, as another signature: one more library to load)
        t = np.array(np.broadcast_to(np.asarray(t, dtype=float), (N,)))
        vx = np.zeros_like(rows) if vx is None else np.require(vx, float, ("C", "W"))
        y = np.zeros((N, self.m)) if y is None else np.array(
            np.broadcast_to(np.asarray(y, dtype=float), (N, np.shape(y)[-1])))
        slip = self._EMPTY_1 if slip is None else np.array(slip, dtype=float)
        speeds = np.zeros((N, 0)) if speeds is None else np.array(speeds, dtype=float)
        return cm.K.elements(cm.ints, cm.floats, what, t, rows, vx, y, slip, speeds,
                             self._EMPTY_F if out is None else out,
                             self._EMPTY_I if R is None else R,
                             self._EMPTY_I if C is None else C,
                             self._EMPTY_F if V is None else V)

    def _load_values(self, what, pattern, width, t, q, v, lam):
        """Values of Q_q, Q_v (``what`` _L_QQ, _L_QV) or Q_lambda (_L_QLAM)
        on ``pattern`` ((rows, cols) in (n, width), unique pairs sorted by
        row, then column): the kernels' triplets summed into it.

        Raises
        ------
        RuntimeError
            A triplet outside the pattern (the group data and the kernels
            disagree: a developer's error).
        """
        keys = pattern[0].astype(np.int64) * width + pattern[1]
        bound = self.kernel_model().bound
        R, C, V = np.empty(bound, np.int64), np.empty(bound, np.int64), np.empty((1, bound))
        p = self._elements(what, self._ext(q)[None], t, self._ext(v)[None],
                           None if lam is None else np.asarray(lam)[None], None, R=R, C=C, V=V)
        got = R[:p] * width + C[:p]
        where = np.minimum(np.searchsorted(keys, got), max(len(keys) - 1, 0))
        if p and (not len(keys) or np.any(keys[where] != got)):
            raise RuntimeError("the kernels' load derivatives leave the model's pattern")
        return np.bincount(where, weights=V[0, :p], minlength=len(keys))

    def Q(self, t, q, v, lam=None, slip=None) -> np.ndarray:
        """Generalized applied forces Q(t, q, v[, lambda]), shape (n,) [N, N m].

        ``slip``: friction's tanh(z/v_reg) replaced, per friction instance
        (NaN: not), for the Coulomb limit at rest (``kernels.loads.friction._friction_law``).

        Raises
        ------
        ValueError
            ``lam`` (m,) not given for a model with friction (its normal
            loads are reactions).
        """
        if not self.has_loads:
            return np.zeros(self.n) if self.gravity_force is None else self.gravity_force.copy()
        self._needs(lam)
        out = np.empty((1, self.nx))
        self._elements(_L_Q, self._ext(q)[None], t, self._ext(v)[None],
                       None if lam is None else np.asarray(lam)[None], out, slip=slip)
        return out[0, : self.n]

    def Q_lam_values(self, t, q, v, lam):
        """dQ/dlambda values on ``pattern_force_lam`` (friction), or None
        without friction."""
        if not self.frictions:
            return None
        return self._load_values(_L_QLAM, self.pattern_force_lam, self.m, t, q, v, lam)

    def Q_lam(self, t, q, v, lam):
        """dQ/dlambda, shape (n, m), or None without friction."""
        vals = self.Q_lam_values(t, q, v, lam)
        return None if vals is None else self._dense(self.pattern_force_lam, vals,
                                                     (self.n, self.m))

    def force_derivative_values(self, t, q, v, lam=None):
        """(Q_q, Q_v) values on ``pattern_force``, or None where no declared
        force depends on q (resp. v); ``lam`` as in :meth:`Q`."""
        if not self.has_Q_q:
            return None, None
        self._needs(lam)
        Qq = self._load_values(_L_QQ, self.pattern_force, self.n, t, q, v, lam)
        Qv = self._load_values(_L_QV, self.pattern_force, self.n, t, q, v, lam) \
            if self.has_Q_v else None
        return Qq, Qv

    def force_derivatives(self, t, q, v, lam=None):
        """(Q_q, Q_v), each shape (n, n), or None where no declared force
        depends on q (resp. v); ``lam`` as in :meth:`Q`."""
        Qq, Qv = self.force_derivative_values(t, q, v, lam)
        shape = (self.n, self.n)
        return (None if Qq is None else self._dense(self.pattern_force, Qq, shape),
                None if Qv is None else self._dense(self.pattern_force, Qv, shape))

    def spring_separations(self, q) -> np.ndarray:
        """d = p2 - p1 of every spring-damper at q (n,), shape (k, 2) [m]."""
        k = self.spring_count
        out = np.empty((1, 2 * k))
        if k:
            self._elements(_L_SPRINGS, self._ext(q)[None], 0.0, None, None, out)
        return out[0].reshape(k, 2)

    def contact_gaps(self, qx):
        """The contacts' gaps g, shape (k,) [m or rad], and their gradients
        over each gap's columns (``ContactState.cols``), shape (k, GAP_WIDTH),
        at the extended configuration qx (nx,)."""
        k = len(self.contact_state.names)
        out = np.empty((1, (1 + GAP_WIDTH) * k))
        self._elements(_L_GAPS, np.ascontiguousarray(qx, dtype=float)[None], 0.0, None, None, out)
        return out[0, :k], out[0, k:].reshape(k, GAP_WIDTH)

    def sensor_values(self, t, q, v, lam, contact_log=()):
        """What the force elements do at rows of a run.

        Parameters
        ----------
        t : ndarray, shape (N,) [s]
        q, v : ndarray, shape (N, n)
        lam : ndarray, shape (N, m)
        contact_log : sequence of (t, gap, speed)
            The run's contact state changes (``Solution.contact_log``): the
            impact speeds behind the contacts' damping.

        Returns
        -------
        dict of str -> ndarray
            ``"gap"`` (N, k, 6), per gap (``contact_state.names``): g [m or
            rad], dg/dt, the normal force f [N or N m], the friction force
            along the tangent t = (n_y, -n_x) of the contact normal n (a
            contact on a line: the line's direction) [N], the power the
            contact dissipates [W] and its elastic energy [J];
            ``"friction"`` (N, kf, 3), per friction joint (``model.forces``
            order): its speed z [rad/s or m/s], its friction load tau [N m or
            N] and the power it dissipates -tau z [W]; ``"spring"`` (N, ks,
            5), per spring-damper: length [m], its rate, tension [N], energy
            [J], power dissipated [W]; ``"rotational"`` (N, kr, 5), per
            rotational spring-damper the same of its angle [rad, rad/s, N m,
            J, W]. From ``kernels.system.elements``, L_SENSORS: the laws the run's
            forces use (its F_t is along -t).
        """
        g = self.contact_state
        forces = self.model.forces
        sizes = {"gap": (len(g.names) if g is not None else 0, 6),
                 "friction": (len(self.frictions), 3),
                 "spring": (self.spring_count, 5),
                 "rotational": (sum(f.kind == "rotational" for f in forces), 5)}
        rows, _ = self._ext_rows(q)
        N = len(rows)
        out = np.zeros((N, sum(k * w for k, w in sizes.values())))
        if N and out.shape[1]:
            speeds = g.speeds_at(t, contact_log) if g is not None else None
            self._elements(_L_SENSORS, rows, t, self._ext_rows(v)[0],
                           np.reshape(lam, (N, self.m)), out, speeds=speeds)
        found, col = {}, 0
        for name, (k, w) in sizes.items():
            found[name] = out[:, col:col + k * w].reshape(N, k, w)
            col += k * w
        found["gap"][:, :, 3] *= -1.0     # along t, not along the kernel's slip direction
        return found

    def friction_speeds(self, q, v, a=None):
        """Per friction joint its speed z (omega_2 - omega_1 or ds/dt), or
        with accelerations ``a`` (n,) its rate dz/dt = w . a + v^T (d^2 s) v,
        shape (k,)."""
        k = len(self.frictions)
        out = np.empty((1, 2 * k))
        acc = self._ext(np.zeros(self.n) if a is None else a)[None]
        self._elements(_L_SLIP, self._ext(q)[None], 0.0, self._ext(v)[None], acc, out)
        return out[0, :k] if a is None else out[0, k:]

    # -- constraints ------------------------------------------------------------------
    # Evaluated by the kernels (``kernels.system.elements``), the one implementation of
    # the joints and drivers; every function takes one state or rows of a stored
    # solution.

    def _ext_rows(self, x):
        """x (n,) or (..., n) -> contiguous rows (N, nx) with the ground's three
        zeros, and the leading shape (...)."""
        qx = self._ext(np.asarray(x, dtype=float))       # a fresh contiguous array
        return qx.reshape(-1, self.nx), qx.shape[:-1]

    def _constraints(self, what, rows, t, y, out, R=None, C=None, V=None):
        """:meth:`_elements` for the joints and drivers (``what`` a C_*)."""
        return self._elements(what, rows, t, None, y, out, R=R, C=C, V=V)

    def _constraint_pattern(self, what: int):
        """(rows, cols) of the triplets of Phi_q (``what`` C_PHIQ = 5),
        (Phi_q^T lambda)_q (6) or (Phi_q v)_q (7), each shape (nnz,), fixed by
        the model."""
        pattern = self._patterns.get(what)
        if pattern is None:
            bound = self.kernel_model().bound
            R, C = np.empty(bound, np.int64), np.empty(bound, np.int64)
            p = self._constraints(what, np.zeros((1, self.nx)), 0.0,
                                  np.zeros((1, self.nx + self.m)), None, R, C,
                                  np.empty((1, bound)))
            pattern = self._patterns[what] = (R[:p].astype(np.intp), C[:p].astype(np.intp))
        return pattern

    @property
    def pattern_Phi_q(self):
        """(rows, cols) of ``Phi_q_values``, each shape (nnz,), in (m, n)."""
        return self._constraint_pattern(_C_PHIQ)

    @property
    def pattern_hessian(self):
        """(rows, cols) of ``PhiqT_lam_q_values``, each shape (nnz,), in (n, n)."""
        return self._constraint_pattern(_C_PHIQT_Y_Q)

    @property
    def pattern_Phiq_v_q(self):
        """(rows, cols) of ``Phiq_v_q_values``, each shape (nnz,), in (m, n)."""
        return self._constraint_pattern(_C_PHIQ_Y_Q)

    def _constraint_values(self, what, q, y, width):
        """Values of a constraint matrix (``_constraint_pattern``) at rows q
        (..., n) with y (..., width) (lambda, or v padded with the ground's
        zeros to nx), shape (..., nnz)."""
        rows, lead = self._ext_rows(q)
        nnz = len(self._constraint_pattern(what)[0])
        yr = np.zeros((len(rows), max(width, 1)))
        if y is not None:
            yy = np.asarray(y, dtype=float)
            yr[:, : yy.shape[-1]] = np.broadcast_to(yy, lead + yy.shape[-1:]).reshape(len(rows), -1)
        V = np.empty((len(rows), nnz))
        if nnz and len(rows):
            self._constraints(what, rows, 0.0, yr, None, np.empty(nnz, np.int64),
                              np.empty(nnz, np.int64), V)
        return V.reshape(lead + (nnz,))

    def _constraint_rows(self, what, q, t, lead=None):
        """Phi, Phi_t or Phi_tt (``what`` _C_PHI, _C_PHI_T, _C_PHI_TT) at rows, shape (..., m)."""
        if lead is None:
            rows, lead = self._ext_rows(q)
        else:                                     # Phi_t, Phi_tt: q is not read
            rows = np.zeros((int(np.prod(lead, dtype=int)), self.nx))
        out = np.empty((len(rows), self.m))
        if self.m and len(rows):
            self._constraints(what, rows, np.reshape(t, -1), None, out)
        return out.reshape(lead + (self.m,))

    def Phi(self, q, t) -> np.ndarray:
        """Constraint values Phi(q, t), shape (m,) [m or rad].

        Rows of a stored solution at once: q of shape (N, n) and t of shape
        (N,) give shape (N, m).
        """
        return self._constraint_rows(_C_PHI, q, t)

    def Phi_q_values(self, q, t=0.0) -> np.ndarray:
        """Values of Phi_q on ``pattern_Phi_q``, shape (nnz,), or (N, nnz)
        for rows q of shape (N, n)."""
        return self._constraint_values(_C_PHIQ, q, None, 0)

    def Phi_q(self, q, t=0.0) -> np.ndarray:
        """Constraint Jacobian, shape (m, n)."""
        return self._dense(self.pattern_Phi_q, self.Phi_q_values(q, t), (self.m, self.n))

    def PhiqT_times(self, q, t, lam) -> np.ndarray:
        """Phi_q^T lambda, shape (n,), without forming Phi_q."""
        rows, _ = self._ext_rows(q)
        out = np.zeros((1, self.nx))
        if self.m:
            self._constraints(_C_PHIQT_Y, rows, t, np.reshape(lam, (1, self.m)), out)
        return out[0, : self.n]

    def Phiq_times(self, q, t, v) -> np.ndarray:
        """Phi_q v, shape (m,), without forming Phi_q; (N, m) for rows q, v
        of shape (N, n)."""
        rows, lead = self._ext_rows(q)
        vrows, _ = self._ext_rows(np.broadcast_to(v, lead + (self.n,)))
        out = np.empty((len(rows), self.m))
        if self.m and len(rows):
            self._constraints(_C_PHIQ_Y, rows, t, vrows, out)
        return out.reshape(lead + (self.m,))

    def Phi_t(self, q, t) -> np.ndarray:
        """Partial time derivative of Phi, shape (m,), or (N, m) for times t
        of shape (N,)."""
        return self._constraint_rows(_C_PHI_T, None, t, lead=np.shape(t))

    def Phi_tt(self, q, t) -> np.ndarray:
        """Second partial time derivative of Phi, shape (m,)."""
        return self._constraint_rows(_C_PHI_TT, None, t, lead=np.shape(t))

    def Phi_qt(self, q, t) -> np.ndarray:
        """Mixed derivative Phi_qt, shape (m, n).

        Zero for every constraint mbdsl provides: drivers prescribe a
        coordinate or a relative angle, linear in q with a time-only term.
        Kept so that gamma and the index-2 velocity constraints are written
        in full.
        """
        return np.zeros((self.m, self.n))

    def Phiq_v_q_values(self, q, v) -> np.ndarray:
        """Values of (Phi_q v)_q on ``pattern_Phiq_v_q``."""
        return self._constraint_values(_C_PHIQ_Y_Q, q, v, self.nx)

    def Phiq_v_q(self, q, v) -> np.ndarray:
        """(Phi_q v)_q, shape (m, n)."""
        return self._dense(self.pattern_Phiq_v_q, self.Phiq_v_q_values(q, v), (self.m, self.n))

    def PhiqT_lam_q_values(self, q, lam) -> np.ndarray:
        """Values of (Phi_q^T lambda)_q on ``pattern_hessian``."""
        return self._constraint_values(_C_PHIQT_Y_Q, q, lam, self.m)

    def PhiqT_lam_q(self, q, lam) -> np.ndarray:
        """(Phi_q^T lambda)_q, shape (n, n), symmetric."""
        return self._dense(self.pattern_hessian, self.PhiqT_lam_q_values(q, lam), (self.n, self.n))

    def gamma(self, q, v, t) -> np.ndarray:
        """Acceleration right side gamma = -(Phi_q v)_q v - 2 Phi_qt v - Phi_tt,
        shape (m,) (Phi_qt = 0: :meth:`Phi_qt`)."""
        rows, cols = self.pattern_Phiq_v_q
        v = np.asarray(v, dtype=float)
        out = -np.bincount(rows, weights=self.Phiq_v_q_values(q, v) * v[cols], minlength=self.m)
        return out - self.Phi_tt(q, t)

    def index1_multipliers(self, t, q, v) -> np.ndarray:
        """lambda from the index-1 system at each state, shape (N, m).

        [[M(q), Phi_q^T], [Phi_q, 0]] [a; lambda] = [Q(t, q, v); gamma(q, v, t)]:
        the Lagrange multipliers of the equations of motion, exact for the
        given q and v (Haug, sec. 6.3). Rows: t (N,) [s], q and v (N, n).
        A singular matrix (a singular configuration) gives NaN for that row.
        """
        t = np.atleast_1d(np.asarray(t, dtype=float))
        q, v = np.atleast_2d(q), np.atleast_2d(v)
        out = np.empty((len(t), self.m))
        for i in range(len(t)):
            try:
                out[i] = self.index1_state(t[i], q[i], v[i])[1]
            except np.linalg.LinAlgError:
                out[i] = np.nan
        return out

    def accelerations(self, t, q, v, lam) -> np.ndarray:
        """q'' = M(q)^-1 (Q(t, q, v, lambda) - Phi_q^T lambda) at rows, shape
        (N, n) [m/s^2, rad/s^2]: the equations of motion M a + Phi_q^T lambda
        = Q solved for the accelerations the multipliers lambda give (with
        the index-1 multipliers, the index-1 accelerations; Haug, sec. 6.3).
        Rows: t (N,) [s], q and v (N, n), lam (N, m) [N, N m]; the contacts'
        impact speeds in force are the contacts' run state's."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        q = np.atleast_2d(np.asarray(q, dtype=float))
        qx, _ = self._ext_rows(q)
        vx, _ = self._ext_rows(np.atleast_2d(v))
        lam = np.ascontiguousarray(np.reshape(lam, (len(t), self.m)), dtype=float)
        f = np.zeros((len(t), self.nx))
        if self.has_loads:
            self._elements(_L_Q, qx, t, vx, lam, f)
        elif self.gravity_force is not None:
            f[:, : self.n] = self.gravity_force
        if self.m:
            reaction = np.zeros_like(f)
            self._constraints(_C_PHIQT_Y, qx, t, lam, reaction)
            f -= reaction
        f = f[:, : self.n]
        if self.mass_is_constant:
            return f / self.mass_diag
        return np.stack([self.mass_solve(qi, fi) for qi, fi in zip(q, f)])

    def index1_state(self, t, q, v):
        """(a, lambda) of the index-1 system at one state (t, q, v), shapes
        (n,) and (m,) [m/s^2, rad/s^2; N, N m]: [[M(q), Phi_q^T], [Phi_q, 0]]
        [a; lambda] = [Q; gamma] (Haug, sec. 6.3); where Phi_q loses rank
        (redundant joints, a singular position) the least-norm multipliers
        (:meth:`index1_matrix`).

        Raises
        ------
        numpy.linalg.LinAlgError
            No finite solution, or friction whose iteration does not settle
            (see :meth:`index1_solve`).
        """
        n = self.n
        K, _, least_norm = self.index1_matrix(t, q)
        sol = self.index1_solve(K, t, q, v, solve=least_norm)
        return sol[:n], sol[n:]

    def index1_matrix(self, t, q):
        """The index-1 matrix K = [[M(q), Phi_q^T], [Phi_q, 0]] at (t, q), its
        LU factors, and where K is singular a solve with the least-norm
        multipliers.

        Where Phi_q loses rank (a redundant joint the augmented formulation
        accepts, a singular position) K is singular: the accelerations are
        unique, the multipliers only up to the null space of Phi_q^T. An LU
        solve then returns multipliers of the size of the inverse round-off
        (1e20 N for a distance joint between two pinned points, whose
        Hessian then made the next step's Newton matrix singular). Here a
        pivot below 1e-14 of the largest marks K singular, and the solve
        takes the Schur complement S = Phi_q M^-1 Phi_q^T by least squares:
        lambda = S^+ (Phi_q M^-1 r_1 - r_2), a = M^-1 (r_1 - Phi_q^T lambda)
        (Haug, Computer-Aided Kinematics and Dynamics of Mechanical Systems,
        sec. 6.3; the pseudo-inverse as ``adaptive.index1_acceleration``'s).

        Returns
        -------
        K : ndarray, shape (n + m, n + m)
        lu : tuple
            ``scipy.linalg.lu_factor(K)``.
        least_norm : callable or None
            r (n + m,) -> (a, lambda) (n + m,) where K is singular; None
            where it is regular (solve with ``lu`` or K).

        Raises
        ------
        numpy.linalg.LinAlgError
            (from ``least_norm``) a solution that is not finite (a singular
            mass matrix).
        """
        import warnings

        import scipy.linalg
        n, m = self.n, self.m
        K = np.zeros((n + m, n + m))
        K[:n, :n] = self.mass_matrix(q)
        P = self.Phi_q(q, t)
        P = P.toarray() if hasattr(P, "toarray") else np.asarray(P)
        K[:n, n:], K[n:, :n] = P.T, P
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", scipy.linalg.LinAlgWarning)   # judged below
            lu = scipy.linalg.lu_factor(K, check_finite=False)
        d = np.abs(np.diag(lu[0]))
        if not m or (np.all(np.isfinite(d)) and d.min() > 1e-14 * d.max()):
            return K, lu, None
        W = self.mass_solve(q, P.T)                       # M^-1 Phi_q^T, (n, m)
        S = P @ W

        def least_norm(r):
            """K x = r with the least-norm multipliers."""
            with np.errstate(all="ignore"):
                lam = np.linalg.lstsq(S, P @ self.mass_solve(q, r[:n]) - r[n:], rcond=1e-13)[0]
                x = np.concatenate([self.mass_solve(q, r[:n] - P.T @ lam), lam])
            if not np.all(np.isfinite(x)):
                raise np.linalg.LinAlgError("singular index-1 matrix")
            return x
        return K, lu, least_norm

    #: Fixed-point iterations on lambda of the index-1 solve with friction.
    FRICTION_ITERATIONS = 100

    def index1_solve(self, K, t, q, v, solve=None, slip=None):
        """(a, lambda) of the index-1 system with matrix K (or its factorization's
        ``solve``), shape (n + m,).

        With friction Q depends on lambda, and the system is solved by the
        fixed-point iteration lambda_{k+1} = lambda(Q(t, q, v, lambda_k)),
        from lambda_0 = 0: its contraction factor is the friction's share of the
        reaction (of order mu r / (lever arm)), small for every physical mu.

        Raises
        ------
        numpy.linalg.LinAlgError
            K singular, or the iteration does not settle (friction coefficients
            so large that the reactions feed themselves).
        """
        n = self.n
        solve = solve or (lambda rhs: np.linalg.solve(K, rhs))
        gam = self.gamma(q, v, t)
        lam = np.zeros(self.m)
        for _ in range(self.FRICTION_ITERATIONS if self.frictions else 1):
            sol = solve(np.concatenate([self.Q(t, q, v, lam, slip), gam]))
            change = np.max(np.abs(sol[n:] - lam), initial=0.0)
            lam = sol[n:]
            if not self.frictions or \
                    change <= 1e-13 * (1.0 + np.max(np.abs(lam), initial=0.0)):
                return sol
        raise np.linalg.LinAlgError("the index-1 multipliers with friction do not settle")

    # -- energy ---------------------------------------------------------------------------
    def kinetic_energy(self, q, v):
        """T = v^T M(q) v / 2 [J]: a float, or shape (N,) for rows q, v of
        shape (N, n); the first-order states' unit masses carry none (their
        values are no motion)."""
        if len(self.state_cols):
            v = np.array(v, dtype=float)
            v[..., self.state_cols] = 0.0
        if np.ndim(q) == 1:
            return float(0.5 * np.dot(v, self.mass_times(q, v)))
        v = np.asarray(v, dtype=float)
        rc = self._rigid_cols
        e = 0.5 * np.einsum("...j,j,...j->...", v[..., rc], self.mass_diag[rc], v[..., rc])
        qx = self._ext(q) if self.beam_sets else None
        for i in np.ndindex(e.shape) if self.beam_sets else ():   # M(q) per beam, row by row
            for s, M in zip(self.beam_sets, self._beam_mass_blocks(qx[i])):
                vb = v[i][s.cols]
                e[i] += 0.5 * np.einsum("ki,kij,kj->", vb, M, vb)
        return e

    def power(self, t, q, v, lam, phi_t=None, contact_log=()):
        """Power put in and power dissipated, per row [W].

        Put in: the applied loads that are not potential forces (torques,
        joint torques, point forces; Q_load . v) and the drivers (lambda .
        Phi_t, the power of the rheonomic constraint forces -Phi_q^T lambda
        on a motion with Phi_q v + Phi_t = 0). Dissipated: the dampers of
        spring-dampers and rotational spring-dampers, friction and the
        contacts (``kernels.system._power``). Gravity, springs and beam strain are
        in :meth:`potential_energy`. Only what the model declares is
        evaluated.

        Parameters
        ----------
        t : ndarray, shape (N,) [s]
        q, v : ndarray, shape (N, n)
        lam : ndarray, shape (N, m)
        phi_t : ndarray, shape (N, m), optional
            Phi_t at the rows, when already computed.
        contact_log : sequence of (t, gap, speed), optional
            The run's contact state changes (``Solution.contact_log``): the
            damping of a contact depends on its impact speed.

        Returns
        -------
        p_in, p_dissipated : ndarray, shape (N,) [W]
        """
        N = len(t)
        p_in, p_diss = np.zeros(N), np.zeros(N)
        if self.has_loads and N:
            rows, _ = self._ext_rows(q)
            out = np.empty((N, 2))
            g = self.contact_state
            speeds = g.speeds_at(t, contact_log) if g is not None else None
            self._elements(_L_POWER, rows, t, self._ext_rows(v)[0],
                           np.reshape(lam, (N, self.m)), out, speeds=speeds)
            p_in, p_diss = out[:, 0].copy(), out[:, 1].copy()
        if self.m and any(not f.constant for f in self.driver_functions):
            pt = self.Phi_t(q, t) if phi_t is None else phi_t
            p_in += np.sum(lam * pt, axis=-1)
        return p_in, p_diss

    def potential_energy(self, q):
        """Gravity, spring, contact and strain potential energy [J] (zero at y
        = 0, unstretched springs, open contacts, undeformed beams): a float,
        or shape (N,) for rows q of shape (N, n)."""
        e = np.zeros(np.shape(q)[:-1])
        if self.gravity_force is not None:
            # each row summed alike whatever the number of rows (a matrix product
            # would round a row by how BLAS blocks the batch: the CSV writer's
            # chunks then differ from the whole run in the last bit)
            cols = np.flatnonzero(self.gravity_force)
            e = e - (np.asarray(q)[..., cols] * self.gravity_force[cols]).sum(axis=-1)
        if self.has_loads:
            rows, lead = self._ext_rows(q)
            out = np.empty((len(rows), 1))
            if len(rows):
                self._elements(_L_ENERGY, rows, 0.0, None, None, out)
            e = e + out[:, 0].reshape(lead)
        return float(e) if np.ndim(q) == 1 else e


#: ``kernels.system.elements``' evaluations (its L_* constants, repeated as the C_* below)
(_L_Q, _L_QQ, _L_QV, _L_QLAM, _L_ENERGY, _L_POWER, _L_GAPS, _L_SPRINGS, _L_SLIP,
 _L_SENSORS) = range(8, 18)
#: ``kernels.system.elements``' evaluations (its C_* constants, repeated here so
#: that building a model never imports numba)
_C_PHI, _C_PHI_T, _C_PHI_TT, _C_PHIQ_Y, _C_PHIQT_Y, _C_PHIQ, _C_PHIQT_Y_Q, _C_PHIQ_Y_Q = range(8)


def _concat_pattern(rows, cols):
    """(rows, cols) int arrays of a pattern made of several groups."""
    return (np.concatenate(rows).astype(np.intp) if rows else np.zeros(0, np.intp),
            np.concatenate(cols).astype(np.intp) if cols else np.zeros(0, np.intp))


def _unique_pattern(rows, cols, width):
    """(rows, cols) int arrays of the distinct pairs of several groups'
    patterns in (., width), sorted by row, then column."""
    keys = np.unique(np.concatenate(rows).astype(np.int64) * width
                     + np.concatenate(cols)) if rows else np.zeros(0, np.int64)
    return (keys // width).astype(np.intp), (keys % width).astype(np.intp)


@paused
def assemble(model: Model) -> AssembledSystem:
    """Build the :class:`AssembledSystem` of a checked model."""
    return AssembledSystem(model)
