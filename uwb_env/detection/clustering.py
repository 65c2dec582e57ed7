r"""One-dimensional hierarchical clustering of CFAR decisions (seed 000 section IV-F) and the ToA of each cluster.

Every '1' of a decision vector starts as a singleton cluster; while the two closest clusters are nearer than
``d_thr`` samples they merge, the distance between clusters being that of their centroids, the median positions of
their members (footnote 13). On a line the closest pair is always a pair of neighbours, so the search runs over
neighbours only. A surviving cluster becomes one detection at its median, with weight omega = its number of '1's;
clusters lighter than ``w_min`` are dropped. The ToA of a detection is the median (the seed) or, with ``peak``, the
strongest sample of d inside the cluster refined by a parabola through it and its neighbours (seed 003's peak
detection with quadratic fit), which removes the sample quantisation of the median.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from uwb_env.typing import BoolArray, FloatArray, IntArray


@nb.njit(cache=True, nogil=True)
def _median(x, lo, hi):  # pragma: no cover - compiled
    m = hi - lo + 1
    return 0.5 * (x[lo + (m - 1) // 2] + x[lo + m // 2])


@nb.njit(cache=True, nogil=True)
def _cluster_rows(decisions, d, d_thr, w_min, use_peak):  # pragma: no cover - compiled
    total = 0
    for b in range(decisions.shape[0]):
        total += np.count_nonzero(decisions[b])
    rows = np.empty(total, dtype=np.int64)
    toas = np.empty(total)
    weights = np.empty(total, dtype=np.int64)
    peaks = np.empty(total)
    out = 0
    n = decisions.shape[1]
    for b in range(decisions.shape[0]):
        x = np.flatnonzero(decisions[b]).astype(np.float64)
        c = x.size
        if c == 0:
            continue
        lo = np.arange(c)
        hi = np.arange(c)
        med = x.copy()
        while c > 1:
            gaps = med[1:c] - med[: c - 1]
            j = np.argmin(gaps)
            if gaps[j] >= d_thr:
                break
            hi[j] = hi[j + 1]
            med[j] = _median(x, lo[j], hi[j])
            lo[j + 1 : c - 1] = lo[j + 2 : c]
            hi[j + 1 : c - 1] = hi[j + 2 : c]
            med[j + 1 : c - 1] = med[j + 2 : c]
            c -= 1
        for j in range(c):
            w = hi[j] - lo[j] + 1
            if w < w_min:
                continue
            a, z = int(x[lo[j]]), int(x[hi[j]])
            k = a + np.argmax(d[b, a : z + 1])
            toa = med[j]
            if use_peak and 0 < k < n - 1:
                y0, ym, yp = d[b, k], d[b, k - 1], d[b, k + 1]
                den = ym - 2.0 * y0 + yp
                off = 0.5 * (ym - yp) / den if den < 0.0 else 0.0
                toa = k + min(max(off, -0.5), 0.5)
            elif use_peak:
                toa = float(k)
            rows[out] = b
            toas[out] = toa
            weights[out] = w
            peaks[out] = d[b, k]
            out += 1
    return rows[:out], toas[:out], weights[:out], peaks[:out]


def cluster_detections(
    decisions: BoolArray, d: FloatArray, d_thr: float, w_min: int, toa: str = "peak"
) -> tuple[IntArray, FloatArray, IntArray, FloatArray]:
    """Cluster the decisions of scans ``(B, N)``; returns flat ``(row, toa [samples], weight, peak d)`` arrays."""
    if toa not in ("median", "peak"):
        raise ValueError(f"toa = {toa!r}: must be 'median' or 'peak'")
    dec = np.ascontiguousarray(np.asarray(decisions, dtype=bool).reshape(-1, decisions.shape[-1]))
    dd = np.ascontiguousarray(np.asarray(d, dtype=float).reshape(-1, d.shape[-1]))
    return _cluster_rows(dec, dd, float(d_thr), int(w_min), toa == "peak")
