"""Spatial joints and the spatial bodies' frames as dot rows: Phi = U . W - c.

A spatial body is held in director coordinates (``model.spatial``): its
columns are r (3) and the body axes a_1, a_2, a_3 (3 each), and a body
vector with weights w = (alpha, s1, s2, s3) is alpha r + s1 a_1 + s2 a_2 +
s3 a_3, linear in q: a point (alpha = 1) or a direction (alpha = 0). Every
row of this family is the dot product of two such vectors, each the sum of
up to two bodies' vectors and a constant (the ground's part),

    Phi = U(q) . W(q) - c,   U = U0 + sum_slots (alpha r + S a),   W likewise,

so that its gradient is U_q^T W + W_q^T U and its Hessian U_q^T W_q +
W_q^T U_q is constant: the frame rows a_k . a_l - delta_kl (``Frame``) and
the spherical joint's p2 - p1 = 0 (U = p2 - p1, W = e_c) are of this form,
as are the other joints of Haug's library (Computer-Aided Kinematics and
Dynamics of Mechanical Systems, 1989, sec. 9.4: the dot-1 and dot-2
constraints, the spherical and distance constraints).

Drivers of a body's x, y or z and of a sliding joint's distance are dot rows
whose c is a function of time f(t): Phi = U . W - f(t), U the body's centre
of mass or the sliding point's offset p1 - p2, W a world axis or the line's
unit direction turning with its body, so that Phi_t = -f'(t), Phi_tt =
-f''(t) and Phi_qt = 0 (Haug 1989, sec. 11.4: driving constraints).

Fields: VROW (k,) the rows; VCOL (k, 4) the first column of the body of
each slot (U's two, W's two; -1: none); VW (k, 16) each slot's weights
(alpha, s1, s2, s3); VC (k, 7) U0 (3), W0 (3) and c, VFN (k, 3) the programs of a driver's f,
f', f'' (-1: none; a constant driver's value is c). A slot's column of
weight j and component c is VCOL + 3 j + c. Weights that are zero are
structural zeros: no triplet is emitted for them, so that the pattern is
fixed by the model. The nonzero weights again as a list of terms, U's then
W's, each in slot and weight order: VTN (k, 2) their counts, VTC (k, 16)
each term's column (VCOL + 3 j), VTW (k, 16) its weight. The loops over the
rows (U, W, the gradient) run over the terms: the same sums in the same
order as over the slots and their weights, without the tests of empty
slots and zero weights (Phi_q^T lambda took 3.7 instead of 2.4 us on the
spatial chain of 10 links).
"""

from __future__ import annotations

import numpy as np

from ..programs import _eval
from ..schema import (VC, VCOL, VFN, VROW, VTC, VTN, VTW, VW, _f, _i, _inline, _jit, _put,
                      _put_phiq, _rows)

#: Its fields in ``schema.MODEL_SCHEMA`` (the first gives the instances).
FIELDS = ("vrow", "vcol", "vw", "vc", "vfn", "vtn", "vtc", "vtw")
#: Newton-matrix triplets per instance (a dot row) at most: Phi_q and (Phi_q v)_q
#: three per term of U and W (eight each); its Hessian's, exactly, ``hess_triplets``.
PHIQ_TRIPLETS, HESS_TRIPLETS, G_TRIPLETS = 48, 0, 48
#: The joints and drivers whose rows it holds: kind -> the first of them among the
#: element's rows.
ELEMENT_ROWS = {"spherical": 0, "revolute": 0, "universal": 0, "cylindrical": 0,
                "point_on_line": 0, "point_on_plane": 0, "distance": 0, "fixed": 0,
                "prismatic": 0, "frame": 0, "coordinate": 0, "joint_distance": 0}
#: The model space whose joints it holds (``assembly.packing``: the planar families hold
#: a planar model's revolute, distance and point_on_line joints, this one a spatial model's).
SPACE = 3
#: A frame's rows: the director pairs (k, l), k <= l, of a_k . a_l = delta_kl.
FRAME_PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2))


