"""Why a run stopped, in the model's words: the diagnosis of a step that cannot
be taken (E601, E602), that the method cannot take stably (E603), or that
an event repeats faster than the steps (E605).

A step Newton cannot converge is explained by what made it fail, in this
order: the rows of a singular (or nearly singular) position of the linkage,
named from the Newton matrix's or Phi_q's smallest singular vector; an element
too stiff for the step (a spring's period or a contact's duration below four
steps); a body with nothing to resist its motion. The time loop
(``python_stepper.PythonStepper.diagnose``) calls :func:`fail` and :func:`fail_tolerance`;
``loop.TimeLoop`` calls :func:`fail_unstable`.
"""

from __future__ import annotations

import numpy as np

from ..errors import Diagnostic
from .newton import NewtonStatus

__all__ = ["fail", "fail_chatter", "fail_stalled", "fail_tolerance", "fail_unstable"]

_HINTS = {
    NewtonStatus.SINGULAR: "the Newton matrix is singular: the mechanism may be at a singular "
                           "(dead-centre) position, or joints may be redundant",
    NewtonStatus.DIVERGING: "Newton diverges: the step may be too large for the fastest motion "
                            "(a stiff spring, a fast driver); try a smaller h",
    NewtonStatus.MAX_ITER: "Newton converges too slowly: try a smaller h or full Newton",
    NewtonStatus.NONFINITE: "a value became infinite or NaN: check stiffnesses, masses and "
                            "driver functions for extreme values",
}


def _null_vector(method, ctx, w):
    """(s_min / s_max, right singular vector of s_min) of the Newton matrix at w
    (dense SVD; None for matrices too large to decompose densely)."""
    J = method.jacobian(w, ctx)
    if hasattr(J, "toarray"):
        if J.shape[0] > 3000:
            return None
        J = J.toarray()
    J = np.asarray(J, dtype=float)
    if not np.all(np.isfinite(J)):
        return None
    _, sv, vt = np.linalg.svd(J)
    return sv[-1] / max(sv[0], 1e-300), vt[-1]


def _near_singular_rows(system, ctx, ratio_limit=1e-3):
    """(s_min / s_max of Phi_q, the joints of its smallest left singular
    vector) at the last accepted configuration when the ratio is below
    ``ratio_limit`` (a mechanism a step away from a singular position, where
    Newton's matrix is not yet singular), else None. Dense SVD: None for more
    than 3000 rows or coordinates."""
    last = ctx.history[-1] if ctx.history else None
    if last is None or system.m == 0 or max(system.m, system.n) > 3000:
        return None
    with np.errstate(all="ignore"):
        A = system.Phi_q(last.q, ctx.t)
        if hasattr(A, "toarray"):
            A = A.toarray()
        if not np.all(np.isfinite(A)):
            return None
        u, sv, _ = np.linalg.svd(np.asarray(A, float))
    if len(sv) < system.m:               # more rows than coordinates: rank-deficient already
        return None
    ratio = sv[-1] / max(sv[0], 1e-300)
    if ratio >= ratio_limit:
        return None
    w = np.abs(u[:, -1])
    names = []
    for i in np.argsort(-w):
        if w[i] < 0.1 * w.max():
            break
        name = system.layout.rows[i][0]
        if name not in names:
            names.append(name)
    return ratio, names[:6]


def _spring_modes(system, h, state):
    """(spring, period [s], "period") of the modes of the linearization at
    ``state`` (a StepState: ``mbdsl.modes``) shorter than 4 h whose strain
    energy a spring holds; None where the spectrum is not available (more
    than ``modes.STEP_CHECK_LIMIT`` coordinates, or no state)."""
    from ..modes import STEP_CHECK_LIMIT, _dense_modes, _springs_in, linearize
    if state is None or system.n > STEP_CHECK_LIMIT:
        return None
    try:
        with np.errstate(all="ignore"):
            lin = linearize(system, state.t, state.q, state.v, state.a, state.lam)
            _, found = _dense_modes(lin, None, False)
    except (np.linalg.LinAlgError, ValueError, FloatingPointError):
        return None
    out, named = [], set()
    for mo in sorted(found, key=lambda m: -m.omega):
        if not mo.stable or not mo.omega > 0.0 or 2.0 * np.pi / mo.omega >= 4.0 * h:
            continue
        springs = _springs_in(system, state.q, lin, mo.shape)
        if springs and springs[0][0] not in named:
            named.add(springs[0][0])
            out.append((springs[0][0], 2.0 * np.pi / mo.omega, "period"))
    return out


