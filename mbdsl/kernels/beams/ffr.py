"""Flexible beams in the floating frame of reference: M(q), (M x)_q, the
quadratic velocity vector, elastic forces with geometric stiffening, gravity.

Beam b's local coordinates (x, y, phi, q_f), c = 3 + nf, are columns
bcol[k0:k0 + c] of q; its shape integrals are floats bdat[f0:] in the order
m, s0 (2), I0, S_bar (2 x nf), a_u (nf), a_I (nf), M_ff, S_tilde, K (nf x nf
each), and for ne elements with geometric stiffening k_e = EA l / 2 (ne),
Bu (ne x dm), G (ne x dm x dm) on each element's dm elastic coordinates,
bdof[d0:d0 + ne dm] (an element's strain reads only its own nodes: without
this restriction a force evaluation costs ne nf^2, 313 000 products for a
32-element beam; padding entries are 0 with zero data). ``_ffr_local`` evaluates the beam's dense
local blocks (Shabana, Dynamics of Multibody Systems, ch. 5; Sharf 1995 for
the stiffening), the scatter functions below it place them.
"""

from __future__ import annotations

import math

import numpy as np

from ..schema import BCOL, BDAT, BDOF, BEAM, GRAV, _f, _i, _inline, _jit, _put, _rows

#: Its fields in ``schema.MODEL_SCHEMA`` (the first gives the instances).
FIELDS = ("beam", "bcol", "bdat", "bdof", "grav")

#: What ``_ffr_local`` evaluates (bits): M, Q, (Q_q, Q_v), (M x)_q; numpy integers, so
#: that passing one does not compile a kernel per value (see ``_0``)
FFR_M, FFR_Q, FFR_DQ, FFR_MXQ = np.int64(1), np.int64(2), np.int64(4), np.int64(8)


def pack(beams, gravity) -> dict:
    """Its fields from the model's flexible beams (their shape integrals,
    stiffness and strain data: ``FlexibleBeam.shape_integrals``,
    ``stiffness``, ``strain_data``, computed once per beam).

    Parameters
    ----------
    beams : sequence of (FlexibleBeam, ndarray of int, shape (3 + nf,))
        Each beam with its local coordinates' columns in q, in the kernels'
        beam order (``assembly.ffr.beam_sets``).
    gravity : ndarray, shape (2,), or None
        [m/s^2]; None: no gravity term.

    Returns
    -------
    dict
        Per beam in BEAM (first entry in bcol, nf, first float in bdat,
        elements with geometric stiffening, first entry in bdof, elastic
        coordinates per element), its columns (BCOL: x, y, phi of its frame,
        then its elastic coordinates), its shape integrals and each
        element's strain data on its own elastic coordinates (BDAT, BDOF, the
        module notes), and gravity (GRAV) [m/s^2].
    """
    beam, bcol, bdat, bdof = [], [], [], []
    for b, cols in beams:
        s, strain = b.shape_integrals, b.strain_data
        ne = len(strain[0]) if strain is not None else 0
        start = sum(len(x) for x in bdat)
        parts = [np.atleast_1d(s.mass), s.s0, np.atleast_1d(s.I0), s.S_bar.ravel(), s.a_u, s.a_I,
                 s.M_ff.ravel(), s.S_tilde.ravel(), b.stiffness.ravel()]
        dofs = []
        if ne:            # each element's coordinates: where its Bu or G is nonzero
            kEA, Bu, G = strain
            dofs = [np.flatnonzero((Bu[e] != 0) | (np.abs(G[e]).sum(0) != 0)
                                   | (np.abs(G[e]).sum(1) != 0)) for e in range(ne)]
        dm = max((len(d) for d in dofs), default=0)
        beam.append((len(bcol), b.n_elastic, start, ne, len(bdof), dm))
        bcol.extend(int(c) for c in cols)
        if ne:
            idx = np.zeros((ne, dm), np.int64)
            Bu_e, G_e = np.zeros((ne, dm)), np.zeros((ne, dm, dm))
            for e, d in enumerate(dofs):
                idx[e, :len(d)] = d
                Bu_e[e, :len(d)] = Bu[e, d]
                G_e[e, :len(d), :len(d)] = G[e][np.ix_(d, d)]
            parts += [kEA, Bu_e.ravel(), G_e.ravel()]
            bdof.extend(int(x) for x in idx.ravel())
        bdat.append(np.concatenate([np.asarray(x, dtype=float).ravel() for x in parts]))
    return {"beam": np.array(beam, np.int64).reshape(-1, 6),
            "bcol": np.array(bcol, np.int64), "bdof": np.array(bdof, np.int64),
            "bdat": np.concatenate(bdat) if bdat else np.zeros(0),
            "grav": np.zeros(0) if gravity is None or not beams else np.asarray(gravity, float)}


