"""HHT-ADD on flexible beams: accurate where its explicit start-of-step
correction is small, refused with E603 where it is not
(``HHTADD.explicit_stiffness``)."""

from pathlib import Path

import numpy as np
import pytest

import mbdsl
from mbdsl.cli.main import main
from mbdsl.integrators.hht_add import HHTADD

ROOT = Path(__file__).resolve().parents[2]

CANTILEVER = """model cantilever   # a 10 m beam clamped at one end, released under gravity
flexible_beam beam {{ mass 12 kg; length 10 m; E 2.8e11 Pa; area 1e-4 m^2; second_moment 5e-8 m^4
                     elements 8; frame first_node }}
joint W: fixed(ground.origin, beam.start)
gravity (0, -{g})
"""


def _dense(a):
    return a.toarray() if hasattr(a, "toarray") else np.asarray(a)


def test_the_spinning_beam_at_ten_milliseconds_is_refused_with_e603(tmp_path, capsys):
    """models/spinup_beam.mbd with hht-add at its h = 1e-2 s: the run stops
    with E603 (exit 3) before the tip leaves HHT-I3's by 1 % of its peak,
    says why and what to use, and keeps its rows."""
    out = tmp_path / "spin.csv"
    code = main(["simulate", str(ROOT / "models" / "spinup_beam.mbd"), "--method", "hht-add",
                 "-q", "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 3
    assert "error[E603]" in err and "explicit stiffness" in err and "hht-i3" in err
    back = mbdsl.load_solution(out)
    assert back.status == "failed" and back.t[-1] > 1.0
    model = mbdsl.load(ROOT / "models" / "spinup_beam.mbd")
    ref = mbdsl.simulate(model, "hht-i3", 1e-2, back.t[-1])
    tip = back.column("beam.v8")
    peak = 0.4001                    # the exact beam's peak (tests/flexible/test_exact_reference)
    assert np.max(np.abs(tip - np.interp(back.t, ref.t, ref.column("beam.v8")))) < 0.01 * peak


def test_the_explicit_stiffness_is_the_spectral_radius_of_dr_dq():
    """kappa = h^2/2 rho(S), S = -M^-1 ((Phi_q^T psi)_q - (M y)_q), by power
    iteration, against numpy's eigenvalues of S formed densely, and S
    against a finite difference of r(q, psi) = -M(q)^-1 Phi_q(q)^T psi."""
    model = mbdsl.load_text(CANTILEVER.format(g=9.81))
    sol = mbdsl.simulate(model, "hht-i3", 1e-3, 0.3)
    system = mbdsl.assemble(model)
    q, lam, t = sol.q[-1], sol.lam[-1], sol.t[-1]

    def r(x):
        return -system.mass_solve(x, system.PhiqT_times(x, t, lam))

    eps = 1e-5                       # central differences: 5e-6 of the largest entry off
    S = np.column_stack([(r(q + eps * e) - r(q - eps * e)) / (2 * eps)
                         for e in np.eye(system.n)])
    y = system.mass_solve(q, system.PhiqT_times(q, t, lam))
    S_formula = -system.mass_solve(q, _dense(system.PhiqT_lam_q(q, lam))
                                   - _dense(system.Ma_q(q, y)))
    assert np.max(np.abs(S - S_formula)) < 1e-4 * np.max(np.abs(S))
    rho = np.max(np.abs(np.linalg.eigvals(S)))
    state = mbdsl.integrators.base.StepState(t, q, sol.v[-1], sol.a[-1], lam)
    h = 1e-2
    kappa = HHTADD().explicit_stiffness(system, state, h)
    assert kappa == pytest.approx(0.5 * h * h * rho, rel=1e-3)
    arpack = HHTADD()
    arpack.DENSE_EIGENVALUES = 0     # the large models' way: ARPACK on products with S
    assert arpack.explicit_stiffness(system, state, h) == pytest.approx(kappa, rel=1e-3)
    assert kappa > 1.0               # 5.5 here: the step is refused
    assert HHTADD().stability_check(system, state, h) is not None
    assert HHTADD().stability_check(system, state, 1e-3) is None


@pytest.mark.parametrize("g, h", [(0.981, 1e-3), (9.81, 3e-4)])
def test_below_the_limit_hht_add_follows_the_beam(g, h):
    """Where kappa stays below one (0.018 and 0.016 here), HHT-ADD completes
    without E603 and its tip follows HHT-I3's at a tenth of the step to
    0.1 % of the largest deflection (measured 0.010 % and 0.038 %)."""
    model = mbdsl.load_text(CANTILEVER.format(g=g))
    sol = mbdsl.simulate(model, "hht-add", h, 1.0)
    assert sol.completed, sol.message
    ref = mbdsl.simulate(model, "hht-i3", h / 10, 1.0)
    tip = np.interp(ref.t, sol.t, sol.column("beam.v8"))
    scale = np.max(np.abs(ref.column("beam.v8")))
    assert np.max(np.abs(tip - ref.column("beam.v8"))) < 1e-3 * scale