def _stiff_elements(system, h, v=None, state=None):
    """Elements too stiff for the step h [s]: (name, time [s], what) sorted by time.

    Springs (translational, rotational) whose mode is shorter than 4 h:
    from the spectrum at the last accepted ``state`` where it is available
    (:func:`_spring_modes`: the mode's period, and the spring that holds its
    strain energy), else from a one-body estimate 2 pi sqrt(m/k) (the lighter
    attached mass or inertia); and contacts and limits whose contact duration
    (:func:`~mbdsl.model.contact.contact_duration`, at the relative speed of
    the two bodies in ``v``, shape (n,), the last accepted velocities) is
    shorter than 4 h: fewer than four steps in it. ``what`` names the time
    ("period" or "contact duration").
    """
    from ..model.contact import Contact, contact_duration
    out = []
    model = system.model
    vx = np.zeros(system.n + 3)
    if v is not None:
        vx[:system.n] = v

    def masses(bodies, rotational):
        """The inertias [kg m^2] (``rotational``) or masses [kg] of the bodies
        that are not the ground."""
        return [model.bodies[b].inertia if rotational else model.bodies[b].mass
                for b in bodies if b >= 0]

    from_spectrum = _spring_modes(system, h, state)
    if from_spectrum is not None:
        out += from_spectrum
    for f in model.forces:
        k = getattr(f, "k", None)
        if not k:
            continue
        if from_spectrum is not None and not isinstance(f, Contact):
            continue
        if isinstance(f, Contact):
            for geometry, data, _ in f.gaps:
                rotational = geometry == "angle"
                inertia = masses((data[0], data[2]), rotational)
                if not inertia:
                    continue
                c = system.cmap([data[0], data[2]])
                dv = vx[c[1]] - vx[c[0]]
                speed = abs(dv[2]) if rotational else float(np.hypot(dv[0], dv[1]))
                duration = contact_duration(k, f.exponent, min(inertia), speed)
                if duration < 4.0 * h:
                    out.append((f.name, duration, "contact duration"))
            continue
        if hasattr(f, "joint"):                      # rotational: k [N m/rad] over inertia
            inertia = masses((f.joint.first.body, f.joint.second.body), True)
        else:
            inertia = masses((f.first.body, f.second.body), False)
        if inertia:
            period = 2.0 * np.pi * np.sqrt(min(inertia) / k)
            if period < 4.0 * h:
                out.append((f.name, period, "period"))
    return sorted(out, key=lambda x: x[1])


def fail_tolerance(sol, method, control, t, step, err):
    """Stop a run whose local error stays above the tolerance at the smallest step."""
    msg = (f"the step from t = {t:.6g} s cannot meet the error tolerance with "
           f"{method.describe()}: at the smallest step h = {step:.3g} s its local error per "
           f"unit step is {err:.3g} times the tolerance (rtol = {control.rtol:g}, "
           f"atol = {control.atol:g} per second)")
    _stop(sol, "E602", msg,
          "a force or driver with a jump or a kink at this time (the error does not shrink "
          "with h there), or a tolerance below the round-off of q: loosen rtol/atol")


def _stop(sol, code, msg, hint, span=None, label=""):
    """The run failed: its status and message, and the one diagnostic saying why."""
    sol.status, sol.message = "failed", msg
    sol.diagnostics = [Diagnostic("error", code, msg, span, label, hint=hint)]


def fail_unstable(sol, msg, hint):
    """Stop a run whose method says it cannot go on stably (E603;
    ``Method.stability_check``): the message says why, the hint what to use."""
    _stop(sol, "E603", msg, hint)


