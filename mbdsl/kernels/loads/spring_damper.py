"""Spring-damper-actuators between two points: Q = -D^T (f e), f = k (l - l0) + c ldot.

d = p2 - p1, l = |d|, e = d / l, ldot = e . d', D = dd/dq: Q = -D^T (f e),
Q_q by the chain rule through e, l, ldot and the Hessians of d, Q_v = -c (D^T
e)(D^T e)^T (Haug, sec. 6.3; Nikravesh, sec. 4.9).
A spring of free length 0 between coincident points has no direction; the
time loop lands a step there as an event and holds the direction
(``_free_length``, docs/contact.md). Points on flexible beams add their
elastic columns (``_emit_spring_elastic``).

Fields: SCOL1, SCOL2 (k, 3) the bodies' columns, SS1, SS2 (k, 2) the local
points [m], SPAR (k, 5) (k [N/m], c [N s/m], l0 [m], held direction), SEL
(k, 4) elastic spans.
"""

from __future__ import annotations

import math

import numpy as np

from ..geometry import _Au, _direction, _direction_derivative, _eshape, _span
from ..schema import ECOL, SCOL1, SCOL2, SEL, SPAR, SS1, SS2, _f, _i, _inline, _hot, _jit, _put, _rows

#: Its fields in ``schema.MODEL_SCHEMA`` (the first gives the instances).
FIELDS = ("scol1", "ss1", "scol2", "ss2", "spar", "sel")
#: Newton-matrix triplets per instance of a force block: a 6 x 6 block over both bodies' columns (a
#: point on a beam: ``triplet_bound``).
FORCE_TRIPLETS = 36
#: The loads it holds (``model.elements.SpringDamper.kind``).
LOADS = ("spring",)


def pack(items, tables) -> dict:
    """Its fields from the model's spring-dampers.

    Parameters
    ----------
    items : list of SpringDamper
        The model's spring-dampers, in its order.
    tables : packing context
        ``points`` and ``elastic_spans`` (``assembly.packing.PackingContext``).

    Returns
    -------
    dict
        field name -> array; SPAR's held direction starts at zero (none held:
        the physical law), the time loop writes it (``_free_length``).
    """
    first, second = [s.first for s in items], [s.second for s in items]
    tables.elastic_spans("sel", first, second)
    scol1, ss1 = tables.points(first)
    scol2, ss2 = tables.points(second)
    spar = np.array([(s.k, s.c, s.length, 0.0, 0.0) for s in items], np.float64).reshape(-1, 5)
    return {"scol1": scol1, "ss1": ss1, "scol2": scol2, "ss2": ss2, "spar": spar}


def pattern(items, tables) -> tuple:
    """(columns (k, c) in q_ext whose Q_q, Q_v entries a spring may fill: both
    points' bodies and elastic coordinates; whether any is damped)."""
    cols = np.concatenate([tables.point_columns([s.first for s in items]),
                           tables.point_columns([s.second for s in items])], axis=1)
    return cols, any(s.c != 0.0 for s in items)


@_jit
def _spring_points(I, Fl, qx, i):
    """(d_x, d_y, (A u)_1, (A u)_2) of spring-damper i at qx: d = p2 - p1 [m]
    and its points' offsets from their frames (A u, u = s + S q_e on a
    flexible beam: ``_Au``); the kinematics of ``_spring`` in scalars."""
    ax1, ay1 = _Au(I, Fl, qx, SCOL1, SS1, SEL, 0, i)
    ax2, ay2 = _Au(I, Fl, qx, SCOL2, SS2, SEL, 1, i)
    dx = (qx[_i(I, SCOL2, i, 0)] - qx[_i(I, SCOL1, i, 0)]) + (ax2 - ax1)
    dy = (qx[_i(I, SCOL2, i, 1)] - qx[_i(I, SCOL1, i, 1)]) + (ay2 - ay1)
    return dx, dy, ax1, ay1, ax2, ay2


