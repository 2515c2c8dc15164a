"""Spatial joints (``space 3d``): the spatial double pendulum against an
independent Newton-Euler solution (``newton_euler.py``, DOP853), every joint
kind's rows against finite differences and its geometry after a run, the
reactions against the bodies' equations, and the language's errors."""

from __future__ import annotations

import numpy as np
import pytest

import mbdsl
from mbdsl.errors import MbdModelError
from tests.conftest import MODELS

from .newton_euler import chain_reference

HERE = MODELS.parent / "tests" / "spatial"
DIRECTORS = ("A11", "A21", "A31", "A12", "A22", "A32", "A13", "A23", "A33")


def _frames(sol, body):
    """(r (N, 3), A (N, 3, 3), v (N, 3), body-axis w (N, 3)) of a spatial body."""
    col = lambda name: sol.column(f"{body}.{name}")                  # noqa: E731
    r = np.column_stack([col(c) for c in "xyz"])
    v = np.column_stack([col(f"v{c}") for c in "xyz"])
    A = np.column_stack([col(d) for d in DIRECTORS]).reshape(-1, 3, 3).transpose(0, 2, 1)
    w = np.column_stack([col(f"w{c}") for c in "xyz"])
    return r, A, v, w


@pytest.fixture(scope="module")
def pendulum_reference():
    """The spatial double pendulum's Newton-Euler solution over 1 s from
    mbdsl's assembled initial state (its positions, velocities and
    orientations satisfy the joints)."""
    model = mbdsl.load(MODELS / "spatial_double_pendulum.mbd")
    start = mbdsl.simulate(model, h=1e-3, t_end=1e-3)
    frames = [_frames(start, b) for b in ("link1", "link2")]
    L, m, rad = 1.0, 1.0, 0.02
    J = [L ** 2 / 12, L ** 2 / 12, rad ** 2 / 2]
    times = np.linspace(0.0, 1.0, 11)
    ref = chain_reference(
        [m, m], [J, J], s_in=[(0, 0, L / 2)] * 2, s_out=[(0, 0, -L / 2)] * 2,
        ground_point=np.zeros(3), gravity=(0, 0, -9.81),
        r0=[f[0][0] for f in frames], R0=[f[1][0] for f in frames],
        v0=[f[2][0] for f in frames], w0=[f[3][0] for f in frames], times=times)
    return model, times, ref


@pytest.mark.parametrize("method", ["hht-i3", "hht-si2", "genalpha", "nstiff-si2"])
def test_the_spatial_double_pendulum_converges_to_the_newton_euler_solution(
        pendulum_reference, method):
    """Positions and orientations at t = 0.1 .. 1 s against the DOP853
    reference of the Newton-Euler equations: order 2 from h = 2e-4 to 1e-4,
    and within 1e-5 at h = 1e-4."""
    model, times, (r_ref, R_ref, w_ref) = pendulum_reference
    errors = []
    for h in (2e-4, 1e-4):
        sol = mbdsl.simulate(model, method=method, h=h, t_end=1.0,
                             output_times=list(times[1:]))
        t = sol.column("t")
        keep = np.isin(np.round(t, 9), np.round(times, 9))
        err = 0.0
        for k, body in enumerate(("link1", "link2")):
            r, A, _, w = _frames(sol, body)
            err = max(err, np.max(np.abs(r[keep] - r_ref[:, k])),
                      np.max(np.abs(A[keep] - R_ref[:, k])))
        errors.append(err)
    assert errors[1] < 1e-5, errors
    assert abs(np.log2(errors[0] / errors[1]) - 2.0) < 0.2, errors


def test_the_newton_euler_reference_keeps_its_invariants(pendulum_reference):
    """The oracle itself: its rotation matrices stay orthonormal and the
    elbow's two points coincide."""
    _, _, (r, R, _) = pendulum_reference
    assert np.max(np.abs(R @ R.transpose(0, 1, 3, 2) - np.eye(3))) < 1e-9
    elbow1 = r[:, 0] + R[:, 0] @ np.array([0, 0, -0.5])
    elbow2 = r[:, 1] + R[:, 1] @ np.array([0, 0, 0.5])
    assert np.max(np.abs(elbow1 - elbow2)) < 1e-9


@pytest.fixture(scope="module")
def all_joints():
    return mbdsl.load(HERE / "all_joints.mbd")


