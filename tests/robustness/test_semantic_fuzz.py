"""Semantic fuzzing: hypothesis builds valid mechanisms, not token mutations.

Random trees of bodies and particles hung from the ground by random joints at
random points, a loop closed by a distance joint at the assembled
configuration's own length, random spring-dampers, torques (of tables too), joint torques and
forces, follower forces in body axes with a drag on their point, a PI controller on a
filtered joint rate (two first-order states), friction, a floor contact, joint limits, a rope
to the ground, gears and racks between the joints, all with physical
parameter ranges; each is checked (``mbdsl.check``) and run for 150 steps
with a random method and step mode. Every example must satisfy the scene
matrix's invariants (``tests/matrix/matrix.py``): no traceback, a completed
run whose energy balance is within 1 % of the energy exchanged or flagged
(W602), or a coded refusal. CI runs 100 derandomized examples; ``-m
nightly`` runs 5000 random ones.
"""

import os
import re

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import mbdsl
from mbdsl.errors import MbdError

from ..matrix.matrix import METHODS, energy_ratio

pytestmark = pytest.mark.filterwarnings("ignore::RuntimeWarning")

num = st.floats  # shorthand


@st.composite
def mechanisms(draw):
    """(text of a valid .mbd model, method, rtol or None) drawn at random."""
    lines = ["model fuzzed"]
    if draw(st.booleans()):
        lines.append("gravity (0, -9.81)")
    n = draw(st.integers(1, 4))
    bodies = []                      # (name, is_particle, points {name: (x, y)})
    for i in range(n):
        particle = draw(st.booleans()) and draw(st.booleans())
        mass = draw(num(0.1, 5.0))
        if particle:
            lines.append(f"particle b{i} {{ mass {mass:.4g} }}")
            bodies.append((f"b{i}", True, {}))
        else:
            pts = {f"p{k}": (draw(num(-0.5, 0.5)), draw(num(-0.5, 0.5))) for k in range(2)}
            text = "; ".join(f"point {k} ({x:.4g}, {y:.4g})" for k, (x, y) in pts.items())
            lines.append(f"body b{i} {{ mass {mass:.4g}; inertia {mass * draw(num(0.005, 0.1)):.4g}; "
                         f"{text} }}")
            bodies.append((f"b{i}", False, pts))
    sliding, turning = [], []
    for i, (name, particle, pts) in enumerate(bodies):
        parent = draw(st.integers(-1, i - 1))
        if parent < 0:
            anchor = "ground.origin"
        else:
            pname, pparticle, ppts = bodies[parent]
            anchor = f"{pname}.cm" if pparticle else f"{pname}.{draw(st.sampled_from(list(ppts)))}"
        mine = f"{name}.cm" if particle else f"{name}.{draw(st.sampled_from(list(pts)))}"
        on_particle = parent >= 0 and bodies[parent][1]      # a line needs a body that turns
        kinds = ["revolute", "distance"] + ([] if on_particle else ["point_on_line"]) \
            + ([] if particle or on_particle else ["prismatic"])
        kind = draw(st.sampled_from(kinds))
        j = f"J{i}"
        if kind == "revolute":
            lines.append(f"joint {j}: revolute({anchor}, {mine})")
            if not particle and not (parent >= 0 and bodies[parent][1]):
                turning.append(j)
        elif kind == "distance":
            lines.append(f"joint {j}: distance({anchor}, {mine}, length = {draw(num(0.2, 1.0)):.4g})")
        elif kind == "point_on_line":
            d = (draw(num(-1, 1)), draw(num(0.3, 1)))
            lines.append(f"joint {j}: point_on_line({mine}, {anchor}, direction = ({d[0]:.3g}, {d[1]:.3g}))")
            sliding.append(j)
        else:
            d = (draw(num(0.3, 1)), draw(num(-1, 1)))
            lines.append(f"joint {j}: prismatic({mine}, {anchor}, direction = ({d[0]:.3g}, {d[1]:.3g}), angle = 0)")
            sliding.append(j)
    names = [b[0] for b in bodies]
    for k in range(draw(st.integers(0, 3))):
        b = draw(st.sampled_from(names))
        a = draw(st.sampled_from(["ground"] + [x for x in names if x != b]))
        pa = "origin" if a == "ground" else "cm"
        lines.append(f"force s{k}: spring_damper({a}.{pa}, {b}.cm, k = {draw(num(1, 1e4)):.4g}, "
                     f"c = {draw(num(0, 5)):.3g}, length = {draw(num(0, 0.8)):.3g})")
    rigid = [b[0] for b in bodies if not b[1]]
    if rigid and draw(st.booleans()):
        lines.append(f"force t0: torque({draw(st.sampled_from(rigid))}, "
                     f"{draw(num(-2, 2)):.3g}*sin({draw(num(0.5, 10)):.3g}*t))")
    if rigid and draw(st.booleans()):     # a table of time and one of the body's speed
        b = draw(st.sampled_from(rigid))
        kind = draw(st.sampled_from(["linear", "pchip", "cubic", "akima"]))
        lines += [f"table tq(t) = [(0, 0), (0.05, {draw(num(-2, 2)):.3g}), (0.1, "
                  f"{draw(num(-2, 2)):.3g}), (0.2, 0)], interpolation = {kind}",
                  f"table drag(w) = [(-10, 2), (0, 0), (10, -2)], interpolation = {kind}, "
                  "extrapolation = linear",
                  f"force t1: torque({b}, tq(t) + drag({b}.omega))"]
    if turning and draw(st.booleans()):
        j = draw(st.sampled_from(turning))
        lines.append(f"force a0: joint_torque({j}, -{draw(num(1, 50)):.3g}*{j}.angle - "
                     f"{draw(num(0, 2)):.3g}*{j}.rate)")
    if sliding and draw(st.booleans()):
        j = draw(st.sampled_from(sliding))
        lines.append(f"force a1: joint_force({j}, {draw(num(-5, 5)):.3g}*cos(3*t) - {j}.speed)")
    if draw(st.booleans()):
        lines.append(f"force g0: force({draw(st.sampled_from(names))}.cm, "
                     f"({draw(num(-3, 3)):.3g}, {draw(num(-3, 3)):.3g}*t))")
    if rigid and draw(st.booleans()):     # a follower force in body axes, a drag on its point
        b = draw(st.sampled_from(rigid))
        lines.append(f"force h0: force({b}.cm, ({draw(num(-3, 3)):.3g} - 0.3*{b}.cm.vx*abs({b}.cm.vx), "
                     f"{draw(num(-3, 3)):.3g}*cos({b}.phi)), frame = body)")
    if turning and draw(st.booleans()):   # a PI controller with a filtered measurement
        j = draw(st.sampled_from(turning))
        lines += [f"state wf {{ der = ({j}.rate - wf)/{draw(num(0.005, 0.2)):.3g}; initial 0 }}",
                  f"state ie {{ der = {draw(num(-3, 3)):.3g} - wf; initial {draw(num(-1, 1)):.3g} }}",
                  f"force pi0: joint_torque({j}, {draw(num(0, 5)):.3g}*({draw(num(-3, 3)):.3g} - wf)"
                  f" + {draw(num(0, 20)):.3g}*ie)"]
    if (turning or sliding) and draw(st.booleans()):
        j = draw(st.sampled_from(turning + sliding))
        extra = ", radius = 0.01" if j in turning else ""
        lines.append(f"force f0: friction({j}, mu = {draw(num(0.01, 0.4)):.3g}{extra})")
    if draw(st.booleans()):
        lines.append(f"force c0: contact({draw(st.sampled_from(names))}.cm, radius = 0.05, "
                     f"line = (ground.origin, (1, 0)), k = {draw(num(1e4, 1e6)):.3g}, "
                     f"restitution = {draw(num(0.3, 1.0)):.3g})")
    if draw(st.booleans()):           # a gear pair on shafts of its own, meshed with the tree
        ga, gb = draw(num(0.01, 0.5)), draw(num(0.01, 0.5))
        lines += [f"body gA {{ mass 1; inertia {ga:.3g}; point e ({draw(num(-0.2, 0.2)):.3g}, 0) }}",
                  f"body gB {{ mass 1; inertia {gb:.3g} }}",
                  "ground { point GA (2, 0); point GB (2.5, 0) }",
                  "joint JA: revolute(ground.GA, gA.e)", "joint JB: revolute(ground.GB, gB.cm)"]
        turning += ["JA", "JB"]
        names += ["gA", "gB"]
    if len(turning) >= 2 and draw(st.booleans()):
        j1, j2 = draw(st.permutations(turning))[:2]
        ratio = draw(num(0.3, 4.0)) * draw(st.sampled_from([-1, 1]))
        lines.append(f"joint G0: gear({j1}, {j2}, ratio = {ratio:.3g})")
    if sliding and turning and draw(st.booleans()):
        lines.append(f"joint R0: rack({draw(st.sampled_from(sliding))}, "
                     f"{draw(st.sampled_from(turning))}, radius = {draw(num(0.02, 0.3)):.3g})")
    if draw(st.booleans()):
        b = draw(st.sampled_from(names))
        lines.append(f"force r0: rope(ground.origin, {b}.cm, length = ROPE*{draw(num(1, 1.3)):.3g}, "
                     f"k = {draw(num(1e2, 1e5)):.3g}, c = {draw(num(0, 50)):.3g})")
    if sliding and draw(st.booleans()):
        lines.append(f"force l0: limit({draw(st.sampled_from(sliding))}, upper = "
                     f"{draw(num(0.1, 0.5)):.3g}, k = 1e5, restitution = 0.5)")
    method = draw(st.sampled_from(METHODS))
    rtol = draw(st.sampled_from([None, None, 1e-4, 1e-6]))
    h = draw(st.sampled_from([1e-3, 2e-3, 5e-3]))
    lines.append(f"simulate {{ h {h:g}; t_end {150 * h:g} }}")
    return "\n".join(lines) + "\n", method, rtol, draw(st.booleans())


