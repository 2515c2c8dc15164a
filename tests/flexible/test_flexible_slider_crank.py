"""The paper's flexible slider crank (sec. 4b): rigid limit, orders, energy error.

* Rigid limit: with E multiplied by 1e4 the rod is rigid for the crank's
  motion; ``crank.omega`` at T = 1 s must match the rigid slider crank with
  the same mass and inertia (a uniform rod m2, m2 L2^2/12) to 1e-4 rad/s.
* Orders (paper Fig. 4): error of ``crank.omega`` at T = 2 s against a
  reference by a *different* method at a step 16 times below the smallest:
  NSTIFF-SI2 for every method but itself, HHT-I3 for NSTIFF-SI2.
* eps(T) (paper Fig. 10): the average energy error of this conservative
  model falls at the method's order.

CI runs h = 2^-7 .. 2^-9 without HHT-ADD (about two minutes on two cores);
the slow test runs all six methods at 2^-8 .. 2^-10.
"""

import pytest

import mbdsl
from mbdsl.studies.study import StudyOptions, run_study

from ..conftest import MODELS

FLEX = MODELS / "flexible_slider_crank.mbd"
ROD = """flexible_beam rod { mass m2; length L2; E E; area S; second_moment I; elements N
                    frame chord; point A at start; point B at end; point M at L2/2 }"""
RIGID_ROD = "body rod { mass m2; inertia m2*L2^2/12; point A (-L2/2, 0); point B (L2/2, 0) }"


def test_rigid_limit():
    text = FLEX.read_text()
    assert ROD in text
    rigid = mbdsl.load_text(text.replace(ROD, RIGID_ROD))
    h = 1e-3

    def omega(model):
        """crank.omega at T = 1 s."""
        return mbdsl.simulate(model, "hht-i3", h=h, t_end=1.0).column("crank.omega")[-1]

    w_rigid = omega(rigid)
    diff = {f: omega(mbdsl.load(FLEX, overrides={"E": 200e9 * f})) - w_rigid
            for f in (1.0, 1e2, 1e4)}
    # measured: -1.04e-5, -9.1e-8, 1.2e-8 rad/s
    assert abs(diff[1e4]) < 1e-4
    # the elastic effect falls like 1/E: the printed rod's flexibility is seen,
    # and a hundred times stiffer rod shows a hundredth of it
    assert abs(diff[1.0]) > 5e-6
    assert 0.5 < diff[1.0] / diff[1e2] / 100 < 2


def _orders(methods, hs):
    """(convergence orders, energy orders) per method from two studies."""
    conv, energy = {}, {}
    plans = [([m for m in methods if m != "nstiff-si2"], "nstiff-si2"),
             (["nstiff-si2"], "hht-i3")]
    for methods, reference in plans:
        opts = StudyOptions(methods=methods, hs=hs, t_end=2.0, quantities=["crank.omega"],
                            reference=reference, jobs=2)
        result = run_study(("convergence", "energy"), FLEX, opts, log=lambda *_: None)
        for section in result.sections:
            table = {t.name: t for t in section.tables}
            if section.kind == "convergence":
                for row in table["convergence_orders"].rows:
                    conv[row[0]] = (row[1], row[2], row[3])
            else:
                for row in table["energy_orders"].rows:
                    energy[row[0]] = (row[1], row[2])
    return conv, energy


def _check(conv, energy, methods):
    print("orders (expected, crank.omega, points):", conv)    # shown with -s
    print("eps(T) orders (expected, fitted):", energy)
    assert set(conv) == set(methods)
    for method, (expected, order, fitted) in conv.items():
        assert fitted >= 3, (method, fitted)          # no point left out near the reference
        assert abs(order - expected) <= 0.2, (method, order)
    for method, (expected, order) in energy.items():
        assert abs(order - expected) <= 0.3, (method, order)


def test_orders_and_energy_error_ci():
    # HHT-ADD reaches its asymptotic range only below h = 2^-8 on this model
    # (measured errors 3.7e-4, 1.7e-4, 4.7e-5, 1.3e-5 at 2^-7 .. 2^-10):
    # it is checked by the slow test
    methods = [m for m in mbdsl.METHODS if m != "hht-add"]
    _check(*_orders(methods, [2 ** -7, 2 ** -8, 2 ** -9]), methods)


@pytest.mark.slow
def test_orders_and_energy_error_all_methods():
    methods = list(mbdsl.METHODS)
    _check(*_orders(methods, [2 ** -8, 2 ** -9, 2 ** -10]), methods)
