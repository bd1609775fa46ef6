"""B-splines for the walkers' paths: least-squares fits, interpolation and derivatives.

The walkers' positions, bob and heading are quintic splines sampled at the simulation rate
(``sim/walkers.py``). ``scipy.interpolate`` computes the same splines, but importing it pulls in
``scipy.optimize``, ``scipy.spatial`` and ``scipy.fft`` (0.1-0.3 s of every ``trackroom generate``'s
start-up, issue 14), and its evaluation handles one derivative per call. This module holds just
what the walkers need, on numpy and LAPACK's banded solvers (``scipy.linalg``, which the other
scipy modules of the command line import anyway):

- :func:`lsq_spline`: the least-squares spline on given knots, by the banded normal equations
  (``scipy.interpolate.make_lsq_spline(..., method="norm-eq")``);
- :func:`interp_spline`: the interpolating spline with scipy's default "not-a-knot" knots
  (``make_interp_spline(x, y, k)``);
- :class:`Spline`: evaluation and derivatives (``BSpline.__call__(x, nu)``).

Both agree with scipy to rounding (tested against it); the recordings' values therefore differ
from those of scipy's splines only in the last bits.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import solve_banded, solveh_banded
from scipy.sparse import csr_matrix


@dataclass(frozen=True)
class Spline:
    """A spline of degree ``k`` on knots ``t`` with coefficients ``c`` (n, ...) (first axis:
    the basis functions; the other axes are independent components)."""

    t: np.ndarray
    c: np.ndarray
    k: int

    def __call__(self, x, nu: int = 0) -> np.ndarray:
        """The ``nu``-th derivative at the points ``x`` (1-D); outside [t[k], t[-k-1]] the end
        pieces' polynomials are extended, as scipy's ``extrapolate=True``."""
        t, c, k = self.t, self.c, self.k
        if not 0 <= nu:
            raise ValueError(f"derivative order must be >= 0, got {nu}")
        if nu > k:
            return np.zeros((len(x),) + c.shape[1:])
        for _ in range(nu):  # the derivative of a spline is a spline of one degree less
            w = (t[k + 1 : k + 1 + len(c) - 1] - t[1 : len(c)]).reshape((-1,) + (1,) * (c.ndim - 1))
            c = k * (c[1:] - c[:-1]) / np.where(w > 0, w, 1.0)
            t, k = t[1:-1], k - 1
        x = np.asarray(x, float)
        return (_design(t, k, x) @ c.reshape(len(c), -1)).reshape((len(x),) + c.shape[1:])


def _spans(t: np.ndarray, k: int, x: np.ndarray) -> np.ndarray:
    """Index i of the knot interval t[i] <= x < t[i + 1] holding each x, within [k, n - 1]."""
    n = len(t) - k - 1
    return np.clip(np.searchsorted(t, x, side="right") - 1, k, n - 1)


def _basis(t: np.ndarray, k: int, x: np.ndarray) -> tuple[np.ndarray, list]:
    """The k + 1 B-splines of degree k that are nonzero at each x (Cox-de Boor, as in Piegl &
    Tiller's BasisFuns, vectorised over x): span indices (m,) and k + 1 value arrays (m,),
    where number r is the basis function number span - k + r."""
    i = _spans(t, k, x)
    basis = [np.ones(len(x))]
    left = [None] + [x - t[i + 1 - j] for j in range(1, k + 1)]
    right = [None] + [t[i + j] - x for j in range(1, k + 1)]
    for j in range(1, k + 1):
        saved = None
        nxt = []
        for r in range(j):
            temp = basis[r] / (right[r + 1] + left[j - r])
            val = right[r + 1] * temp
            nxt.append(val if saved is None else val + saved)
            saved = left[j - r] * temp
        nxt.append(saved)
        basis = nxt
    return i, basis


def _design(t: np.ndarray, k: int, x: np.ndarray) -> csr_matrix:
    """The sparse design matrix B (m, n): B[j, i] = B_i(x[j]), k + 1 nonzeros per row."""
    span, basis = _basis(t, k, x)
    m = len(x)
    data = np.empty((m, k + 1))
    for r in range(k + 1):
        data[:, r] = basis[r]
    cols = (span - k)[:, None] + np.arange(k + 1)
    return csr_matrix((data.ravel(), cols.ravel(), np.arange(0, m * (k + 1) + 1, k + 1)), shape=(m, len(t) - k - 1))


def _as_columns(y: np.ndarray) -> tuple[np.ndarray, tuple]:
    y = np.asarray(y, float)
    return y.reshape(len(y), -1), y.shape[1:]


def lsq_spline(x, y, t, k: int) -> Spline:
    """Least-squares spline of degree k on knots t through the samples y(x) (x increasing;
    y (m, ...)), solving the banded normal equations B'B c = B'y by Cholesky."""
    x = np.asarray(x, float)
    t = np.asarray(t, float)
    y2, tail = _as_columns(y)
    n = len(t) - k - 1
    if len(x) != len(y2):
        raise ValueError(f"x has {len(x)} samples but y has {len(y2)}")
    span, basis = _basis(t, k, x)
    first = span - k  # the column of each sample's first nonzero basis function
    # upper banded storage for solveh_banded: ab[k + row - col, col] = (B'B)[row, col], row <= col
    ab = np.zeros((k + 1, n))
    rhs = np.zeros((n, y2.shape[1]))
    starts = np.flatnonzero(np.r_[True, first[1:] != first[:-1]])  # x increasing: spans in runs
    cols = first[starts]
    for r in range(k + 1):
        rhs[cols + r] += np.add.reduceat(basis[r][:, None] * y2, starts, axis=0)
        for s in range(r, k + 1):
            ab[k - (s - r), cols + s] += np.add.reduceat(basis[r] * basis[s], starts)
    c = solveh_banded(ab, rhs, check_finite=False)
    return Spline(t, c.reshape((n,) + tail), k)


def not_a_knot(x: np.ndarray, k: int) -> np.ndarray:
    """scipy's default knots for interpolation of degree k at the sites x: the data sites less
    the first and last (k + 1) // 2 (for even k the midpoints less k // 2 at each end), with
    the ends repeated k + 1 times."""
    if k % 2 == 1:
        inner = x[(k + 1) // 2 : len(x) - (k + 1) // 2]
    else:
        mid = 0.5 * (x[1:] + x[:-1])
        inner = mid[k // 2 : len(mid) - k // 2]
    return np.r_[(x[0],) * (k + 1), inner, (x[-1],) * (k + 1)]


def interp_spline(x, y, k: int) -> Spline:
    """The spline of degree k through y(x) (x strictly increasing, len(x) > k) with the
    not-a-knot knots, as ``scipy.interpolate.make_interp_spline(x, y, k)``."""
    x = np.asarray(x, float)
    y2, tail = _as_columns(y)
    if len(x) != len(y2):
        raise ValueError(f"x has {len(x)} samples but y has {len(y2)}")
    if len(x) <= k or np.any(np.diff(x) <= 0):
        raise ValueError(f"interpolation of degree {k} needs more than {k} strictly increasing sites")
    if k == 0:
        return Spline(np.r_[x, x[-1]], y2.reshape((len(x),) + tail).copy(), 0)
    if k == 1:
        return Spline(np.r_[x[0], x, x[-1]], y2.reshape((len(x),) + tail).copy(), 1)
    t = not_a_knot(x, k)
    n = len(x)
    span, basis = _basis(t, k, x)
    # general banded storage for solve_banded((k, k)): ab[k + row - col, col] = A[row, col]
    ab = np.zeros((2 * k + 1, n))
    rows = np.arange(n)
    for r in range(k + 1):
        col = span - k + r
        ab[k + rows - col, col] = basis[r]
    c = solve_banded((k, k), ab, y2, check_finite=False)
    return Spline(t, c.reshape((n,) + tail), k)
