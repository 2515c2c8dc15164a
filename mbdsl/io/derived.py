"""The columns derived from a run's rows: energies and their balance (work
put in, energy dissipated), constraint norms, joint reactions, driver and
coupler loads, the model's ``output`` expressions and the sensors of its loads.

Shapes: N rows, n coordinates, m constraint equations.
"""

from __future__ import annotations

import numpy as np

from ..assembly.points import PointSet
from .rows import STAT_NAMES

__all__ = ["DERIVED_NAMES", "LOAD_PREFIXES", "KEPT_PREFIXES", "energy_flows", "driver_loads", "coupler_loads",
           "rope_gaps", "rope_tensions", "output_columns", "derived_columns", "result_columns"]


#: Derived columns every model has, in CSV order (``Solution.DERIVED_NAMES``).
DERIVED_NAMES = ("energy.kinetic", "energy.potential", "energy.total", "energy.work",
                 "energy.dissipated", "energy.balance",
                 "constraint.position", "constraint.velocity")


class _Reactions:
    """Reaction of every joint on its second body, vectorised over joints and rows.

    For each joint: (fx, fy) [N] in global coordinates, applied at the
    joint's first point, and the couple [N m] about that point (zero for a
    revolute joint). The generalized constraint force of a joint's rows is
    -Phi_q^T lambda (sign convention M a + Phi_q^T lambda = Q). When the
    second body is the ground, the reaction is minus the one on the first
    body (the joint is massless).

    Built once: which entries of the Phi_q pattern (a joint's rows, the
    columns x, y, phi of the body read) add into which reaction component,
    sorted so that one ``np.add.reduceat`` sums them for all rows at once.
    """

    def __init__(self, system):
        joints = system.model.joints
        element = {name: k for k, name in enumerate(system.layout.element_rows)}
        elem = np.array([element[j.name] for j in joints], dtype=np.intp)
        second = np.array([j.second.body for j in joints], dtype=np.intp)
        first = np.array([j.first.body for j in joints], dtype=np.intp)
        self.body = np.where(second >= 0, second, first)          # whose force we read
        self.sign = np.where(second >= 0, 1.0, -1.0)
        self.first_points = PointSet(system.cmap, [j.first for j in joints])  # deformation included
        self.system, self.n_joints = system, len(joints)
        # zero by construction, written as 0 rather than the round-off of the sum:
        # a pin, a rod (its force along the rod, through the first point) and a
        # point on a line transmit no couple about the first point, nor does
        # anything acting on a particle
        particle = [getattr(system.model.bodies[b], "particle", False) if b >= 0 else False
                    for b in self.body]
        self.pinned = np.array([not j.locks_angle or p for j, p in zip(joints, particle)],
                               dtype=bool)
        rows, cols = system.pattern_Phi_q
        joint_of_element = np.full(system.layout.n_elements, -1, dtype=np.intp)
        joint_of_element[elem] = np.arange(len(joints))
        jt = joint_of_element[system.layout.row_element[rows]]
        # the columns (x, y, phi) of the body whose force we read, per joint
        self.body_cols = system.cmap(self.body).reshape(-1, 3)
        match = cols[:, None] == self.body_cols[np.maximum(jt, 0)]
        comp = np.where(match.any(axis=1), match.argmax(axis=1), -1)
        keep = np.flatnonzero((jt >= 0) & (comp >= 0))
        target = 3 * jt[keep] + comp[keep]
        order = np.argsort(target, kind="stable")
        self.entries = keep[order]                   # pattern entries, grouped by target
        self.rows = rows[self.entries]
        self.targets, self.starts = np.unique(target[order], return_index=True)

    def __call__(self, q, t, lam) -> np.ndarray:
        """(fx, fy, couple) of every joint, shape (joints, 3), or (N, joints,
        3) for rows q (N, n), t (N,), lam (N, m)."""
        q, lam = np.asarray(q, dtype=float), np.asarray(lam, dtype=float)
        vals = self.system.Phi_q_values(q, t)[..., self.entries] * -lam[..., self.rows]
        gen = np.zeros(q.shape[:-1] + (3 * self.n_joints,))
        if len(self.entries):
            gen[..., self.targets] = np.add.reduceat(vals, self.starts, axis=-1)
        gen = gen.reshape(q.shape[:-1] + (self.n_joints, 3))
        qx = np.concatenate([q, np.zeros(q.shape[:-1] + (3,))], axis=-1)  # ground: 0
        point = self.first_points.position(qx[..., self.first_points.cols])
        d = point - np.stack([qx[..., self.body_cols[:, 0]], qx[..., self.body_cols[:, 1]]], -1)
        couple = gen[..., 2] - (d[..., 0] * gen[..., 1] - d[..., 1] * gen[..., 0])
        couple = np.where(self.pinned, 0.0, couple)     # a revolute transmits no couple
        return self.sign[:, None] * np.stack([gen[..., 0], gen[..., 1], couple], -1)



