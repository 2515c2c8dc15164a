"""The same mbdsl model built and run in Exudyn (the only module importing exudyn).

Exudyn (https://github.com/jgerstmayr/EXUDYN, C++ core, ``pip install
exudyn``, the optional ``bench`` extra) is what our users compare us with.
:func:`run_exudyn` translates a checked rigid mbdsl model element by element
into Exudyn items and integrates it with Exudyn's nearest settings to HHT:

* generalized-alpha, index 3 (``useIndex2Constraints = False``), spectral
  radius rho_inf = (1 + alpha) / (1 - alpha), the HHT value for alpha
  (Chung & Hulbert 1993; HHT is the alpha_m = 0 member of that family);
* modified Newton, Exudyn's default tolerances;
* ``EigenSparse`` above 50 coordinates, dense LU (``EXUdense``) below.

The initial state is mbdsl's consistent one (q, v), so both codes start from
the same point and their errors at T can be compared against one reference.

Element mapping: rigid body -> NodeRigidBody2D + ObjectRigidBody2D; revolute
-> ObjectJointRevolute2D; point_on_line -> ObjectJointPrismatic2D with the
rotation free (the line's normal in the line body's frame as
``normalMarker1``, the line body as marker 1); spring_damper -> ObjectConnectorSpringDamper; gravity ->
LoadMassProportional per body. Any other element raises ``NotImplementedError``.

Spatial models (``space 3d``): body -> ``CreateRigidBody`` (Euler parameters,
its frame from mbdsl's directors, angular velocity in world axes);
spherical -> ``CreateSphericalJoint``; revolute -> ``CreateRevoluteJoint``;
prismatic -> ``CreatePrismaticJoint`` (both in world axes at the start);
universal -> ``CreateGenericJoint`` with the rotation about a x b locked, its
frame (a, b, a x b) at the start; spring_damper -> ``CreateSpringDamper``;
gravity per body.
"""

from __future__ import annotations

import time

import numpy as np


def available() -> bool:
    """True when exudyn can be imported."""
    try:
        import exudyn  # noqa: F401
    except ImportError:
        return False
    return True


def version() -> str:
    """Exudyn's version string."""
    import exudyn
    return exudyn.__version__


def _build(model, q0, v0):
    if getattr(model, "space", 2) == 3:
        return _build_spatial(model, q0, v0)
    import exudyn as exu
    from exudyn import itemInterface as ii
    from mbdsl.model.elements import RigidBody, SpringDamper
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddObject(ii.ObjectGround())
    bodies, nodes = [], []
    for b in model.bodies:
        if not isinstance(b, RigidBody):
            raise NotImplementedError(f"{b.name}: only rigid bodies are translated")
        i = 3 * b.index
        nd = mbs.AddNode(ii.NodeRigidBody2D(referenceCoordinates=list(q0[i:i + 3]),
                                            initialVelocities=list(v0[i:i + 3])))
        nodes.append(nd)
        bodies.append(mbs.AddObject(ii.ObjectRigidBody2D(physicsMass=b.mass,
                                                         physicsInertia=b.inertia,
                                                         nodeNumber=nd)))
        if model.gravity is not None and np.any(model.gravity != 0):
            mm = mbs.AddMarker(ii.MarkerBodyMass(bodyNumber=bodies[-1]))
            mbs.AddLoad(ii.LoadMassProportional(markerNumber=mm,
                                                loadVector=[*model.gravity, 0.0]))

    def marker(p, rigid=False):
        body = ground if p.body < 0 else bodies[p.body]
        pos = [float(p.local[0]), float(p.local[1]), 0.0]
        if rigid:
            return mbs.AddMarker(ii.MarkerBodyRigid(bodyNumber=body, localPosition=pos))
        return mbs.AddMarker(ii.MarkerBodyPosition(bodyNumber=body, localPosition=pos))

    for j in model.joints:
        if j.kind == "revolute":
            mbs.AddObject(ii.ObjectJointRevolute2D(markerNumbers=[marker(j.first),
                                                                  marker(j.second)]))
        elif j.kind == "point_on_line":        # first moves on the line through second
            # Exudyn: (p1 - p0) . A1 n1 = 0 with n1 in marker 1's body frame, so the
            # line's body is marker 1 and its normal n1; marker 0 is the moving point.
            d = [float(j.direction[0]), float(j.direction[1]), 0.0]
            mbs.AddObject(ii.ObjectJointPrismatic2D(
                markerNumbers=[marker(j.first, rigid=True), marker(j.second, rigid=True)],
                axisMarker0=d, normalMarker1=[-d[1], d[0], 0.0], constrainRotation=False))
        else:
            raise NotImplementedError(f"joint {j.name}: {j.kind} is not translated")
    if model.drivers:
        raise NotImplementedError("drivers are not translated")
    for f in model.forces:
        if not isinstance(f, SpringDamper):
            raise NotImplementedError(f"force {f.name} is not translated")
        mbs.AddObject(ii.ObjectConnectorSpringDamper(
            markerNumbers=[marker(f.first), marker(f.second)], referenceLength=f.length,
            stiffness=f.k, damping=f.c))
    mbs.Assemble()
    return exu, mbs, nodes