@_inline
def _bd(I, Fl, k):
    """Float k of the beams' data."""
    return Fl[I[3 * BDAT] + k]


@_inline
def _ffr_mass(I, Fl, nf, qf, m, Bsx, Bsy, ASb, aU, aT, f0, au_, mff_, M):
    """The mass matrix M(q) of the beam's local coordinates (R, phi, q_f), (c,
    c)."""
    M[:, :] = 0.0
    M[0, 0] = M[1, 1] = m
    M[0, 2] = M[2, 0] = Bsx
    M[1, 2] = M[2, 1] = Bsy
    mpp = _bd(I, Fl, f0 + 3)
    for j in range(nf):
        mpp += (2.0 * _bd(I, Fl, au_ + j) + (aU[j] - _bd(I, Fl, au_ + j))) * qf[j]
        M[0, 3 + j] = M[3 + j, 0] = ASb[0, j]
        M[1, 3 + j] = M[3 + j, 1] = ASb[1, j]
        M[2, 3 + j] = M[3 + j, 2] = aT[j]
        for i in range(nf):
            M[3 + i, 3 + j] = _bd(I, Fl, mff_ + i * nf + j)
    M[2, 2] = mpp


@_inline
def _ffr_force(I, Fl, nf, qf, qd, w, w2, m, gx, gy, Asx, Asy, Bsx, Bsy, Bqd0, Bqd1, aUqd, ASb, aU,
               st_, kk_, Q):
    """Q = Q_v - K q_f + Q_gravity of the local coordinates, (c,)."""
    Q[0] = w2 * Asx - 2.0 * w * Bqd0 + m * gx
    Q[1] = w2 * Asy - 2.0 * w * Bqd1 + m * gy
    Q[2] = -2.0 * w * aUqd + Bsx * gx + Bsy * gy
    for i in range(nf):
        acc = w2 * aU[i] + ASb[0, i] * gx + ASb[1, i] * gy
        for j in range(nf):
            acc -= (2.0 * w * _bd(I, Fl, st_ + i * nf + j) * qd[j]
                    + _bd(I, Fl, kk_ + i * nf + j) * qf[j])
        Q[3 + i] = acc


@_inline
def _ffr_force_derivatives(I, Fl, nf, qd, w, w2, gx, gy, Asx, Asy, Bsx, Bsy, Aqd0, Aqd1, Bqd0,
                           Bqd1, aUqd, ASb, BSb, aU, mff_, st_, kk_, Qq, Qv):
    """Q_q and Q_v of the local coordinates, (c, c) each."""
    Qq[:, :] = 0.0
    Qv[:, :] = 0.0
    Qq[0, 2], Qq[1, 2] = w2 * Bsx + 2.0 * w * Aqd0, w2 * Bsy + 2.0 * w * Aqd1
    Qv[0, 2], Qv[1, 2] = 2.0 * w * Asx - 2.0 * Bqd0, 2.0 * w * Asy - 2.0 * Bqd1
    Qv[2, 2] = -2.0 * aUqd
    Qq[2, 2] = -(Asx * gx + Asy * gy)
    for j in range(nf):
        for a in range(2):
            Qq[a, 3 + j] = w2 * ASb[a, j]
            Qv[a, 3 + j] = -2.0 * w * BSb[a, j]
        mq, sq = 0.0, 0.0
        for k in range(nf):
            mq += _bd(I, Fl, mff_ + j * nf + k) * qd[k]
            sq += _bd(I, Fl, st_ + j * nf + k) * qd[k]
        Qq[2, 3 + j] = -2.0 * w * mq + BSb[0, j] * gx + BSb[1, j] * gy
        Qq[3 + j, 2] = BSb[0, j] * gx + BSb[1, j] * gy
        Qv[2, 3 + j] = -2.0 * w * aU[j]
        Qv[3 + j, 2] = 2.0 * w * aU[j] - 2.0 * sq
        for i in range(nf):
            Qq[3 + j, 3 + i] = (w2 * _bd(I, Fl, mff_ + j * nf + i)
                                - _bd(I, Fl, kk_ + j * nf + i))
            Qv[3 + j, 3 + i] = -2.0 * w * _bd(I, Fl, st_ + j * nf + i)


