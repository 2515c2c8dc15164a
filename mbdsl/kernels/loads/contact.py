"""Contacts and joint limits: one-sided gaps g(q) and the Hunt-Crossley law.

One instance per gap (``Contact.gaps`` of the model's contacts and limits,
in its order). KGI: (kind, line row in GEO or -1); KCOL: the columns it reads
(``model.contact.gap_columns``: a planar gap's six, x, y, phi of the first
body, then of the second; a spatial gap's 24, its two bodies' twelve); KPAR:
(offset, sign, s1 (2), s2 (2), n0 (2), r, K, n, chi, mu, v_reg, c); KIMP: the
impact speed of each closed gap (0 while open), the contact's state, written
by the time loop at its events. A spatial gap's KBODY: its two bodies' first
columns (-1: the ground); KGEO: a dot gap's weights and constants (U on body
A (4), on body B (4), U's constant (3), then W's likewise), an angle's
reference vectors f_1, g_1, f_2 (``joints.spatial_angles``). A spatial gap's
local column 12 b + 3 j + c is component c of body b's weight j (r, a_1,
a_2, a_3).
The geometries and the law are those of ``model.contact`` (its module notes):
line  g = n . (p_P - p_L) - r            (``_line`` with the normal as direction)
slide g = sign (s - bound)                (``_line``)
angle g = sign (phi_2 - phi_1 - bound)
circle g = (R - r) - |p_P - p_C|
dot    g = sign (U . W - offset)        (spatial: ``_dot_gap``)
spatial_angle g = sign (theta - bound)   (spatial: ``_angle_gap``)
f = K delta^n (1 + chi ddelta/dt / v_impact) + f_c >= 0, delta = -g,
Q = f grad g; f_c = c ddelta/dt limited to +-K delta^n, a rope's linear damping
(Modelica's ElastoGap: no jump where the rope goes taut at speed, and the
damping never makes it push); a rope is a circle of radius L, r = 0
plus, with mu > 0, the regularised Coulomb force -mu f tanh(v_t / v_reg) w.
"""

from __future__ import annotations

import math

import numpy as np

from mbdsl.model.contact import GAP_WIDTH, SPEED_FLOOR as _CONTACT_SPEED_FLOOR, gap_columns

from ..geometry import _direction, _direction_derivative, _line
from ..joints import spatial_angles
from ..schema import KBODY, KCOL, KGEO, KGI, KIMP, KPAR, _f, _i, _inline, _jit, _put, _rows

#: Its fields in ``schema.MODEL_SCHEMA`` (the first gives the instances).
FIELDS = ("kgi", "kcol", "kpar", "kimp", "kbody", "kgeo")
#: Newton-matrix triplets per instance of a force block, counted per gap by ``triplets``
#: (a planar gap's 6 x 6 block, a spatial gap's 24 x 24).
FORCE_TRIPLETS = 0
#: The columns a gap reads at most (``model.contact.GAP_WIDTH``, as a literal).
WIDTH = 24
if WIDTH != GAP_WIDTH:     # pragma: no cover (a developer's error)
    raise ImportError("contact.WIDTH differs from model.contact.GAP_WIDTH")
#: ``model.contact.SPEED_FLOOR`` as a literal (checked at import, as the recipe indices are)
SPEED_FLOOR = 1e-3
if SPEED_FLOOR != _CONTACT_SPEED_FLOOR:     # pragma: no cover (a developer's error)
    raise ImportError("compiled.SPEED_FLOOR differs from model.contact.SPEED_FLOOR")
#: gap kinds (KGI's first column), as ``pack`` writes them
GAP_LINE, GAP_SLIDE, GAP_ANGLE, GAP_CIRCLE, GAP_DOT, GAP_SPATIAL_ANGLE = 0, 1, 2, 3, 4, 5
#: The loads it holds (``model.contact.Contact.kind``: contacts and joint limits).
LOADS = ("contact", "limit", "rope", "cable")