def _build_spatial(model, q0, v0):
    import exudyn as exu
    from exudyn.utilities import RigidBodyInertia
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.CreateGround()
    g = list(model.gravity) if model.gravity is not None else [0.0, 0.0, 0.0]
    bodies, nodes, frames = [], [], []
    for b in model.bodies:
        i = 12 * b.index
        r, A = q0[i:i + 3], q0[i + 3:i + 12].reshape(3, 3).T
        dA = v0[i + 3:i + 12].reshape(3, 3).T
        W = dA @ A.T                                  # [w]x, world axes
        w = [W[2, 1], W[0, 2], W[1, 0]]
        d = mbs.CreateRigidBody(inertia=RigidBodyInertia(b.mass, np.diag(b.inertia)),
                                referencePosition=list(r), referenceRotationMatrix=A,
                                initialVelocity=list(v0[i:i + 3]), initialAngularVelocity=w,
                                gravity=g, returnDict=True)
        bodies.append(d["bodyNumber"])
        nodes.append(d["nodeNumber"])
        frames.append((r, A))

    def world(p):
        if p.body < 0:
            return np.asarray(p.local, float)
        r, A = frames[p.body]
        return r + A @ np.asarray(p.local, float)

    def direction(body, a):
        return np.asarray(a, float) if body < 0 else frames[body][1] @ np.asarray(a, float)

    def pair(j):
        return [ground if p.body < 0 else bodies[p.body] for p in (j.first, j.second)]

    for j in model.joints:
        if j.kind == "frame":
            continue                                    # mbdsl's orthonormality rows
        pos = list(world(j.first))
        if j.kind == "spherical":
            mbs.CreateSphericalJoint(bodyNumbers=pair(j), position=pos)
        elif j.kind in ("revolute", "prismatic"):
            axis = list(direction(*j.axes[-1]))
            create = (mbs.CreateRevoluteJoint if j.kind == "revolute"
                      else mbs.CreatePrismaticJoint)
            create(bodyNumbers=pair(j), position=pos, axis=axis)
        elif j.kind == "universal":
            a, b = (direction(*ax) for ax in j.axes)
            mbs.CreateGenericJoint(bodyNumbers=pair(j), position=pos,
                                   rotationMatrixAxes=np.column_stack([a, b, np.cross(a, b)]),
                                   constrainedAxes=[1, 1, 1, 0, 0, 1])
        else:
            raise NotImplementedError(f"joint {j.name}: spatial {j.kind} is not translated")
    if model.drivers:
        raise NotImplementedError("drivers are not translated")
    for f in model.forces:
        raise NotImplementedError(f"force {f.name} is not translated")
    mbs.Assemble()
    return exu, mbs, nodes