def test_every_joint_kind_holds_its_geometry(all_joints):
    """After 0.5 s of motion under gravity, each joint's condition holds to
    Newton's tolerance, read from the bodies' coordinates: coincident points,
    parallel (revolute, cylindrical) or perpendicular (universal) axes, a
    point on a line or a plane, a distance, a slider's axes kept (prismatic),
    a body welded to another (fixed)."""
    sol = mbdsl.simulate(all_joints, method="hht-si2", h=1e-3, t_end=0.5)
    F = {b.name: _frames(sol, b.name) for b in all_joints.bodies}
    ground_axes = {"x": np.eye(3)[0], "y": np.eye(3)[1], "z": np.eye(3)[2]}

    def point(body, local):
        if body == "ground":
            return np.asarray(local, float)
        r, A = F[body][0], F[body][1]
        return r + A @ np.asarray(local, float)

    def axis(body, local):
        if body == "ground":
            return ground_axes.get(local, local)
        return F[body][1] @ np.asarray(local, float)

    tol = 1e-9
    # see all_joints.mbd
    assert np.max(np.abs(point("ground", (0, 0, 0)) - point("a", (0, 0, 0.5)))) < tol
    assert np.max(np.linalg.norm(np.cross(axis("a", (1, 0, 0)), np.eye(3)[0]), axis=1)) < tol
    assert np.max(np.abs(point("a", (0, 0, -0.5)) - point("b", (0, 0, 0.5)))) < tol
    assert np.max(np.abs(np.einsum("ni,ni->n", axis("a", (0, 1, 0)), axis("b", (0, 1, 0))))) < tol
    d = point("b", (0, 0, -0.5)) - point("c", (0, 0, 0.5))
    assert np.max(np.abs(d)) < tol
    # cylindrical: c's z axis parallel to d's, d's point on c's line
    zc, zd = axis("c", (0, 0, 1)), axis("d", (0, 0, 1))
    assert np.max(np.linalg.norm(np.cross(zc, zd), axis=1)) < tol
    off = point("d", (0, 0, 0)) - point("c", (0, 0, -0.5))
    assert np.max(np.linalg.norm(np.cross(off, zc), axis=1)) < tol
    assert np.ptp(np.einsum("ni,ni->n", off, zc)) > 1e-4            # it slides
    # point_on_line: e's point on the ground's x line through (0, 1, -1)
    pe = point("e", (0, 0, 0.2))
    assert np.max(np.abs(pe[:, 1:] - [1.0, -1.0])) < tol
    # point_on_plane: f's point on the plane z = -2
    assert np.max(np.abs(point("f", (0.1, 0, 0))[:, 2] + 2.0)) < tol
    # distance: 0.7 m between g's point and the ground's (2, 0, 0)
    dist = np.linalg.norm(point("g", (0, 0, 0.3)) - [2.0, 0, 0], axis=1)
    assert np.max(np.abs(dist - 0.7)) < tol
    # prismatic: h's axes stay the ground's, h's point on the slope's line through S
    assert np.max(np.abs(F["h"][1] - np.eye(3))) < tol
    slope = np.array([1.0, 0.0, 0.2]) / np.linalg.norm([1.0, 0.0, 0.2])
    off = point("h", (0, 0, 0.4)) - [0.0, 3.0, 0.0]
    assert np.max(np.linalg.norm(np.cross(off, slope), axis=1)) < tol
    assert np.ptp(off @ slope) > 0.05                               # it slides
    # fixed: k welded to h, its point at h's centre of mass, its axes h's
    assert np.max(np.abs(F["k"][1] - F["h"][1])) < tol
    assert np.max(np.abs(point("k", (0.1, 0.2, 0)) - F["h"][0])) < tol


def test_the_dot_rows_of_every_kind_against_finite_differences(all_joints):
    """Phi_q, (Phi_q^T lambda)_q and (Phi_q v)_q of every joint kind at a
    general configuration against central differences."""
    system = mbdsl.assemble(all_joints)
    n, m = system.n, system.m
    rng = np.random.default_rng(5)
    q, v, lam = rng.normal(size=n), rng.normal(size=n), rng.normal(size=m)
    eps = 1e-6
    E = np.eye(n)
    fd = np.column_stack([(system.Phi(q + eps * e, 0.0) - system.Phi(q - eps * e, 0.0))
                          / (2 * eps) for e in E])
    assert np.max(np.abs(np.asarray(system.Phi_q(q, 0.0)) - fd)) < 1e-7
    H = np.column_stack([(system.PhiqT_times(q + eps * e, 0.0, lam)
                          - system.PhiqT_times(q - eps * e, 0.0, lam)) / (2 * eps) for e in E])
    assert np.max(np.abs(np.asarray(system.PhiqT_lam_q(q, lam)) - H)) < 1e-7
    G = np.column_stack([(system.Phiq_times(q + eps * e, 0.0, v)
                          - system.Phiq_times(q - eps * e, 0.0, v)) / (2 * eps) for e in E])
    assert np.max(np.abs(np.asarray(system.Phiq_v_q(q, v)) - G)) < 1e-7


