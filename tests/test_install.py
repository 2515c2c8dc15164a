"""The kernels compiled at install time (``setup.py``): numba's in-tree cache,
moved with the package to another folder as a wheel moves it into
site-packages, is loaded there instead of compiled again.

What makes that work is that numba keys a cached function on the SHA-256 of
its source file (not its path or time stamp) and on the CPU, and mbdsl's
marker on the kernels' sources, numba's version and the CPU: a copy of the
package with new time stamps must find both valid. The check is numba's own
count of cache hits and misses of the time loop's entry point, not a time.
"""

import json
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from .conftest import ROOT

_PROBE = """
import json
import mbdsl
from mbdsl.kernels import cache
from mbdsl.integrators import integrate, make_method
from mbdsl.integrators import compiled
ready = cache.kernels_ready()
text = '''model probe
body b { mass 1; inertia 0.1; point O (-0.5, 0) }
joint O: revolute(ground.origin, b.O)
gravity (0, -9.81)
initial b.phi = 0.3
'''
system = mbdsl.assemble(mbdsl.load_text(text))
sol = integrate(system, make_method("hht-i3"), 0.01, 1e-3, engine="compiled")
stats = compiled.run.stats
print(json.dumps({"ready": ready, "status": sol.status, "where": str(cache._cache_dir()),
                  "hits": sum(stats.cache_hits.values()),
                  "misses": sum(stats.cache_misses.values())}))
"""


def _probe(folder):
    """Run the probe on the package under ``folder`` (numba's in-tree cache)."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(PYTHONPATH=str(folder), MBDSL_BACKGROUND_COMPILE="0")
    done = subprocess.run([sys.executable, "-c", _PROBE], cwd=folder, env=env,
                          capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_the_kernel_cache_moves_with_the_package(tmp_path):
    """The package with its compiled kernels copied to a new folder, every
    file with a new time stamp: the marker says built, and the time loop
    loads from the cache (hits, no miss), in the copy's own folders."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        pytest.skip("NUMBA_CACHE_DIR is set: numba's cache is not in the package's folders")
    from mbdsl.integrators import kernel_cache
    kernel_cache.ensure_loaded("dense")           # built in-tree here when it is not yet
    import mbdsl                                  # the copy these tests import
    shutil.copytree(Path(mbdsl.__file__).parent, tmp_path / "mbdsl",
                    copy_function=shutil.copyfile,
                    ignore=shutil.ignore_patterns("*.pyc", "mbdsl-kernels.lock"))
    got = _probe(tmp_path)
    assert got["ready"] and got["status"] == "completed", got
    assert got["where"].startswith(str(tmp_path)), got
    assert got["hits"] >= 1 and got["misses"] == 0, got


@pytest.mark.slow
def test_the_wheel_carries_the_compiled_kernels(tmp_path):
    """``pip wheel`` (setup.py's step, in pip's isolated build environment,
    whose numba is the package index's newest, as in this environment after
    ``pip install``) packs the marker and numba's cache of the time loop;
    unpacked elsewhere as pip installs it, the time loop loads from it
    without compiling. About four minutes: the kernels are compiled in the
    build folder."""
    build = tmp_path / "src"
    shutil.copytree(ROOT, build, ignore=shutil.ignore_patterns(
        "__pycache__", "build", "*.egg-info", ".git", "docs", "tests", "benchmarks"))
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    done = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps",
                           "-w", str(tmp_path / "wheel"), str(build)],
                          env=env, capture_output=True, text=True, timeout=1800)
    assert done.returncode == 0, done.stderr[-3000:]
    (wheel,) = (tmp_path / "wheel").glob("mbdsl-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    assert "mbdsl/kernels/__pycache__/mbdsl-kernels.json" in names
    assert any(n.startswith("mbdsl/integrators/compiled/__pycache__/loop._run-")
               and n.endswith(".nbc") for n in names)
    site = tmp_path / "site"
    zipfile.ZipFile(wheel).extractall(site)
    got = _probe(site)
    assert got["ready"] and got["status"] == "completed", got
    assert got["hits"] >= 1 and got["misses"] == 0, got
