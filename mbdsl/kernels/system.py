"""The aggregates over the element families, in a fixed order.

Phi, Phi_q^T lambda, Phi_q v (coincidence, point on line, linear rows,
distance, couplers, spatial dot rows, spatial joint angles, then the elastic
columns of beam points), Q (gravity, springs, spatial springs and rotational
springs, rotational springs and torques, point forces, loads of the state,
friction, contacts, beams), the Newton-matrix emitters of their derivatives, the
loads' potential energy and power, and :func:`elements`, the evaluations
Python asks for. The order is that of the triplets and of every sum, so the
results do not depend on which families a model declares.
"""

from __future__ import annotations


import numpy as np

from .beams.elastic_points import (_elastic_phiqT_add, _elastic_phiq_times, _emit_elastic_G,
                                   _emit_elastic_hess, _emit_elastic_phiq)
from .beams.ffr import FFR_DQ, FFR_M, _emit_beams, _ffr_energy, _ffr_forces_add
from .geometry import _direction
from .joints import (coincidence, couplers, distance, linear_rows, point_on_line, spatial,
                     spatial_angles)
from .loads import (contact, friction, point_forces, spatial_loads, spatial_rotational,
                    spatial_springs, spring_damper, state_loads, torques)
from .loads.contact import (_contact_energy, _contact_friction, _contact_law, _contacts_add,
                            _emit_contacts, _gap)
from .loads.friction import (_emit_friction, _emit_friction_lam, _friction_col, _friction_kin,
                             _friction_law)
from .loads.spring_damper import _spring_energy, _spring_points, _spring_rate, _springs_add
from .loads.torques import _rotational_energy
from .schema import (AROW, BEAM, CROW, HCOL, DROW, ECOL, FCOL, FEL, FRI, GEO, KCOL, KGI, KPAR, LROW, MASS,
                     MRIG, PROW, Q0, RCOL, ROW_ELEMENT, RPAR, SCOL1, SDV, SEL, SPAR, STQ, VROW, WCOL,
                     XTRM, YCOL, ZCOL, _0, _NO, _YES, _f, _i, _inline, _hot, _jit, _put, _rows)


#: The joint families in the order of every aggregate, each with its first field
#: (whose rows are its instances).
JOINTS = ((coincidence, CROW), (point_on_line, PROW), (linear_rows, LROW), (distance, DROW),
          (couplers, XTRM), (spatial, VROW), (spatial_angles, AROW))
#: The joint families, in that order: each declares the joints and drivers whose rows
#: it holds (``ELEMENT_ROWS``) and packs them from the model (``pack``); a family may
#: also say where the initial conditions' first guess puts a joint's far body
#: (``start_point``) and how far a joint is from holding (``miss``): see :func:`joint_hook`.
JOINT_FAMILIES = tuple(family for family, _ in JOINTS)


def joint_hook(kind: str, name: str):
    """The function ``name`` ("start_point" or "miss") of the family that holds
    a joint kind's rows, or None (no family of the kind defines it).

    Parameters
    ----------
    kind : str
        A joint kind (``Joint.kind``).
    name : str
        The hook's name.
    """
    for family in JOINT_FAMILIES:
        if kind in family.ELEMENT_ROWS and hasattr(family, name):
            return getattr(family, name)
    return None


#: The load families, in the order their data are packed: each declares the load
#: kinds it holds (``LOADS``, the model elements' ``kind``), packs them from the
#: model (``pack``) and says which columns the derivatives of its loads may fill
#: (``pattern``; friction also its reaction rows: ``multiplier_pattern``).
LOAD_FAMILIES = (spring_damper, torques, state_loads, point_forces, friction, contact,
                 spatial_springs, spatial_loads, spatial_rotational)
#: The load families with a force block, each with the field that counts it
#: (a load of the state counts twice: per load, STQ, and per partial derivative, SDV).
LOADS = ((spring_damper, SCOL1), (torques, RCOL), (point_forces, FCOL), (state_loads, STQ),
         (state_loads, SDV), (friction, FRI), (contact, KGI), (spatial_springs, WCOL),
          (spatial_loads, YCOL), (spatial_rotational, HCOL))


@_hot
def _phi_time_add(I, Fl, t, out, order):
    """out (m,) += the order-th partial time derivative of Phi (1: Phi_t,
    2: Phi_tt): -f'(t) or -f''(t) in the rows of drivers f(t)."""
    linear_rows.phi_time_add(I, Fl, t, out, order)
    point_on_line.phi_time_add(I, Fl, t, out, order)
    if _rows(I, VROW) > 0:
        spatial.phi_time_add(I, Fl, t, out, order)
    if _rows(I, AROW) > 0:
        spatial_angles.phi_time_add(I, Fl, t, out, order)