@_jit
def _free_length(I, Fl, i, dx, dy):
    """The free length spring i's force k (l - l0') e reads at d = (dx, dy):
    l0, or -l0 while d points against the spring's held direction u_ref
    (SPAR columns 3, 4; (0, 0): none held, the physical law).

    A spring with a free length whose points pass each other has a force
    that turns over at the pass (e = d / l flips). While a step is landed on
    the pass (``loop.TimeLoop.land``), u_ref holds the direction before it,
    so that the steps the event locator tries feel the old branch continued
    past the root (k (l + l0) e with e the new direction is -k (-l - l0)
    e_old: the force of the signed length -l, smooth through the root) and
    not the new one over their whole length, an O(step) error of an implicit
    step that ends past the root; the commit clears u_ref, and the method
    restarts on the new branch. The potential energy (``_potential``) keeps
    the physical law: the two agree except past the root within a landing."""
    l0 = _f(I, Fl, SPAR, i, 2)
    ux, uy = _f(I, Fl, SPAR, i, 3), _f(I, Fl, SPAR, i, 4)
    if dx * ux + dy * uy < 0.0:
        return -l0
    return l0


@_jit
def _spring(I, Fl, qx, vx, i, G, v6):
    """Kinematics of spring i: D = dd/dq_local into G (2, 6), local v into v6;
    returns (d, ddot, l, A s1, A s2)."""
    dx, dy, ax1, ay1, ax2, ay2 = _spring_points(I, Fl, qx, i)
    G[:] = 0.0
    G[0, 0] = -1.0
    G[1, 1] = -1.0
    G[0, 2] = ay1
    G[1, 2] = -ax1
    G[0, 3] = 1.0
    G[1, 4] = 1.0
    G[0, 5] = -ay2
    G[1, 5] = ax2
    for j in range(3):
        v6[j] = vx[_i(I, SCOL1, i, j)]
        v6[3 + j] = vx[_i(I, SCOL2, i, j)]
    ddx = 0.0
    ddy = 0.0
    for j in range(6):
        ddx += G[0, j] * v6[j]
        ddy += G[1, j] * v6[j]
    return dx, dy, ddx, ddy, math.sqrt(dx * dx + dy * dy), ax1, ay1, ax2, ay2


@_jit
def _spring_passed(I, Fl, qa, qb):
    """Whether the points of a spring-damper with a free length passed each
    other between configurations qa and qb (n+3,): d_a . d_b < 0, where its
    force k (l - l0) e flips direction (``events.EventLocator``)."""
    for i in range(_rows(I, SCOL1)):
        if _f(I, Fl, SPAR, i, 2) > 0.0:
            dxa, dya, _, _, _, _ = _spring_points(I, Fl, qa, i)
            dxb, dyb, _, _, _, _ = _spring_points(I, Fl, qb, i)
            if dxa * dxb + dya * dyb < 0.0:
                return True
    return False


@_jit
def _spring_rate(I, Fl, qx, vx, i, ex, ey, ax1, ay1, ax2, ay2):
    """ldot = e . d' of spring-damper i, its points' offsets A u from
    ``_spring_points`` (with the elastic terms' velocities -+ A S_k v_k of a
    point on a flexible beam)."""
    w1, w2 = vx[_i(I, SCOL1, i, 2)], vx[_i(I, SCOL2, i, 2)]
    ddx = (vx[_i(I, SCOL2, i, 0)] - vx[_i(I, SCOL1, i, 0)]) + (-ay2 * w2 + ay1 * w1)
    ddy = (vx[_i(I, SCOL2, i, 1)] - vx[_i(I, SCOL1, i, 1)]) + (ax2 * w2 - ax1 * w1)
    for side in range(2):
        k0, k1 = _span(I, SEL, i, side)
        ph = qx[_i(I, SCOL1 if side == 0 else SCOL2, i, 2)]
        sg = -1.0 if side == 0 else 1.0
        for k in range(k0, k1):
            Ax, Ay, Bx, By = _eshape(I, Fl, k, ph)
            vk = vx[_i(I, ECOL, k, 0)]
            ddx += sg * Ax * vk
            ddy += sg * Ay * vk
    return ex * ddx + ey * ddy