def _spatial_state(mbs, OVT, nodes):
    """q and v in mbdsl's spatial layout (r, then the directors A's columns;
    v, then A' = [w]x A) from Exudyn's nodes."""
    q, v = [], []
    for nd in nodes:
        A = np.asarray(mbs.GetNodeOutput(nd, OVT.RotationMatrix)).reshape(3, 3)
        w = np.asarray(mbs.GetNodeOutput(nd, OVT.AngularVelocity))
        W = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
        q += [np.asarray(mbs.GetNodeOutput(nd, OVT.Position)), A.T.ravel()]
        v += [np.asarray(mbs.GetNodeOutput(nd, OVT.Velocity)), (W @ A).T.ravel()]
    return np.concatenate(q), np.concatenate(v)


def _settings(exu, n, t_end, steps, alpha, tolerance=None):
    s = exu.SimulationSettings()
    ti = s.timeIntegration
    if tolerance is not None:
        ti.newton.relativeTolerance = ti.newton.absoluteTolerance = tolerance
    ti.endTime = t_end
    ti.numberOfSteps = steps
    ti.verboseMode = 0
    ti.generalizedAlpha.spectralRadius = (1.0 + alpha) / (1.0 - alpha)
    ti.generalizedAlpha.useIndex2Constraints = False
    ti.generalizedAlpha.useNewmark = False
    ti.newton.useModifiedNewton = True
    s.solutionSettings.writeSolutionToFile = False
    s.displayComputationTime = False
    s.displayStatistics = False
    s.linearSolverType = (exu.LinearSolverType.EigenSparse if n > 50
                          else exu.LinearSolverType.EXUdense)
    return s


def run_exudyn(model, q0, v0, t_end: float, h: float, alpha: float, repeat: int = 5,
               tolerance: float | None = None) -> dict:
    """Integrate in Exudyn; wall time per step (median of ``repeat`` runs,
    minus a one-step run that measures Exudyn's own set-up), Newton
    iterations and Jacobians per step, and q, v at t_end (a spatial model's
    in mbdsl's layout: r and the directors). ``tolerance``: Newton's relative
    and absolute tolerance (Exudyn's defaults when None).

    Returns
    -------
    dict with s_per_step, iterations, jacobians (per step), q, v (n,)
    """
    steps = int(round(t_end / h))
    walls, result = [], None
    for _ in range(repeat):
        exu, mbs, nodes = _build(model, q0, v0)
        solver = exu.MainSolverImplicitSecondOrder()
        t0 = time.perf_counter()
        solver.SolveSystem(mbs, _settings(exu, len(q0), t_end, steps, alpha, tolerance))
        full = time.perf_counter() - t0
        exu1, mbs1, _ = _build(model, q0, v0)
        solver1 = exu1.MainSolverImplicitSecondOrder()
        t1 = time.perf_counter()
        solver1.SolveSystem(mbs1, _settings(exu1, len(q0), h, 1, alpha, tolerance))
        one = time.perf_counter() - t1
        walls.append(max(full - one, 0.0) / max(steps - 1, 1))
        result = (exu, mbs, nodes, solver)
    exu, mbs, nodes, solver = result
    OVT = exu.OutputVariableType
    if getattr(model, "space", 2) == 3:
        q, v = _spatial_state(mbs, OVT, nodes)
    else:
        q = np.concatenate([q0[3 * i:3 * i + 3] + np.asarray(mbs.GetNodeOutput(nd, OVT.Coordinates))
                            for i, nd in enumerate(nodes)])
        v = np.concatenate([np.asarray(mbs.GetNodeOutput(nd, OVT.Coordinates_t)) for nd in nodes])
    return {"s_per_step": float(np.median(walls)),
            "iterations": solver.it.newtonStepsCount / steps,
            "jacobians": solver.it.newtonJacobiCount / steps,
            "q": q, "v": v}
