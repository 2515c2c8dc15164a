"""Compiled kernels (numba): the recipe methods (``recipe.py``) on planar rigid and flexible models.

With :mod:`mbdsl.kernels`, the only package of mbdsl that imports numba. It
is imported lazily, when a run asks for the compiled engine (:mod:`mbdsl.integrators.engine`), so that
``import mbdsl`` and model checking stay fast; the kernels are compiled once
per machine and cached on disk (``cache=True``, numba's ``__pycache__``).

Why compiled code here: on small mechanisms the numpy formulation is
dominated by call overhead (about a microsecond per numpy call, dozens of
calls per Newton iteration), not by arithmetic. The kernels evaluate the
element formulas the groups of :mod:`mbdsl.assembly` state, with scalar loops
over the instances of each element type (struct of arrays, fixed at build), and for
systems of up to ``DENSE_LIMIT`` unknowns run the whole time loop, Newton
iteration included, without returning to Python. They are the one
evaluation of every element: Python asks for Phi, Q, their derivatives,
energies and power through ``elements``, ``beam_blocks`` and
``beam_energies`` (``AssembledSystem``).

The element kernels are :mod:`mbdsl.kernels` (one module per element
family, their fields in ``kernels.schema.MODEL_SCHEMA``, packed into two flat
arrays by ``assembly.packing.PackedModel``). This package holds the step kernels:

* ``layout``: a recipe's unknowns, state and predictor;
* ``recipes``, ``additive``: the residual and Newton matrix of the linear
  family and of HHT-ADD;
* ``index1``: index-1 multipliers and accelerations, mobility, Newton's scales;
* ``linalg``: the linear solvers; ``newton``: the Newton iteration;
* ``loop``: the time loop; ``entry``: the entry points Python calls.

The Newton iteration is the one of :mod:`mbdsl.integrators.newton`
(weighted velocity-equivalent norm, contraction-based stopping, modified
Newton with refresh on poor contraction, the round-off stall rule), with
one of four linear solvers (``_factor``, ``_solve``):

* DENSE: an explicit inverse of the (small) Newton matrix computed by LAPACK
  through ``numpy.linalg.inv``; the inverse is only used to compute Newton
  updates, while the residual is evaluated exactly, so its round-off
  changes the contraction, never the converged solution;
* DENSE_SPLIT: the explicit inverses of HHT-SI2's two diagonal blocks, or of
  the first alone where the second is a multiple of it (``dense``);
* CONDENSED: the coordinates eliminated group by group, then the Schur
  complement's band LU (``condensed``);
* BANDED: LAPACK's band LU with partial pivoting (dgbtrf) on the Newton
  matrix reordered by reverse Cuthill-McKee (``solver_plans.band_ordering``),
  called through the address scipy.linalg.cython_lapack exports, and its
  band substitution (dgbtrs's operations, ``band._band_substitute``). The
  address is an argument, not constants, so the kernels stay cacheable
  (numba refuses to cache code that embeds a ctypes pointer).
"""

from __future__ import annotations

# The package's public names: what the engine (``engine.CompiledModel``, ``K``) and the
# tests call, from the modules that define them.
from mbdsl.integrators.outcomes import CONVERGED, NONFINITE, SINGULAR  # noqa: F401

from ...kernels.beams.ffr import (FFR_DQ, FFR_M, FFR_MXQ, FFR_Q, _ffr_local,  # noqa: F401
                                  beam_blocks, beam_energies)
from ...kernels.beams.ffr import pack as pack_beams  # noqa: F401
from ...kernels.loads.contact import GAP_ANGLE, GAP_CIRCLE, GAP_LINE, GAP_SLIDE  # noqa: F401
from ...kernels.schema import (_0, _HEADER, MODEL_FIELDS, MODEL_SCHEMA, _jit,  # noqa: F401
                               pack, unpack)
from ...kernels.system import (C_PHI, C_PHI_T, C_PHI_TT, C_PHIQ, C_PHIQ_Y,  # noqa: F401
                                C_PHIQ_Y_Q, C_PHIQT_Y, C_PHIQT_Y_Q, L_ENERGY, L_GAPS, L_POWER,
                                L_Q, L_QLAM, L_QQ, L_QV, L_SENSORS, L_SLIP, L_SPRINGS,
                                JOINT_FAMILIES, LOAD_FAMILIES, SENSOR_FRICTION, SENSOR_GAP, SENSOR_SPRING,
                                elements, forces, joint_hook, phi, triplet_bound)
from .index1 import (_index1_acceleration, _index1_multipliers,  # noqa: F401
                     _index1_scratch,
                     _index1_multipliers_band, _mobility)
from .layout import advance, layout, predict, state  # noqa: F401
from .linalg import (BANDED, CONDENSED, DENSE, DENSE_SPLIT, _factor, _solve,  # noqa: F401
                     lapack_band_addresses)
from .loop import _run, step_end, step_ratio  # noqa: F401
from .recipes import accumulate  # noqa: F401
from .entry import (force_term, index1_multipliers, index1_multipliers_band,  # noqa: F401
                    jacobian_triplets, mobility, old_force, residual, run, workspace)

__all__ = ["MODEL_SCHEMA", "MODEL_FIELDS", "residual", "jacobian_triplets", "force_term", "old_force",
           "predict", "state", "layout", "advance", "mobility", "index1_multipliers",
           "index1_multipliers_band",
           "accumulate", "elements", "beam_blocks", "beam_energies", "run", "workspace", "triplet_bound", "pack", "unpack", "lapack_band_addresses",
           "DENSE", "BANDED", "CONDENSED", "DENSE_SPLIT"]
