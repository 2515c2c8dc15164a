"""Tables: a quantity given by measured or listed points, y(x), as a
piecewise cubic polynomial (linear: its cubic and quadratic terms zero).

The coefficients come from scipy's interpolators at check time (``cubic``:
``CubicSpline``, not-a-knot; ``pchip``: ``PchipInterpolator``, Fritsch and
Carlson's monotone cubic; ``akima``: ``Akima1DInterpolator``); ``linear`` joins
the points by straight lines. Outside the points a table holds its end value
(``hold``: its derivatives zero), continues along its end slope (``linear``)
or has no value (``error``: NaN, which stops a run with a message naming the
table). The kernels evaluate the same polynomials and their derivatives
(``kernels.programs``), so Newton's matrix has the exact slope.
"""

from __future__ import annotations

import hashlib
import math

import numpy as np

__all__ = ["Table", "INTERPOLATIONS", "EXTRAPOLATIONS", "build_table"]

INTERPOLATIONS = ("linear", "pchip", "cubic", "akima")
#: Extrapolation modes, by their code in the kernels' table rows.
EXTRAPOLATIONS = ("hold", "linear", "error")


class Table:
    """y(x) on breakpoints x_0 < ... < x_k: on [x_i, x_i+1], with s = x - x_i,
    y = c0 s^3 + c1 s^2 + c2 s + c3 (scipy's ``PPoly`` layout).

    Parameters
    ----------
    name : str
    x : ndarray, shape (k + 1,)
        Breakpoints, increasing [the argument's SI unit].
    c : ndarray, shape (4, k)
        Coefficients per interval, highest power first.
    interpolation, extrapolation : str
        As declared (:data:`INTERPOLATIONS`, :data:`EXTRAPOLATIONS`).
    source : str
        Where the points came from: a file's path, or ``"inline"``.
    digest : str
        sha256 of the points as read (the file's bytes, or the inline values).
    """

    def __init__(self, name, x, c, interpolation, extrapolation, source="inline", digest=""):
        self.name = name
        self.x = np.ascontiguousarray(x, dtype=np.float64)
        self.c = np.ascontiguousarray(c, dtype=np.float64).reshape(4, len(self.x) - 1)
        self.interpolation, self.extrapolation = interpolation, extrapolation
        self.source, self.digest = source, digest

    def __repr__(self) -> str:
        return f"Table({self.name})"

    @property
    def kinked(self) -> bool:
        """Whether the interpolant's slope jumps at its breakpoints (linear)."""
        return self.interpolation == "linear" and len(self.x) > 2

    def value(self, u: float, order: int = 0) -> float:
        """The order-th derivative of y at u (order 0..3); NaN outside the
        points with ``error`` extrapolation, or for a NaN argument."""
        x = self.x
        u = float(u)
        if not u == u:
            return math.nan
        if u < x[0] or u > x[-1]:
            if self.extrapolation == "error":
                return math.nan
            i, s = (0, 0.0) if u < x[0] else (len(x) - 2, x[-1] - x[-2])
            y = self._poly(i, s, 0)
            if self.extrapolation == "hold":
                return y if order == 0 else 0.0
            slope = self._poly(i, s, 1)
            d = u - (x[0] if u < x[0] else x[-1])
            return y + slope * d if order == 0 else (slope if order == 1 else 0.0)
        i = min(max(int(np.searchsorted(x, u, side="right")) - 1, 0), len(x) - 2)
        return self._poly(i, u - x[i], order)

    def _poly(self, i, s, order) -> float:
        """The order-th derivative of interval i's cubic at s = x - x_i."""
        return float(self._polys(i, float(s), order))

    def values(self, u, order: int = 0) -> np.ndarray:
        """:meth:`value` over an array of arguments (vectorised: the same
        interval choice and Horner form, so the same numbers)."""
        u = np.asarray(u, dtype=float)
        x, k = self.x, len(self.x) - 1
        flat = u.ravel()
        inside = (flat >= x[0]) & (flat <= x[-1])
        i = np.clip(np.searchsorted(x, flat, side="right") - 1, 0, k - 1)
        s = np.where(inside, flat - x[i], 0.0)
        out = self._polys(i, s, order)
        outside = ~inside & ~np.isnan(flat)
        if outside.any():
            out[outside] = [self.value(v, order) for v in flat[outside]]
        out[np.isnan(flat)] = np.nan
        return out.reshape(u.shape)

    def _polys(self, i, s, order) -> np.ndarray:
        """:meth:`_poly` over arrays of intervals and offsets."""
        c0, c1, c2, c3 = self.c[:, i]
        if order == 0:
            return ((c0 * s + c1) * s + c2) * s + c3
        if order == 1:
            return (3.0 * c0 * s + 2.0 * c1) * s + c2
        if order == 2:
            return 6.0 * c0 * s + 2.0 * c1
        return 6.0 * c0 if order == 3 else np.zeros_like(s)

    def switches(self):
        """A table of the same argument whose sign changes at each point
        where this one's slope jumps (every breakpoint of a linear table;
        the two ends of a table that holds its end values), and nowhere
        else; None where there are none. For landing steps on them."""
        if self.interpolation == "linear" and self.extrapolation != "error":
            x = self.x
        elif self.extrapolation == "hold":
            x = self.x[[0, -1]]
        else:
            return None
        k = len(x) - 1
        lengths = np.diff(x)
        sign = (-1.0) ** np.arange(k)
        # (-1)^i (u - x_i)(x_i+1 - u) / l_i on [x_i, x_i+1], continued by its end slopes
        c = np.vstack([np.zeros(k), -sign / lengths, sign, np.zeros(k)])
        return Table(f"{self.name} switches", x, c, "cubic", "linear")


def build_table(name, x, y, interpolation="linear", extrapolation="hold", source="inline",
                digest=""):
    """A :class:`Table` through the points (x_i, y_i) [SI].

    Raises
    ------
    ValueError
        Fewer than two points, x not strictly increasing, a non-finite
        value, or an unknown interpolation or extrapolation (the message
        says which).
    """
    from scipy.interpolate import Akima1DInterpolator, CubicSpline, PchipInterpolator
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if interpolation not in INTERPOLATIONS:
        raise ValueError(f"unknown interpolation '{interpolation}'; use "
                         f"{', '.join(INTERPOLATIONS)}")
    if extrapolation not in EXTRAPOLATIONS:
        raise ValueError(f"unknown extrapolation '{extrapolation}'; use "
                         f"{', '.join(EXTRAPOLATIONS)}")
    if len(x) < 2:
        raise ValueError(f"a table needs at least two points, got {len(x)}")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise ValueError("a table's values must be finite numbers")
    bad = np.flatnonzero(np.diff(x) <= 0.0)
    if bad.size:
        raise ValueError(f"the table's x must increase: point {bad[0] + 2} "
                         f"({x[bad[0] + 1]:g}) follows {x[bad[0]]:g}")
    if interpolation == "linear" or len(x) == 2:
        k = len(x) - 1
        c = np.vstack([np.zeros(k), np.zeros(k), np.diff(y) / np.diff(x), y[:-1]])
    else:
        if interpolation == "cubic" and len(x) == 3:
            spline = CubicSpline(x, y, bc_type="natural")
        else:
            spline = {"cubic": CubicSpline, "pchip": PchipInterpolator,
                      "akima": Akima1DInterpolator}[interpolation](x, y)
        c = np.asarray(spline.c, dtype=float)
    if not digest:
        digest = hashlib.sha256(np.concatenate([x, y]).tobytes()).hexdigest()
    return Table(name, x, c, interpolation, extrapolation, source, digest)
