"""A flexible beam's number of elements is bounded: a mistyped ``elements
1e12`` (found by the mutation fuzzer on the flexible slider crank and the
spin-up beam) is refused at its place in the file, where it used to start
building a mesh whose strain data (N^3 numbers) no machine holds."""

from pathlib import Path

import pytest

import mbdsl
from mbdsl.dsl.check.bodies import MAX_BEAM_ELEMENTS

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("count", ["1e12", str(MAX_BEAM_ELEMENTS + 1)])
def test_too_many_elements_is_refused_where_it_is_written(count):
    text = (ROOT / "models" / "flexible_slider_crank.mbd").read_text()
    line = next(l for l in text.splitlines() if l.startswith("parameter N = 4"))
    with pytest.raises(mbdsl.MbdModelError) as err:
        mbdsl.load_text(text.replace(line, line.replace("= 4", f"= {count}", 1)), file="x.mbd")
    (d,) = [d for d in err.value.diagnostics if d.is_error]
    assert d.code == "E303" and "more than 300" in d.message
    beam = next(i for i, l in enumerate(text.splitlines(), 1) if l.startswith("flexible_beam rod"))
    assert d.span.line == beam and d.span.column > 1


def test_the_shipped_beams_are_within_the_limit():
    model = mbdsl.load(ROOT / "models" / "flexible_slider_crank.mbd",
                       {"N": str(MAX_BEAM_ELEMENTS)})
    assert model.flexible_bodies[0].elements == MAX_BEAM_ELEMENTS
