"""The spatial double pendulum against Exudyn's (rigid bodies in Euler
parameters, spherical joints, its generalized-alpha at spectral radius 1)
from mbdsl's assembled start, both at converged steps. Exudyn is not a
dependency of mbdsl: the test runs where it is installed."""

from __future__ import annotations

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
