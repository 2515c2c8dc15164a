"""An independent, vectorised numpy evaluation of the joints and drivers:
the oracle the constraint kernels of ``mbdsl.kernels``
(``phi``, ``phiq_times``, ``phiqT_add``, ``_emit_phiq``, ``_emit_hess``,
``_emit_G``, ``_phi_time_add``) are tested against. Not part of the
package: mbdsl evaluates its constraints with the kernels only.

The oracle reads the model's joints and drivers itself (:func:`groups_of`:
which rows each kind holds, and their data) and groups them by the form of
their rows: coincidence, point on line, linear, distance. Each group's
*local* arrays over the c coordinates it touches (columns ``cols`` (k, c)
into q_ext = [q, 0, 0, 0]) are scattered into dense matrices:

* ``phi``  (k, r)        constraint values
* ``jac``  (k, r, c)     d phi / d q_local
* ``hess`` (k, r, c, c)  d^2 phi / d q_local^2 (linear groups: none)

All formulas in absolute planar coordinates (Haug, Computer-Aided
Kinematics and Dynamics of Mechanical Systems, ch. 3; Nikravesh,
Computer-Aided Analysis of Mechanical Systems, ch. 4); a point of a flexible
beam at r + A (s + S q_e) (Shabana, Dynamics of Multibody Systems, sec. 5.3).
The kernel families' docstrings (``mbdsl/kernels/joints``) state each constraint.
"""

from __future__ import annotations

import numpy as np

from types import SimpleNamespace

from mbdsl.assembly.points import PointSet
from mbdsl.model.elements import line_columns

__all__ = ["ConstraintOracle", "groups_of", "line_distance"]


def _point_pair(cmap, first, second):
    """Two point sets side by side: columns (k, c1 + c2), c1, the sets."""
    P1, P2 = PointSet(cmap, first), PointSet(cmap, second)
    return SimpleNamespace(P1=P1, P2=P2, c1=P1.c, cols=np.concatenate([P1.cols, P2.cols], 1))


def groups_of(system, model=None):
    """The joints and drivers of ``model`` (default: the system's) grouped by
    the form of their rows, read from the model: a revolute's and a fixed
    joint's two coincidence rows, a fixed joint's third and a prismatic
    joint's second row (the locked angle phi2 - phi1 - angle), a sliding
    joint's row n . (p_first - p_second), n = A_second (-u_y, u_x); drivers: a
    coordinate q_c - f, a joint angle phi2 - phi1 - f, a sliding joint's
    distance u . (p_first - p_second) - f; a distance joint's (|d|^2 -
    L^2) / (2 L). Rows: joints in declaration order, then drivers."""
    model = system.model if model is None else model
    cmap, n = system.cmap, system.n
    coinc, pol, lin, dist = [], [], [], []
    row = 0
    phi = lambda body: cmap.column(body, 2)          # noqa: E731
    for j in model.joints:
        a, b = j.first, j.second
        if j.kind in ("revolute", "fixed"):
            coinc.append(((row, row + 1), a, b))
            if j.kind == "fixed":
                lin.append((row + 2, (phi(a.body), phi(b.body)), (-1.0, 1.0), j.angle, None))
        elif j.kind in ("point_on_line", "prismatic"):
            pol.append((row, b, a, (-j.direction[1], j.direction[0]), None))
            if j.kind == "prismatic":
                lin.append((row + 1, (phi(a.body), phi(b.body)), (-1.0, 1.0), j.angle, None))
        elif j.kind == "distance":
            dist.append((row, a, b, j.length))
        else:
            raise AssertionError(f"the oracle has no rows for a {j.kind} joint")
        row += j.rows
    for d in model.drivers:
        if d.kind == "coordinate":
            lin.append((row, (n, cmap.column(d.body, d.coord)), (0.0, 1.0), 0.0, d.function))
        elif d.kind == "joint_distance":
            pol.append((row, d.joint.second, d.joint.first, tuple(d.joint.direction), d.function))
        else:
            lin.append((row, (phi(d.joint.first.body), phi(d.joint.second.body)), (-1.0, 1.0),
                        0.0, d.function))
        row += 1
    couplers = [(row + k, c) for k, c in enumerate(model.couplers)]
    groups = []
    if coinc:
        rows, p1, p2 = zip(*coinc)
        groups.append(SimpleNamespace(kind="coincidence", rows=np.array(rows).reshape(-1, 2),
                                      pair=_point_pair(cmap, p1, p2), functions=[None] * len(rows)))
    if pol:
        rows, line, point, n0, fns = zip(*pol)
        groups.append(SimpleNamespace(kind="point_on_line", rows=np.array(rows).reshape(-1, 1),
                                      pair=_point_pair(cmap, line, point), n0=np.array(n0, float),
                                      functions=list(fns)))
    if lin:
        rows, cols, coefs, off, fns = zip(*lin)
        groups.append(SimpleNamespace(kind="linear", rows=np.array(rows).reshape(-1, 1),
                                      cols=np.array(cols).reshape(-1, 2),
                                      coefs=np.array(coefs, float), offset=np.array(off, float),
                                      functions=list(fns)))
    if dist:
        rows, p1, p2, lengths = zip(*dist)
        groups.append(SimpleNamespace(kind="distance", rows=np.array(rows).reshape(-1, 1),
                                      pair=_point_pair(cmap, p1, p2), L=np.array(lengths, float),
                                      functions=[None] * len(rows)))
    groups += [_coupler_group(system, r, c) for r, c in couplers]
    for g in groups:
        if g.kind not in ("linear", "coupler"):
            g.cols = g.pair.cols
        g.time_dependent = any(f is not None for f in g.functions)
    return groups


