"""Semantic checks: ModelSpec -> Model, or every diagnostic at once.

The check runs named passes in order over one :class:`CheckContext` (as
MuJoCo's compiler does): each pass is a module with its own diagnostics, and
:data:`PASSES` lists them. All passes run even after an error so that a user
sees every problem of a file in one go; a pass skips only the elements whose
inputs were already reported broken. The structure pass runs last, on the
resolved model, and only when nothing else failed.

=============  =========================================================
pass           module
=============  =========================================================
parameters     ``parameters.py``: values, units, ``--set`` overrides
tables         ``data_tables.py``: tables y(x), inline or from data files
loops          ``loops.py``: ``for`` blocks flattened, indexed names
space          ``spatial.py``: what a spatial model (``space 3d``) has not
ground         ``bodies.py``: the ground's points
bodies         ``bodies.py``: rigid bodies, particles, flexible beams
gravity        ``forces.py``
joints         ``joints.py`` (kinds in ``tables.py``)
couplers       ``couplers.py``: gears, racks, couplers between joints
drivers        ``drivers.py``
states         ``states.py``: first-order states (controllers, filters)
forces         ``forces.py`` and ``contact.py`` (kinds in ``tables.py``)
initials       ``initials.py``
outputs        ``outputs.py``
settings       ``settings.py``: the simulate section
structure      ``structure.py``: connectivity to the ground
=============  =========================================================
"""

from __future__ import annotations

import dataclasses
import hashlib

from ...errors import MbdModelError
from ...gcpause import paused
from ...model.elements import Model
from ..components import flatten
from ..spec import ModelSpec
from .bodies import check_bodies, check_ground
from .context import CheckContext, point_ref
from .couplers import check_couplers
from .data_tables import check_tables
from .drivers import check_drivers
from .forces import check_forces, check_gravity
from .initials import check_initials
from .joints import check_joints
from .loops import expand_loops
from .outputs import check_outputs
from .parameters import check_parameters
from .settings import check_settings
from .spatial import check_space
from .states import check_states
from .structure import check_structure
from .tables import FORCE_KINDS, JOINT_KINDS, KNOWN_METHODS, SETTINGS

__all__ = ["check_spec", "CheckContext", "PASSES", "JOINT_KINDS", "FORCE_KINDS", "SETTINGS",
           "KNOWN_METHODS", "point_ref"]

#: The passes in order, by name. Each takes the context; gravity's returns the
#: model's gravity vector (or None).
PASSES = (("parameters", check_parameters), ("tables", check_tables), ("loops", expand_loops),
          ("space", check_space), ("ground", check_ground), ("bodies", check_bodies), ("gravity", check_gravity),
          ("joints", check_joints), ("couplers", check_couplers), ("drivers", check_drivers),
          ("states", check_states), ("forces", check_forces),
          ("initials", check_initials), ("outputs", check_outputs),
          ("settings", check_settings))


@paused
def check_spec(spec: ModelSpec, overrides: dict | None = None,
               stored_sources: dict | None = None) -> Model:
    """Check a model specification and resolve it into a :class:`Model`.

    Parameters
    ----------
    spec : ModelSpec
        As parsed (``parse_text``) or built in Python.
    overrides : dict of str -> float or str, optional
        Parameter values replacing the declared ones (``--set``; an
        instance's by its path, ``upper.L``).
    stored_sources : dict of str -> str, optional
        The texts of the files the model imports, by key (a result file's
        ``imports``), read instead of the files.

    Returns
    -------
    Model
        With any warnings in ``model.warnings``.

    Raises
    ------
    MbdModelError
        Carrying every diagnostic (errors and warnings) when there is at
        least one error.
    """
    flat = flatten(spec, stored_sources)
    c = CheckContext(flat.spec, overrides)
    c.diags.extend(flat.diagnostics)
    if spec.library:
        c.error("E110", f"'{spec.name}' is a library of components, not a model", spec.span,
                "a library", hint="write a model that imports it (`import \"file.mbd\"`) "
                "and declares instances of its components")
    gravity = None
    for name, run in PASSES:
        value = run(c)
        if name == "gravity":
            gravity = value
    source = spec.source or ""
    model = Model(
        name=spec.name, bodies=tuple(c.bodies.values()), ground_points=c.ground_points,
        joints=tuple(c.joints.values()), drivers=tuple(c.drivers), forces=tuple(c.forces),
        gravity=gravity, initials=tuple(c.initials), settings=c.settings,
        parameters=dict(c.params), file=spec.file, source=spec.source,
        sha256=hashlib.sha256(source.encode()).hexdigest() if spec.source else "",
        static=bool(spec.static), static_span=spec.static_span, outputs=tuple(c.outputs),
        couplers=tuple(c.couplers), tables=tuple(c.tables.values()),
        states=tuple(c.first_order), imports=dict(flat.sources),
        instances=dict(flat.instances), space=c.space)
    if not any(d.is_error for d in c.diags):
        check_structure(c, model)
    if any(d.is_error for d in c.diags):
        errors = [d for d in c.diags if d.is_error]
        raise MbdModelError(f"{len(errors)} error{'s' if len(errors) != 1 else ''} in "
                            f"{spec.file}", c.diags)
    # the fields alone: what the model derives from them (``functools.cached_property``,
    # e.g. its coordinate map) is derived again by the new one, not passed to it
    return dataclasses.replace(model, warnings=tuple(c.diags))