#: Rows evaluated together for derived columns (bounds the temporary arrays).
_ROW_CHUNK = 1024


def energy_flows(system, t, q, v, lam, total, phi_t=None, start=None, contact_log=None,
                 flows=None) -> dict:
    """``energy.work``, ``energy.dissipated`` and ``energy.balance`` of rows.

    work(t) = int_0^t p_in, dissipated(t) = int_0^t p_dissipated
    (``AssembledSystem.power``), by the trapezoidal rule over the rows (second
    order, as the methods' energies; with ``--output-every`` K the rows are K
    steps apart and the quadrature error grows as (K h)^2). balance = E(t) -
    E(0) - work + dissipated is zero for the exact motion; its size is the
    integration's energy error.

    Parameters
    ----------
    total : ndarray, shape (N,) [J]
        ``energy.total`` of the rows.
    start : dict, optional
        The state after the rows before these (:func:`energy_end`): a run
        written chunk by chunk integrates on from it; None: the rows start
        the run.
    contact_log : list, optional
        The run's contact state changes (``Solution.contact_log``); None: those
        of the run under way (``ContactState.log``).
    flows : dict of str -> ndarray, shape (N,) [J], optional
        ``energy.work`` and ``energy.dissipated`` at the rows, integrated over
        the run's steps (rows at requested times, ``integrators.dense``):
        taken as they are, and the balance from them.
    """
    if flows is not None:
        work = np.asarray(flows["energy.work"], dtype=float)
        diss = np.asarray(flows["energy.dissipated"], dtype=float)
        e0 = total[0] if start is None else start["E0"]
        return {"energy.work": work, "energy.dissipated": diss,
                "energy.balance": total - e0 - work + diss,
                "_end": {"t": t[-1], "p_in": np.nan, "p_dissipated": np.nan,
                         "work": work[-1], "dissipated": diss[-1], "E0": e0}}
    group = getattr(system, "contact_state", None)
    if contact_log is None:
        contact_log = group.log if group is not None else ()
    p_in, p_diss = system.power(t, q, v, lam, phi_t, contact_log=contact_log)
    if start is None:
        start = {"t": t[0], "p_in": p_in[0], "p_dissipated": p_diss[0], "work": 0.0,
                 "dissipated": 0.0, "E0": total[0]}
    t_prev = np.concatenate([[start["t"]], t[:-1]])
    dt = 0.5 * (t - t_prev)
    work = np.cumsum(np.concatenate([[start["work"]], dt * (
        p_in + np.concatenate([[start["p_in"]], p_in[:-1]]))]))[1:]
    diss = np.cumsum(np.concatenate([[start["dissipated"]], dt * (
        p_diss + np.concatenate([[start["p_dissipated"]], p_diss[:-1]]))]))[1:]
    return {"energy.work": work, "energy.dissipated": diss,
            "energy.balance": total - start["E0"] - work + diss,
            "_end": {"t": t[-1], "p_in": p_in[-1], "p_dissipated": p_diss[-1],
                     "work": work[-1], "dissipated": diss[-1], "E0": start["E0"]}}