@_inline
def _phi_others(I, Fl, t, qx, out):
    """Phi's rows of every joint family but the revolute joints' (``coincidence``)."""
    point_on_line.phi(I, Fl, t, qx, out)
    linear_rows.phi(I, Fl, t, qx, out)
    distance.phi(I, Fl, t, qx, out)
    if _rows(I, XTRM) > 0:
        couplers.phi(I, Fl, t, qx, out)
    if _rows(I, VROW) > 0:
        spatial.phi(I, Fl, t, qx, out)
    if _rows(I, AROW) > 0:
        spatial_angles.phi(I, Fl, t, qx, out)


@_inline
def _phiqT_others_add(I, Fl, qx, lam, coef, out):
    """out += coef Phi_q^T lambda of every joint family but the revolute joints'."""
    point_on_line.phiqT_add(I, Fl, qx, lam, coef, out)
    linear_rows.phiqT_add(I, Fl, qx, lam, coef, out)
    distance.phiqT_add(I, Fl, qx, lam, coef, out)
    if _rows(I, XTRM) > 0:
        couplers.phiqT_add(I, Fl, qx, lam, coef, out)
    if _rows(I, VROW) > 0:
        spatial.phiqT_add(I, Fl, qx, lam, coef, out)
    if _rows(I, AROW) > 0:
        spatial_angles.phiqT_add(I, Fl, qx, lam, coef, out)
    if _rows(I, ECOL) > 0:
        _elastic_phiqT_add(I, Fl, qx, lam, coef, out)
        distance.elastic_phiqT_add(I, Fl, qx, lam, coef, out)


@_jit
def phi(I, Fl, t, qx, out):
    """Phi(q) into out (m,) [m or rad]: every joint family's rows."""
    coincidence.phi(I, Fl, t, qx, out)
    _phi_others(I, Fl, t, qx, out)


@_jit
def phiqT_add(I, Fl, qx, lam, coef, out):
    """out[:n+3] += coef Phi_q^T lambda."""
    coincidence.phiqT_add(I, Fl, qx, lam, coef, out)
    _phiqT_others_add(I, Fl, qx, lam, coef, out)


@_jit
def phi_phiqT_add(I, Fl, t, qx, lam, out_phi, out):
    """:func:`phi` into out_phi (m,) and out (n+3,) += Phi_q^T lambda
    (:func:`phiqT_add`, coef 1): the index-3 residual's joint terms, the
    revolute joints' in one pass that rotates each point once for both
    (``coincidence.phi_phiqT_add``). The same numbers: every row of Phi is
    written once, and Phi_q^T lambda summed family by family in
    :func:`phiqT_add`'s order."""
    coincidence.phi_phiqT_add(I, Fl, qx, lam, out_phi, out)
    _phi_others(I, Fl, t, qx, out_phi)
    _phiqT_others_add(I, Fl, qx, lam, 1.0, out)


@_jit
def phiq_times(I, Fl, qx, vx, out):
    """Phi_q v into out (m,)."""
    coincidence.phiq_times(I, Fl, qx, vx, out)
    point_on_line.phiq_times(I, Fl, qx, vx, out)
    linear_rows.phiq_times(I, Fl, qx, vx, out)
    distance.phiq_times(I, Fl, qx, vx, out)
    if _rows(I, XTRM) > 0:
        couplers.phiq_times(I, Fl, qx, vx, out)
    if _rows(I, VROW) > 0:
        spatial.phiq_times(I, Fl, qx, vx, out)
    if _rows(I, AROW) > 0:
        spatial_angles.phiq_times(I, Fl, qx, vx, out)
    if _rows(I, ECOL) > 0:
        _elastic_phiq_times(I, Fl, qx, vx, out)
        distance.elastic_phiq_times(I, Fl, qx, vx, out)


