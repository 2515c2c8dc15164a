"""Components, instances and libraries: a model built from parts equals, bit for
bit, the same model written out by hand; parameters by path; diagnostics
through instances; imports; result files that rebuild without the library."""

import hashlib
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

import mbdsl
from mbdsl.cli.main import main
from mbdsl.dsl.parser import parse_text
from mbdsl.dsl.unparse import spec_text
from mbdsl.io.csvfile import read_csv_metadata

ROOT = Path(__file__).resolve().parents[2]
HERE = Path(__file__).parent / "components"


def _same_run(a, b):
    for field in ("t", "q", "v", "a", "lam"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=field)


@pytest.mark.parametrize("method", sorted(mbdsl.METHODS))
def test_slider_crank_of_two_library_links_is_the_flat_file_bit_for_bit(method):
    flat = mbdsl.load(ROOT / "models" / "slider_crank.mbd")
    parts = mbdsl.load(HERE / "slider_crank_parts.mbd")
    assert [b.name for b in parts.bodies] == ["crank.b", "rod.b"]
    a = mbdsl.simulate(flat, method=method, h=1e-3, t_end=2.0)
    b = mbdsl.simulate(parts, method=method, h=1e-3, t_end=2.0)
    assert len(a.t) == 2001
    _same_run(a, b)
    assert (len(flat.warnings), len(a.warnings)) == (len(parts.warnings), len(b.warnings))


def test_double_wishbone_of_one_arm_component_is_its_flat_version():
    model = mbdsl.load(HERE / "wishbone.mbd")
    flat = mbdsl.load(HERE / "wishbone_flat.mbd")
    for method in ("hht-i3", "hht-si2"):
        _same_run(mbdsl.simulate(model, method=method), mbdsl.simulate(flat, method=method))


def test_set_by_path_changes_only_that_instance():
    base = mbdsl.load(HERE / "wishbone.mbd")
    moved = mbdsl.load(HERE / "wishbone.mbd", {"upper.L": 0.28})
    bodies = {b.name: b for b in base.bodies}
    after = {b.name: b for b in moved.bodies}
    assert after["upper.b"].inertia == pytest.approx(1.5 * 0.28 ** 2 / 12, rel=1e-15)
    assert after["upper.b"].points["O"][0] == pytest.approx(0.14, rel=1e-15)
    assert moved.ground_points["upper.P"][0] == pytest.approx(0.35 - 0.28, rel=1e-15)
    for name in ("lower.b", "upright"):
        assert after[name].inertia == bodies[name].inertia
        assert all(np.array_equal(after[name].points[k], bodies[name].points[k])
                   for k in bodies[name].points)
    np.testing.assert_array_equal(moved.ground_points["lower.P"], base.ground_points["lower.P"])
    assert moved.parameters["upper.L"] == 0.28 and moved.parameters["lower.L"] == 0.35


def test_set_by_path_from_the_command_line(tmp_path, capsys):
    out = tmp_path / "w.csv"
    assert main(["simulate", str(HERE / "wishbone.mbd"), "--set", "upper.L=0.28", "-q",
                 "-o", str(out), "--t-end", "0.01"]) == 0
    sol = mbdsl.load_solution(out)
    assert sol.model.parameters["upper.L"] == 0.28
    assert main(["simulate", str(HERE / "wishbone.mbd"), "--set", "uper.L=0.28", "-q",
                 "-o", str(out)]) == 1
    err = capsys.readouterr().err
    assert "error[E201]: --set uper.L" in err and "did you mean 'upper.L'" in err


def test_chain_of_link_instances_in_a_for_block_is_the_shipped_chain():
    parts = mbdsl.load(HERE / "chain_parts.mbd", {"N": 100})
    flat = mbdsl.load(ROOT / "models" / "pendulum_chain.mbd", {"N": 100})
    assert len(parts.bodies) == 100 and parts.bodies[99].name == "link[100].b"
    _same_run(mbdsl.simulate(parts, t_end=0.02), mbdsl.simulate(flat, t_end=0.02))
    # an instance of a for block has its parameters by path too
    one = mbdsl.load(HERE / "chain_parts.mbd", {"N": 3, "link[2].L": 0.2})
    assert [b.points["B"][0] for b in one.bodies] == [0.05, 0.1, 0.05]


