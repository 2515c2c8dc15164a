"""Compiles mbdsl's kernels while pip installs it, so that an installed mbdsl
runs compiled from its first run.

The project's metadata is in pyproject.toml; this file adds one step to
setuptools' ``build_py``: once the package is copied to the build folder,
``python -m mbdsl.integrators.build_kernels`` runs on that copy and leaves
numba's cache of every kernel in the copy's ``__pycache__`` folders (numba's
in-tree cache), which the wheel carries into site-packages beside the same
sources. numba (0.68 and later) keys a cached function on the SHA-256 of its
source file and on this machine's CPU, and mbdsl's marker on the kernels' sources, numba's
version and the CPU (``mbdsl.kernels.cache``): an installed copy on this
machine loads them, and anywhere else they are simply not used (the first
run builds them then, as without this step).

The step takes about three minutes on two cores. ``MBDSL_BUILD_KERNELS=0``
skips it (the first run then compiles them in the background, as an
editable install always does); a step that fails leaves the install as it
would be without it.
"""

import os
import subprocess
import sys

from setuptools import setup
from setuptools.command.build_py import build_py


def _cache_moves() -> bool:
    """Whether numba keys a cached function on its source's content (numba
    0.68 and later: the SHA-256 of the file), so that its cache is valid in
    site-packages; before, on the file's time stamp, which installing
    changes."""
    from importlib.metadata import PackageNotFoundError, version
    try:
        major, minor = (int(x) for x in version("numba").split(".")[:2])
    except (PackageNotFoundError, ValueError):
        return False
    return (major, minor) >= (0, 68)


class BuildPyWithKernels(build_py):
    """setuptools' ``build_py``, then the kernels compiled in the build folder."""

    def run(self):
        """Copy the package, then compile its kernels there (module notes)."""
        super().run()
        if getattr(self, "editable_mode", False) or os.environ.get("MBDSL_BUILD_KERNELS") == "0":
            return
        if not _cache_moves():
            print("mbdsl: numba before 0.68 keys its cache on the source files' time stamps, "
                  "which the install changes; the first run builds the kernels", flush=True)
            return
        build_lib = os.path.abspath(self.build_lib)
        # the build folder first; pip's isolated build environment is on PYTHONPATH too
        path = os.pathsep.join(p for p in (build_lib, os.environ.get("PYTHONPATH")) if p)
        env = dict(os.environ, PYTHONPATH=path, MBDSL_BACKGROUND_COMPILE="0")
        env.pop("NUMBA_CACHE_DIR", None)          # numba's in-tree cache: beside the sources
        print("mbdsl: compiling the kernels for this machine (about 3 minutes; "
              "MBDSL_BUILD_KERNELS=0 skips this, and the first run builds them instead)",
              flush=True)
        done = subprocess.run([sys.executable, "-m", "mbdsl.integrators.build_kernels"],
                              env=env, cwd=build_lib, check=False)
        if done.returncode != 0:
            print("mbdsl: the kernels were not compiled now; the first run builds them",
                  file=sys.stderr, flush=True)


setup(cmdclass={"build_py": BuildPyWithKernels})
