"""Compiled kernels (numba): the recipe methods (``recipe.py``) on planar rigid and flexible models.

The only module of mbdsl that imports numba. It is imported lazily, when a
run asks for the compiled engine (:mod:`mbdsl.integrators.engine`), so that
``import mbdsl`` and model checking stay fast; the kernels are compiled once
per machine and cached on disk (``cache=True``, numba's ``__pycache__``).

Why compiled code here: on small mechanisms the numpy formulation is
dominated by call overhead (about a microsecond per numpy call, dozens of
calls per Newton iteration), not by arithmetic. The kernels evaluate the
element formulas the groups of :mod:`mbdsl.assembly` state, with scalar loops
over the instances of each element type (struct of arrays, fixed at build), and for
systems of up to ``DENSE_LIMIT`` unknowns run the whole time loop, Newton
iteration included, without returning to Python. They are the one
evaluation of every element: Python asks for Phi, Q, their derivatives,
energies and power through ``elements``, ``beam_blocks`` and
``beam_energies`` (``AssembledSystem``).

Model data: the fields of :data:`MODEL_SCHEMA` packed into two flat arrays
(integers ``I``, floats ``Fl``; built by ``engine.CompiledModel``) and read
by name (``_i(I, CROW, i, 0)``): body columns index the extended coordinate
vector q_ext = [q, 0, 0, 0], the trailing three being the ground, whose
entries are never written to a matrix.

Formulas (Haug, Computer-Aided Kinematics and Dynamics of Mechanical
Systems, ch. 3 and 6; Nikravesh, Computer-Aided Analysis of Mechanical
Systems, ch. 4): a body point is at r + A(phi) s, with d/dphi (A s) = B s =
(-(A s)_y, (A s)_x) and d^2/dphi^2 (A s) = -A s.

* coincidence (revolute): Phi = p2 - p1
* point on line: Phi = n . (p_P - p_L), n = A_L n0
* distance: Phi = (d . d - L^2) / (2 L), d = p2 - p1
* linear rows: c1 q[i1] + c2 q[i2] - offset (locked angles)
* spring-damper: Q = -D^T (f e), f = k (l - l0) + c ldot
* rotational spring-damper: tau = k (phi2 - phi1 - angle) + c (w2 - w1)
* point forces F(t) and torques tau(t) (a constant one as a constant program),
  gravity in the constant vector Q0
* friction in joints: tau = -N mu(z) tanh(z/v_reg) - c z along w (``FrictionGroup``),
  N from the joint's multipliers: Q reads lambda, Q_lambda beside Phi_q^T
* flexible beams in the floating frame of reference: M(q), (M x)_q, the
  quadratic velocity vector, elastic forces with geometric stiffening and
  gravity (``assembly/ffr.py``), and the elastic columns of coincidence and
  point-on-line joints on beam points ("Joint points on flexible beams")

The Newton iteration is the one of :mod:`mbdsl.integrators.newton`
(weighted velocity-equivalent norm, contraction-based stopping, modified
Newton with refresh on poor contraction, the round-off stall rule), with
one of two linear solvers (``_factor``, ``_solve``):

* DENSE: an explicit inverse of the (small) Newton matrix computed by LAPACK
  through ``numpy.linalg.inv``; the inverse is only used to compute Newton
  updates, while the residual is evaluated exactly, so its round-off
  changes the contraction, never the converged solution;
* BANDED: LAPACK's band LU with partial pivoting (dgbtrf, dgbtrs) on the
  Newton matrix reordered by reverse Cuthill-McKee (``engine.band_ordering``),
  called through the addresses scipy.linalg.cython_lapack exports. The
  addresses are arguments, not constants, so the kernels stay cacheable
  (numba refuses to cache code that embeds a ctypes pointer).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from llvmlite import ir
from numba.extending import intrinsic

from ..dsl.expressions import OPCODES
from ..model.contact import SPEED_FLOOR as _CONTACT_SPEED_FLOOR
# The time loop's modes and statuses (Newton's, the tolerance at h_min, an event, a
# rejection in a single-attempt mode): one contract for every stepper (outcomes.py).
from .outcomes import (ATTEMPT, CONVERGED, DIVERGING, EVENT, LAND, MAX_ITER,  # noqa: F401
                       NONFINITE, REJECTED, RUN, SINGULAR, TOLERANCE)
from .recipe import RECIPE_FIELDS

__all__ = ["MODEL_SCHEMA", "MODEL_FIELDS", "residual", "jacobian_triplets", "force_term", "old_force",
           "predict", "state", "layout", "advance", "mobility", "index1_multipliers",
           "index1_multipliers_band",
           "accumulate", "elements", "beam_blocks", "beam_energies", "run", "triplet_bound", "pack", "unpack", "lapack_band_addresses",
           "DENSE", "BANDED"]

#: The recipe entries (``recipe.RECIPE_FIELDS``, checked below): literals here, so that
#: numba's cache of this file never holds indices of another file's version.
(FORM, HAS_Y, SPLIT, CQX, CQY, CVX, CVY, CM, CF, DM, DI, DV, SP, SV, SX, SY, MU_MOB, FLOOR,
 PQ0, PQ1, PV0, PV1, PA, VV0, VV1, VA, Y0V, KA1, KA2, KB, CQ, SM, PB, VB, BB, BA, BX,
 REG, ERR, EAUX, EABS, MH) = range(42)
_RECIPE = ("form", "has_y", "split", "cqx", "cqy", "cvx", "cvy", "cM", "cF", "dM", "dI", "dV",
           "sP", "sV", "sx", "sy", "mu_mob", "floor",
           "pq0", "pq1", "pv0", "pv1", "pa", "vv0", "vv1", "va", "y0v",
           "ka1", "ka2", "kb", "cQ", "sm", "pb", "vb", "bb", "ba", "bx", "reg", "err", "eaux",
           "eabs", "mh")
_OPCODES = ("const", "t", "neg", "+", "-", "*", "/", "^", "sin", "cos", "tan", "asin", "acos",
            "atan", "sinh", "cosh", "tanh", "sqrt", "exp", "log", "abs", "sign", "x", "min",
            "max", "<", ">", "<=", ">=", "if")
if _RECIPE != RECIPE_FIELDS or _OPCODES != OPCODES:     # pragma: no cover (a developer's error, caught by any test)
    raise ImportError("compiled.py's recipe indices differ from recipe.RECIPE_FIELDS")

#: Linear solvers of the compiled loop: explicit inverse (LAPACK getrf/getri through
#: numpy.linalg.inv), or LAPACK's band LU (dgbtrf/dgbtrs) on a bandwidth-reducing ordering.
DENSE, BANDED = 0, 1

#: The two forms of a recipe: the linear family, and HHT with additive corrections.
LINEAR, ADDITIVE = 0, 1


#: The model data's schema, one entry per field: (name, "i" or "f", columns per
#: instance; 0 for a 1-D field). Packing (``pack``), the kernels' named access (the
#: index constants below, checked against it) and ``triplet_bound`` derive from it.
#: Body columns index the extended coordinate vector q_ext = [q, 0, 0, 0].
MODEL_SCHEMA = (
    ("mass", "f", 0), ("Q0", "f", 0),                                  # diag of M (beams: M(0)); Q const
    ("crow", "i", 2), ("ccol1", "i", 3), ("cs1", "f", 2),              # coincidence: rows,
    ("ccol2", "i", 3), ("cs2", "f", 2),                                # bodies, local points
    ("prow", "i", 0), ("pcolL", "i", 3), ("psL", "f", 2),              # point on line
    ("pcolP", "i", 3), ("psP", "f", 2), ("pn0", "f", 2),
    ("lrow", "i", 0), ("lcol", "i", 2), ("lcoef", "f", 2), ("loff", "f", 0),   # linear rows
    ("scol1", "i", 3), ("ss1", "f", 2), ("scol2", "i", 3), ("ss2", "f", 2),   # spring-dampers
    ("spar", "f", 5),                                  # (k, c, l0, u_ref): see _free_length
    ("rcol", "i", 2), ("rpar", "f", 3),                                # rotational (k, c, angle)
    ("fcol", "i", 3), ("fs", "f", 2), ("fF", "f", 2),                  # constant point forces
    ("row_element", "i", 0),                                           # constraint row -> element
    ("code", "i", 0), ("consts", "f", 0),                              # time-function programs
    ("prog", "i", 2),                                                  # program: (start, end)
    ("lfn", "i", 3),                                                   # linear row: f, f', f'' programs
    ("tcol", "i", 0), ("tfn", "i", 0),                                 # torque of t: column, f
    ("ffn", "i", 2),                                                   # point force: fx, fy programs
    ("stack", "f", 0),                                                 # the programs' stack
    ("var", "i", 4), ("varc", "f", 2),                                 # state variables: level,
    ("xval", "f", 0),                                                  # 2 (column, coef), line; values
    ("stq", "i", 4),                                                   # loads of the state: f,
    ("sdv", "i", 3),                                                   # +col, -col, line; dtau/dx
    ("pfn", "i", 3),                                                   # point on line: f, f', f''
    ("geo", "i", 6), ("geof", "f", 6),                                 # sliding joints' lines
    ("fri", "i", 5), ("frp", "f", 6),                                  # friction: +col, -col,
                                                                       # line, row, rows; law
    ("drow", "i", 0), ("dcol1", "i", 3), ("ds1", "f", 2),              # distance joints
    ("dcol2", "i", 3), ("ds2", "f", 2), ("dlen", "f", 0),
    ("mrig", "f", 0),                                                  # M's rigid diagonal (0 at beams)
    ("beam", "i", 6), ("bcol", "i", 0), ("bdat", "f", 0),              # FFR beams: (first column,
    ("bdof", "i", 0), ("grav", "f", 0),                                # nf, first float, elements,
                                                                       # first dof, dofs/element)
    ("cel", "i", 4), ("pel", "i", 4),                                  # elastic terms of joint points:
    ("ecol", "i", 0), ("eshp", "f", 2),                                # spans; column, shape (S_x, S_y)
    ("kgi", "i", 2), ("kcol", "i", 6),                                 # contact gaps: kind, line row;
    ("kpar", "f", 14), ("kimp", "f", 0),                               # columns; data, law; impact speed
    ("sel", "i", 4), ("fel", "i", 2),                                  # elastic terms of spring and
    ("dsp", "i", 4),                                                   # point-force points, distance
)                                                                      # joints' points: spans
#: The field names, and the scalar "n_elements" (the header's last entry).
MODEL_FIELDS = tuple(name for name, _, _ in MODEL_SCHEMA) + ("n_elements",)

ROUNDOFF_BAND = 1e3        # as in newton.py
EPS = 2.220446049250313e-16

# error_model="numpy": a division by zero gives inf or NaN, as in numpy and in the
# language's functions (``expressions.compile_function``), which Newton's NaN test and the
# failure report catch; numba's default ("python") would raise ZeroDivisionError from
# inside a time loop, an exception in place of the report in the model's words. (It is
# not for speed: the time loop's object code 3.36 -> 3.35 MB, the same us/step.)
_jit = numba.njit(cache=True, nogil=True, error_model="numpy")
#: The accessors of the packed model data are inlined in numba's IR (see "Named access").
_inline = numba.njit(cache=True, nogil=True, inline="always", error_model="numpy")

#: 0, True and False as run-time values, for the offsets, positions and flags a kernel
#: passes to the emitting kernels. numba types a Python constant argument by its value
#: (Literal[int](0), Literal[bool](True)) and compiles the callee once per value and call
#: site: the time loop's library held 11 copies of ``_emit_beams``, 6 of ``_emit_phiq``,
#: 4 of ``_emit_force``, 7.9 MB of IR in all, which every process parses when it loads
#: the library from the cache (and compiles, once). numpy scalars are typed by type.
_0, _YES, _NO = np.int64(0), np.bool_(True), np.bool_(False)


#: The model data's fields (``MODEL_FIELDS``) by name: literals, checked against the
#: schema below, so that numba's cache of this file never holds another version's indices.
(MASS, Q0, CROW, CCOL1, CS1, CCOL2, CS2, PROW, PCOLL, PSL, PCOLP, PSP, PN0,
 LROW, LCOL, LCOEF, LOFF, SCOL1, SS1, SCOL2, SS2, SPAR, RCOL, RPAR,
 FCOL, FS, FF, ROW_ELEMENT, CODE, CONSTS, PROG, LFN, TCOL, TFN, FFN, STACK,
 VAR, VARC, XVAL, STQ, SDV, PFN, GEO, GEOF, FRI, FRP,
 DROW, DCOL1, DS1, DCOL2, DS2, DLEN, MRIG, BEAM, BCOL, BDAT, BDOF, GRAV, CEL, PEL, ECOL,
 ESHP, KGI, KCOL, KPAR, KIMP, SEL, FEL, DSP) = range(69)
if any(globals()[name.upper()] != k for k, (name, _, _) in enumerate(MODEL_SCHEMA)):
    raise ImportError("compiled.py's field indices differ from MODEL_SCHEMA")   # pragma: no cover


# --------------------------------------------------------------------------------------------
# Named access to the packed model data
#
# The model data cross every kernel call as two flat arrays (integers I, floats
# Fl) with a header of (offset, rows, columns) per field, and are read through
# the scalar accessors below, inlined by numba. Why not a tuple of arrays, one
# per field: numba increments and decrements the reference count of every array
# a called kernel binds (atomic operations), and a kernel that unpacked the
# 28-array tuple paid that 56 times per call: measured, 130-440 ns per call of
# an empty element loop, most of a step's time on a double pendulum (perf: the
# NRT atomics took nearly all samples of the time loop). Two arrays and scalar
# reads cost a few ns.
# --------------------------------------------------------------------------------------------

@_inline
def _rows(I, k):
    """Rows (instances) of field k."""
    return I[3 * k + 1]


@_inline
def _i(I, k, i, j):
    """Entry (i, j) of integer field k (j = 0 for a 1-D field)."""
    return I[I[3 * k] + I[3 * k + 2] * i + j]


@_inline
def _f(I, Fl, k, i, j):
    """Entry (i, j) of float field k (j = 0 for a 1-D field)."""
    return Fl[I[3 * k] + I[3 * k + 2] * i + j]


@_jit
def _As(I, Fl, qx, cols, s, i):
    """A(phi) s of instance i of the element whose body columns are integer
    field ``cols`` and whose local vectors are float field ``s``: (x, y)."""
    ph = qx[_i(I, cols, i, 2)]
    c, sn = math.cos(ph), math.sin(ph)
    s0, s1 = _f(I, Fl, s, i, 0), _f(I, Fl, s, i, 1)
    return c * s0 - sn * s1, sn * s0 + c * s1


@_inline
def _span(I, el, i, side):
    """(first, end) of the elastic terms of point ``side`` (0, 1) of instance i
    of an element whose spans are field ``el`` (CEL, PEL, SEL, FEL, DSP); (0, 0)
    when the model has no point on a flexible beam (the field is then empty)."""
    if _rows(I, el) == 0:
        return 0, 0
    return _i(I, el, i, 2 * side), _i(I, el, i, 2 * side + 1)


@_jit
def _Au(I, Fl, qx, cols, s, el, side, i):
    """A(phi) u of point ``side`` of joint instance i, u = s + sum_k S_k q_k:
    s its undeformed local position (field ``s``), S_k (2,) the shape column
    of elastic coordinate q_k of a point on a flexible beam (``PointSet``;
    none on a rigid body). Returns (x, y)."""
    ph = qx[_i(I, cols, i, 2)]
    ux, uy = _f(I, Fl, s, i, 0), _f(I, Fl, s, i, 1)
    k0, k1 = _span(I, el, i, side)
    for k in range(k0, k1):
        qk = qx[_i(I, ECOL, k, 0)]
        ux += _f(I, Fl, ESHP, k, 0) * qk
        uy += _f(I, Fl, ESHP, k, 1) * qk
    c, sn = math.cos(ph), math.sin(ph)
    return c * ux - sn * uy, sn * ux + c * uy


@_inline
def _eshape(I, Fl, k, ph):
    """A S_k and B S_k = d(A S_k)/dphi of elastic term k on a body at angle ph:
    (Ax, Ay, Bx, By)."""
    sx, sy = _f(I, Fl, ESHP, k, 0), _f(I, Fl, ESHP, k, 1)
    c, sn = math.cos(ph), math.sin(ph)
    ax, ay = c * sx - sn * sy, sn * sx + c * sy
    return ax, ay, -ay, ax


@_jit
def _pol(I, Fl, qx, i):
    """Point-on-line parts: n, d = p_P - p_L, A u_L, A u_P."""
    axL, ayL = _Au(I, Fl, qx, PCOLL, PSL, PEL, 0, i)
    axP, ayP = _Au(I, Fl, qx, PCOLP, PSP, PEL, 1, i)
    dx = (qx[_i(I, PCOLP, i, 0)] - qx[_i(I, PCOLL, i, 0)]) + (axP - axL)
    dy = (qx[_i(I, PCOLP, i, 1)] - qx[_i(I, PCOLL, i, 1)]) + (ayP - ayL)
    nx, ny = _As(I, Fl, qx, PCOLL, PN0, i)
    return nx, ny, dx, dy, axL, ayL, axP, ayP


@_jit
def _dist(I, Fl, qx, i, g):
    """Distance joint i: d = p2 - p1 and A1 u1, A2 u2 (u = s + S q_e on a
    flexible beam), its length L; the gradient of Phi over (x1, y1, phi1,
    x2, y2, phi2) into g (6,) (the elastic columns: ``_dist_local``).
    Returns (dx, dy, ax1, ay1, ax2, ay2, L)."""
    ax1, ay1 = _Au(I, Fl, qx, DCOL1, DS1, DSP, 0, i)
    ax2, ay2 = _Au(I, Fl, qx, DCOL2, DS2, DSP, 1, i)
    dx = (qx[_i(I, DCOL2, i, 0)] - qx[_i(I, DCOL1, i, 0)]) + (ax2 - ax1)
    dy = (qx[_i(I, DCOL2, i, 1)] - qx[_i(I, DCOL1, i, 1)]) + (ay2 - ay1)
    L = _f(I, Fl, DLEN, i, 0)
    g[0], g[1], g[2] = -dx / L, -dy / L, (dx * ay1 - dy * ax1) / L
    g[3], g[4], g[5] = dx / L, dy / L, (-dx * ay2 + dy * ax2) / L
    return dx, dy, ax1, ay1, ax2, ay2, L


@_jit
def _dist_col(I, i, j):
    """Column of local entry j (x1, y1, phi1, x2, y2, phi2) of distance joint i."""
    return _i(I, DCOL1, i, j) if j < 3 else _i(I, DCOL2, i, j - 3)


@_jit
def _dist_hess(dx, dy, ax1, ay1, ax2, ay2, L, H):
    """Hessian of the distance row, (D^T D + sum_a d_a D_a,qq) / L, into H (6, 6);
    D = dd/dq = [[-1, 0, ay1, 1, 0, -ay2], [0, -1, -ax1, 0, 1, ax2]]."""
    D0 = (-1.0, 0.0, ay1, 1.0, 0.0, -ay2)
    D1 = (0.0, -1.0, -ax1, 0.0, 1.0, ax2)
    for a in range(6):
        for b in range(6):
            H[a, b] = (D0[a] * D0[b] + D1[a] * D1[b]) / L
    H[2, 2] += (dx * ax1 + dy * ay1) / L
    H[5, 5] -= (dx * ax2 + dy * ay2) / L


@_jit
def _pol_grad(nx, ny, dx, dy, axL, ayL, axP, ayP):
    """Local gradient of n . d over (x_L, y_L, phi_L, x_P, y_P, phi_P): six
    scalars (no array: an allocation costs more than the arithmetic here)."""
    return (-nx, -ny, -(-nx * ayL + ny * axL) + (-ny * dx + nx * dy),
            nx, ny, -nx * ayP + ny * axP)


@_jit
def _pol_hess(nx, ny, dx, dy, axL, ayL, axP, ayP, bnd):
    """Hessian of n . d: (Bn . D) into bnd (6,); returns (H[phiL, phiL], H[phiP, phiP]).

    H = n . D_qq + e_L (Bn)^T D + D^T Bn e_L^T - (n . d) e_L e_L^T
    (``PointOnLineGroup``): its only nonzeros are row and column phi_L and
    the entry (phi_P, phi_P).
    """
    bx, by = -ny, nx
    bnd[0] = -bx
    bnd[1] = -by
    bnd[2] = -(bx * (-ayL) + by * axL)
    bnd[3] = bx
    bnd[4] = by
    bnd[5] = bx * (-ayP) + by * axP
    hLL = (nx * axL + ny * ayL) + 2.0 * bnd[2] - (nx * dx + ny * dy)
    hPP = -(nx * axP + ny * ayP)
    return hLL, hPP


# --------------------------------------------------------------------------------------------
# Vectors: Phi, Phi_q^T lambda, Phi_q v, Q
# --------------------------------------------------------------------------------------------

# --------------------------------------------------------------------------------------------
# Functions of time: the language's expressions as postfix programs
# (``dsl.expressions.postfix``), with the same non-raising semantics as
# ``compile_function``: a division by zero gives +-inf (0/0 NaN), a domain
# error NaN, so that a bad value stops the run with a message, not a crash.
# --------------------------------------------------------------------------------------------

#: Opcodes (``dsl.expressions.OPCODES``, checked at import): literals, as the field indices.
(OP_CONST, OP_T, OP_NEG, OP_ADD, OP_SUB, OP_MUL, OP_DIV, OP_POW,
 OP_SIN, OP_COS, OP_TAN, OP_ASIN, OP_ACOS, OP_ATAN, OP_SINH, OP_COSH, OP_TANH,
 OP_SQRT, OP_EXP, OP_LOG, OP_ABS, OP_SIGN, OP_X, OP_MIN, OP_MAX,
 OP_LT, OP_GT, OP_LE, OP_GE, OP_IF) = range(30)


@_jit
def _eval(I, Fl, p, t):
    """The value at time t [s] of program p (row of field PROG); a program of
    the state reads the variables' values from XVAL (``_state_values``)."""
    base, sp = I[3 * STACK], 0              # the stack is the float field STACK
    k, end = _i(I, PROG, p, 0), _i(I, PROG, p, 1)
    while k < end:
        op = _i(I, CODE, k, 0)
        k += 1
        if op == OP_CONST:
            Fl[base + sp] = _f(I, Fl, CONSTS, _i(I, CODE, k, 0), 0)
            k += 1
            sp += 1
        elif op == OP_T:
            Fl[base + sp] = t
            sp += 1
        elif op == OP_NEG:
            Fl[base + sp - 1] = -Fl[base + sp - 1]
        elif op == OP_X:
            Fl[base + sp] = Fl[I[3 * XVAL] + _i(I, CODE, k, 0)]
            k += 1
            sp += 1
        elif op == OP_MIN or op == OP_MAX:
            a, b = Fl[base + sp - 2], Fl[base + sp - 1]
            sp -= 1
            Fl[base + sp - 1] = min(a, b) if op == OP_MIN else max(a, b)
        elif op >= OP_LT and op <= OP_GE:    # comparisons: 1.0 or 0.0
            a, b = Fl[base + sp - 2], Fl[base + sp - 1]
            sp -= 1
            if op == OP_LT:
                c = a < b
            elif op == OP_GT:
                c = a > b
            elif op == OP_LE:
                c = a <= b
            else:
                c = a >= b
            Fl[base + sp - 1] = 1.0 if c else 0.0
        elif op == OP_IF:                    # test, then, other -> the chosen one
            test, a, b = Fl[base + sp - 3], Fl[base + sp - 2], Fl[base + sp - 1]
            sp -= 2
            Fl[base + sp - 1] = a if test != 0.0 else b
        elif op <= OP_POW:
            a, b = Fl[base + sp - 2], Fl[base + sp - 1]
            sp -= 1
            if op == OP_ADD:
                x = a + b
            elif op == OP_SUB:
                x = a - b
            elif op == OP_MUL:
                x = a * b
            elif op == OP_DIV:
                if b != 0.0:
                    x = a / b
                elif a != 0.0:
                    x = math.copysign(math.inf, a)
                else:
                    x = math.nan
            else:
                x = _pow(a, b)
            Fl[base + sp - 1] = x
        else:
            Fl[base + sp - 1] = _call(op, Fl[base + sp - 1])
    return Fl[base]


@_jit
def _pow(a, b):
    """a ** b as ``expressions._pow``: inf on overflow or 0 ** negative, NaN
    for a negative base with a fractional exponent."""
    if a == 0.0 and b < 0.0:
        return math.inf
    if a < 0.0 and b != math.floor(b):
        return math.nan
    return math.pow(a, b)


@_jit
def _call(op, x):
    """The function of opcode op at x; NaN outside its domain."""
    if op == OP_SIN:
        return math.sin(x)
    if op == OP_COS:
        return math.cos(x)
    if op == OP_TAN:
        return math.tan(x)
    if op == OP_ASIN:
        return math.asin(x) if abs(x) <= 1.0 else math.nan
    if op == OP_ACOS:
        return math.acos(x) if abs(x) <= 1.0 else math.nan
    if op == OP_ATAN:
        return math.atan(x)
    if op == OP_SINH:
        return math.sinh(x)
    if op == OP_COSH:
        return math.cosh(x)
    if op == OP_TANH:
        return math.tanh(x)
    if op == OP_SQRT:
        return math.sqrt(x) if x >= 0.0 else math.nan
    if op == OP_EXP:
        return math.exp(x)
    if op == OP_LOG:
        return math.log(x) if x > 0.0 else math.nan
    if op == OP_SIGN:
        return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)
    return abs(x)


@_jit
def _point_force(I, Fl, t, i):
    """(fx, fy) [N] of point force i at time t: constant, or its programs."""
    fx, fy = _f(I, Fl, FF, i, 0), _f(I, Fl, FF, i, 1)
    if _i(I, FFN, i, 0) >= 0:
        fx = _eval(I, Fl, _i(I, FFN, i, 0), t)
    if _i(I, FFN, i, 1) >= 0:
        fy = _eval(I, Fl, _i(I, FFN, i, 1), t)
    return fx, fy


@_jit
def _line(I, Fl, qx, g, grad, H):
    """Distance s along sliding line g (fields GEO, GEOF: columns of the line's
    body and of the point's body, s_L, s_P, u0) with ds/dq into grad (6,) and
    d^2 s/dq^2 into H (6, 6) over (x_L, y_L, phi_L, x_P, y_P, phi_P):
    s = u . (p_P - p_L), u = A(phi_L) u0, p = r + A(phi) s_body (as
    ``model.elements.line_distance``, which gives the output columns s and
    its rate). Returns s."""
    phL, phP = qx[_i(I, GEO, g, 2)], qx[_i(I, GEO, g, 5)]
    cL, sL_, cP, sP_ = math.cos(phL), math.sin(phL), math.cos(phP), math.sin(phP)
    u0x, u0y = _f(I, Fl, GEOF, g, 4), _f(I, Fl, GEOF, g, 5)
    ux, uy = cL * u0x - sL_ * u0y, sL_ * u0x + cL * u0y
    bux, buy = -uy, ux                                   # B(phi_L) u0
    lx, ly = _f(I, Fl, GEOF, g, 0), _f(I, Fl, GEOF, g, 1)
    px, py = _f(I, Fl, GEOF, g, 2), _f(I, Fl, GEOF, g, 3)
    aLx, aLy = cL * lx - sL_ * ly, sL_ * lx + cL * ly
    aPx, aPy = cP * px - sP_ * py, sP_ * px + cP * py
    dx = qx[_i(I, GEO, g, 3)] + aPx - qx[_i(I, GEO, g, 0)] - aLx
    dy = qx[_i(I, GEO, g, 4)] + aPy - qx[_i(I, GEO, g, 1)] - aLy
    s = ux * dx + uy * dy
    grad[0] = -ux
    grad[1] = -uy
    grad[2] = (bux * dx + buy * dy) - (ux * -aLy + uy * aLx)
    grad[3] = ux
    grad[4] = uy
    grad[5] = ux * -aPy + uy * aPx
    H[:, :] = 0.0
    row0, row1, row2 = -bux, -buy, -(bux * -aLy + buy * aLx)
    row3, row4, row5 = bux, buy, bux * -aPy + buy * aPx
    for j, r in enumerate((row0, row1, row2, row3, row4, row5)):
        H[2, j] += r
        H[j, 2] += r
    H[2, 2] += (ux * aLx + uy * aLy) - s
    H[5, 5] -= ux * aPx + uy * aPy
    return s