def test_nested_components_with_loops_equal_their_flat_version():
    model = mbdsl.load(HERE / "chains.mbd")
    flat = mbdsl.load(HERE / "chains_flat.mbd")
    assert [b.name for b in model.bodies] == [f"left.s[{j}].b" for j in (1, 2, 3)] + [
        "right.s[1].b", "right.s[2].b"]
    assert model.instances == {"left": "arms.Chain", "left.s[...]": "segments.Segment",
                               "right": "arms.Chain", "right.s[...]": "segments.Segment"}
    a, b = mbdsl.simulate(model), mbdsl.simulate(flat)
    _same_run(a, b)
    np.testing.assert_array_equal(a.column("output.right_tip"), b.column("sr[2].y"))
    assert set(model.imports) == {"lib/arms.mbd", "lib/segments.mbd"}


def test_check_lists_the_elements_by_instance(capsys):
    assert main(["check", str(HERE / "chains.mbd")]) == 0
    out = capsys.readouterr().out
    assert "left (arms.Chain): 3 bodies, 3 joints, 0 forces, 0 drivers" in out
    assert "right.s[...] (segments.Segment): 2 bodies, 0 joints" in out


def _cli(tmp_path, capsys, files, main_text):
    for name, text in files.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text)
    (tmp_path / "model.mbd").write_text(main_text)
    status = main(["simulate", str(tmp_path / "model.mbd"), "-q", "-o",
                   str(tmp_path / "out.csv"), "--t-end", "0.01"])
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return status, err


ARM = """library arm_parts
component Arm(L = 1 m, m = 1 kg) {
    body b { mass m; inertia m*L^2/12; point A (-L/2, 0); point B (L/2, 0) }
    joint J: revolute(ground.origin, b.C)
}
"""


def test_an_error_inside_an_imported_component_shows_the_instance_and_both_places(
        tmp_path, capsys):
    status, err = _cli(tmp_path, capsys, {"lib/arm_parts.mbd": ARM},
                       'model m\nimport "lib/arm_parts.mbd"\narm_parts.Arm upper(L = 0.4)\n')
    assert status == 1
    assert "joint 'upper.J': body 'upper.b' has no point 'C'" in err
    assert f"{tmp_path / 'lib' / 'arm_parts.mbd'}:4:38" in err      # the definition
    assert f"{tmp_path / 'model.mbd'}:3:15" in err                   # the instance
    assert "in 'upper', an instance of Arm" in err
    assert "4 |     joint J: revolute(ground.origin, b.C)" in err


@pytest.mark.parametrize("text, code, words", [
    ('model m\nimport "a.mbd"\n', "E109", "imports form a cycle"),
    ('model m\nimport "missing.mbd"\n', "E109", "cannot read the import 'missing.mbd'"),
    ('model m\nimport no_such_library\n', "E109", "MBDSL_PATH"),
    ('model m\nimport "body.mbd"\n', "E110", "declares more than components"),
    ('model m\nimport parts\nparts.Lnk a\n', "E201", "did you mean 'parts.Link'"),
    ('model m\nimport parts\nparts.Link a(Q = 1)\n', "E201", "has no parameter 'Q'"),
    ('model m\nimport parts\nparts.Link a(2)\n', "E305", "given by name"),
    ('model m\nimport parts\nparts.Link a(L = 2 kg)\n', "E307", "'L' is a length"),
    ('model m\ncomponent C(k) { body b { mass 1; inertia k } }\nC c\n', "E304",
     "does not give the parameter 'k'"),
    ('model m\nparameter g0 = 1\ncomponent C() { body b { mass g0; inertia 1 } }\nC c\n',
     "E201", "unknown name 'g0' in component C"),
    ('model m\nimport parts\nparts.Link a\nparts.Link a\n', "E202", "duplicate instance 'a'"),
    ('model m\nimport parts\nparts.Link upper\n'
     'joint J: revolute(ground.origin, uper.b.A)\n', "E201", "did you mean 'upper'"),
    ('model m\nimport parts\nparts.Link rod\nguess rod.bphi = 0.5\n', "E201",
     "'rod.bphi': Link has no parameter 'bphi'"),
    ('model m\ninitial a.b.c = 1\n', "E201", "unknown body 'a.b'"),
    ('library m\ncomponent C() { body b { mass 1; inertia 1 } }\n', "E110",
     "a library of components, not a model"),
])
def test_mistakes_with_components_and_imports_are_clean_errors(tmp_path, capsys, text, code,
                                                               words):
    files = {"a.mbd": 'library a\nimport "b.mbd"\n', "b.mbd": 'library b\nimport "a.mbd"\n',
             "body.mbd": "library body\nbody x { mass 1; inertia 1 }\n"}
    status, err = _cli(tmp_path, capsys, files, text)
    assert status == 1
    assert f"error[{code}]" in err and words in err, err


