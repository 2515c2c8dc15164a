"""Each method's Newton matrix against central differences of its own residual.

On the model with every joint, driver and force type (rigid, and on
flexible beams: (M a)_q and HHT-ADD's M(q)^-1 products), at a perturbed
(not converged) iterate and a step that is not tiny, so that every term of
the matrix matters. Dense and sparse assembly must give the same matrix.
"""

from pathlib import Path

import numpy as np
import pytest

import mbdsl
from mbdsl.assembly.sparse import JacobianAssembler
from mbdsl.integrators import make_method

MODELS = {
    "all_elements": Path(__file__).parents[1] / "dsl" / "valid" / "all_elements.mbd",
    "sliding_elements": Path(__file__).parents[1] / "dsl" / "valid" / "sliding_elements.mbd",
    "friction_elements": Path(__file__).parents[1] / "dsl" / "valid" / "friction_elements.mbd",
    "distance_elements": Path(__file__).parents[1] / "dsl" / "valid" / "distance_elements.mbd",
    "coupler_elements": Path(__file__).parents[1] / "dsl" / "valid" / "coupler_elements.mbd",
    "double_pendulum_stiff": Path(__file__).parents[2] / "models" / "double_pendulum_stiff.mbd",
    "flexible_elements": Path(__file__).parents[1] / "dsl" / "valid" / "flexible_elements.mbd",
    "flexible_slider_crank": Path(__file__).parents[2] / "models" / "flexible_slider_crank.mbd",
}


def fd_jacobian(f, w, eps=1e-6):
    cols = []
    for i in range(len(w)):
        e = np.zeros_like(w)
        e[i] = eps * max(1.0, abs(w[i]))
        cols.append((f(w + e) - f(w - e)) / (2 * e[i]))
    return np.stack(cols, axis=1)


@pytest.mark.parametrize("model_name", list(MODELS))
@pytest.mark.parametrize("method", list(mbdsl.METHODS))
def test_newton_matrix_is_the_derivative_of_the_residual(method, model_name):
    model = mbdsl.load(MODELS[model_name], overrides={"elbow0": 1e-3} if "stiff" in model_name else None)
    system = mbdsl.assemble(model)
    init = mbdsl.consistent_initial_state(system)
    m = make_method(method)
    history = m.start(system, init)
    h = 1e-2
    # a second step for the two-step methods, so that BDF2 (not BDF1) is checked
    for _ in range(2):
        ctx = m.context(system, history, history[-1].t + h, h)
        rng = np.random.default_rng(0)
        w = m.predict(ctx) * (1 + 0.01 * rng.normal(size=len(m.predict(ctx)))) + 0.01 * rng.normal(
            size=len(m.predict(ctx)))
        J = m.jacobian(w, ctx)
        J_fd = fd_jacobian(lambda x: m.residual(x, ctx), w)
        scale = np.maximum(np.abs(J_fd).max(axis=1, keepdims=True), 1.0)
        err = np.abs(J - J_fd) / scale
        # central differences: truncation ~1e-5 on the stiff model (k = 1e7);
        # the wrong block this test once caught gave 1.6e-3 and 500
        assert err.max() < 1e-4, (np.unravel_index(err.argmax(), err.shape), err.max())
        ctx.assembler = JacobianAssembler(J.shape[0], sparse=True)
        assert np.allclose(m.jacobian(w, ctx).toarray(), J, rtol=1e-14, atol=1e-12)
        history = (list(history) + [m.accept(m.predict(ctx), ctx)])[-m.history_length:]
