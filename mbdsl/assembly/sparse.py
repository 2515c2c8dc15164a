"""Newton matrices from fixed sparsity patterns: dense or sparse, one code path.

The system exposes every matrix term (M, Phi_q, (Phi_q^T lambda)_q,
(Phi_q v)_q, Q_q, Q_v) as values on a coordinate (COO) pattern fixed when the
model is built. A method lists the terms of its Newton matrix with their
block offsets and coefficients; :class:`JacobianAssembler` sums them into a
dense array (small models, LAPACK LU) or a CSC matrix (large models, SuperLU).
The COO -> CSC map is computed once per run: each later assembly is one
``np.bincount`` refilling the values of a fixed pattern.
"""

from __future__ import annotations

import sys

import numpy as np
import scipy

__all__ = ["Term", "JacobianAssembler", "DENSE_LIMIT", "issparse"]

#: Newton matrices of at most this many rows are dense by default. Measured on
#: pendulum chains: dense LU wins below about 300 unknowns, SuperLU above.
DENSE_LIMIT = 300


def issparse(J) -> bool:
    """``scipy.sparse.issparse(J)`` without importing scipy.sparse (about
    0.1 s of start-up) when no sparse matrix can exist yet."""
    module = sys.modules.get("scipy.sparse")
    return module is not None and module.issparse(J)


class Term:
    """One block term of a Newton matrix: coefficient * values on a pattern.

    Parameters
    ----------
    rows, cols : ndarray of int
        Pattern in the block's own coordinates (fixed for a model).
    vals : ndarray of float
        Values on the pattern (same length).
    row0, col0 : int
        Block offsets in the Newton matrix.
    coef : float
    transpose : bool
        Place the transposed block (e.g. Phi_q^T from Phi_q's pattern).
    """

    __slots__ = ("rows", "cols", "vals")

    def __init__(self, rows, cols, vals, row0=0, col0=0, coef=1.0, transpose=False):
        if transpose:
            rows, cols = cols, rows
        self.rows = rows + row0
        self.cols = cols + col0
        self.vals = vals * coef if coef != 1.0 else vals


class JacobianAssembler:
    """Sums :class:`Term` lists into an (N, N) matrix with a cached pattern.

    Parameters
    ----------
    size : int
        N, the number of unknowns.
    sparse : bool
        CSC matrix (for scipy.sparse.linalg.splu) or dense ndarray.
    """

    def __init__(self, size: int, sparse: bool):
        self.size, self.sparse = int(size), bool(sparse)
        self._nnz = None

    def _pattern(self, rows, cols):
        N = self.size
        if self.sparse:
            key = cols.astype(np.int64) * N + rows          # column-major: CSC order
            uniq, self._inverse = np.unique(key, return_inverse=True)
            self._indices = (uniq % N).astype(np.int32)
            counts = np.bincount((uniq // N).astype(np.int64), minlength=N)
            self._indptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int32)
            self._nuniq = len(uniq)
        else:
            self._flat = rows.astype(np.int64) * N + cols
        self._nnz = len(rows)

    def assemble(self, terms):
        """The Newton matrix: dense ndarray or scipy.sparse.csc_matrix, shape (N, N)."""
        rows = np.concatenate([t.rows for t in terms])
        vals = np.concatenate([t.vals for t in terms])
        if self._nnz != len(rows):       # first call (patterns are fixed afterwards)
            self._pattern(rows, np.concatenate([t.cols for t in terms]))
        N = self.size
        if self.sparse:
            data = np.bincount(self._inverse, weights=vals, minlength=self._nuniq)
            return scipy.sparse.csc_matrix((data, self._indices, self._indptr), shape=(N, N))
        return np.bincount(self._flat, weights=vals, minlength=N * N).reshape(N, N)
