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
def normal_equations(ranges, w, tx, rx, px, py):  # pragma: no cover - compiled
    """Gauss-Newton's sums at p = (px, py): ``(A00, A01, A11, g0, g1, cost)``, A = J^T W J, g = J^T W res.

    Residuals res_k = r_k - (|p - tx_k| + |p - rx_k|) of the bistatic ranges ``ranges (nu,)``, weights ``w (nu,)``,
    node positions ``tx, rx (nu, 2)``; used by ``_gauss_newton`` and ``tracking.initiation.gauss_newton_exact``.
    """
    a00 = a01 = a11 = g0 = g1 = cost = 0.0
    for k in range(ranges.shape[0]):
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
    return a00, a01, a11, g0, g1, cost


@nb.njit(cache=True, fastmath=False, nogil=True)
def _gauss_newton(ranges, w, tx, rx, p0, n_iter):  # pragma: no cover - compiled
    """One tuple from one start: ``(x, y, cost, i00, i01, i11)`` with the information at the solution."""
    px, py = p0[0], p0[1]
    for it in range(n_iter + 1):
        a00, a01, a11, g0, g1, cost = normal_equations(ranges, w, tx, rx, px, py)
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


@nb.njit(cache=True, fastmath=False, nogil=True)
def two_ellipse_intersections(q, var, tx, rx):  # pragma: no cover - compiled
    """Both intersections of the two iso-range ellipses of each pair of detections sharing a transmitter.

    Closed form (seed 000 eqs. 17-21 with nu = 2): with z = p - tx and r_i' = rx_i - tx, each ellipse reads
    |z| = c_i + u_i . z, c_i = (q_i^2 - |r_i'|^2) / (2 q_i), u_i = r_i' / q_i; their difference is the line
    (u_1 - u_2) . z = c_2 - c_1, and on it z = z0 + s n (n the line's unit direction) the first equation squared is
    the quadratic s^2 (1 - b^2) + 2 s (z0 . n - a b) + |z0|^2 - a^2 = 0, a = c_1 + u_1 . z0, b = u_1 . n, whose roots
    with c_1 + u_1 . z >= 0 are the (at most two: the target and its mirror) intersections. Two receivers cannot
    tell them apart; track initiation keeps both and two scans' velocity gate resolves the ambiguity.

    Args: q, var ``(N, 2)`` bistatic ranges [m] and variances; tx ``(2,)`` the shared transmitter; rx ``(2, 2)``.

    Returns: positions ``(N, 2, 2)`` (tuple, root, xy), covariances ``(N, 2, 2, 2)`` = (J^T V^-1 J)^-1 (regularised
    like :func:`ellipse_intersection`), valid ``(N, 2)``.
    """
    N = q.shape[0]
    pos = np.zeros((N, 2, 2))
    cov = np.zeros((N, 2, 2, 2))
    valid = np.zeros((N, 2), np.bool_)
    r1x, r1y = rx[0, 0] - tx[0], rx[0, 1] - tx[1]
    r2x, r2y = rx[1, 0] - tx[0], rx[1, 1] - tx[1]
    for n in range(N):
        q1, q2 = q[n, 0], q[n, 1]
        if q1 <= math.hypot(r1x, r1y) or q2 <= math.hypot(r2x, r2y):
            continue  # shorter than a baseline: no ellipse
        c1 = (q1 * q1 - r1x * r1x - r1y * r1y) / (2.0 * q1)
        c2 = (q2 * q2 - r2x * r2x - r2y * r2y) / (2.0 * q2)
        u1x, u1y, u2x, u2y = r1x / q1, r1y / q1, r2x / q2, r2y / q2
        ax, ay = u1x - u2x, u1y - u2y
        aa = ax * ax + ay * ay
        if aa < 1e-18:
            continue  # parallel: the ellipses do not cross at two points
        z0x, z0y = (c2 - c1) * ax / aa, (c2 - c1) * ay / aa
        na = math.sqrt(aa)
        nx, ny = -ay / na, ax / na
        a = c1 + u1x * z0x + u1y * z0y
        b = u1x * nx + u1y * ny
        A2 = 1.0 - b * b
        B2 = 2.0 * (z0x * nx + z0y * ny - a * b)
        C2 = z0x * z0x + z0y * z0y - a * a
        disc = B2 * B2 - 4.0 * A2 * C2
        if A2 <= 0.0 or disc < 0.0:
            continue
        sq = math.sqrt(disc)
        for k in range(2):
            s = (-B2 + (sq if k == 0 else -sq)) / (2.0 * A2)
            if a + b * s < 0.0:
                continue  # a root of the squared equation only
            zx, zy = z0x + s * nx, z0y + s * ny
            i00 = i01 = i11 = 0.0
            for j in range(2):
                rjx, rjy = (r1x, r1y) if j == 0 else (r2x, r2y)
                lt = max(math.hypot(zx, zy), 1e-9)
                lr = max(math.hypot(zx - rjx, zy - rjy), 1e-9)
                jx, jy = zx / lt + (zx - rjx) / lr, zy / lt + (zy - rjy) / lr
                w = 1.0 / var[n, j]
                i00 += w * jx * jx
                i01 += w * jx * jy
                i11 += w * jy * jy
            reg = 1e-9 * (i00 + i11 + 1e-12)
            i00 += reg
            i11 += reg
            det = i00 * i11 - i01 * i01
            pos[n, k, 0], pos[n, k, 1] = zx + tx[0], zy + tx[1]
            cov[n, k, 0, 0], cov[n, k, 0, 1] = i11 / det, -i01 / det
            cov[n, k, 1, 0], cov[n, k, 1, 1] = -i01 / det, i00 / det
            valid[n, k] = True
    return pos, cov, valid
