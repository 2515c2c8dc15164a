"""The last pass, on the resolved model: connectivity to the ground (W401). The
degrees of freedom, redundant (E401) and inconsistent (E503) joints are judged
by the assembly, by rank.
"""

from __future__ import annotations

from ...model import graph
from ...model.elements import Model


def check_structure(c, model: Model):
    """Connectivity to the ground (the DOF are judged by the assembly)."""
    # more equations than coordinates is not decided here: the rows may be
    # redundant (E401) or inconsistent (E503), which the assembly tells apart
    # and names the joints (assembly/structure.py)
    from ...model.contact import Contact
    touching = {data[k] for f in model.forces if isinstance(f, Contact)
                for _, data, _ in f.gaps for k in (0, 2)}
    for body_index in graph.bodies_not_connected_to_ground(model):
        if body_index in touching:          # held by a contact: free between impacts
            continue
        b = model.bodies[body_index]
        c.warning("W401", f"body '{b.name}' is not connected to the ground by joints",
                  b.span, "floats freely",
                  hint="that is fine for a free body; otherwise add a joint")