@_hot
def _springs_add(I, Fl, qx, vx, out):
    """The spring-dampers' Q = -D^T (f e), f = k (l - l0) + c ldot, added to
    out (n+3,) [N, N m]."""
    for i in range(_rows(I, SCOL1)):
        # (no scratch array on this hot path); a point on a flexible beam at A u (its terms below)
        dx, dy, ax1, ay1, ax2, ay2 = _spring_points(I, Fl, qx, i)
        l = math.sqrt(dx * dx + dy * dy)
        ex, ey = _direction(dx, dy, l)
        f = _f(I, Fl, SPAR, i, 0) * (l - _free_length(I, Fl, i, dx, dy))
        if _f(I, Fl, SPAR, i, 1) != 0.0:
            f = f + _f(I, Fl, SPAR, i, 1) * _spring_rate(I, Fl, qx, vx, i, ex, ey, ax1, ay1,
                                                         ax2, ay2)
        fx, fy = f * ex, f * ey
        # Q = -D^T (f e), D = dd/dq_local (``_spring``'s G)
        out[_i(I, SCOL1, i, 0)] += fx
        out[_i(I, SCOL1, i, 1)] += fy
        out[_i(I, SCOL1, i, 2)] -= ay1 * fx - ax1 * fy
        out[_i(I, SCOL2, i, 0)] -= fx
        out[_i(I, SCOL2, i, 1)] -= fy
        out[_i(I, SCOL2, i, 2)] -= -ay2 * fx + ax2 * fy
        for side in range(2):              # elastic terms: -+ (A S_k) . (f e)
            k0, k1 = _span(I, SEL, i, side)
            ph = qx[_i(I, SCOL1 if side == 0 else SCOL2, i, 2)]
            sg = 1.0 if side == 0 else -1.0
            for k in range(k0, k1):
                Ax, Ay, Bx, By = _eshape(I, Fl, k, ph)
                out[_i(I, ECOL, k, 0)] += sg * (Ax * fx + Ay * fy)