def fail_stalled(sol, method, t0, t, steps, h):
    """Stop an error-controlled run whose steps stay collapsed (E604)."""
    msg = (f"the error-controlled steps of {method.describe()} stayed collapsed: {steps} "
           f"steps from t = {t0:.6g} s to {t:.6g} s, {(t - t0) / max(steps, 1):.3g} s each "
           f"against the nominal h = {h:g} s")
    _stop(sol, "E604", msg,
          "a switch the error estimate chases (friction sticking and slipping, a force with "
          "a kink) or a part of the model the steps cannot resolve: a looser tolerance, "
          "fixed steps, or smoothing the switch")


def fail_chatter(sol, t, spring, passes, span):
    """Stop a run whose spring's points keep passing each other (E605): its
    points stay together, where the force's direction is not defined."""
    msg = (f"spring '{spring}' passed through zero length {passes} times in {span:.3g} s "
           f"(up to t = {t:.6g} s), faster than the steps can follow: its points stay "
           f"together, where the direction of its force is not defined")
    where = next((f.span for f in sol.system.model.forces if f.name == spring), None)
    _stop(sol, "E605", msg,
          "attach the spring's ends to points that move apart (two points a joint holds at "
          "one place never do), or give it free length 0 (a force that vanishes with the "
          "length, as a spring to a fixed point does)",
          where, "its points stay together" if where else "")


def fail(sol, method, ctx, res, t, step, h):
    """Stop a run at a step Newton could not converge (E601), in the model's
    words: a singular position (the rows of the Newton matrix's or Phi_q's
    smallest singular vector), an element too stiff for the step
    (:func:`_stiff_elements`), or a free motion; ``res`` the Newton result,
    ``step`` the last size tried [s], ``h`` the size it was halved from [s]."""
    system = ctx.system
    detail, span = _worst_residual(system, method, ctx, res)
    hint = _HINTS.get(res.status, "")
    try:
        with np.errstate(all="ignore"):        # at the last accepted state: finite, meaningful
            svd = _null_vector(method, ctx, method.predict(ctx))
    except (FloatingPointError, ValueError, np.linalg.LinAlgError):
        svd = None
    # 1e-6: a step failing next to a singular position (the N-four-bar's
    # Newton matrix at its last accepted state: 2e-7) is told so
    near_singular = svd is not None and svd[0] < 1e-6
    stiff = []
    if res.status in (NewtonStatus.DIVERGING, NewtonStatus.MAX_ITER):
        last = ctx.history[-1] if ctx.history else None
        stiff = _stiff_elements(system, step, getattr(last, "v", None), last)
    found = None
    if res.status is NewtonStatus.SINGULAR or near_singular:
        found = _singular_direction(system, method, res, svd, near_singular, bool(stiff))
    if found is None and not stiff and res.status in (NewtonStatus.DIVERGING,
                                                      NewtonStatus.MAX_ITER):
        found = _near_singular_rows_explained(system, method, ctx)
    if found is None and stiff:
        found = _too_stiff(system, method, stiff, step)
    if found is None and res.status is NewtonStatus.NONFINITE:
        found = _nonfinite_function(system, ctx, t, step)
    if found is not None:
        more, where, hint = found
        detail += more
        span = where or span
    msg = (f"the step from t = {t:.6g} s could not converge with {method.describe()} "
           f"(h = {step:.3g} s after halving from {h:.3g} s): {res.status.value}; "
           f"{_norms_text(res.norms)}{detail}")
    _stop(sol, "E601", msg, hint, span, "involved here" if span else "")