@_inline
def _ffr_stiffening(I, Fl, what, qf, ne, dm, d0, kea_, bu_, gg_, Q, Qq):
    """Geometric stiffening: - dU_G/dq_f into Q and - d^2U_G/dq_f^2 into Q_q,
    as ``what`` asks (the axial force's bending stiffness, element by
    element)."""
    g, dof = np.empty(dm), np.empty(dm, np.int64)
    for e in range(ne):
        ke = _bd(I, Fl, kea_ + e)
        for i in range(dm):
            dof[i] = _i(I, BDOF, d0 + e * dm + i, 0)
        ae, ce = 0.0, 0.0
        for i in range(dm):
            ae += _bd(I, Fl, bu_ + e * dm + i) * qf[dof[i]]
            gi = 0.0
            for j in range(dm):
                gi += _bd(I, Fl, gg_ + (e * dm + i) * dm + j) * qf[dof[j]]
            g[i] = gi
        for i in range(dm):
            ce += g[i] * qf[dof[i]]
        for i in range(dm):
            bui = _bd(I, Fl, bu_ + e * dm + i)
            if what & FFR_Q:
                Q[3 + dof[i]] -= ke * (ce * bui + (2.0 * ae + ce) * g[i])
            if what & FFR_DQ:
                for j in range(dm):
                    buj = _bd(I, Fl, bu_ + e * dm + j)
                    Qq[3 + dof[i], 3 + dof[j]] -= ke * (
                        2.0 * (bui * g[j] + g[i] * buj) + 2.0 * g[i] * g[j]
                        + (2.0 * ae + ce) * _bd(I, Fl, gg_ + (e * dm + i) * dm + j))


@_inline
def _ffr_mxq(I, Fl, k0, nf, cph, x, Asx, Asy, BSb, aU, st_, Mxq):
    """(M(q) x)_q of the local coordinates for the extended vector x, (c, c)."""
    xR0, xR1 = x[_i(I, BCOL, k0, 0)], x[_i(I, BCOL, k0 + 1, 0)]
    xp = x[cph]
    Mxq[:, :] = 0.0
    Mxq[0, 2], Mxq[1, 2] = -Asx * xp, -Asy * xp
    Mxq[2, 2] = -(Asx * xR0 + Asy * xR1)
    for j in range(nf):
        xj = x[_i(I, BCOL, k0 + 3 + j, 0)]
        Mxq[0, 2] += BSb[0, j] * xj
        Mxq[1, 2] += BSb[1, j] * xj
        Mxq[0, 3 + j], Mxq[1, 3 + j] = BSb[0, j] * xp, BSb[1, j] * xp
        bx = BSb[0, j] * xR0 + BSb[1, j] * xR1
        Mxq[3 + j, 2] = bx
        sx = 0.0
        for k in range(nf):
            sx += _bd(I, Fl, st_ + j * nf + k) * x[_i(I, BCOL, k0 + 3 + k, 0)]
            Mxq[3 + j, 3 + k] = _bd(I, Fl, st_ + j * nf + k) * xp
        Mxq[2, 3 + j] = bx + 2.0 * aU[j] * xp - sx