ROPE = re.compile(r"length = ROPE\*([0-9.e+-]+)")


def slack_rope(text):
    """The model with its rope's length the drawn factor (1 to 1.3) of the
    assembled distance of its body's centre from the origin: slack or just
    taut at the start. (A length drawn on its own, 0.48 m for a body 1 m
    away with k = 2e4 N/m, threw a body of 0.1 kg at 400 m/s: 6.5e6 steps at
    rtol 1e-6, 100 s for one example, a fifth of the suite.)"""
    m = ROPE.search(text)
    if m is None:
        return text
    body = re.search(r"rope\(ground\.origin, (\w+)\.cm", text).group(1)
    model = mbdsl.load_text(re.sub(r"force r0: rope\([^\n]*\n", "", text))
    system = mbdsl.assemble(model)
    q = mbdsl.consistent_initial_state(system).q
    b = next(x for x in model.bodies if x.name == body)
    d = float(np.hypot(*q[system.cmap.table[b.index, :2]]))
    return text.replace(m.group(0), f"length = {max(d, 0.05) * float(m.group(1))!r}")


def close_a_loop(text):
    """The model with a distance joint between two bodies' centres at their
    assembled distance (a closed loop, consistent at the start), or None."""
    model = mbdsl.load_text(text)
    if len(model.bodies) < 2:
        return None
    init = mbdsl.consistent_initial_state(mbdsl.assemble(model))
    cm = mbdsl.assemble(model).cmap
    a, b = model.bodies[-1], model.bodies[0]
    pa, pb = init.q[cm.table[a.index, :2]], init.q[cm.table[b.index, :2]]
    length = float(np.hypot(*(pa - pb)))
    if length < 1e-3:
        return None
    return text.replace("simulate", f"joint C: distance({a.name}.cm, {b.name}.cm, "
                                    f"length = {length!r})\nsimulate")