def driver_loads(system) -> list[tuple[str, int]]:
    """(column, constraint row) of every driver's load: ``driver.<name>.force``
    [N] for a driven x, y (z) or joint distance, ``driver.<name>.torque`` [N m]
    for a driven phi or joint angle. The load is -lambda of the driver's row
    (sign convention M a + Phi_q^T lambda = Q, a driver row q_c - f(t)): the
    generalized force the driver applies to the driven coordinate, i.e. on
    the driven body's x, y or phi, on a joint's second body (its first body
    takes the opposite), or along the line on a sliding joint's first point."""
    out = []
    for d in system.model.drivers:
        row = system.layout.element_rows[d.name][0]
        out.append((f"driver.{d.name}.{d.load}", int(row)))
    return out


#: The prefixes of the load columns derived per element: joint reactions, driver and
#: coupler loads, rope tensions (``mbdsl static`` prints them; the result files keep
#: them with the model's outputs, ``KEPT_PREFIXES``).
LOAD_PREFIXES = ("reaction.", "driver.", "coupler.", "rope.")
#: ... and with the outputs: the derived columns the result files keep beside the
#: energies and constraint norms (``io/csvfile``, ``io/hdf5``).
KEPT_PREFIXES = LOAD_PREFIXES + ("output.",)


def _sensor_reader(system, t, q, v, lam, contact_log):
    """A function giving ``AssembledSystem.sensor_values`` at the rows, read
    once on the first call: lambda 0 where not given (the friction loads it
    reads are then not used), the contacts' impact speeds from
    ``contact_log`` (None: the run under way's)."""
    held = []

    def read():
        """The sensors' values, dict of name -> (N, k, fields)."""
        if not held:
            group = system.contact_state
            log = (contact_log if contact_log is not None
                   else group.log if group is not None else ())
            held.append(system.sensor_values(
                t, q, v, np.zeros((len(t), system.m)) if lam is None else lam, log))
        return held[0]
    return read


def rope_gaps(system) -> list[tuple[str, int]]:
    """(column, gap index) of every rope's and cable's tension,
    ``rope.<name>.tension`` [N], in the model's order."""
    group = system.contact_state
    if group is None:
        return []
    kinds = {f.name: f.kind for f in system.model.forces}
    return [(f"rope.{name}.tension", i) for i, name in enumerate(group.elements)
            if kinds.get(name) in ("rope", "cable")]


def rope_tensions(system, sensors) -> dict:
    """``rope.<name>.tension`` [N] of stored rows, shape (N,) each: the law's
    force f = k (l - L) + c dl/dt where the rope is taut, cut at 0, 0 where
    it is slack (a gap's normal force of ``sensors()``, the rows'
    ``AssembledSystem.sensor_values``)."""
    ropes = rope_gaps(system)
    if not ropes:
        return {}
    gaps = sensors()["gap"]
    return {name: gaps[:, i, 2] for name, i in ropes}


def coupler_loads(system) -> list[tuple[str, int, float]]:
    """(column, constraint row, factor) of the load every coupler puts on each
    coordinate it relates: ``coupler.<name>.<variable>.torque`` [N m] on a
    joint's angle or a body's phi, ``.force`` [N] along a sliding joint's
    line or a body's x, y; the load is factor * lambda, factor = -a_k, the
    term's share of -Phi_q^T lambda (``model.elements.Coupler``). A gear
    G(J1, J2, ratio = n) puts -lambda on J1's second body and n lambda on
    J2's (and their opposites on the first bodies); a rack R(Jr, Jp, radius
    = r) the tooth force -lambda along the rack and r lambda on the pinion."""
    out = []
    for c in system.model.couplers:
        row = system.layout.element_rows[c.name][0]
        for v, a in zip(c.variables, c.coefficients):
            turning = v.line is None and all(j == 2 for _, j, _ in v.terms)
            out.append((f"coupler.{c.name}.{v.name}.{'torque' if turning else 'force'}",
                        int(row), -float(a)))
    return out


