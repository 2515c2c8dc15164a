"""Modal reduction of flexible beams (``modes K``, ``model/beam.ModalMesh``).

Checked against independent numbers: Euler-Bernoulli's cantilever
frequencies (beta_i L = 1.875104, 4.694091, 7.854757), the full mesh's own
eigenvalues, and runs of the same models with the nodal coordinates.
"""

import numpy as np
import pytest
import scipy.linalg

import mbdsl

from ..conftest import MODELS

SPINUP = (MODELS / "spinup_beam.mbd").read_text()
SLIDER = (MODELS / "flexible_slider_crank.mbd").read_text()


def _with(text, extra, stiffening=True):
    text = text.replace("elements 8", f"elements 8; {extra}") if "elements 8" in text else \
        text.replace("elements N", f"elements N; {extra}")
    return text if stiffening else text.replace("frame first_node", "frame first_node; "
                                                "stiffening off").replace(
        "frame chord", "frame chord; stiffening off")


@pytest.mark.parametrize("stiffening", [False, True])
def test_modes_are_the_cantilever_frequencies(stiffening):
    """The spin-up beam (10 m, EI = 14000 N m^2, rho A = 1.2 kg/m, 8
    elements, clamped frame) with 3 modes: its bending frequencies are the
    Euler-Bernoulli cantilever's to the mesh's accuracy, and the lowest of
    the full mesh's own eigenproblem."""
    model = mbdsl.load_text(_with(SPINUP, "modes 3", stiffening), "m.mbd")
    beam = model.flexible_bodies[0]
    mesh = beam.mesh
    scale = np.sqrt(14000.0 / (1.2 * 10.0 ** 4))
    exact = np.array([1.875104, 4.694091, 7.854757]) ** 2 * scale   # 3.798, 23.80, 66.64 rad/s
    assert mesh.frequencies == pytest.approx(exact, rel=2e-3)
    # the reduced stiffness and mass give the same frequencies back
    s = mesh.shape_integrals(beam.mass / beam.length)
    K = mesh.stiffness(beam.E * beam.area, beam.E * beam.second_moment)
    bend = [i for i, name in enumerate(mesh.names) if name.startswith("eta")]
    w2 = scipy.linalg.eigh(K[np.ix_(bend, bend)], s.M_ff[np.ix_(bend, bend)], eigvals_only=True)
    assert np.sqrt(w2) == pytest.approx(mesh.frequencies, rel=1e-9)
    full = mesh.mesh
    sf = full.shape_integrals(beam.mass / beam.length)
    wf = np.sqrt(scipy.linalg.eigh(full.stiffness(beam.E * beam.area,
                                                  beam.E * beam.second_moment),
                                   sf.M_ff, eigvals_only=True))
    assert np.all(np.isin(np.round(mesh.frequencies, 6), np.round(wf, 6)))
    # coordinates: 3 modes, plus the 8 axial nodal ones with geometric stiffening
    assert beam.n_elastic == (3 + 8 if stiffening else 3)
    assert mesh.names[:3] == ["eta1", "eta2", "eta3"]


@pytest.mark.parametrize("stiffening, modes", [(False, 12), (True, 8)])
def test_every_mode_kept_is_the_nodal_beam(stiffening, modes):
    """All the modes span the nodal coordinates: the flexible slider crank
    runs as with them, to round-off of the change of basis."""
    T = 0.3
    nodal = mbdsl.simulate(mbdsl.load_text(_with(SLIDER, "", stiffening), "n.mbd"), t_end=T)
    modal = mbdsl.simulate(mbdsl.load_text(_with(SLIDER, f"modes {modes}", stiffening),
                                           "m.mbd"), t_end=T)
    assert modal.q.shape[1] == nodal.q.shape[1] == 18
    for col in ("crank.phi", "crank.omega", "rod.phi", "rod.deflection_mid"):
        ref = nodal.column(col)
        assert np.max(np.abs(modal.column(col) - ref)) <= 1e-9 * max(1.0, np.max(np.abs(ref)))


def test_two_modes_follow_the_flexible_slider_crank():
    """Two bending modes (1665 and 6685 rad/s) and the axial nodal
    coordinates: 12 coordinates for 18, the crank within 1e-7 rad/s of the
    nodal mesh over 2 s (measured 1.7e-8) and the rod's mid-span deflection
    within 1 % (measured 0.4 %)."""
    T = 2.0
    nodal = mbdsl.simulate(mbdsl.load_text(SLIDER, "n.mbd"), t_end=T)
    modal = mbdsl.simulate(mbdsl.load_text(_with(SLIDER, "modes 2"), "m.mbd"), t_end=T)
    assert modal.q.shape[1] == 12 and nodal.q.shape[1] == 18
    assert np.max(np.abs(modal.column("crank.omega") - nodal.column("crank.omega"))) < 1e-7
    d_nodal, d_modal = nodal.column("rod.deflection_mid"), modal.column("rod.deflection_mid")
    assert np.max(np.abs(d_modal - d_nodal)) < 1e-2 * np.max(np.abs(d_nodal))


def test_four_modes_follow_the_spinning_beam():
    """Spin-up to 4 rad/s (above the first frequency, 3.80 rad/s) and held,
    30 s: with geometric stiffening the modal beam's tip follows the nodal
    one's to 1e-4 m (measured 2.1e-5) over its -0.400 m lag."""
    tips = []
    for text in (SPINUP, _with(SPINUP, "modes 4")):
        sol = mbdsl.simulate(mbdsl.load_text(text, "s.mbd", overrides={"ws": 4.0}))
        assert sol.status == "completed"
        beam = sol.model.flexible_bodies[0]
        mesh = beam.mesh
        eta = sol.q[:, beam.elastic_columns()]
        nodal = mesh.nodal(eta) if hasattr(mesh, "nodal") else eta
        names = mesh.mesh.names if hasattr(mesh, "mesh") else mesh.names
        tips.append(nodal[:, names.index("v8")])
    assert tips[0].min() == pytest.approx(-0.4004, abs=1e-3)
    assert np.max(np.abs(tips[1] - tips[0])) < 1e-4


@pytest.mark.parametrize("value, code", [("13", "E303"), ("0", "E303"), ("2.5", "E301")])
def test_a_bad_mode_count_is_refused(value, code):
    with pytest.raises(mbdsl.MbdModelError) as info:
        mbdsl.load_text(_with(SLIDER, f"modes {value}"), "bad.mbd")
    assert info.value.diagnostics[0].code == code
    assert "modes" in info.value.diagnostics[0].message or "mode" in info.value.diagnostics[0].message