@_jit
def phiq_products(I, Fl, qx, vx, lam, mu, out_l, out_mu, out_v):
    """out_l (n+3,) += Phi_q^T lambda, out_mu (n+3,) += Phi_q^T mu and out_v
    (m,) = Phi_q v: the sums of :func:`phiqT_add` (coef 1) and
    :func:`phiq_times`, family by family in their order (the same numbers),
    with one gradient per row of the spatial families (their ``products``):
    the stabilized index-2 residual's three products, which three passes
    over the spatial rows made 12 of its 16 us on the spatial chain of 10
    links."""
    coincidence.phiqT_add(I, Fl, qx, lam, 1.0, out_l)
    coincidence.phiqT_add(I, Fl, qx, mu, 1.0, out_mu)
    coincidence.phiq_times(I, Fl, qx, vx, out_v)
    point_on_line.phiqT_add(I, Fl, qx, lam, 1.0, out_l)
    point_on_line.phiqT_add(I, Fl, qx, mu, 1.0, out_mu)
    point_on_line.phiq_times(I, Fl, qx, vx, out_v)
    linear_rows.phiqT_add(I, Fl, qx, lam, 1.0, out_l)
    linear_rows.phiqT_add(I, Fl, qx, mu, 1.0, out_mu)
    linear_rows.phiq_times(I, Fl, qx, vx, out_v)
    distance.phiqT_add(I, Fl, qx, lam, 1.0, out_l)
    distance.phiqT_add(I, Fl, qx, mu, 1.0, out_mu)
    distance.phiq_times(I, Fl, qx, vx, out_v)
    if _rows(I, XTRM) > 0:
        couplers.phiqT_add(I, Fl, qx, lam, 1.0, out_l)
        couplers.phiqT_add(I, Fl, qx, mu, 1.0, out_mu)
        couplers.phiq_times(I, Fl, qx, vx, out_v)
    if _rows(I, VROW) > 0:
        spatial.products(I, Fl, qx, vx, lam, mu, out_l, out_mu, out_v)
    if _rows(I, AROW) > 0:
        spatial_angles.products(I, Fl, qx, vx, lam, mu, out_l, out_mu, out_v)
    if _rows(I, ECOL) > 0:
        _elastic_phiqT_add(I, Fl, qx, lam, 1.0, out_l)
        distance.elastic_phiqT_add(I, Fl, qx, lam, 1.0, out_l)
        _elastic_phiqT_add(I, Fl, qx, mu, 1.0, out_mu)
        distance.elastic_phiqT_add(I, Fl, qx, mu, 1.0, out_mu)
        _elastic_phiq_times(I, Fl, qx, vx, out_v)
        distance.elastic_phiq_times(I, Fl, qx, vx, out_v)


@_jit
def _inputs_add(I, Fl, t, qx, vx, out):
    """The loads that put work in, added to out (n+3,) [N, N m]: point
    forces F(t) (J^T F), torques tau(t) and loads of the state tau(t, x) w
    (+-tau on a joint's bodies, or tau grad s along a sliding line), spatial
    forces and torques."""
    point_forces.forces_add(I, Fl, t, qx, vx, out)
    torques.time_torques_add(I, Fl, t, out)
    state_loads.forces_add(I, Fl, t, qx, vx, out)
    if _rows(I, YCOL) > 0:                         # spatial forces and torques
        spatial_loads.forces_add(I, Fl, t, qx, out)


@_jit
def _forces(I, Fl, t, qx, vx, lam, slip, out):
    """Q(q, v, lambda) into out (n+3,) [N, N m] (overwritten): gravity (Q0),
    spring-dampers, rotational spring-dampers, the loads that put work in,
    friction (reading lambda (m,), and ``slip`` as ``_friction_law``),
    contacts and flexible beams."""
    for j in range(out.shape[0]):       # a loop: numba's array-to-array slice copy checks overlap
        out[j] = _f(I, Fl, Q0, j, 0)
    _springs_add(I, Fl, qx, vx, out)
    if _rows(I, WCOL) > 0:                         # spatial spring-dampers
        spatial_springs.forces_add(I, Fl, qx, vx, out)
    if _rows(I, HCOL) > 0:                         # spatial rotational spring-dampers
        spatial_rotational.forces_add(I, Fl, qx, vx, out)
    torques.forces_add(I, Fl, qx, vx, out)
    _inputs_add(I, Fl, t, qx, vx, out)
    if _rows(I, FRI) > 0:                          # friction: tau w
        friction.forces_add(I, Fl, qx, vx, lam, slip, out)
    if _rows(I, KGI) > 0:                          # contacts and joint limits
        _contacts_add(I, Fl, qx, vx, out)
    if _rows(I, BEAM) > 0:                         # flexible beams
        _ffr_forces_add(I, Fl, qx, vx, out)


@_jit
def forces(I, Fl, t, qx, vx, lam, out):
    """Q(q, v, lambda) into out (n+3,) [N, N m] (overwritten), friction by its
    law: ``_forces``, the time loops' evaluation."""
    _forces(I, Fl, t, qx, vx, lam, Fl[:0], out)


@_hot
def _emit_mass(I, Fl, n, qM, R, C, V, p, r0, c0, coef):
    """coef M(qM) at (r0, c0): the rigid diagonal, and every beam's block."""
    for j in range(n):
        if _f(I, Fl, MRIG, j, 0) != 0.0:
            p = _put(R, C, V, p, r0 + j, c0 + j, coef * _f(I, Fl, MRIG, j, 0))
    if _rows(I, BEAM) > 0:
        p = _emit_beams(I, Fl, qM, qM, qM, FFR_M, R, C, V, p, r0, c0, coef, 0.0)
    return p


