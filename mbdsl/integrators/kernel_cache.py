"""Loading the compiled kernels: numba's on-disk cache, announced compilation,
and a background build for a first run that should not wait.

numba compiles the kernels (:mod:`mbdsl.kernels`, :mod:`.compiled`) once per machine (about
2 min 40 s on two cores, docs/performance.md) and caches them on disk; later
processes load them in a fraction of a second. Two things follow for a tool that reports its own
cost:

* loading or compiling is timed apart from the time loop
  (``Solution.timings["kernels"]``) and is never step time;
* a newcomer's first run should not sit silent for minutes. The command
  line therefore asks :func:`kernels_ready` first; when the kernels are not
  built yet it starts :func:`start_background_build` (a detached process
  running ``python -m mbdsl.integrators.build_kernels``) and starts this one
  model on the same kernels uncompiled (:func:`uncompiled_kernels`), saying
  so; the run goes on compiled once the build is done
  (``driver.KernelUpgrade``). Where waiting is wanted (the Python
  API, ``MBDSL_BACKGROUND_COMPILE=0``), :func:`ensure_loaded` compiles in
  the process and announces it first.

Whether the kernels are built is recorded by a marker file beside numba's
cache, written after every entry point was loaded or compiled, keyed by the
sources of both packages (``kernel_sources``), the numba version and the host CPU (numba's own
cache is keyed by the same). A marker that is wrong (numba's cache cleared
by hand) costs only a late announcement: :func:`ensure_loaded` then reports
the compilation once it has taken more than a few seconds.
"""

from __future__ import annotations

import json
import os
import sys
import threading
import time
from pathlib import Path

import numpy as np

# what the build shares with the assembled system's choice of kernels (kernels/cache.py)
from ..kernels.cache import (_STALE_LOCK, KERNEL_PACKAGES, UNCOMPILED_ROOT,  # noqa: F401
                             _cache_dir, _key, _loaded, _lock, _marker, build_in_progress,
                             import_uncompiled, kernel_sources, kernels_ready, loaded,
                             package_root)
from .records import LIN_J, LIN_JINV

__all__ = ["kernels_ready", "ensure_loaded", "loaded", "start_background_build", "build_in_progress",
           "background_allowed", "warm_up", "uncompiled_kernels"]

#: Environment variable: "0" makes the command line compile in the process
#: (announced) instead of in the background.
BACKGROUND_ENV = "MBDSL_BACKGROUND_COMPILE"


def _cache_folders() -> list:
    """The folders numba caches the kernel packages' functions in (one per
    package folder; under ``NUMBA_CACHE_DIR`` when set), from the
    dispatchers of the imported kernel modules."""
    from . import compiled      # noqa: F401  (imports every kernel module)
    folders = set()
    for name, module in list(sys.modules.items()):
        if not name.startswith(("mbdsl.kernels", "mbdsl.integrators.compiled")):
            continue
        for value in vars(module).values():
            cache = getattr(getattr(value, "_cache", None), "_cache_path", None)
            if isinstance(cache, str) and getattr(value, "__module__", None) == name:
                folders.add(Path(cache))
                break
    return sorted(folders)


def purge_kernel_caches() -> int:
    """Delete numba's cached machine code of every kernel (``*.nbi``, ``*.nbc``).

    numba checks a cached function against its own file's time stamp only, so
    a kernel whose callee in another file changed would load its old machine
    code (numba issue #1833). A build for a new key (``ensure_loaded``)
    therefore starts from an empty cache. The marker and the lock stay.

    Returns
    -------
    int
        The number of files deleted.
    """
    count = 0
    for folder in _cache_folders():
        for path in list(folder.glob("*.nbi")) + list(folder.glob("*.nbc")):
            try:
                path.unlink()
                count += 1
            except OSError:
                pass
    return count


def background_allowed() -> bool:
    """Whether the command line may build the kernels in the background
    (``MBDSL_BACKGROUND_COMPILE`` is not "0")."""
    return os.environ.get(BACKGROUND_ENV, "1") != "0"


def start_background_build() -> bool:
    """Start a detached process that compiles every kernel and writes the
    marker, unless one is running. Returns True when a build is (now)
    under way."""
    import subprocess
    try:
        lock = _lock()
        lock.parent.mkdir(parents=True, exist_ok=True)
        if build_in_progress():
            return True
        lock.unlink(missing_ok=True)            # stale
        fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
    except FileExistsError:
        return True
    except (OSError, ImportError):
        return False
    os.close(fd)
    try:
        # run from the folder that holds this very package: ``-m`` puts the
        # working directory first on the path, and from a source checkout
        # (``pip install . && mbdsl simulate ...``, run where the README
        # says) the child would otherwise build the checkout's copy, whose
        # numba cache the installed command never reads
        subprocess.Popen([sys.executable, "-m", "mbdsl.integrators.build_kernels"],
                         cwd=package_root(), stdin=subprocess.DEVNULL,
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                         start_new_session=True, close_fds=True)
    except OSError:
        lock.unlink(missing_ok=True)
        return False
    return True


#: Groups of entry points, one per linear solver of the compiled engine.
GROUPS = ("dense", "banded", "sparse")

#: The warm-up run (``warm_up.run``), registered when the package
#: ``mbdsl.integrators`` is imported: a short simulation through the driver,
#: which imports the engine, which imports this module; registered rather
#: than imported, so that the kernel cache sits below the driver.
_WARM_UP: list = []


def register_warm_up(run) -> None:
    """Make ``run(groups, output)`` the warm-up :func:`warm_up` calls."""
    _WARM_UP[:] = [run]