def _side(tables, terms):
    """One side of a dot row: (slot columns [2], weights (8,), constant (3,))
    of the sum of ``terms`` (body, alpha, s (3,), sign): a body's point
    (alpha 1) or direction (alpha 0) s in its frame, or the ground's, whose
    world components go to the constant."""
    cols, weights, const, k = [-1, -1], np.zeros(8), np.zeros(3), 0
    for body, alpha, local, sign in terms:
        local = np.asarray(local, float)
        if body < 0:
            const += sign * local
            continue
        cols[k] = tables.cmap.spatial[body]
        weights[4 * k:4 * k + 4] = sign * np.r_[alpha, local]
        k += 1
    return cols, weights, const


def _perpendiculars(axis):
    """Two unit vectors (3,) perpendicular to ``axis`` and to each other: f
    across the world axis least aligned with it, g = axis x f."""
    a = np.asarray(axis, float)
    f = np.cross(np.eye(3)[int(np.argmin(np.abs(a)))], a)
    f /= np.linalg.norm(f)
    return f, np.cross(a, f)


def _rows_of(e, point, direction):
    """The dot rows (U terms, W terms, c) of a spatial joint or frame, in its
    row order (Haug 1989, sec. 9.4: the spherical, dot-1 and dot-2
    constraints)."""
    if e.kind == "coordinate":               # the centre of mass's x, y or z
        return [([(e.body, 1.0, np.zeros(3), 1.0)], [(-1, 0.0, np.eye(3)[e.coord], 1.0)], 0.0)]
    if e.kind == "joint_distance":           # u . (p1 - p2), u the line's (the second body's)
        j = e.joint
        b2, u = j.axes[-1]
        return [([point(j.first, 1.0), point(j.second, -1.0)], [direction(b2, u)], 0.0)]
    if e.kind == "frame":
        return [([(e.body, 0.0, np.eye(3)[a], 1.0)], [(e.body, 0.0, np.eye(3)[b], 1.0)],
                 1.0 if a == b else 0.0) for a, b in FRAME_PAIRS]
    d = [point(e.second, 1.0), point(e.first, -1.0)]                  # p2 - p1
    sphere = [(d, [(-1, 0.0, np.eye(3)[c], 1.0)], 0.0) for c in range(3)]
    if e.kind == "spherical":
        return sphere
    b1, b2 = e.first.body, e.second.body
    # the bodies' axes held parallel, x to x, y to y, z to z: x1 . y2 = y1 . z2 = z1 . x2 = 0
    # (with the frames orthonormal, the small relative rotation's three components)
    aligned = [([direction(b1, np.eye(3)[a])], [direction(b2, np.eye(3)[(a + 1) % 3])], 0.0)
               for a in range(3)]
    if e.kind == "fixed":
        return sphere + aligned
    if e.kind == "prismatic":                    # aligned, and p1 on the line through p2
        (_, a2), = e.axes
        f2, g2 = _perpendiculars(a2)
        return aligned + [([direction(b2, f2)], d, 0.0), ([direction(b2, g2)], d, 0.0)]
    if e.kind == "distance":            # (d . d - L^2) / (2 L): a length; its multiplier N
        L = e.length
        return [([(b, al, s, sg / (2.0 * L)) for b, al, s, sg in d], d, L / 2.0)]
    if e.kind in ("revolute", "universal", "cylindrical"):
        (b1, a1), (b2, a2) = e.axes
        f2, g2 = _perpendiculars(a2)
        across = [[direction(b1, a1)], [direction(b2, f2)]], [[direction(b1, a1)],
                                                             [direction(b2, g2)]]
        if e.kind == "universal":
            return sphere + [([direction(b1, a1)], [direction(b2, a2)], 0.0)]
        parallel = [(u, w, 0.0) for u, w in across]
        if e.kind == "revolute":
            return sphere + parallel
        return parallel + [([direction(b2, f2)], d, 0.0), ([direction(b2, g2)], d, 0.0)]
    (b2, a2), = e.axes
    if e.kind == "point_on_plane":
        return [([direction(b2, a2)], d, 0.0)]
    f2, g2 = _perpendiculars(a2)           # point_on_line
    return [([direction(b2, f2)], d, 0.0), ([direction(b2, g2)], d, 0.0)]