@_jit
def _emit_phiq(I, Fl, n, qx, R, C, V, p, r0, c0, coef, transpose):
    """coef Phi_q at (r0, c0), or coef Phi_q^T when transpose."""
    p = coincidence.emit_phiq(I, Fl, n, qx, R, C, V, p, r0, c0, coef, transpose)
    p = point_on_line.emit_phiq(I, Fl, n, qx, R, C, V, p, r0, c0, coef, transpose)
    p = linear_rows.emit_phiq(I, Fl, n, qx, R, C, V, p, r0, c0, coef, transpose)
    p = distance.emit_phiq(I, Fl, n, qx, R, C, V, p, r0, c0, coef, transpose)
    if _rows(I, XTRM) > 0:
        p = couplers.emit_phiq(I, Fl, n, qx, R, C, V, p, r0, c0, coef, transpose)
    if _rows(I, VROW) > 0:
        p = spatial.emit_phiq(I, Fl, n, qx, R, C, V, p, r0, c0, coef, transpose)
    if _rows(I, AROW) > 0:
        p = spatial_angles.emit_phiq(I, Fl, n, qx, R, C, V, p, r0, c0, coef, transpose)
    if _rows(I, ECOL) > 0:
        p = _emit_elastic_phiq(I, Fl, n, qx, R, C, V, p, r0, c0, coef, transpose)
        p = distance.emit_elastic_phiq(I, Fl, n, qx, R, C, V, p, r0, c0, coef, transpose)
    return p


@_inline
def phiq_triplets(I):
    """The most triplets :func:`_emit_phiq` emits: each joint family's
    ``PHIQ_TRIPLETS`` per instance, and two per elastic term of a joint point."""
    return (coincidence.PHIQ_TRIPLETS * _rows(I, CROW)
            + point_on_line.PHIQ_TRIPLETS * _rows(I, PROW)
            + linear_rows.PHIQ_TRIPLETS * _rows(I, LROW)
            + distance.PHIQ_TRIPLETS * _rows(I, DROW)
            + couplers.PHIQ_TRIPLETS * _rows(I, XTRM)
            + spatial.PHIQ_TRIPLETS * _rows(I, VROW)
            + spatial_angles.PHIQ_TRIPLETS * _rows(I, AROW) + 2 * _rows(I, ECOL))


@_jit
def _emit_hess(I, Fl, n, qx, lam, R, C, V, p, r0, c0, coef):
    """coef (Phi_q^T lambda)_q at (r0, c0) (linear rows have none)."""
    p = coincidence.emit_hess(I, Fl, n, qx, lam, R, C, V, p, r0, c0, coef)
    p = point_on_line.emit_hess(I, Fl, n, qx, lam, R, C, V, p, r0, c0, coef)
    p = distance.emit_hess(I, Fl, n, qx, lam, R, C, V, p, r0, c0, coef)
    if _rows(I, XTRM) > 0:
        p = couplers.emit_hess(I, Fl, n, qx, lam, R, C, V, p, r0, c0, coef)
    if _rows(I, VROW) > 0:
        p = spatial.emit_hess(I, Fl, n, qx, lam, R, C, V, p, r0, c0, coef)
    if _rows(I, AROW) > 0:
        p = spatial_angles.emit_hess(I, Fl, n, qx, lam, R, C, V, p, r0, c0, coef)
    if _rows(I, ECOL) > 0:
        p = _emit_elastic_hess(I, Fl, n, qx, lam, R, C, V, p, r0, c0, coef)
        p = distance.emit_elastic_hess(I, Fl, n, qx, lam, R, C, V, p, r0, c0, coef)
    return p


@_jit
def _emit_G(I, Fl, n, qx, vx, R, C, V, p, r0, c0, coef):
    """coef (Phi_q v)_q at (r0, c0) (Phi_qt = 0 for these constraints; linear
    rows have no second derivative)."""
    p = coincidence.emit_G(I, Fl, n, qx, vx, R, C, V, p, r0, c0, coef)
    p = point_on_line.emit_G(I, Fl, n, qx, vx, R, C, V, p, r0, c0, coef)
    p = distance.emit_G(I, Fl, n, qx, vx, R, C, V, p, r0, c0, coef)
    if _rows(I, XTRM) > 0:
        p = couplers.emit_G(I, Fl, n, qx, vx, R, C, V, p, r0, c0, coef)
    if _rows(I, VROW) > 0:
        p = spatial.emit_G(I, Fl, n, qx, vx, R, C, V, p, r0, c0, coef)
    if _rows(I, AROW) > 0:
        p = spatial_angles.emit_G(I, Fl, n, qx, vx, R, C, V, p, r0, c0, coef)
    if _rows(I, ECOL) > 0:
        p = _emit_elastic_G(I, Fl, n, qx, vx, R, C, V, p, r0, c0, coef)
        p = distance.emit_elastic_G(I, Fl, n, qx, vx, R, C, V, p, r0, c0, coef)
    return p


