"""An independent reference for spatial chains on spherical joints: the
Newton-Euler equations of each body (centre of mass r, rotation matrix R,
body-axis angular velocity w) with the joints' forces as unknowns, solved
at index 1 and integrated by scipy's DOP853.

Nothing of mbdsl is used: not its coordinates (here R and w, not
directors), nor its assembly. Per body i (mass m, principal inertia J,
joint points s_in (to the body before, or the ground) and s_out (to the next
body), in body axes):

    m a_i = m g + F_i - F_{i+1},
    J alpha_i + w_i x J w_i = s_in x R_i^T F_i - s_out x R_i^T F_{i+1},
    R_i' = R_i [w_i]x,

F_i the force joint i applies on body i (and -F_i on body i - 1), with the
acceleration constraints of the joints (point i of body i - 1 and of body i
move together):

    a_i + R_i (alpha_i x s_in + w_i x (w_i x s_in))
      = a_{i-1} + R_{i-1} (alpha_{i-1} x s_out + w_{i-1} x (w_{i-1} x s_out))

(the ground's point at rest for i = 0). Sources: Shabana, Dynamics of
Multibody Systems, 4th ed., sec. 3.11 (Newton-Euler equations); Haug 1989,
sec. 11.1.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp


def _skew(w):
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def chain_reference(mass, inertia, s_in, s_out, ground_point, gravity, r0, R0, v0, w0,
                    times, rtol=1e-12, atol=1e-12):
    """The chain's motion at ``times``: (r (T, k, 3), R (T, k, 3, 3), w (T, k, 3)).

    Parameters are per body (k of them): mass (k,), inertia (k, 3), s_in,
    s_out (k, 3) in body axes; ground_point (3,); gravity (3,); initial
    r0, v0 (k, 3), R0 (k, 3, 3), w0 (k, 3) (body axes), consistent with the
    joints.
    """
    k = len(mass)
    mass, inertia = np.asarray(mass, float), np.asarray(inertia, float)
    s_in, s_out = np.asarray(s_in, float), np.asarray(s_out, float)
    g = np.asarray(gravity, float)

    def unpack(y):
        r = y[:3 * k].reshape(k, 3)
        v = y[3 * k:6 * k].reshape(k, 3)
        R = y[6 * k:15 * k].reshape(k, 3, 3)
        w = y[15 * k:].reshape(k, 3)
        return r, v, R, w

    def rhs(t, y):
        r, v, R, w = unpack(y)
        # unknowns: a (3k), alpha (3k), F (3k); equations: 3k + 3k + 3k
        n = 9 * k
        A, b = np.zeros((n, n)), np.zeros(n)
        ia, il, iF = (lambda i: slice(3 * i, 3 * i + 3)), \
            (lambda i: slice(3 * k + 3 * i, 3 * k + 3 * i + 3)), \
            (lambda i: slice(6 * k + 3 * i, 6 * k + 3 * i + 3))
        for i in range(k):
            e = slice(3 * i, 3 * i + 3)                     # translation of body i
            A[e, ia(i)] = mass[i] * np.eye(3)
            A[e, iF(i)] = -np.eye(3)
            if i + 1 < k:
                A[e, iF(i + 1)] = np.eye(3)
            b[e] = mass[i] * g
            e = slice(3 * k + 3 * i, 3 * k + 3 * i + 3)     # rotation of body i (body axes)
            A[e, il(i)] = np.diag(inertia[i])
            A[e, iF(i)] = -_skew(s_in[i]) @ R[i].T
            if i + 1 < k:
                A[e, iF(i + 1)] = _skew(s_out[i]) @ R[i].T
            b[e] = -np.cross(w[i], inertia[i] * w[i])
            e = slice(6 * k + 3 * i, 6 * k + 3 * i + 3)     # joint i's acceleration
            A[e, ia(i)] = np.eye(3)
            A[e, il(i)] = -R[i] @ _skew(s_in[i])
            rhs_i = -R[i] @ np.cross(w[i], np.cross(w[i], s_in[i]))
            if i > 0:
                A[e, ia(i - 1)] = -np.eye(3)
                A[e, il(i - 1)] = R[i - 1] @ _skew(s_out[i - 1])
                rhs_i += R[i - 1] @ np.cross(w[i - 1], np.cross(w[i - 1], s_out[i - 1]))
            b[e] = rhs_i
        x = np.linalg.solve(A, b)
        acc, alpha = x[:3 * k], x[3 * k:6 * k].reshape(k, 3)
        Rdot = np.einsum("kij,kjl->kil", R, np.array([_skew(wi) for wi in w]))
        return np.concatenate([v.ravel(), acc, Rdot.ravel(), alpha.ravel()])

    y0 = np.concatenate([np.ravel(r0), np.ravel(v0), np.ravel(R0), np.ravel(w0)])
    sol = solve_ivp(rhs, (times[0], times[-1]), y0, method="DOP853", rtol=rtol, atol=atol,
                    t_eval=times)
    assert sol.success, sol.message
    Y = sol.y.T
    r = Y[:, :3 * k].reshape(-1, k, 3)
    R = Y[:, 6 * k:15 * k].reshape(-1, k, 3, 3)
    w = Y[:, 15 * k:].reshape(-1, k, 3)
    return r, R, w