def pack(items, tables) -> dict:
    """Its fields from the model's spatial joints and frames.

    Parameters
    ----------
    items : list of (int, Joint or Frame)
        Per element, its first row of lambda and the element, in the model's
        order.
    tables : packing context
        ``cmap.spatial``: each spatial body's first column.

    Returns
    -------
    dict
        field name -> array, as ``schema.MODEL_SCHEMA`` declares them.
    """
    def point(ref, sign):
        """The term (body, alpha, s, sign) of a point: sign (r + A s)."""
        return (ref.body, 1.0, ref.local, sign)

    def direction(body, axis):
        """The term of a direction A s of a body's frame."""
        return (body, 0.0, axis, 1.0)

    rows, cols, weights, consts, fns, counts, tcols, tweights = [], [], [], [], [], [], [], []
    for row, e in items:
        f = getattr(e, "function", None)               # a driver's f(t)
        constant = f is not None and f.constant
        for k, (U, W, c) in enumerate(_rows_of(e, point, direction)):
            cu, wu, u0 = _side(tables, U)
            cw, ww, w0 = _side(tables, W)
            rows.append(row + k)
            cols.append(cu + cw)
            weights.append(np.r_[wu, ww])
            consts.append(np.r_[u0, w0, c + (f.f(0.0) if constant else 0.0)])
            fns.append(tables.programs(f) if f is not None else (-1, -1, -1))
            n_terms, tc, tw = _terms(cu + cw, np.r_[wu, ww])
            counts.append(n_terms)
            tcols.append(tc)
            tweights.append(tw)
    return {"vrow": np.array(rows, np.int64), "vcol": np.array(cols, np.int64).reshape(-1, 4),
            "vw": np.array(weights, np.float64).reshape(-1, 16),
            "vc": np.array(consts, np.float64).reshape(-1, 7),
            "vfn": np.array(fns, np.int64).reshape(-1, 3),
            "vtn": np.array(counts, np.int64).reshape(-1, 2),
            "vtc": np.array(tcols, np.int64).reshape(-1, 16),
            "vtw": np.array(tweights, np.float64).reshape(-1, 16)}


