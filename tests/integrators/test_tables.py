"""Tables: y(x) given by points, inline or from a data file, in any
expression of time or of the state.

Oracles: the closed form a table stands for (a motor's cubic torque-speed
curve, which a not-a-knot cubic spline through six of its points reproduces
exactly; the same curve through pchip, akima and linear interpolants, whose
runs stay within the bound |d omega| <= t max|d tau| / J that the
interpolation error allows); the same road bump written as a piecewise
function of time (``if``); a flywheel under a torque table of time,
piecewise linear, integrated in closed form (theta a piecewise cubic) at
second order; the language's diagnostics for every misuse, at the table's
line and column.
"""

import json
import math

import numpy as np
import pytest

import mbdsl
from mbdsl.errors import MbdModelError
from mbdsl.io import metadata

J = 0.2
W = (0.0, 3.0, 6.0, 9.0, 12.0, 15.0)


def torque(w):
    """The motor's curve [N m] at w [rad/s]: 20 N m at rest, none at 15 rad/s."""
    return 20.0 * (1.0 - w / 15.0) * (1.0 + 0.03 * w - 0.002 * w * w)


def motor(curve: str, interpolation: str = "cubic") -> str:
    return f"""model motor_map
table motor(w) = [{", ".join(f"({w!r} rad/s, {torque(w)!r} N*m)" for w in W)}], interpolation = {interpolation}
body fly {{ mass 1; inertia {J} }}
joint O: revolute(ground.origin, fly.cm)
force drive: torque(fly, {curve})
"""


POLY = "20*(1 - fly.omega/15)*(1 + 0.03*fly.omega - 0.002*fly.omega^2)"