@_jit
def _state_values(I, Fl, qx, vx, grad, H):
    """The state variables' values into XVAL: sum of coef q[col] (level 0) or
    coef v[col] (level 1) over their two (column, coef) entries, or a sliding
    line's distance s (level 0) or speed grad s . v (level 1); grad (6,), H
    (6, 6) scratch."""
    base = I[3 * XVAL]
    for k in range(_rows(I, VAR)):
        g = _i(I, VAR, k, 3)
        if g >= 0:
            s = _line(I, Fl, qx, g, grad, H)
            if _i(I, VAR, k, 0) == 0:
                Fl[base + k] = s
            else:
                acc = 0.0
                for j in range(6):
                    acc += grad[j] * vx[_i(I, GEO, g, j)]
                Fl[base + k] = acc
            continue
        c1, c2 = _i(I, VAR, k, 1), _i(I, VAR, k, 2)
        a1, a2 = _f(I, Fl, VARC, k, 0), _f(I, Fl, VARC, k, 1)
        if _i(I, VAR, k, 0) == 0:
            Fl[base + k] = a1 * qx[c1] + a2 * qx[c2]
        else:
            Fl[base + k] = a1 * vx[c1] + a2 * vx[c2]


@_jit
def _phi_time_add(I, Fl, t, out, order):
    """out (m,) += the order-th partial time derivative of Phi (1: Phi_t,
    2: Phi_tt): -f'(t) or -f''(t) in the rows of drivers f(t)."""
    for i in range(_rows(I, LROW)):
        if _i(I, LFN, i, order) >= 0:
            out[_i(I, LROW, i, 0)] -= _eval(I, Fl, _i(I, LFN, i, order), t)
    for i in range(_rows(I, PROW)):
        if _i(I, PFN, i, order) >= 0:
            out[_i(I, PROW, i, 0)] -= _eval(I, Fl, _i(I, PFN, i, order), t)


@_jit
def phi(I, Fl, t, qx, out):
    """Phi(q) into out (m,) [m or rad]."""
    for i in range(_rows(I, CROW)):
        ax1, ay1 = _Au(I, Fl, qx, CCOL1, CS1, CEL, 0, i)
        ax2, ay2 = _Au(I, Fl, qx, CCOL2, CS2, CEL, 1, i)
        out[_i(I, CROW, i, 0)] = (qx[_i(I, CCOL2, i, 0)] - qx[_i(I, CCOL1, i, 0)]) + (ax2 - ax1)
        out[_i(I, CROW, i, 1)] = (qx[_i(I, CCOL2, i, 1)] - qx[_i(I, CCOL1, i, 1)]) + (ay2 - ay1)
    for i in range(_rows(I, PROW)):
        nx, ny, dx, dy, axL, ayL, axP, ayP = _pol(I, Fl, qx, i)
        out[_i(I, PROW, i, 0)] = nx * dx + ny * dy
        if _i(I, PFN, i, 0) >= 0:                  # a distance driver f(t)
            out[_i(I, PROW, i, 0)] -= _eval(I, Fl, _i(I, PFN, i, 0), t)
    for i in range(_rows(I, LROW)):
        val = (_f(I, Fl, LCOEF, i, 0) * qx[_i(I, LCOL, i, 0)]
               + _f(I, Fl, LCOEF, i, 1) * qx[_i(I, LCOL, i, 1)] - _f(I, Fl, LOFF, i, 0))
        if _i(I, LFN, i, 0) >= 0:                  # a driver f(t)
            val -= _eval(I, Fl, _i(I, LFN, i, 0), t)
        out[_i(I, LROW, i, 0)] = val
    if _rows(I, DROW) > 0:
        g = np.empty(6)
        for i in range(_rows(I, DROW)):
            dx, dy, ax1, ay1, ax2, ay2, L = _dist(I, Fl, qx, i, g)
            out[_i(I, DROW, i, 0)] = (dx * dx + dy * dy - L * L) / (2.0 * L)


@_jit
def phiqT_add(I, Fl, qx, lam, coef, out):
    """out[:n+3] += coef Phi_q^T lambda."""
    for i in range(_rows(I, CROW)):
        l0, l1 = coef * lam[_i(I, CROW, i, 0)], coef * lam[_i(I, CROW, i, 1)]
        ax1, ay1 = _Au(I, Fl, qx, CCOL1, CS1, CEL, 0, i)
        ax2, ay2 = _Au(I, Fl, qx, CCOL2, CS2, CEL, 1, i)
        out[_i(I, CCOL1, i, 0)] -= l0
        out[_i(I, CCOL1, i, 1)] -= l1
        out[_i(I, CCOL1, i, 2)] -= -ay1 * l0 + ax1 * l1
        out[_i(I, CCOL2, i, 0)] += l0
        out[_i(I, CCOL2, i, 1)] += l1
        out[_i(I, CCOL2, i, 2)] += -ay2 * l0 + ax2 * l1
    for i in range(_rows(I, PROW)):
        nx, ny, dx, dy, axL, ayL, axP, ayP = _pol(I, Fl, qx, i)
        g0, g1, g2, g3, g4, g5 = _pol_grad(nx, ny, dx, dy, axL, ayL, axP, ayP)
        lv = coef * lam[_i(I, PROW, i, 0)]
        out[_i(I, PCOLL, i, 0)] += lv * g0
        out[_i(I, PCOLL, i, 1)] += lv * g1
        out[_i(I, PCOLL, i, 2)] += lv * g2
        out[_i(I, PCOLP, i, 0)] += lv * g3
        out[_i(I, PCOLP, i, 1)] += lv * g4
        out[_i(I, PCOLP, i, 2)] += lv * g5
    for i in range(_rows(I, LROW)):
        lv = coef * lam[_i(I, LROW, i, 0)]
        out[_i(I, LCOL, i, 0)] += _f(I, Fl, LCOEF, i, 0) * lv
        out[_i(I, LCOL, i, 1)] += _f(I, Fl, LCOEF, i, 1) * lv
    if _rows(I, DROW) > 0:
        g = np.empty(6)
        for i in range(_rows(I, DROW)):
            _dist(I, Fl, qx, i, g)
            lv = coef * lam[_i(I, DROW, i, 0)]
            for j in range(6):
                out[_dist_col(I, i, j)] += lv * g[j]
    if _rows(I, ECOL) > 0:
        _elastic_phiqT_add(I, Fl, qx, lam, coef, out)


@_jit
def phiq_times(I, Fl, qx, vx, out):
    """Phi_q v into out (m,)."""
    for i in range(_rows(I, CROW)):
        ax1, ay1 = _Au(I, Fl, qx, CCOL1, CS1, CEL, 0, i)
        ax2, ay2 = _Au(I, Fl, qx, CCOL2, CS2, CEL, 1, i)
        w1, w2 = vx[_i(I, CCOL1, i, 2)], vx[_i(I, CCOL2, i, 2)]
        out[_i(I, CROW, i, 0)] = (vx[_i(I, CCOL2, i, 0)] - vx[_i(I, CCOL1, i, 0)]) + (-ay2 * w2 + ay1 * w1)
        out[_i(I, CROW, i, 1)] = (vx[_i(I, CCOL2, i, 1)] - vx[_i(I, CCOL1, i, 1)]) + (ax2 * w2 - ax1 * w1)
    for i in range(_rows(I, PROW)):
        nx, ny, dx, dy, axL, ayL, axP, ayP = _pol(I, Fl, qx, i)
        g0, g1, g2, g3, g4, g5 = _pol_grad(nx, ny, dx, dy, axL, ayL, axP, ayP)
        out[_i(I, PROW, i, 0)] = (g0 * vx[_i(I, PCOLL, i, 0)] + g1 * vx[_i(I, PCOLL, i, 1)] + g2 * vx[_i(I, PCOLL, i, 2)]
                        + g3 * vx[_i(I, PCOLP, i, 0)] + g4 * vx[_i(I, PCOLP, i, 1)] + g5 * vx[_i(I, PCOLP, i, 2)])
    for i in range(_rows(I, LROW)):
        out[_i(I, LROW, i, 0)] = _f(I, Fl, LCOEF, i, 0) * vx[_i(I, LCOL, i, 0)] + _f(I, Fl, LCOEF, i, 1) * vx[_i(I, LCOL, i, 1)]
    if _rows(I, DROW) > 0:
        g = np.empty(6)
        for i in range(_rows(I, DROW)):
            _dist(I, Fl, qx, i, g)
            acc = 0.0
            for j in range(6):
                acc += g[j] * vx[_dist_col(I, i, j)]
            out[_i(I, DROW, i, 0)] = acc
    if _rows(I, ECOL) > 0:
        _elastic_phiq_times(I, Fl, qx, vx, out)


@_jit
def _spring_points(I, Fl, qx, i):
    """(d_x, d_y, (A u)_1, (A u)_2) of spring-damper i at qx: d = p2 - p1 [m]
    and its points' offsets from their frames (A u, u = s + S q_e on a
    flexible beam: ``_Au``); the kinematics of ``_spring`` in scalars."""
    ax1, ay1 = _Au(I, Fl, qx, SCOL1, SS1, SEL, 0, i)
    ax2, ay2 = _Au(I, Fl, qx, SCOL2, SS2, SEL, 1, i)
    dx = (qx[_i(I, SCOL2, i, 0)] - qx[_i(I, SCOL1, i, 0)]) + (ax2 - ax1)
    dy = (qx[_i(I, SCOL2, i, 1)] - qx[_i(I, SCOL1, i, 1)]) + (ay2 - ay1)
    return dx, dy, ax1, ay1, ax2, ay2


@_jit
def _free_length(I, Fl, i, dx, dy):
    """The free length spring i's force k (l - l0') e reads at d = (dx, dy):
    l0, or -l0 while d points against the spring's held direction u_ref
    (SPAR columns 3, 4; (0, 0): none held, the physical law).

    A spring with a free length whose points pass each other has a force
    that turns over at the pass (e = d / l flips). While a step is landed on
    the pass (``loop.TimeLoop.land``), u_ref holds the direction before it,
    so that the steps the event locator tries feel the old branch continued
    past the root (k (l + l0) e with e the new direction is -k (-l - l0)
    e_old: the force of the signed length -l, smooth through the root) and
    not the new one over their whole length, an O(step) error of an implicit
    step that ends past the root; the commit clears u_ref, and the method
    restarts on the new branch. The potential energy (``_potential``) keeps
    the physical law: the two agree except past the root within a landing."""
    l0 = _f(I, Fl, SPAR, i, 2)
    ux, uy = _f(I, Fl, SPAR, i, 3), _f(I, Fl, SPAR, i, 4)
    if dx * ux + dy * uy < 0.0:
        return -l0
    return l0


@_jit
def _direction(dx, dy, l):
    """e = d / l of a spring-damper, (0, 0) at l = 0: two coincident points
    have no direction, and no force along it (``SpringDamperGroup``)."""
    if l > 0.0:
        return dx / l, dy / l
    return 0.0, 0.0


@_jit
def _direction_derivative(ex, ey, l):
    """(P00, P01, P11) of de/dd = (I - e e^T) / l, 0 at l = 0."""
    if l > 0.0:
        return (1.0 - ex * ex) / l, -ex * ey / l, (1.0 - ey * ey) / l
    return 0.0, 0.0, 0.0


@_jit
def _spring(I, Fl, qx, vx, i, G, v6):
    """Kinematics of spring i: D = dd/dq_local into G (2, 6), local v into v6;
    returns (d, ddot, l, A s1, A s2)."""
    dx, dy, ax1, ay1, ax2, ay2 = _spring_points(I, Fl, qx, i)
    G[:] = 0.0
    G[0, 0] = -1.0
    G[1, 1] = -1.0
    G[0, 2] = ay1
    G[1, 2] = -ax1
    G[0, 3] = 1.0
    G[1, 4] = 1.0
    G[0, 5] = -ay2
    G[1, 5] = ax2
    for j in range(3):
        v6[j] = vx[_i(I, SCOL1, i, j)]
        v6[3 + j] = vx[_i(I, SCOL2, i, j)]
    ddx = 0.0
    ddy = 0.0
    for j in range(6):
        ddx += G[0, j] * v6[j]
        ddy += G[1, j] * v6[j]
    return dx, dy, ddx, ddy, math.sqrt(dx * dx + dy * dy), ax1, ay1, ax2, ay2


@_jit
def _friction_law(I, Fl, i, z, lam, slip):
    """(tau, dtau/dz, dtau/dN_raw, R) of friction instance i at joint speed z,
    the law of the ``FrictionGroup`` notes, with R = |lambda_J| (N = r R).
    dtau/dlambda_J = dtau/dN_raw lambda_J / R (0 at R = 0). ``slip`` (k,),
    read where it is not NaN, replaces tanh(z/v_reg) (and mu(z) by mu_s):
    the Coulomb limit at rest of the initial conditions; empty: the law."""
    mu_k, mu_s, v_s = _f(I, Fl, FRP, i, 0), _f(I, Fl, FRP, i, 1), _f(I, Fl, FRP, i, 2)
    c, v_reg, rad = _f(I, Fl, FRP, i, 3), _f(I, Fl, FRP, i, 4), _f(I, Fl, FRP, i, 5)
    e, dmu = 0.0, 0.0
    if v_s > 0.0:
        e = math.exp(-(z / v_s) ** 2)
        dmu = (mu_s - mu_k) * e * (-2.0 * z / (v_s * v_s))
    mu = mu_k + (mu_s - mu_k) * e
    th = math.tanh(z / v_reg)
    if i < slip.shape[0] and not math.isnan(slip[i]):
        th, mu, dmu = slip[i], mu_s, 0.0
    row, nr = _i(I, FRI, i, 3), _i(I, FRI, i, 4)
    R2 = 0.0
    for k in range(nr):
        R2 += lam[row + k] * lam[row + k]
    R = math.sqrt(R2)
    N = rad * R
    tau = -N * mu * th - c * z
    dz = -N * (dmu * th + mu * (1.0 - th * th) / v_reg) - c
    return tau, dz, -mu * th * rad, R


@_jit
def _friction_kin(I, Fl, i, qx, vx, grad, H):
    """Joint speed z of friction instance i; its direction w into grad (6,)
    (revolute: (1, -1) on its +col, -col) and, for a sliding line, d^2 s
    into H. Returns (z, g): g the line's row, -1 for a revolute."""
    g = _i(I, FRI, i, 2)
    if g < 0:
        grad[0], grad[1] = 1.0, -1.0
        return vx[_i(I, FRI, i, 0)] - vx[_i(I, FRI, i, 1)], g
    _line(I, Fl, qx, g, grad, H)
    z = 0.0
    for j in range(6):
        z += grad[j] * vx[_i(I, GEO, g, j)]
    return z, g


@_jit
def _friction_col(I, i, g, a):
    """Column of local entry a of friction instance i (line g, or a revolute)."""
    return _i(I, FRI, i, a) if g < 0 else _i(I, GEO, g, a)


# --------------------------------------------------------------------------------------------
# Contacts and joint limits: one-sided gaps g(q) and the Hunt-Crossley law
#
# One instance per gap (``assembly.contact.ContactGroup``'s instances, in its
# order). KGI: (kind, line row in GEO or -1); KCOL: the six columns (x, y, phi
# of the first body, then of the second); KPAR: (offset, sign, s1 (2), s2 (2),
# n0 (2), r, K, n, chi, mu, v_reg); KIMP: the impact speed of each closed gap
# (0 while open), the contact's state, written by the time loop at its events.
# The geometries and the law are those of ``model.contact`` (its module notes):
# line  g = n . (p_P - p_L) - r            (``_line`` with the normal as direction)
# slide g = sign (s - bound)                (``_line``)
# angle g = sign (phi_2 - phi_1 - bound)
# circle g = (R - r) - |p_P - p_C|
# f = K delta^n (1 + chi ddelta/dt / v_impact) >= 0, delta = -g, Q = f grad g
# plus, with mu > 0, the regularised Coulomb force -mu f tanh(v_t / v_reg) w.
# --------------------------------------------------------------------------------------------

#: ``model.contact.SPEED_FLOOR`` as a literal (checked at import, as the recipe indices are)
SPEED_FLOOR = 1e-3
if SPEED_FLOOR != _CONTACT_SPEED_FLOOR:     # pragma: no cover (a developer's error)
    raise ImportError("compiled.SPEED_FLOOR differs from model.contact.SPEED_FLOOR")
#: gap kinds (KGI's first column), as ``engine.CompiledModel`` writes them
GAP_LINE, GAP_SLIDE, GAP_ANGLE, GAP_CIRCLE = 0, 1, 2, 3


@_jit
def _gap(I, Fl, qx, i, grad, H):
    """g of gap i [m or rad], dg/dq into grad (6,) and d^2 g/dq^2 into H (6, 6)
    over its KCOL columns (the geometries of ``model.contact``)."""
    kind = _i(I, KGI, i, 0)
    off, sgn = _f(I, Fl, KPAR, i, 0), _f(I, Fl, KPAR, i, 1)
    if kind == GAP_LINE or kind == GAP_SLIDE:
        s = _line(I, Fl, qx, _i(I, KGI, i, 1), grad, H)
        if sgn != 1.0:
            for a in range(6):
                grad[a] *= sgn
                for b in range(6):
                    H[a, b] *= sgn
        return sgn * (s - off)
    H[:, :] = 0.0
    grad[:] = 0.0
    if kind == GAP_ANGLE:
        grad[2], grad[5] = -sgn, sgn
        return sgn * (qx[_i(I, KCOL, i, 5)] - qx[_i(I, KCOL, i, 2)] - off)
    # circle: g = c - |d|, d = p_P - p_C
    phC, phP = qx[_i(I, KCOL, i, 2)], qx[_i(I, KCOL, i, 5)]
    cC, sC, cP, sP = math.cos(phC), math.sin(phC), math.cos(phP), math.sin(phP)
    s1x, s1y, s2x, s2y = (_f(I, Fl, KPAR, i, 2), _f(I, Fl, KPAR, i, 3), _f(I, Fl, KPAR, i, 4),
                          _f(I, Fl, KPAR, i, 5))
    aCx, aCy = cC * s1x - sC * s1y, sC * s1x + cC * s1y
    aPx, aPy = cP * s2x - sP * s2y, sP * s2x + cP * s2y
    dx = qx[_i(I, KCOL, i, 3)] + aPx - qx[_i(I, KCOL, i, 0)] - aCx
    dy = qx[_i(I, KCOL, i, 4)] + aPy - qx[_i(I, KCOL, i, 1)] - aCy
    l = math.sqrt(dx * dx + dy * dy)
    if l == 0.0:                   # centred: open by the clearance, no normal
        return off
    ex, ey = _direction(dx, dy, l)
    D = np.zeros((2, 6))           # dd/dq
    D[0, 0], D[1, 1], D[0, 3], D[1, 4] = -1.0, -1.0, 1.0, 1.0
    D[0, 2], D[1, 2] = aCy, -aCx   # -B(phi_C) s_C
    D[0, 5], D[1, 5] = -aPy, aPx   # B(phi_P) s_P
    P00, P01, P11 = _direction_derivative(ex, ey, l)
    for a in range(6):
        grad[a] = -(ex * D[0, a] + ey * D[1, a])
        pa0 = P00 * D[0, a] + P01 * D[1, a]
        pa1 = P01 * D[0, a] + P11 * D[1, a]
        for b in range(6):
            H[a, b] = -(pa0 * D[0, b] + pa1 * D[1, b])
    H[2, 2] -= ex * aCx + ey * aCy
    H[5, 5] += ex * aPx + ey * aPy
    return off - l


@_jit
def _slip(I, Fl, qx, i, w, dw):
    """The slip direction w (6,) of gap i's contact, v_t = w . v, and dw/dq
    into dw (6, 6) (a line or a hole; ``model.contact``'s notes)."""
    c = np.empty(6, np.int64)
    for a in range(6):
        c[a] = _i(I, KCOL, i, a)
    w[:] = 0.0
    dw[:, :] = 0.0
    r = _f(I, Fl, KPAR, i, 8)
    ph1, ph2 = qx[c[2]], qx[c[5]]
    c1, s1, c2, s2 = math.cos(ph1), math.sin(ph1), math.cos(ph2), math.sin(ph2)
    a2x = c2 * _f(I, Fl, KPAR, i, 4) - s2 * _f(I, Fl, KPAR, i, 5)
    a2y = s2 * _f(I, Fl, KPAR, i, 4) + c2 * _f(I, Fl, KPAR, i, 5)
    B2x, B2y = -a2y, a2x
    dnu = np.zeros((2, 6))
    if _i(I, KGI, i, 0) == GAP_LINE:
        n0x, n0y = _f(I, Fl, KPAR, i, 6), _f(I, Fl, KPAR, i, 7)
        nux, nuy = c1 * n0x - s1 * n0y, s1 * n0x + c1 * n0y
        dnu[0, 2], dnu[1, 2] = -nuy, nux
    else:
        a1x = c1 * _f(I, Fl, KPAR, i, 2) - s1 * _f(I, Fl, KPAR, i, 3)
        a1y = s1 * _f(I, Fl, KPAR, i, 2) + c1 * _f(I, Fl, KPAR, i, 3)
        dx = qx[c[3]] + a2x - qx[c[0]] - a1x
        dy = qx[c[4]] + a2y - qx[c[1]] - a1y
        l = math.sqrt(dx * dx + dy * dy)
        if l == 0.0:
            return
        ex, ey = _direction(dx, dy, l)
        D = np.zeros((2, 6))
        D[0, 0], D[1, 1], D[0, 3], D[1, 4] = -1.0, -1.0, 1.0, 1.0
        D[0, 2], D[1, 2] = a1y, -a1x
        D[0, 5], D[1, 5] = B2x, B2y
        nux, nuy = -ex, -ey
        P00, P01, P11 = _direction_derivative(ex, ey, l)
        for b in range(6):
            dnu[0, b] = -(P00 * D[0, b] + P01 * D[1, b])
            dnu[1, b] = -(P01 * D[0, b] + P11 * D[1, b])
    taux, tauy = -nuy, nux
    # c - r_1 = q_2 + A_2 s_P - r nu - q_1
    cx = qx[c[3]] + a2x - r * nux - qx[c[0]]
    cy = qx[c[4]] + a2y - r * nuy - qx[c[1]]
    w[0], w[1], w[3], w[4] = -taux, -tauy, taux, tauy
    w[2] = -(nux * cx + nuy * cy)
    w[5] = nux * a2x + nuy * a2y - r
    for b in range(6):
        dtx, dty = -dnu[1, b], dnu[0, b]        # dtau = J dnu
        dcx, dcy = -r * dnu[0, b], -r * dnu[1, b]
        if b == 0:
            dcx -= 1.0
        elif b == 1:
            dcy -= 1.0
        elif b == 3:
            dcx += 1.0
        elif b == 4:
            dcy += 1.0
        elif b == 5:
            dcx += B2x
            dcy += B2y
        dw[0, b], dw[1, b], dw[3, b], dw[4, b] = -dtx, -dty, dtx, dty
        dw[2, b] = -(dnu[0, b] * cx + dnu[1, b] * cy + dcx * nux + dcy * nuy)
        dw[5, b] = dnu[0, b] * a2x + dnu[1, b] * a2y
    dw[5, 5] += nux * B2x + nuy * B2y


@_jit
def _contact_friction(I, Fl, qx, vx, i, f, w, dw):
    """Friction at gap i's contact under normal force f: its slip direction
    and dw/dq into w, dw (``_slip``); returns (F_t, v_t, T) with v_t = w . v,
    T = tanh(v_t / v_reg), F_t = -mu f T."""
    _slip(I, Fl, qx, i, w, dw)
    vt = 0.0
    for a in range(6):
        vt += w[a] * vx[_i(I, KCOL, i, a)]
    T = math.tanh(vt / _f(I, Fl, KPAR, i, 13))
    return -_f(I, Fl, KPAR, i, 12) * f * T, vt, T


@_jit
def _contact_law(I, Fl, qx, vx, i, imp, grad, H):
    """Gap i's normal force under the Hunt-Crossley law (module notes of
    ``assembly.contact``) at impact speed ``imp`` (0: not armed), with grad,
    H of ``_gap``: returns (g, delta, ddelta/dt, f, K delta^n, v_impact,
    armed); f = 0 where the gap is open or the force is cut."""
    g = _gap(I, Fl, qx, i, grad, H)
    if g >= 0.0:
        return g, 0.0, 0.0, 0.0, 0.0, 0.0, False
    delta = -g
    ddelta = 0.0
    for a in range(6):
        ddelta -= grad[a] * vx[_i(I, KCOL, i, a)]
    elastic = _f(I, Fl, KPAR, i, 9) * delta ** _f(I, Fl, KPAR, i, 10)
    # not armed yet (a trial step into a contact its event has not closed): the
    # approach speed now stands for the impact speed
    speed = imp if imp > 0.0 else max(ddelta, SPEED_FLOOR)
    armed = imp > 0.0 or ddelta <= SPEED_FLOOR
    f = elastic * (1.0 + _f(I, Fl, KPAR, i, 11) * ddelta / speed)
    return g, delta, ddelta, max(f, 0.0), elastic, speed, armed


@_jit
def _contacts_add(I, Fl, qx, vx, out):
    """The contacts' generalized forces f grad g (+ F_t w with friction) added
    to out (n+3,) [N, N m]."""
    grad, H = np.empty(6), np.empty((6, 6))
    w, dw = np.empty(6), np.empty((6, 6))
    for i in range(_rows(I, KGI)):
        g, delta, ddelta, f, elastic, speed, armed = _contact_law(
            I, Fl, qx, vx, i, _f(I, Fl, KIMP, i, 0), grad, H)
        if f <= 0.0:
            continue
        for a in range(6):
            out[_i(I, KCOL, i, a)] += f * grad[a]
        if _f(I, Fl, KPAR, i, 12) > 0.0:
            Ft, vt, T = _contact_friction(I, Fl, qx, vx, i, f, w, dw)
            for a in range(6):
                out[_i(I, KCOL, i, a)] += Ft * w[a]


