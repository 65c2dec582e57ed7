r"""Two-dimensional hierarchical clustering of position measurements (seed 000 section V-C, Algorithm 2).

Each measurement starts as a singleton cluster; while the two closest clusters are nearer than ``d_thr`` they merge.
The distance between clusters Z1, Z2 is one of
    centroid:  ||c(Z1) - c(Z2)||, c the mean (eqs. 26-27),
    single:    min ||z1 - z2|| over Z1 x Z2 (eq. 28),
    complete:  max ||z1 - z2|| over Z1 x Z2 (eq. 29).
Single and complete linkage update the cluster distances by the Lance-Williams rule (min / max of the merged
pair's distances), which is exactly eqs. 28-29; centroid linkage recomputes the merged cluster's centroid.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from uwb_env.typing import FloatArray, IntArray

LINKAGES = ("centroid", "single", "complete")


@nb.njit(cache=True, nogil=True)
def _agglomerate(z, d_thr, linkage):  # pragma: no cover - compiled
    n = z.shape[0]
    label = np.arange(n)
    alive = np.ones(n, dtype=np.bool_)
    count = np.ones(n)
    cen = z.copy()
    D = np.full((n, n), np.inf)
    for i in range(n):
        for j in range(i + 1, n):
            D[i, j] = D[j, i] = np.sqrt((z[i, 0] - z[j, 0]) ** 2 + (z[i, 1] - z[j, 1]) ** 2)
    for _ in range(n - 1):
        best, bi, bj = np.inf, -1, -1
        for i in range(n):
            if not alive[i]:
                continue
            for j in range(i + 1, n):
                if alive[j] and D[i, j] < best:
                    best, bi, bj = D[i, j], i, j
        if bi < 0 or best >= d_thr:
            break
        total = count[bi] + count[bj]
        cen[bi] = (count[bi] * cen[bi] + count[bj] * cen[bj]) / total
        count[bi] = total
        alive[bj] = False
        for m in range(n):
            if label[m] == bj:
                label[m] = bi
        for k in range(n):
            if not alive[k] or k == bi:
                continue
            if linkage == 0:
                d = np.sqrt((cen[bi, 0] - cen[k, 0]) ** 2 + (cen[bi, 1] - cen[k, 1]) ** 2)
            elif linkage == 1:
                d = min(D[bi, k], D[bj, k])
            else:
                d = max(D[bi, k], D[bj, k])
            D[bi, k] = D[k, bi] = d
    return label


def cluster_positions(z: FloatArray, d_thr: float, linkage: str = "centroid") -> tuple[IntArray, FloatArray]:
    """Algorithm 2 on measurements ``z`` (M, 2): ``(cluster index (M,) in 0..C-1, centroids (C, 2))``.

    Clusters are numbered in the order of their first member.
    """
    if linkage not in LINKAGES:
        raise ValueError(f"linkage = {linkage!r}: must be one of {LINKAGES}")
    z = np.ascontiguousarray(np.asarray(z, dtype=float).reshape(-1, 2))
    if z.shape[0] == 0:
        return np.zeros(0, np.int64), np.zeros((0, 2))
    label = _agglomerate(z, float(d_thr), LINKAGES.index(linkage))
    _, first, index = np.unique(label, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    index = rank[index]
    counts = np.bincount(index)
    centroids = np.stack([np.bincount(index, z[:, i]) / counts for i in range(2)], axis=-1)
    return index, centroids