def pack(items, tables) -> dict:
    """Its fields from the model's contacts and limits: one instance per
    gap (``Contact.gaps``), in the model's order.

    Parameters
    ----------
    items : list of Contact
        The model's contacts and limits, in its order.
    tables : packing context
        ``line_row`` and ``cmap`` (``assembly.packing.PackingContext``).

    Returns
    -------
    dict
        KGI (kind, line row), KCOL the six columns, KPAR (offset, sign, s1,
        s2, n0, r, K, n, chi, mu, v_reg, c), KIMP the impact speeds in force
        (zeros: every gap open; the time loop writes them, from
        ``assembly.contact.ContactState``).
    """
    kgi, kcol, kpar, kbody, kgeo = [], [], [], [], []
    for c in items:
        law = (c.k, c.exponent, c.damping, c.mu, c.v_reg, c.viscous)
        for geometry, data, _ in c.gaps:
            s1 = s2 = n0 = (0.0, 0.0)
            r, row, bodies, geo = 0.0, -1, (-1, -1), np.zeros(22)
            if geometry == "dot":           # (body A, body B, wU, U0, wW, W0, offset, sign)
                kind, off, sign = GAP_DOT, data[6], data[7]
                geo = np.r_[data[2], data[3], data[4], data[5]]
            elif geometry == "spatial_angle":   # (body 1, body 2, axis 1, axis 2, bound, sign)
                kind, off, sign = GAP_SPATIAL_ANGLE, data[4], data[5]
                geo[:9] = spatial_angles.reference_vectors(data[2], data[3])
            elif geometry == "line":          # (body L, s_L, body P, s_P, n0, r)
                kind, row, off, sign = GAP_LINE, tables.line_row(tuple(data[:5])), data[5], 1.0
                s1, s2, n0, r = data[1], data[3], data[4], data[5]
            elif geometry == "slide":       # (body L, s_L, body P, s_P, u0, bound, sign)
                kind, row, off, sign = GAP_SLIDE, tables.line_row(tuple(data[:5])), data[5], data[6]
            elif geometry == "angle":       # (body 1, None, body 2, None, bound, sign)
                kind, off, sign = GAP_ANGLE, data[4], data[5]
            elif geometry == "circle":      # (body C, s_C, body P, s_P, clearance, r)
                kind, off, sign = GAP_CIRCLE, data[4], 1.0
                s1, s2, r = data[1], data[3], data[5]
            else:                           # pragma: no cover (model.contact lists four)
                raise ValueError(f"no kernel for the gap geometry {geometry!r}")
            if kind >= GAP_DOT:
                bodies = tuple(tables.cmap.spatial.get(b, -1) for b in data[:2])
            kgi.append((kind, row))
            kcol.append(gap_columns(geometry, data, tables.cmap))
            kpar.append((off, sign, *s1, *s2, *n0, r, *law))
            kbody.append(bodies)
            kgeo.append(geo)
    return {"kgi": np.array(kgi, np.int64).reshape(-1, 2),
            "kcol": np.array(kcol, np.int64).reshape(-1, WIDTH),
            "kpar": np.array(kpar, np.float64).reshape(-1, 15),
            "kimp": np.zeros(len(kgi)),
            "kbody": np.array(kbody, np.int64).reshape(-1, 2),
            "kgeo": np.array(kgeo, np.float64).reshape(-1, 22)}


def pattern(items, tables) -> tuple:
    """(the columns of each gap, (k, WIDTH): ``model.contact.gap_columns``,
    the ground's and the padding n + 2; whether any gap is damped or has
    friction)."""
    cols = [gap_columns(geometry, data, tables.cmap) for c in items for geometry, data, _ in c.gaps]
    damped = any(c.damping > 0.0 or c.mu > 0.0 or c.viscous > 0.0 for c in items)
    return np.array(cols, np.int64).reshape(-1, WIDTH), damped