@_jit
def _emit_contacts(I, Fl, n, qx, vx, R, C, V, p, r0, c0, cq, cv):
    """The contacts' -(cq Q_q + cv Q_v) at (r0, c0) (``assembly.contact``'s
    notes): all 36 entries of every gap whose bodies are not the
    ground's, zeros while it is open, so that the pattern stays fixed."""
    grad, H = np.empty(6), np.empty((6, 6))
    w, dw = np.empty(6), np.empty((6, 6))
    dfdq, dfdv, Hv = np.empty(6), np.empty(6), np.empty(6)
    Qq, Qv = np.empty((6, 6)), np.empty((6, 6))
    v = np.empty(6)
    for i in range(_rows(I, KGI)):
        g, delta, ddelta, f, elastic, speed, armed = _contact_law(
            I, Fl, qx, vx, i, _f(I, Fl, KIMP, i, 0), grad, H)
        Qq[:, :] = 0.0
        Qv[:, :] = 0.0
        if f > 0.0:
            K, ex, chi = _f(I, Fl, KPAR, i, 9), _f(I, Fl, KPAR, i, 10), _f(I, Fl, KPAR, i, 11)
            for a in range(6):
                v[a] = vx[_i(I, KCOL, i, a)]
            # df/d(delta) and the damping's df/d(ddelta); unarmed, f = K delta^n
            # (1 + chi) does not depend on ddelta
            damp = elastic * chi / speed if armed else 0.0
            df_ddelta = ex * K * delta ** (ex - 1.0) * (1.0 + chi * ddelta / speed)
            for a in range(6):
                Hv[a] = 0.0
                for b in range(6):
                    Hv[a] += H[a, b] * v[b]
            for a in range(6):
                dfdq[a] = -df_ddelta * grad[a] - damp * Hv[a]
                dfdv[a] = -damp * grad[a]
            for a in range(6):
                for b in range(6):
                    Qq[a, b] = grad[a] * dfdq[b] + f * H[a, b]
                    Qv[a, b] = grad[a] * dfdv[b]
            mu = _f(I, Fl, KPAR, i, 12)
            if mu > 0.0:
                # Q = F_t w, F_t = -mu f T(v_t): Q_q = w dF_t/dq^T + F_t dw/dq,
                # Q_v = w dF_t/dv^T; dv_t/dq = (dw/dq)^T v, dv_t/dv = w
                Ft, vt, T = _contact_friction(I, Fl, qx, vx, i, f, w, dw)
                dT = (1.0 - T * T) / _f(I, Fl, KPAR, i, 13)
                for b in range(6):
                    dvt = 0.0
                    for a in range(6):
                        dvt += dw[a, b] * v[a]
                    dFq = -mu * (T * dfdq[b] + f * dT * dvt)
                    dFv = -mu * (T * dfdv[b] + f * dT * w[b])
                    for a in range(6):
                        Qq[a, b] += w[a] * dFq + Ft * dw[a, b]
                        Qv[a, b] += w[a] * dFv
        for a in range(6):
            ra = _i(I, KCOL, i, a)
            if ra >= n:
                continue
            for b in range(6):
                cb = _i(I, KCOL, i, b)
                if cb < n:
                    p = _put(R, C, V, p, r0 + ra, c0 + cb, -(cq * Qq[a, b] + cv * Qv[a, b]))
    return p


@_jit
def _spring_passed(I, Fl, qa, qb):
    """Whether the points of a spring-damper with a free length passed each
    other between configurations qa and qb (n+3,): d_a . d_b < 0, where its
    force k (l - l0) e flips direction (``events.EventLocator``)."""
    for i in range(_rows(I, SCOL1)):
        if _f(I, Fl, SPAR, i, 2) > 0.0:
            dxa, dya, _, _, _, _ = _spring_points(I, Fl, qa, i)
            dxb, dyb, _, _, _, _ = _spring_points(I, Fl, qb, i)
            if dxa * dxb + dya * dyb < 0.0:
                return True
    return False


@_jit
def _spring_rate(I, Fl, qx, vx, i, ex, ey, ax1, ay1, ax2, ay2):
    """ldot = e . d' of spring-damper i, its points' offsets A u from
    ``_spring_points`` (with the elastic terms' velocities -+ A S_k v_k of a
    point on a flexible beam)."""
    w1, w2 = vx[_i(I, SCOL1, i, 2)], vx[_i(I, SCOL2, i, 2)]
    ddx = (vx[_i(I, SCOL2, i, 0)] - vx[_i(I, SCOL1, i, 0)]) + (-ay2 * w2 + ay1 * w1)
    ddy = (vx[_i(I, SCOL2, i, 1)] - vx[_i(I, SCOL1, i, 1)]) + (ax2 * w2 - ax1 * w1)
    for side in range(2):
        k0, k1 = _span(I, SEL, i, side)
        ph = qx[_i(I, SCOL1 if side == 0 else SCOL2, i, 2)]
        sg = -1.0 if side == 0 else 1.0
        for k in range(k0, k1):
            Ax, Ay, Bx, By = _eshape(I, Fl, k, ph)
            vk = vx[_i(I, ECOL, k, 0)]
            ddx += sg * Ax * vk
            ddy += sg * Ay * vk
    return ex * ddx + ey * ddy


@_jit
def _springs_add(I, Fl, qx, vx, out):
    """The spring-dampers' Q = -D^T (f e), f = k (l - l0) + c ldot, added to
    out (n+3,) [N, N m]."""
    for i in range(_rows(I, SCOL1)):
        # (no scratch array on this hot path); a point on a flexible beam at A u (its terms below)
        dx, dy, ax1, ay1, ax2, ay2 = _spring_points(I, Fl, qx, i)
        l = math.sqrt(dx * dx + dy * dy)
        ex, ey = _direction(dx, dy, l)
        f = _f(I, Fl, SPAR, i, 0) * (l - _free_length(I, Fl, i, dx, dy))
        if _f(I, Fl, SPAR, i, 1) != 0.0:
            f = f + _f(I, Fl, SPAR, i, 1) * _spring_rate(I, Fl, qx, vx, i, ex, ey, ax1, ay1,
                                                         ax2, ay2)
        fx, fy = f * ex, f * ey
        # Q = -D^T (f e), D = dd/dq_local (``_spring``'s G)
        out[_i(I, SCOL1, i, 0)] += fx
        out[_i(I, SCOL1, i, 1)] += fy
        out[_i(I, SCOL1, i, 2)] -= ay1 * fx - ax1 * fy
        out[_i(I, SCOL2, i, 0)] -= fx
        out[_i(I, SCOL2, i, 1)] -= fy
        out[_i(I, SCOL2, i, 2)] -= -ay2 * fx + ax2 * fy
        for side in range(2):              # elastic terms: -+ (A S_k) . (f e)
            k0, k1 = _span(I, SEL, i, side)
            ph = qx[_i(I, SCOL1 if side == 0 else SCOL2, i, 2)]
            sg = 1.0 if side == 0 else -1.0
            for k in range(k0, k1):
                Ax, Ay, Bx, By = _eshape(I, Fl, k, ph)
                out[_i(I, ECOL, k, 0)] += sg * (Ax * fx + Ay * fy)


@_jit
def _inputs_add(I, Fl, t, qx, vx, out):
    """The loads that put work in, added to out (n+3,) [N, N m]: point
    forces F(t) (J^T F), torques tau(t) and loads of the state tau(t, x) w
    (+-tau on a joint's bodies, or tau grad s along a sliding line)."""
    for i in range(_rows(I, FCOL)):
        ax, ay = _Au(I, Fl, qx, FCOL, FS, FEL, 0, i)
        fx, fy = _point_force(I, Fl, t, i)
        out[_i(I, FCOL, i, 0)] += fx
        out[_i(I, FCOL, i, 1)] += fy
        out[_i(I, FCOL, i, 2)] += -ay * fx + ax * fy
        k0, k1 = _span(I, FEL, i, 0)
        for k in range(k0, k1):            # a point on a flexible beam: (A S_k) . F
            Ax, Ay, Bx, By = _eshape(I, Fl, k, qx[_i(I, FCOL, i, 2)])
            out[_i(I, ECOL, k, 0)] += Ax * fx + Ay * fy
    for i in range(_rows(I, TCOL)):
        out[_i(I, TCOL, i, 0)] += _eval(I, Fl, _i(I, TFN, i, 0), t)
    if _rows(I, STQ) > 0:                          # loads of the state, in joints
        grad, H = np.empty(6), np.empty((6, 6))
        _state_values(I, Fl, qx, vx, grad, H)
        for i in range(_rows(I, STQ)):
            tau = _eval(I, Fl, _i(I, STQ, i, 0), t)
            g = _i(I, STQ, i, 3)
            if g < 0:                              # a torque: +tau, -tau
                out[_i(I, STQ, i, 1)] += tau
                out[_i(I, STQ, i, 2)] -= tau
            else:                                  # a force along a sliding line: tau grad s
                _line(I, Fl, qx, g, grad, H)
                for j in range(6):
                    out[_i(I, GEO, g, j)] += tau * grad[j]


@_jit
def _forces(I, Fl, t, qx, vx, lam, slip, out):
    """Q(q, v, lambda) into out (n+3,) [N, N m] (overwritten): gravity (Q0),
    spring-dampers, rotational spring-dampers, the loads that put work in,
    friction (reading lambda (m,), and ``slip`` as ``_friction_law``),
    contacts and flexible beams."""
    for j in range(out.shape[0]):       # a loop: numba's array-to-array slice copy checks overlap
        out[j] = _f(I, Fl, Q0, j, 0)
    _springs_add(I, Fl, qx, vx, out)
    for i in range(_rows(I, RCOL)):
        tau = (_f(I, Fl, RPAR, i, 0) * (qx[_i(I, RCOL, i, 1)] - qx[_i(I, RCOL, i, 0)] - _f(I, Fl, RPAR, i, 2))
               + _f(I, Fl, RPAR, i, 1) * (vx[_i(I, RCOL, i, 1)] - vx[_i(I, RCOL, i, 0)]))
        out[_i(I, RCOL, i, 0)] += tau
        out[_i(I, RCOL, i, 1)] -= tau
    _inputs_add(I, Fl, t, qx, vx, out)
    if _rows(I, FRI) > 0:                          # friction: tau w
        grad, H = np.empty(6), np.empty((6, 6))
        for i in range(_rows(I, FRI)):
            z, g = _friction_kin(I, Fl, i, qx, vx, grad, H)
            tau, dz, dN, Rn = _friction_law(I, Fl, i, z, lam, slip)
            for a in range(2 if g < 0 else 6):
                out[_friction_col(I, i, g, a)] += tau * grad[a]
    if _rows(I, KGI) > 0:                          # contacts and joint limits
        _contacts_add(I, Fl, qx, vx, out)
    if _rows(I, BEAM) > 0:                         # flexible beams
        _ffr_forces_add(I, Fl, qx, vx, out)


@_jit
def forces(I, Fl, t, qx, vx, lam, out):
    """Q(q, v, lambda) into out (n+3,) [N, N m] (overwritten), friction by its
    law: ``_forces``, the time loops' evaluation."""
    _forces(I, Fl, t, qx, vx, lam, Fl[:0], out)


# --------------------------------------------------------------------------------------------
# Joint points on flexible beams: the elastic terms of Phi_q (``PointSet``)
#
# A point of a flexible beam is at r + A(phi) u, u = s + sum_k S_k q_k. Its
# position's derivative by q_k is A S_k, and the only second derivatives the
# elastic terms add are d^2/dphi dq_k = B S_k (Shabana, Dynamics of Multibody
# Systems, sec. 5.3). The rigid kernels above already read u (``_Au``) where
# they read s; the functions below add the entries of the elastic columns.
# Coincidence: Phi = p2 - p1, sign -1 for point 1. Point on line: Phi = n . (p_P
# - p_L), n = A_L n0: d/dq_k = +-n . (A S_k), and for a term of P the mixed
# entries (phi_L, q_k) = (B_L n0) . (A_P S_k) and (phi_P, q_k) = n . (B_P S_k);
# a term of L has the constant gradient -n0 . S_k and no second derivative.
# --------------------------------------------------------------------------------------------

@_jit
def _elastic_grad(I, Fl, qx, rows, cols, vals):
    """The elastic entries of Phi_q: (constraint row, column, value) into rows,
    cols, vals (each of 2 x the elastic terms); returns their count.
    Coincidence: +-A S_k per row; point on line: +-n . (A S_k)."""
    p = 0
    for i in range(_rows(I, CROW)):
        for sd in range(2):
            sg, ph = (-1.0 if sd == 0 else 1.0), qx[_i(I, CCOL1 if sd == 0 else CCOL2, i, 2)]
            k0, k1 = _span(I, CEL, i, sd)
            for k in range(k0, k1):
                ax, ay, bx, by = _eshape(I, Fl, k, ph)
                for a in range(2):
                    rows[p], cols[p] = _i(I, CROW, i, a), _i(I, ECOL, k, 0)
                    vals[p] = sg * (ax if a == 0 else ay)
                    p += 1
    for i in range(_rows(I, PROW)):
        nx, ny, dx, dy, axL, ayL, axP, ayP = _pol(I, Fl, qx, i)
        p = _scalar_row_terms(I, Fl, qx, PCOLL, PCOLP, PEL, i, _i(I, PROW, i, 0), nx, ny,
                              rows, cols, vals, p)
    if _rows(I, DSP) > 0:
        g = np.empty(6)
        for i in range(_rows(I, DROW)):
            dx, dy, ax1, ay1, ax2, ay2, L = _dist(I, Fl, qx, i, g)
            p = _scalar_row_terms(I, Fl, qx, DCOL1, DCOL2, DSP, i, _i(I, DROW, i, 0), dx / L,
                                  dy / L, rows, cols, vals, p)
    return p


@_jit
def _scalar_row_terms(I, Fl, qx, col1, col2, el, i, row, nx, ny, rows, cols, vals, p):
    """The elastic entries of a scalar row whose gradient is n . dd/dq (a point
    on a line: its normal; a distance joint: d / L): -+n . (A S_k) of the
    terms of instance i's first and second point, from p on; returns p."""
    for sd in range(2):
        sg, ph = (-1.0 if sd == 0 else 1.0), qx[_i(I, col1 if sd == 0 else col2, i, 2)]
        k0, k1 = _span(I, el, i, sd)
        for k in range(k0, k1):
            ax, ay, bx, by = _eshape(I, Fl, k, ph)
            rows[p], cols[p] = row, _i(I, ECOL, k, 0)
            vals[p] = sg * (nx * ax + ny * ay)
            p += 1
    return p


@_jit
def _dist_local(I, Fl, qx, i, cols, D, Hd):
    """Distance joint i with points on flexible beams over its local
    columns (x, y, phi of both bodies, then each point's elastic terms):
    their columns into cols, D = dd/dq_local (2, nc) and Hd = d^2 d/dq_local^2
    (2, nc, nc) into D, Hd (zeroed; d^2 p/dphi^2 = -A u, d^2 p/dphi dq_k =
    B S_k). Returns (nc, dx, dy, L); Phi's Hessian is (D^T D + d . Hd) / L."""
    g = np.empty(6)
    dx, dy, ax1, ay1, ax2, ay2, L = _dist(I, Fl, qx, i, g)
    D[:, :] = 0.0
    Hd[:, :, :] = 0.0
    for j in range(3):
        cols[j] = _i(I, DCOL1, i, j)
        cols[3 + j] = _i(I, DCOL2, i, j)
    D[0, 0], D[1, 1], D[0, 3], D[1, 4] = -1.0, -1.0, 1.0, 1.0
    D[0, 2], D[1, 2], D[0, 5], D[1, 5] = ay1, -ax1, -ay2, ax2
    Hd[0, 2, 2], Hd[1, 2, 2], Hd[0, 5, 5], Hd[1, 5, 5] = ax1, ay1, -ax2, -ay2
    j = 6
    for sd in range(2):
        sg, cph = (-1.0, 2) if sd == 0 else (1.0, 5)
        k0, k1 = _span(I, DSP, i, sd)
        for k in range(k0, k1):
            cols[j] = _i(I, ECOL, k, 0)
            ax, ay, bx, by = _eshape(I, Fl, k, qx[cols[cph]])
            D[0, j], D[1, j] = sg * ax, sg * ay
            Hd[0, cph, j], Hd[1, cph, j] = sg * bx, sg * by
            Hd[0, j, cph], Hd[1, j, cph] = sg * bx, sg * by
            j += 1
    return j, dx, dy, L


@_jit
def _dist_columns(I):
    """The most local columns of a distance joint (``_dist_local``)."""
    out = 6
    for i in range(_rows(I, DROW)):
        a0, a1 = _span(I, DSP, i, 0)
        b0, b1 = _span(I, DSP, i, 1)
        out = max(out, 6 + (a1 - a0) + (b1 - b0))
    return out


@_inline
def _dist_h(D, Hd, dx, dy, L, a, b):
    """Entry (a, b) of a distance row's Hessian (``_dist_local``)."""
    return (D[0, a] * D[0, b] + D[1, a] * D[1, b] + dx * Hd[0, a, b] + dy * Hd[1, a, b]) / L


@_jit
def _elastic_phiqT_add(I, Fl, qx, lam, coef, out):
    """out += coef Phi_q^T lambda in the elastic columns."""
    k = 2 * _rows(I, ECOL)
    rows, cols, vals = np.empty(k, np.int64), np.empty(k, np.int64), np.empty(k)
    for e in range(_elastic_grad(I, Fl, qx, rows, cols, vals)):
        out[cols[e]] += coef * lam[rows[e]] * vals[e]


@_jit
def _elastic_phiq_times(I, Fl, qx, vx, out):
    """out += Phi_q v of the elastic columns."""
    k = 2 * _rows(I, ECOL)
    rows, cols, vals = np.empty(k, np.int64), np.empty(k, np.int64), np.empty(k)
    for e in range(_elastic_grad(I, Fl, qx, rows, cols, vals)):
        out[rows[e]] += vals[e] * vx[cols[e]]


@_jit
def _emit_elastic_phiq(I, Fl, n, qx, R, C, V, p, r0, c0, coef, transpose):
    """The elastic columns of coef Phi_q at (r0, c0) (or of Phi_q^T)."""
    k = 2 * _rows(I, ECOL)
    rows, cols, vals = np.empty(k, np.int64), np.empty(k, np.int64), np.empty(k)
    for e in range(_elastic_grad(I, Fl, qx, rows, cols, vals)):
        if transpose:
            p = _put(R, C, V, p, r0 + cols[e], c0 + rows[e], coef * vals[e])
        else:
            p = _put(R, C, V, p, r0 + rows[e], c0 + cols[e], coef * vals[e])
    return p


@_jit
def _emit_elastic_hess(I, Fl, n, qx, lam, R, C, V, p, r0, c0, coef):
    """The elastic entries of coef (Phi_q^T lambda)_q at (r0, c0): the mixed
    (phi, q_k) second derivatives, both triangles."""
    for i in range(_rows(I, CROW)):
        l0, l1 = coef * lam[_i(I, CROW, i, 0)], coef * lam[_i(I, CROW, i, 1)]
        for sd in range(2):
            cph = _i(I, CCOL1 if sd == 0 else CCOL2, i, 2)
            sg, ph = (-1.0 if sd == 0 else 1.0), qx[cph]
            k0, k1 = _span(I, CEL, i, sd)
            for k in range(k0, k1):
                ax, ay, bx, by = _eshape(I, Fl, k, ph)
                col, val = _i(I, ECOL, k, 0), sg * (l0 * bx + l1 * by)
                if cph < n:
                    p = _put(R, C, V, p, r0 + cph, c0 + col, val)
                    p = _put(R, C, V, p, r0 + col, c0 + cph, val)
    for i in range(_rows(I, PROW)):
        nx, ny, dx, dy, axL, ayL, axP, ayP = _pol(I, Fl, qx, i)
        lv = coef * lam[_i(I, PROW, i, 0)]
        cL, cP = _i(I, PCOLL, i, 2), _i(I, PCOLP, i, 2)
        k0, k1 = _span(I, PEL, i, 1)
        for k in range(k0, k1):
            ax, ay, bx, by = _eshape(I, Fl, k, qx[cP])
            col = _i(I, ECOL, k, 0)
            hL, hP = -ny * ax + nx * ay, nx * bx + ny * by
            if cL < n:
                p = _put(R, C, V, p, r0 + cL, c0 + col, lv * hL)
                p = _put(R, C, V, p, r0 + col, c0 + cL, lv * hL)
            if cP < n:
                p = _put(R, C, V, p, r0 + cP, c0 + col, lv * hP)
                p = _put(R, C, V, p, r0 + col, c0 + cP, lv * hP)
    if _rows(I, DSP) > 0:      # distance rows: every entry with an elastic column
        nmax = _dist_columns(I)
        cols = np.empty(nmax, np.int64)
        D, Hd = np.empty((2, nmax)), np.empty((2, nmax, nmax))
        for i in range(_rows(I, DROW)):
            nc, dx, dy, L = _dist_local(I, Fl, qx, i, cols, D, Hd)
            lv = coef * lam[_i(I, DROW, i, 0)]
            for a in range(nc):
                for b in range(nc):
                    if (a >= 6 or b >= 6) and cols[a] < n and cols[b] < n:
                        p = _put(R, C, V, p, r0 + cols[a], c0 + cols[b],
                                 lv * _dist_h(D, Hd, dx, dy, L, a, b))
    return p


@_jit
def _emit_elastic_G(I, Fl, n, qx, vx, R, C, V, p, r0, c0, coef):
    """The elastic entries of coef (Phi_q v)_q at (r0, c0)."""
    for i in range(_rows(I, CROW)):
        for sd in range(2):
            cph = _i(I, CCOL1 if sd == 0 else CCOL2, i, 2)
            sg, ph, w = (-1.0 if sd == 0 else 1.0), qx[cph], vx[cph]
            k0, k1 = _span(I, CEL, i, sd)
            for k in range(k0, k1):
                ax, ay, bx, by = _eshape(I, Fl, k, ph)
                col, vk = _i(I, ECOL, k, 0), vx[_i(I, ECOL, k, 0)]
                for a in range(2):
                    row, b = _i(I, CROW, i, a), (bx if a == 0 else by)
                    if cph < n:
                        p = _put(R, C, V, p, r0 + row, c0 + cph, coef * sg * b * vk)
                    p = _put(R, C, V, p, r0 + row, c0 + col, coef * sg * b * w)
    for i in range(_rows(I, PROW)):
        nx, ny, dx, dy, axL, ayL, axP, ayP = _pol(I, Fl, qx, i)
        row = _i(I, PROW, i, 0)
        cL, cP = _i(I, PCOLL, i, 2), _i(I, PCOLP, i, 2)
        k0, k1 = _span(I, PEL, i, 1)
        for k in range(k0, k1):
            ax, ay, bx, by = _eshape(I, Fl, k, qx[cP])
            col, vk = _i(I, ECOL, k, 0), vx[_i(I, ECOL, k, 0)]
            hL, hP = -ny * ax + nx * ay, nx * bx + ny * by
            if cL < n:
                p = _put(R, C, V, p, r0 + row, c0 + cL, coef * hL * vk)
            if cP < n:
                p = _put(R, C, V, p, r0 + row, c0 + cP, coef * hP * vk)
            p = _put(R, C, V, p, r0 + row, c0 + col, coef * (hL * vx[cL] + hP * vx[cP]))
    if _rows(I, DSP) > 0:      # distance rows: v^T Hess, the terms with an elastic column
        nmax = _dist_columns(I)
        cols = np.empty(nmax, np.int64)
        D, Hd = np.empty((2, nmax)), np.empty((2, nmax, nmax))
        for i in range(_rows(I, DROW)):
            nc, dx, dy, L = _dist_local(I, Fl, qx, i, cols, D, Hd)
            row = _i(I, DROW, i, 0)
            for b in range(nc):
                if cols[b] >= n:
                    continue
                acc = 0.0
                for a in range(nc):
                    if a >= 6 or b >= 6:
                        acc += _dist_h(D, Hd, dx, dy, L, a, b) * vx[cols[a]]
                if nc > 6:
                    p = _put(R, C, V, p, r0 + row, c0 + cols[b], coef * acc)
    return p


# --------------------------------------------------------------------------------------------
# Flexible beams in the floating frame of reference (``assembly/ffr.py``)
#
# Beam b's local coordinates (x, y, phi, q_f), c = 3 + nf, are columns
# bcol[k0:k0 + c] of q; its shape integrals are floats bdat[f0:] in the order
# m, s0 (2), I0, S_bar (2 x nf), a_u (nf), a_I (nf), M_ff, S_tilde, K (nf x nf
# each), and for ne elements with geometric stiffening k_e = EA l / 2 (ne),
# Bu (ne x dm), G (ne x dm x dm) on each element's dm elastic coordinates,
# bdof[d0:d0 + ne dm] (an element's strain reads only its own nodes: without
# this restriction a force evaluation costs ne nf^2, 313 000 products for a
# 32-element beam; padding entries are 0 with zero data). ``_ffr_local`` evaluates the beam's dense
# local blocks (Shabana, Dynamics of Multibody Systems, ch. 5; Sharf 1995 for
# the stiffening), the scatter functions below it place them.
# --------------------------------------------------------------------------------------------

#: What ``_ffr_local`` evaluates (bits): M, Q, (Q_q, Q_v), (M x)_q; numpy integers, so
#: that passing one does not compile a kernel per value (see ``_0``)
FFR_M, FFR_Q, FFR_DQ, FFR_MXQ = np.int64(1), np.int64(2), np.int64(4), np.int64(8)


@_inline
def _bd(I, Fl, k):
    """Float k of the beams' data."""
    return Fl[I[3 * BDAT] + k]