def _nonfinite_function(system, ctx, t, step) -> tuple | None:
    """(text, span, hint) naming the first load or driver whose function is
    not finite at the step's end (the last accepted state, at t + step), and
    a table it reads outside its points (``extrapolation = error``); None
    where every one is finite."""
    from ..dsl.expressions import TableCall, compile_function, compile_state_function
    from ..dsl.unparse import expr_text
    last = ctx.history[-1] if ctx.history else None
    if last is None:
        return None
    cmap = system.cmap
    qx, vx = (np.concatenate([np.asarray(a, float), np.zeros(3)]) for a in (last.q, last.v))
    te = t + step

    def calls(e):
        """The TableCall nodes of an expression."""
        if isinstance(e, TableCall):
            yield e
        for child in vars(e).values() if hasattr(e, "__dataclass_fields__") else ():
            if hasattr(child, "__dataclass_fields__"):
                yield from calls(child)
    elements = list(system.model.drivers) + list(system.model.loads)
    for el in elements:
        for fn in getattr(el, "functions", None) or (getattr(el, "function", None),):
            if fn is None or getattr(fn, "expr", None) is None:
                continue
            variables = getattr(fn, "variables", ())
            names = tuple(v.name for v in variables)
            try:
                with np.errstate(all="ignore"):
                    x = np.array([v.value(qx, vx, cmap) for v in variables])

                    def at(e):
                        """The expression e of t and the variables at (t + step, x)."""
                        return (compile_state_function(e, names)(te, x) if names
                                else compile_function(e)(te))
                    if np.isfinite(at(fn.expr)):
                        bad = [v.name for v, g in zip(variables, getattr(fn, "grad_exprs", ()))
                               if not np.isfinite(at(g))]
                        if not bad:
                            continue
                        return (f"; the derivative of {el.name}'s {expr_text(fn.expr)} with "
                                f"respect to {bad[0]} is not finite at t = {te:.6g} s",
                                getattr(el, "span", None),
                                "Newton's matrix needs it: sqrt(x) has none at x = 0 "
                                "(write sqrt(x + eps)), abs(x) is kinked but finite")
                    for call in calls(fn.expr):
                        tab, u = call.table, at(call.arg)
                        if tab.extrapolation == "error" and not tab.x[0] <= u <= tab.x[-1]:
                            return (f"; table '{tab.name}' is read at {u:.6g}, outside its "
                                    f"points [{tab.x[0]:.6g}, {tab.x[-1]:.6g}] "
                                    f"(extrapolation = error), by {el.name}",
                                    getattr(el, "span", None),
                                    "extend the table's points, or let it hold or extend "
                                    "its end values (extrapolation = hold | linear)")
            except (ValueError, TypeError, ZeroDivisionError, OverflowError):
                continue
            return (f"; {el.name}'s value {expr_text(fn.expr)} is not finite at t = {te:.6g} s",
                    getattr(el, "span", None),
                    "a division by zero, a root of a negative number or a derivative "
                    "that does not exist there (sqrt at 0): reformulate the expression")
    return None


def _worst_residual(system, method, ctx, res) -> tuple:
    """(text, span) of the largest constraint residual at Newton's last
    iterate, or ("", None) where it cannot be evaluated."""
    try:
        with np.errstate(all="ignore"):
            state = method.accept(res.w, ctx)
            phi = system.Phi(state.q, ctx.t)
        if np.all(np.isfinite(phi)) and system.m:
            name, value = system.layout.worst_element(phi)
            return (f"; the largest constraint residual is at '{name}' ({value:.3g})",
                    system.layout.span_of(name))
    except (FloatingPointError, ValueError, ZeroDivisionError, np.linalg.LinAlgError):
        pass
    return "", None


def _augmented_advice(method) -> str:
    """The augmented formulation as a way through a singular position, where
    the method takes it and runs without it."""
    return ("--formulation augmented goes through such positions, or "
            if method.accepts_augmented and method.formulation == "lagrange" else "")