def test_a_result_file_rebuilds_its_model_without_the_library(tmp_path, monkeypatch):
    src = tmp_path / "work"
    shutil.copytree(HERE / "lib", src / "lib")
    shutil.copy(HERE / "chains.mbd", src / "chains.mbd")
    for suffix in (".csv", ".h5"):
        assert main(["simulate", str(src / "chains.mbd"), "-q", "-o",
                     str(src / f"out{suffix}")]) == 0
    alone = tmp_path / "alone"
    alone.mkdir()
    for suffix in (".csv", ".h5"):
        shutil.copy(src / f"out{suffix}", alone / f"out{suffix}")
    before = mbdsl.load_solution(src / "out.h5").column("right.s[2].b.phi")
    shutil.rmtree(src)
    monkeypatch.chdir(alone)
    for suffix in (".csv", ".h5"):
        sol = mbdsl.load_solution(alone / f"out{suffix}")
        assert [b.name for b in sol.system.model.bodies][-1] == "right.s[2].b"
        text = (HERE / "lib" / "arms.mbd").read_text()
        assert sol.system.model.imports["lib/arms.mbd"] == (
            text, hashlib.sha256(text.encode()).hexdigest())
        np.testing.assert_allclose(sol.column("right.s[2].b.phi"), before, rtol=0, atol=1e-12)
        assert sol.system.model.parameters["right.L"] == 0.2
    meta = read_csv_metadata(alone / "out.csv")[0]
    stored = json.loads(meta["imports"])
    assert set(stored) == {"lib/arms.mbd", "lib/segments.mbd"}
    assert all(v["sha256"] == hashlib.sha256(v["source"].encode()).hexdigest()
               for v in stored.values())


def test_components_from_python_equal_the_text_and_write_back():
    link = mbdsl.Component("Link", {"L": "1 m", "m": "1 kg"}, [mbdsl.BodySpec.rigid(
        "b", mass="m", inertia="m*L^2/12", points={"A": ("-L/2", 0), "B": ("L/2", 0)})])
    spec = mbdsl.ModelSpec(
        "slider_crank_py", parameters=[mbdsl.ParameterSpec("k", 100), mbdsl.ParameterSpec("c", 5)],
        gravity=(0, -9.81), components=[link],
        instances=[link("crank", L=0.3, m=3), link("rod", L=0.6, m=0.9)],
        joints=[mbdsl.JointSpec("O", "revolute", ["ground.origin", "crank.b.A"]),
                mbdsl.JointSpec("A", "revolute", ["crank.b.B", "rod.b.A"]),
                mbdsl.JointSpec("B", "point_on_line", ["rod.b.B", "ground.origin"],
                                {"direction": (1, 0)})],
        forces=[mbdsl.ForceSpec("spring", "spring_damper", ["ground.origin", "rod.b.B"],
                                {"k": "k", "c": "c", "length": 0})],
        initials=[mbdsl.InitialSpec("crank.b.phi", "3*pi/2"),
                  mbdsl.InitialSpec("crank.b.omega", 0),
                  mbdsl.InitialSpec("rod.b.phi", 0.5, guess=True)])
    model = mbdsl.from_spec(spec)
    text = mbdsl.load(HERE / "slider_crank_parts.mbd")
    _same_run(mbdsl.simulate(model, h=1e-3, t_end=0.5), mbdsl.simulate(text, h=1e-3, t_end=0.5))
    written = spec_text(spec)
    assert "component Link(L = 1 m, m = 1 kg) {" in written and "Link crank(L = 0.3, m = 3)" in written
    again = parse_text(written)
    assert [c.name for c in again.components] == ["Link"]
    assert [b.name for b in mbdsl.load_text(written).bodies] == ["crank.b", "rod.b"]
    # an instance of a library part from Python
    lib = mbdsl.ModelSpec("one", imports=[mbdsl.ImportSpec("parts")],
                          instances=[mbdsl.InstanceSpec.of("parts.Wheel", "w", r=0.2)],
                          bodies=[mbdsl.BodySpec.rigid("hub", 1, 0.1)])
    assert "import parts" in spec_text(lib)
    built = mbdsl.from_spec(lib)
    assert [b.name for b in built.bodies] == ["hub", "w.b"]
    assert built.bodies[1].inertia == pytest.approx(0.5 * 1 * 0.2 ** 2)
    # its text (a result file's source) rebuilds the same coordinates in the same order
    assert [b.name for b in mbdsl.load_text(spec_text(lib)).bodies] == ["hub", "w.b"]


def test_a_model_without_components_is_checked_as_before():
    from mbdsl.dsl.components import flatten
    spec = mbdsl.parse_file(ROOT / "models" / "pendulum_chain.mbd")
    assert flatten(spec).spec is spec