#: What ``elements`` evaluates at each row for the joints and drivers: Phi,
#: Phi_t, Phi_tt into out (N, m); Phi_q y into out (N, m); Phi_q^T y into out
#: (N, nx); the triplets of Phi_q, (Phi_q^T y)_q and (Phi_q y)_q into R, C and
#: V (N, nnz).
(C_PHI, C_PHI_T, C_PHI_TT, C_PHIQ_Y, C_PHIQT_Y,
 C_PHIQ, C_PHIQT_Y_Q, C_PHIQ_Y_Q) = range(8)


@_jit
def _constraints_row(I, Fl, n, what, r, t, qx, y, out, R, C, V):
    """The joints' and drivers' evaluation ``what`` (C_*) at row r of t,
    qx, y, into out[r] or R, C, V[r] (see ``elements``); returns the
    triplets' count (0 for a vector)."""
    p = 0
    if what == C_PHI:
        phi(I, Fl, t[r], qx[r], out[r])
    elif what == C_PHI_T or what == C_PHI_TT:
        row = out[r]
        for j in range(row.shape[0]):
            row[j] = 0.0
        _phi_time_add(I, Fl, t[r], row, what)
    elif what == C_PHIQ_Y:
        phiq_times(I, Fl, qx[r], y[r], out[r])
    elif what == C_PHIQT_Y:
        row = out[r]
        for j in range(row.shape[0]):
            row[j] = 0.0
        phiqT_add(I, Fl, qx[r], y[r], 1.0, row)
    elif what == C_PHIQ:
        p = _emit_phiq(I, Fl, n, qx[r], R, C, V[r], _0, _0, _0, 1.0, _NO)
    elif what == C_PHIQT_Y_Q:
        p = _emit_hess(I, Fl, n, qx[r], y[r], R, C, V[r], _0, _0, _0, 1.0)
    else:
        p = _emit_G(I, Fl, n, qx[r], y[r], R, C, V[r], _0, _0, _0, 1.0)
    return p


@_jit
def _emit_force(I, Fl, t, n, qx, vx, lam, R, C, V, p, r0, c0, cq, cv):
    """-(cq Q_q + cv Q_v) at (r0, c0) of every applied load (the load families' notes)."""
    p = spring_damper.emit_force(I, Fl, n, qx, vx, R, C, V, p, r0, c0, cq, cv)
    if _rows(I, WCOL) > 0:
        p = spatial_springs.emit_force(I, Fl, n, qx, vx, R, C, V, p, r0, c0, cq, cv)
    if _rows(I, HCOL) > 0:
        p = spatial_rotational.emit_force(I, Fl, n, qx, vx, R, C, V, p, r0, c0, cq, cv)
    p = torques.emit_force(I, Fl, n, R, C, V, p, r0, c0, cq, cv)
    p = point_forces.emit_force(I, Fl, t, n, qx, vx, R, C, V, p, r0, c0, cq, cv)
    p = state_loads.emit_force(I, Fl, t, n, qx, vx, R, C, V, p, r0, c0, cq, cv)
    if _rows(I, YCOL) > 0:
        p = spatial_loads.emit_force(I, Fl, t, qx, R, C, V, p, r0, c0, cq)
    if _rows(I, FRI) > 0:
        p = _emit_friction(I, Fl, n, qx, vx, lam, R, C, V, p, r0, c0, cq, cv)
    if _rows(I, KGI) > 0:
        p = _emit_contacts(I, Fl, n, qx, vx, R, C, V, p, r0, c0, cq, cv)
    if _rows(I, BEAM) > 0:
        p = _emit_beams(I, Fl, qx, vx, qx, FFR_DQ, R, C, V, p, r0, c0, cq, cv)
    return p


#: What ``elements`` evaluates at each row for the applied loads: Q into out
#: (N, nx); the triplets of Q_q, Q_v, Q_lambda into R, C and V (N, nnz); the
#: potential energy of the loads into out[:, 0]; the power put in and
#: dissipated into out[:, :2]; the contacts' gaps and their gradients, the
#: spring-dampers' d = p2 - p1 and the friction joints' speeds and their
#: rates into out (see ``elements``). Numbered after the C_*.
(L_Q, L_QQ, L_QV, L_QLAM, L_ENERGY, L_POWER, L_GAPS, L_SPRINGS, L_SLIP,
 L_SENSORS) = range(8, 18)
#: Values per gap, per friction joint and per (rotational) spring-damper of L_SENSORS.
SENSOR_GAP, SENSOR_FRICTION, SENSOR_SPRING = 6, 3, 5


@_jit
def _potential(I, Fl, qx):
    """The loads' potential energy at qx [J]: springs k (l - l0)^2 / 2,
    rotational springs k theta^2 / 2, contacts K delta^(n+1) / (n+1), beams'
    strain and gravity (``_ffr_energy``); the rigid bodies' gravity is
    -Q0 . q, the caller's."""
    e = 0.0
    e = spring_damper.energy_add(I, Fl, qx, e)
    e = spatial_springs.energy_add(I, Fl, qx, e)
    e = spatial_rotational.energy_add(I, Fl, qx, e)
    e = torques.energy_add(I, Fl, qx, e)
    e = contact.energy_add(I, Fl, qx, e)
    for b in range(_rows(I, BEAM)):
        e += _ffr_energy(I, Fl, b, qx, _YES)
    return e