def warm_up(groups=GROUPS, output: bool = True) -> None:
    """Load (compiling if needed) the kernels of each group of entry points
    (``dense``, ``banded``, ``sparse``; with ``output`` also those the output
    calls) by the registered warm-up run (:func:`.warm_up.run`, which says
    what each group holds).

    Raises
    ------
    RuntimeError
        No warm-up registered (``mbdsl.integrators`` not imported).
    """
    if not _WARM_UP:
        raise RuntimeError("no kernel warm-up registered: import mbdsl.integrators first")
    _WARM_UP[0](groups, output)


def ensure_loaded(group: str | None = None, announce=None) -> float:
    """Load the kernels a run needs, compiling them if they are not cached.

    Parameters
    ----------
    group : {"dense", "banded", "sparse"}, optional
        The linear solver of the run, whose entry points it uses (see
        :func:`warm_up`). Whatever the group, when the kernels are not built
        every group is compiled and the marker written; with None, nothing
        more is loaded.
    announce : callable (str) -> None, optional
        Told before a compilation starts (or, when the marker was wrong,
        once loading has taken more than 5 s), and when it ends.

    Returns
    -------
    float [s]
        Time spent loading or compiling (0 when already loaded here).
    """
    if (group is not None and group in _loaded) or (group is None and _loaded):
        return 0.0
    t0 = time.perf_counter()
    ready = kernels_ready()
    if ready and group is None:
        return time.perf_counter() - t0
    timer = None
    if not ready:
        purge_kernel_caches()
        if announce is not None:
            announce("compiling the kernels for this machine (once; about three minutes on two "
                     "cores, then cached) ...")
    elif announce is not None:
        def late():
            """Said when a load thought cached has taken long: it is compiling."""
            announce("the kernel cache is out of date: compiling the kernels for this "
                     "machine (once) ...")
        timer = threading.Timer(5.0, late)
        timer.daemon = True
        timer.start()
    try:
        if ready:
            warm_up((group,), output=False)
        else:
            warm_up(GROUPS)
    finally:
        if timer is not None:
            timer.cancel()
    elapsed = time.perf_counter() - t0
    if not ready:
        try:
            _marker().write_text(json.dumps(_key()))
        except OSError:
            pass
        if announce is not None:
            announce(f"compiled the kernels in {elapsed:.0f} s; later runs load them from "
                     "the cache")
    return elapsed


#: The module name of the uncompiled copy's entry points.
UNCOMPILED_MODULE = UNCOMPILED_ROOT + ".integrators.compiled"


def uncompiled_kernels():
    """The kernels of :mod:`mbdsl.kernels` and :mod:`.compiled` as plain Python
    functions: the same sources executed a second time, as the packages under
    ``UNCOMPILED_ROOT``, with numba's JIT disabled while their decorators run
    (numba's ``DISABLE_JIT``: ``njit`` then returns the function itself). The
    kernels import each other relatively, so the copy's modules see the copy;
    what they import from the rest of mbdsl (absolute imports: opcodes,
    recipe fields, outcomes) is shared. This process's compiled kernels are
    untouched, and never imported by this function.

    This is the uncompiled engine (``engine="uncompiled"``): the one
    implementation of the physics and the methods, runnable under pdb and
    print, with no compilation at all. The interpreter loops over every
    element, entry and unknown: on small rigid models it runs about as
    fast as a vectorised numpy evaluation, on a flexible beam several
    times slower.

    The dense linear algebra differs from the compiled module, none of it
    physics: the dense factorization's scatter of the triplets (``_factor``:
    ``np.add.at``) and the dense solve (``_solve``: numpy's matrix product)
    are numpy's, where the interpreter would loop over every triplet and all
    n^2 entries (half of a run of the four-bar chain, 40 % of Andrews'
    mechanism). LAPACK's band routines cannot be called (``_fortran_call`` is
    a numba intrinsic): an uncompiled run takes the dense inverse or SuperLU.

    Returns
    -------
    module
        Cached in ``sys.modules`` for the rest of the process.
    """
    module = import_uncompiled("integrators.compiled")
    if getattr(module, "_linear_algebra_replaced", False):
        return module
    copies = [m for k, m in sys.modules.items() if k.startswith(UNCOMPILED_ROOT + ".")]
    kernel_solve = module._solve

    def _solve(solver, lin, r, dw):
        """dw = J^-1 r: numpy's product with the stored transposed inverse for
        the dense solver (``integrators.compiled.linalg._solve`` loops), else the kernel."""
        if solver == module.DENSE:
            size = r.shape[0]
            np.matmul(r, lin[LIN_JINV][:size, :size], out=dw[:size])
            return
        kernel_solve(solver, lin, r, dw)

    def _fortran_call(address, args):
        raise RuntimeError("the uncompiled kernels cannot call LAPACK's band routines")

    kernel_factor = module._factor
    linalg = sys.modules[UNCOMPILED_ROOT + ".integrators.compiled.linalg"]

    def _factor(solver, lin, R, C, V, p):
        """``integrators.compiled.linalg._factor`` for the dense solver on whole arrays, else the kernel."""
        if solver != module.DENSE:
            return kernel_factor(solver, lin, R, C, V, p)
        if not np.all(np.isfinite(V[:p])):
            return module.NONFINITE
        J = lin[LIN_J]
        J[:, :] = 0.0
        np.add.at(J, (R[:p], C[:p]), V[:p])
        return module.CONVERGED if linalg._invert(J, lin[LIN_JINV]) else module.SINGULAR

    # every module of the copy that calls them reads its own global
    replaced = {kernel_solve: _solve, kernel_factor: _factor,
                sys.modules[UNCOMPILED_ROOT + ".integrators.compiled.band"]._fortran_call:
                _fortran_call}
    for copy in copies:
        for name, value in list(vars(copy).items()):
            if callable(value) and value in replaced:
                setattr(copy, name, replaced[value])
    module._linear_algebra_replaced = True
    return module
