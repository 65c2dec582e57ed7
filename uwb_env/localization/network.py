r"""Network processing of seed 000 section V: per-receiver ToAs -> position measurements for the tracker.

1. Measurement generation (V-A): for every nu-subset of pairs with detections and every choice of one detection
   per pair (a nu-tuple), the closed-form LS ellipse intersection when the pairs share one transmitter, else
   Gauss-Newton least squares (:mod:`uwb_env.localization.ellipse`).
2. False-alarm reduction (V-B): keep a tuple iff its weight Omega = sum of the detections' weights omega is at least
   ``min_weight``, its ellipse residual is at most ``max_residual_m`` and it falls in the surveillance area.
3. Measurement clustering (V-C, Algorithm 2); each cluster's centroid is one measurement.
4. Covariance (our addition; the seed's PHD filter uses none): the geometry's (J^T J)^-1 sigma_r^2 at the centroid,
   J the gradients of the bistatic ranges of every pair that contributed to the cluster (rows (u_t + u_r)^T),
   sigma_r the per-range standard deviation.
"""

from __future__ import annotations

import functools
import itertools
from dataclasses import dataclass

import numpy as np

from uwb_env.localization.clustering import cluster_positions
from uwb_env.localization.ellipse import ellipse_intersection, ls_ellipse_intersection
from uwb_env.typing import FloatArray, IntArray


@dataclass(frozen=True, slots=True)
class TupleMeasurements:
    """All nu-tuple LS solutions of one scan.

    positions ``(M, 2)``, residual ``(M,)`` [m], weight ``(M,)``, ``members`` ``(M, nu)`` flat indices of the
    detections used (into the scan's detection list).
    """

    positions: FloatArray
    residual: FloatArray
    weight: FloatArray
    members: IntArray


def tuple_measurements(
    ranges: FloatArray,
    weights: FloatArray,
    pair: IntArray,
    tx: FloatArray,
    rx: FloatArray,
    nu: int,
    starts: FloatArray | None = None,
) -> TupleMeasurements:
    """Measurement generation over every nu-tuple of detections from nu different pairs.

    Args:
        ranges, weights, pair: ``(D,)`` bistatic range [m], weight omega and pair index of each detection;
        tx, rx: ``(D, 2)`` the nodes of each detection's pair; nu: tuple size (>= 3); starts: ``(S, 2)``
        Gauss-Newton starts, used when the pairs do not share one transmitter (a monostatic network).

    One transmitter (seed 000): the closed form of :func:`ls_ellipse_intersection`. Otherwise the seed's linear
    elimination of |z - t| does not apply, and each tuple is solved by Gauss-Newton least squares on its ranges
    (:func:`ellipse_intersection`) with the same residual, the RMS range residual at the solution [m].
    """
    if nu < 3:
        raise ValueError(f"nu = {nu}: the intersection needs nu >= 3 receivers")
    members = _combinations(ranges.shape[0], nu)
    grp = np.sort(pair[members], axis=1)
    members = members[np.all(grp[:, 1:] != grp[:, :-1], axis=1)]  # one detection per pair
    q = ranges[members]
    if members.shape[0] == 0 or np.all(tx == tx[:1]):
        pos, res = ls_ellipse_intersection(q, rx[members], tx[0] if tx.shape[0] else np.zeros(2))
    else:
        if starts is None:
            raise ValueError("starts: required when the pairs do not share one transmitter")
        pos, _, cost = ellipse_intersection(q, np.ones_like(q), tx[members], rx[members], starts)
        res = np.sqrt(cost / nu)
    return TupleMeasurements(pos, res, weights[members].sum(axis=1), members)


@functools.lru_cache(maxsize=256)
def _combinations(n: int, k: int) -> IntArray:
    """``(C(n, k), k)`` index tuples of ``itertools.combinations(range(n), k)`` (cached, read-only)."""
    out = np.array(list(itertools.combinations(range(n), k)), dtype=np.int64).reshape(-1, k)
    out.flags.writeable = False
    return out


def geometry_covariance(p: FloatArray, tx: FloatArray, rx: FloatArray, range_var: float) -> FloatArray:
    """``(2, 2)`` covariance (J^T J)^-1 range_var of a position ``p`` (2,) ranged by the pairs ``tx``, ``rx`` (n, 2)."""
    ut = (p[None] - tx) / np.maximum(np.linalg.norm(p[None] - tx, axis=-1), 1e-9)[:, None]
    ur = (p[None] - rx) / np.maximum(np.linalg.norm(p[None] - rx, axis=-1), 1e-9)[:, None]
    J = ut + ur
    info = J.T @ J / range_var
    info += 1e-9 * (np.trace(info) + 1e-12) * np.eye(2)  # a degenerate geometry gives a huge, finite covariance
    return np.linalg.inv(info)


def locate(
    ranges: FloatArray,
    weights: FloatArray,
    pair: IntArray,
    tx: FloatArray,
    rx: FloatArray,
    area: FloatArray,
    nu: int,
    min_weight: float,
    max_residual_m: float,
    cluster_distance_m: float,
    linkage: str,
    range_std_m: float,
) -> tuple[FloatArray, FloatArray, list[IntArray]]:
    """The whole network chain (module docstring).

    ``pair``, ``tx``, ``rx``: per detection (see :func:`tuple_measurements`); ``area`` ``[x0, x1, y0, y1]``.
    Returns positions ``(C, 2)``, covariances ``(C, 2, 2)`` and, per cluster, the detection indices it used.
    """
    gx, gy = np.meshgrid(np.linspace(area[0], area[1], 4)[1:-1], np.linspace(area[2], area[3], 4)[1:-1])
    starts = np.stack([gx.ravel(), gy.ravel()], axis=-1)  # 2 x 2 interior grid for Gauss-Newton
    tm = tuple_measurements(ranges, weights, pair, tx, rx, nu, starts)
    p = tm.positions
    keep = (
        (tm.weight >= min_weight)
        & (tm.residual <= max_residual_m)
        & (p[:, 0] >= area[0])
        & (p[:, 0] <= area[1])
        & (p[:, 1] >= area[2])
        & (p[:, 1] <= area[3])
    )
    p, members = p[keep], tm.members[keep]
    index, centroids = cluster_positions(p, cluster_distance_m, linkage)
    covs = np.zeros((centroids.shape[0], 2, 2))
    used = []
    for c in range(centroids.shape[0]):  # one per cluster: a handful per scan
        dets = np.unique(members[index == c])
        used.append(dets)
        _, first = np.unique(pair[dets], return_index=True)  # one gradient row per contributing pair
        covs[c] = geometry_covariance(centroids[c], tx[dets[first]], rx[dets[first]], range_std_m**2)
    return centroids, covs, used