@_jit
def _power(I, Fl, t, qx, vx, lam, speeds, work):
    """(put in, dissipated) [W] at (t, qx, vx, lambda): Q . v of the loads
    that put work in (``_inputs_add``, work (nx,) its scratch); c ldot^2 of
    the spring-dampers, c theta'^2 of the rotational ones, -tau z of
    friction, and of the contacts, at the impact speeds ``speeds`` (k,),
    (f - K delta^n) ddelta/dt (the damping's power and, where the force is
    cut at zero, the elastic power it leaves out) and -F_t v_t. A first-order
    state's rate is no load: its column is left out (ZCOL)."""
    for j in range(work.shape[0]):
        work[j] = 0.0
    _inputs_add(I, Fl, t, qx, vx, work)
    for k in range(_rows(I, ZCOL)):
        work[_i(I, ZCOL, k, 0)] = 0.0
    p_in = 0.0
    for j in range(work.shape[0]):
        p_in += work[j] * vx[j]
    p = 0.0
    p = spring_damper.power_add(I, Fl, qx, vx, p)
    p = spatial_springs.power_add(I, Fl, qx, vx, p)
    p = spatial_rotational.power_add(I, Fl, qx, vx, p)
    p = torques.power_add(I, Fl, vx, p)
    p = friction.power_add(I, Fl, qx, vx, lam, p)
    p = contact.power_add(I, Fl, qx, vx, speeds, p)
    return p_in, p


@_jit
def elements(I, Fl, what, t, qx, vx, y, slip, speeds, out, R, C, V):
    """The elements' evaluations Python asks for (``AssembledSystem.Phi``,
    ``AssembledSystem.Q`` and the functions after them; the contacts' and
    springs' events), at the rows t (N,) [s], qx, vx (N, nx) and y (N, m:
    lambda; N, nx: v for C_PHIQ_Y and C_PHIQ_Y_Q, accelerations for L_SLIP),
    as ``what`` says. The joints and drivers (C_*, ``_constraints_row``, vx
    unread): Phi, Phi_t, Phi_tt, Phi_q y into out (N, m), Phi_q^T y into out
    (N, nx), the triplets of Phi_q, (Phi_q^T y)_q and (Phi_q y)_q (their
    rows and columns into R, C, the values of row r into V[r]; the count
    returned, the same at every state: the pattern is fixed by the model).
    The applied loads (L_*):

    * L_Q: Q into out (N, nx), friction with ``slip`` (``_friction_law``);
    * L_QQ, L_QV, L_QLAM: the triplets of Q_q, Q_v (N, n) and Q_lambda
      (n, m) into R, C and V; the count returned (entries that are zero at
      a state may be left out: a caller sums them into a pattern of its own);
    * L_ENERGY: the loads' potential energy into out[:, 0] (``_potential``);
    * L_POWER: the power put in and dissipated into out[:, 0], out[:, 1],
      the contacts at the impact speeds speeds (N, k) (``_power``);
    * L_GAPS: the contacts' gaps g into out[:, :k] and their gradients over
      their ``contact.WIDTH`` columns (KCOL) into out[:, k + W i: k + W (i + 1)]
      (a planar gap's past its six: zeros);
    * L_SPRINGS: d = p2 - p1 of spring-damper i into out[:, 2 i: 2 i + 2];
    * L_SLIP: the friction joints' speeds z into out[:, :k] and their rates
      dz/dt = w . a + v^T (d^2 s) v, a = y, into out[:, k:];
    * L_SENSORS: what the force elements do, y = lambda, for the sensors
      of ``output`` lines, by the laws of the run's forces, ``_potential``
      and ``_power``: per gap i at the impact speeds ``speeds`` (N, k),
      SENSOR_GAP values (g, dg/dt, normal force f, friction force F_t,
      power dissipated (f - K delta^n) ddelta/dt - F_t v_t, elastic energy)
      (``_contact_law``, ``_contact_friction``, ``_contact_energy``); then
      per friction joint SENSOR_FRICTION values (joint speed z, friction
      load tau, power dissipated -tau z) (``_friction_law``); then per
      spring-damper SENSOR_SPRING values (length l, dl/dt, tension k (l -
      l0) + c dl/dt, energy, power dissipated c (dl/dt)^2); then per
      rotational spring-damper the same of its angle (theta, dtheta/dt,
      torque, energy, power).

    The contacts' impact speeds of L_Q, L_QQ and L_QV are the model's state
    (KIMP). One entry point, so that a process loads one library for all of
    them (numba's cache loads each entry point and each signature on its
    own, 20-70 ms each on two cores)."""
    n = _rows(I, MASS)
    p = 0
    nx = qx.shape[1]
    work = np.empty(nx)
    grad, H = np.empty(contact.WIDTH), np.empty((contact.WIDTH, contact.WIDTH))
    for r in range(qx.shape[0]):
        if what < L_Q:
            p = _constraints_row(I, Fl, n, what, r, t, qx, y, out, R, C, V)
        elif what == L_Q:
            _forces(I, Fl, t[r], qx[r], vx[r], y[r], slip, out[r])
        elif what == L_QQ:
            p = _emit_force(I, Fl, t[r], n, qx[r], vx[r], y[r], R, C, V[r], _0, _0, _0, -1.0, 0.0)
        elif what == L_QV:
            p = _emit_force(I, Fl, t[r], n, qx[r], vx[r], y[r], R, C, V[r], _0, _0, _0, 0.0, -1.0)
        elif what == L_QLAM:
            p = _emit_friction_lam(I, Fl, n, qx[r], vx[r], y[r], R, C, V[r], _0, _0, _0, -1.0)
        elif what == L_ENERGY:
            out[r, 0] = _potential(I, Fl, qx[r])
        elif what == L_POWER:
            out[r, 0], out[r, 1] = _power(I, Fl, t[r], qx[r], vx[r], y[r], speeds[r], work)
        elif what == L_GAPS:
            k = _rows(I, KGI)
            for i in range(k):
                out[r, i] = _gap(I, Fl, qx[r], i, grad, H)
                nc = contact.width(I, i)
                for a in range(contact.WIDTH):
                    out[r, k + contact.WIDTH * i + a] = grad[a] if a < nc else 0.0
        elif what == L_SPRINGS:
            for i in range(_rows(I, SCOL1)):
                dx, dy, ax1, ay1, ax2, ay2 = _spring_points(I, Fl, qx[r], i)
                out[r, 2 * i], out[r, 2 * i + 1] = dx, dy
        elif what == L_SENSORS:
            _sensors_row(I, Fl, qx[r], vx[r], y[r], speeds[r], grad, H, out[r])
        else:
            _slip_row(I, Fl, qx[r], vx[r], y[r], grad, H, out[r])
    return p