def test_the_reactions_are_the_bodies_equations():
    """On the spatial double pendulum (newmark: M a + Phi_q^T lambda = Q at
    every step): the lower link's only joint load is the elbow's, so its
    force is m (a - g) and its couple about the centre of mass is the
    elbow point's moment of that force (a spherical joint transmits no
    couple), which also equals d/dt of the link's angular momentum."""
    sol = mbdsl.simulate(mbdsl.load(MODELS / "spatial_double_pendulum.mbd"), method="newmark",
                         h=1e-4, t_end=0.2)
    f = np.column_stack([sol.column(f"reaction.E.f{c}") for c in "xyz"])
    tq = np.column_stack([sol.column(f"reaction.E.t{c}") for c in "xyz"])
    a = np.column_stack([sol.column(f"link2.a{c}") for c in "xyz"])
    want = a - np.array([0, 0, -9.81])
    assert np.max(np.abs(f - want)) < 1e-7 * np.max(np.abs(want))
    _, A, _, _ = _frames(sol, "link2")
    arm = A @ np.array([0.0, 0.0, 0.5])
    assert np.max(np.abs(tq - np.cross(arm, f))) < 1e-7 * np.max(np.abs(tq))


def test_the_model_counts_its_degrees_of_freedom(all_joints):
    """Gruebler-Kutzbach in director coordinates: 12 - 6 per body, minus the
    joints' rows."""
    bodies = len(all_joints.bodies)
    rows = sum(j.rows for j in all_joints.joints)
    assert all_joints.dof == 6 * bodies - rows
    assert [j.rows for j in all_joints.joints] == [5, 4, 3, 4, 2, 1, 1, 5, 6]


@pytest.mark.parametrize("text, code, where", [
    ("joint J: revolute(ground.origin, b.cm, b.z, ground.z)", "E305", "first body"),
    ("joint J: revolute(ground.origin, b.cm, ground.w, b.z)", "E201", "no axis 'w'"),
    ("joint J: point_on_plane(b.cm, ground.origin, b.z)", "E305", "second body"),
    ("joint J: distance(ground.origin, b.cm, length = -1)", "E303", "positive"),
])
def test_spatial_joint_errors(text, code, where):
    with pytest.raises(MbdModelError) as err:
        mbdsl.load_text("model t\nspace 3d\nbody b { mass 1; inertia (1, 1, 1); "
                        f"axis a (0, 0, 0) }}\n{text}\n")
    codes = [(d.code, d.message) for d in err.value.diagnostics if d.is_error]
    assert ("E306", "axis 'b.a' must be a non-zero vector") in codes
    assert any(c == code and where in msg for c, msg in codes), codes


def test_an_axis_line_in_a_planar_model_is_refused():
    with pytest.raises(MbdModelError) as err:
        mbdsl.load_text("model t\nbody b { mass 1; inertia 1; axis a (1, 0) }\n")
    assert err.value.diagnostics[0].code == "E205"


def test_bricard_is_one_redundant_row_and_one_degree_of_freedom():
    """Bricard's mechanism: Gruebler counts 0, the rank 1; the check names a
    joint's row as the redundant one (never a body's frame row) and accepts
    it (the augmented formulation)."""
    model = mbdsl.load(MODELS / "bricard.mbd")
    assert model.dof == 0
    system = mbdsl.assemble(model)
    from mbdsl.assembly.structure import analyse_structure
    q = mbdsl.simulate(model, h=1e-3, t_end=1e-3).q[0]
    report = analyse_structure(system, q, 0.0)
    assert report.dof_rank == 1
    assert [r.name for r in report.redundant] == ["J5"]


@pytest.mark.parametrize("method", ["hht-i3", "genalpha"])
def test_bricard_runs_ten_seconds_holding_its_loop(method):
    """10 s at h = 1e-3: the loop closed to 1e-10 m and the energy at the
    end within 1e-6 of the largest kinetic energy of its start."""
    sol = mbdsl.simulate(mbdsl.load(MODELS / "bricard.mbd"), method=method, h=1e-3,
                         t_end=10.0)
    assert sol.completed
    assert np.max(sol.column("constraint.position")) < 1e-10
    E, T = sol.column("energy.total"), sol.column("energy.kinetic")
    assert np.max(T) > 1.0                       # it moves
    assert abs(E[-1] - E[0]) < 1e-6 * np.max(T), (E[-1] - E[0], np.max(T))


@pytest.mark.parametrize("line", [
    "body c { mass 1; inertia (1, 2, 3) }",          # a spatial inertia in a planar model
    "body c { mass (1, 2); inertia 1 }",
    "force f: torque(b, (1, 2, 3))",
    "force s: spring_damper(b.A, ground.origin, k = (1, 2), c = 1, length = 1)",
    "initial b.x = (1, 2)",
])
def test_a_vector_where_a_number_belongs_is_an_error_at_its_line(line):
    """E305 at the vector (before: a TypeError traceback from the evaluator)."""
    text = ("model t\nbody b { mass 1; inertia 1; point A (0, 0) }\n"
            f"joint A: revolute(ground.origin, b.A)\n{line}\n")
    with pytest.raises(MbdModelError) as err:
        mbdsl.load_text(text)
    d = err.value.diagnostics[0]
    assert d.code == "E305" and "got a vector" in d.message and d.span.line == 4
