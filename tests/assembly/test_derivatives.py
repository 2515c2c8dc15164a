"""Every analytic derivative of the assembly against central finite differences.

The model ``all_elements.mbd`` declares every joint, driver and force type;
``flexible_elements.mbd`` puts every joint and point force on flexible beams
(both frames, two beam sizes); ``coupler_elements.mbd`` every coupler (a
rack on a turning line, joints that share a body); ``follower_elements.mbd``
point forces that read the motion (in body axes, drag from point velocities,
joint coordinates, on nodal and modal beams); ``table_elements.mbd`` tables of
time and of the state (every interpolation) in a driver, torques and forces;
``state_elements.mbd`` first-order states whose rates read the motion, a beam,
a table, time and the states, read by torques, joint forces and a follower force.
Configurations and velocities are random
(not consistent: the derivatives are identities in q, v, t). A tolerance of 1e-6 relative catches a wrong
sign or a missing term, which change entries by O(1).
"""

from pathlib import Path

import numpy as np
import pytest

import mbdsl
from mbdsl.assembly.system import assemble

VALID = Path(__file__).parents[1] / "dsl" / "valid"
MODEL = VALID / "all_elements.mbd"
FLEXIBLE = VALID / "flexible_elements.mbd"
COUPLERS = VALID / "coupler_elements.mbd"
FOLLOWER = VALID / "follower_elements.mbd"
TABLES = VALID / "table_elements.mbd"
STATES = VALID / "state_elements.mbd"
SPATIAL = VALID / "spatial_drivers.mbd"
SPATIAL_GAPS = VALID / "spatial_contacts.mbd"
SPATIAL_STATE = VALID / "spatial_state_loads.mbd"
EPS = 1e-6


@pytest.fixture(scope="module", params=[MODEL, FLEXIBLE, COUPLERS, FOLLOWER, TABLES, STATES,
                                        SPATIAL, SPATIAL_GAPS, SPATIAL_STATE],
                ids=["rigid", "flexible", "couplers", "follower", "tables", "states", "spatial",
                     "spatial-gaps", "spatial-state-loads"])
def system(request):
    return assemble(mbdsl.load(request.param))


def fd(f, x, eps=EPS):
    """Central-difference Jacobian of f at x; columns are d f / d x_i."""
    cols = []
    for i in range(len(x)):
        e = np.zeros_like(x)
        e[i] = eps
        cols.append((np.asarray(f(x + e)) - np.asarray(f(x - e))) / (2 * eps))
    return np.stack(cols, axis=-1)


def close(analytic, numeric, rtol=1e-6):
    scale = max(1.0, float(np.max(np.abs(numeric))))
    err = float(np.max(np.abs(analytic - numeric)))
    assert err <= rtol * scale, f"max error {err:.3e} (scale {scale:.3e})"


def states(system, count=4, seed=1):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        q = rng.normal(size=system.n)
        v = rng.normal(size=system.n)
        for b in system.model.flexible_bodies:      # deformations of a few cm
            q[b.elastic_columns()] *= 0.03
        lam = rng.normal(size=system.m)
        t = float(rng.uniform(0, 2))
        yield q, v, lam, t


def test_model_declares_every_element_type(system):
    if system.model.name == "table_elements":      # every interpolation and extrapolation
        assert {t.interpolation for t in system.model.tables} == {"linear", "pchip", "cubic",
                                                                "akima"}
        assert {t.extrapolation for t in system.model.tables} == {"hold", "linear"}
        return
    if system.model.name == "follower_elements":
        forces = {f.name: f for f in system.model.forces}
        assert {f.kind for f in forces.values()} == {"point_force"}
        assert {f.frame for f in forces.values()} == {"world", "body"}
        read = {v.name for f in forces.values() for c in (f.fx, f.fy) for v in c.variables}
        # joint angle, sliding distance and speed, body and particle rates, a nodal
        # and a modal beam's elastic coordinates and rates, a point's motion on a beam
        assert {"O.angle", "S.distance", "S.speed", "bob.vx", "arm.omega", "rod.theta3",
                "lam.eta2", "rod.theta3_t", "rod.u3_t"} <= read
        return
    if system.model.couplers:
        assert {c.kind for c in system.model.couplers} == {"gear", "rack", "coupler"}
        return
    if system.model.states:              # states read by every load kind of the state
        assert len(system.model.states) == 5
        read = {v.name for s in system.model.states for v in getattr(s.function, "variables", ())}
        assert {"O.rate", "wf", "ie", "S.distance", "tip", "rod.theta3"} <= read
        loads = {f.kind for f in system.model.forces}
        assert loads == {"joint_torque", "joint_force", "point_force", "state_torque"}
        return
    if system.model.name == "spatial_contacts":      # every spatial gap geometry
        gaps = [(c.name, g[0]) for c in system.model.forces for g in c.gaps]
        assert {g for _, g in gaps} == {"dot", "spatial_angle"} and len(gaps) == 6
        return
    if system.model.name == "spatial_state_loads":   # forces and torques of the motion
        loads = system.model.forces
        assert {f.kind for f in loads} == {"spatial_state_load"}
        # F on r and s_k F on a_k: a.P 3 + 9, b.Q (s_3 = 0) 3 + 6; a torque 9; in
        # joints: on both bodies, 9 + 9, and F at e.cm 3, -F at a.O 3 + 3
        assert sorted(len(f.entries) for f in loads) == [9, 9, 9, 9, 12, 18]
        read = {v.name for f in loads for fn in f.functions for v in fn.variables}
        assert {"a.P.vx", "H.angle", "L.speed"} & read == set()   # read through the bodies'
        assert {"a.vx", "a.A11_t", "b.vz", "b.A12_t", "b.A31", "a.z", "b.z", "d.A23_t",
                "e.x"} <= read
        return
    if system.model.space == 3:          # every spatial driver, a rotational spring-damper
        assert {(d.kind, d.joint.kind if d.joint else None) for d in system.model.drivers} == {
            ("joint_angle", "revolute"), ("joint_distance", "prismatic"),
            ("coordinate", None), ("joint_angle", "cylindrical")}
        assert {f.kind for f in system.model.forces} == {"rsda"}
        return
    if system.model.flexible_bodies:
        assert {j.kind for j in system.model.joints} == {"revolute", "prismatic",
                                                         "point_on_line", "fixed"}
        assert [len(s.beams) for s in system.beam_sets] == [2, 1]
        return
    kinds = {j.kind for j in system.model.joints}
    assert kinds == {"revolute", "prismatic", "point_on_line", "fixed"}
    assert {d.kind for d in system.model.drivers} == {"coordinate", "joint_angle",
                                                      "joint_distance"}
    # a load of every kind but friction and contact (their own tests)
    assert {f.kind for f in system.model.forces} == {"spring", "rotational", "torque",
                                                    "point_force", "joint_torque",
                                                    "state_torque"}
    assert system.m == 2 + 2 + 1 + 3 + 1 + 2 + 2 + 1