@_jit
def _emit_spring_elastic(I, Fl, n, qx, vx, i, R, C, V, p, r0, c0, cq, cv):
    """-(cq Q_q + cv Q_v) at (r0, c0) of spring-damper i with a point on a
    flexible beam (the module notes) over its local columns:
    x, y, phi of both bodies, then the elastic terms of each point (u = s +
    S q_e). With D = dd/dq_local and Hd = d^2 d/dq_local^2 (d^2 p/dphi^2 = -A u,
    d^2 p/dphi dq_k = B S_k; Shabana, sec. 5.3): Q_q = -D^T d(f e)/dq - (f e)
    . Hd, Q_v = -c (D^T e)(D^T e)^T."""
    a0, a1 = _span(I, SEL, i, 0)
    b0, b1 = _span(I, SEL, i, 1)
    nc = 6 + (a1 - a0) + (b1 - b0)
    cols = np.empty(nc, np.int64)
    D, Hd = np.zeros((2, nc)), np.zeros((2, nc, nc))
    v, de, Hv = np.empty(nc), np.empty((2, nc)), np.empty((2, nc))
    for j in range(3):
        cols[j] = _i(I, SCOL1, i, j)
        cols[3 + j] = _i(I, SCOL2, i, j)
    ph1, ph2 = qx[cols[2]], qx[cols[5]]
    ax1, ay1 = _Au(I, Fl, qx, SCOL1, SS1, SEL, 0, i)
    ax2, ay2 = _Au(I, Fl, qx, SCOL2, SS2, SEL, 1, i)
    D[0, 0], D[1, 1], D[0, 3], D[1, 4] = -1.0, -1.0, 1.0, 1.0
    D[0, 2], D[1, 2], D[0, 5], D[1, 5] = ay1, -ax1, -ay2, ax2
    Hd[0, 2, 2], Hd[1, 2, 2], Hd[0, 5, 5], Hd[1, 5, 5] = ax1, ay1, -ax2, -ay2
    j = 6
    for side in range(2):
        k0, k1 = (a0, a1) if side == 0 else (b0, b1)
        sg, cph = (-1.0, 2) if side == 0 else (1.0, 5)
        for k in range(k0, k1):
            cols[j] = _i(I, ECOL, k, 0)
            Ax, Ay, Bx, By = _eshape(I, Fl, k, ph1 if side == 0 else ph2)
            D[0, j], D[1, j] = sg * Ax, sg * Ay
            Hd[0, cph, j], Hd[1, cph, j] = sg * Bx, sg * By
            Hd[0, j, cph], Hd[1, j, cph] = sg * Bx, sg * By
            j += 1
    for j in range(nc):
        v[j] = vx[cols[j]]
    k, c = _f(I, Fl, SPAR, i, 0), _f(I, Fl, SPAR, i, 1)
    dx = (qx[cols[3]] - qx[cols[0]]) + (ax2 - ax1)
    dy = (qx[cols[4]] - qx[cols[1]]) + (ay2 - ay1)
    l0 = _free_length(I, Fl, i, dx, dy)
    l = math.sqrt(dx * dx + dy * dy)
    ex, ey = _direction(dx, dy, l)
    ddx, ddy = 0.0, 0.0
    for j in range(nc):
        ddx += D[0, j] * v[j]
        ddy += D[1, j] * v[j]
    P00, P01, P11 = _direction_derivative(ex, ey, l)
    for j in range(nc):
        de[0, j] = P00 * D[0, j] + P01 * D[1, j]
        de[1, j] = P01 * D[0, j] + P11 * D[1, j]
        for a in range(2):
            acc = 0.0
            for m2 in range(nc):
                acc += Hd[a, j, m2] * v[m2]
            Hv[a, j] = acc
    ldot = ex * ddx + ey * ddy
    f = k * (l - l0) + c * ldot
    Fx, Fy = f * ex, f * ey
    for a in range(nc):
        ra = cols[a]
        if ra >= n:
            continue
        Ge_a = D[0, a] * ex + D[1, a] * ey
        for b in range(nc):
            cb = cols[b]
            if cb >= n:
                continue
            dl = ex * D[0, b] + ey * D[1, b]
            dldot = ddx * de[0, b] + ddy * de[1, b] + ex * Hv[0, b] + ey * Hv[1, b]
            df = k * dl + c * dldot
            dFx, dFy = ex * df + f * de[0, b], ey * df + f * de[1, b]
            qq = -(D[0, a] * dFx + D[1, a] * dFy) - (Fx * Hd[0, a, b] + Fy * Hd[1, a, b])
            qv = -c * Ge_a * (D[0, b] * ex + D[1, b] * ey)
            p = _put(R, C, V, p, r0 + ra, c0 + cb, -(cq * qq + cv * qv))
    return p


@_jit
def _spring_energy(I, Fl, qx, i):
    """(length l [m], k (l - l0)^2 / 2 [J]) of spring-damper i at qx."""
    dx, dy, ax1, ay1, ax2, ay2 = _spring_points(I, Fl, qx, i)
    l = math.sqrt(dx * dx + dy * dy)
    s = l - _f(I, Fl, SPAR, i, 2)
    return l, 0.5 * _f(I, Fl, SPAR, i, 0) * s * s


