"""The element kernels: every element's physics, written once, compiled by numba.

One module per element family, each with its fields in the packed model data
(``schema.MODEL_SCHEMA``), its contributions to Phi, Phi_q^T lambda, Phi_q v
(joints) or Q (loads), the triplets of their derivatives for the Newton
matrix, its energy and power, and its triplet counts:

* ``joints/``: ``coincidence`` (revolute), ``point_on_line`` (prismatic rows,
  slots), ``linear_rows`` (locked and driven coordinates and angles),
  ``distance``;
* ``loads/``: ``spring_damper``, ``torques`` (rotational spring-dampers,
  torques of time), ``point_forces``, ``state_loads`` (loads of the state in
  joints), ``friction``, ``contact`` (contacts and joint limits);
* ``beams/``: ``ffr`` (flexible beams in the floating frame of reference),
  ``elastic_points`` (joint points on flexible beams);
* ``system``: the aggregates over the families in a fixed order (``phi``,
  ``forces``, the emitters, the energies, ``elements``, ``triplet_bound``);
* ``schema`` (the packed data and its named access), ``geometry``,
  ``programs`` (the language's expressions, compiled), ``jit`` (numba).

The step kernels that use them (the recipes' residual and Newton matrix,
Newton, the time loop, linear algebra) are :mod:`mbdsl.integrators.compiled`.
Nothing here imports :mod:`mbdsl.integrators`; only these two packages import
numba. Importing a module here does not compile anything: numba compiles (or
loads from its cache) at the first call, which :mod:`.kernel_cache
<mbdsl.integrators.kernel_cache>` announces and times.
"""

#: The package the uncompiled copy of the kernels is imported under
#: (``cache.import_uncompiled``): ``mbdsl._uncompiled.kernels...`` and
#: ``mbdsl._uncompiled.integrators.compiled...``.
UNCOMPILED_ROOT = "mbdsl._uncompiled"
