"""Pass 12, the simulate section: the method by name, the formulation, positive
step, end time and tolerances, and each method coefficient in its range
(``registry.check_coefficient``). Diagnostics: E202 (given twice), E206 (an
unknown method), E303 (out of range), E304 (an unknown setting or formulation).
"""

from __future__ import annotations

from ...registry import METHOD_COEFFICIENTS, check_coefficient
from ..expressions import Name
from .context import did_you_mean
from .tables import KNOWN_METHODS, SETTINGS


def check_settings(c):
    """Check the simulate section (known method, positive h and t_end,
    method coefficients in range)."""
    c.settings = {}
    spans = {}
    for s in c.spec.settings:
        if s.name in c.settings:
            c.error("E202", f"simulate: '{s.name}' is given twice", s.span, "given again")
            continue
        if s.name == "method":
            if s.value not in KNOWN_METHODS:
                c.error("E206", f"simulate: unknown method '{s.value}'", s.span,
                        "unknown method", hint=did_you_mean(s.value, KNOWN_METHODS)
                        or f"methods are {', '.join(KNOWN_METHODS)}")
                continue
            c.settings["method"] = s.value
            continue
        if s.name == "formulation":         # formulation lagrange | augmented
            v = s.value
            if isinstance(v, Name) and v.name in ("lagrange", "augmented"):
                c.settings["formulation"] = v.name
            else:
                c.error("E304", "simulate: 'formulation' is 'lagrange' or 'augmented'",
                        getattr(v, "span", None) or s.span, "unknown formulation",
                        hint="'augmented' runs through singular positions and "
                        "redundant joints (newmark, hht-i3, nstiff, genalpha)")
            continue
        if s.name not in SETTINGS:
            c.error("E304", f"simulate: unknown setting '{s.name}'", s.span, "unknown setting",
                    hint=did_you_mean(s.name, list(SETTINGS) + ["method", "formulation"])
                    or f"settings are method, formulation, {', '.join(SETTINGS)}")
            continue
        v = c.number(s.value, s.span, f"simulate: {s.name}",
                     unit="s" if s.name in ("h", "t_end", "t_start", "output_dt")
                     else None if s.name == "atol" else "1")   # atol: m or rad
        if v is None:
            continue
        if SETTINGS[s.name] and v <= 0:
            c.error("E303", f"simulate: '{s.name}' must be positive, got {v:g}",
                    getattr(s.value, "span", None) or s.span, "not positive")
            continue
        c.settings[s.name] = v
        spans[s.name] = getattr(s.value, "span", None) or s.span
    _check_coefficients(c, spans)


def _check_coefficients(c, spans):
    """Method coefficients in their ranges, each against the methods that use
    it (alpha: the HHT family; beta, gamma: newmark; b: hht-add), so that a
    file never reaches the integrator with a value it would refuse."""
    st = c.settings
    groups, claimed = [], set()      # each coefficient against the first method taking it
    for method, coefs in METHOD_COEFFICIENTS.items():
        names = tuple(c for c in coefs if c not in claimed)
        claimed.update(names)
        if names:
            groups.append((method, names))
    for method, names in groups:
        given = {k: st[k] for k in names if k in st}
        if not given:
            continue
        gamma = st.get("gamma", METHOD_COEFFICIENTS["newmark"]["gamma"])
        try:
            for k, v in given.items():      # in the constructor's order: gamma, beta
                check_coefficient(k, v, gamma=gamma)
        except ValueError as exc:
            name = next(iter(given))
            c.error("E303", f"simulate: {exc}", spans.get(name), "out of range")
            for k in given:
                st.pop(k, None)
