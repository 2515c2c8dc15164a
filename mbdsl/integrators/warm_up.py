"""The kernels' warm-up: a two-link pendulum run a few steps through every
group of the compiled engine's entry points, with the argument types of a
real run, which loads them (compiling when they are not cached).

A run through the driver, which imports the engine, which asks the kernel
cache to load the kernels: this module sits above all three, and the kernel
cache calls it through :func:`.kernel_cache.register_warm_up` (the package's
``__init__`` registers :func:`run` when it is imported), so that the cache
imports nothing of the driver.
"""

from __future__ import annotations

import numpy as np

from . import kernel_cache
from .kernel_cache import GROUPS

__all__ = ["run"]

_PENDULUM = """model kernel_warm_up
body b { mass 1; inertia 0.1; point O (-0.5, 0); point P (0.5, 0) }
body c { mass 1; inertia 0.1; point O (-0.5, 0) }
joint O: revolute(ground.origin, b.O)
joint P: revolute(b.P, c.O)
force s: spring_damper(ground.origin, c.O, k = 10, c = 1, length = 0)
initial b.phi = 0.3
"""


def run(groups=GROUPS, output: bool = True) -> None:
    """Load (compiling if needed) the kernels of each group of entry points
    by running a two-link pendulum two steps through them, with the
    argument types of every real run:

    * "dense": the compiled time loop with the explicit inverse (``run``,
      which takes fixed and error-controlled steps);
    * "banded": the same loop with the band LU (``run``, and
      ``jacobian_triplets`` for the band ordering);
    * "sparse": the compiled residuals and triplets under the Python Newton
      loop, which is also the compiled loop's fallback (``predict``,
      ``old_force``, ``residual``, ``jacobian_triplets``, ``accumulate``,
      ``mobility``, ``state``, ``layout``, ``step_end``, ``step_ratio``
      and generalized-alpha's ``advance``: this group runs GENALPHA, with
      error control);

    and with ``output`` the kernels of the output's index-1 multipliers
    (``index1_multipliers_band`` for rigid bodies, ``index1_multipliers``
    for flexible beams, the pendulum calling both), which a run with warm
    kernels loads when its output first needs them, and of the flexible
    beams' blocks and energies
    (``beam_blocks``, ``beam_energies``), which every evaluation of a beam
    outside the compiled loop calls (the other elements' ``elements``,
    which the initial conditions call, the pendulum's run loads).

    Every method shares every signature (the method is a recipe array,
    ``recipe.py``), so one of them loads what all use.
    """
    from ..assembly.system import assemble
    from ..dsl.check import check_spec
    from ..dsl.parser import parse_text
    from .driver import integrate
    from .genalpha import GenAlpha
    from .hht_i3 import HHTI3
    from .newton import NewtonOptions
    from .adaptive import StepControl
    from .compiled import lapack_band_addresses
    system = assemble(check_spec(parse_text(_PENDULUM, file="<kernel warm-up>")))
    groups = [g for g in groups if g != "banded" or lapack_band_addresses() is not None]
    # integrate: no warm-up again (the set ensure_loaded reads, looked up now: a test
    # gives the cache a set of its own, as a new process has)
    kernel_cache._loaded.update(groups)
    for solver in groups:
        method = GenAlpha() if solver == "sparse" else HHTI3()
        integrate(system, method, 2e-3, 1e-3, engine="compiled",
                  newton=NewtonOptions(linear_solver=solver),
                  control=StepControl(1.0, 1.0) if solver == "sparse" else None)
    if output:                 # the output's multipliers (HHT-ADD), contacts' energy and power
        from .engine import CompiledModel, index1_multipliers
        index1_multipliers(system, np.zeros(1), np.zeros((1, system.n)), np.zeros((1, system.n)))
        rows = np.zeros((1, system.nx))
        cm = CompiledModel(system)
        # the dense index-1 system of flexible beams (M(q) not diagonal), with the
        # argument types engine.index1_multipliers passes
        q = np.zeros((1, system.n))
        cm.K.index1_multipliers(cm.ints, cm.floats, np.zeros(1), q, q.copy(),
                                np.empty((1, system.m)), np.empty(cm.bound, np.int64),
                                np.empty(cm.bound, np.int64), np.empty(cm.bound),
                                system.FRICTION_ITERATIONS)
        # the applied loads' evaluations from Python (``AssembledSystem.Q`` and
        # after it; the initial conditions call Q already): the energies and power
        system.power(np.zeros(1), rows[:, :system.n], rows[:, :system.n],
                     np.zeros((1, system.m)))
        # the flexible beams' evaluations from Python (``assembly.ffr``),
        # with the argument types it passes: no beam here, the signatures only
        blocks = [np.zeros((0, 3, 3)), np.zeros((0, 3))] + [np.zeros((0, 3, 3))] * 3
        cm.K.beam_blocks(cm.ints, cm.floats, 0, rows[0], rows[0], rows[0], 1, *blocks)
        cm.K.beam_energies(cm.ints, cm.floats, 0, 0, rows, True, np.zeros(1))