@_jit
def _ffr_local(I, Fl, b, qx, vx, x, what, M, Q, Qq, Qv, Mxq):
    """Local blocks of beam b (c = 3 + nf): M(q) into M (c, c), Q = Q_v - K
    q_f (- dU_G/dq_f) + Q_gravity into Q (c,), Q_q, Q_v into Qq, Qv (c, c),
    (M(q) x)_q into Mxq (c, c) for the extended vector x, as ``what`` asks
    (FFR_* bits); (q, v) from qx, vx."""
    k0, nf, f0, ne = _i(I, BEAM, b, 0), _i(I, BEAM, b, 1), _i(I, BEAM, b, 2), _i(I, BEAM, b, 3)
    d0, dm = _i(I, BEAM, b, 4), _i(I, BEAM, b, 5)
    sb_, au_ = f0 + 4, f0 + 4 + 2 * nf
    ai_, mff_ = au_ + nf, au_ + 2 * nf
    st_, kk_ = mff_ + nf * nf, mff_ + 2 * nf * nf
    kea_ = mff_ + 3 * nf * nf
    bu_, gg_ = kea_ + ne, kea_ + ne + ne * dm
    qf, qd = np.empty(nf), np.empty(nf)
    for j in range(nf):
        col = _i(I, BCOL, k0 + 3 + j, 0)
        qf[j], qd[j] = qx[col], vx[col]
    cph = _i(I, BCOL, k0 + 2, 0)
    cs, sn, w = math.cos(qx[cph]), math.sin(qx[cph]), vx[cph]
    m = _bd(I, Fl, f0)
    # s_bar = s0 + S_bar q_f, a_U = a_u + M_ff q_f, a_T = a_I + S_tilde q_f
    sbx, sby = _bd(I, Fl, f0 + 1), _bd(I, Fl, f0 + 2)
    aU, aT = np.empty(nf), np.empty(nf)
    ASb, BSb = np.empty((2, nf)), np.empty((2, nf))
    for i in range(nf):
        s0i, s1i = _bd(I, Fl, sb_ + i), _bd(I, Fl, sb_ + nf + i)
        sbx += s0i * qf[i]
        sby += s1i * qf[i]
        ASb[0, i], ASb[1, i] = cs * s0i - sn * s1i, sn * s0i + cs * s1i
        BSb[0, i], BSb[1, i] = -ASb[1, i], ASb[0, i]
        u, tt = _bd(I, Fl, au_ + i), _bd(I, Fl, ai_ + i)
        for j in range(nf):
            u += _bd(I, Fl, mff_ + i * nf + j) * qf[j]
            tt += _bd(I, Fl, st_ + i * nf + j) * qf[j]
        aU[i], aT[i] = u, tt
    Asx, Asy = cs * sbx - sn * sby, sn * sbx + cs * sby          # A s_bar
    Bsx, Bsy = -Asy, Asx                                         # B s_bar
    if what & FFR_M:
        M[:, :] = 0.0
        M[0, 0] = M[1, 1] = m
        M[0, 2] = M[2, 0] = Bsx
        M[1, 2] = M[2, 1] = Bsy
        mpp = _bd(I, Fl, f0 + 3)
        for j in range(nf):
            mpp += (2.0 * _bd(I, Fl, au_ + j) + (aU[j] - _bd(I, Fl, au_ + j))) * qf[j]
            M[0, 3 + j] = M[3 + j, 0] = ASb[0, j]
            M[1, 3 + j] = M[3 + j, 1] = ASb[1, j]
            M[2, 3 + j] = M[3 + j, 2] = aT[j]
            for i in range(nf):
                M[3 + i, 3 + j] = _bd(I, Fl, mff_ + i * nf + j)
        M[2, 2] = mpp
    if what & (FFR_Q | FFR_DQ):
        Bqd0, Bqd1, Aqd0, Aqd1, aUqd = 0.0, 0.0, 0.0, 0.0, 0.0
        for j in range(nf):
            Bqd0 += BSb[0, j] * qd[j]
            Bqd1 += BSb[1, j] * qd[j]
            Aqd0 += ASb[0, j] * qd[j]
            Aqd1 += ASb[1, j] * qd[j]
            aUqd += aU[j] * qd[j]
        w2 = w * w
        gx, gy = 0.0, 0.0
        if _rows(I, GRAV) > 0:
            gx, gy = _f(I, Fl, GRAV, 0, 0), _f(I, Fl, GRAV, 1, 0)
        if what & FFR_Q:
            Q[0] = w2 * Asx - 2.0 * w * Bqd0 + m * gx
            Q[1] = w2 * Asy - 2.0 * w * Bqd1 + m * gy
            Q[2] = -2.0 * w * aUqd + Bsx * gx + Bsy * gy
            for i in range(nf):
                acc = w2 * aU[i] + ASb[0, i] * gx + ASb[1, i] * gy
                for j in range(nf):
                    acc -= (2.0 * w * _bd(I, Fl, st_ + i * nf + j) * qd[j]
                            + _bd(I, Fl, kk_ + i * nf + j) * qf[j])
                Q[3 + i] = acc
        if what & FFR_DQ:
            Qq[:, :] = 0.0
            Qv[:, :] = 0.0
            Qq[0, 2], Qq[1, 2] = w2 * Bsx + 2.0 * w * Aqd0, w2 * Bsy + 2.0 * w * Aqd1
            Qv[0, 2], Qv[1, 2] = 2.0 * w * Asx - 2.0 * Bqd0, 2.0 * w * Asy - 2.0 * Bqd1
            Qv[2, 2] = -2.0 * aUqd
            Qq[2, 2] = -(Asx * gx + Asy * gy)
            for j in range(nf):
                for a in range(2):
                    Qq[a, 3 + j] = w2 * ASb[a, j]
                    Qv[a, 3 + j] = -2.0 * w * BSb[a, j]
                mq, sq = 0.0, 0.0
                for k in range(nf):
                    mq += _bd(I, Fl, mff_ + j * nf + k) * qd[k]
                    sq += _bd(I, Fl, st_ + j * nf + k) * qd[k]
                Qq[2, 3 + j] = -2.0 * w * mq + BSb[0, j] * gx + BSb[1, j] * gy
                Qq[3 + j, 2] = BSb[0, j] * gx + BSb[1, j] * gy
                Qv[2, 3 + j] = -2.0 * w * aU[j]
                Qv[3 + j, 2] = 2.0 * w * aU[j] - 2.0 * sq
                for i in range(nf):
                    Qq[3 + j, 3 + i] = (w2 * _bd(I, Fl, mff_ + j * nf + i)
                                        - _bd(I, Fl, kk_ + j * nf + i))
                    Qv[3 + j, 3 + i] = -2.0 * w * _bd(I, Fl, st_ + j * nf + i)
        if ne > 0:          # geometric stiffening: - dU_G/dq_f, - d^2U_G/dq_f^2
            g, dof = np.empty(dm), np.empty(dm, np.int64)
            for e in range(ne):
                ke = _bd(I, Fl, kea_ + e)
                for i in range(dm):
                    dof[i] = _i(I, BDOF, d0 + e * dm + i, 0)
                ae, ce = 0.0, 0.0
                for i in range(dm):
                    ae += _bd(I, Fl, bu_ + e * dm + i) * qf[dof[i]]
                    gi = 0.0
                    for j in range(dm):
                        gi += _bd(I, Fl, gg_ + (e * dm + i) * dm + j) * qf[dof[j]]
                    g[i] = gi
                for i in range(dm):
                    ce += g[i] * qf[dof[i]]
                for i in range(dm):
                    bui = _bd(I, Fl, bu_ + e * dm + i)
                    if what & FFR_Q:
                        Q[3 + dof[i]] -= ke * (ce * bui + (2.0 * ae + ce) * g[i])
                    if what & FFR_DQ:
                        for j in range(dm):
                            buj = _bd(I, Fl, bu_ + e * dm + j)
                            Qq[3 + dof[i], 3 + dof[j]] -= ke * (
                                2.0 * (bui * g[j] + g[i] * buj) + 2.0 * g[i] * g[j]
                                + (2.0 * ae + ce) * _bd(I, Fl, gg_ + (e * dm + i) * dm + j))
    if what & FFR_MXQ:
        xR0, xR1 = x[_i(I, BCOL, k0, 0)], x[_i(I, BCOL, k0 + 1, 0)]
        xp = x[cph]
        Mxq[:, :] = 0.0
        Mxq[0, 2], Mxq[1, 2] = -Asx * xp, -Asy * xp
        Mxq[2, 2] = -(Asx * xR0 + Asy * xR1)
        for j in range(nf):
            xj = x[_i(I, BCOL, k0 + 3 + j, 0)]
            Mxq[0, 2] += BSb[0, j] * xj
            Mxq[1, 2] += BSb[1, j] * xj
            Mxq[0, 3 + j], Mxq[1, 3 + j] = BSb[0, j] * xp, BSb[1, j] * xp
            bx = BSb[0, j] * xR0 + BSb[1, j] * xR1
            Mxq[3 + j, 2] = bx
            sx = 0.0
            for k in range(nf):
                sx += _bd(I, Fl, st_ + j * nf + k) * x[_i(I, BCOL, k0 + 3 + k, 0)]
                Mxq[3 + j, 3 + k] = _bd(I, Fl, st_ + j * nf + k) * xp
            Mxq[2, 3 + j] = bx + 2.0 * aU[j] * xp - sx


@_jit
def _ffr_scratch(I):
    """Scratch blocks (M, Q, Qq, Qv, Mxq) for the largest beam of the model."""
    c = 3
    for b in range(_rows(I, BEAM)):
        c = max(c, 3 + _i(I, BEAM, b, 1))
    return (np.empty((c, c)), np.empty(c), np.empty((c, c)), np.empty((c, c)),
            np.empty((c, c)))


@_jit
def _ffr_forces_add(I, Fl, qx, vx, out):
    """out += Q of every beam (``FlexibleBeamGroup.forces``)."""
    M, Q, Qq, Qv, Mxq = _ffr_scratch(I)
    for b in range(_rows(I, BEAM)):
        _ffr_local(I, Fl, b, qx, vx, qx, FFR_Q, M, Q, Qq, Qv, Mxq)
        k0 = _i(I, BEAM, b, 0)
        for a in range(3 + _i(I, BEAM, b, 1)):
            out[_i(I, BCOL, k0 + a, 0)] += Q[a]


@_jit
def _beam_mass_add(I, Fl, qM, x, coef, out):
    """out += coef M_b(qM) x on every beam's columns (x, out indexed by
    column; the rigid diagonal is the caller's, in its own expression)."""
    M, Q, Qq, Qv, Mxq = _ffr_scratch(I)
    for b in range(_rows(I, BEAM)):
        _ffr_local(I, Fl, b, qM, qM, qM, FFR_M, M, Q, Qq, Qv, Mxq)
        k0, c = _i(I, BEAM, b, 0), 3 + _i(I, BEAM, b, 1)
        for a in range(c):
            acc = 0.0
            for d in range(c):
                acc += M[a, d] * x[_i(I, BCOL, k0 + d, 0)]
            out[_i(I, BCOL, k0 + a, 0)] += coef * acc


@_jit
def _ffr_energy(I, Fl, b, qx, gravity):
    """Potential energy of beam b at qx [J]: the strain energy q_f^T K q_f / 2
    (+ U_G = sum_e k_e (a_e c_e + c_e^2 / 4) with geometric stiffening) and,
    with ``gravity`` and a gravity field g, - m g . R - g . A s_bar
    (``ffr`` module notes; zero at y = 0 and an undeformed beam)."""
    k0, nf, f0, ne = _i(I, BEAM, b, 0), _i(I, BEAM, b, 1), _i(I, BEAM, b, 2), _i(I, BEAM, b, 3)
    d0, dm = _i(I, BEAM, b, 4), _i(I, BEAM, b, 5)
    sb_ = f0 + 4
    kk_ = f0 + 4 + 4 * nf + 2 * nf * nf
    kea_ = kk_ + nf * nf
    bu_, gg_ = kea_ + ne, kea_ + ne + ne * dm
    qf = np.empty(nf)
    for j in range(nf):
        qf[j] = qx[_i(I, BCOL, k0 + 3 + j, 0)]
    e = 0.0
    for i in range(nf):
        acc = 0.0
        for j in range(nf):
            acc += _bd(I, Fl, kk_ + i * nf + j) * qf[j]
        e += 0.5 * qf[i] * acc
    for el in range(ne):
        ae, ce = 0.0, 0.0
        for i in range(dm):
            fi = qf[_i(I, BDOF, d0 + el * dm + i, 0)]
            ae += _bd(I, Fl, bu_ + el * dm + i) * fi
            for j in range(dm):
                fj = qf[_i(I, BDOF, d0 + el * dm + j, 0)]
                ce += fi * _bd(I, Fl, gg_ + (el * dm + i) * dm + j) * fj
        e += _bd(I, Fl, kea_ + el) * (ae * ce + 0.25 * ce * ce)
    if gravity and _rows(I, GRAV) > 0:
        gx, gy = _f(I, Fl, GRAV, 0, 0), _f(I, Fl, GRAV, 1, 0)
        sbx, sby = _bd(I, Fl, f0 + 1), _bd(I, Fl, f0 + 2)
        for i in range(nf):
            sbx += _bd(I, Fl, sb_ + i) * qf[i]
            sby += _bd(I, Fl, sb_ + nf + i) * qf[i]
        ph = qx[_i(I, BCOL, k0 + 2, 0)]
        cs, sn = math.cos(ph), math.sin(ph)
        m = _bd(I, Fl, f0)
        e -= (m * (gx * qx[_i(I, BCOL, k0, 0)] + gy * qx[_i(I, BCOL, k0 + 1, 0)])
              + gx * (cs * sbx - sn * sby) + gy * (sn * sbx + cs * sby))
    return e


@_jit
def beam_blocks(I, Fl, b0, qx, vx, x, what, M, Q, Qq, Qv, Mxq):
    """The local blocks of beams b0 .. b0 + k - 1 (k = len(M), all of one size
    c = 3 + nf), as ``_ffr_local`` evaluates them: M(q) into M (k, c, c),
    Q into Q (k, c), Q_q and Q_v into Qq, Qv (k, c, c), (M(q) x)_q into Mxq
    (k, c, c), as the FFR_* bits of ``what`` ask; qx, vx and x extended
    vectors (nx,). The one evaluation of the beams' physics that Python
    calls (``assembly.ffr.FlexibleBeamGroup``)."""
    for k in range(M.shape[0]):
        _ffr_local(I, Fl, b0 + k, qx, vx, x, what, M[k], Q[k], Qq[k], Qv[k], Mxq[k])


@_jit
def beam_energies(I, Fl, b0, b1, qx, gravity, out):
    """out[r] = the potential energy of beams b0 .. b1 - 1 at row qx[r]
    (``_ffr_energy``; qx (N, nx), out (N,) [J])."""
    for r in range(qx.shape[0]):
        e = 0.0
        for b in range(b0, b1):
            e += _ffr_energy(I, Fl, b, qx[r], gravity)
        out[r] = e


@_jit
def _emit_beams(I, Fl, qx, vx, x, what, R, C, V, p, r0, c0, c1, c2):
    """Every beam's local block(s) at (r0, c0): c1 M (FFR_M), c1 (M x)_q
    (FFR_MXQ), or -(c1 Q_q + c2 Q_v) (FFR_DQ); all c x c entries, so that
    the pattern is fixed."""
    M, Q, Qq, Qv, Mxq = _ffr_scratch(I)
    for b in range(_rows(I, BEAM)):
        _ffr_local(I, Fl, b, qx, vx, x, what, M, Q, Qq, Qv, Mxq)
        k0, c = _i(I, BEAM, b, 0), 3 + _i(I, BEAM, b, 1)
        for a in range(c):
            ra = r0 + _i(I, BCOL, k0 + a, 0)
            for d in range(c):
                cd = c0 + _i(I, BCOL, k0 + d, 0)
                if what == FFR_M:
                    val = c1 * M[a, d]
                elif what == FFR_MXQ:
                    val = c1 * Mxq[a, d]
                else:
                    val = -(c1 * Qq[a, d] + c2 * Qv[a, d])
                p = _put(R, C, V, p, ra, cd, val)
    return p


# --------------------------------------------------------------------------------------------
# Matrix blocks as (row, column, value) triplets in a fixed order
# --------------------------------------------------------------------------------------------

@_jit
def _put(R, C, V, p, r, c, v):
    R[p] = r
    C[p] = c
    V[p] = v
    return p + 1


@_jit
def _emit_mass(I, Fl, n, qM, R, C, V, p, r0, c0, coef):
    """coef M(qM) at (r0, c0): the rigid diagonal, and every beam's block."""
    for j in range(n):
        if _f(I, Fl, MRIG, j, 0) != 0.0:
            p = _put(R, C, V, p, r0 + j, c0 + j, coef * _f(I, Fl, MRIG, j, 0))
    if _rows(I, BEAM) > 0:
        p = _emit_beams(I, Fl, qM, qM, qM, FFR_M, R, C, V, p, r0, c0, coef, 0.0)
    return p


@_jit
def _emit_phiq(I, Fl, n, qx, R, C, V, p, r0, c0, coef, transpose):
    """coef Phi_q at (r0, c0), or coef Phi_q^T when transpose."""
    for i in range(_rows(I, CROW)):
        ax1, ay1 = _Au(I, Fl, qx, CCOL1, CS1, CEL, 0, i)
        ax2, ay2 = _Au(I, Fl, qx, CCOL2, CS2, CEL, 1, i)
        for a in range(2):
            row = _i(I, CROW, i, a)
            # d(p2 - p1)_a / d(x1, y1, phi1, x2, y2, phi2): -e_a, -(B s1)_a, e_a, (B s2)_a
            for which in range(4):
                if which == 0:
                    col, g = _i(I, CCOL1, i, a), -1.0
                elif which == 1:
                    col, g = _i(I, CCOL1, i, 2), (ay1 if a == 0 else -ax1)
                elif which == 2:
                    col, g = _i(I, CCOL2, i, a), 1.0
                else:
                    col, g = _i(I, CCOL2, i, 2), (-ay2 if a == 0 else ax2)
                if col < n:
                    if transpose:
                        p = _put(R, C, V, p, r0 + col, c0 + row, coef * g)
                    else:
                        p = _put(R, C, V, p, r0 + row, c0 + col, coef * g)
    g = np.empty(6)
    for i in range(_rows(I, PROW)):
        nx, ny, dx, dy, axL, ayL, axP, ayP = _pol(I, Fl, qx, i)
        g[0], g[1], g[2], g[3], g[4], g[5] = _pol_grad(nx, ny, dx, dy, axL, ayL, axP, ayP)
        row = _i(I, PROW, i, 0)
        for j in range(6):
            col = _i(I, PCOLL, i, j) if j < 3 else _i(I, PCOLP, i, j - 3)
            if col < n:
                if transpose:
                    p = _put(R, C, V, p, r0 + col, c0 + row, coef * g[j])
                else:
                    p = _put(R, C, V, p, r0 + row, c0 + col, coef * g[j])
    for i in range(_rows(I, LROW)):
        for j in range(2):
            col = _i(I, LCOL, i, j)
            if col < n:
                if transpose:
                    p = _put(R, C, V, p, r0 + col, c0 + _i(I, LROW, i, 0), coef * _f(I, Fl, LCOEF, i, j))
                else:
                    p = _put(R, C, V, p, r0 + _i(I, LROW, i, 0), c0 + col, coef * _f(I, Fl, LCOEF, i, j))
    for i in range(_rows(I, DROW)):
        _dist(I, Fl, qx, i, g)
        row = _i(I, DROW, i, 0)
        for j in range(6):
            col = _dist_col(I, i, j)
            if col < n:
                if transpose:
                    p = _put(R, C, V, p, r0 + col, c0 + row, coef * g[j])
                else:
                    p = _put(R, C, V, p, r0 + row, c0 + col, coef * g[j])
    if _rows(I, ECOL) > 0:
        p = _emit_elastic_phiq(I, Fl, n, qx, R, C, V, p, r0, c0, coef, transpose)
    return p


@_jit
def _emit_hess(I, Fl, n, qx, lam, R, C, V, p, r0, c0, coef):
    """coef (Phi_q^T lambda)_q at (r0, c0)."""
    for i in range(_rows(I, CROW)):
        l0, l1 = lam[_i(I, CROW, i, 0)], lam[_i(I, CROW, i, 1)]
        ax1, ay1 = _Au(I, Fl, qx, CCOL1, CS1, CEL, 0, i)
        ax2, ay2 = _Au(I, Fl, qx, CCOL2, CS2, CEL, 1, i)
        c1, c2 = _i(I, CCOL1, i, 2), _i(I, CCOL2, i, 2)
        if c1 < n:
            p = _put(R, C, V, p, r0 + c1, c0 + c1, coef * (l0 * ax1 + l1 * ay1))
        if c2 < n:
            p = _put(R, C, V, p, r0 + c2, c0 + c2, -coef * (l0 * ax2 + l1 * ay2))
    bnd = np.empty(6)
    for i in range(_rows(I, PROW)):
        nx, ny, dx, dy, axL, ayL, axP, ayP = _pol(I, Fl, qx, i)
        hLL, hPP = _pol_hess(nx, ny, dx, dy, axL, ayL, axP, ayP, bnd)
        lv = coef * lam[_i(I, PROW, i, 0)]
        cL, cP = _i(I, PCOLL, i, 2), _i(I, PCOLP, i, 2)
        for j in range(6):
            col = _i(I, PCOLL, i, j) if j < 3 else _i(I, PCOLP, i, j - 3)
            if j == 2 or col >= n or cL >= n:
                continue
            p = _put(R, C, V, p, r0 + cL, c0 + col, lv * bnd[j])
            p = _put(R, C, V, p, r0 + col, c0 + cL, lv * bnd[j])
        if cL < n:
            p = _put(R, C, V, p, r0 + cL, c0 + cL, lv * hLL)
        if cP < n:
            p = _put(R, C, V, p, r0 + cP, c0 + cP, lv * hPP)
    if _rows(I, DROW) > 0:
        g, H = np.empty(6), np.empty((6, 6))
        for i in range(_rows(I, DROW)):
            dx, dy, ax1, ay1, ax2, ay2, L = _dist(I, Fl, qx, i, g)
            _dist_hess(dx, dy, ax1, ay1, ax2, ay2, L, H)
            lv = coef * lam[_i(I, DROW, i, 0)]
            for a in range(6):
                ca = _dist_col(I, i, a)
                for b in range(6):
                    cb = _dist_col(I, i, b)
                    if ca < n and cb < n:
                        p = _put(R, C, V, p, r0 + ca, c0 + cb, lv * H[a, b])
    if _rows(I, ECOL) > 0:
        p = _emit_elastic_hess(I, Fl, n, qx, lam, R, C, V, p, r0, c0, coef)
    return p


@_jit
def _emit_G(I, Fl, n, qx, vx, R, C, V, p, r0, c0, coef):
    """coef (Phi_q v)_q at (r0, c0) (Phi_qt = 0 for these constraints)."""
    for i in range(_rows(I, CROW)):
        ax1, ay1 = _Au(I, Fl, qx, CCOL1, CS1, CEL, 0, i)
        ax2, ay2 = _Au(I, Fl, qx, CCOL2, CS2, CEL, 1, i)
        c1, c2 = _i(I, CCOL1, i, 2), _i(I, CCOL2, i, 2)
        w1, w2 = vx[c1], vx[c2]
        for a in range(2):
            s1 = ax1 if a == 0 else ay1
            s2 = ax2 if a == 0 else ay2
            if c1 < n:
                p = _put(R, C, V, p, r0 + _i(I, CROW, i, a), c0 + c1, coef * s1 * w1)
            if c2 < n:
                p = _put(R, C, V, p, r0 + _i(I, CROW, i, a), c0 + c2, -coef * s2 * w2)
    bnd = np.empty(6)
    v6 = np.empty(6)
    for i in range(_rows(I, PROW)):
        nx, ny, dx, dy, axL, ayL, axP, ayP = _pol(I, Fl, qx, i)
        hLL, hPP = _pol_hess(nx, ny, dx, dy, axL, ayL, axP, ayP, bnd)
        for j in range(3):
            v6[j] = vx[_i(I, PCOLL, i, j)]
            v6[3 + j] = vx[_i(I, PCOLP, i, j)]
        row = _i(I, PROW, i, 0)
        for j in range(6):       # (H v)_j, H symmetric
            col = _i(I, PCOLL, i, j) if j < 3 else _i(I, PCOLP, i, j - 3)
            if j == 2:
                hv = hLL * v6[2]
                for k in range(6):
                    if k != 2:
                        hv += bnd[k] * v6[k]
            else:
                hv = bnd[j] * v6[2]
                if j == 5:
                    hv += hPP * v6[5]
            if col < n:
                p = _put(R, C, V, p, r0 + row, c0 + col, coef * hv)
    if _rows(I, DROW) > 0:
        g, H = np.empty(6), np.empty((6, 6))
        for i in range(_rows(I, DROW)):
            dx, dy, ax1, ay1, ax2, ay2, L = _dist(I, Fl, qx, i, g)
            _dist_hess(dx, dy, ax1, ay1, ax2, ay2, L, H)
            for j in range(6):
                v6[j] = vx[_dist_col(I, i, j)]
            row = _i(I, DROW, i, 0)
            for a in range(6):
                col = _dist_col(I, i, a)
                if col < n:
                    hv = 0.0
                    for b in range(6):
                        hv += H[a, b] * v6[b]
                    p = _put(R, C, V, p, r0 + row, c0 + col, coef * hv)
    if _rows(I, ECOL) > 0:
        p = _emit_elastic_G(I, Fl, n, qx, vx, R, C, V, p, r0, c0, coef)
    return p


#: What ``elements`` evaluates at each row for the joints and drivers: Phi,
#: Phi_t, Phi_tt into out (N, m); Phi_q y into out (N, m); Phi_q^T y into out
#: (N, nx); the triplets of Phi_q, (Phi_q^T y)_q and (Phi_q y)_q into R, C and
#: V (N, nnz).
(C_PHI, C_PHI_T, C_PHI_TT, C_PHIQ_Y, C_PHIQT_Y,
 C_PHIQ, C_PHIQT_Y_Q, C_PHIQ_Y_Q) = range(8)


@_jit
def _constraints_row(I, Fl, n, what, r, t, qx, y, out, R, C, V):
    """The joints' and drivers' evaluation ``what`` (C_*) at row r of t,
    qx, y, into out[r] or R, C, V[r] (see ``elements``); returns the
    triplets' count (0 for a vector)."""
    p = 0
    if what == C_PHI:
        phi(I, Fl, t[r], qx[r], out[r])
    elif what == C_PHI_T or what == C_PHI_TT:
        row = out[r]
        for j in range(row.shape[0]):
            row[j] = 0.0
        _phi_time_add(I, Fl, t[r], row, what)
    elif what == C_PHIQ_Y:
        phiq_times(I, Fl, qx[r], y[r], out[r])
    elif what == C_PHIQT_Y:
        row = out[r]
        for j in range(row.shape[0]):
            row[j] = 0.0
        phiqT_add(I, Fl, qx[r], y[r], 1.0, row)
    elif what == C_PHIQ:
        p = _emit_phiq(I, Fl, n, qx[r], R, C, V[r], _0, _0, _0, 1.0, _NO)
    elif what == C_PHIQT_Y_Q:
        p = _emit_hess(I, Fl, n, qx[r], y[r], R, C, V[r], _0, _0, _0, 1.0)
    else:
        p = _emit_G(I, Fl, n, qx[r], y[r], R, C, V[r], _0, _0, _0, 1.0)
    return p


@_jit
def _emit_friction(I, Fl, n, qx, vx, lam, R, C, V, p, r0, c0, cq, cv):
    """Friction's -(cq Q_q + cv Q_v) at (r0, c0): Q_q = tau d^2 s + w dtau/dz
    (d^2 s v)^T, Q_v = w dtau/dz w^T (``FrictionGroup`` notes)."""
    w, H = np.empty(6), np.empty((6, 6))
    Hv = np.empty(6)
    for i in range(_rows(I, FRI)):
        z, g = _friction_kin(I, Fl, i, qx, vx, w, H)
        tau, dz, dN, Rn = _friction_law(I, Fl, i, z, lam, Fl[:0])
        k = 2 if g < 0 else 6
        for b in range(k):
            Hv[b] = 0.0
            if g >= 0:
                for j in range(6):
                    Hv[b] += H[b, j] * vx[_i(I, GEO, g, j)]
        for a in range(k):
            ra = _friction_col(I, i, g, a)
            if ra >= n:
                continue
            for b in range(k):
                cb = _friction_col(I, i, g, b)
                if cb >= n:
                    continue
                val = cv * dz * w[a] * w[b]
                if g >= 0:
                    val += cq * (tau * H[a, b] + dz * w[a] * Hv[b])
                p = _put(R, C, V, p, r0 + ra, c0 + cb, -val)
    return p


@_jit
def _emit_friction_lam(I, Fl, n, qx, vx, lam, R, C, V, p, r0, c0, coef):
    """-coef Q_lambda at (r0, c0), Q_lambda = w (dtau/dlambda_J)^T over the
    joint's reaction rows (``FrictionGroup`` notes)."""
    w, H = np.empty(6), np.empty((6, 6))
    for i in range(_rows(I, FRI)):
        z, g = _friction_kin(I, Fl, i, qx, vx, w, H)
        tau, dz, dN, Rn = _friction_law(I, Fl, i, z, lam, Fl[:0])
        row, nr = _i(I, FRI, i, 3), _i(I, FRI, i, 4)
        for a in range(2 if g < 0 else 6):
            ra = _friction_col(I, i, g, a)
            if ra >= n:
                continue
            for k in range(nr):
                d = dN * lam[row + k] / Rn if Rn > 0.0 else 0.0
                p = _put(R, C, V, p, r0 + ra, c0 + row + k, -coef * w[a] * d)
    return p


