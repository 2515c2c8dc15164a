"""What start-up (import, parse, check, assemble) loads.

Start-up time is a benchmark target (``benchmarks/speed.py``: below 0.5 s
for the slider crank), not a timed test; what is tested here is its cause:
the heavy libraries a run needs only later (the compiled kernels, SciPy's
linear algebra, plotting, HDF5) are not imported until a run or an output
asks for them.
"""

import json
import subprocess
import sys

from .conftest import MODELS


def test_loading_and_assembling_a_model_imports_no_solver_plotting_or_jit_library():
    code = ("import json, sys, mbdsl; "
            f"s = mbdsl.assemble(mbdsl.load({str(MODELS / 'slider_crank.mbd')!r})); "
            "print(json.dumps(sorted(m for m in sys.modules if m.split('.')[0] in "
            "('numba', 'scipy', 'matplotlib', 'h5py', 'llvmlite', 'plotly'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    loaded = set(json.loads(out.stdout))
    for heavy in ("numba", "llvmlite", "matplotlib", "h5py", "scipy.sparse", "scipy.linalg",
                  "scipy.integrate", "plotly"):
        assert heavy not in loaded, f"{heavy} is imported at start-up"


def test_a_compiled_run_loads_the_kernels_only_then():
    code = ("import sys, mbdsl; "
            f"s = mbdsl.assemble(mbdsl.load({str(MODELS / 'pendulum.mbd')!r})); "
            "assert 'numba' not in sys.modules; "
            "from mbdsl.integrators import integrate, make_method; "
            "sol = integrate(s, make_method('hht-i3'), 0.01, 1e-3, engine='compiled'); "
            "print(sol.engine, 'numba' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["compiled", "True"]