def _coupler_group(system, row, coupler):
    """One coupler, sum_k a_k x_k - c: its terms' columns side by side (a
    column two terms share appears twice, summed by the scatter), each term a
    linear combination of body coordinates or a sliding joint's distance
    (:func:`line_distance`); c given, or the relation's value at the
    positions as placed."""
    from mbdsl.assembly.placement import place_bodies
    cmap, n = system.cmap, system.n
    terms, cols = [], []
    for v, a in zip(coupler.variables, coupler.coefficients):
        if v.line is not None:
            c = line_columns(v.line, cmap)
            terms.append(("line", a, v.line, slice(len(cols), len(cols) + 6)))
        else:
            c = [cmap.column(b, j) for b, j, _ in v.terms]
            terms.append(("linear", a, np.array([w for _, _, w in v.terms]),
                          slice(len(cols), len(cols) + len(c))))
        cols += c
    g = SimpleNamespace(kind="coupler", rows=np.array([[row]]), cols=np.array([cols]),
                        terms=terms, functions=[None], offset=0.0, cmap=cmap)
    if coupler.value is not None:
        g.offset = coupler.value
    else:
        qx = np.concatenate([place_bodies(system), np.zeros(3)])
        g.offset = float(_coupler_local(g, qx)[0][0, 0])
    return g


def _coupler_local(g, qx):
    """(phi, jac, hess) of a coupler group, as :func:`local` (c excluded)."""
    c = g.cols.shape[1]
    phi, jac, hess = 0.0, np.zeros(c), np.zeros((c, c))
    for kind, a, data, where in g.terms:
        if kind == "line":
            s, grad, H = line_distance(data, qx, g.cmap)
            phi += a * s
            jac[where] += a * grad
            hess[where, where] += a * H
        else:
            phi += a * float(data @ qx[g.cols[0, where]])
            jac[where] += a * data
    return np.array([[phi]]), jac[None, None], hess[None, None]


def rot(phi, s):
    """A(phi) s, phi (k,), s (k, 2) -> (k, 2)."""
    return np.einsum("kab,kb->ka", _AB(phi)[0], np.broadcast_to(s, np.shape(phi) + (2,)))


def drot(phi, s):
    """B(phi) s = dA/dphi s, as :func:`rot`."""
    return np.einsum("kab,kb->ka", _AB(phi)[1], np.broadcast_to(s, np.shape(phi) + (2,)))


def _local(P, q):
    """u = s + S q_e of a PointSet, shape (k, 2), from local coordinates (k, c)."""
    return P.s + np.einsum("kaj,kj->ka", P.S, q[:, 3:]) if P.flexible else P.s


def _AB(phi):
    """Rotation matrices A(phi) and B(phi) = dA/dphi, each shape (k, 2, 2)."""
    c, s = np.cos(phi), np.sin(phi)
    return (np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2),
            np.stack([np.stack([-s, -c], -1), np.stack([c, -s], -1)], -2))