@_jit
def _emit_spring_elastic(I, Fl, n, qx, vx, i, R, C, V, p, r0, c0, cq, cv):
    """-(cq Q_q + cv Q_v) at (r0, c0) of spring-damper i with a point on a
    flexible beam (``SpringDamperGroup`` notes) over its local columns:
    x, y, phi of both bodies, then the elastic terms of each point (u = s +
    S q_e). With D = dd/dq_local and Hd = d^2 d/dq_local^2 (d^2 p/dphi^2 = -A u,
    d^2 p/dphi dq_k = B S_k; Shabana, sec. 5.3): Q_q = -D^T d(f e)/dq - (f e)
    . Hd, Q_v = -c (D^T e)(D^T e)^T."""
    a0, a1 = _span(I, SEL, i, 0)
    b0, b1 = _span(I, SEL, i, 1)
    nc = 6 + (a1 - a0) + (b1 - b0)
    cols = np.empty(nc, np.int64)
    D, Hd = np.zeros((2, nc)), np.zeros((2, nc, nc))
    v, de, Hv = np.empty(nc), np.empty((2, nc)), np.empty((2, nc))
    for j in range(3):
        cols[j] = _i(I, SCOL1, i, j)
        cols[3 + j] = _i(I, SCOL2, i, j)
    ph1, ph2 = qx[cols[2]], qx[cols[5]]
    ax1, ay1 = _Au(I, Fl, qx, SCOL1, SS1, SEL, 0, i)
    ax2, ay2 = _Au(I, Fl, qx, SCOL2, SS2, SEL, 1, i)
    D[0, 0], D[1, 1], D[0, 3], D[1, 4] = -1.0, -1.0, 1.0, 1.0
    D[0, 2], D[1, 2], D[0, 5], D[1, 5] = ay1, -ax1, -ay2, ax2
    Hd[0, 2, 2], Hd[1, 2, 2], Hd[0, 5, 5], Hd[1, 5, 5] = ax1, ay1, -ax2, -ay2
    j = 6
    for side in range(2):
        k0, k1 = (a0, a1) if side == 0 else (b0, b1)
        sg, cph = (-1.0, 2) if side == 0 else (1.0, 5)
        for k in range(k0, k1):
            cols[j] = _i(I, ECOL, k, 0)
            Ax, Ay, Bx, By = _eshape(I, Fl, k, ph1 if side == 0 else ph2)
            D[0, j], D[1, j] = sg * Ax, sg * Ay
            Hd[0, cph, j], Hd[1, cph, j] = sg * Bx, sg * By
            Hd[0, j, cph], Hd[1, j, cph] = sg * Bx, sg * By
            j += 1
    for j in range(nc):
        v[j] = vx[cols[j]]
    k, c = _f(I, Fl, SPAR, i, 0), _f(I, Fl, SPAR, i, 1)
    dx = (qx[cols[3]] - qx[cols[0]]) + (ax2 - ax1)
    dy = (qx[cols[4]] - qx[cols[1]]) + (ay2 - ay1)
    l0 = _free_length(I, Fl, i, dx, dy)
    l = math.sqrt(dx * dx + dy * dy)
    ex, ey = _direction(dx, dy, l)
    ddx, ddy = 0.0, 0.0
    for j in range(nc):
        ddx += D[0, j] * v[j]
        ddy += D[1, j] * v[j]
    P00, P01, P11 = _direction_derivative(ex, ey, l)
    for j in range(nc):
        de[0, j] = P00 * D[0, j] + P01 * D[1, j]
        de[1, j] = P01 * D[0, j] + P11 * D[1, j]
        for a in range(2):
            acc = 0.0
            for m2 in range(nc):
                acc += Hd[a, j, m2] * v[m2]
            Hv[a, j] = acc
    ldot = ex * ddx + ey * ddy
    f = k * (l - l0) + c * ldot
    Fx, Fy = f * ex, f * ey
    for a in range(nc):
        ra = cols[a]
        if ra >= n:
            continue
        Ge_a = D[0, a] * ex + D[1, a] * ey
        for b in range(nc):
            cb = cols[b]
            if cb >= n:
                continue
            dl = ex * D[0, b] + ey * D[1, b]
            dldot = ddx * de[0, b] + ddy * de[1, b] + ex * Hv[0, b] + ey * Hv[1, b]
            df = k * dl + c * dldot
            dFx, dFy = ex * df + f * de[0, b], ey * df + f * de[1, b]
            qq = -(D[0, a] * dFx + D[1, a] * dFy) - (Fx * Hd[0, a, b] + Fy * Hd[1, a, b])
            qv = -c * Ge_a * (D[0, b] * ex + D[1, b] * ey)
            p = _put(R, C, V, p, r0 + ra, c0 + cb, -(cq * qq + cv * qv))
    return p


@_jit
def _emit_force(I, Fl, t, n, qx, vx, lam, R, C, V, p, r0, c0, cq, cv):
    """-(cq Q_q + cv Q_v) at (r0, c0) of every applied load (the groups' notes)."""
    G = np.empty((2, 6))
    v6 = np.empty(6)
    de = np.empty((2, 6))
    dF = np.empty((2, 6))
    dl = np.empty(6)
    dldot = np.empty(6)
    cols = np.empty(6, np.int64)
    for i in range(_rows(I, SCOL1)):
        a0, a1 = _span(I, SEL, i, 0)
        b0, b1 = _span(I, SEL, i, 1)
        if a1 > a0 or b1 > b0:            # a point on a flexible beam
            p = _emit_spring_elastic(I, Fl, n, qx, vx, i, R, C, V, p, r0, c0, cq, cv)
            continue
        k, c = _f(I, Fl, SPAR, i, 0), _f(I, Fl, SPAR, i, 1)
        dx, dy, ddx, ddy, l, ax1, ay1, ax2, ay2 = _spring(I, Fl, qx, vx, i, G, v6)
        l0 = _free_length(I, Fl, i, dx, dy)
        ex, ey = _direction(dx, dy, l)
        P00, P01, P11 = _direction_derivative(ex, ey, l)
        ldot = ex * ddx + ey * ddy
        f = k * (l - l0) + c * ldot
        for j in range(6):
            de[0, j] = P00 * G[0, j] + P01 * G[1, j]
            de[1, j] = P01 * G[0, j] + P11 * G[1, j]
            dl[j] = ex * G[0, j] + ey * G[1, j]
            dldot[j] = ddx * de[0, j] + ddy * de[1, j]
        # e . Hv: Hd[a, 2, 2] = (A s1)_a, Hd[a, 5, 5] = -(A s2)_a
        dldot[2] += (ex * ax1 + ey * ay1) * v6[2]
        dldot[5] -= (ex * ax2 + ey * ay2) * v6[5]
        for j in range(6):
            dfj = k * dl[j] + c * dldot[j]
            dF[0, j] = ex * dfj + f * de[0, j]
            dF[1, j] = ey * dfj + f * de[1, j]
        Fx, Fy = f * ex, f * ey
        for j in range(3):
            cols[j] = _i(I, SCOL1, i, j)
            cols[3 + j] = _i(I, SCOL2, i, j)
        for a in range(6):
            if cols[a] >= n:
                continue
            for b in range(6):
                if cols[b] >= n:
                    continue
                qq = -(G[0, a] * dF[0, b] + G[1, a] * dF[1, b])
                if a == b and a == 2:
                    qq -= Fx * ax1 + Fy * ay1
                elif a == b and a == 5:
                    qq += Fx * ax2 + Fy * ay2
                val = cq * qq
                if c != 0.0:
                    val += cv * (-c * (G[0, a] * ex + G[1, a] * ey) * (G[0, b] * ex + G[1, b] * ey))
                p = _put(R, C, V, p, r0 + cols[a], c0 + cols[b], -val)
    for i in range(_rows(I, RCOL)):
        for a in range(2):
            for b in range(2):
                if _i(I, RCOL, i, a) < n and _i(I, RCOL, i, b) < n:
                    sgn = -1.0 if a == b else 1.0      # Q_q = k [[-1, 1], [1, -1]]
                    val = sgn * (cq * _f(I, Fl, RPAR, i, 0) + cv * _f(I, Fl, RPAR, i, 1))
                    p = _put(R, C, V, p, r0 + _i(I, RCOL, i, a), c0 + _i(I, RCOL, i, b), -val)
    for i in range(_rows(I, FCOL)):
        cph = _i(I, FCOL, i, 2)
        if cph < n:
            ax, ay = _Au(I, Fl, qx, FCOL, FS, FEL, 0, i)
            fx, fy = _point_force(I, Fl, t, i)
            val = cq * -(ax * fx + ay * fy)
            p = _put(R, C, V, p, r0 + cph, c0 + cph, -val)
            k0, k1 = _span(I, FEL, i, 0)
            for k in range(k0, k1):        # d2p/dphi dq_k = B S_k
                Ax, Ay, Bx, By = _eshape(I, Fl, k, qx[cph])
                val = cq * (Bx * fx + By * fy)
                ck = _i(I, ECOL, k, 0)
                p = _put(R, C, V, p, r0 + cph, c0 + ck, -val)
                p = _put(R, C, V, p, r0 + ck, c0 + cph, -val)
    if _rows(I, STQ) > 0:      # loads of the state: Q = tau w, w = +-e_phi or grad s
        grad, H = np.empty(6), np.empty((6, 6))
        wg, wH = np.empty(6), np.empty((6, 6))
        _state_values(I, Fl, qx, vx, grad, H)
        if cq != 0.0:          # tau dw/dq of a force along a sliding line
            for i in range(_rows(I, STQ)):
                g = _i(I, STQ, i, 3)
                if g < 0:
                    continue
                tau = _eval(I, Fl, _i(I, STQ, i, 0), t)
                _line(I, Fl, qx, g, wg, wH)
                for a in range(6):
                    ra = _i(I, GEO, g, a)
                    for b in range(6):
                        cb = _i(I, GEO, g, b)
                        if ra < n and cb < n and wH[a, b] != 0.0:
                            p = _put(R, C, V, p, r0 + ra, c0 + cb, -cq * tau * wH[a, b])
        for e in range(_rows(I, SDV)):   # w (dtau/dx_k) (dx_k/dq, dx_k/dv)
            si, kv = _i(I, SDV, e, 0), _i(I, SDV, e, 1)
            gk = _eval(I, Fl, _i(I, SDV, e, 2), t)
            gs = _i(I, STQ, si, 3)
            if gs >= 0:
                _line(I, Fl, qx, gs, wg, wH)
            nrow = 2 if gs < 0 else 6
            gv = _i(I, VAR, kv, 3)
            if gv >= 0:
                _line(I, Fl, qx, gv, grad, H)
            for a in range(nrow):
                if gs < 0:
                    row, w = _i(I, STQ, si, 1 + a), (1.0 if a == 0 else -1.0)
                else:
                    row, w = _i(I, GEO, gs, a), wg[a]
                if row >= n or w == 0.0:
                    continue
                if gv < 0:                 # linear in q (level 0) or v (level 1)
                    c = cq if _i(I, VAR, kv, 0) == 0 else cv
                    if c == 0.0:
                        continue
                    for j in range(2):
                        col = _i(I, VAR, kv, 1 + j)
                        if col < n and _f(I, Fl, VARC, kv, j) != 0.0:
                            p = _put(R, C, V, p, r0 + row, c0 + col,
                                     -c * w * gk * _f(I, Fl, VARC, kv, j))
                    continue
                for j in range(6):         # a sliding distance (grad s) or speed
                    col = _i(I, GEO, gv, j)
                    if col >= n:
                        continue
                    if _i(I, VAR, kv, 0) == 0:
                        dq, dv = grad[j], 0.0
                    else:                  # d(grad s . v)/dq = H v, d/dv = grad s
                        dq = 0.0
                        for m2 in range(6):
                            dq += H[j, m2] * vx[_i(I, GEO, gv, m2)]
                        dv = grad[j]
                    val = cq * dq + cv * dv
                    if val != 0.0:
                        p = _put(R, C, V, p, r0 + row, c0 + col, -w * gk * val)
    if _rows(I, FRI) > 0:
        p = _emit_friction(I, Fl, n, qx, vx, lam, R, C, V, p, r0, c0, cq, cv)
    if _rows(I, KGI) > 0:
        p = _emit_contacts(I, Fl, n, qx, vx, R, C, V, p, r0, c0, cq, cv)
    if _rows(I, BEAM) > 0:
        p = _emit_beams(I, Fl, qx, vx, qx, FFR_DQ, R, C, V, p, r0, c0, cq, cv)
    return p


#: What ``elements`` evaluates at each row for the applied loads: Q into out
#: (N, nx); the triplets of Q_q, Q_v, Q_lambda into R, C and V (N, nnz); the
#: potential energy of the loads into out[:, 0]; the power put in and
#: dissipated into out[:, :2]; the contacts' gaps and their gradients, the
#: spring-dampers' d = p2 - p1 and the friction joints' speeds and their
#: rates into out (see ``elements``). Numbered after the C_*.
(L_Q, L_QQ, L_QV, L_QLAM, L_ENERGY, L_POWER, L_GAPS, L_SPRINGS, L_SLIP,
 L_SENSORS) = range(8, 18)
#: Values per gap, per friction joint and per (rotational) spring-damper of L_SENSORS.
SENSOR_GAP, SENSOR_FRICTION, SENSOR_SPRING = 6, 3, 5


@_jit
def _spring_energy(I, Fl, qx, i):
    """(length l [m], k (l - l0)^2 / 2 [J]) of spring-damper i at qx."""
    dx, dy, ax1, ay1, ax2, ay2 = _spring_points(I, Fl, qx, i)
    l = math.sqrt(dx * dx + dy * dy)
    s = l - _f(I, Fl, SPAR, i, 2)
    return l, 0.5 * _f(I, Fl, SPAR, i, 0) * s * s


@_jit
def _rotational_energy(I, Fl, qx, i):
    """(relative angle theta_2 - theta_1 [rad], k (theta - theta0)^2 / 2 [J])
    of rotational spring-damper i at qx."""
    a = qx[_i(I, RCOL, i, 1)] - qx[_i(I, RCOL, i, 0)]
    th = a - _f(I, Fl, RPAR, i, 2)
    return a, 0.5 * _f(I, Fl, RPAR, i, 0) * th * th


@_jit
def _contact_energy(I, Fl, i, g):
    """K delta^(n+1) / (n+1) [J] of gap i at gap g (delta = -g; 0 when open)."""
    if g >= 0.0:
        return 0.0
    ex = _f(I, Fl, KPAR, i, 10)
    return _f(I, Fl, KPAR, i, 9) * (-g) ** (ex + 1.0) / (ex + 1.0)


@_jit
def _potential(I, Fl, qx):
    """The loads' potential energy at qx [J]: springs k (l - l0)^2 / 2,
    rotational springs k theta^2 / 2, contacts K delta^(n+1) / (n+1), beams'
    strain and gravity (``_ffr_energy``); the rigid bodies' gravity is
    -Q0 . q, the caller's."""
    e = 0.0
    for i in range(_rows(I, SCOL1)):
        e += _spring_energy(I, Fl, qx, i)[1]
    for i in range(_rows(I, RCOL)):
        e += _rotational_energy(I, Fl, qx, i)[1]
    if _rows(I, KGI) > 0:
        grad, H = np.empty(6), np.empty((6, 6))
        for i in range(_rows(I, KGI)):
            e += _contact_energy(I, Fl, i, _gap(I, Fl, qx, i, grad, H))
    for b in range(_rows(I, BEAM)):
        e += _ffr_energy(I, Fl, b, qx, _YES)
    return e


@_jit
def _power(I, Fl, t, qx, vx, lam, speeds, work):
    """(put in, dissipated) [W] at (t, qx, vx, lambda): Q . v of the loads
    that put work in (``_inputs_add``, work (nx,) its scratch); c ldot^2 of
    the spring-dampers, c theta'^2 of the rotational ones, -tau z of
    friction, and of the contacts, at the impact speeds ``speeds`` (k,),
    (f - K delta^n) ddelta/dt (the damping's power and, where the force is
    cut at zero, the elastic power it leaves out) and -F_t v_t."""
    for j in range(work.shape[0]):
        work[j] = 0.0
    _inputs_add(I, Fl, t, qx, vx, work)
    p_in = 0.0
    for j in range(work.shape[0]):
        p_in += work[j] * vx[j]
    p = 0.0
    for i in range(_rows(I, SCOL1)):
        c = _f(I, Fl, SPAR, i, 1)
        if c != 0.0:
            dx, dy, ax1, ay1, ax2, ay2 = _spring_points(I, Fl, qx, i)
            l = math.sqrt(dx * dx + dy * dy)
            ex, ey = _direction(dx, dy, l)
            ld = _spring_rate(I, Fl, qx, vx, i, ex, ey, ax1, ay1, ax2, ay2)
            p += c * ld * ld
    for i in range(_rows(I, RCOL)):
        w = vx[_i(I, RCOL, i, 1)] - vx[_i(I, RCOL, i, 0)]
        p += _f(I, Fl, RPAR, i, 1) * w * w
    grad, H = np.empty(6), np.empty((6, 6))
    for i in range(_rows(I, FRI)):
        z, g = _friction_kin(I, Fl, i, qx, vx, grad, H)
        tau, dz, dN, Rn = _friction_law(I, Fl, i, z, lam, Fl[:0])
        p -= tau * z
    if _rows(I, KGI) > 0:
        w, dw = np.empty(6), np.empty((6, 6))
        for i in range(_rows(I, KGI)):
            g, delta, ddelta, f, elastic, speed, armed = _contact_law(
                I, Fl, qx, vx, i, speeds[i], grad, H)
            if delta > 0.0:
                p += (f - elastic) * ddelta
                if _f(I, Fl, KPAR, i, 12) > 0.0 and f > 0.0:
                    Ft, vt, T = _contact_friction(I, Fl, qx, vx, i, f, w, dw)
                    p -= Ft * vt
    return p_in, p


@_jit
def elements(I, Fl, what, t, qx, vx, y, slip, speeds, out, R, C, V):
    """The elements' evaluations Python asks for (``AssembledSystem.Phi``,
    ``AssembledSystem.Q`` and the functions after them; the contacts' and
    springs' events), at the rows t (N,) [s], qx, vx (N, nx) and y (N, m:
    lambda; N, nx: v for C_PHIQ_Y and C_PHIQ_Y_Q, accelerations for L_SLIP),
    as ``what`` says. The joints and drivers (C_*, ``_constraints_row``, vx
    unread): Phi, Phi_t, Phi_tt, Phi_q y into out (N, m), Phi_q^T y into out
    (N, nx), the triplets of Phi_q, (Phi_q^T y)_q and (Phi_q y)_q (their
    rows and columns into R, C, the values of row r into V[r]; the count
    returned, the same at every state: the pattern is fixed by the model).
    The applied loads (L_*):

    * L_Q: Q into out (N, nx), friction with ``slip`` (``_friction_law``);
    * L_QQ, L_QV, L_QLAM: the triplets of Q_q, Q_v (N, n) and Q_lambda
      (n, m) into R, C and V; the count returned (entries that are zero at
      a state may be left out: a caller sums them into a pattern of its own);
    * L_ENERGY: the loads' potential energy into out[:, 0] (``_potential``);
    * L_POWER: the power put in and dissipated into out[:, 0], out[:, 1],
      the contacts at the impact speeds speeds (N, k) (``_power``);
    * L_GAPS: the contacts' gaps g into out[:, :k] and their gradients over
      their six columns into out[:, k + 6 i: k + 6 i + 6];
    * L_SPRINGS: d = p2 - p1 of spring-damper i into out[:, 2 i: 2 i + 2];
    * L_SLIP: the friction joints' speeds z into out[:, :k] and their rates
      dz/dt = w . a + v^T (d^2 s) v, a = y, into out[:, k:];
    * L_SENSORS: what the force elements do, y = lambda, for the sensors
      of ``output`` lines, by the laws of the run's forces, ``_potential``
      and ``_power``: per gap i at the impact speeds ``speeds`` (N, k),
      SENSOR_GAP values (g, dg/dt, normal force f, friction force F_t,
      power dissipated (f - K delta^n) ddelta/dt - F_t v_t, elastic energy)
      (``_contact_law``, ``_contact_friction``, ``_contact_energy``); then
      per friction joint SENSOR_FRICTION values (joint speed z, friction
      load tau, power dissipated -tau z) (``_friction_law``); then per
      spring-damper SENSOR_SPRING values (length l, dl/dt, tension k (l -
      l0) + c dl/dt, energy, power dissipated c (dl/dt)^2); then per
      rotational spring-damper the same of its angle (theta, dtheta/dt,
      torque, energy, power).

    The contacts' impact speeds of L_Q, L_QQ and L_QV are the model's state
    (KIMP). One entry point, so that a process loads one library for all of
    them (numba's cache loads each entry point and each signature on its
    own, 20-70 ms each on two cores)."""
    n = _rows(I, MASS)
    p = 0
    nx = qx.shape[1]
    work = np.empty(nx)
    grad, H = np.empty(6), np.empty((6, 6))
    for r in range(qx.shape[0]):
        if what < L_Q:
            p = _constraints_row(I, Fl, n, what, r, t, qx, y, out, R, C, V)
        elif what == L_Q:
            _forces(I, Fl, t[r], qx[r], vx[r], y[r], slip, out[r])
        elif what == L_QQ:
            p = _emit_force(I, Fl, t[r], n, qx[r], vx[r], y[r], R, C, V[r], _0, _0, _0, -1.0, 0.0)
        elif what == L_QV:
            p = _emit_force(I, Fl, t[r], n, qx[r], vx[r], y[r], R, C, V[r], _0, _0, _0, 0.0, -1.0)
        elif what == L_QLAM:
            p = _emit_friction_lam(I, Fl, n, qx[r], vx[r], y[r], R, C, V[r], _0, _0, _0, -1.0)
        elif what == L_ENERGY:
            out[r, 0] = _potential(I, Fl, qx[r])
        elif what == L_POWER:
            out[r, 0], out[r, 1] = _power(I, Fl, t[r], qx[r], vx[r], y[r], speeds[r], work)
        elif what == L_GAPS:
            k = _rows(I, KGI)
            for i in range(k):
                out[r, i] = _gap(I, Fl, qx[r], i, grad, H)
                for a in range(6):
                    out[r, k + 6 * i + a] = grad[a]
        elif what == L_SPRINGS:
            for i in range(_rows(I, SCOL1)):
                dx, dy, ax1, ay1, ax2, ay2 = _spring_points(I, Fl, qx[r], i)
                out[r, 2 * i], out[r, 2 * i + 1] = dx, dy
        elif what == L_SENSORS:
            k = _rows(I, KGI)
            w, dw = np.empty(6), np.empty((6, 6))
            o = 0                    # the next value's column
            for i in range(k):
                g, delta, ddelta, f, elastic, speed, armed = _contact_law(
                    I, Fl, qx[r], vx[r], i, speeds[r, i], grad, H)
                if g >= 0.0:         # open: the gap's rate all the same
                    ddelta = 0.0
                    for a in range(6):
                        ddelta -= grad[a] * vx[r, _i(I, KCOL, i, a)]
                ft, dissipated = 0.0, 0.0
                if delta > 0.0:
                    dissipated = (f - elastic) * ddelta
                    if _f(I, Fl, KPAR, i, 12) > 0.0 and f > 0.0:
                        ft, vt, T = _contact_friction(I, Fl, qx[r], vx[r], i, f, w, dw)
                        dissipated -= ft * vt
                out[r, o], out[r, o + 1], out[r, o + 2] = g, -ddelta, f
                out[r, o + 3], out[r, o + 4] = ft, dissipated
                out[r, o + 5] = _contact_energy(I, Fl, i, g)
                o += SENSOR_GAP
            for i in range(_rows(I, FRI)):
                z, g = _friction_kin(I, Fl, i, qx[r], vx[r], grad, H)
                tau, dz, dN, Rn = _friction_law(I, Fl, i, z, y[r], Fl[:0])
                out[r, o], out[r, o + 1], out[r, o + 2] = z, tau, -tau * z
                o += SENSOR_FRICTION
            for i in range(_rows(I, SCOL1)):
                l, e = _spring_energy(I, Fl, qx[r], i)
                dx, dy, ax1, ay1, ax2, ay2 = _spring_points(I, Fl, qx[r], i)
                ex, ey = _direction(dx, dy, l)
                ld = _spring_rate(I, Fl, qx[r], vx[r], i, ex, ey, ax1, ay1, ax2, ay2)
                c = _f(I, Fl, SPAR, i, 1)
                out[r, o], out[r, o + 1] = l, ld
                out[r, o + 2] = _f(I, Fl, SPAR, i, 0) * (l - _f(I, Fl, SPAR, i, 2)) + c * ld
                out[r, o + 3], out[r, o + 4] = e, c * ld * ld
                o += SENSOR_SPRING
            for i in range(_rows(I, RCOL)):
                a, e = _rotational_energy(I, Fl, qx[r], i)
                wr = vx[r, _i(I, RCOL, i, 1)] - vx[r, _i(I, RCOL, i, 0)]
                c = _f(I, Fl, RPAR, i, 1)
                out[r, o], out[r, o + 1] = a, wr
                out[r, o + 2] = _f(I, Fl, RPAR, i, 0) * (a - _f(I, Fl, RPAR, i, 2)) + c * wr
                out[r, o + 3], out[r, o + 4] = e, c * wr * wr
                o += SENSOR_SPRING
        else:
            k = _rows(I, FRI)
            for i in range(k):
                z, g = _friction_kin(I, Fl, i, qx[r], vx[r], grad, H)
                rate = 0.0
                for a in range(2 if g < 0 else 6):
                    col = _friction_col(I, i, g, a)
                    rate += grad[a] * y[r, col]
                    if g >= 0:
                        for b in range(6):
                            rate += vx[r, col] * H[a, b] * vx[r, _i(I, GEO, g, b)]
                out[r, i], out[r, k + i] = z, rate
    return p


# --------------------------------------------------------------------------------------------
# The methods as data: residual and Newton matrix of a recipe (``recipe.py``)
# --------------------------------------------------------------------------------------------

@_jit
def _emit_identity(n, R, C, V, p, r0, c0, coef):
    """coef I (n x n) at (r0, c0)."""
    for j in range(n):
        p = _put(R, C, V, p, r0 + j, c0 + j, coef)
    return p


@_jit
def _layout(rec, n, m):
    """(size, column of lambda, column of the extra multipliers, column of a)
    of the unknowns: w = (x, [y,] lambda, [mu]) in the linear form, (dq,
    dv, a, psi_I, psi_II) in the additive form (lambda := psi_II, the extra
    multipliers psi_I)."""
    if rec[FORM] == ADDITIVE:
        return 3 * n + 2 * m, 3 * n + m, 3 * n, 2 * n
    if rec[HAS_Y] != 0.0:
        return 2 * (n + m), 2 * n, 2 * n + m, 0
    return n + m, n, n + m, 0


@_jit
def _state(rec, n, w, q_pred, v_pred, qx, vx):
    """q_{n+1}, v_{n+1} into the extended vectors from the unknowns w."""
    cqx, cvx = rec[CQX], rec[CVX]
    for j in range(n):
        qx[j] = q_pred[j] + cqx * w[j]
        vx[j] = v_pred[j] + cvx * w[j]
    if rec[HAS_Y] != 0.0:
        cqy, cvy = rec[CQY], rec[CVY]
        for j in range(n):
            qx[j] += cqy * w[n + j]
            vx[j] += cvy * w[n + j]


@_jit
def predict(rec, first, q, v, a, b, q_prev, v_prev, q_pred, v_pred):
    """The recipe's predictors into q_pred, v_pred (n,) from the state at t_n
    (q, v, a, the auxiliary acceleration b) and, unless ``first``, the one h
    before (q_prev, v_prev)."""
    n = q.shape[0]
    pq0, pq1, pv0, pv1, pa = rec[PQ0], rec[PQ1], rec[PV0], rec[PV1], rec[PA]
    vv0, vv1, va = rec[VV0], rec[VV1], rec[VA]
    for j in range(n):
        q_pred[j] = pq0 * q[j] + pv0 * v[j] + pa * a[j]
        v_pred[j] = vv0 * v[j] + va * a[j]
    pb, vb = rec[PB], rec[VB]
    if pb != 0.0 or vb != 0.0:
        for j in range(n):
            q_pred[j] += pb * b[j]
            v_pred[j] += vb * b[j]
    if not first and (pq1 != 0.0 or pv1 != 0.0 or vv1 != 0.0):
        for j in range(n):
            q_pred[j] += pq1 * q_prev[j] + pv1 * v_prev[j]
            v_pred[j] += vv1 * v_prev[j]


@_jit
def _advance(rec, b, a, x):
    """The auxiliary acceleration b (n,) in place from t_n to t_{n+1}:
    b_{n+1} = bb b_n + ba a_n + bx x, x = a_{n+1} (recipes without it: nothing)."""
    bb, ba, bx = rec[BB], rec[BA], rec[BX]
    if bb != 0.0 or ba != 0.0 or bx != 0.0:
        for j in range(b.shape[0]):
            b[j] = bb * b[j] + ba * a[j] + bx * x[j]


#: The state map, the layout of the unknowns and the auxiliary's update, for the Python
#: Newton loop (``engine.SparseAdapter``): the same compiled functions as the time loop's.
state, layout, advance = _state, _layout, _advance