@_inline
def _sensors_row(I, Fl, qx_r, vx_r, y_r, speeds_r, grad, H, out_r):
    """L_SENSORS of ``elements`` at one row: per contact gap SENSOR_GAP
    values, per friction joint SENSOR_FRICTION, per spring-damper and per
    rotational spring-damper SENSOR_SPRING, into out_r in that order."""
    k = _rows(I, KGI)
    w, dw = np.empty(6), np.empty((6, 6))
    o = 0                    # the next value's column
    for i in range(k):
        g, delta, ddelta, f, elastic, speed, armed = _contact_law(
            I, Fl, qx_r, vx_r, i, speeds_r[i], grad, H)
        if g >= 0.0:         # open: the gap's rate all the same
            ddelta = 0.0
            for a in range(contact.width(I, i)):
                ddelta -= grad[a] * vx_r[_i(I, KCOL, i, a)]
        ft, dissipated = 0.0, 0.0
        if delta > 0.0:
            dissipated = (f - elastic) * ddelta
            if _f(I, Fl, KPAR, i, 12) > 0.0 and f > 0.0:
                ft, vt, T = _contact_friction(I, Fl, qx_r, vx_r, i, f, w, dw)
                dissipated -= ft * vt
        out_r[o], out_r[o + 1], out_r[o + 2] = g, -ddelta, f
        out_r[o + 3], out_r[o + 4] = ft, dissipated
        out_r[o + 5] = _contact_energy(I, Fl, i, g)
        o += SENSOR_GAP
    for i in range(_rows(I, FRI)):
        z, g = _friction_kin(I, Fl, i, qx_r, vx_r, grad, H)
        tau, dz, dN, Rn = _friction_law(I, Fl, i, z, y_r, Fl[:0])
        out_r[o], out_r[o + 1], out_r[o + 2] = z, tau, -tau * z
        o += SENSOR_FRICTION
    for i in range(_rows(I, SCOL1)):
        l, e = _spring_energy(I, Fl, qx_r, i)
        dx, dy, ax1, ay1, ax2, ay2 = _spring_points(I, Fl, qx_r, i)
        ex, ey = _direction(dx, dy, l)
        ld = _spring_rate(I, Fl, qx_r, vx_r, i, ex, ey, ax1, ay1, ax2, ay2)
        c = _f(I, Fl, SPAR, i, 1)
        out_r[o], out_r[o + 1] = l, ld
        out_r[o + 2] = _f(I, Fl, SPAR, i, 0) * (l - _f(I, Fl, SPAR, i, 2)) + c * ld
        out_r[o + 3], out_r[o + 4] = e, c * ld * ld
        o += SENSOR_SPRING
    for i in range(_rows(I, RCOL)):
        a, e = _rotational_energy(I, Fl, qx_r, i)
        wr = vx_r[_i(I, RCOL, i, 1)] - vx_r[_i(I, RCOL, i, 0)]
        c = _f(I, Fl, RPAR, i, 1)
        out_r[o], out_r[o + 1] = a, wr
        out_r[o + 2] = _f(I, Fl, RPAR, i, 0) * (a - _f(I, Fl, RPAR, i, 2)) + c * wr
        out_r[o + 3], out_r[o + 4] = e, c * wr * wr
        o += SENSOR_SPRING


