"""The packed model data: the fields every kernel reads, and their named access.

The model data cross every kernel call as two flat arrays (integers ``I``,
floats ``Fl``) with a header of (offset, rows, columns) per field of
:data:`MODEL_SCHEMA`, built by :func:`pack` and read through the scalar
accessors :func:`_i`, :func:`_f` and :func:`_rows`, which numba inlines.
Body columns index the extended coordinate vector q_ext = [q, 0, 0, 0], the
trailing three being the ground's, never written to a matrix.
"""

from __future__ import annotations

import numpy as np

from .jit import _hot, _inline, _jit  # noqa: F401  (the kernels import them from here)

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
    ("kgi", "i", 2), ("kcol", "i", 24),                                # contact gaps: kind, line row;
    ("kpar", "f", 15), ("kimp", "f", 0),                               # columns; data, law; impact speed
    ("sel", "i", 4), ("fel", "i", 2),                                  # elastic terms of spring and
    ("dsp", "i", 4),                                                   # point-force points, distance
                                                                       # joints' points: spans
    ("xtrm", "i", 2), ("xtc", "f", 0),                                 # couplers: terms (row, var),
    ("xrow", "i", 0), ("xoff", "f", 0),                                # coefficients; rows, c
    ("fdv", "i", 4),                                                   # point forces of the state:
                                                                       # (force, component, var, dF/dx)
    ("tbl", "i", 3), ("tbd", "f", 0),                                  # tables: (offset, intervals,
                                                                       # extrapolation); x, then c
    ("zcol", "i", 0),                                                  # first-order states' columns
    ("swp", "i", 2),                                                   # kinks of tables of the state:
                                                                       # (u's program, kinks' table)
    ("vrow", "i", 0), ("vcol", "i", 4), ("vw", "f", 16), ("vc", "f", 7),  # spatial dot rows
    ("wcol", "i", 2), ("ws", "f", 8), ("w0", "f", 3), ("wpar", "f", 3),   # spatial springs
    ("ycol", "i", 2), ("ypar", "f", 6), ("yfn", "i", 3),               # spatial forces, torques
    ("vfn", "i", 3),                                                   # spatial dot rows: f, f', f''
    ("arow", "i", 0), ("acol", "i", 2), ("av", "f", 9), ("afn", "i", 3),  # spatial joint angles
    ("hcol", "i", 2), ("hv", "f", 9), ("hpar", "f", 3),                # spatial rotational springs
    ("kbody", "i", 2), ("kgeo", "f", 22),                              # spatial gaps: bodies, geometry
    ("frow", "i", 0),                                                  # spatial bodies' frame rows
    ("vtn", "i", 2), ("vtc", "i", 16), ("vtw", "f", 16),               # spatial dot rows' terms
)
#: The fields no element family owns: the mass diagonal, the constant forces (gravity),
#: the constraint rows' elements, the rigid bodies' mass diagonal, the columns of
#: the first-order states (``model.elements.FirstOrderState``) and the spatial bodies'
#: frame rows (``model.spatial.Frame``: Newton's test of orthonormality).
FIELDS = ("mass", "Q0", "row_element", "mrig", "zcol", "frow")
#: The field names, and the scalar "n_elements" (the header's last entry).
MODEL_FIELDS = tuple(name for name, _, _ in MODEL_SCHEMA) + ("n_elements",)

ROUNDOFF_BAND = 1e3        # as in newton.py
FRAME_TOL = 1e-12          # as in newton.py (the bound; FRAME_HOLD, the read iterate's)
FRAME_HOLD = 0.5e-12       # as in newton.py
EPS = 2.220446049250313e-16


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
 ESHP, KGI, KCOL, KPAR, KIMP, SEL, FEL, DSP, XTRM, XTC, XROW, XOFF, FDV, TBL, TBD,
 ZCOL, SWP, VROW, VCOL, VW, VC, WCOL, WS, W0, WPAR, YCOL, YPAR, YFN, VFN,
 AROW, ACOL, AV, AFN, HCOL, HV, HPAR, KBODY, KGEO, FROW, VTN, VTC, VTW) = range(103)
if any(globals()[name.upper()] != k for k, (name, _, _) in enumerate(MODEL_SCHEMA)):
    raise ImportError("schema.py's field indices differ from MODEL_SCHEMA")   # pragma: no cover


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


# --------------------------------------------------------------------------------------------
# Matrix blocks as (row, column, value) triplets in a fixed order
# --------------------------------------------------------------------------------------------


@_jit
def _put(R, C, V, p, r, c, v):
    """Triplet p := (r, c, v); returns p + 1."""
    R[p] = r
    C[p] = c
    V[p] = v
    return p + 1


@_inline
def _put_phiq(R, C, V, p, r0, c0, row, col, v, transpose):
    """The Phi_q entry (row, col) = v at (r0, c0), or at (r0 + col, c0 + row) when
    ``transpose`` (the Phi_q^T block of a saddle-point matrix); returns p + 1."""
    if transpose:
        return _put(R, C, V, p, r0 + col, c0 + row, v)
    return _put(R, C, V, p, r0 + row, c0 + col, v)


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
