r"""Network processing of seed 000 section V: per-receiver ToAs -> position measurements for the tracker.

1. Measurement generation (V-A): for every nu-subset of receivers with detections and every choice of one detection
   per receiver (a nu-tuple), the closed-form LS ellipse intersection (:mod:`uwb_env.localization.ellipse`).
2. False-alarm reduction (V-B): keep a tuple iff its weight Omega = sum of the detections' weights omega is at least
   ``min_weight``, its ellipse residual is at most ``max_residual_m`` and it falls in the surveillance area.
3. Measurement clustering (V-C, Algorithm 2); each cluster's centroid is one measurement.
4. Covariance (our addition; the seed's PHD filter uses none): the geometry's (J^T J)^-1 sigma_r^2 at the centroid,
   J the gradients of the bistatic ranges of every receiver that contributed to the cluster (rows (u_t + u_r)^T),
   sigma_r the per-range standard deviation.
"""

from __future__ import annotations

import functools
import itertools
from dataclasses import dataclass

import numpy as np

from uwb_env.localization.clustering import cluster_positions
from uwb_env.localization.ellipse import ls_ellipse_intersection
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
    ranges: FloatArray, weights: FloatArray, receiver: IntArray, rx_pos: FloatArray, tx_pos: FloatArray, nu: int
) -> TupleMeasurements:
    """Measurement generation over every nu-tuple of detections from nu different receivers.

    Args:
        ranges, weights, receiver: ``(D,)`` bistatic range [m], weight omega and receiver index of each detection;
        rx_pos: ``(R, 2)``; tx_pos: ``(2,)`` the common transmitter; nu: tuple size (>= 3).
    """
    if nu < 3:
        raise ValueError(f"nu = {nu}: the closed-form intersection needs nu >= 3 receivers")
    members = _combinations(ranges.shape[0], nu)
    rec = np.sort(receiver[members], axis=1)
    members = members[np.all(rec[:, 1:] != rec[:, :-1], axis=1)]  # one detection per receiver
    pos, res = ls_ellipse_intersection(ranges[members], rx_pos[receiver[members]], tx_pos)
    return TupleMeasurements(pos, res, weights[members].sum(axis=1), members)


@functools.lru_cache(maxsize=256)
def _combinations(n: int, k: int) -> IntArray:
    """``(C(n, k), k)`` index tuples of ``itertools.combinations(range(n), k)`` (cached, read-only)."""
    out = np.array(list(itertools.combinations(range(n), k)), dtype=np.int64).reshape(-1, k)
    out.flags.writeable = False
    return out


def geometry_covariance(p: FloatArray, tx: FloatArray, rx: FloatArray, range_var: float) -> FloatArray:
    """``(2, 2)`` covariance (J^T J)^-1 range_var of a position ``p`` (2,) ranged by receivers ``rx`` (n, 2)."""
    ut = (p - tx) / max(float(np.linalg.norm(p - tx)), 1e-9)
    ur = (p[None] - rx) / np.maximum(np.linalg.norm(p[None] - rx, axis=-1), 1e-9)[:, None]
    J = ut[None] + ur
    info = J.T @ J / range_var
    info += 1e-9 * (np.trace(info) + 1e-12) * np.eye(2)  # a degenerate geometry gives a huge, finite covariance
    return np.linalg.inv(info)


def locate(
    ranges: FloatArray,
    weights: FloatArray,
    receiver: IntArray,
    rx_pos: FloatArray,
    tx_pos: FloatArray,
    area: FloatArray,
    nu: int,
    min_weight: float,
    max_residual_m: float,
    cluster_distance_m: float,
    linkage: str,
    range_std_m: float,
) -> tuple[FloatArray, FloatArray, list[IntArray]]:
    """The whole network chain (module docstring).

    Returns positions ``(C, 2)``, covariances ``(C, 2, 2)`` and, per cluster, the detection indices it used.
    """
    tm = tuple_measurements(ranges, weights, receiver, rx_pos, tx_pos, nu)
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
        covs[c] = geometry_covariance(centroids[c], tx_pos, rx_pos[np.unique(receiver[dets])], range_std_m**2)
    return centroids, covs, used
