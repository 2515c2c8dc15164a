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
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic, overload

__all__ = ["_jit", "_hot", "_inline", "borrowed", "available", "version", "host_cpu", "jit_disabled"]

# error_model="numpy": a division by zero gives inf or NaN, as in numpy and in the
# language's functions (``expressions.compile_function``), which Newton's NaN test and the
# failure report catch; numba's default ("python") would raise ZeroDivisionError from
# inside a time loop, an exception in place of the report in the model's words. (It is
# not for speed: the time loop's object code 3.36 -> 3.35 MB, the same us/step.)
#
# ``_nrt=True`` is explicit: numba gives a callee that does not set it its
# caller's, and a kernel that ``_hot`` calls may allocate (below).
_jit = numba.njit(cache=True, nogil=True, error_model="numpy", _nrt=True)
#: The kernels a Newton iteration runs (residual, Newton matrix, solve, the
#: elements' forces and constraints): compiled without numba's reference
#: counting. numba counts the references to an array in every function that
#: holds it (``NRT_incref``/``NRT_decref``, a locked increment of a counter);
#: a step passes its arrays through some 500 calls and slices, and on the
#: double pendulum those counts were 63 % of the step's time (perf on this
#: machine's AMD EPYC; 1 000 locked operations per step). Such a kernel only
#: reads and writes arrays its caller owns: it allocates none and returns
#: none (``tests/test_structure.py`` checks both), so no count is needed.
_hot = numba.njit(cache=True, nogil=True, error_model="numpy", _nrt=False)
#: The accessors of the packed model data are inlined in numba's IR (see ``schema``).
_inline = numba.njit(cache=True, nogil=True, inline="always", error_model="numpy")



def _unowned(context, builder, ty, value):
    """The array struct ``value`` of type ``ty`` with a NULL meminfo."""
    ary = context.make_array(ty)(context, builder, value=value)
    ary.meminfo = cgutils.get_null_value(ary.meminfo.type)
    return ary._getvalue()


def borrowed(value):
    """An array, or a tuple of arrays, as a view numba counts no references
    to: the same data, shape and strides with a NULL meminfo, so that each
    count a ``_jit`` kernel makes on it is a test of a NULL pointer instead
    of a locked increment (see ``_hot``). The caller must hold the owner
    while the view is in use: the time loop's entry (``run``) borrows only
    its own arguments, which its caller holds for the call, and nothing
    borrowed is returned or kept.
    """
    return value      # uncompiled: the array itself (compiled: the overload below)


@intrinsic
def _borrowed(typingctx, value):
    """The compiled ``borrowed``: the struct with a NULL meminfo."""
    if isinstance(value, types.Array):
        def codegen(context, builder, signature, args):
            """LLVM IR: the array's struct with a NULL meminfo (``_unowned``)."""
            return _unowned(context, builder, value, args[0])
        return value(value), codegen
    if isinstance(value, types.BaseTuple) and all(isinstance(t, types.Array) for t in value):
        def codegen(context, builder, signature, args):
            """LLVM IR: the tuple of the arrays' structs, each with a NULL meminfo."""
            items = [_unowned(context, builder, t, v)
                     for t, v in zip(value, cgutils.unpack_tuple(builder, args[0]))]
            return context.make_tuple(builder, value, items)
        return value(value), codegen
    return None


@overload(borrowed, jit_options={"cache": True})
def _borrowed_overload(value):
    """``borrowed`` in compiled code."""
    return lambda value: _borrowed(value)


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