@_jit
def _ffr_local(I, Fl, b, qx, vx, x, what, M, Q, Qq, Qv, Mxq):
    """Local blocks of beam b (c = 3 + nf): M(q) into M (c, c), Q = Q_v - K
    q_f (- dU_G/dq_f) + Q_gravity into Q (c,), Q_q, Q_v into Qq, Qv (c, c),
    (M(q) x)_q into Mxq (c, c) for the extended vector x, as ``what`` asks
    (FFR_* bits); (q, v) from qx, vx."""
    k0, nf, f0, ne = _i(I, BEAM, b, 0), _i(I, BEAM, b, 1), _i(I, BEAM, b, 2), _i(I, BEAM, b, 3)
    d0, dm = _i(I, BEAM, b, 4), _i(I, BEAM, b, 5)
    sb_, au_ = f0 + 4, f0 + 4 + 2 * nf
    ai_, mff_ = au_ + nf, au_ + 2 * nf
    st_, kk_ = mff_ + nf * nf, mff_ + 2 * nf * nf
    kea_ = mff_ + 3 * nf * nf
    bu_, gg_ = kea_ + ne, kea_ + ne + ne * dm
    qf, qd = np.empty(nf), np.empty(nf)
    for j in range(nf):
        col = _i(I, BCOL, k0 + 3 + j, 0)
        qf[j], qd[j] = qx[col], vx[col]
    cph = _i(I, BCOL, k0 + 2, 0)
    cs, sn, w = math.cos(qx[cph]), math.sin(qx[cph]), vx[cph]
    m = _bd(I, Fl, f0)
    # s_bar = s0 + S_bar q_f, a_U = a_u + M_ff q_f, a_T = a_I + S_tilde q_f
    sbx, sby = _bd(I, Fl, f0 + 1), _bd(I, Fl, f0 + 2)
    aU, aT = np.empty(nf), np.empty(nf)
    ASb, BSb = np.empty((2, nf)), np.empty((2, nf))
    for i in range(nf):
        s0i, s1i = _bd(I, Fl, sb_ + i), _bd(I, Fl, sb_ + nf + i)
        sbx += s0i * qf[i]
        sby += s1i * qf[i]
        ASb[0, i], ASb[1, i] = cs * s0i - sn * s1i, sn * s0i + cs * s1i
        BSb[0, i], BSb[1, i] = -ASb[1, i], ASb[0, i]
        u, tt = _bd(I, Fl, au_ + i), _bd(I, Fl, ai_ + i)
        for j in range(nf):
            u += _bd(I, Fl, mff_ + i * nf + j) * qf[j]
            tt += _bd(I, Fl, st_ + i * nf + j) * qf[j]
        aU[i], aT[i] = u, tt
    Asx, Asy = cs * sbx - sn * sby, sn * sbx + cs * sby          # A s_bar
    Bsx, Bsy = -Asy, Asx                                         # B s_bar
    if what & FFR_M:
        _ffr_mass(I, Fl, nf, qf, m, Bsx, Bsy, ASb, aU, aT, f0, au_, mff_, M)
    if what & (FFR_Q | FFR_DQ):
        Bqd0, Bqd1, Aqd0, Aqd1, aUqd = 0.0, 0.0, 0.0, 0.0, 0.0
        for j in range(nf):
            Bqd0 += BSb[0, j] * qd[j]
            Bqd1 += BSb[1, j] * qd[j]
            Aqd0 += ASb[0, j] * qd[j]
            Aqd1 += ASb[1, j] * qd[j]
            aUqd += aU[j] * qd[j]
        w2 = w * w
        gx, gy = 0.0, 0.0
        if _rows(I, GRAV) > 0:
            gx, gy = _f(I, Fl, GRAV, 0, 0), _f(I, Fl, GRAV, 1, 0)
        if what & FFR_Q:
            _ffr_force(I, Fl, nf, qf, qd, w, w2, m, gx, gy, Asx, Asy, Bsx, Bsy, Bqd0, Bqd1, aUqd,
                       ASb, aU, st_, kk_, Q)
        if what & FFR_DQ:
            _ffr_force_derivatives(I, Fl, nf, qd, w, w2, gx, gy, Asx, Asy, Bsx, Bsy, Aqd0, Aqd1,
                                   Bqd0, Bqd1, aUqd, ASb, BSb, aU, mff_, st_, kk_, Qq, Qv)
        if ne > 0:          # geometric stiffening: - dU_G/dq_f, - d^2U_G/dq_f^2
            _ffr_stiffening(I, Fl, what, qf, ne, dm, d0, kea_, bu_, gg_, Q, Qq)
    if what & FFR_MXQ:
        _ffr_mxq(I, Fl, k0, nf, cph, x, Asx, Asy, BSb, aU, st_, Mxq)



