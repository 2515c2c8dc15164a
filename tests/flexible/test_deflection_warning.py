"""W404: a flexible beam whose deflection leaves the small-deflection range
says so, once, with the time it happened.

Oracle: the spin-up beam of Kane, Ryan & Banerjee (1987) (10 m, EI = 14 000
N m^2, rho A = 1.2 kg/m) spun to 10 rad/s, far above its first bending
frequency (3.80 rad/s): the linear floating-frame beam has no geometric
stiffening and diverges (tip deflection -2.3e4 m at 9 s); the paper's
flexible slider crank deflects by millimetres and raises nothing.
"""

from pathlib import Path

import mbdsl
from mbdsl.cli.main import main

HERE = Path(__file__).parent
MODELS = Path(__file__).parents[2] / "models"


def test_a_beam_spun_above_its_first_frequency_is_reported_once():
    sol = mbdsl.simulate(mbdsl.load(HERE / "spinup_beam.mbd"))
    warnings = sol.run_warnings()
    assert [w.code for w in warnings] == ["W404"]
    w = warnings[0]
    assert "'beam'" in w.message and w.span.line == 5
    # the first stored time past 1 m (10 % of 10 m), before the divergence is total
    t_first = float(w.message.split("at t = ")[1].split(" s")[0])
    assert 3.0 < t_first < 8.0
    assert "largest" in w.message


def test_the_paper_s_flexible_slider_crank_raises_no_deflection_warning(capsys):
    assert main(["simulate", str(MODELS / "flexible_slider_crank.mbd"), "--t-end", "0.2",
                 "-q", "-o", "/dev/null"]) == 0
    assert "W404" not in capsys.readouterr().err
    sol = mbdsl.simulate(mbdsl.load(MODELS / "flexible_slider_crank.mbd"), t_end=0.2)
    assert sol.run_warnings() == []


def test_the_cli_prints_it(capsys, tmp_path):
    assert main(["simulate", str(HERE / "spinup_beam.mbd"), "-q", "-o",
                 str(tmp_path / "s.csv")]) == 0
    err = capsys.readouterr().err
    assert "warning[W404]" in err and "Traceback" not in err
