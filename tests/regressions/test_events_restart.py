"""Non-smooth events restart every method: a spring whose points pass each
other (its force's direction jumps), against a reduced-coordinate reference."""

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import mbdsl

MODEL = Path(__file__).resolve().parent / "models" / "spring_pass.mbd"
MB, MP, L, K, L0, G = 1.0, 0.5, 0.5, 50.0, 0.2, 9.81
T_END = 1.2


def _rhs(t, y, side):
    """The block x on its guide and the pendulum's angle th from the
    vertical, Lagrange's equations in (x, th): M(th) [x'', th''] = Q with the
    spring's force -k (|x| - l0) sign(x), sign(x) = ``side`` on this branch."""
    x, th, xd, thd = y
    c, s = np.cos(th), np.sin(th)
    ic = MP * L ** 2 / 12
    M = np.array([[MB + MP, MP * L / 2 * c], [MP * L / 2 * c, MP * L ** 2 / 4 + ic]])
    Q = np.array([-K * (abs(x) - L0) * side + MP * L / 2 * s * thd ** 2, -MP * G * L / 2 * s])
    acc = np.linalg.solve(M, Q)
    return [xd, thd, acc[0], acc[1]]


def reference(t_end=T_END):
    """(x, th, x', th') at t_end by DOP853 at 1e-13, restarted on the new
    branch at each root of x (located by solve_ivp's events)."""
    t, y, side, direction = 0.0, np.array([0.3, 0.3, -2.0, 0.0]), 1.0, 0.0
    passes = []
    while t < t_end:
        def crossing(t, y, side):
            return y[0]
        crossing.terminal, crossing.direction = True, direction
        r = solve_ivp(_rhs, (t, t_end), y, args=(side,), method="DOP853", rtol=1e-13,
                      atol=1e-13, events=crossing)
        t, y = r.t[-1], r.y[:, -1]
        if r.status == 1:
            passes.append(t)
            side, direction = -side, -np.sign(y[2])
    return y, passes


@pytest.fixture(scope="module")
def ref():
    return reference()


def _state(sol):
    return np.array([sol.column("block.x")[-1], sol.column("pend.phi")[-1] + np.pi / 2,
                     sol.column("block.vx")[-1], sol.column("pend.omega")[-1]])


def test_the_reference_passes_twice(ref):
    y, passes = ref
    assert len(passes) == 2 and passes[1] < T_END - 0.1


SECOND_ORDER = ["hht-i3", "nstiff", "nstiff-si2", "hht-add", "hht-si2", "genalpha",
                "genalpha-si2"]


@pytest.mark.parametrize("method", SECOND_ORDER)
def test_a_spring_passing_zero_length_keeps_second_order(ref, method):
    """Fixed steps 4, 2, 1, 0.5 ms over two passes: the error of (x, th, x',
    th') at 1.2 s falls at order 2 +- 0.2: kept across the passes only if the
    steps landed on a pass continue the spring's old branch (a held
    direction) and the method restarts on the new one after it."""
    model = mbdsl.load(MODEL)
    hs = [4e-3, 2e-3, 1e-3, 5e-4]
    errors = [np.max(np.abs(_state(mbdsl.simulate(model, method=method, h=h, t_end=T_END))
                            - ref[0])) for h in hs]
    order = np.polyfit(np.log(hs), np.log(errors), 1)[0]
    assert order == pytest.approx(2.0, abs=0.2), errors


@pytest.mark.parametrize("method", ["newmark", "hht-i3", "nstiff", "nstiff-si2", "hht-add",
                                    "hht-si2", "genalpha", "genalpha-si2"])
@pytest.mark.parametrize("rtol", [None, 1e-6])
def test_every_landed_pass_changes_the_side(method, rtol):
    """The event is the side change itself: each pass lies within the event
    tolerance (1e-6 h) of a step's start or end, the rows around it are on
    the two sides, and x changes side nowhere else (no step crosses
    unlanded)."""
    h = 1e-3
    sol = mbdsl.simulate(mbdsl.load(MODEL), method=method, h=h, t_end=T_END, rtol=rtol)
    t, x = sol.t, sol.column("block.x")
    passes = [e[0] for e in sol.events if e[2] == "passed"]
    assert len(passes) == 2
    changes = np.flatnonzero(np.sign(x[1:]) != np.sign(x[:-1])) + 1
    assert len(changes) == 2
    for row, t_pass in zip(changes, passes):
        assert t[row - 1] <= t_pass <= t[row]
        assert min(t_pass - t[row - 1], t[row] - t_pass) <= 1e-6 * h + 1e-12


def test_hht_add_lands_a_closing_where_the_others_do():
    """HHT-ADD's carried acceleration is the applied forces' only: the free
    flight to a closing reads the index-1 acceleration, so the pendulum
    reaches its stop within half a step of HHT-SI2 (h = 1e-4; it was 1.6
    steps late reading its applied-force acceleration alone)."""
    model = mbdsl.load(MODEL.parents[2].parent / "models" / "pendulum_stop.mbd", {"e": 1.0})
    a, b = (mbdsl.simulate(model, method=m, h=1e-4, t_end=0.3) for m in ("hht-add", "hht-si2"))
    closed = [[e[0] for e in s.events if e[2] == "closed"][0] for s in (a, b)]
    assert closed[0] == pytest.approx(closed[1], abs=5e-5)