def output_columns(system, t, q, v, a, derived, lam=None, contact_log=None,
                   sensors=None) -> dict:
    """The ``output.<name>`` columns of the model's ``output`` lines, shape (N,)
    each, evaluated over the rows (numpy: a division by zero gives inf).

    Parameters
    ----------
    t : ndarray, shape (N,) [s]
    q, v : ndarray, shape (N, n)
    a : ndarray, shape (N, n), or None
        Accelerations (None: an output that reads one is NaN).
    derived : dict
        The derived columns of the same rows (energies, reactions, loads).
    lam : ndarray, shape (N, m), optional
        The multipliers (``lambda.<joint>.<row>``; the loads of friction
        elements); None: NaN.
    contact_log : list, optional
        The run's contact state changes (the impact speeds behind a contact's
        normal force); None: those of the run under way.
    sensors : callable, optional
        The rows' sensor values when the caller reads them too
        (``_sensor_reader``); by default read here on first use.
    """
    from ..assembly.points import drot, rot
    from ..dsl.expressions import evaluate_rows
    from ..model.elements import SENSOR_UNITS
    lay, N, cmap = system.layout, len(t), system.cmap
    qx = np.concatenate([q, np.zeros((N, 3))], axis=1)      # ground (and particles' phi): 0
    vx = np.concatenate([v, np.zeros((N, 3))], axis=1)
    index = {name: (q, i) for i, name in enumerate(lay.coordinates)}
    index.update({name: (v, i) for i, name in enumerate(lay.velocities)})
    if a is not None:
        index.update({name: (a, i) for i, name in enumerate(lay.accelerations)})
    if lam is not None:
        index.update({name: (lam, i) for i, name in enumerate(lay.multiplier_names())})
    if sensors is None:
        sensors = _sensor_reader(system, t, q, v, lam, contact_log)
    out = {}
    for o in system.model.outputs:
        env = {}
        for var in o.variables:
            if var.kind in SENSOR_UNITS:
                k = list(SENSOR_UNITS[var.kind]).index(var.field)
                reads_lam = var.kind == "friction" and k > 0     # a friction load: lambda
                env[var.name] = (sensors()[var.kind][:, var.index, k]
                                 if lam is not None or not reads_lam else np.full(N, np.nan))
            elif var.kind == "beam_point":
                env[var.name] = _beam_point(system, var, qx, vx)
            elif var.kind == "column":
                if var.column in index:
                    arr, i = index[var.column]
                    env[var.name] = arr[:, i]
                else:
                    env[var.name] = derived.get(var.column, np.full(N, np.nan))
            elif var.kind == "joint" and var.line is not None:      # s or ds/dt
                from ..model.elements import line_columns, line_distance
                cols = line_columns(var.line, cmap)
                vals = np.empty(N)
                for r in range(N):
                    s, grad = line_distance(var.line, qx[r], cmap)
                    vals[r] = s if var.field == "distance" else grad @ vx[r, cols]
                env[var.name] = vals
            elif var.kind == "spatial_joint":
                env[var.name] = _spatial_joint(system, var.line, var.field, qx, vx)
            elif var.kind in ("spatial_spring", "spatial_rotational"):
                env[var.name] = _spatial_sensor(system, var, qx, vx)
            elif var.kind == "joint":
                src = qx if var.field == "angle" else vx
                val = np.zeros(N)
                for b, sign in zip(var.bodies, (-1.0, 1.0)):
                    if b >= 0:
                        val = val + sign * src[:, cmap.column(b, 2)]
                env[var.name] = val
            else:                               # a point of a rigid body (or the ground)
                b, s = var.point.body, np.asarray(var.point.local, dtype=float)
                if system.cmap.spatial:
                    rate = var.field.startswith("v")
                    env[var.name] = _spatial_point(system, b, s, vx if rate else qx,
                                                   rate)[:, "xyz".index(var.field[-1])]
                    continue
                if b < 0:
                    pos, vel = np.tile(s, (N, 1)), np.zeros((N, 2))
                else:
                    cx, cy, cp = cmap(b)[0]
                    phi = qx[:, cp]
                    pos = qx[:, [cx, cy]] + rot(phi, np.broadcast_to(s, (N, 2)))
                    vel = vx[:, [cx, cy]] + vx[:, cp:cp + 1] * drot(
                        phi, np.broadcast_to(s, (N, 2)))
                k = {"x": 0, "y": 1, "vx": 0, "vy": 1}[var.field]
                env[var.name] = (pos if var.field in ("x", "y") else vel)[:, k]
        out[f"output.{o.name}"] = np.broadcast_to(
            evaluate_rows(o.expr, env, np.asarray(t, dtype=float)), (N,)).astype(float)
    return out