def _singular_direction(system, method, res, svd, near_singular, stiff) -> tuple | None:
    """(text, span, hint) from the Newton matrix's singular direction: the
    rows of dependent joints (a singular position), or coordinates no joint
    holds (a free motion; unless an element is too stiff, the likelier
    cause); None when it names neither."""
    from ..assembly.structure import involved_names
    null = svd[1] if svd is not None else None
    coords, elements = involved_names(system, method, null) if null is not None else ([], [])
    nearly = (f"; the Newton matrix is nearly singular (s_min/s_max = {svd[0]:.1e})"
              if near_singular and res.status is not NewtonStatus.SINGULAR else "")
    if elements:
        detail = nearly + ("; the singular direction involves the rows of "
                           + ", ".join(f"'{e}'" for e in elements)
                           + (" and the coordinates " + ", ".join(coords) if coords else ""))
        hint = (f"the equations of {', '.join(repr(e) for e in elements)} become "
                "dependent here: a singular (dead-centre or locked) position of the "
                "linkage, e.g. a crank and rod in line; " + _augmented_advice(method)
                + "start elsewhere, drive past it with a motion, or check the joint "
                "geometry")
        return detail, system.layout.span_of(elements[0]), hint
    if coords and not stiff:
        # a stiff element also makes the matrix nearly singular (k h^2
        # against a small inertia): then the stiffness is the cause
        return (nearly + "; the singular direction involves " + ", ".join(coords), None,
                "no joint holds these coordinates: a body with no mass or inertia in "
                "that direction, or a free motion with nothing to resist it")
    return None


def _near_singular_rows_explained(system, method, ctx) -> tuple | None:
    """(text, span, hint) when Phi_q is nearly rank-deficient at the last
    accepted state (:func:`_near_singular_rows`), else None."""
    near = _near_singular_rows(system, ctx)
    if near is None:
        return None
    ratio, elements = near
    detail = (f"; Phi_q is nearly rank-deficient at the last accepted state "
              f"(s_min/s_max = {ratio:.1e}) in the rows of "
              + ", ".join(f"'{e}'" for e in elements))
    hint = (f"the mechanism is close to a singular position, where the equations of "
            f"{', '.join(repr(e) for e in elements)} become dependent: a smaller step "
            "does not help there; " + _augmented_advice(method)
            + "start elsewhere, drive past it with a motion, or check the joint geometry")
    return detail, system.layout.span_of(elements[0]), hint


def _too_stiff(system, method, stiff, step) -> tuple:
    """(text, span, hint) for the stiffest element (:func:`_stiff_elements`):
    a contact shorter than four steps, or a period the step cannot follow,
    with the remedy the method has left."""
    name, time, what = stiff[0]
    alpha = getattr(method, "alpha", None)
    rho_inf = getattr(method, "rho_inf", None)
    detail = ""
    if what == "contact duration":
        detail = (f"; contact '{name}' lasts about {time:.2g} s an impact, "
                  f"shorter than four steps of h = {step:.2g} s")
        hint = (f"'{name}' is too stiff for the step: use error control (--rtol), which "
                f"lands on the contact and steps through it, a step below {time / 4:.2g} s, "
                "or a softer contact (smaller k)")
    else:
        if alpha is not None and alpha <= -0.3 + 1e-9:      # that advice is followed
            remedy = ("use a smaller h (alpha is already -0.3, the most damping HHT "
                      "allows), or nstiff / nstiff-si2, which damp such a mode more")
        elif rho_inf is not None and rho_inf <= 1e-12:
            remedy = ("use a smaller h (rho_inf is already 0: such a mode is removed in "
                      "one step where the step resolves nothing of it)")
        else:
            remedy = ("use a smaller h, or a method with numerical damping "
                      "(hht-i3/hht-si2 with alpha = -0.3, genalpha/genalpha-si2 with "
                      "rho_inf = 0)")
        hint = (f"'{name}' oscillates with a period of about {time:.2g} s, "
                f"shorter than the step can follow (h = {step:.2g} s): {remedy}")
    span = next((f.span for f in system.model.forces if f.name == name), None)
    return detail, span, hint


def _norms_text(norms) -> str:
    """Newton's residual norms as a user reads them: where they started and
    where they ended (the trend is what helps)."""
    k = len(norms)
    if k == 0:
        return "no Newton iteration"
    if k <= 2:
        return "Newton norms " + ", ".join(f"{x:.2g}" for x in norms)
    return f"Newton norm {norms[0]:.2g} -> {norms[-1]:.2g} in {k} iterations"