def triplets(I) -> int:
    """The Newton-matrix triplets of a force block of the packed model's gaps
    (``kernels.system.triplet_bound``): 36 per planar gap, 576 per spatial."""
    k, off = int(I[3 * KGI + 1]), int(I[3 * KGI])
    kinds = I[off:off + 2 * k:2]
    return int(sum(36 if kind < GAP_DOT else WIDTH * WIDTH for kind in kinds))


@_inline
def width(I, i):
    """The columns gap i reads: 6 (planar), WIDTH (spatial)."""
    return 6 if _i(I, KGI, i, 0) < GAP_DOT else WIDTH


@_jit
def _dot_gap(I, Fl, qx, i, grad, H):
    """g = sign (U . W - offset) of spatial gap i (module notes), its gradient
    into grad (WIDTH,) and its constant Hessian into H (WIDTH, WIDTH) over the
    local columns: grad = sign (U_q^T W + W_q^T U), H = sign (U_q^T W_q +
    W_q^T U_q) (Haug 1989, sec. 9.4)."""
    U, W = np.empty(3), np.empty(3)
    for c in range(3):
        U[c] = _f(I, Fl, KGEO, i, 8 + c)
        W[c] = _f(I, Fl, KGEO, i, 19 + c)
    for a in range(8):                     # body a // 4, weight a % 4
        wu, ww = _f(I, Fl, KGEO, i, a), _f(I, Fl, KGEO, i, 11 + a)
        if wu == 0.0 and ww == 0.0:
            continue
        base = 12 * (a // 4) + 3 * (a % 4)
        for c in range(3):
            x = qx[_i(I, KCOL, i, base + c)]
            U[c] += wu * x
            W[c] += ww * x
    sgn = _f(I, Fl, KPAR, i, 1)
    H[:, :] = 0.0
    for a in range(8):
        wua, wwa = _f(I, Fl, KGEO, i, a), _f(I, Fl, KGEO, i, 11 + a)
        ba = 12 * (a // 4) + 3 * (a % 4)
        for c in range(3):
            grad[ba + c] = sgn * (wua * W[c] + wwa * U[c])
        for b in range(8):
            h = sgn * (wua * _f(I, Fl, KGEO, i, 11 + b) + wwa * _f(I, Fl, KGEO, i, b))
            if h != 0.0:
                bb = 12 * (b // 4) + 3 * (b % 4)
                for c in range(3):
                    H[ba + c, bb + c] = h
    return sgn * (U[0] * W[0] + U[1] * W[1] + U[2] * W[2] - _f(I, Fl, KPAR, i, 0))


@_inline
def _angle_column(k):
    """The local column of director entry k (0..17) of ``joints.spatial_angles``:
    body A's a_1..a_3 (3..11), then body B's (15..23)."""
    return 3 + k if k < 9 else k + 6


@_jit
def _angle_gap(I, Fl, qx, i, grad, H):
    """g = sign (theta - bound) of spatial gap i, a revolute's angle
    (``joints.spatial_angles``), its gradient into grad (WIDTH,) and Hessian
    into H (WIDTH, WIDTH) over the local columns."""
    sq, cq, g18, h18 = np.empty(18), np.empty(18), np.empty(18), np.empty((18, 18))
    th, s, c = spatial_angles.angle(I, Fl, KBODY, KGEO, i, qx, sq, cq)
    spatial_angles.gradient(s, c, sq, cq, g18)
    spatial_angles.hessian(I, Fl, KGEO, i, s, c, sq, cq, h18)
    sgn = _f(I, Fl, KPAR, i, 1)
    grad[:] = 0.0
    H[:, :] = 0.0
    for k in range(18):
        a = _angle_column(k)
        grad[a] = sgn * g18[k]
        for l in range(18):
            H[a, _angle_column(l)] = sgn * h18[k, l]
    return sgn * (th - _f(I, Fl, KPAR, i, 0))


@_jit
def _gap(I, Fl, qx, i, grad, H):
    """g of gap i [m or rad], dg/dq into grad (WIDTH,) and d^2 g/dq^2 into H
    (WIDTH, WIDTH) over its KCOL columns (the geometries of ``model.contact``;
    a planar gap's first six)."""
    kind = _i(I, KGI, i, 0)
    if kind == GAP_DOT:
        return _dot_gap(I, Fl, qx, i, grad, H)
    if kind == GAP_SPATIAL_ANGLE:
        return _angle_gap(I, Fl, qx, i, grad, H)
    off, sgn = _f(I, Fl, KPAR, i, 0), _f(I, Fl, KPAR, i, 1)
    if kind == GAP_LINE or kind == GAP_SLIDE:
        s = _line(I, Fl, qx, _i(I, KGI, i, 1), grad, H)
        if sgn != 1.0:
            for a in range(6):
                grad[a] *= sgn
                for b in range(6):
                    H[a, b] *= sgn
        return sgn * (s - off)
    H[:, :] = 0.0
    grad[:] = 0.0
    if kind == GAP_ANGLE:
        grad[2], grad[5] = -sgn, sgn
        return sgn * (qx[_i(I, KCOL, i, 5)] - qx[_i(I, KCOL, i, 2)] - off)
    # circle: g = c - |d|, d = p_P - p_C
    phC, phP = qx[_i(I, KCOL, i, 2)], qx[_i(I, KCOL, i, 5)]
    cC, sC, cP, sP = math.cos(phC), math.sin(phC), math.cos(phP), math.sin(phP)
    s1x, s1y, s2x, s2y = (_f(I, Fl, KPAR, i, 2), _f(I, Fl, KPAR, i, 3), _f(I, Fl, KPAR, i, 4),
                          _f(I, Fl, KPAR, i, 5))
    aCx, aCy = cC * s1x - sC * s1y, sC * s1x + cC * s1y
    aPx, aPy = cP * s2x - sP * s2y, sP * s2x + cP * s2y
    dx = qx[_i(I, KCOL, i, 3)] + aPx - qx[_i(I, KCOL, i, 0)] - aCx
    dy = qx[_i(I, KCOL, i, 4)] + aPy - qx[_i(I, KCOL, i, 1)] - aCy
    l = math.sqrt(dx * dx + dy * dy)
    if l == 0.0:                   # centred: open by the clearance, no normal
        return off
    ex, ey = _direction(dx, dy, l)
    D = np.zeros((2, 6))           # dd/dq
    D[0, 0], D[1, 1], D[0, 3], D[1, 4] = -1.0, -1.0, 1.0, 1.0
    D[0, 2], D[1, 2] = aCy, -aCx   # -B(phi_C) s_C
    D[0, 5], D[1, 5] = -aPy, aPx   # B(phi_P) s_P
    P00, P01, P11 = _direction_derivative(ex, ey, l)
    for a in range(6):
        grad[a] = -(ex * D[0, a] + ey * D[1, a])
        pa0 = P00 * D[0, a] + P01 * D[1, a]
        pa1 = P01 * D[0, a] + P11 * D[1, a]
        for b in range(6):
            H[a, b] = -(pa0 * D[0, b] + pa1 * D[1, b])
    H[2, 2] -= ex * aCx + ey * aCy
    H[5, 5] += ex * aPx + ey * aPy
    return off - l


@_jit
def _slip(I, Fl, qx, i, w, dw):
    """The slip direction w (6,) of gap i's contact, v_t = w . v, and dw/dq
    into dw (6, 6) (a line or a hole; ``model.contact``'s notes)."""
    c = np.empty(6, np.int64)
    for a in range(6):
        c[a] = _i(I, KCOL, i, a)
    w[:] = 0.0
    dw[:, :] = 0.0
    r = _f(I, Fl, KPAR, i, 8)
    ph1, ph2 = qx[c[2]], qx[c[5]]
    c1, s1, c2, s2 = math.cos(ph1), math.sin(ph1), math.cos(ph2), math.sin(ph2)
    a2x = c2 * _f(I, Fl, KPAR, i, 4) - s2 * _f(I, Fl, KPAR, i, 5)
    a2y = s2 * _f(I, Fl, KPAR, i, 4) + c2 * _f(I, Fl, KPAR, i, 5)
    B2x, B2y = -a2y, a2x
    dnu = np.zeros((2, 6))
    if _i(I, KGI, i, 0) == GAP_LINE:
        n0x, n0y = _f(I, Fl, KPAR, i, 6), _f(I, Fl, KPAR, i, 7)
        nux, nuy = c1 * n0x - s1 * n0y, s1 * n0x + c1 * n0y
        dnu[0, 2], dnu[1, 2] = -nuy, nux
    else:
        a1x = c1 * _f(I, Fl, KPAR, i, 2) - s1 * _f(I, Fl, KPAR, i, 3)
        a1y = s1 * _f(I, Fl, KPAR, i, 2) + c1 * _f(I, Fl, KPAR, i, 3)
        dx = qx[c[3]] + a2x - qx[c[0]] - a1x
        dy = qx[c[4]] + a2y - qx[c[1]] - a1y
        l = math.sqrt(dx * dx + dy * dy)
        if l == 0.0:
            return
        ex, ey = _direction(dx, dy, l)
        D = np.zeros((2, 6))
        D[0, 0], D[1, 1], D[0, 3], D[1, 4] = -1.0, -1.0, 1.0, 1.0
        D[0, 2], D[1, 2] = a1y, -a1x
        D[0, 5], D[1, 5] = B2x, B2y
        nux, nuy = -ex, -ey
        P00, P01, P11 = _direction_derivative(ex, ey, l)
        for b in range(6):
            dnu[0, b] = -(P00 * D[0, b] + P01 * D[1, b])
            dnu[1, b] = -(P01 * D[0, b] + P11 * D[1, b])
    taux, tauy = -nuy, nux
    # c - r_1 = q_2 + A_2 s_P - r nu - q_1
    cx = qx[c[3]] + a2x - r * nux - qx[c[0]]
    cy = qx[c[4]] + a2y - r * nuy - qx[c[1]]
    w[0], w[1], w[3], w[4] = -taux, -tauy, taux, tauy
    w[2] = -(nux * cx + nuy * cy)
    w[5] = nux * a2x + nuy * a2y - r
    for b in range(6):
        dtx, dty = -dnu[1, b], dnu[0, b]        # dtau = J dnu
        dcx, dcy = -r * dnu[0, b], -r * dnu[1, b]
        if b == 0:
            dcx -= 1.0
        elif b == 1:
            dcy -= 1.0
        elif b == 3:
            dcx += 1.0
        elif b == 4:
            dcy += 1.0
        elif b == 5:
            dcx += B2x
            dcy += B2y
        dw[0, b], dw[1, b], dw[3, b], dw[4, b] = -dtx, -dty, dtx, dty
        dw[2, b] = -(dnu[0, b] * cx + dnu[1, b] * cy + dcx * nux + dcy * nuy)
        dw[5, b] = dnu[0, b] * a2x + dnu[1, b] * a2y
    dw[5, 5] += nux * B2x + nuy * B2y


@_jit
def _contact_friction(I, Fl, qx, vx, i, f, w, dw):
    """Friction at gap i's contact under normal force f: its slip direction
    and dw/dq into w, dw (``_slip``); returns (F_t, v_t, T) with v_t = w . v,
    T = tanh(v_t / v_reg), F_t = -mu f T."""
    _slip(I, Fl, qx, i, w, dw)
    vt = 0.0
    for a in range(6):
        vt += w[a] * vx[_i(I, KCOL, i, a)]
    T = math.tanh(vt / _f(I, Fl, KPAR, i, 13))
    return -_f(I, Fl, KPAR, i, 12) * f * T, vt, T


@_jit
def _contact_law(I, Fl, qx, vx, i, imp, grad, H):
    """Gap i's normal force under the Hunt-Crossley law (module notes of
    ``assembly.contact``) at impact speed ``imp`` (0: not armed), with grad,
    H of ``_gap``: returns (g, delta, ddelta/dt, f, K delta^n, v_impact,
    armed); f = 0 where the gap is open or the force is cut."""
    g = _gap(I, Fl, qx, i, grad, H)
    if g >= 0.0:
        return g, 0.0, 0.0, 0.0, 0.0, 0.0, False
    delta = -g
    ddelta = 0.0
    for a in range(width(I, i)):
        ddelta -= grad[a] * vx[_i(I, KCOL, i, a)]
    elastic = _f(I, Fl, KPAR, i, 9) * delta ** _f(I, Fl, KPAR, i, 10)
    # not armed yet (a trial step into a contact its event has not closed): the
    # approach speed now stands for the impact speed
    speed = imp if imp > 0.0 else max(ddelta, SPEED_FLOOR)
    armed = imp > 0.0 or ddelta <= SPEED_FLOOR
    f = elastic * (1.0 + _f(I, Fl, KPAR, i, 11) * ddelta / speed)
    if _f(I, Fl, KPAR, i, 14) > 0.0:           # a rope's c ddelta/dt, within +-K delta^n
        f += min(max(_f(I, Fl, KPAR, i, 14) * ddelta, -elastic), elastic)
    return g, delta, ddelta, max(f, 0.0), elastic, speed, armed


@_jit
def _contacts_add(I, Fl, qx, vx, out):
    """The contacts' generalized forces f grad g (+ F_t w with friction) added
    to out (n+3,) [N, N m]."""
    grad, H = np.empty(WIDTH), np.empty((WIDTH, WIDTH))
    w, dw = np.empty(6), np.empty((6, 6))
    for i in range(_rows(I, KGI)):
        g, delta, ddelta, f, elastic, speed, armed = _contact_law(
            I, Fl, qx, vx, i, _f(I, Fl, KIMP, i, 0), grad, H)
        if f <= 0.0:
            continue
        for a in range(width(I, i)):
            out[_i(I, KCOL, i, a)] += f * grad[a]
        if _f(I, Fl, KPAR, i, 12) > 0.0:
            Ft, vt, T = _contact_friction(I, Fl, qx, vx, i, f, w, dw)
            for a in range(6):
                out[_i(I, KCOL, i, a)] += Ft * w[a]


@_jit
def _emit_contacts(I, Fl, n, qx, vx, R, C, V, p, r0, c0, cq, cv):
    """The contacts' -(cq Q_q + cv Q_v) at (r0, c0) (``assembly.contact``'s
    notes): all 36 entries (a spatial gap's 576) of every gap whose bodies are not the
    ground's, zeros while it is open, so that the pattern stays fixed."""
    grad, H = np.empty(WIDTH), np.empty((WIDTH, WIDTH))
    w, dw = np.empty(6), np.empty((6, 6))
    dfdq, dfdv, Hv = np.empty(WIDTH), np.empty(WIDTH), np.empty(WIDTH)
    Qq, Qv = np.empty((WIDTH, WIDTH)), np.empty((WIDTH, WIDTH))
    v = np.empty(WIDTH)
    for i in range(_rows(I, KGI)):
        g, delta, ddelta, f, elastic, speed, armed = _contact_law(
            I, Fl, qx, vx, i, _f(I, Fl, KIMP, i, 0), grad, H)
        nc = width(I, i)
        for a in range(nc):
            for b in range(nc):
                Qq[a, b] = 0.0
                Qv[a, b] = 0.0
        if f > 0.0:
            K, ex, chi = _f(I, Fl, KPAR, i, 9), _f(I, Fl, KPAR, i, 10), _f(I, Fl, KPAR, i, 11)
            for a in range(nc):
                v[a] = vx[_i(I, KCOL, i, a)]
            # df/d(delta) and the damping's df/d(ddelta); unarmed, K delta^n
            # (1 + chi) does not depend on ddelta (a rope's c ddelta/dt does,
            # where it is within +-K delta^n, and is +-K delta^n beyond)
            damp = elastic * chi / speed if armed else 0.0
            dK = ex * K * delta ** (ex - 1.0)
            df_ddelta = dK * (1.0 + chi * ddelta / speed)
            visc = _f(I, Fl, KPAR, i, 14)
            if visc > 0.0:
                if visc * ddelta > elastic:
                    df_ddelta += dK
                elif visc * ddelta < -elastic:
                    df_ddelta -= dK
                else:
                    damp += visc
            for a in range(nc):
                Hv[a] = 0.0
                for b in range(nc):
                    Hv[a] += H[a, b] * v[b]
            for a in range(nc):
                dfdq[a] = -df_ddelta * grad[a] - damp * Hv[a]
                dfdv[a] = -damp * grad[a]
            for a in range(nc):
                for b in range(nc):
                    Qq[a, b] = grad[a] * dfdq[b] + f * H[a, b]
                    Qv[a, b] = grad[a] * dfdv[b]
            mu = _f(I, Fl, KPAR, i, 12)
            if mu > 0.0:
                # Q = F_t w, F_t = -mu f T(v_t): Q_q = w dF_t/dq^T + F_t dw/dq,
                # Q_v = w dF_t/dv^T; dv_t/dq = (dw/dq)^T v, dv_t/dv = w
                Ft, vt, T = _contact_friction(I, Fl, qx, vx, i, f, w, dw)
                dT = (1.0 - T * T) / _f(I, Fl, KPAR, i, 13)
                for b in range(6):
                    dvt = 0.0
                    for a in range(6):
                        dvt += dw[a, b] * v[a]
                    dFq = -mu * (T * dfdq[b] + f * dT * dvt)
                    dFv = -mu * (T * dfdv[b] + f * dT * w[b])
                    for a in range(6):
                        Qq[a, b] += w[a] * dFq + Ft * dw[a, b]
                        Qv[a, b] += w[a] * dFv
        for a in range(nc):
            ra = _i(I, KCOL, i, a)
            if ra >= n:
                continue
            for b in range(nc):
                cb = _i(I, KCOL, i, b)
                if cb < n:
                    p = _put(R, C, V, p, r0 + ra, c0 + cb, -(cq * Qq[a, b] + cv * Qv[a, b]))
    return p


@_jit
def _contact_energy(I, Fl, i, g):
    """K delta^(n+1) / (n+1) [J] of gap i at gap g (delta = -g; 0 when open)."""
    if g >= 0.0:
        return 0.0
    ex = _f(I, Fl, KPAR, i, 10)
    return _f(I, Fl, KPAR, i, 9) * (-g) ** (ex + 1.0) / (ex + 1.0)


@_inline
def energy_add(I, Fl, qx, e):
    """e + the contacts' potential K delta^(n+1) / (n+1) [J]."""
    if _rows(I, KGI) > 0:
        grad, H = np.empty(WIDTH), np.empty((WIDTH, WIDTH))
        for i in range(_rows(I, KGI)):
            e += _contact_energy(I, Fl, i, _gap(I, Fl, qx, i, grad, H))
    return e


@_inline
def power_add(I, Fl, qx, vx, speeds, p):
    """p + the power the contacts dissipate at the impact speeds ``speeds`` (k,):
    (f - K delta^n) ddelta/dt and -F_t v_t of their friction [W]."""
    if _rows(I, KGI) > 0:
        grad, H = np.empty(WIDTH), np.empty((WIDTH, WIDTH))
        w, dw = np.empty(6), np.empty((6, 6))
        for i in range(_rows(I, KGI)):
            g, delta, ddelta, f, elastic, speed, armed = _contact_law(
                I, Fl, qx, vx, i, speeds[i], grad, H)
            if delta > 0.0:
                p += (f - elastic) * ddelta
                if _f(I, Fl, KPAR, i, 12) > 0.0 and f > 0.0:
                    Ft, vt, T = _contact_friction(I, Fl, qx, vx, i, f, w, dw)
                    p -= Ft * vt
    return p
