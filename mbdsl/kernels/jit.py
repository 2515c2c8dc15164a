"""numba behind one module: the decorators every kernel is compiled with, and
what the kernel cache asks of numba (its version, the host CPU, JIT switched
off for the uncompiled copy).

Importing this module imports numba (about 0.3 s); nothing else of mbdsl
outside the kernel packages (:mod:`mbdsl.kernels`, :mod:`mbdsl.integrators.compiled`)
imports numba or llvmlite.
"""

from __future__ import annotations

import contextlib

import numba

__all__ = ["_jit", "_inline", "available", "version", "host_cpu", "jit_disabled"]

# error_model="numpy": a division by zero gives inf or NaN, as in numpy and in the
# language's functions (``expressions.compile_function``), which Newton's NaN test and the
# failure report catch; numba's default ("python") would raise ZeroDivisionError from
# inside a time loop, an exception in place of the report in the model's words. (It is
# not for speed: the time loop's object code 3.36 -> 3.35 MB, the same us/step.)
_jit = numba.njit(cache=True, nogil=True, error_model="numpy")
#: The accessors of the packed model data are inlined in numba's IR (see ``schema``).
_inline = numba.njit(cache=True, nogil=True, inline="always", error_model="numpy")


def available() -> bool:
    """True: numba imported (this module exists only where it does)."""
    return True


def version() -> str:
    """numba's version (part of the kernel cache's key)."""
    return numba.__version__


def host_cpu() -> str:
    """The host CPU's name as LLVM sees it (numba's cache is keyed by it too)."""
    import llvmlite.binding as llvm
    return llvm.get_host_cpu_name()


@contextlib.contextmanager
def jit_disabled():
    """numba's ``DISABLE_JIT`` while the block runs: ``njit`` then returns the
    function itself (the uncompiled copy of the kernels)."""
    before = numba.config.DISABLE_JIT
    numba.config.DISABLE_JIT = True
    try:
        yield
    finally:
        numba.config.DISABLE_JIT = before