def _terms(cols, weights):
    """A dot row's nonzero weights as terms: ((U's count, W's count), each
    term's column (16,), its weight (16,)), U's then W's, each in slot and
    weight order (the order the loops over slots and weights take); from the
    slots' first columns ``cols`` (4,) (-1: none) and their weights (16,)."""
    counts, tc, tw = [0, 0], np.zeros(16, np.int64), np.zeros(16)
    t = 0
    for s in range(4):
        if cols[s] < 0:
            continue
        for j in range(4):
            if weights[4 * s + j] != 0.0:
                tc[t], tw[t] = cols[s] + 3 * j, weights[4 * s + j]
                counts[s // 2] += 1
                t += 1
    return counts, tc, tw


def hess_triplets(I) -> int:
    """An upper bound of the triplets of the family's Hessian
    (:func:`emit_hess`: 2 x 3 per pair of a weight of U and one of W), from
    the packed integers ``I`` alone: every weight of a slot with a body
    counted (4 per slot), zero or not."""
    out = 0
    rows = int(I[3 * VROW + 1])
    o = int(I[3 * VCOL])
    for i in range(rows):
        nu = sum(4 for s in (0, 1) if I[o + 4 * i + s] >= 0)
        nw = sum(4 for s in (2, 3) if I[o + 4 * i + s] >= 0)
        out += 6 * nu * nw
    return out


@_inline
def _vector(I, Fl, qx, i, first, out):
    """U (first = 0) or W (first = 2) of dot row i at qx into out (3,)."""
    for c in range(3):
        out[c] = _f(I, Fl, VC, i, 3 * (first // 2) + c)
    nu = _i(I, VTN, i, 0)
    t0, t1 = (0, nu) if first == 0 else (nu, nu + _i(I, VTN, i, 1))
    for t in range(t0, t1):
        w, col = _f(I, Fl, VTW, i, t), _i(I, VTC, i, t)
        for c in range(3):
            out[c] += w * qx[col + c]


@_inline
def phi(I, Fl, t, qx, out):
    """Phi into out (m,) [m, or 1 for the frame rows]."""
    if _rows(I, VROW) == 0:
        return
    U, W = np.empty(3), np.empty(3)
    for i in range(_rows(I, VROW)):
        _vector(I, Fl, qx, i, 0, U)
        _vector(I, Fl, qx, i, 2, W)
        c = _f(I, Fl, VC, i, 6)
        if _i(I, VFN, i, 0) >= 0:                     # a driver's f(t)
            c += _eval(I, Fl, _i(I, VFN, i, 0), t)
        out[_i(I, VROW, i, 0)] = U[0] * W[0] + U[1] * W[1] + U[2] * W[2] - c


@_inline
def phi_time_add(I, Fl, t, out, order):
    """out (m,) += -f'(t) (order 1) or -f''(t) (order 2) of the drivers' rows."""
    for i in range(_rows(I, VROW)):
        prog = _i(I, VFN, i, order)
        if prog >= 0:
            out[_i(I, VROW, i, 0)] -= _eval(I, Fl, prog, t)


@_inline
def _gradient(I, Fl, qx, i, U, W, cols, vals):
    """The entries of dot row i's gradient, U_q^T W + W_q^T U, into cols,
    vals (48,) (a column may repeat: the entries add); returns their count."""
    _vector(I, Fl, qx, i, 0, U)
    _vector(I, Fl, qx, i, 2, W)
    p = 0
    nu = _i(I, VTN, i, 0)
    for t in range(nu + _i(I, VTN, i, 1)):
        w, col = _f(I, Fl, VTW, i, t), _i(I, VTC, i, t)
        other = W if t < nu else U
        for c in range(3):
            cols[p] = col + c
            vals[p] = w * other[c]
            p += 1
    return p


@_inline
def phiqT_add(I, Fl, qx, lam, coef, out):
    """out (n+3,) += coef Phi_q^T lambda."""
    if _rows(I, VROW) == 0:
        return
    U, W = np.empty(3), np.empty(3)
    cols, vals = np.empty(48, np.int64), np.empty(48)
    for i in range(_rows(I, VROW)):
        k = _gradient(I, Fl, qx, i, U, W, cols, vals)
        lv = coef * lam[_i(I, VROW, i, 0)]
        for e in range(k):
            out[cols[e]] += lv * vals[e]


@_inline
def phiq_times(I, Fl, qx, vx, out):
    """Phi_q v into out (m,)."""
    if _rows(I, VROW) == 0:
        return
    U, W = np.empty(3), np.empty(3)
    cols, vals = np.empty(48, np.int64), np.empty(48)
    for i in range(_rows(I, VROW)):
        k = _gradient(I, Fl, qx, i, U, W, cols, vals)
        acc = 0.0
        for e in range(k):
            acc += vals[e] * vx[cols[e]]
        out[_i(I, VROW, i, 0)] = acc


@_inline
def products(I, Fl, qx, vx, lam, mu, out_l, out_mu, out_v):
    """The three products of the stabilized index-2 residual at one gradient
    per row: out_l (n+3,) += Phi_q^T lambda, out_mu (n+3,) += Phi_q^T mu,
    out_v (m,) = Phi_q v; each the sum :func:`phiqT_add` (coef 1) and
    :func:`phiq_times` make, in their order (the same numbers)."""
    if _rows(I, VROW) == 0:
        return
    U, W = np.empty(3), np.empty(3)
    cols, vals = np.empty(48, np.int64), np.empty(48)
    for i in range(_rows(I, VROW)):
        k = _gradient(I, Fl, qx, i, U, W, cols, vals)
        row = _i(I, VROW, i, 0)
        lv, mv, acc = 1.0 * lam[row], 1.0 * mu[row], 0.0
        for e in range(k):
            out_l[cols[e]] += lv * vals[e]
            out_mu[cols[e]] += mv * vals[e]
            acc += vals[e] * vx[cols[e]]
        out_v[row] = acc


@_inline
def emit_phiq(I, Fl, n, qx, R, C, V, p, r0, c0, coef, transpose):
    """coef Phi_q at (r0, c0), or coef Phi_q^T when transpose; returns p."""
    if _rows(I, VROW) == 0:
        return p
    U, W = np.empty(3), np.empty(3)
    cols, vals = np.empty(48, np.int64), np.empty(48)
    for i in range(_rows(I, VROW)):
        k = _gradient(I, Fl, qx, i, U, W, cols, vals)
        row = _i(I, VROW, i, 0)
        for e in range(k):
            p = _put_phiq(R, C, V, p, r0, c0, row, cols[e], coef * vals[e], transpose)
    return p


@_inline
def emit_hess(I, Fl, n, qx, lam, R, C, V, p, r0, c0, coef):
    """coef (Phi_q^T lambda)_q at (r0, c0): lambda (U_q^T W_q + W_q^T U_q),
    constant in q; returns p."""
    if _rows(I, VROW) == 0:
        return p
    for i in range(_rows(I, VROW)):
        lv = coef * lam[_i(I, VROW, i, 0)]
        for su in range(2):
            bu = _i(I, VCOL, i, su)
            if bu < 0:
                continue
            for sw in range(2, 4):
                bw = _i(I, VCOL, i, sw)
                if bw < 0:
                    continue
                for ju in range(4):
                    wu = _f(I, Fl, VW, i, 4 * su + ju)
                    if wu == 0.0:
                        continue
                    for jw in range(4):
                        ww = _f(I, Fl, VW, i, 4 * sw + jw)
                        if ww == 0.0:
                            continue
                        for c in range(3):
                            a, b = bu + 3 * ju + c, bw + 3 * jw + c
                            p = _put(R, C, V, p, r0 + a, c0 + b, lv * wu * ww)
                            p = _put(R, C, V, p, r0 + b, c0 + a, lv * wu * ww)
    return p


@_inline
def emit_G(I, Fl, n, qx, vx, R, C, V, p, r0, c0, coef):
    """coef (Phi_q v)_q at (r0, c0): the gradient of U . W with U, W
    replaced by U_q v, W_q v (the Hessian times v); returns p."""
    if _rows(I, VROW) == 0:
        return p
    U, W = np.empty(3), np.empty(3)
    for i in range(_rows(I, VROW)):
        # U_q v and W_q v are U and W of the velocities without the constants
        for c in range(3):
            U[c] = 0.0
            W[c] = 0.0
        nu = _i(I, VTN, i, 0)
        k = nu + _i(I, VTN, i, 1)
        for t in range(k):
            w, col = _f(I, Fl, VTW, i, t), _i(I, VTC, i, t)
            for c in range(3):
                if t < nu:
                    U[c] += w * vx[col + c]
                else:
                    W[c] += w * vx[col + c]
        row = _i(I, VROW, i, 0)
        for t in range(k):
            w, col = _f(I, Fl, VTW, i, t), _i(I, VTC, i, t)
            other = W if t < nu else U
            for c in range(3):
                p = _put(R, C, V, p, r0 + row, c0 + col + c, coef * w * other[c])
    return p
