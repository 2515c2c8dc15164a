"""The element kernels Python calls outside a time loop: the evaluations of every
element (``elements``), the flexible beams' blocks and energies, and the
packed model data's schema and packing.

The assembled system evaluates its elements through this module
(``AssembledSystem.kernel_model``), compiled or as its uncompiled copy
(:func:`.cache.element_kernels`); the step kernels' facade
(:mod:`mbdsl.integrators.compiled`) re-exports it.
"""

from __future__ import annotations

from .beams.ffr import (FFR_DQ, FFR_M, FFR_MXQ, FFR_Q, _ffr_local,  # noqa: F401
                        beam_blocks, beam_energies)
from .beams.ffr import pack as pack_beams  # noqa: F401
from .loads.contact import GAP_ANGLE, GAP_CIRCLE, GAP_LINE, GAP_SLIDE  # noqa: F401
from .schema import _0, _HEADER, MODEL_FIELDS, MODEL_SCHEMA, pack, unpack  # noqa: F401
from .system import (C_PHI, C_PHI_T, C_PHI_TT, C_PHIQ, C_PHIQ_Y, C_PHIQ_Y_Q,  # noqa: F401
                     C_PHIQT_Y, C_PHIQT_Y_Q, L_ENERGY, L_GAPS, L_POWER, L_Q, L_QLAM, L_QQ, L_QV,
                     JOINT_FAMILIES, LOAD_FAMILIES, L_SENSORS, L_SLIP, L_SPRINGS, SENSOR_FRICTION,
                     SENSOR_GAP, SENSOR_SPRING, elements, forces, joint_hook, phi, triplet_bound)
