"""One BLAS thread while a run's time loop runs (threadpoolctl, only here).

The Newton matrices of a step are small: the compiled loop's dense inverse
(up to ``assembly.sparse.DENSE_LIMIT`` unknowns) and band LU (LAPACK
dgetrf/dgetri and dgbtrf, called from the kernels through scipy's
OpenBLAS), the numpy engine's dense LU. A threaded BLAS gains nothing on
them, and where the cores are shared it loses badly: OpenBLAS's threads
wait for one another by spinning, so a run beside other busy processes
waits for cores it cannot get. Measured on a 2-core machine (Andrews'
mechanism with NSTIFF-SI2, 82 unknowns, a new Newton matrix every two
steps, 12 000 steps, the time loop's time): alone 1.4-1.8 s with two BLAS
threads and 1.6 s with one; beside two busy processes 6.8-8.2 s with two
and 2.6-2.9 s with one; three such runs at once 6.5-36.7 s each with two
(96-107 s beside two runs of the numpy engine) and 2.4-2.8 s with one.
So a run limits the BLAS libraries loaded in the process to one thread
(:func:`one_thread`), and gives them back their count when it ends: the
caller's own numpy work afterwards keeps its threads.
"""

from __future__ import annotations

import contextlib

__all__ = ["one_thread"]

_controller = None


def _blas():
    """threadpoolctl's controller of the BLAS libraries loaded in this
    process, made once (about 1 ms), after scipy.linalg has loaded the
    OpenBLAS the kernels' LAPACK calls go to."""
    global _controller
    if _controller is None:
        import scipy.linalg  # noqa: F401  (loads scipy's BLAS before it is listed)
        from threadpoolctl import ThreadpoolController
        _controller = ThreadpoolController()
    return _controller


@contextlib.contextmanager
def one_thread():
    """Within the block, every BLAS library loaded in this process runs one
    thread; on leaving it (normally or by an exception, Ctrl-C included)
    each gets its count back. Costs about 20 us.

    Yields
    ------
    None
    """
    with _blas().limit(limits=1, user_api="blas"):
        yield