def _point_jac(P, q):
    """d position / d q_local of a PointSet, [I, B u, A S], shape (k, 2, c)."""
    A, B = _AB(q[:, 2])
    eye = np.broadcast_to(np.eye(2), (len(q), 2, 2))
    parts = [eye, np.einsum("kab,kb->ka", B, _local(P, q))[:, :, None]]
    if P.flexible:
        parts.append(np.einsum("kab,kbj->kaj", A, P.S))
    return np.concatenate(parts, axis=2)


def _point_hess(P, q):
    """d^2 position / d q_local^2 of a PointSet, shape (k, 2, c, c): -A u in
    (phi, phi), B S in (phi, q_e) and (q_e, phi)."""
    A, B = _AB(q[:, 2])
    H = np.zeros((len(q), 2, P.c, P.c))
    H[:, :, 2, 2] = -np.einsum("kab,kb->ka", A, _local(P, q))
    if P.flexible:
        BS = np.einsum("kab,kbj->kaj", B, P.S)
        H[:, :, 2, 3:] = H[:, :, 3:, 2] = BS
    return H


def _pair(g, qx):
    """Local coordinates of both points, d = p2 - p1, D = dd/dq, DD = d^2d/dq^2."""
    pair = g.pair
    q = qx[pair.cols]
    q1, q2 = q[:, :pair.c1], q[:, pair.c1:]
    d = (q2[:, 0:2] - q1[:, 0:2]) + (rot(q2[:, 2], _local(pair.P2, q2))
                                     - rot(q1[:, 2], _local(pair.P1, q1)))
    k, c = pair.cols.shape
    D = np.zeros((k, 2, c))
    D[:, :, :pair.c1] = -_point_jac(pair.P1, q1)
    D[:, :, pair.c1:] = _point_jac(pair.P2, q2)
    DD = np.zeros((k, 2, c, c))
    DD[:, :, :pair.c1, :pair.c1] = -_point_hess(pair.P1, q1)
    DD[:, :, pair.c1:, pair.c1:] = _point_hess(pair.P2, q2)
    return q1, d, D, DD


def _functions(g, t, which):
    """f(t), f'(t) or f''(t) (``which`` "f", "df", "ddf") per instance (None: 0)."""
    return np.array([0.0 if f is None else getattr(f, which)(t) for f in g.functions])


def local(g, qx, t):
    """(phi (k, r), jac (k, r, c), hess (k, r, c, c) or None) of one group."""
    if g.kind == "coupler":
        phi, jac, hess = _coupler_local(g, qx)
        return phi - g.offset, jac, hess
    if g.kind == "linear":
        phi = np.einsum("kj,kj->k", g.coefs, qx[g.cols]) - g.offset - _functions(g, t, "f")
        return phi[:, None], g.coefs[:, None, :].copy(), None
    q1, d, D, DD = _pair(g, qx)
    if g.kind == "coincidence":
        return d, D, DD
    if g.kind == "distance":
        L = g.L
        phi = (np.einsum("ka,ka->k", d, d) - L ** 2) / (2.0 * L)
        jac = np.einsum("ka,kaj->kj", d, D) / L[:, None]
        hess = (np.einsum("kai,kaj->kij", D, D) + np.einsum("ka,kaij->kij", d, DD)) \
            / L[:, None, None]
        return phi[:, None], jac[:, None], hess[:, None]
    assert g.kind == "point_on_line"
    nvec, Bn = rot(q1[:, 2], g.n0), drot(q1[:, 2], g.n0)
    phi = np.einsum("ka,ka->k", nvec, d) - _functions(g, t, "f")
    jac = np.einsum("ka,kaj->kj", nvec, D)
    jac[:, 2] += np.einsum("ka,ka->k", Bn, d)
    hess = np.einsum("ka,kaij->kij", nvec, DD)
    BnD = np.einsum("ka,kaj->kj", Bn, D)
    hess[:, 2, :] += BnD
    hess[:, :, 2] += BnD
    hess[:, 2, 2] -= np.einsum("ka,ka->k", nvec, d)
    return phi[:, None], jac[:, None], hess[:, None]


class SystemOracle:
    """An oracle of an ``AssembledSystem``'s elements; one state at a time.

    Parameters
    ----------
    system : mbdsl.assembly.system.AssembledSystem
    """

    def __init__(self, system):
        self.system = system
        self.n, self.m, self.nx = system.n, system.m, system.nx

    def _ext(self, x):
        out = np.zeros(self.nx)
        out[: self.n] = x
        return out