def _spatial_frame(system, b, x, rate) -> np.ndarray:
    """A spatial body's axes (``rate``: their rates) over the rows, (N, 3, 3)
    with rows a_1, a_2, a_3 (the ground's: the world axes, at rest; a
    particle's too: its one point is its centre, s = 0)."""
    N = len(x)
    if b < 0 or system.cmap.spatial_width[b] != 12:   # the ground, or a particle's cm only
        return np.zeros((N, 3, 3)) if rate else np.broadcast_to(np.eye(3), (N, 3, 3))
    c = system.cmap.spatial[b]
    return x[:, c + 3:c + 12].reshape(N, 3, 3)


def _spatial_point(system, b, s, x, rate) -> np.ndarray:
    """The point s (3,) of a spatial body (or the ground) over the rows x
    (N, nx), (N, 3) world axes: r + sum_k s_k a_k [m], or with ``rate`` (x
    the velocities) its velocity [m/s]."""
    if b < 0:
        return np.zeros((len(x), 3)) if rate else np.broadcast_to(s, (len(x), 3))
    c = system.cmap.spatial[b]
    return x[:, c:c + 3] + s @ _spatial_frame(system, b, x, rate)


def _spatial_joint(system, line, field, qx, vx) -> np.ndarray:
    """A spatial joint's angle theta [rad] or rate [rad/s]
    (``kernels.joints.spatial_angles``: atan2(G1 . F2, F1 . F2), its rate
    (c s' - s c') / (s^2 + c^2)), or its distance u . (p1 - p2) [m] or speed
    [m/s] (u turning with the line's body), over the rows: ``field`` of the
    joint geometry ``line`` (``check.outputs._spatial_joint_variable``)."""
    if line[0] == "angle":
        from ..model.spatial import reference_vectors
        _, b1, b2, a1, a2 = line
        v9 = reference_vectors(a1, a2)
        f1, g1, f2 = v9[:3], v9[3:6], v9[6:]
        A1, A2 = (_spatial_frame(system, b, qx, False) for b in (b1, b2))
        F1, G1, F2 = f1 @ A1, g1 @ A1, f2 @ A2
        s, c = np.sum(G1 * F2, axis=1), np.sum(F1 * F2, axis=1)
        if field == "angle":
            return np.arctan2(s, c)
        D1, D2 = (_spatial_frame(system, b, vx, True) for b in (b1, b2))
        ds = np.sum((g1 @ D1) * F2 + G1 * (f2 @ D2), axis=1)
        dc = np.sum((f1 @ D1) * F2 + F1 * (f2 @ D2), axis=1)
        return (c * ds - s * dc) / (s * s + c * c)
    _, bp, sp, bq, sq, bu, u = line
    sp, sq, u = (np.asarray(x, dtype=float) for x in (sp, sq, u))
    d = _spatial_point(system, bp, sp, qx, False) - _spatial_point(system, bq, sq, qx, False)
    U = u @ _spatial_frame(system, bu, qx, False)
    if field == "distance":
        return np.sum(U * d, axis=1)
    dd = _spatial_point(system, bp, sp, vx, True) - _spatial_point(system, bq, sq, vx, True)
    return np.sum((u @ _spatial_frame(system, bu, vx, True)) * d + U * dd, axis=1)


