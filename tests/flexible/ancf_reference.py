"""An independent, geometrically exact reference for the spin-up beam: planar
ANCF beam elements (gradient-deficient, cubic in the arc length), written
here for the tests and sharing no code with mbdsl.

Each node has its position r and slope r' = dr/dx in the global frame; in an
element of length l, r(x) = N1 r_i + N2 r'_i + N3 r_j + N4 r'_j with the
Hermite functions N1 = 1 - 3 xi^2 + 2 xi^3, N2 = l (xi - 2 xi^2 + xi^3),
N3 = 3 xi^2 - 2 xi^3, N4 = l (xi^3 - xi^2). The mass matrix is constant; the
strain energy is exact in the large rotations:

    U = 1/2 int EA eps^2 + EI kappa^2 dx,
    eps = (r'.r' - 1)/2 (Green),  kappa = (r' x r'') / |r'|^3,

(Berzeri & Shabana, J. Sound Vib. 235 (2000) 539; Gerstmayr & Shabana,
Nonlinear Dyn. 45 (2006) 109). The beam is clamped to the hub at its first
node: r_0 = 0 and r'_0 = (cos theta(t), sin theta(t)), prescribed; the other
nodes are free, and M_ff a_f = Q_f - M_fp a_p(t) is integrated by scipy's
BDF. No foreshortening, modal or floating-frame assumption enters.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.integrate
import scipy.linalg


def spin(t, ws, Ts):
    """Hub angle, rate and acceleration of Kane, Ryan & Banerjee's profile."""
    if t < Ts:
        a = 2 * math.pi * t / Ts
        c = (Ts / (2 * math.pi))
        return (ws / Ts * (t * t / 2 + c * c * (math.cos(a) - 1)),
                ws / Ts * (t - c * math.sin(a)), ws / Ts * (1 - math.cos(a)))
    return ws * (t - Ts / 2), ws, 0.0


def spinup_tip(ws, Ts=15.0, T=30.0, L=10.0, EI=14000.0, EA=2.8e7, rhoA=1.2, elements=16,
               times=None, rtol=1e-7, atol=1e-9, method="Radau"):
    """(times, tip transverse deflection in the hub frame [m]) of the spin-up beam."""
    N, l = elements, L / elements
    gx, gw = np.polynomial.legendre.leggauss(5)
    xi, w = 0.5 * (gx + 1), 0.5 * gw * l                # points in [0, 1], weights in x
    n = np.stack([1 - 3 * xi**2 + 2 * xi**3, l * (xi - 2 * xi**2 + xi**3),
                  3 * xi**2 - 2 * xi**3, l * (xi**3 - xi**2)], 1)          # (g, 4)
    dn = np.stack([-6 * xi + 6 * xi**2, l * (1 - 4 * xi + 3 * xi**2),
                   6 * xi - 6 * xi**2, l * (3 * xi**2 - 2 * xi)], 1) / l
    ddn = np.stack([-6 + 12 * xi, l * (-4 + 6 * xi), 6 - 12 * xi, l * (6 * xi - 2)], 1) / l**2
    ndof = 4 * (N + 1)
    # element dof map: node i (r: 4i, 4i+1; r': 4i+2, 4i+3), as (4 functions, 2 components)
    emap = np.array([[[4 * e, 4 * e + 1], [4 * e + 2, 4 * e + 3],
                      [4 * e + 4, 4 * e + 5], [4 * e + 6, 4 * e + 7]] for e in range(N)])
    M = np.zeros((ndof, ndof))
    me = rhoA * np.einsum("g,ga,gb->ab", w, n, n)
    for e in range(N):
        for c in range(2):
            M[np.ix_(emap[e, :, c], emap[e, :, c])] += me
    free = np.arange(4, ndof)
    pres = np.arange(4)
    Mff = scipy.linalg.cho_factor(M[np.ix_(free, free)])
    Mfp = M[np.ix_(free, pres)]

    def elastic(q):
        """Generalized elastic forces -dU/dq, shape (ndof,)."""
        E = q[emap]                                      # (N, 4, 2)
        r1 = np.einsum("ga,eac->egc", dn, E)             # r' at the points
        r2 = np.einsum("ga,eac->egc", ddn, E)            # r''
        g = np.einsum("egc,egc->eg", r1, r1)
        eps = 0.5 * (g - 1.0)
        cr = r1[..., 0] * r2[..., 1] - r1[..., 1] * r2[..., 0]
        kap = cr * g ** -1.5
        Jr2 = np.stack([r2[..., 1], -r2[..., 0]], -1)    # d(r1 x r2)/d r1
        Jr1 = np.stack([-r1[..., 1], r1[..., 0]], -1)    # d(r1 x r2)/d r2
        dkap_r1 = g[..., None] ** -1.5 * Jr2 - 3.0 * cr[..., None] * g[..., None] ** -2.5 * r1
        dkap_r2 = g[..., None] ** -1.5 * Jr1
        f1 = EA * eps[..., None] * r1 + EI * kap[..., None] * dkap_r1      # dU/dr1 density
        f2 = EI * kap[..., None] * dkap_r2
        fe = (np.einsum("g,ga,egc->eac", w, dn, f1) + np.einsum("g,ga,egc->eac", w, ddn, f2))
        out = np.zeros(ndof)
        np.add.at(out, emap, -fe)
        return out

    def prescribed(t):
        th, om, al = spin(t, ws, Ts)
        c, s = math.cos(th), math.sin(th)
        q = np.array([0.0, 0.0, c, s])
        v = np.array([0.0, 0.0, -s * om, c * om])
        a = np.array([0.0, 0.0, -s * al - c * om * om, c * al - s * om * om])
        return q, v, a

    def rhs(t, y):
        qp, _, ap = prescribed(t)
        q = np.concatenate([qp, y[:len(free)]])
        Q = elastic(q)
        acc = scipy.linalg.cho_solve(Mff, Q[free] - Mfp @ ap)
        return np.concatenate([y[len(free):], acc])

    x = np.arange(N + 1) * l
    q0 = np.zeros(ndof)
    q0[0::4], q0[2::4] = x, 1.0
    y0 = np.concatenate([q0[free], np.zeros(len(free))])
    sol = scipy.integrate.solve_ivp(rhs, (0.0, T), y0, method=method, rtol=rtol, atol=atol,
                                    t_eval=times, dense_output=times is None)
    ts = sol.t
    tip = []
    for t, y in zip(ts, sol.y.T):
        th = spin(t, ws, Ts)[0]
        rx, ry = y[4 * N - 4], y[4 * N - 3]               # last node's position
        tip.append(-math.sin(th) * rx + math.cos(th) * ry)
    return ts, np.array(tip)