@_jit
def _ffr_scratch(I):
    """Scratch blocks (M, Q, Qq, Qv, Mxq) for the largest beam of the model."""
    c = 3
    for b in range(_rows(I, BEAM)):
        c = max(c, 3 + _i(I, BEAM, b, 1))
    return (np.empty((c, c)), np.empty(c), np.empty((c, c)), np.empty((c, c)),
            np.empty((c, c)))


@_jit
def _ffr_forces_add(I, Fl, qx, vx, out):
    """out += Q of every beam (``assembly.ffr.forces``)."""
    M, Q, Qq, Qv, Mxq = _ffr_scratch(I)
    for b in range(_rows(I, BEAM)):
        _ffr_local(I, Fl, b, qx, vx, qx, FFR_Q, M, Q, Qq, Qv, Mxq)
        k0 = _i(I, BEAM, b, 0)
        for a in range(3 + _i(I, BEAM, b, 1)):
            out[_i(I, BCOL, k0 + a, 0)] += Q[a]


@_jit
def _beam_mass_add(I, Fl, qM, x, coef, out):
    """out += coef M_b(qM) x on every beam's columns (x, out indexed by
    column; the rigid diagonal is the caller's, in its own expression)."""
    M, Q, Qq, Qv, Mxq = _ffr_scratch(I)
    for b in range(_rows(I, BEAM)):
        _ffr_local(I, Fl, b, qM, qM, qM, FFR_M, M, Q, Qq, Qv, Mxq)
        k0, c = _i(I, BEAM, b, 0), 3 + _i(I, BEAM, b, 1)
        for a in range(c):
            acc = 0.0
            for d in range(c):
                acc += M[a, d] * x[_i(I, BCOL, k0 + d, 0)]
            out[_i(I, BCOL, k0 + a, 0)] += coef * acc