def _spatial_sensor(system, var, qx, vx) -> np.ndarray:
    """What a spatial spring-damper does over the rows (``SENSOR_UNITS``):
    length l [m], rate [m/s], tension k (l - l0) + c dl/dt [N], energy
    k (l - l0)^2 / 2 [J], power c (dl/dt)^2 [W] (``kernels.loads.spatial_springs``);
    of a rotational one its joint's angle [rad] and rate [rad/s], torque
    k wrap(theta - theta_0) + c dtheta/dt [N m], energy, power
    (``kernels.loads.spatial_rotational``)."""
    kind = "tsda" if var.kind == "spatial_spring" else "rsda"
    e = [f for f in system.model.forces if f.kind == kind][var.index]
    if kind == "tsda":
        d, dd = (_spatial_point(system, e.second.body, np.asarray(e.second.local, float), x,
                                rate)
                 - _spatial_point(system, e.first.body, np.asarray(e.first.local, float), x, rate)
                 for x, rate in ((qx, False), (vx, True)))
        x = np.linalg.norm(d, axis=1)
        rate = np.sum(d * dd, axis=1) / x
        stretch = x - e.length
    else:
        (b1, a1), (b2, a2) = e.joint.axes
        line = ("angle", b1, b2, tuple(a1), tuple(a2))
        x = _spatial_joint(system, line, "angle", qx, vx)
        rate = _spatial_joint(system, line, "rate", qx, vx)
        stretch = np.mod(x - e.angle + np.pi, 2 * np.pi) - np.pi        # within [-pi, pi)
    value = {"length": x, "angle": x, "rate": rate, "tension": e.k * stretch + e.c * rate,
             "torque": e.k * stretch + e.c * rate, "energy": 0.5 * e.k * stretch ** 2,
             "power": e.c * rate ** 2}
    return value[var.field]


def _beam_point(system, var, qx, vx) -> np.ndarray:
    """``field`` of the material point at arc x of a flexible beam at rows qx,
    vx (N, n + 3): r + A(phi) ((x, 0) + S(x) q_f) and its velocity (the
    floating frame of reference); "deflection": the point's elastic
    displacement normal to the frame's axis, (S(x) q_f)_y [m]."""
    from ..assembly.points import drot, rot
    beam = system.model.bodies[var.bodies[0]]
    S = beam.mesh.shape(np.array([var.arc]))[0]               # (2, nf)
    cols = beam.elastic_columns()
    disp, rate = qx[:, cols] @ S.T, vx[:, cols] @ S.T          # (N, 2)
    if var.field == "deflection":
        return disp[:, 1].copy()
    cx, cy, cp = system.cmap(beam.index)[0]
    local = disp + np.array([var.arc, 0.0])
    phi = qx[:, cp]
    if var.field in ("x", "y"):
        return (qx[:, [cx, cy]] + rot(phi, local))[:, "xy".index(var.field)]
    vel = vx[:, [cx, cy]] + vx[:, cp:cp + 1] * drot(phi, local) + rot(phi, rate)
    return vel[:, 0 if var.field == "vx" else 1]