@_inline
def emit_force(I, Fl, n, qx, vx, R, C, V, p, r0, c0, cq, cv):
    """-(cq Q_q + cv Q_v) of the spring-dampers at (r0, c0) (the module
    notes; a point on a flexible beam: ``_emit_spring_elastic``); returns p."""
    if _rows(I, SCOL1) == 0:
        return p
    G = np.empty((2, 6))
    v6 = np.empty(6)
    de = np.empty((2, 6))
    dF = np.empty((2, 6))
    dl = np.empty(6)
    dldot = np.empty(6)
    cols = np.empty(6, np.int64)
    for i in range(_rows(I, SCOL1)):
        a0, a1 = _span(I, SEL, i, 0)
        b0, b1 = _span(I, SEL, i, 1)
        if a1 > a0 or b1 > b0:            # a point on a flexible beam
            p = _emit_spring_elastic(I, Fl, n, qx, vx, i, R, C, V, p, r0, c0, cq, cv)
            continue
        k, c = _f(I, Fl, SPAR, i, 0), _f(I, Fl, SPAR, i, 1)
        dx, dy, ddx, ddy, l, ax1, ay1, ax2, ay2 = _spring(I, Fl, qx, vx, i, G, v6)
        l0 = _free_length(I, Fl, i, dx, dy)
        ex, ey = _direction(dx, dy, l)
        P00, P01, P11 = _direction_derivative(ex, ey, l)
        ldot = ex * ddx + ey * ddy
        f = k * (l - l0) + c * ldot
        for j in range(6):
            de[0, j] = P00 * G[0, j] + P01 * G[1, j]
            de[1, j] = P01 * G[0, j] + P11 * G[1, j]
            dl[j] = ex * G[0, j] + ey * G[1, j]
            dldot[j] = ddx * de[0, j] + ddy * de[1, j]
        # e . Hv: Hd[a, 2, 2] = (A s1)_a, Hd[a, 5, 5] = -(A s2)_a
        dldot[2] += (ex * ax1 + ey * ay1) * v6[2]
        dldot[5] -= (ex * ax2 + ey * ay2) * v6[5]
        for j in range(6):
            dfj = k * dl[j] + c * dldot[j]
            dF[0, j] = ex * dfj + f * de[0, j]
            dF[1, j] = ey * dfj + f * de[1, j]
        Fx, Fy = f * ex, f * ey
        for j in range(3):
            cols[j] = _i(I, SCOL1, i, j)
            cols[3 + j] = _i(I, SCOL2, i, j)
        for a in range(6):
            if cols[a] >= n:
                continue
            for b in range(6):
                if cols[b] >= n:
                    continue
                qq = -(G[0, a] * dF[0, b] + G[1, a] * dF[1, b])
                if a == b and a == 2:
                    qq -= Fx * ax1 + Fy * ay1
                elif a == b and a == 5:
                    qq += Fx * ax2 + Fy * ay2
                val = cq * qq
                if c != 0.0:
                    val += cv * (-c * (G[0, a] * ex + G[1, a] * ey) * (G[0, b] * ex + G[1, b] * ey))
                p = _put(R, C, V, p, r0 + cols[a], c0 + cols[b], -val)
    return p


@_inline
def energy_add(I, Fl, qx, e):
    """e + the springs' potential k (l - l0)^2 / 2 [J]."""
    for i in range(_rows(I, SCOL1)):
        e += _spring_energy(I, Fl, qx, i)[1]
    return e


@_inline
def power_add(I, Fl, qx, vx, p):
    """p + the power the dampers dissipate, c ldot^2 [W]."""
    for i in range(_rows(I, SCOL1)):
        c = _f(I, Fl, SPAR, i, 1)
        if c != 0.0:
            dx, dy, ax1, ay1, ax2, ay2 = _spring_points(I, Fl, qx, i)
            l = math.sqrt(dx * dx + dy * dy)
            ex, ey = _direction(dx, dy, l)
            ld = _spring_rate(I, Fl, qx, vx, i, ex, ey, ax1, ay1, ax2, ay2)
            p += c * ld * ld
    return p
