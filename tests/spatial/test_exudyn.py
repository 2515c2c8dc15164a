"""The spatial double pendulum and the spatial slider-crank against Exudyn's
(rigid bodies in Euler parameters, its joints, its generalized-alpha at
spectral radius 1) from mbdsl's assembled start, both at converged steps.
Exudyn is not a dependency of mbdsl: the tests run where it is installed."""

from __future__ import annotations

import sys

import numpy as np
import pytest

import mbdsl
from tests.conftest import MODELS

exu = pytest.importorskip("exudyn")

DIRECTORS = ("A11", "A21", "A31", "A12", "A22", "A32", "A13", "A23", "A33")


def test_the_spatial_double_pendulum_agrees_with_exudyn():
    """Centres of mass at t = 1 s within 1e-6 m (measured 5.8e-8 at h = 1e-4,
    3.1e-9 at 5e-5)."""
    from exudyn.utilities import RigidBodyInertia
    model = mbdsl.load(MODELS / "spatial_double_pendulum.mbd")
    h, T = 1e-4, 1.0
    sol = mbdsl.simulate(model, method="hht-si2", h=h, t_end=T)
    ours = np.array([sol.column(f"link{k}.{c}")[-1] for k in (1, 2) for c in "xyz"])
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.CreateGround()
    bodies, frames = [], []
    J = np.diag([1.0 / 12, 1.0 / 12, 0.02 ** 2 / 2])
    for b in ("link1", "link2"):
        r = np.array([sol.column(f"{b}.{c}")[0] for c in "xyz"])
        v = np.array([sol.column(f"{b}.v{c}")[0] for c in "xyz"])
        A = np.array([sol.column(f"{b}.{d}")[0] for d in DIRECTORS]).reshape(3, 3).T
        w = A @ np.array([sol.column(f"{b}.w{c}")[0] for c in "xyz"])      # world axes
        frames.append((r, A))
        bodies.append(mbs.CreateRigidBody(inertia=RigidBodyInertia(1.0, J),
                                          referencePosition=list(r), referenceRotationMatrix=A,
                                          initialVelocity=list(v),
                                          initialAngularVelocity=list(w),
                                          gravity=[0, 0, -9.81]))
    r1, A1 = frames[0]
    mbs.CreateSphericalJoint(bodyNumbers=[ground, bodies[0]], position=list(r1 + A1 @ [0, 0, 0.5]))
    mbs.CreateSphericalJoint(bodyNumbers=[bodies[0], bodies[1]],
                             position=list(r1 + A1 @ [0, 0, -0.5]))
    mbs.Assemble()
    s = exu.SimulationSettings()
    s.timeIntegration.numberOfSteps, s.timeIntegration.endTime = int(round(T / h)), T
    s.timeIntegration.newton.relativeTolerance = 1e-12
    s.timeIntegration.generalizedAlpha.spectralRadius = 1.0
    s.solutionSettings.writeSolutionToFile = False
    exu.SolveDynamic(mbs, s)
    theirs = np.concatenate([mbs.GetObjectOutputBody(b, exu.OutputVariableType.Position,
                                                     localPosition=[0, 0, 0]) for b in bodies])
    assert np.max(np.abs(ours - theirs)) < 1e-6


def test_the_spatial_slider_crank_agrees_with_exudyn():
    """The model translated by ``benchmarks/exudyn_side.py`` (revolute,
    spherical, universal as a generic joint, prismatic), Newton's tolerance
    1e-12 in both: every coordinate at t = 1 s within 1e-6 (measured 2.9e-7
    at h = 5e-5, 1.7e-6 at 1e-4). With Exudyn's default tolerances its
    solution leaves the reference after 0.5 s (7.7e-4 at 0.6 s, h = 1e-4),
    where mbdsl's stays within 1e-5 of the Newton-Euler solution."""
    sys.path.insert(0, str(MODELS.parent / "benchmarks"))
    import exudyn_side
    model = mbdsl.load(MODELS / "spatial_slider_crank.mbd")
    h, T = 5e-5, 1.0
    start = mbdsl.simulate(model, h=1e-3, t_end=1e-3)
    sol = mbdsl.simulate(model, method="hht-si2", h=h, t_end=T)
    theirs = exudyn_side.run_exudyn(model, start.q[0], start.v[0], T, h, alpha=0.0, repeat=1,
                                    tolerance=1e-12)
    assert np.max(np.abs(sol.q[-1] - theirs["q"])) < 1e-6