@pytest.mark.parametrize("engine", ["compiled", "numpy"])
@pytest.mark.parametrize("method", ["hht-i3", "nstiff", "hht-si2", "genalpha"])
def test_a_cubic_table_of_a_cubic_curve_is_the_curve(method, engine):
    """Six points of a cubic through a not-a-knot cubic spline: the spline is
    the cubic, so the runs agree to round-off (1e-12), Newton's matrix (the
    table's slope) included."""
    runs = [mbdsl.simulate(mbdsl.load_text(motor(c)), method=method, h=1e-3, t_end=2.0,
                           engine=engine) for c in ("motor(fly.omega)", POLY)]
    assert runs[0].completed and runs[1].completed
    assert runs[0].column("fly.omega")[-1] > 14.0            # near the free speed
    np.testing.assert_allclose(runs[0].q, runs[1].q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(runs[0].v, runs[1].v, rtol=0, atol=1e-11)


@pytest.mark.parametrize("interpolation", ["linear", "pchip", "akima"])
def test_other_interpolants_stay_within_their_interpolation_error(interpolation):
    """|omega_table - omega_curve|(t) <= t max |tau_table - tau_curve| / J
    (both runs' torques differ by at most that), and the run is not the
    curve's (the interpolant is another function)."""
    from mbdsl.model.table import build_table
    T = 2.0
    table = build_table("m", W, [torque(w) for w in W], interpolation)
    grid = np.linspace(0.0, 15.0, 3001)
    gap = np.max(np.abs(table.values(grid) - torque(grid)))
    runs = [mbdsl.simulate(mbdsl.load_text(motor(c, interpolation)), method="hht-i3", h=1e-3,
                           t_end=T) for c in ("motor(fly.omega)", POLY)]
    # the curve's run at the table's rows (a linear table's steps also end on its
    # kinks), by the cubic Hermite interpolant of its omega and alpha (error h^4)
    from scipy.interpolate import CubicHermiteSpline
    curve = CubicHermiteSpline(runs[1].t, runs[1].column("fly.omega"),
                               runs[1].column("fly.alpha"))
    d = np.abs(runs[0].column("fly.omega") - curve(runs[0].t))
    assert np.all(d <= runs[0].t * gap / J + 1e-9)
    assert d.max() > 1e-6


ROAD = """# a bump 5 cm high over 1.25 m of road
x [m], z [mm]
0, 0
2, 0
2.25, 20
2.5, 45
2.75, 50
3, 30
3.25, 0
10, 0
"""

QUARTER = """model quarter_car   # a quarter car at 10 m/s over a bump
parameter v = 10            # [m/s]
{table}particle base {{ mass 1 }}
particle wheel {{ mass 40 }}
particle car {{ mass 300 }}
ground {{ point B0 (0, 0); point W0 (0, 0.3); point C0 (0, 0.8) }}
joint Pb: point_on_line(base.cm, ground.B0, direction = (0, 1))
joint Pw: point_on_line(wheel.cm, ground.W0, direction = (0, 1))
joint Pc: point_on_line(car.cm, ground.C0, direction = (0, 1))
driver lift: Pb.distance = {road}
force tyre: spring_damper(base.cm, wheel.cm, k = 2e5, c = 100, length = 0.3)
force suspension: spring_damper(wheel.cm, car.cm, k = 2e4, c = 1500, length = 0.5)
simulate {{ method hht-i3; h 1e-3; t_end 0.6 }}
"""


def _piecewise(xs, zs, x="v*t"):
    """The same profile as nested if()s of straight segments [m]."""
    out = "0"
    for i in range(len(xs) - 2, -1, -1):
        slope = (zs[i + 1] - zs[i]) / (xs[i + 1] - xs[i])
        out = f"if({x} < {xs[i + 1]!r}, {zs[i]!r} + {slope!r}*({x} - {xs[i]!r}), {out})"
    return out


@pytest.mark.parametrize("method", ["hht-i3", "newmark", "hht-si2"])
def test_a_quarter_car_over_a_measured_road_equals_the_piecewise_bump(method, tmp_path):
    """The road from a CSV (units in its header: mm) and the same bump as a
    piecewise function of time: the same run to round-off, both landing on
    the same kinks (six: where the wheel meets each measured point)."""
    (tmp_path / "road.csv").write_text(ROAD)
    (tmp_path / "quarter.mbd").write_text(QUARTER.format(
        table='table road(x) = "road.csv"\n', road="road(v*t)"))
    rows = [r.split(",") for r in ROAD.splitlines()[2:]]
    xs, zs = [float(a) for a, _ in rows], [float(b) / 1000 for _, b in rows]
    tab = mbdsl.simulate(mbdsl.load(tmp_path / "quarter.mbd"), method=method)
    pw = mbdsl.simulate(mbdsl.load_text(QUARTER.format(table="", road=_piecewise(xs, zs))),
                        method=method)
    assert tab.completed and pw.completed
    assert tab.column("car.y").max() - 0.8 > 0.01                 # the car feels the bump
    np.testing.assert_allclose(tab.q, pw.q, rtol=0, atol=1e-10)
    np.testing.assert_allclose(tab.column("base.y"), np.interp(10 * tab.t, xs, zs), atol=1e-12)
    for x in xs[1:-1]:                          # a step ends at each kink's time
        assert np.min(np.abs(tab.t - x / 10)) < 1e-9
    meta = json.loads(metadata(tab)["tables"])
    assert meta["road"]["source"] == "road.csv" and meta["road"]["interpolation"] == "linear"
    assert meta["road"]["x"] == xs and np.allclose(meta["road"]["y"], zs)
    assert len(meta["road"]["sha256"]) == 64


FLY = """model flywheel_table
table push(t) = [(0 s, 0 N*m), (0.3 s, 2 N*m), (0.55 s, -1 N*m), (1 s, 0.5 N*m)]
body fly { mass 1; inertia 0.5 }
joint O: revolute(ground.origin, fly.cm)
force drive: torque(fly, push(t))
"""


def _flywheel_exact(t):
    """theta(t) of I theta'' = tau(t), tau piecewise linear through FLY's
    points (hold after 1 s), from rest: twice-integrated segments."""
    pts = [(0.0, 0.0), (0.3, 2.0), (0.55, -1.0), (1.0, 0.5)]
    out = np.empty_like(t)
    for k, tk in enumerate(t):
        th, w = 0.0, 0.0
        for (a, ta), (b, tb) in zip(pts, pts[1:] + [(math.inf, 0.5)]):
            s = (tb - ta) / (b - a) if math.isfinite(b) else 0.0
            dt = min(tk, b) - a
            if dt <= 0:
                break
            th += w * dt + (ta * dt ** 2 / 2 + s * dt ** 3 / 6) / 0.5
            w += (ta * dt + s * dt ** 2 / 2) / 0.5
        out[k] = th
    return out


@pytest.mark.parametrize("method", ["hht-i3", "nstiff", "genalpha"])
def test_a_linear_table_of_time_keeps_second_order(method):
    """A torque table of time with kinks at 0.3 and 0.55 s (not on the step
    grid): the steps land on them, so halving h divides the error by 4."""
    model = mbdsl.load_text(FLY)
    errors = []
    for h in (1.6e-2, 8e-3):
        sol = mbdsl.simulate(model, method=method, h=h, t_end=1.5)
        errors.append(np.abs(sol.column("fly.phi") - _flywheel_exact(sol.t)).max())
        assert min(np.abs(sol.t - 0.3).min(), np.abs(sol.t - 0.55).min()) < 1e-9
    assert 1.8 < math.log2(errors[0] / errors[1]) < 2.3, errors


BASE = "model m\nbody b { mass 1; inertia 1 }\njoint O: revolute(ground.origin, b.cm)\n"


@pytest.mark.parametrize("text,code,where", [
    ('table r(x) = "missing.csv"', "E308", '"missing.csv"'),
    ('table r(x) = "bad.csv"', "E308", '"bad.csv"'),
    ("table r(x) = [(0, 1), (0, 2)]", "E303", "[(0, 1), (0, 2)]"),
    ("table r(x) = [(0, 1), (1, 2)], interpolation = spline", "E305", "spline"),
    ("table r(x) = [(0, 1), (1, 2)], smoothing = 2", "E304", "smoothing = 2"),
    ("table r(x) = [(0 s, 1), (1 m, 2)]", "E307", "1 m"),
    ("table sin(x) = [(0, 1), (1, 2)]", "E202", "sin"),
    ("table r(x) = [(0 s, 1 N*m), (1 s, 2 N*m)]\nforce f: torque(b, r(t + 3 m))", "E307", "r(t + 3 m)"),
])
def test_misused_tables_are_named_at_their_place(text, code, where, tmp_path):
    """A missing file, a malformed row (its line named), x not increasing,
    an unknown interpolation or option, points of two kinds, a built-in's
    name, a table of time read at a length."""
    (tmp_path / "bad.csv").write_text("t [s], F [N]\n0, 1\n0.5, 2\n1.0 abc\n")
    path = tmp_path / "m.mbd"
    path.write_text(BASE + text + "\n")
    with pytest.raises(MbdModelError) as err:
        mbdsl.load(path)
    diags = [d for d in err.value.diagnostics if d.severity == "error"]
    assert [d.code for d in diags] == [code], [str(d) for d in diags]
    line = (BASE + text).splitlines()[diags[0].span.line - 1]
    col = diags[0].span.column - 1
    assert line[col:col + len(where)] == where, (line, diags[0].span)
    if "bad.csv" in text:
        assert "line 4" in diags[0].message


def test_a_table_outside_its_points_holds_extends_or_stops():
    """hold: the end value; linear: along the end slope; error: the run stops
    with a message naming the table."""
    base = ("model m\nbody b { mass 1; inertia 1 }\njoint O: revolute(ground.origin, b.cm)\n"
            "table r(t) = [(0, 1), (0.5, 2)], extrapolation = EXT\n"
            "force f: torque(b, r(t))\n")
    hold = mbdsl.simulate(mbdsl.load_text(base.replace("EXT", "hold")), method="hht-i3", h=1e-2,
                          t_end=1.0)
    lin = mbdsl.simulate(mbdsl.load_text(base.replace("EXT", "linear")), method="hht-i3", h=1e-2,
                         t_end=1.0)
    # omega = int tau dt: 0.75 by 0.5 s, then +2 t (hold) or +(2 + 2 s) (linear)
    # (to the method's O(h^2) on a torque whose slope jumps; 0.25 apart)
    assert hold.column("b.omega")[-1] == pytest.approx(0.75 + 2 * 0.5, abs=1e-4)
    assert lin.column("b.omega")[-1] == pytest.approx(0.75 + 2 * 0.5 + 0.25, abs=1e-4)
    err = mbdsl.simulate(mbdsl.load_text(base.replace("EXT", "error")), method="hht-i3", h=1e-2,
                         t_end=1.0, on_failure="return")
    assert not err.completed
    assert "r(t)" in err.message or "table 'r'" in err.message, err.message


def test_the_language_docs_example_spins_up_as_its_text_says():
    """docs/language.md's motor map: J omega' = tau(omega), pchip through
    (0, 20), (10, 15), (15, 0) N m; the speed rises to the curve's zero,
    15 rad/s, and meanwhile omega(t) follows the quadrature t = J int dw /
    tau(w) of the same interpolant (scipy's, independently of the run's)."""
    import re
    from pathlib import Path

    from scipy.integrate import quad
    from scipy.interpolate import PchipInterpolator
    doc = (Path(__file__).resolve().parents[2] / "docs" / "language.md").read_text()
    (text,) = [b for b in re.findall(r"```\n(.*?)```", doc, re.S)
               if b.startswith("model motor_map")]
    sol = mbdsl.simulate(mbdsl.load_text(text))
    assert sol.completed and not sol.warnings
    tau = PchipInterpolator([0.0, 10.0, 15.0], [20.0, 15.0, 0.0])
    for w in (5.0, 10.0, 14.0):
        t_w = 0.2 * quad(lambda x: 1.0 / tau(x), 0.0, w)[0]
        assert np.interp(t_w, sol.t, sol.column("fly.omega")) == pytest.approx(w, rel=1e-5)
    assert 14.5 < sol.column("fly.omega")[-1] < 15.0 + 1e-9


@pytest.mark.parametrize("interpolation", ["linear", "pchip", "cubic", "akima"])
@pytest.mark.parametrize("extrapolation", ["hold", "linear", "error"])
def test_a_table_is_scipys_interpolant_inside_and_its_extrapolation_outside(interpolation,
                                                                          extrapolation):
    """Inside the points a table and its derivatives are scipy's interpolant's
    (numpy's interp for linear); outside, the end value (hold), the end
    tangent (linear) or NaN (error); the vectorised evaluation is the
    scalar one, bit for bit."""
    from scipy.interpolate import Akima1DInterpolator, CubicSpline, PchipInterpolator

    from mbdsl.model.table import build_table
    rng = np.random.default_rng(3)
    x, y = np.cumsum(rng.uniform(0.1, 1.0, 9)), rng.normal(size=9)
    table = build_table("r", x, y, interpolation, extrapolation)
    u = np.linspace(x[0], x[-1], 401)
    if interpolation == "linear":
        np.testing.assert_allclose(table.values(u), np.interp(u, x, y), atol=1e-13)
    else:
        ref = {"pchip": PchipInterpolator, "cubic": CubicSpline,
               "akima": Akima1DInterpolator}[interpolation](x, y)
        for order in range(4):
            np.testing.assert_allclose(table.values(u, order), ref(u, order), atol=1e-9)
    end, slope = table.value(x[-1]), table.value(x[-1], 1)
    beyond = table.value(x[-1] + 0.5)
    expected = {"hold": end, "linear": end + 0.5 * slope, "error": math.nan}[extrapolation]
    assert beyond == pytest.approx(expected, nan_ok=True)
    w = np.concatenate([rng.uniform(x[0] - 1, x[-1] + 1, 300), x, [np.nan]])
    for order in range(4):
        assert np.array_equal(table.values(w, order), [table.value(v, order) for v in w],
                              equal_nan=True)