class ConstraintOracle(SystemOracle):
    """Phi and its derivatives of an ``AssembledSystem``'s joints and drivers,
    dense; ``model`` (default: the system's) gives the joints and drivers."""

    def __init__(self, system, model=None):
        super().__init__(system)
        self.groups = groups_of(system, model)

    def _each(self, q, t):
        qx = self._ext(q)
        for g in self.groups:
            yield g, local(g, qx, t)

    def Phi(self, q, t):
        """Phi, shape (m,)."""
        out = np.zeros(self.m)
        for g, (phi, _, _) in self._each(q, t):
            out[g.rows] = phi
        return out

    def Phi_q(self, q, t=0.0):
        """Phi_q, shape (m, n) (the ground's columns dropped)."""
        out = np.zeros((self.m, self.nx))
        for g, (_, jac, _) in self._each(q, t):
            for i in range(len(g.rows)):
                np.add.at(out, (g.rows[i][:, None], g.cols[i][None, :]), jac[i])
        return out[:, : self.n]

    def hessians(self, q):
        """d^2 Phi_r / dq^2 of every row r, shape (m, n, n)."""
        out = np.zeros((self.m, self.nx, self.nx))
        for g, (_, _, hess) in self._each(q, 0.0):
            if hess is None:
                continue
            for i in range(len(g.rows)):
                c = g.cols[i]
                for r, row in enumerate(g.rows[i]):
                    np.add.at(out[row], (c[:, None], c[None, :]), hess[i, r])
        return out[:, : self.n, : self.n]

    def PhiqT_lam_q(self, q, lam):
        """(Phi_q^T lambda)_q, shape (n, n)."""
        return np.einsum("r,rij->ij", lam, self.hessians(q))

    def Phiq_v_q(self, q, v):
        """(Phi_q v)_q, shape (m, n)."""
        return np.einsum("rij,j->ri", self.hessians(q), v)

    def Phi_t(self, t, order=1):
        """d^order Phi / dt^order (order 1 or 2), shape (m,)."""
        out = np.zeros(self.m)
        which = "df" if order == 1 else "ddf"
        for g in self.groups:
            if g.time_dependent:
                out[g.rows[:, 0]] = -_functions(g, t, which)
        return out

    def gamma(self, q, v, t):
        """-(Phi_q v)_q v - Phi_tt, shape (m,)."""
        return -self.Phiq_v_q(q, v) @ v - self.Phi_t(t, 2)


# -- a sliding joint's distance (loads of the state, sliding limits) --------------------------
def _A(phi):
    """The rotation matrix A(phi) and its derivative A'(phi), each (2, 2)."""
    c, s = np.cos(phi), np.sin(phi)
    return np.array([[c, -s], [s, c]]), np.array([[-s, -c], [c, -s]])


def line_distance(line, qx, cmap):
    """A sliding joint's distance s = u . d, u = A(phi_L) u0,
    d = r_P + A(phi_P) s_P - r_L - A(phi_L) s_L, with its gradient (6,) and
    Hessian (6, 6) over (x_L, y_L, phi_L, x_P, y_P, phi_P), by A'' = -A."""
    q = qx[line_columns(line, cmap)]
    _, sL, _, sP, u0 = line
    sL, sP, u0 = (np.asarray(x, float) for x in (sL, sP, u0))
    AL, dAL = _A(q[2])
    AP, dAP = _A(q[5])
    u, du = AL @ u0, dAL @ u0
    d = q[3:5] + AP @ sP - q[0:2] - AL @ sL
    s = float(u @ d)
    grad = np.concatenate([-u, [du @ d - u @ (dAL @ sL)], u, [u @ (dAP @ sP)]])
    H = np.zeros((6, 6))
    H[2, 0:2], H[2, 3:5] = -du, du
    H[2, 2] = -s - 2.0 * du @ (dAL @ sL) + u @ (AL @ sL)
    H[2, 5] = du @ (dAP @ sP)
    H[5, 5] = -u @ (AP @ sP)
    H[0:2, 2], H[3:5, 2], H[5, 2] = H[2, 0:2], H[2, 3:5], H[2, 5]
    return s, grad, H