def derived_columns(system, t, q, v, lam, start=None, end=None, a=None,
                    contact_log=None, flows=None) -> dict:
    """Energies, constraint norms and joint reactions of stored rows.

    Every element is evaluated for all rows at once (the kernels loop over
    the rows for the joints, drivers and beams; the force groups broadcast
    over leading axes), in chunks of ``_ROW_CHUNK`` rows.

    Parameters
    ----------
    system : AssembledSystem
    t : ndarray, shape (N,) [s]
    q, v : ndarray, shape (N, n)
    lam : ndarray, shape (N, m)

    start, end : dict, optional
        The energy integrals carried from the rows before (``start``, None
        when these rows begin the run) and to the rows after (``end`` is
        filled): see :func:`energy_flows`.
    contact_log, flows : optional
        See :func:`energy_flows`.

    Returns
    -------
    dict of str -> ndarray, shape (N,)
        ``energy.kinetic|potential|total``, ``energy.work|dissipated|balance``
        [J], ``constraint.position``
        (max |Phi|), ``constraint.velocity`` (max |Phi_q v + Phi_t|) and
        ``reaction.<joint>.fx|fy|torque`` [N, N m].
    """
    N = len(t)
    kin, pot, cpos, cvel = (np.zeros(N) for _ in range(4))
    phi_t = np.zeros((N, system.m))
    joints = system.model.joints
    spatial = bool(system.cmap.spatial)
    reactions = _Reactions(system) if joints and not spatial else None
    reac = np.zeros((N, len(joints), len(reaction_fields(system))))
    for i0 in range(0, N, _ROW_CHUNK):
        sl = slice(i0, min(i0 + _ROW_CHUNK, N))
        qs, vs, ts = q[sl], v[sl], t[sl]
        kin[sl] = system.kinetic_energy(qs, vs)
        pot[sl] = system.potential_energy(qs)
        if system.m:
            cpos[sl] = np.max(np.abs(system.Phi(qs, ts)), axis=1)
            phi_t[sl] = system.Phi_t(qs, ts)
            cvel[sl] = np.max(np.abs(system.Phiq_times(qs, ts, vs) + phi_t[sl]), axis=1)
            if reactions is not None:
                reac[sl] = reactions(qs, ts, lam[sl])
    out = {"energy.kinetic": kin, "energy.potential": pot, "energy.total": kin + pot}
    energies = energy_flows(system, t, q, v, lam, kin + pot, phi_t, start, contact_log, flows)
    carry = energies.pop("_end")
    out.update(energies)
    out.update({"constraint.position": cpos, "constraint.velocity": cvel})
    if spatial and joints:
        reac = spatial_reactions(system, t, q, lam)
    for k, j in enumerate(joints):
        for c, comp in enumerate(reaction_fields(system)):
            out[f"reaction.{j.name}.{comp}"] = reac[:, k, c]
    out.update(spatial_columns(system, q, v))
    for name, row in driver_loads(system):
        out[name] = -lam[:, row]
    for name, row, factor in coupler_loads(system):
        out[name] = factor * lam[:, row]
    sensors = _sensor_reader(system, t, q, v, lam, contact_log)    # read once, if at all
    out.update(rope_tensions(system, sensors))
    if system.model.outputs:
        out.update(output_columns(system, t, q, v, a, out, lam=lam, contact_log=contact_log,
                                  sensors=sensors))
    if end is not None:              # for a writer that goes on with the next rows
        end.update(carry)
    return out


def result_columns(system, extra_names=()) -> list[str]:
    """Names of every column of a run of ``system``, in CSV order
    (``Solution.columns``), whose method stores the extra multipliers
    ``extra_names`` (``mu``, ``psi1``)."""
    lay, model = system.layout, system.model
    extras = [f"{x}.{name}.{k}" for x in extra_names for name, k in lay.rows]
    reactions = [f"reaction.{j.name}.{c}" for j in model.joints for c in reaction_fields(system)]
    reactions += list(spatial_columns(system))
    reactions += [name for name, _ in driver_loads(system)]
    reactions += [name for name, _, _ in coupler_loads(system)]
    reactions += [name for name, _ in rope_gaps(system)]
    reactions += [f"output.{o.name}" for o in model.outputs]
    beams = [f"{b.name}.deflection_mid" for b in model.flexible_bodies]
    return (["t"] + lay.coordinates + lay.velocities + lay.accelerations
            + list(DERIVED_NAMES) + beams + lay.multiplier_names()
            + extras + reactions
            + [f"newton.{k}" for k in STAT_NAMES[:-1]] + ["step.h"])


def reaction_fields(system) -> tuple:
    """The components of a joint's reaction columns: (fx, fy, torque) [N, N m]
    in a planar model; in a spatial one (fx, fy, fz, tx, ty, tz) [N, N m]
    (:func:`spatial_reactions`)."""
    return (("fx", "fy", "fz", "tx", "ty", "tz") if system.cmap.spatial
            else ("fx", "fy", "torque"))