@_jit
def _residual(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, r, qx, vx, work):
    """Upsilon(w) of the recipe ``rec``, size n + m (index 3), 2 (n + m)
    (stabilized index 2) or 3 n + 2 m (additive form).

    ``qx``, ``vx``, ``work`` are scratch vectors of size n + 3 (ground entries
    zero); ``qx_old`` the extended q_n + mh v_n (the additive form's q_n of
    Phi_q(q_n), or where a held Mhat is evaluated). The
    same equations as each method's numpy ``residual`` (the additive form's
    rows 1, 2 and 5 multiplied by M).
    """
    if rec[FORM] == ADDITIVE:
        _residual_additive(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, r, qx, vx, work)
        return
    n, m = _rows(I, MASS), _rows(I, ROW_ELEMENT)
    size, l0, u0, a0 = _layout(rec, n, m)
    _state(rec, n, w, q_pred, v_pred, qx, vx)
    cM, cF = rec[CM], rec[CF]
    qM = qx_old if rec[MH] != 0.0 else qx      # M held at q_n + mh v_n, or M(q)
    forces(I, Fl, t, qx, vx, w[l0:l0 + m], work)
    for j in range(n):
        work[j] = -work[j]
    phiqT_add(I, Fl, qx, w[l0:l0 + m], 1.0, work)
    for j in range(n):
        r[j] = cM * _f(I, Fl, MRIG, j, 0) * w[j] + work[j] - cF * F_old[j]
    if _rows(I, BEAM) > 0:
        _beam_mass_add(I, Fl, qM, w, cM, r)
    phi(I, Fl, t, qx, r[l0:l0 + m])
    sP = rec[SP]
    for i in range(m):
        r[l0 + i] *= sP
    if rec[HAS_Y] != 0.0:
        dM, dI, dV = rec[DM], rec[DI], rec[DV]
        work[:] = 0.0
        phiqT_add(I, Fl, qx, w[u0:], 1.0, work)
        for j in range(n):
            r[n + j] = (dM * _f(I, Fl, MRIG, j, 0) + dI) * w[n + j] + dV * vx[j] + work[j]
        if dM != 0.0 and _rows(I, BEAM) > 0:
            _beam_mass_add(I, Fl, qM, w[n:2 * n], dM, r[n:2 * n])
        phiq_times(I, Fl, qx, vx, r[u0:])
        _phi_time_add(I, Fl, t, r[u0:], 1)
        sV = rec[SV]
        for i in range(m):
            r[u0 + i] *= sV


@_jit
def _jacobian_triplets(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, R, C, V, qx, vx):
    """Newton matrix entries (R, C, V) of the recipe ``rec``, in an order and
    pattern fixed by the model and the method; returns their count.
    Duplicates are summed by the caller.

    The chain rule on ``_residual``: with K(u) = (Phi_q^T u)_q and
    G = (Phi_q v)_q,
    d R1/dx = cM M + cqx (K(lambda) - Q_q) - cvx Q_v, d R1/dy likewise with
    cqy, cvy; d R2/dx = cqx K(mu) + dV cvx I, d R2/dy = dM M + (dI + dV cvy) I
    + cqy K(mu); d R3/d(x, y) = sP (cqx, cqy) Phi_q; d R4/d(x, y) = sV (cvx
    Phi_q + cqx G, cvy Phi_q + cqy G); Phi_q^T in the multiplier columns.
    With flexible beams and M(q) not held (mh = 0) d R1/dx gains cM cqx (M
    x)_q, d R1/dy cM cqy (M x)_q, and d R2/d(x, y) dM (cqx, cqy) (M y)_q.
    Zero coefficients are structural (the same for every h of a method) and
    emit nothing.
    """
    if rec[FORM] == ADDITIVE:
        return _jacobian_additive(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, R, C, V, qx,
                                  vx)
    n, m = _rows(I, MASS), _rows(I, ROW_ELEMENT)
    size, l0, u0, a0 = _layout(rec, n, m)
    _state(rec, n, w, q_pred, v_pred, qx, vx)
    cqx, cvx, sP = rec[CQX], rec[CVX], rec[SP]
    lam = w[l0:l0 + m]
    held = rec[MH] != 0.0                  # M held at q_n + mh v_n: no (M x)_q
    beams = _rows(I, BEAM) > 0 and not held
    p = 0
    p = _emit_mass(I, Fl, n, qx_old if held else qx, R, C, V, p, _0, _0, rec[CM])
    if beams and cqx != 0.0:               # (M(q) x)_q
        p = _emit_beams(I, Fl, qx, vx, w, FFR_MXQ, R, C, V, p, _0, _0, rec[CM] * cqx, 0.0)
    if cqx != 0.0:
        p = _emit_hess(I, Fl, n, qx, lam, R, C, V, p, _0, _0, cqx)
    p = _emit_force(I, Fl, t, n, qx, vx, lam, R, C, V, p, _0, _0, cqx, cvx)
    p = _emit_phiq(I, Fl, n, qx, R, C, V, p, _0, l0, 1.0, _YES)
    if _rows(I, FRI) > 0:                  # Phi_q^T - Q_lambda: friction reads lambda
        p = _emit_friction_lam(I, Fl, n, qx, vx, lam, R, C, V, p, _0, l0, 1.0)
    if cqx != 0.0:
        p = _emit_phiq(I, Fl, n, qx, R, C, V, p, l0, _0, sP * cqx, _NO)
    if rec[REG] != 0.0:                    # the augmented formulation: -epsilon I
        p = _emit_identity(m, R, C, V, p, l0, l0, -rec[REG])
    if rec[HAS_Y] != 0.0:
        cqy, cvy, sV, dM, dI, dV = rec[CQY], rec[CVY], rec[SV], rec[DM], rec[DI], rec[DV]
        mu = w[u0:]
        y = w[n:2 * n]
        if beams and cqy != 0.0:
            p = _emit_beams(I, Fl, qx, vx, w, FFR_MXQ, R, C, V, p, _0, n, rec[CM] * cqy, 0.0)
        if beams and dM != 0.0:
            if cqx != 0.0:
                p = _emit_beams(I, Fl, qx, vx, y, FFR_MXQ, R, C, V, p, n, _0, dM * cqx, 0.0)
            if cqy != 0.0:
                p = _emit_beams(I, Fl, qx, vx, y, FFR_MXQ, R, C, V, p, n, n, dM * cqy, 0.0)
        if cqy != 0.0:
            p = _emit_hess(I, Fl, n, qx, lam, R, C, V, p, _0, n, cqy)
        if cqy != 0.0 or cvy != 0.0:
            p = _emit_force(I, Fl, t, n, qx, vx, lam, R, C, V, p, _0, n, cqy, cvy)
        if cqx != 0.0:
            p = _emit_hess(I, Fl, n, qx, mu, R, C, V, p, n, _0, cqx)
        if dV * cvx != 0.0:
            p = _emit_identity(n, R, C, V, p, n, _0, dV * cvx)
        if dM != 0.0:
            p = _emit_mass(I, Fl, n, qx_old if held else qx, R, C, V, p, n, n, dM)
        if dI + dV * cvy != 0.0:
            p = _emit_identity(n, R, C, V, p, n, n, dI + dV * cvy)
        if cqy != 0.0:
            p = _emit_hess(I, Fl, n, qx, mu, R, C, V, p, n, n, cqy)
        p = _emit_phiq(I, Fl, n, qx, R, C, V, p, n, u0, 1.0, _YES)
        if cqy != 0.0:
            p = _emit_phiq(I, Fl, n, qx, R, C, V, p, l0, n, sP * cqy, _NO)
        if cvx != 0.0:
            p = _emit_phiq(I, Fl, n, qx, R, C, V, p, u0, _0, sV * cvx, _NO)
        if cqx != 0.0:
            p = _emit_G(I, Fl, n, qx, vx, R, C, V, p, u0, _0, sV * cqx)
        if cvy != 0.0:
            p = _emit_phiq(I, Fl, n, qx, R, C, V, p, u0, n, sV * cvy, _NO)
        if cqy != 0.0:
            p = _emit_G(I, Fl, n, qx, vx, R, C, V, p, u0, n, sV * cqy)
    return p


@_jit
def _mass_solve(I, Fl, qM, x, out):
    """out[:n] = M(qM)^-1 x[:n]: a division on the rigid diagonal, a dense
    solve per flexible beam block (``AssembledSystem.mass_solve``)."""
    for j in range(_rows(I, MRIG)):
        if _f(I, Fl, MRIG, j, 0) != 0.0:
            out[j] = x[j] / _f(I, Fl, MRIG, j, 0)
    if _rows(I, BEAM) > 0:
        M, Q, Qq, Qv, Mxq = _ffr_scratch(I)
        for b in range(_rows(I, BEAM)):
            _ffr_local(I, Fl, b, qM, qM, qM, FFR_M, M, Q, Qq, Qv, Mxq)
            k0, c = _i(I, BEAM, b, 0), 3 + _i(I, BEAM, b, 1)
            rhs = np.empty(c)
            for a in range(c):
                rhs[a] = x[_i(I, BCOL, k0 + a, 0)]
            y = np.linalg.solve(M[:c, :c], rhs)
            for a in range(c):
                out[_i(I, BCOL, k0 + a, 0)] = y[a]


@_jit
def _minus_correction(I, Fl, qx, psi, y):
    """y[:n] = M(q)^-1 Phi_q(q)^T psi at qx: minus the additive form's
    correction r(q, psi) (``HHTADD._r``); y of size n + 3, overwritten."""
    y[:] = 0.0
    phiqT_add(I, Fl, qx, psi, 1.0, y)
    _mass_solve(I, Fl, qx, y, y)


@_jit
def _rigid_mass_times(I, Fl, x):
    """x[:n] = M x[:n] on the rigid bodies' rows (the constant diagonal), 0
    on the beams' rows."""
    for j in range(_rows(I, MRIG)):
        if _f(I, Fl, MRIG, j, 0) != 0.0:
            x[j] *= _f(I, Fl, MRIG, j, 0)
    for b in range(_rows(I, BEAM)):
        k0 = _i(I, BEAM, b, 0)
        for a in range(3 + _i(I, BEAM, b, 1)):
            x[_i(I, BCOL, k0 + a, 0)] = 0.0


@_jit
def _additive_parts(rec, I, Fl, t, F_old, qx_old, w, qx, vx, z1, z2, z5, y):
    """The vectors M(q) multiplies in HHT-ADD's scaled rows 1, 2 and 5 (the
    state (qx, vx) already set): z1 = dq - ka1 a + (1 - kb)/2 y, z2 = dv -
    ka2 a + y/2, z5 = a - cF F_n, y = M(q_n)^-1 Phi_q(q_n)^T psi_I (y:
    scratch of size n + 3)."""
    n, m = _rows(I, MASS), _rows(I, ROW_ELEMENT)
    size, l0, e0, a0 = _layout(rec, n, m)
    ka1, ka2, kb, cF = rec[KA1], rec[KA2], rec[KB], rec[CF]
    _minus_correction(I, Fl, qx_old, w[e0:e0 + m], y)
    for j in range(n):
        a = w[a0 + j]
        z1[j] = w[j] - ka1 * a + 0.5 * (1.0 - kb) * y[j]
        z2[j] = w[n + j] - ka2 * a + 0.5 * y[j]
        z5[j] = a - cF * F_old[j]


@_jit
def _residual_additive(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, r, qx, vx, work):
    """Upsilon(w) of HHT-ADD (``hht_add.py``) with its rows 1, 2 and 5
    multiplied by M(q) (for rigid bodies a constant diagonal: Newton's
    iterates are those of the unscaled system, and the rows are the M dq -
    ka1 M a + (1 - kb)/2 Phi_q(q_n)^T psi_I ... of ``recipe.py``)::

        M(q) z1 + kb/2 Phi_q^T psi_II,   M(q) z2 + 1/2 Phi_q^T psi_II
        sP Phi,   sV (Phi_q v + Phi_t)
        M(q) z5 - cQ Q(q, v)

    z1, z2, z5 of ``_additive_parts``, F_n = -M(q_n)^-1 Q_n (``_old_force``),
    q = q_pred + cqx dq, v = v_pred + cvy dv. With flexible beams M(q_n)
    and M(q) differ and y = M(q_n)^-1 Phi_q(q_n)^T psi_I is a block solve;
    a beam's rows are then left unscaled (M_b(q)^-1 times the above, the
    rows of ``hht_add.py`` themselves, formed as z_i + M_b^-1 times the
    other terms, one block solve per beam): scaled by M(q), whose q moves with
    the iterate, Newton converged poorly from the predictor (measured on
    tests/dsl/valid/flexible_joints.mbd: 5 to 12 iterations a step and
    steps 3e-5 m off the converged solution, against 5 to 8 unscaled).
    """
    n, m = _rows(I, MASS), _rows(I, ROW_ELEMENT)
    size, l0, e0, a0 = _layout(rec, n, m)
    _state(rec, n, w, q_pred, v_pred, qx, vx)
    r5 = 2 * n + 2 * m
    _additive_parts(rec, I, Fl, t, F_old, qx_old, w, qx, vx, r[:n], r[n:2 * n], r[r5:], work)
    beams = _rows(I, BEAM) > 0
    if beams:                     # a beam's rows: z_i + M_b^-1 (the other terms), below
        z = np.empty((3, n))
        z[0], z[1], z[2] = r[:n], r[n:2 * n], r[r5:]
    for off in (0, n, r5):        # the z_i in place of M z_i (rigid; 0 on the beams' rows)
        _rigid_mass_times(I, Fl, r[off:off + n])
    kb = rec[KB]
    work[:] = 0.0
    phiqT_add(I, Fl, qx, w[l0:l0 + m], 1.0, work)                # Phi_q(q)^T psi_II
    for j in range(n):
        r[j] += 0.5 * kb * work[j]
        r[n + j] += 0.5 * work[j]
    phi(I, Fl, t, qx, r[2 * n:2 * n + m])
    phiq_times(I, Fl, qx, vx, r[2 * n + m:2 * n + 2 * m])
    _phi_time_add(I, Fl, t, r[2 * n + m:2 * n + 2 * m], 1)
    sP, sV = rec[SP], rec[SV]
    for i in range(m):
        r[2 * n + i] *= sP
        r[2 * n + m + i] *= sV
    forces(I, Fl, t, qx, vx, w[l0:l0 + m], work)              # friction reads psi_II
    cQ = rec[CQ]
    for j in range(n):
        r[r5 + j] -= cQ * work[j]
    if beams:                      # a beam's rows unscaled: z_i + M_b(q)^-1 (the other terms)
        _beam_rows_solve(I, Fl, qx, r, n, r5)
        for b in range(_rows(I, BEAM)):
            k0 = _i(I, BEAM, b, 0)
            for a in range(3 + _i(I, BEAM, b, 1)):
                col = _i(I, BCOL, k0 + a, 0)
                r[col] += z[0, col]
                r[n + col] += z[1, col]
                r[r5 + col] += z[2, col]


@_jit
def _beam_inverses(I, Fl, qx):
    """M_b(q)^-1 of every beam, shape (beams, c_max, c_max)."""
    nb, cmax = _rows(I, BEAM), 3
    for b in range(nb):
        cmax = max(cmax, 3 + _i(I, BEAM, b, 1))
    out = np.zeros((nb, cmax, cmax))
    M, Q, Qq, Qv, Mxq = _ffr_scratch(I)
    for b in range(nb):
        c = 3 + _i(I, BEAM, b, 1)
        _ffr_local(I, Fl, b, qx, qx, qx, FFR_M, M, Q, Qq, Qv, Mxq)
        out[b, :c, :c] = np.linalg.inv(M[:c, :c].copy())
    return out


@_jit
def _beam_rows_solve(I, Fl, qx, r, n, r5):
    """r's rows 1, 2 and 5 of the additive form (offsets 0, n, r5) on each
    beam's columns replaced by M_b(q)^-1 times them: one solve with three
    right-hand sides per beam."""
    M, Q, Qq, Qv, Mxq = _ffr_scratch(I)
    for b in range(_rows(I, BEAM)):
        k0, c = _i(I, BEAM, b, 0), 3 + _i(I, BEAM, b, 1)
        _ffr_local(I, Fl, b, qx, qx, qx, FFR_M, M, Q, Qq, Qv, Mxq)
        rhs = np.empty((c, 3))
        for a in range(c):
            col = _i(I, BCOL, k0 + a, 0)
            rhs[a, 0], rhs[a, 1], rhs[a, 2] = r[col], r[n + col], r[r5 + col]
        y = np.linalg.solve(M[:c, :c].copy(), rhs)
        for a in range(c):
            col = _i(I, BCOL, k0 + a, 0)
            r[col], r[n + col], r[r5 + col] = y[a, 0], y[a, 1], y[a, 2]


@_jit
def _beam_map(I, n):
    """(beam, local index) of each of the n columns: the beam whose
    coordinates it is (-1 for a rigid body's), and its place among them."""
    beam_of, local = np.full(n, -1, np.int64), np.zeros(n, np.int64)
    for b in range(_rows(I, BEAM)):
        k0 = _i(I, BEAM, b, 0)
        for a in range(3 + _i(I, BEAM, b, 1)):
            beam_of[_i(I, BCOL, k0 + a, 0)] = b
            local[_i(I, BCOL, k0 + a, 0)] = a
    return beam_of, local


@_jit
def _emit_mass_ratio_phiqT(I, Fl, n, qx, qx_old, R, C, V, p, c0, coef0, coef1):
    """coef0 M(q) M(q_n)^-1 Phi_q(q_n)^T at rows 0 and coef1 times it at rows
    n (a block left out where its coefficient is 0), columns from c0:
    Phi_q(q_n)^T on the rigid columns; on a beam's columns its block T =
    M_b(q) M_b(q_n)^-1 times the beam's rows of Phi_q(q_n)^T, formed once
    for both blocks."""
    if _rows(I, BEAM) == 0:
        if coef0 != 0.0:
            p = _emit_phiq(I, Fl, n, qx_old, R, C, V, p, _0, c0, coef0, _YES)
        if coef1 != 0.0:
            p = _emit_phiq(I, Fl, n, qx_old, R, C, V, p, n, c0, coef1, _YES)
        return p
    nb, cmax = _rows(I, BEAM), 3
    for b in range(nb):
        cmax = max(cmax, 3 + _i(I, BEAM, b, 1))
    beam_of, local = _beam_map(I, n)
    T = np.zeros((nb, cmax, cmax))
    M, Q, Qq, Qv, Mxq = _ffr_scratch(I)
    for b in range(nb):
        c = 3 + _i(I, BEAM, b, 1)
        _ffr_local(I, Fl, b, qx_old, qx_old, qx_old, FFR_M, M, Q, Qq, Qv, Mxq)
        Mn = M[:c, :c].copy()
        _ffr_local(I, Fl, b, qx, qx, qx, FFR_M, M, Q, Qq, Qv, Mxq)
        X = np.linalg.solve(Mn, M[:c, :c].copy())        # M_n^-1 M(q); T = X^T (M symmetric)
        for a in range(c):
            for d in range(c):
                T[b, a, d] = X[d, a]
    k = 8 * _rows(I, CROW) + 6 * _rows(I, PROW) + 2 * _rows(I, LROW) + 6 * _rows(I, DROW) \
        + 2 * _rows(I, ECOL)
    Rs, Cs, Vs = np.empty(k, np.int64), np.empty(k, np.int64), np.empty(k)
    ks = _emit_phiq(I, Fl, n, qx_old, Rs, Cs, Vs, _0, _0, _0, 1.0, _YES)
    for r0, coef in ((0, coef0), (n, coef1)):
        if coef == 0.0:
            continue
        for i in range(ks):
            j, row, g = Rs[i], Cs[i], coef * Vs[i]
            b = beam_of[j]
            if b < 0:
                p = _put(R, C, V, p, r0 + j, c0 + row, g)
                continue
            k0, c = _i(I, BEAM, b, 0), 3 + _i(I, BEAM, b, 1)
            for a in range(c):
                p = _put(R, C, V, p, r0 + _i(I, BCOL, k0 + a, 0), c0 + row, T[b, a, local[j]] * g)
    return p


@_jit
def _jacobian_additive(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, R, C, V, qx, vx):
    """Newton matrix of ``_residual_additive``, K(u) = (Phi_q^T u)_q, G =
    (Phi_q v)_q, B = M(q) M(q_n)^-1 Phi_q(q_n)^T, and with flexible beams
    Z_i = (M z_i)_q (zero for rigid bodies)::

        [[M + cqx (Z1 + kb/2 K(psi_II)), 0,  -ka1 M, (1-kb)/2 B, kb/2 Phi_q^T],
         [cqx (Z2 + 1/2 K(psi_II)),      M,  -ka2 M, 1/2 B,      1/2 Phi_q^T ],
         [sP cqx Phi_q,                  0,  0,      0,          0           ],
         [sV cqx G,             sV cvy Phi_q, 0,     0,          0           ],
         [cqx (Z5 - cQ Q_q),    -cQ cvy Q_v,  M,     0,          0           ]]
    """
    n, m = _rows(I, MASS), _rows(I, ROW_ELEMENT)
    size, l0, e0, a0 = _layout(rec, n, m)
    _state(rec, n, w, q_pred, v_pred, qx, vx)
    ka1, ka2, kb, cqx, cvy = rec[KA1], rec[KA2], rec[KB], rec[CQX], rec[CVY]
    psi2 = w[l0:l0 + m]
    r5 = 2 * n + 2 * m
    p = 0
    p = _emit_mass(I, Fl, n, qx, R, C, V, p, _0, _0, 1.0)
    if kb != 0.0:
        p = _emit_hess(I, Fl, n, qx, psi2, R, C, V, p, _0, _0, 0.5 * kb * cqx)
        p = _emit_phiq(I, Fl, n, qx, R, C, V, p, _0, l0, 0.5 * kb, _YES)
    p = _emit_mass(I, Fl, n, qx, R, C, V, p, _0, a0, -ka1)
    p = _emit_mass_ratio_phiqT(I, Fl, n, qx, qx_old, R, C, V, p, e0, 0.5 * (1.0 - kb), 0.5)
    p = _emit_hess(I, Fl, n, qx, psi2, R, C, V, p, n, _0, 0.5 * cqx)
    p = _emit_mass(I, Fl, n, qx, R, C, V, p, n, n, 1.0)
    p = _emit_mass(I, Fl, n, qx, R, C, V, p, n, a0, -ka2)
    p = _emit_phiq(I, Fl, n, qx, R, C, V, p, n, l0, 0.5, _YES)
    p = _emit_phiq(I, Fl, n, qx, R, C, V, p, 2 * n, _0, rec[SP] * cqx, _NO)
    p = _emit_G(I, Fl, n, qx, vx, R, C, V, p, 2 * n + m, _0, rec[SV] * cqx)
    p = _emit_phiq(I, Fl, n, qx, R, C, V, p, 2 * n + m, n, rec[SV] * cvy, _NO)
    p = _emit_mass(I, Fl, n, qx, R, C, V, p, r5, a0, 1.0)
    p = _emit_force(I, Fl, t, n, qx, vx, psi2, R, C, V, p, r5, _0, rec[CQ] * cqx, 0.0)
    p = _emit_force(I, Fl, t, n, qx, vx, psi2, R, C, V, p, r5, n, 0.0, rec[CQ] * cvy)
    if _rows(I, FRI) > 0:
        p = _emit_friction_lam(I, Fl, n, qx, vx, psi2, R, C, V, p, r5, l0, rec[CQ])
    if _rows(I, BEAM) > 0:
        p = _unscale_beam_rows(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, R, C, V, p,
                               qx, vx)
    return p


@_jit
def _unscale_beam_rows(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, R, C, V, p, qx, vx):
    """The Newton matrix of the beams' unscaled rows from the scaled one's
    triplets R, C, V[:p] (M(q) held in them): the scaled rows are r = M(q) z
    + (terms without M), so with r = M_b(q) u on a beam's rows, du/dw =
    M_b^-1 (dr/dw|_M + cqx (M_b (z - u))_q). Adds the last term (z of
    ``_additive_parts``, u the unscaled residual), gathers the triplets
    on a beam's rows into dense rows (the originals kept at zero, so that
    the pattern is fixed) and emits M_b^-1 times them on their structural
    columns; returns the new count."""
    n, m = _rows(I, MASS), _rows(I, ROW_ELEMENT)
    size, l0, e0, a0 = _layout(rec, n, m)
    r5 = 2 * n + 2 * m
    u = np.empty(size)
    _residual_additive(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, u, qx, vx, np.zeros(n + 3))
    _state(rec, n, w, q_pred, v_pred, qx, vx)
    z = np.empty((3, n))
    _additive_parts(rec, I, Fl, t, F_old, qx_old, w, qx, vx, z[0], z[1], z[2], np.empty(n + 3))
    cqx = rec[CQX]
    for k in range(3):
        off = (0, n, r5)[k]
        for j in range(n):
            z[k, j] -= u[off + j]
        p = _emit_beams(I, Fl, qx, vx, z[k], FFR_MXQ, R, C, V, p, off, _0, cqx, 0.0)
    Minv = _beam_inverses(I, Fl, qx)
    beam_of, local = _beam_map(I, n)
    nb, cmax = Minv.shape[0], Minv.shape[1]
    rows_of = np.zeros((3, nb, cmax, size))        # the beams' rows, by block, dense
    used = np.zeros((3, nb, size), np.bool_)       # their structural columns
    for i in range(p):
        row = R[i]
        k = 0 if row < n else (1 if row < 2 * n else (2 if row >= r5 else -1))
        if k < 0:
            continue
        j = row - (0, n, r5)[k]
        b = beam_of[j]
        if b < 0:
            continue
        rows_of[k, b, local[j], C[i]] += V[i]
        used[k, b, C[i]] = True
        V[i] = 0.0
    for k in range(3):
        off = (0, n, r5)[k]
        for b in range(nb):
            k0, c = _i(I, BEAM, b, 0), 3 + _i(I, BEAM, b, 1)
            for col in range(size):
                if not used[k, b, col]:
                    continue
                for d in range(c):
                    acc = 0.0
                    for a in range(c):
                        acc += Minv[b, d, a] * rows_of[k, b, a, col]
                    p = _put(R, C, V, p, off + _i(I, BCOL, k0 + d, 0), col, acc)
    return p


@_jit
def _old_force(rec, I, Fl, t, q, v, lam, out, qx, vx, work):
    """F_n of the recipe into out (n,): Phi_q^T lambda - Q (linear form),
    -M(q)^-1 Q (additive form: minus HHT-ADD's f_n)."""
    if rec[FORM] == ADDITIVE:
        n = q.shape[0]
        qx[:n] = q
        vx[:n] = v
        forces(I, Fl, t, qx, vx, lam, work)
        for j in range(n):
            work[j] = -work[j]
        _mass_solve(I, Fl, qx, work, out)
    else:
        _force_term(I, Fl, t, q, v, lam, out, qx, vx, work)


@_jit
def accumulate(V, count, position, data):
    """data[position[i]] += V[i] for the first ``count`` triplets (data zeroed
    first): the values of a sparse matrix on its fixed pattern."""
    data[:] = 0.0
    for i in range(count):
        data[position[i]] += V[i]


@_jit
def _force_term(I, Fl, t, q, v, lam, out, qx, vx, work):
    """Phi_q^T lambda - Q(q, v) into out (n,) (``common.force_term``)."""
    n = q.shape[0]
    qx[:n] = q
    vx[:n] = v
    forces(I, Fl, t, qx, vx, lam, work)
    for j in range(n + 3):
        work[j] = -work[j]
    phiqT_add(I, Fl, qx, lam, 1.0, work)
    out[:] = work[:n]