def check_mechanism(case):
    text, method, rtol, loop = case
    try:
        text = slack_rope(text)
        if loop:
            text = close_a_loop(text) or text
        model = mbdsl.load_text(text)
        sol = mbdsl.simulate(model, method=method, rtol=rtol, on_failure="return")
    except MbdError as exc:
        assert exc.diagnostics and all(d.code[0] in "EW" for d in exc.diagnostics), text
        return
    codes = [w.code for w in sol.warnings]
    if sol.status == "failed":
        assert sol.diagnostics and sol.diagnostics[0].code.startswith("E6"), (text, sol.message)
        return
    assert sol.status == "completed", (text, sol.status, sol.message)
    assert np.all(np.isfinite(sol.q)), text
    if energy_ratio(sol) > 0.01:
        assert "W602" in codes, (text, method, rtol)


@settings(max_examples=int(os.environ.get("MBDSL_SEMANTIC_FUZZ", 100)), deadline=None,
          derandomize=True, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(mechanisms())
def test_generated_mechanisms_are_right_or_refused(case):
    check_mechanism(case)


@pytest.mark.nightly
@pytest.mark.slow
@settings(max_examples=5000, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(mechanisms())
def test_generated_mechanisms_are_right_or_refused_nightly(case):
    check_mechanism(case)
