"""Compiled (numba) twin of :func:`uwb_env.localization.ellipse.ellipse_intersection` (the numpy reference).

Track initiation from range-only detections (seed 003's measurement set: range and range-rate, no azimuth) forms
every tuple of two receivers' ranges each scan: ~200 tuples x 5 starts x 15 Gauss-Newton iterations. In numpy that
is ~7 ms a scan (98 % of a random-policy env step); one compiled pass is two orders of magnitude faster. Same
algorithm, same fixed iterations and regularisation, so the two agree to rounding (tests/unit/test_localization.py).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from uwb_env.typing import FloatArray


@nb.njit(cache=True, fastmath=False, nogil=True)
def _gauss_newton(ranges, w, tx, rx, p0, n_iter):  # pragma: no cover - compiled
    """One tuple from one start: ``(x, y, cost, i00, i01, i11)`` with the information at the solution."""
    px, py = p0[0], p0[1]
    nu = ranges.shape[0]
    for it in range(n_iter + 1):
        a00 = a01 = a11 = g0 = g1 = cost = 0.0
        for k in range(nu):
            dtx, dty = px - tx[k, 0], py - tx[k, 1]
            drx, dry = px - rx[k, 0], py - rx[k, 1]
            lt = max(math.sqrt(dtx * dtx + dty * dty), 1e-9)
            lr = max(math.sqrt(drx * drx + dry * dry), 1e-9)
            res = ranges[k] - (lt + lr)
            jx, jy = dtx / lt + drx / lr, dty / lt + dry / lr
            a00 += w[k] * jx * jx
            a01 += w[k] * jx * jy
            a11 += w[k] * jy * jy
            g0 += w[k] * jx * res
            g1 += w[k] * jy * res
            cost += w[k] * res * res
        if it == n_iter:
            return px, py, cost, a00, a01, a11
        reg = 1e-9 * (a00 + a11 + 1e-12)
        b00, b11 = a00 + reg, a11 + reg
        det = b00 * b11 - a01 * a01
        px += (b11 * g0 - a01 * g1) / det
        py += (b00 * g1 - a01 * g0) / det
    return px, py, 0.0, 0.0, 0.0, 0.0


@nb.njit(cache=True, fastmath=False, nogil=True)
def ellipse_intersection(ranges, variances, tx, rx, starts, n_iter=15):  # pragma: no cover - compiled
    """ellipse.ellipse_intersection, compiled: same arguments ``(N, nu)``, ``(N, nu, 2)``, ``(S, 2)`` and returns."""
    N, nu = ranges.shape
    S = starts.shape[0]
    pos = np.empty((N, 2))
    cov = np.empty((N, 2, 2))
    best_cost = np.empty(N)
    w = np.empty(nu)
    for n in range(N):
        for k in range(nu):
            w[k] = 1.0 / variances[n, k]
        bc = np.inf
        bx = by = i00 = i01 = i11 = 0.0
        for s in range(S):
            x, y, c, a00, a01, a11 = _gauss_newton(ranges[n], w, tx[n], rx[n], starts[s], n_iter)
            if c < bc:  # the first of equal costs, as argmin
                bc, bx, by, i00, i01, i11 = c, x, y, a00, a01, a11
        reg = 1e-9 * (i00 + i11 + 1e-12)
        i00 += reg
        i11 += reg
        det = i00 * i11 - i01 * i01
        pos[n, 0], pos[n, 1] = bx, by
        cov[n, 0, 0], cov[n, 0, 1], cov[n, 1, 0], cov[n, 1, 1] = i11 / det, -i01 / det, -i01 / det, i00 / det
        best_cost[n] = bc
    return pos, cov, best_cost


def ellipse_intersection_fast(
    ranges: FloatArray, variances: FloatArray, tx: FloatArray, rx: FloatArray, starts: FloatArray, n_iter: int = 15
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The compiled kernel on contiguous float64 copies of its inputs (broadcast node arrays are views)."""
    c = np.ascontiguousarray
    return ellipse_intersection(
        c(ranges, dtype=float), c(variances, dtype=float), c(tx, dtype=float), c(rx, dtype=float),
        c(starts, dtype=float), n_iter,
    )  # fmt: skip
