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


# --- any mechanism: joints as elementary conditions -----------------------------

def _point_rows(R, w, s):
    """A body point's velocity map and centripetal acceleration, world axes:
    p' = v - R [s]x w,  p'' = a - R [s]x alpha + R (w x (w x s))."""
    return -R @ _skew(s), R @ np.cross(w, np.cross(w, s))


def mechanism_reference(mass, inertia, conditions, gravity, r0, R0, v0, w0, times,
                        rtol=1e-12, atol=1e-12):
    """The motion at ``times`` of rigid bodies joined by elementary conditions:
    (r (T, k, 3), R (T, k, 3, 3), w (T, k, 3) body axes).

    The unknowns are the accelerations a_i (world) and alpha_i (body axes)
    and a multiplier per condition row, from the index-1 system

        [[M, J^T], [J, 0]] [acc; lambda] = [F; gamma],

    M = diag(m_i I, J_i), F_i = (m_i g, -w_i x J_i w_i), J the conditions'
    rows over (v_i, w_i) and gamma their velocity-squared terms (Haug 1989,
    sec. 11.1; Nikravesh 1988, ch. 6). ``conditions`` (body j None: the
    ground, its vectors in world axes):

    - ("point", i, s_i, j, s_j): r_i + R_i s_i = r_j + R_j s_j (3 rows);
    - ("perp", i, a_i, j, b_j): (R_i a_i) . (R_j b_j) = 0 (1 row);
    - ("plane", i, s_i, n, P): n . (r_i + R_i s_i - P) = 0, n, P in world axes (1 row);
    - ("lock", i): w_i = 0, the body does not turn (3 rows).
    """
    k = len(mass)
    mass, inertia = np.asarray(mass, float), np.asarray(inertia, float)
    g = np.asarray(gravity, float)
    vel = lambda i: slice(6 * i, 6 * i + 3)          # noqa: E731
    ang = lambda i: slice(6 * i + 3, 6 * i + 6)      # noqa: E731

    def unpack(y):
        return (y[:3 * k].reshape(k, 3), y[3 * k:6 * k].reshape(k, 3),
                y[6 * k:15 * k].reshape(k, 3, 3), y[15 * k:].reshape(k, 3))

    def rows(R, w):
        Js, gs = [], []
        for cond in conditions:
            kind, i = cond[0], cond[1]
            if kind == "point":
                s_i, j, s_j = np.asarray(cond[2], float), cond[3], np.asarray(cond[4], float)
                Jr = np.zeros((3, 6 * k))
                Jr[:, vel(i)] = np.eye(3)
                Jr[:, ang(i)], c = _point_rows(R[i], w[i], s_i)
                if j is not None:
                    Jr[:, vel(j)] = -np.eye(3)
                    Jw, cj = _point_rows(R[j], w[j], s_j)
                    Jr[:, ang(j)] = -Jw
                    c = c - cj
                Js.append(Jr)
                gs.append(-c)
            elif kind == "perp":
                a, j, b = np.asarray(cond[2], float), cond[3], np.asarray(cond[4], float)
                A, dA = R[i] @ a, R[i] @ np.cross(w[i], a)
                if j is None:
                    B, dB, ddB = b, np.zeros(3), np.zeros(3)
                else:
                    B, dB = R[j] @ b, R[j] @ np.cross(w[j], b)
                    ddB = R[j] @ np.cross(w[j], np.cross(w[j], b))
                Jr = np.zeros((1, 6 * k))
                Jr[0, ang(i)] = np.cross(a, R[i].T @ B)
                if j is not None:
                    Jr[0, ang(j)] = np.cross(b, R[j].T @ A)
                ddA = R[i] @ np.cross(w[i], np.cross(w[i], a))
                Js.append(Jr)
                gs.append([-(ddA @ B + 2.0 * dA @ dB + A @ ddB)])
            elif kind == "plane":
                s, n = np.asarray(cond[2], float), np.asarray(cond[3], float)
                Jr = np.zeros((1, 6 * k))
                Jr[0, vel(i)] = n
                Jw, c = _point_rows(R[i], w[i], s)
                Jr[0, ang(i)] = n @ Jw
                Js.append(Jr)
                gs.append([-(n @ c)])
            elif kind == "lock":
                Jr = np.zeros((3, 6 * k))
                Jr[:, ang(i)] = np.eye(3)
                Js.append(Jr)
                gs.append(np.zeros(3))
            else:
                raise ValueError(f"unknown condition {kind!r}")
        return np.vstack(Js), np.concatenate([np.ravel(x) for x in gs])

    def rhs(t, y):
        r, v, R, w = unpack(y)
        J, gam = rows(R, w)
        n, m = 6 * k, J.shape[0]
        K, b = np.zeros((n + m, n + m)), np.zeros(n + m)
        for i in range(k):
            K[vel(i), vel(i)] = mass[i] * np.eye(3)
            K[ang(i), ang(i)] = np.diag(inertia[i])
            b[vel(i)] = mass[i] * g
            b[ang(i)] = -np.cross(w[i], inertia[i] * w[i])
        K[:n, n:], K[n:, :n], b[n:] = J.T, J, gam
        x = np.linalg.solve(K, b)[:n].reshape(k, 6)
        Rdot = np.einsum("kij,kjl->kil", R, np.array([_skew(wi) for wi in w]))
        return np.concatenate([v.ravel(), x[:, :3].ravel(), Rdot.ravel(), x[:, 3:].ravel()])

    y0 = np.concatenate([np.ravel(r0), np.ravel(v0), np.ravel(R0), np.ravel(w0)])
    sol = solve_ivp(rhs, (times[0], times[-1]), y0, method="DOP853", rtol=rtol, atol=atol,
                    t_eval=times)
    assert sol.success, sol.message
    Y = sol.y.T
    return (Y[:, :3 * k].reshape(-1, k, 3), Y[:, 6 * k:15 * k].reshape(-1, k, 3, 3),
            Y[:, 15 * k:].reshape(-1, k, 3))