@_jit
def _ffr_energy(I, Fl, b, qx, gravity):
    """Potential energy of beam b at qx [J]: the strain energy q_f^T K q_f / 2
    (+ U_G = sum_e k_e (a_e c_e + c_e^2 / 4) with geometric stiffening) and,
    with ``gravity`` and a gravity field g, - m g . R - g . A s_bar
    (``ffr`` module notes; zero at y = 0 and an undeformed beam)."""
    k0, nf, f0, ne = _i(I, BEAM, b, 0), _i(I, BEAM, b, 1), _i(I, BEAM, b, 2), _i(I, BEAM, b, 3)
    d0, dm = _i(I, BEAM, b, 4), _i(I, BEAM, b, 5)
    sb_ = f0 + 4
    kk_ = f0 + 4 + 4 * nf + 2 * nf * nf
    kea_ = kk_ + nf * nf
    bu_, gg_ = kea_ + ne, kea_ + ne + ne * dm
    qf = np.empty(nf)
    for j in range(nf):
        qf[j] = qx[_i(I, BCOL, k0 + 3 + j, 0)]
    e = 0.0
    for i in range(nf):
        acc = 0.0
        for j in range(nf):
            acc += _bd(I, Fl, kk_ + i * nf + j) * qf[j]
        e += 0.5 * qf[i] * acc
    for el in range(ne):
        ae, ce = 0.0, 0.0
        for i in range(dm):
            fi = qf[_i(I, BDOF, d0 + el * dm + i, 0)]
            ae += _bd(I, Fl, bu_ + el * dm + i) * fi
            for j in range(dm):
                fj = qf[_i(I, BDOF, d0 + el * dm + j, 0)]
                ce += fi * _bd(I, Fl, gg_ + (el * dm + i) * dm + j) * fj
        e += _bd(I, Fl, kea_ + el) * (ae * ce + 0.25 * ce * ce)
    if gravity and _rows(I, GRAV) > 0:
        gx, gy = _f(I, Fl, GRAV, 0, 0), _f(I, Fl, GRAV, 1, 0)
        sbx, sby = _bd(I, Fl, f0 + 1), _bd(I, Fl, f0 + 2)
        for i in range(nf):
            sbx += _bd(I, Fl, sb_ + i) * qf[i]
            sby += _bd(I, Fl, sb_ + nf + i) * qf[i]
        ph = qx[_i(I, BCOL, k0 + 2, 0)]
        cs, sn = math.cos(ph), math.sin(ph)
        m = _bd(I, Fl, f0)
        e -= (m * (gx * qx[_i(I, BCOL, k0, 0)] + gy * qx[_i(I, BCOL, k0 + 1, 0)])
              + gx * (cs * sbx - sn * sby) + gy * (sn * sbx + cs * sby))
    return e


@_jit
def beam_blocks(I, Fl, b0, qx, vx, x, what, M, Q, Qq, Qv, Mxq):
    """The local blocks of beams b0 .. b0 + k - 1 (k = len(M), all of one size
    c = 3 + nf), as ``_ffr_local`` evaluates them: M(q) into M (k, c, c),
    Q into Q (k, c), Q_q and Q_v into Qq, Qv (k, c, c), (M(q) x)_q into Mxq
    (k, c, c), as the FFR_* bits of ``what`` ask; qx, vx and x extended
    vectors (nx,). The one evaluation of the beams' physics that Python
    calls (``assembly.ffr.local_blocks``)."""
    for k in range(M.shape[0]):
        _ffr_local(I, Fl, b0 + k, qx, vx, x, what, M[k], Q[k], Qq[k], Qv[k], Mxq[k])


@_jit
def beam_energies(I, Fl, b0, b1, qx, gravity, out):
    """out[r] = the potential energy of beams b0 .. b1 - 1 at row qx[r]
    (``_ffr_energy``; qx (N, nx), out (N,) [J])."""
    for r in range(qx.shape[0]):
        e = 0.0
        for b in range(b0, b1):
            e += _ffr_energy(I, Fl, b, qx[r], gravity)
        out[r] = e


@_jit
def _emit_beams(I, Fl, qx, vx, x, what, R, C, V, p, r0, c0, c1, c2):
    """Every beam's local block(s) at (r0, c0): c1 M (FFR_M), c1 (M x)_q
    (FFR_MXQ), or -(c1 Q_q + c2 Q_v) (FFR_DQ); all c x c entries, so that
    the pattern is fixed."""
    M, Q, Qq, Qv, Mxq = _ffr_scratch(I)
    for b in range(_rows(I, BEAM)):
        _ffr_local(I, Fl, b, qx, vx, x, what, M, Q, Qq, Qv, Mxq)
        k0, c = _i(I, BEAM, b, 0), 3 + _i(I, BEAM, b, 1)
        for a in range(c):
            ra = r0 + _i(I, BCOL, k0 + a, 0)
            for d in range(c):
                cd = c0 + _i(I, BCOL, k0 + d, 0)
                if what == FFR_M:
                    val = c1 * M[a, d]
                elif what == FFR_MXQ:
                    val = c1 * Mxq[a, d]
                else:
                    val = -(c1 * Qq[a, d] + c2 * Qv[a, d])
                p = _put(R, C, V, p, ra, cd, val)
    return p