@_jit
def _index1_gamma(I, Fl, t, qx, vx, gam, R, C, V):
    """-gamma = (Phi_q v)_q v + Phi_tt into gam (m,) at (t, qx, vx) (Haug, sec. 6.3)."""
    n = _rows(I, MASS)
    gam[:] = 0.0
    _phi_time_add(I, Fl, t, gam, 2)
    p = _emit_G(I, Fl, n, qx, vx, R, C, V, _0, _0, _0, 1.0)
    for i in range(p):
        gam[R[i]] += V[i] * vx[C[i]]


@_jit
def _index1_multipliers_band(I, Fl, t, q, v, out, R, C, V, iterations, order, kd, addr):
    """The index-1 multipliers of ``_index1_multipliers`` for rigid bodies
    (M a constant diagonal) from the Schur complement

        A lambda = Phi_q M^-1 Q - gamma,    A = Phi_q M^-1 Phi_q^T (m x m, SPD),

    the constraint rows reordered by ``order`` (position k holds row
    order[k]) so that A is a band of half-width kd, factored by LAPACK's
    band Cholesky (dpbtrf, dpbtrs at ``addr``). A chain of N links costs
    O(N) per row instead of the O((n + m)^3) of the dense index-1 matrix.
    Friction: the fixed point of ``_index1_multipliers`` on the same
    factorization. A matrix that is not positive definite, or whose
    Cholesky pivots (U_kk^2) fall below 1e-13 of the largest (redundant
    joints, a singular position), gives NaN for that row."""
    n, m = q.shape[1], out.shape[1]
    qx, vx, work = np.zeros(n + 3), np.zeros(n + 3), np.zeros(n + 3)
    ldab = kd + 1
    AB, b, gam, lam = np.empty((m, ldab)), np.empty(m), np.empty(m), np.zeros(m)
    place = np.empty(m, np.int64)
    for k in range(m):
        place[order[k]] = k
    ints = np.array([m, kd, ldab, 1, 0], np.int32)    # n, kd, ldab, nrhs, info
    uplo = np.array([ord("U")], np.uint8)
    minv = np.empty(n)
    for j in range(n):
        minv[j] = 1.0 / _f(I, Fl, MASS, j, 0)
    friction = _rows(I, FRI) > 0
    by_col = np.empty(0, np.int64)
    start = np.zeros(n + 1, np.int64)
    for row in range(q.shape[0]):
        for j in range(n):
            qx[j], vx[j] = q[row, j], v[row, j]
        _index1_gamma(I, Fl, t[row], qx, vx, gam, R, C, V)    # before R, C, V hold Phi_q
        p = _emit_phiq(I, Fl, n, qx, R, C, V, _0, _0, _0, 1.0, _NO)
        if row == 0:               # the pattern is fixed: entries grouped by column once
            by_col = np.argsort(C[:p], kind="mergesort")
            for i in range(p):
                start[C[i] + 1] += 1
            for j in range(n):
                start[j + 1] += start[j]
        AB[:, :] = 0.0             # A(i, j), i <= j, at AB[j, kd + i - j] (LAPACK "U")
        ok = True
        for col in range(n):
            for x in range(start[col], start[col + 1]):
                ex = by_col[x]
                i = place[R[ex]]
                for y in range(start[col], start[col + 1]):
                    ey = by_col[y]
                    j = place[R[ey]]
                    if i <= j:
                        if j - i > kd:
                            ok = False
                        else:
                            AB[j, kd + i - j] += V[ex] * V[ey] * minv[col]
        if ok:
            ints[4] = 0
            _fortran_call(addr[0], (uplo, ints[0:1], ints[1:2], AB, ints[2:3], ints[4:5]))
            ok = ints[4] == 0
            # dependent rows leave a pivot of round-off (3e-15 of the largest on a
            # parallelogram with a redundant link), which dpbtrf accepts
            dmin, dmax = np.inf, 0.0
            for k in range(m):
                d = AB[k, kd] * AB[k, kd]
                dmin, dmax = min(dmin, d), max(dmax, d)
            ok = ok and dmin >= 1e-13 * dmax
        lam[:] = 0.0
        settled = False
        for sweep in range(iterations if (friction and ok) else (1 if ok else 0)):
            forces(I, Fl, t[row], qx, vx, lam, work)
            for k in range(m):
                b[k] = gam[order[k]]            # Phi_q M^-1 Q - gamma, reordered
            for e in range(p):
                b[place[R[e]]] += V[e] * minv[C[e]] * work[C[e]]
            _fortran_call(addr[1], (uplo, ints[0:1], ints[1:2], ints[3:4], AB, ints[2:3], b,
                                    ints[0:1], ints[4:5]))
            change, big = 0.0, 0.0
            for k in range(m):
                xk = b[place[k]]
                change = max(change, abs(xk - lam[k]))
                big = max(big, abs(xk))
                lam[k] = xk
            if not friction or change <= 1e-13 * (1.0 + big):
                settled = True
                break
        for k in range(m):
            out[row, k] = lam[k] if settled and np.isfinite(lam[k]) else np.nan


@_jit
def _index1_multipliers(I, Fl, t, q, v, out, R, C, V, iterations):
    """The Lagrange multipliers of the index-1 system at each row into out
    (N, m): [[M(q), Phi_q^T], [Phi_q, 0]] [a; lambda] = [Q(t, q, v,
    lambda); gamma], gamma = -(Phi_q v)_q v - Phi_tt (Haug, sec. 6.3;
    ``AssembledSystem.index1_multipliers``). With friction Q reads lambda:
    up to ``iterations`` fixed-point sweeps from lambda = 0, to a change of
    1e-13 relative (``AssembledSystem.index1_solve``). A singular matrix, or
    friction that does not settle, gives NaN for that row. Rows: t (N,), q,
    v (N, n); R, C, V triplet scratch of ``triplet_bound`` entries."""
    n, m = q.shape[1], out.shape[1]
    size = n + m
    qx, vx, work = np.zeros(n + 3), np.zeros(n + 3), np.zeros(n + 3)
    K, rhs, gam, lam = np.empty((size, size)), np.empty(size), np.empty(m), np.zeros(m)
    friction = _rows(I, FRI) > 0
    for row in range(q.shape[0]):
        for j in range(n):
            qx[j], vx[j] = q[row, j], v[row, j]
        p = _emit_mass(I, Fl, n, qx, R, C, V, _0, _0, _0, 1.0)
        p = _emit_phiq(I, Fl, n, qx, R, C, V, p, _0, n, 1.0, _YES)
        p = _emit_phiq(I, Fl, n, qx, R, C, V, p, n, _0, 1.0, _NO)
        K[:, :] = 0.0
        for i in range(p):
            K[R[i], C[i]] += V[i]
        _index1_gamma(I, Fl, t[row], qx, vx, gam, R, C, V)
        lam[:] = 0.0
        ok = False
        for sweep in range(iterations if friction else 1):
            forces(I, Fl, t[row], qx, vx, lam, work)
            for j in range(n):
                rhs[j] = work[j]
            for i in range(m):
                rhs[n + i] = -gam[i]
            try:
                sol = np.linalg.solve(K, rhs)
            except Exception:       # a singular configuration
                break
            change, big = 0.0, 0.0
            for i in range(m):
                change = max(change, abs(sol[n + i] - lam[i]))
                big = max(big, abs(sol[n + i]))
                lam[i] = sol[n + i]
            if not friction or change <= 1e-13 * (1.0 + big):
                ok = True
                break
        for i in range(m):
            out[row, i] = lam[i] if ok else np.nan


@_jit
def _mobility(I, Fl, q, out, R, C, V, qx, per):
    """Multiplier mobility per constraint row into out (m,)
    (``AssembledSystem.multiplier_mobility``): max over the element's
    Phi_q entries of |Phi_q[k, j]| / M_jj; ``per``: scratch of n_elements."""
    n = _rows(I, MASS)
    qx[:n] = q
    p = _emit_phiq(I, Fl, n, qx, R, C, V, _0, _0, _0, 1.0, _NO)
    per[:] = 0.0
    for i in range(p):
        ratio = abs(V[i]) / _f(I, Fl, MASS, C[i], 0)
        e = _i(I, ROW_ELEMENT, R[i], 0)
        if ratio > per[e]:
            per[e] = ratio
    for i in range(out.shape[0]):
        out[i] = per[_i(I, ROW_ELEMENT, i, 0)]


@_jit
def _scales_weights(rec, I, Fl, q, w, opts, R, C, V, qx, weight, scratch):
    """Newton weights (``Newton.solve``): scales / (atol + rtol |s w|), with the
    multipliers' relative part taken norm-wise, and the round-off floor
    (``Method.scales``, ``Method.roundoff_floor``: the recipe's sx, sy,
    mu_mob and floor). ``scratch``: m + n_elements + 2 size floats, so that
    a step allocates nothing."""
    n, m, ne = _rows(I, MASS), _rows(I, ROW_ELEMENT), I[_HEADER - 1]
    size, l0, u0, a0 = _layout(rec, n, m)
    rtol, atol_k, atol_m = opts[0], opts[1], opts[2]
    mob = scratch[:m]
    _mobility(I, Fl, q, mob, R, C, V, qx, scratch[m:m + ne])
    qmax = 0.0
    for j in range(n):
        qmax = max(qmax, abs(q[j]))
    floor = 32.0 * EPS * (1.0 + qmax) * rec[FLOOR]
    scales = scratch[m + ne:m + ne + size]
    mult = scratch[m + ne + size:m + ne + 2 * size]
    mult[:] = 0.0
    sx, sy = rec[SX], rec[SY]
    scales[:n] = sx
    if rec[FORM] == ADDITIVE:          # dq, dv: sx; a: sy; psi_I, psi_II: sm times the mobility
        scales[n:2 * n] = sx
        scales[2 * n:3 * n] = sy
        for i in range(m):
            scales[u0 + i] = scales[l0 + i] = rec[SM] * mob[i]
            mult[u0 + i] = mult[l0 + i] = 1.0
    else:
        for i in range(m):
            scales[l0 + i] = sx * mob[i]
            mult[l0 + i] = 1.0
    if rec[FORM] != ADDITIVE and rec[HAS_Y] != 0.0:
        scales[n:2 * n] = sy
        for i in range(m):
            scales[u0 + i] = sy * mob[i] if rec[MU_MOB] != 0.0 else sy
            mult[u0 + i] = 1.0
    smax = 0.0
    for i in range(size):
        if mult[i] != 0.0:
            smax = max(smax, abs(scales[i] * w[i]))
    for i in range(size):
        is_mult = mult[i] != 0.0
        atol = max(atol_m if is_mult else atol_k, floor)
        sz = smax if is_mult else abs(scales[i] * w[i])
        weight[i] = scales[i] / (atol + rtol * sz)
    if rec[REG] != 0.0:        # augmented: only Phi_q^T lambda is unique; converge on x
        for i in range(m):
            weight[l0 + i] = 0.0


# --------------------------------------------------------------------------------------------
# Linear solvers
#
# ``lin`` = (J, Jinv^T, AB, ipiv, rperm, cperm, lp, addr, trans, b, Lr, Lc, Lv):
# the dense Newton matrix and its inverse, stored transposed (size x size;
# DENSE), and for BANDED: the band storage AB (size x ldab in C order, i.e. LAPACK's
# column-major ldab x size, ldab = 2 kl + ku + 1), LAPACK's pivots, the
# orderings (equation i is row rperm[i], unknown j is column cperm[j] of the
# band matrix), the integer arguments lp = (s, s, kl, ku, ldab, 1, s, info,
# blocks, coupling count) with s = size / blocks, the addresses of dgbtrf
# and dgbtrs (``lapack_band_addresses``), the character "N", a right-hand
# side buffer, and the triplets of the coupling block (below).
#
# Blocks: with one block the band matrix is the Newton matrix reordered.
# With two (HHT-SI2: block 0 = the (a, lambda) unknowns with the dynamics
# and velocity-constraint rows, block 1 = (abar, mu) with the abar and
# position-constraint rows) it is the block lower-triangular part of the
# Newton matrix: the diagonal blocks are factored apart (two band LUs of n +
# m unknowns and a third of the bandwidth, instead of one of 2 (n + m)), the
# lower block L21 enters the solve by a product, and the upper block, the
# dependence of the dynamics and velocity-constraint rows on abar (h^2/2 K,
# h/2 d(Phi_q v)/dq: O(h^2) and O(h) against the mass and Phi_q they sit
# beside), is left out. That changes the Newton matrix, never the residual:
# modified Newton converges to the same solution, at a contraction rate of
# the order of those terms. Arrays a solver does not use are one-element
# placeholders, so that every solver shares one compiled signature.
# --------------------------------------------------------------------------------------------

@intrinsic
def _fortran_call(typingctx, address, args):
    """Call the Fortran-convention routine at ``address`` (an int64 known only
    at run time, so the calling function stays cacheable) with the data
    pointers of the arrays in the tuple ``args``: every argument of a LAPACK
    routine is passed by reference."""
    sig = numba.types.void(address, args)

    def codegen(context, builder, signature, llargs):
        """LLVM IR: the arrays' data pointers, cast to i8*, passed to the
        routine at ``addr`` as a void function of as many pointers."""
        addr, tup = llargs
        byte_ptr = ir.IntType(8).as_pointer()
        ptrs = []
        for i, ty in enumerate(signature.args[1]):
            arr = context.make_array(ty)(context, builder, builder.extract_value(tup, i))
            ptrs.append(builder.bitcast(arr.data, byte_ptr))
        fnty = ir.FunctionType(ir.VoidType(), [byte_ptr] * len(ptrs))
        builder.call(builder.inttoptr(addr, fnty.as_pointer()), ptrs)
        return context.get_dummy_value()

    return sig, codegen


def lapack_band_addresses(names=("dgbtrf", "dgbtrs")):
    """int64 array: the addresses of LAPACK's routines ``names`` (default the
    band LU, dgbtrf and dgbtrs; the band Cholesky is dpbtrf, dpbtrs) in
    scipy.linalg.cython_lapack (the LAPACK scipy itself links), or None when
    that build uses 64-bit integers (the kernels pass 32-bit ones)."""
    import scipy
    from numba.extending import get_cython_function_address
    try:
        blas = scipy.show_config(mode="dicts")["Build Dependencies"]["blas"]
        if any("ilp64" in str(k) and v not in (False, "False", None) for k, v in blas.items()):
            return None
    except Exception:       # noqa: BLE001 - an older scipy without the dict: LP64 builds only
        pass
    return np.array([get_cython_function_address("scipy.linalg.cython_lapack", name)
                     for name in names], np.int64)


@_jit
def _invert(J, Jinv):
    """Jinv = (J^-1)^T, the inverse stored transposed (``_solve`` then reads
    it along memory); False when J is singular or too ill-conditioned to use
    (1-norm condition number above 1e15)."""
    if not np.all(np.isfinite(J)):    # whole-array: also the uncompiled copy's speed
        return False
    try:
        inv = np.linalg.inv(J)
    except Exception:      # noqa: BLE001 - numba raises LinAlgError for an exactly singular J
        return False
    na = np.max(np.sum(np.abs(J), axis=0))
    ni = np.max(np.sum(np.abs(inv), axis=0))
    if not np.isfinite(ni) or na * ni > 1e15:
        return False
    Jinv[:, :] = inv.T
    return True


@_jit
def _factor(solver, lin, R, C, V, p):
    """Factor the Newton matrix given by p triplets; the Newton status code
    (CONVERGED for success, SINGULAR or NONFINITE)."""
    J, Jinv, AB, ipiv, rperm, cperm, lp, addr = (lin[0], lin[1], lin[2], lin[3], lin[4],
                                                 lin[5], lin[6], lin[7])
    Lr, Lc, Lv = lin[10], lin[11], lin[12]
    for i in range(p):
        if not np.isfinite(V[i]):
            return NONFINITE
    if solver == DENSE:
        J[:, :] = 0.0
        for i in range(p):
            J[R[i], C[i]] += V[i]
        return CONVERGED if _invert(J, Jinv) else SINGULAR
    s, kl, ku, blocks = lp[0], lp[2], lp[3], lp[8]
    diag = kl + ku
    AB[:, :] = 0.0
    nc = 0
    for i in range(p):
        row, col = rperm[R[i]], cperm[C[i]]
        rb, cb = row // s, col // s
        if rb == cb:
            row -= rb * s
            col -= cb * s
            if row - col > kl or col - row > ku:     # outside the band found at build
                return SINGULAR
            AB[cb * s + col, diag + row - col] += V[i]
        elif rb > cb:                                  # the coupling block L21
            Lr[nc], Lc[nc], Lv[nc] = row - s, col, V[i]
            nc += 1
    lp[9] = nc
    for blk in range(blocks):
        lp[7] = 0
        _fortran_call(addr[0], (lp[0:1], lp[1:2], lp[2:3], lp[3:4], AB[blk * s:(blk + 1) * s],
                                lp[4:5], ipiv[blk * s:(blk + 1) * s], lp[7:8]))
        if lp[7] != 0:                               # info > 0: an exactly zero pivot
            return SINGULAR
    # as SparseLU: a pivot below 1e-14 of the largest is numerically singular
    dmin, dmax = np.inf, 0.0
    for j in range(AB.shape[0]):
        d = abs(AB[j, diag])
        dmin, dmax = min(dmin, d), max(dmax, d)
    if not (dmin >= 1e-14 * dmax) or not np.isfinite(dmax):
        return SINGULAR
    return CONVERGED


@_jit
def _solve(solver, lin, r, dw):
    """dw = J^-1 r with the factorization of ``_factor``."""
    size = r.shape[0]
    if solver == DENSE:
        # dw = sum_k r_k (J^-1)[:, k], column by column of J^-1 (a row of the
        # stored transpose): the inner loop runs along memory and over
        # independent sums, which the compiler vectorises; each dw_i adds the
        # same products in the same order as a row-times-vector loop would
        # (bit-identical), 3x faster at 28 unknowns
        JinvT = lin[1]
        dw[:size] = 0.0
        for k in range(size):
            rk = r[k]
            for i in range(size):
                dw[i] += JinvT[k, i] * rk
        return
    AB, ipiv, rperm, cperm, lp, addr, trans, b = (lin[2], lin[3], lin[4], lin[5], lin[6],
                                                  lin[7], lin[8], lin[9])
    Lr, Lc, Lv = lin[10], lin[11], lin[12]
    s, blocks = lp[0], lp[8]
    for i in range(size):
        b[rperm[i]] = r[i]
    for blk in range(blocks):
        if blk == 1:                                   # block 1's rows: r2 - L21 x1
            for k in range(lp[9]):
                b[s + Lr[k]] -= Lv[k] * b[Lc[k]]
        _fortran_call(addr[1], (trans, lp[1:2], lp[2:3], lp[3:4], lp[5:6],
                                AB[blk * s:(blk + 1) * s], lp[4:5], ipiv[blk * s:(blk + 1) * s],
                                b[blk * s:(blk + 1) * s], lp[6:7], lp[7:8]))
    for i in range(size):
        dw[i] = b[cperm[i]]


@_jit
def _newton(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, weight, opts, solver, lin, lu_state,
            R, C, V, r, dw, qx, vx, work, counts, spare):
    """One step's Newton iteration on w (in place), with the stored
    factorization (``_factor``, ``_solve``) reused across iterations and
    steps (modified Newton). ``spare``: scratch of 2 size floats for the
    residual's round-off test (``_rest_at_roundoff``, newton.py's).

    ``opts`` = (rtol, atol_k, atol_m, max_iter, rate_refresh, full);
    ``lu_state`` = (valid, rate); ``counts`` += (iterations, residuals,
    jacobians, factorizations, stalled steps). Returns the status code.
    """
    max_iter, rate_refresh, full = int(opts[3]), opts[4], opts[5] != 0.0
    size = w.shape[0]
    # the augmented formulation factors a Newton matrix of its own every step
    # (``Method.formulated``: near a singular position one from an earlier step
    # ends the iteration away from the step's solution)
    valid = lu_state[0] != 0.0 and not full and rec[REG] == 0.0
    age = 1 << 30
    prev = -1.0
    best = np.inf
    stalls = 0
    grows = 0
    theta = lu_state[1]
    n_jac = 0
    for _ in range(max_iter):
        if not valid:
            p = _jacobian_triplets(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, R, C, V, qx,
                                   vx)
            counts[2] += 1
            n_jac += 1
            status = _factor(solver, lin, R, C, V, p)
            if status != CONVERGED:
                lu_state[0] = 0.0
                return status
            counts[3] += 1
            valid = True
            age = 0
        _residual(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, r, qx, vx, work)
        counts[1] += 1
        for i in range(size):
            if not np.isfinite(r[i]):
                lu_state[0] = 0.0
                return NONFINITE
        _solve(solver, lin, r, dw)
        norm = 0.0
        for i in range(size):
            norm = max(norm, abs(dw[i] * weight[i]))
        for i in range(size):
            w[i] -= dw[i]
        counts[0] += 1
        current = age == 0
        age += 1
        for i in range(size):
            if not np.isfinite(w[i]):
                lu_state[0] = 0.0
                return NONFINITE
        if prev > 0.0:
            theta = norm / prev
        eta = max(theta / (1.0 - theta), 1e-2) if theta < 1.0 else np.inf
        stuck = prev >= 0.0 and norm >= max(0.5, rate_refresh) * prev   # newton.py's rule
        if current:
            stalls = stalls + 1 if norm >= 0.5 * best else 0
            best = min(best, norm)
        roundoff = stalls >= 2 and norm <= ROUNDOFF_BAND
        grows = grows + 1 if (prev >= 0.0 and theta >= 1.0 and current) else 0
        diverging = theta > 100.0 or (grows >= 2 and norm > ROUNDOFF_BAND)
        if ((stalls >= 2 or diverging) and not roundoff and norm > 1.0 and rec[FORM] == LINEAR
                and rec[REG] == 0.0
                and _rest_at_roundoff(rec, I, solver, lin, r, qx, vx, weight, spare)):
            for i in range(size):         # the iterate whose residual r was read
                w[i] += dw[i]
            roundoff = True
        if norm == 0.0 or (eta * norm <= 1.0 and norm <= 1.0) or roundoff:
            if roundoff:
                counts[4] += 1
            lu_state[1] = min(max(theta, 1e-3), 0.9) if np.isfinite(theta) else 0.5
            lu_state[0] = 0.0 if full else 1.0
            return CONVERGED
        if diverging:
            lu_state[0] = 0.0
            return DIVERGING
        from_earlier_step = n_jac == 0
        if (full or stuck or (from_earlier_step and prev >= 0.0 and theta > rate_refresh)
                or (norm <= ROUNDOFF_BAND and prev >= 0.0 and theta > 0.25)):
            valid = False
        prev = norm
    lu_state[0] = 0.0
    return MAX_ITER


ROUNDOFF_ULPS = 8.0        # as in newton.py


@_jit
def _rest_at_roundoff(rec, I, solver, lin, r, qx, vx, weight, spare):
    """newton.py's residual test of a stagnating exact-Newton iteration at
    the iterate whose residual is r (state in qx, vx): its constraint rows
    (Phi scaled by sP, at index 2 Phi_q v + Phi_t scaled by sV) within
    ROUNDOFF_ULPS ulps of their terms, and the update the other rows alone
    ask for, J^-1 r' (r' = r with those rows zeroed, in spare[:size]; the
    update in spare[size:]), within the tolerance."""
    n, m = _rows(I, MASS), _rows(I, ROW_ELEMENT)
    if m == 0:
        return False
    size, l0, u0, _ = _layout(rec, n, m)
    qmax, vmax = 0.0, 0.0
    for j in range(n):
        qmax = max(qmax, abs(qx[j]))
        vmax = max(vmax, abs(vx[j]))
    scale = ROUNDOFF_ULPS * EPS * (1.0 + qmax)
    for i in range(m):
        if abs(r[l0 + i]) > abs(rec[SP]) * scale:
            return False
    if rec[HAS_Y] != 0.0:
        for i in range(m):
            if abs(r[u0 + i]) > abs(rec[SV]) * scale * (1.0 + vmax):
                return False
    rest, dw = spare[:size], spare[size:2 * size]
    for i in range(size):
        rest[i] = r[i]
    for i in range(m):
        rest[l0 + i] = 0.0
    if rec[HAS_Y] != 0.0:
        for i in range(m):
            rest[u0 + i] = 0.0
    _solve(solver, lin, rest, dw)
    for i in range(size):
        if abs(dw[i] * weight[i]) > 1.0:
            return False
    return True


def triplet_bound(I) -> int:
    """An upper bound of the Newton-matrix triplets any recipe emits for the
    packed model data ``I`` (its header's row counts): up to five mass (and
    identity) blocks, four Hessian, two force, two G and six Phi_q blocks (a force
    block: 36 entries per spring-damper and per contact gap, 4 per rotational one, 1 per point
    force, 36 per partial derivative of a load of the state (6 rows by 6
    columns) and 36 per load of the state (tau d^2 s of a joint force)), and the
    augmented formulation's multiplier diagonal; per flexible beam 15 blocks of
    (3 + nf)^2 (mass, (M x)_q and force blocks), per elastic term of a joint
    point 40 entries, per spring-damper with points on beams (6 + e)^2
    instead of 36, per point force on a beam 1 + 2 e, per distance joint on
    beams four (6 + e)^2 Hessian and two 6 + e G blocks; and 3 + nf per column
    of the additive form's three blocks of each beam's rows
    (``_unscale_beam_rows``)."""
    def rows(k):
        """Instances of field k (the header's row count)."""
        return int(I[3 * k + 1])
    n = rows(MASS)
    kc, kp, kl, kd = rows(CROW), rows(PROW), rows(LROW), rows(DROW)
    ks, kr, kf = rows(SCOL1), rows(RCOL), rows(FCOL)
    phiq = 8 * kc + 6 * kp + 2 * kl + 6 * kd
    beams, csum = 0, 0
    for b in range(rows(BEAM)):     # blocks, and the additive form's M M_n^-1 Phi_q^T (twice)
        c = 3 + int(I[int(I[3 * BEAM]) + 6 * b + 1])
        beams += 15 * c * c + 2 * c * (phiq + 2 * rows(ECOL))
        csum += c
    base = (6 * n + rows(ROW_ELEMENT) + 6 * phiq + 4 * (2 * kc + 12 * kp + 36 * kd)
            + 2 * (36 * ks + 4 * kr + kf + 36 * rows(SDV) + 36 * rows(STQ) + 36 * rows(FRI)
                   + 36 * rows(KGI))
            + 2 * (4 * kc + 6 * kp + 6 * kd) + 12 * rows(FRI) + beams + 40 * rows(ECOL))
    # springs and point forces on beam points: (6 + e)^2 and 1 + 2 e entries, e their
    # elastic terms (spans into ECOL), in each of the two force blocks
    ecs = 0
    for i in range(rows(SEL)):
        o = int(I[3 * SEL]) + 4 * i
        c = 6 + int(I[o + 1] - I[o] + I[o + 3] - I[o + 2])
        ecs += c * c - 36
    for i in range(rows(FEL)):
        o = int(I[3 * FEL]) + 2 * i
        ecs += 2 * int(I[o + 1] - I[o])
    for i in range(rows(DSP)):          # distance joints: four Hessian and two G blocks
        o = int(I[3 * DSP]) + 4 * i
        c = 6 + int(I[o + 1] - I[o] + I[o + 3] - I[o + 2])
        ecs += 2 * c * c + c
    # the additive form's unscaled beam rows: c entries per structural column, 3 blocks
    return base + 2 * ecs + 3 * (3 * n + 2 * rows(ROW_ELEMENT)) * csum


@_jit
def _workspace(n, m, size, I):
    """The time loops' scratch arrays, allocated once per call: (r, dw, w,
    weight, qx, vx, work, q_pred, v_pred, qx_old, F, scratch)."""
    return (np.empty(size), np.empty(size), np.empty(size), np.empty(size), np.zeros(n + 3),
            np.zeros(n + 3), np.zeros(n + 3), np.empty(n), np.empty(n), np.zeros(n + 3),
            np.zeros(n), np.empty(m + I[_HEADER - 1] + 2 * size))