def test_Phi_q(system):
    for q, v, lam, t in states(system):
        close(system.Phi_q(q, t), fd(lambda x: system.Phi(x, t), q))


def test_Phi_t_Phi_tt_Phi_qt(system):
    for q, v, lam, t in states(system):
        f = lambda s: system.Phi(q, s[0])
        close(system.Phi_t(q, t), fd(f, np.array([t]))[:, 0])
        g = lambda s: system.Phi_t(q, s[0])
        close(system.Phi_tt(q, t), fd(g, np.array([t]))[:, 0])
        h = lambda s: system.Phi_q(q, s[0])
        close(system.Phi_qt(q, t), fd(h, np.array([t]))[..., 0])


def test_Phiq_v_q_and_PhiqT_lam_q(system):
    for q, v, lam, t in states(system):
        close(system.Phiq_v_q(q, v), fd(lambda x: system.Phi_q(x, t) @ v, q))
        close(system.PhiqT_lam_q(q, lam), fd(lambda x: system.Phi_q(x, t).T @ lam, q))


def test_gamma_is_minus_second_time_derivative_of_Phi(system):
    # Along q(s) = q + v s (zero acceleration): d^2/ds^2 Phi(q(s), t + s) = -gamma.
    for q, v, lam, t in states(system):
        h = 1e-4
        f = lambda s: system.Phi(q + v * s, t + s)
        d2 = (f(h) - 2 * f(0.0) + f(-h)) / h**2
        close(system.gamma(q, v, t), -d2, rtol=1e-5)


def test_Q_q_and_Q_v(system):
    for q, v, lam, t in states(system):
        Q_q, Q_v = system.force_derivatives(t, q, v)
        close(Q_q, fd(lambda x: system.Q(t, x, v), q))
        # Q is at most quadratic in v (central differences exact but for
        # round-off), so a larger step keeps the round-off of the large
        # elastic forces of stiff beams (~1e5 N) out of the differences
        close(Q_v, fd(lambda x: system.Q(t, q, x), v, eps=1e-4))


def test_Ma_q(system):
    for q, v, lam, t in states(system):
        M = system.mass_matrix(q)
        assert np.allclose(M, M.T) and np.all(np.linalg.eigvalsh(M) > 0)
        if not system.model.flexible_bodies:
            assert system.Ma_q(q, v) is None        # rigid: M constant
            continue
        close(system.Ma_q(q, lam[:1] * v), fd(lambda x: system.mass_times(x, lam[:1] * v), q))
        close(system.mass_times(q, v), M @ v, rtol=1e-12)
        close(system.mass_solve(q, M @ v), v, rtol=1e-9)


def test_potential_energy_gradient_is_minus_conservative_force(system):
    # With damping, time-dependent and non-potential forces removed, Q = -dV/dq.
    model = system.model
    from dataclasses import replace
    from mbdsl.model.elements import SpringDamper, RotationalSpringDamper
    from mbdsl.model.spatial import SpatialRotationalSpring, SpatialSpring
    forces = tuple(replace(f, c=0.0) for f in model.forces
                   if isinstance(f, (SpringDamper, RotationalSpringDamper, SpatialSpring,
                                     SpatialRotationalSpring)))
    sys2 = assemble(replace(model, forces=forces, states=()))   # a state's rate is no force
    for q, v, lam, t in states(sys2):
        grad = fd(lambda x: np.array([sys2.potential_energy(x)]), q)[0]
        # at v = 0 (the quadratic velocity vector of flexible beams vanishes)
        close(sys2.Q(t, q, 0 * v), -grad)