@_inline
def _slip_row(I, Fl, qx_r, vx_r, y_r, grad, H, out_r):
    """L_SLIP of ``elements`` at one row: the friction joints' speeds z into
    out_r[:k] and their rates dz/dt = w . a + v^T (d^2 s) v (a = y_r) into
    out_r[k:]."""
    k = _rows(I, FRI)
    for i in range(k):
        z, g = _friction_kin(I, Fl, i, qx_r, vx_r, grad, H)
        rate = 0.0
        for a in range(2 if g < 0 else 6):
            col = _friction_col(I, i, g, a)
            rate += grad[a] * y_r[col]
            if g >= 0:
                for b in range(6):
                    rate += vx_r[col] * H[a, b] * vx_r[_i(I, GEO, g, b)]
        out_r[i], out_r[k + i] = z, rate


def triplet_bound(I) -> int:
    """An upper bound of the Newton-matrix triplets any recipe emits for the
    packed model data ``I`` (its header's row counts): up to five mass (and
    identity) blocks, four Hessian, two force, two G and six Phi_q blocks (a force
    block: 36 entries per spring-damper and per planar contact gap (576 per spatial one),
    4 per rotational one, 1 per point
    force (and 6 (3 + e) per partial derivative of a point force of the state,
    ``point_forces.triplets``), 36 per partial derivative of a load of the state (6 rows by 6
    columns) and 36 per load of the state (tau d^2 s of a joint force)), and the
    augmented formulation's multiplier diagonal; per flexible beam 15 blocks of
    (3 + nf)^2 (mass, (M x)_q and force blocks), per elastic term of a joint
    point 40 entries, per spring-damper with points on beams (6 + e)^2
    instead of 36, per point force on a beam 1 + 2 e, per distance joint on
    beams four (6 + e)^2 Hessian and two 6 + e G blocks; and 3 + nf per column
    of the additive form's three blocks of each beam's rows
    (``_unscale_beam_rows``)."""
    def rows(k):
        """Instances of field k (the header's row count)."""
        return int(I[3 * k + 1])
    n = rows(MASS)
    # per family: its instances (its first field's rows) times its triplets per instance
    phiq = sum(j.PHIQ_TRIPLETS * rows(field) for j, field in JOINTS)
    hess = sum(j.HESS_TRIPLETS * rows(field) for j, field in JOINTS) + spatial.hess_triplets(I)
    G = sum(j.G_TRIPLETS * rows(field) for j, field in JOINTS)
    force = (sum(load.FORCE_TRIPLETS * rows(field) for load, field in LOADS)
             + point_forces.triplets(I) + contact.triplets(I))
    beams, csum = 0, 0
    for b in range(rows(BEAM)):     # blocks, and the additive form's M M_n^-1 Phi_q^T (twice)
        c = 3 + int(I[int(I[3 * BEAM]) + 6 * b + 1])
        beams += 15 * c * c + 2 * c * (phiq + 2 * rows(ECOL))
        csum += c
    base = (6 * n + rows(ROW_ELEMENT) + 6 * phiq + 4 * hess + 2 * force + 2 * G
            + 12 * rows(FRI) + beams + 40 * rows(ECOL))
    # springs and point forces on beam points: (6 + e)^2 and 1 + 2 e entries, e their
    # elastic terms (spans into ECOL), in each of the two force blocks
    ecs = 0
    for i in range(rows(SEL)):
        o = int(I[3 * SEL]) + 4 * i
        c = 6 + int(I[o + 1] - I[o] + I[o + 3] - I[o + 2])
        ecs += c * c - 36
    for i in range(rows(FEL)):
        o = int(I[3 * FEL]) + 2 * i
        ecs += 2 * int(I[o + 1] - I[o])
    # a family's own blocks of points on beams (distance joints: Hessian and G blocks)
    ecs += sum(j.elastic_triplets(I) for j, _ in JOINTS if hasattr(j, "elastic_triplets"))
    # the additive form's unscaled beam rows: c entries per structural column, 3 blocks
    return base + 2 * ecs + 3 * (3 * n + 2 * rows(ROW_ELEMENT)) * csum