@_jit
def _start_force(rc, I, Fl, t0, q, v, lam, F0, F, qx, vx, work):
    """F_n at t0 into F (recipes with cF != 0): F0 when given (not NaN),
    else the law's at (q, v, lambda)."""
    if rc[CF] != 0.0:
        if F0.shape[0] == F.shape[0] and not math.isnan(F0[0]):
            F[:] = F0
        else:
            _old_force(rc, I, Fl, t0, q, v, lam, F, qx, vx, work)


@_jit
def _start_w(rc, I, Fl, q, a, v, lam, w, qx, y):
    """Newton's start: x = a_n, lambda_n; y = y0v v_n. The additive form:
    a = a_n, psi_I = psi_II = lambda_n, and dq, dv with the corrections of
    the step before, R_n = -M(q_n)^-1 Phi_q(q_n)^T lambda_n, in place of R_I
    and R_II (``HHTADD.predict``): dq = ka1 a_n + R_n / 2, dv = ka2 a_n +
    R_n. ``qx``, ``y``: scratch of size n + 3."""
    n, m = _rows(I, MASS), _rows(I, ROW_ELEMENT)
    size, l0, e0, a0 = _layout(rc, n, m)
    w[:] = 0.0
    w[a0:a0 + n] = a
    w[l0:l0 + m] = lam
    if rc[FORM] == ADDITIVE:
        qx[:n] = q
        _minus_correction(I, Fl, qx, lam, y)          # y = -R_n
        for j in range(n):
            w[j] = rc[KA1] * a[j] - 0.5 * y[j]
            w[n + j] = rc[KA2] * a[j] - y[j]
        w[e0:e0 + m] = lam
    elif e0 < size:
        for j in range(n):
            w[n + j] = rc[Y0V] * v[j]


@_jit
def _record(rec, t, q, v, a, lam, mu, counts, out_t, out_q, out_v, out_a, out_lam, out_mu,
            out_stats):
    """Row ``rec`` of the out_* arrays: the state, and the Newton counts
    since the last record (then zeroed); returns rec + 1."""
    out_t[rec] = t
    out_q[rec] = q
    out_v[rec] = v
    out_a[rec] = a
    out_lam[rec] = lam
    out_mu[rec] = mu
    for i in range(6):
        out_stats[rec, i] = counts[i]
    counts[:] = 0
    return rec + 1


@_jit
def _total_acceleration(I, Fl, n, qx, a, psi, R, C, V, out):
    """a - M(q)^{-1} Phi_q(q)^T psi into out (n,) [m/s^2 or rad/s^2] at qx:
    the additive form's total acceleration a + R (``HHTADD.local_error``);
    R, C, V: triplet scratch (unused)."""
    y = np.empty(n + 3)
    _minus_correction(I, Fl, qx, psi, y)
    for j in range(n):
        out[j] = a[j] - y[j]


@_jit
def _recipe_at(mono, h, c0, w0, w1, rec):
    """The recipe at step size h and BDF coefficients c0, w0, w1 from its
    monomials (``engine.recipe_monomials``, mono (5, F)): rec[i] =
    c h^a c0^b w0^c w1^d."""
    for i in range(rec.shape[0]):
        c = mono[0, i]
        rec[i] = (c * h ** mono[1, i] * c0 ** mono[2, i] * w0 ** mono[3, i] * w1 ** mono[4, i]
                  if c != 0.0 else 0.0)


@_jit
def _bdf_ratio(two_step, h, h_last):
    """(c0 [1/s], w0, w1) of a two-step recipe's step of size h [s] after one
    of h_last [s] (BDF2 of the ratio w = h / h_last: c0 = (1 + 2w)/((1 + w) h),
    w0 = (1 + w)^2/(1 + 2w), w1 = -w^2/(1 + 2w); BDF1, (1/h, 1, 0), when
    h_last is 0); (1, 1, 1) for a one-step recipe, which reads none of them."""
    if not two_step:
        return 1.0, 1.0, 1.0
    if h_last == 0.0:
        return 1.0 / h, 1.0, 0.0
    wr = h / h_last
    return ((1.0 + 2.0 * wr) / ((1.0 + wr) * h), (1.0 + wr) ** 2 / (1.0 + 2.0 * wr),
            -wr * wr / (1.0 + 2.0 * wr))


@_jit
def _crossed(I, Fl, n, q, qx, gaps, springs, qs, grad6, H6):
    """Whether the step from q (n,) to qx (n + 3,) changes the sign of a gap
    of the contacts and joint limits (``gaps``) or takes the points of a
    spring-damper with a free length past each other (``springs``): an
    event. qs (n + 3,), grad6 (6,), H6 (6, 6): scratch."""
    qs[:n] = q
    if springs and _spring_passed(I, Fl, qs, qx):
        return True
    for i in range(_rows(I, KGI) if gaps else 0):        # a gap opens or closes
        if (_gap(I, Fl, qs, i, grad6, H6) > 0.0) != (_gap(I, Fl, qx, i, grad6, H6) > 0.0):
            return True
    return False


#: The step-size controller (``adaptive``): the order k of the error per unit
#: step in h, and the gains of Soderlind's H211b digital filter with b = 4
#: (G. Soderlind, "Digital filters in adaptive time-stepping", ACM TOMS 29
#: (2003) 1-26, sec. 6): beta1 = beta2 = 1/(b k), alpha2 = 1/b.
ERROR_ORDER = 2.0
H211B_BETA = 1.0 / (4.0 * ERROR_ORDER)
H211B_ALPHA = 0.25


@_jit
def step_ratio(err, err_last, ratio_last, safety, fmin, fmax):
    """The next step's size over this one's from the error per unit step
    ``err`` of this step (``_error_norm``) and, when both are positive, the
    last accepted step's ``err_last`` and the ratio ``ratio_last`` chosen
    after it: Soderlind's H211b filter

        r = (theta / err)^beta1 (theta / err_last)^beta2 ratio_last^(-alpha2),

    theta = safety^k (the filter's fixed point is err = theta), else the
    elementary controller (theta / err)^(1/k) (the first step, and after a
    rejection or an event); within [fmin, fmax]. An error of 0 gives fmax, a
    non-finite one fmin. Both steppers' rule (``_run``,
    ``loop.PythonStepper``)."""
    if err == 0.0:
        return fmax
    if not math.isfinite(err):
        return fmin
    theta = safety ** ERROR_ORDER
    if err_last > 0.0 and ratio_last > 0.0:
        r = ((theta / err) ** H211B_BETA * (theta / err_last) ** H211B_BETA
             * ratio_last ** (-H211B_ALPHA))
    else:
        r = (theta / err) ** (1.0 / ERROR_ORDER)
    return min(fmax, max(fmin, r))


#: Constraint rows up to which an index-3 method's error estimate is taken on
#: its index-1 accelerations (``_index1_acceleration``: m Jacobian products
#: and an m x m least-squares solve per step); above it, on a as it is.
INDEX1_LIMIT = 200


@_jit
def _index1_acceleration(I, Fl, n, m, t, qx, vx, a, out, R, C, V, S, col, g, y):
    """out[:n] = a - M^-1 Phi_q^T (Phi_q M^-1 Phi_q^T)^+ (Phi_q a - gamma) at
    (t, qx, vx): the acceleration a (n,) made to meet the acceleration
    constraints Phi_q a = gamma, gamma = -(Phi_q v)_q v - Phi_tt (Haug, sec.
    6.3), by a change along the directions M^-1 Phi_q^T lambda in which the
    multipliers act: the index-1 acceleration when a's tangential part is
    the true one (the pseudo-inverse keeps redundant rows). An index-3
    method's a meets only Phi = 0; its normal part is the multipliers'
    round-off over beta h^2. R, C, V: triplet scratch; S (m, m), col, g
    (m,), y (n + 3,): scratch, allocated once per call of the time loop."""
    for i in range(m):
        col[:] = 0.0
        col[i] = 1.0
        _minus_correction(I, Fl, qx, col, y)        # M^-1 Phi_q^T e_i
        y[n:] = 0.0                                 # the ground's columns
        phiq_times(I, Fl, qx, y, g)
        S[:, i] = g
    y[:n] = a[:n]
    y[n:] = 0.0
    phiq_times(I, Fl, qx, y, g)
    _index1_gamma(I, Fl, t, qx, vx, col, R, C, V)   # -gamma
    for i in range(m):
        g[i] += col[i]
    z = np.linalg.lstsq(S, g, 1e-13)[0]
    _minus_correction(I, Fl, qx, z, y)
    for j in range(n):
        out[j] = a[j] - y[j]


@_jit
def _error_norm(rc, n, q, qx, a_new, a, b, b_new, additive, acc_old, acc_new, rtol, atol, h,
                index1, d):
    """The error per unit step of a step of size h [s]: the weighted RMS norm
    of its local error estimate e = err d (``adaptive``: Hairer, Norsett &
    Wanner I, sec. II.4) over h / (1 s): d the change of the
    auxiliary acceleration b -> b_new when the recipe's ``eaux``, of HHT-ADD's
    a + R_II or of an index-3 recipe's index-1 acceleration when
    ``index1`` (acc_old -> acc_new), acc_new itself when ``eabs`` and
    ``index1``, a_new when ``eabs``, else a -> a_new; each entry over
    atol + rtol max(|q|, |q_new|), an entry's tolerance for the step never
    below the estimate's round-off, err / h^2 ulps of max(|q|, |q_new|)
    (``StepControl.norm``). d (n,): scratch."""
    if n == 0:
        return 0.0
    for j in range(n):
        if index1:
            d[j] = acc_new[j] if rc[EABS] != 0.0 else acc_new[j] - acc_old[j]
        elif rc[EAUX] != 0.0:
            d[j] = b_new[j] - b[j]
        elif additive:
            d[j] = acc_new[j] - acc_old[j]
        elif rc[EABS] != 0.0:
            d[j] = a_new[j]
        else:
            d[j] = a_new[j] - a[j]
    acc = 0.0
    noise = abs(rc[ERR]) / (h * h) * EPS       # the estimate's round-off per unit of |q|
    for j in range(n):
        size = max(abs(q[j]), abs(qx[j]))
        e = rc[ERR] * d[j] / max((atol + rtol * size) * h, noise * size)
        acc += e * e
    return math.sqrt(acc / n)


@_jit
def step_end(h, t, t_end, carry):
    """The next step of the time loop from t [s] towards t_end [s], of size h
    [s] at most: (step [s], its end time t_new [s], the new carry). The
    last step lands on t_end exactly and never leaves a sliver (under 1e-6
    of a step) before it; t_new is a compensated (Kahan) sum with
    ``carry``, the rounding error of the sum so far, so that t stays exact
    to round-off over 1e6 steps. Both steppers' rule (``_run``,
    ``loop.PythonStepper``)."""
    step = min(h, t_end - t)
    if t_end - (t + step) < 1e-6 * step:
        step = t_end - t
    if step == t_end - t:
        return step, t_end, 0.0
    y = step - carry
    t_new = t + y
    return step, t_new, (t_new - t) - y


@_jit
def _run(mono, I, Fl, h, t0, t_end, step0, every, q, v, a, b, lam, mu, q_prev, v_prev,
         ctl, opts, solver, lin, lu_state, R, C, V, out_t, out_h, out_q, out_v, out_a,
         out_lam, out_mu, out_stats, counts, F0, state, trial):
    """The compiled time loop: steps of every method, fixed or error-controlled,
    from (t0, q, v, a, b, lam, mu) towards t_end, until t_end, a step that
    fails, an event, or the out_* arrays are full.

    ``mu`` (m,) holds the method's extra multipliers (mu, or HHT-ADD's
    psi_I), ``b`` (n,) the auxiliary acceleration of the recipes that carry
    one (generalized-alpha). The state arrays are updated in place after
    every accepted step, so that they hold the last accepted state when
    the loop returns.

    ``mono`` (2, 5, len(RECIPE_FIELDS)): the recipe's monomials for a
    start-up step and the steps after it (``engine.recipe_monomials``); a
    recipe that reads c0, w0, w1 (BDF2) takes them from the ratio
    w = h / h_prev of this step to the last one, c0 = (1 + 2w)/((1 + w) h),
    w0 = (1 + w)^2/(1 + 2w), w1 = -w^2/(1 + 2w), and its start-up
    coefficients (BDF1: 1/h, 1, 0) while there is no last step;
    ``q_prev``, ``v_prev`` the state before (q, v). The recipe is evaluated
    again only when h or these coefficients change. ``lu_state`` (4,) =
    (factorization valid, contraction rate (``_newton``), the step h and c0
    it was made for): a step of another h or c0 takes a new Newton matrix.

    ``ctl`` = (rtol, atol, safety, min_factor, max_factor, h_min, h_max,
    fixed). Error control (fixed = 0): after each converged step the local
    error estimate e = err (x - x_n) (on b when ``eaux``; err x when
    ``eabs``; HHT-ADD's the change of a + R_II) is measured per unit step,
    E = ||e||_RMS,w / (h / 1 s) (``_error_norm``); E > 1 rejects the step
    (retried with h max(min_factor, safety E^(-1/2))), else it is accepted
    and the next h follows the H211b filter (``step_ratio``; not growing
    right after a rejection); a step Newton cannot converge is not halved
    here. Fixed steps (fixed = 1): steps of h, the last one
    shortened to land on t_end; no error estimate. Either way a step Newton
    cannot converge ends the call at once (its Newton status, with the
    step's size in state[1]): halving, the augmented formulation's jump and
    any hand-over are the time loop's (``loop.TimeLoop``, ``loop.StepSizes``;
    this loop is its ``engine.KernelStepper``).

    Every ``every``-th accepted step (global number step0 + k) and the last
    one are recorded in the out_* arrays with their step size in out_h and
    the Newton counts summed since the previous record (out_stats columns:
    iterations, residuals, jacobians, factorizations, stalled steps,
    steps); ``counts`` (6,) carries those sums between records and calls.
    R, C, V are triplet buffers of ``triplet_bound(md)`` entries. ``F0``
    (n,): F_n at t0 when F0[0] is not NaN (a start whose forces are not the
    law's at (q, v, lambda): friction's Coulomb limit, ``InitialState.Q``).

    ``state`` (10,) in/out: (t, h of the next step, rejected steps, h of the
    last step or 0, mode, the compensation of the sum t, 1 when the last
    attempt was rejected (the next accepted step does not grow h), the
    number of accepted steps this call may take or 0 for no limit, the last
    accepted step's error per unit step E or 0 (none: the step-size filter
    restarts), the step ratio chosen after it).
    Returns (status, steps, records): CONVERGED, a Newton status (a step
    that does not converge), TOLERANCE (the error above 1 at h_min), EVENT
    or REJECTED below.

    Events: a converged step that changes the sign of a gap of the contacts
    and joint limits (KGI), or across which the points of a spring-damper
    with a free length pass each other, is not taken; the loop returns EVENT
    with its end (q, v) in ``trial`` (2, n) and its size in state[1], for
    the time loop to land a step on the event (``events.EventLocator``).
    Mode (state[4]) RUN goes on until t_end, an event, a failure or a full
    output; ATTEMPT and LAND make one attempt at a step of h (with error
    control halved while Newton fails) and return: EVENT (ATTEMPT only),
    REJECTED (its error estimate: the next h in state[1]) or CONVERGED with
    the step taken; LAND takes a step across an event."""
    n, m = _rows(I, MASS), _rows(I, ROW_ELEMENT)
    rc = np.empty(mono.shape[2])
    _recipe_at(mono[1], 1.0, 1.0, 1.0, 1.0, rc)
    size, l0, e0, a0 = _layout(rc, n, m)
    two_step = False                    # a recipe reading c0, w0, w1
    for i in range(mono.shape[2]):
        two_step = two_step or mono[1, 2, i] != 0.0 or mono[1, 3, i] != 0.0 \
            or mono[1, 4, i] != 0.0
    has_extra = e0 < size
    rtol, atol, safety, fmin, fmax, h_min, h_max = (ctl[0], ctl[1], ctl[2], ctl[3], ctl[4],
                                                    ctl[5], ctl[6])
    fixed = ctl[7] != 0.0
    r, dw, w, weight, qx, vx, work, q_pred, v_pred, qx_old, F, scratch = _workspace(n, m, size, I)
    b_new, d_err = np.empty(n), np.empty(n)
    # an index-3 recipe (no velocity constraints, not additive) takes its error estimate
    # on its index-1 accelerations: the normal part of its own is the multipliers'
    # round-off over beta h^2, which a tolerance per unit step would chase; not where
    # friction reads the multipliers (their oscillation then moves q: the estimate sees it)
    index1 = (not fixed and ctl[8] != 0.0 and rc[FORM] != ADDITIVE and not has_extra
              and 0 < m <= INDEX1_LIMIT and _rows(I, FRI) == 0)
    mode = int(state[4])
    gaps = _rows(I, KGI) > 0 and mode != LAND
    springs = False                     # spring-dampers with a free length
    for i in range(_rows(I, SCOL1)):
        springs = springs or (_f(I, Fl, SPAR, i, 2) > 0.0 and mode != LAND)
    qs, grad6, H6 = np.zeros(n + 3), np.empty(6), np.empty((6, 6))
    additive = rc[FORM] == ADDITIVE
    acc_old, acc_new = np.empty(n), np.empty(n)     # the additive form's a + R_II
    if additive and not fixed:                      # at the last accepted state, then carried
        qx_old[:n] = q
        _total_acceleration(I, Fl, n, qx_old, a, lam, R, C, V, acc_old)
    k1 = m if index1 else 0                         # the index-1 acceleration's scratch
    S1, col1, g1, y1 = np.empty((k1, k1)), np.empty(k1), np.empty(k1), np.empty(n + 3)
    if index1:
        qx_old[:n] = q
        vx[:n] = v
        _index1_acceleration(I, Fl, n, m, t0, qx_old, vx, a, acc_old, R, C, V, S1, col1, g1,
                             y1)
    _start_force(rc, I, Fl, t0, q, v, lam, F0, F, qx, vx, work)
    t = t0
    # the step, start-up flag and c0, w0, w1 of the recipe in rc
    h_rc, first_rc, c0_rc, w0_rc, w1_rc = -1.0, False, -1.0, -1.0, -1.0
    after_rejection = state[6] != 0.0     # the last attempt, before this call, was rejected
    limit = int(state[7])                 # accepted steps this call may take (0: no limit)
    rec = 0
    k = 0
    while t < t_end - 1e-12 * (t_end - t0) and rec < out_t.shape[0]:
        step, t_new, carry = step_end(h, t, t_end, state[5])
        first = two_step and state[3] == 0.0
        c0, w0, w1 = _bdf_ratio(two_step, step, state[3])
        if step != h_rc or first != first_rc or c0 != c0_rc or w0 != w0_rc or w1 != w1_rc:
            _recipe_at(mono[0] if first else mono[1], step, c0, w0, w1, rc)
            h_rc, first_rc, c0_rc, w0_rc, w1_rc = step, first, c0, w0, w1
        if step != lu_state[2] or c0 != lu_state[3]:    # the Newton matrix depends on them
            lu_state[0] = 0.0
            lu_state[2], lu_state[3] = step, c0
        predict(rc, first, q, v, a, b, q_prev, v_prev, q_pred, v_pred)
        _start_w(rc, I, Fl, q, a, v, lam, w, qx, work)
        for j in range(n):                 # q_n (the additive form), or Mhat's q_n + mh v_n
            qx_old[j] = q[j] + rc[MH] * v[j]
        _scales_weights(rc, I, Fl, q, w, opts, R, C, V, qx, weight, scratch)
        status = _newton(rc, I, Fl, t_new, q_pred, v_pred, F, qx_old, w, weight, opts, solver,
                         lin, lu_state, R, C, V, r, dw, qx, vx, work, counts,
                         scratch[scratch.shape[0] - 2 * size:])
        if status != CONVERGED:       # the driver decides: halve, jump, or hand over
            state[0], state[1] = t, step
            state[6] = 1.0 if after_rejection else 0.0
            return status, k, rec
        _state(rc, n, w, q_pred, v_pred, qx, vx)
        # an event within the step: the caller lands a step on it
        if (gaps or springs) and _crossed(I, Fl, n, q, qx, gaps, springs, qs, grad6, H6):
                trial[0, :] = qx[:n]
                trial[1, :] = vx[:n]
                state[0], state[1] = t, step
                return EVENT, k, rec
        # the local error estimate and its weighted RMS norm
        if rc[EAUX] != 0.0:
            b_new[:] = b
            _advance(rc, b_new, a, w[a0:a0 + n])
        err, factor = 0.0, fmax
        if not fixed:
            if additive:    # HHT-ADD: the change of a + R_II, which sees the constraint forces
                _total_acceleration(I, Fl, n, qx, w[a0:a0 + n], w[l0:l0 + m], R, C, V, acc_new)
            elif index1:
                _index1_acceleration(I, Fl, n, m, t_new, qx, vx, w[a0:a0 + n], acc_new, R, C, V,
                                     S1, col1, g1, y1)
            err = _error_norm(rc, n, q, qx, w[a0:a0 + n], a, b, b_new, additive, acc_old,
                              acc_new, rtol, atol, step, index1, d_err)
            if err > 1.0 or after_rejection:        # the filter restarts after a rejection
                state[8] = 0.0
            factor = step_ratio(err, state[8], state[9], safety, fmin, fmax)
        if err > 1.0:
            if step <= h_min * (1.0 + 1e-9):
                state[0], state[1] = t, step
                return TOLERANCE, k, rec
            state[2] += 1.0
            h = max(step * min(factor, 1.0), h_min)
            after_rejection = True
            if mode != RUN:
                state[0], state[1], state[6] = t, h, 1.0
                return REJECTED, k, rec
            continue
        if after_rejection:
            factor = min(factor, 1.0)
        after_rejection = False
        if not fixed:
            state[8], state[9] = err, factor
        q_prev[:] = q
        v_prev[:] = v
        state[3] = step
        q[:] = qx[:n]
        v[:] = vx[:n]
        if rc[EAUX] != 0.0:
            b[:] = b_new
        else:
            _advance(rc, b, a, w[a0:a0 + n])
        if additive or index1:
            acc_old[:] = acc_new
        a[:] = w[a0:a0 + n]
        lam[:] = w[l0:l0 + m]
        if has_extra:
            mu[:] = w[e0:e0 + m]
        t = t_new
        state[5] = carry
        if rc[CF] != 0.0:                  # F_n enters the next residual only through cF
            _old_force(rc, I, Fl, t, q, v, lam, F, qx, vx, work)
        counts[5] += 1
        k += 1
        if not fixed:
            # a step shortened to land on t_end (a segment's end: a switch of a function
            # of time) leaves the size planned before it for the next stretch
            h = max(min(step * factor, h_max), h if t >= t_end - 1e-12 * (t_end - t0) else 0.0)
        if (step0 + k) % every == 0 or t >= t_end - 1e-12 * (t_end - t0):
            out_h[rec] = step
            rec = _record(rec, t, q, v, a, lam, mu, counts, out_t, out_q, out_v, out_a, out_lam,
                          out_mu, out_stats)
        if mode != RUN or k == limit:
            break
    state[0], state[1], state[6] = t, h, 1.0 if after_rejection else 0.0
    return CONVERGED, k, rec


# --------------------------------------------------------------------------------------------
# Packing, and the public entry points on the packed model data
#
# Numba checks the type of every argument on each call (about 0.3 us per
# array), and inside the kernels every bound array costs reference-count
# updates (see "Named access" above): the model data cross the boundary, and
# every kernel call, as two flat arrays (integers, floats) with a header of
# offsets and shapes, laid out by MODEL_SCHEMA.
# --------------------------------------------------------------------------------------------

_HEADER = 3 * len(MODEL_FIELDS) + 1


def pack(fields: dict):
    """(ints, floats): the model data of ``fields`` (name -> array as
    MODEL_SCHEMA declares it, and "n_elements" -> int) as two flat arrays,
    header first in ``ints``.

    Raises
    ------
    ValueError
        A field whose columns differ from the schema's.
    """
    ints = [np.zeros(_HEADER, np.int64)]
    floats = []
    ni, nf = _HEADER, 0
    header = ints[0]
    header[-1] = int(fields["n_elements"])
    for k, (name, kind, columns) in enumerate(MODEL_SCHEMA):
        x = np.asarray(fields[name])
        if (x.ndim == 1) != (columns == 0) or (columns and x.shape[1] != columns):
            raise ValueError(f"model data field {name!r}: shape {x.shape}, schema columns {columns}")
        rows, cols = x.shape[0], max(columns, 1)
        if kind == "i":
            header[3 * k:3 * k + 3] = (ni, rows, cols)
            ints.append(x.astype(np.int64).ravel())
            ni += x.size
        else:
            header[3 * k:3 * k + 3] = (nf, rows, cols)
            floats.append(x.astype(np.float64).ravel())
            nf += x.size
    return np.concatenate(ints), (np.concatenate(floats) if floats else np.zeros(0))


def unpack(I, Fl) -> dict:
    """The packed model data as {field: array view} (MODEL_SCHEMA's shapes),
    and "n_elements": for tests and debugging; the kernels read the packed
    arrays through ``_i`` and ``_f``."""
    out = {"n_elements": int(I[_HEADER - 1])}
    for k, (name, kind, columns) in enumerate(MODEL_SCHEMA):
        o, r, c = (int(x) for x in I[3 * k:3 * k + 3])
        x = (I if kind == "i" else Fl)[o:o + r * c]
        out[name] = x if columns == 0 else x.reshape(r, c)
    return out


@_jit
def residual(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, r, qx, vx, work):
    """Upsilon(w) of recipe ``rec`` into r; see ``_residual``. Returns False
    when r is not finite."""
    _residual(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, r, qx, vx, work)
    for x in r:
        if not np.isfinite(x):
            return False
    return True


@_jit
def jacobian_triplets(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, R, C, V, qx, vx):
    """Newton-matrix triplets; see ``_jacobian_triplets``. Returns their count."""
    return _jacobian_triplets(rec, I, Fl, t, q_pred, v_pred, F_old, qx_old, w, R, C, V, qx, vx)


@_jit
def old_force(rec, I, Fl, t, q, v, lam, out, qx, vx, work):
    """F_n of the recipe into out (n,); see ``_old_force``."""
    _old_force(rec, I, Fl, t, q, v, lam, out, qx, vx, work)


@_jit
def force_term(I, Fl, t, q, v, lam, out, qx, vx, work):
    """Phi_q^T lambda - Q(q, v) into out (n,)."""
    _force_term(I, Fl, t, q, v, lam, out, qx, vx, work)


@_jit
def index1_multipliers(I, Fl, t, q, v, out, R, C, V, iterations):
    """Entry point of ``_index1_multipliers``."""
    _index1_multipliers(I, Fl, t, q, v, out, R, C, V, iterations)


@_jit
def index1_multipliers_band(I, Fl, t, q, v, out, R, C, V, iterations, order, kd, addr):
    """Entry point of ``_index1_multipliers_band``."""
    _index1_multipliers_band(I, Fl, t, q, v, out, R, C, V, iterations, order, kd, addr)


@_jit
def mobility(I, Fl, q, out, R, C, V, qx):
    """Multiplier mobility per constraint row into out (m,)."""
    _mobility(I, Fl, q, out, R, C, V, qx, np.empty(I[_HEADER - 1]))


@_jit
def run(mono, I, Fl, h, t0, t_end, step0, every, q, v, a, b, lam, mu, q_prev, v_prev,
        ctl, opts, solver, lin, lu_state, R, C, V, out_t, out_h, out_q, out_v, out_a,
        out_lam, out_mu, out_stats, counts, F0, state, trial):
    """The compiled time loop; see ``_run``."""
    return _run(mono, I, Fl, h, t0, t_end, step0, every, q, v, a, b, lam, mu, q_prev,
                v_prev, ctl, opts, solver, lin, lu_state, R, C, V, out_t, out_h, out_q,
                out_v, out_a, out_lam, out_mu, out_stats, counts, F0, state, trial)