def spatial_reactions(system, t, q, lam) -> np.ndarray:
    """The force and couple each joint of a spatial model applies on its
    second body, shape (N, joints, 6) [N, N m], world axes, the couple about
    the body's centre of mass; when the second body is the ground, minus
    those on the first body (about the first body's centre of mass).

    The joint's constraint load on the body's coordinates is
    G = -(Phi_q^T lambda) over the joint's rows; in director coordinates its
    force is G on r and its couple sum_k a_k x G on a_k (virtual work
    G_ak . (dtheta x a_k) = dtheta . (a_k x G_ak)).

    Rows: t (N,), q (N, n), lam (N, m).
    """
    rows, cols = system.pattern_Phi_q
    values = system.Phi_q_values(q, t)                     # (N, nnz)
    load = -values * lam[:, rows]
    out = np.zeros((len(t), len(system.model.joints), 6))
    for k, j in enumerate(system.model.joints):
        r0 = system.joint_rows[j.name]
        body, sign = ((j.second.body, 1.0) if j.second.body >= 0 else (j.first.body, -1.0))
        c0, width = system.cmap.spatial[body], system.cmap.spatial_width[body]
        mine = (rows >= r0) & (rows < r0 + j.rows) & (cols >= c0) & (cols < c0 + width)
        G = np.zeros((len(t), width))
        np.add.at(G.T, cols[mine] - c0, load[:, mine].T)
        out[:, k, :3] = sign * G[:, :3]
        if width == 12:                  # a particle takes no couple
            A = q[:, c0 + 3:c0 + 12].reshape(-1, 3, 3)         # rows: a_1, a_2, a_3
            out[:, k, 3:] = sign * np.cross(A, G[:, 3:].reshape(-1, 3, 3)).sum(axis=1)
    return out


#: a spatial body's readable angles (z-y'-x''), as its columns name them
ROTATION_ANGLES = ("yaw", "pitch", "roll")


def spatial_columns(system, q=None, v=None) -> dict:
    """Each spatial body's Euler parameters ``<body>.e0`` .. ``e3`` (e0 >= 0),
    its z-y'-x'' angles ``<body>.yaw``, ``pitch``, ``roll`` [rad] and its
    angular velocity in body axes ``<body>.wx``, ``wy``, ``wz`` [rad/s]
    (:func:`rotation_columns`) over rows q, v (N, n); with q None, only the
    names (values None)."""
    out = {}
    for i, col in system.cmap.spatial.items():
        if system.cmap.spatial_width[i] != 12:          # a particle does not turn
            continue
        name = system.model.bodies[i].name
        if q is None:
            out.update(dict.fromkeys(rotation_columns(name)))
            continue
        out.update(rotation_columns(name, q[:, col + 3:col + 12], v[:, col + 3:col + 12]))
    return out


def rotation_columns(name, directors=None, rates=None) -> dict:
    """One spatial body's ``<name>.e0`` .. ``e3``, ``<name>.yaw``, ``pitch``,
    ``roll`` (:func:`mbdsl.model.spatial.zyx_angles`, each row on its own:
    no unwrapping across rows, so a file written in pieces equals one written
    at once) and ``<name>.wx``, ``wy``, ``wz`` from its directors and their
    rates (``model.spatial``), each (N, 9) in column order A11, A21, ...,
    A33; with directors None, the names (values None)."""
    from ..model.spatial import body_angular_velocity, euler_parameters, zyx_angles
    names = ([f"{name}.e{k}" for k in range(4)] + [f"{name}.{a}" for a in ROTATION_ANGLES]
             + [f"{name}.w{c}" for c in "xyz"])
    if directors is None:
        return dict.fromkeys(names)
    A = np.asarray(directors).reshape(-1, 3, 3).transpose(0, 2, 1)
    A_t = np.asarray(rates).reshape(-1, 3, 3).transpose(0, 2, 1)
    values = np.concatenate([euler_parameters(A), zyx_angles(A),
                             body_angular_velocity(A, A_t)], axis=1)
    return {k: values[:, j] for j, k in enumerate(names)}
