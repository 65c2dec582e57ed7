r"""Track initiation: candidate positions from unassociated measurements, then two-point differencing.

Candidates (one scan):
    * a detection with range and azimuth (array receiver): the point of the iso-range ellipse on the bearing line,
      p = rx + d u(theta), d = (r^2 - |a|^2) / (2 (r + a . u)), a = rx - tx (closed form), covariance by the
      Jacobian of (r, theta) -> p;
    * range-only detections: two receivers of one transmitter (seed 003's network): both intersections of the two
      iso-range ellipses in closed form (``localization.compiled.two_ellipse_intersections``; the target and its
      mirror, which the next scan's velocity gate tells apart); otherwise least-squares intersection of the iso-range
      ellipses of a nu-tuple of detections from different receivers (seed 000 section V-A, eqs. 16-23): Gauss-Newton
      on sum_k (r_k - h_k(p))^2 / var_k from several starts, kept if inside the surveillance area and (for nu > 2)
      its normalised residual passes the chi-square test; covariance (J^T V^-1 J)^-1. The compiled path gives the
      same bits with less work: a lower bound of the residual over the area (triangle inequality on the ranges'
      foci, :func:`_residual_lower_bound`) rejects most tuples before Gauss-Newton, and each start stops at an exact
      fixed point or 2-cycle of the iteration (:func:`gauss_newton_exact`).
For chirps the range is the ridge-corrected one, r - (R_rd / R_dd) rdot, whose variance R_rr - R_rd^2 / R_dd is
the delay-Doppler ridge's (see uwb_env.sensing): the single-chirp range-rate is too coarse to use otherwise.

Candidates less precise than ``max_std`` are dropped (they could only start tracks whose gates swallow others'
detections). Candidates of one scan that are the same point seen by two receivers (mutual nearest neighbours
within the gate) are fused, information-weighted. Two-point differencing (seed 003 section 4.2.1) pairs a
candidate with one of the previous scan's when each velocity component satisfies |dx / T| <= v_max + 2 sigma_v.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numba as nb
import numpy as np
from scipy.stats import chi2

from uwb_env.localization.compiled import ellipse_intersection_fast, normal_equations, two_ellipse_intersections
from uwb_env.tracking.compiled import initiate
from uwb_env.typing import BoolArray, FloatArray, IntArray

if TYPE_CHECKING:
    from uwb_env.config import TrackerConfig
    from uwb_env.sensing.records import Detections


def ridge_range(
    z: FloatArray, R: FloatArray, names: tuple[str, ...], max_range_rate: float
) -> tuple[FloatArray, FloatArray]:
    """Range and its variance usable without a range-rate prior: ``(r (n,), var (n,))``.

    With a range-rate column, r - (R_rd / R_dd) rdot with variance R_rr - R_rd^2 / R_dd + (R_rd / R_dd)^2
    v_max^2 / 3 (the unknown true range-rate, uniform in +-v_max); otherwise the range itself.
    """
    if "range_rate" not in names:
        return z[:, 0], R[:, 0, 0]
    j = names.index("range_rate")
    slope = R[:, 0, j] / R[:, j, j]
    var = R[:, 0, 0] - slope * R[:, 0, j] + slope**2 * max_range_rate**2 / 3.0
    return z[:, 0] - slope * z[:, j], var


def range_azimuth_candidates(
    r: FloatArray, var_r: FloatArray, theta: FloatArray, var_theta: FloatArray, tx: FloatArray, rx: FloatArray
) -> tuple[FloatArray, FloatArray, BoolArray]:
    """Positions where the bearing line from ``rx`` meets the iso-range ellipse (module docstring).

    Args: r, var_r, theta, var_theta ``(n,)``; tx, rx ``(2,)``.
    Returns: positions ``(n, 2)``, covariances ``(n, 2, 2)``, valid ``(n,)`` (range beyond the baseline, d > 0).
    """
    a = rx - tx
    u = np.stack([np.cos(theta), np.sin(theta)], axis=-1)
    up = np.stack([-np.sin(theta), np.cos(theta)], axis=-1)
    au = u @ a
    den = 2.0 * (r + au)
    num = r**2 - a @ a
    valid = (r > np.linalg.norm(a)) & (den > 0)
    den_s = np.where(valid, den, 1.0)
    d = num / den_s
    valid &= d > 0
    dd_dr = (2.0 * r * den_s - 2.0 * num) / den_s**2
    dd_dth = -num * 2.0 * (up @ a) / den_s**2
    p = rx + d[:, None] * u
    J = np.stack([u * dd_dr[:, None], u * dd_dth[:, None] + d[:, None] * up], axis=-1)  # (n, 2, 2)
    cov = J @ (np.stack([var_r, var_theta], axis=-1)[:, :, None] * np.swapaxes(J, -1, -2))
    return p, 0.5 * (cov + np.swapaxes(cov, -1, -2)), valid


def range_only_candidates(
    groups: list[tuple[FloatArray, FloatArray, FloatArray, FloatArray]],
    nu: int,
    area: FloatArray,
    starts: FloatArray,
    residual_probability: float = 0.99,
) -> tuple[FloatArray, FloatArray]:
    """Candidates from nu-tuples of range-only detections of different receivers.

    Args:
        groups: per receiver ``(ranges (n,), variances (n,), tx (2,), rx (2,))``; nu: tuple size (>= 2);
        area: ``[x_min, x_max, y_min, y_max]``; starts: ``(S, 2)`` Gauss-Newton starts.

    Returns:
        positions ``(C, 2)``, covariances ``(C, 2, 2)``.
    """
    rows = []
    for combo in itertools.combinations([g for g in groups if g[0].size], nu):  # receiver subsets: a small set
        grids = np.meshgrid(*[np.arange(g[0].size) for g in combo], indexing="ij")
        sel = [gr.reshape(-1) for gr in grids]
        rows.append(
            (
                np.stack([g[0][s] for g, s in zip(combo, sel, strict=True)], axis=1),
                np.stack([g[1][s] for g, s in zip(combo, sel, strict=True)], axis=1),
                np.broadcast_to(np.stack([g[2] for g in combo])[None], (sel[0].size, nu, 2)),
                np.broadcast_to(np.stack([g[3] for g in combo])[None], (sel[0].size, nu, 2)),
            )
        )
    if not rows:
        return np.zeros((0, 2)), np.zeros((0, 2, 2))
    if nu == 2 and all(np.array_equal(row[2][0, 0], row[2][0, 1]) for row in rows):
        return _shared_transmitter_pairs(rows, area)
    r, v, t, x = (np.concatenate([row[i] for row in rows]) for i in range(4))
    p, cov, cost = ellipse_intersection_fast(r, v, t, x, starts)  # the compiled twin of ellipse_intersection
    ok = (p[:, 0] >= area[0]) & (p[:, 0] <= area[1]) & (p[:, 1] >= area[2]) & (p[:, 1] <= area[3])
    if nu > 2:
        ok &= cost <= chi2.ppf(residual_probability, nu - 2)
    return p[ok], cov[ok]


def _shared_transmitter_pairs(rows: list[tuple[FloatArray, ...]], area: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Two receivers of one transmitter: both closed-form intersections of each pair of ellipses, inside the area."""
    ps, covs = [], []
    for r, v, t, x in rows:  # receiver pairs: a small set
        p, cov, ok = two_ellipse_intersections(
            np.ascontiguousarray(r), np.ascontiguousarray(v), np.ascontiguousarray(t[0, 0]), np.ascontiguousarray(x[0])
        )
        p, cov = p[ok], cov[ok]
        inside = (p[:, 0] >= area[0]) & (p[:, 0] <= area[1]) & (p[:, 1] >= area[2]) & (p[:, 1] <= area[3])
        ps.append(p[inside])
        covs.append(cov[inside])
    return np.concatenate(ps), np.concatenate(covs)


def fuse_candidates(p: FloatArray, cov: FloatArray, gate_d2: float) -> tuple[FloatArray, FloatArray]:
    """Fuse candidates that are each other's nearest neighbour within ``gate_d2``, information-weighted.

    The Mahalanobis distance uses the summed covariances; only mutual pairs fuse, so a wide candidate cannot
    chain others. Returns the fused ``(C', 2)``, ``(C', 2, 2)``.
    """
    n = p.shape[0]
    if n <= 1:
        return p, cov
    dx, dy = p[:, None, 0] - p[None, :, 0], p[:, None, 1] - p[None, :, 1]
    a = cov[:, None, 0, 0] + cov[None, :, 0, 0]
    b = cov[:, None, 0, 1] + cov[None, :, 0, 1]
    c = cov[:, None, 1, 1] + cov[None, :, 1, 1]
    d2 = (c * dx * dx - 2.0 * b * dx * dy + a * dy * dy) / (a * c - b * b)  # 2 x 2 Mahalanobis, closed form
    np.fill_diagonal(d2, np.inf)
    nn = np.argmin(d2, axis=1)
    idx = np.arange(n)
    mutual = (nn[nn] == idx) & (d2[idx, nn] < gate_d2) & (idx < nn)
    a, b = idx[mutual], nn[mutual]
    info_a, info_b = np.linalg.inv(cov[a]), np.linalg.inv(cov[b])
    P = np.linalg.inv(info_a + info_b)
    x = np.einsum("nij,nj->ni", P, np.einsum("nij,nj->ni", info_a, p[a]) + np.einsum("nij,nj->ni", info_b, p[b]))
    single = np.ones(n, bool)
    single[a] = single[b] = False
    return np.concatenate([p[single], x]), np.concatenate([cov[single], P])


def two_point_pairs(
    p: FloatArray, cov: FloatArray, p_prev: FloatArray, cov_prev: FloatArray, dt: float, max_speed: float
) -> tuple[np.ndarray, np.ndarray]:
    """Pairs (current i, previous j) passing the velocity gate of seed 003 section 4.2.1, each index used once.

    The gate per axis: |p_i - p_j| / T <= v_max + 2 sigma_v, sigma_v^2 = (cov_i + cov_j)_axis / T^2. Conflicts
    are resolved greedily by the normalised velocity (smallest first).
    """
    if p.shape[0] == 0 or p_prev.shape[0] == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    v = (p[:, None] - p_prev[None]) / dt  # (C, Cp, 2)
    sig = np.sqrt(np.diagonal(cov[:, None] + cov_prev[None], axis1=-2, axis2=-1)) / dt
    ok = np.all(np.abs(v) <= max_speed + 2.0 * sig, axis=-1)
    i, j = np.nonzero(ok)
    cost = np.sum((v[i, j] / (max_speed + 2.0 * sig[i, j])) ** 2, axis=-1)
    order = np.argsort(cost, kind="stable")
    i, j = i[order], j[order]
    _, first_i = np.unique(i, return_index=True)
    i, j = i[np.sort(first_i)], j[np.sort(first_i)]
    _, first_j = np.unique(j, return_index=True)
    keep = np.sort(first_j)
    return i[keep], j[keep]


# ------------------------------------------------------------------------------------- compiled initiation
_jit = nb.njit(cache=True, fastmath=False, nogil=True)
_EMPTY_P, _EMPTY_COV = np.zeros((0, 2)), np.zeros((0, 2, 2))
_RATE_COLUMN: dict[tuple[str, ...], int] = {}


def _rate_column(names: tuple[str, ...]) -> int:
    """The range-rate column of measurements ``names`` (-1: none; cached per measurement set)."""
    col = _RATE_COLUMN.get(names)
    if col is None:
        col = _RATE_COLUMN[names] = names.index("range_rate") if "range_rate" in names else -1
    return col


def offsets(sizes: Sequence[int]) -> IntArray:
    """``(E + 1,)`` row offsets of E consecutive blocks of ``sizes`` rows."""
    if isinstance(sizes, np.ndarray):
        start = np.zeros(sizes.size + 1, np.int64)
        np.cumsum(sizes, out=start[1:])
        return start
    return np.array([0, *itertools.accumulate(sizes)], np.int64)  # a short list: cheaper than np.cumsum


@functools.lru_cache(maxsize=16)
def _tuple_bounds(cap: int) -> tuple[IntArray, float]:
    """``(per_rx (4,), residual_max)``: the nu-tuples' detections per receiver and residual bound.

    ``Tracker._initiate`` keeps at most ``cap`` tuples per receiver subset; the 3-tuples' chi-square bound is
    :func:`range_only_candidates`' default ``residual_probability``.
    """
    per_rx = np.array([0, 0, max(1, int(cap ** (1.0 / 2))), max(1, int(cap ** (1.0 / 3)))], np.int64)
    return per_rx, float(chi2.ppf(0.99, 1))


_GROUP_NODES: dict[tuple, tuple] = {}


def _group_nodes(
    groups: tuple[tuple[int, int, tuple[str, ...]], ...], tx_pos: FloatArray, rx_pos: FloatArray
) -> tuple[FloatArray, FloatArray, IntArray]:
    """The pair-groups' transmitter and receiver positions ``(G, 2)`` and range-rate columns ``(G,)`` (cached).

    ``groups``: each group's ``(tx, rx, measurement names)``; cached per groups and node arrays (by identity; the
    arrays are a tracker's layout, never written). The returned arrays are shared: not to be written.
    """
    key = (groups, id(tx_pos), id(rx_pos))
    hit = _GROUP_NODES.get(key)
    if hit is not None and hit[0] is tx_pos and hit[1] is rx_pos:
        return hit[2]
    out = (
        tx_pos[[t for t, _, _ in groups]].reshape(-1, 2),
        rx_pos[[r for _, r, _ in groups]].reshape(-1, 2),
        np.array([_rate_column(names) for _, _, names in groups], np.int64),
    )
    if len(_GROUP_NODES) > 256:
        _GROUP_NODES.clear()
    _GROUP_NODES[key] = (tx_pos, rx_pos, out)
    return out


def initiate_compiled(
    groups: Sequence[Sequence[tuple[Detections, BoolArray]]],
    extra: Sequence[tuple[FloatArray, FloatArray] | None],
    previous: Sequence[Any],
    times_s: Sequence[float],
    tx_pos: FloatArray,
    rx_pos: FloatArray,
    area: FloatArray,
    starts: FloatArray,
    gate2: float,
    cfg: TrackerConfig,
) -> tuple[FloatArray, FloatArray, IntArray, FloatArray, FloatArray, IntArray]:
    """``Tracker._initiate`` after its per-pair candidates, for E environments in one compiled call.

    ``groups[e]``: environment e's range-only pairs with a free detection ``(detections, free (n,))``, in the scan's
    order; ``extra[e]``: its other candidates ``(p (k, 2), cov (k, 2, 2))`` (array receivers, fused positions) or
    None; ``previous[e]``: its previous scan's unpaired candidates (``.p``, ``.cov``, ``.time_s``); ``times_s[e]`` its
    scan time. The node positions, area, Gauss-Newton starts and the 2-D gate are the trackers' (one configuration).

    Returns the new tracks' x ``(n, 6)``, P ``(n, 6, 6)`` and environment offsets ``(E + 1,)``, then the unpaired
    candidates ``(C, 2)``, ``(C, 2, 2)`` and their offsets (:func:`range_only_initiation`).
    """
    dets = [d for g in groups for d, _ in g]
    if len(dets) == 1:
        d = dets[0]
        z, R, snr, free = d.z, d.R, d.snr, next(f for g in groups for _, f in g)
    elif dets:
        m = max(d.z.shape[1] for d in dets)
        if all(d.z.shape[1] == m for d in dets):
            z, R = np.concatenate([d.z for d in dets]), np.concatenate([d.R for d in dets])
        else:  # mixed measurement sets (range, range-rate): only columns 0 and the range-rate one are read
            z, R = np.zeros((sum(len(d) for d in dets), m)), np.zeros((sum(len(d) for d in dets), m, m))
            i = 0
            for d in dets:
                k, w = len(d), d.z.shape[1]
                z[i : i + k, :w], R[i : i + k, :w, :w] = d.z, d.R
                i += k
        snr = np.concatenate([d.snr for d in dets])
        free = np.concatenate([f for g in groups for _, f in g])
    else:
        z, R, snr, free = np.zeros((0, 1)), np.zeros((0, 1, 1)), np.zeros(0), np.zeros(0, bool)
    have = [e for e in extra if e is not None]
    if len(have) == len(extra) == 1:
        extra_p, extra_cov = have[0]
    elif have:
        extra_p, extra_cov = np.concatenate([e[0] for e in have]), np.concatenate([e[1] for e in have])
    else:
        extra_p, extra_cov = _EMPTY_P, _EMPTY_COV
    if len(previous) == 1:
        prev_p, prev_cov = previous[0].p, previous[0].cov
    else:
        prev_p, prev_cov = np.concatenate([c.p for c in previous]), np.concatenate([c.cov for c in previous])
    per_rx, residual_max = _tuple_bounds(cfg.init_max_candidates)
    group_tx, group_rx, group_rr = _group_nodes(tuple((d.tx, d.rx, d.measurement_names) for d in dets), tx_pos, rx_pos)
    c = np.ascontiguousarray
    out = range_only_initiation(
        c(z, dtype=float),
        c(R, dtype=float),
        c(snr, dtype=float),
        c(free, dtype=bool),
        offsets([len(d) for d in dets]),
        group_tx,
        group_rx,
        offsets([len(g) for g in groups]),
        group_rr,
        cfg.init_max_candidates,
        (2.0 * cfg.max_speed_mps) ** 2,
        per_rx,
        area,
        starts,
        residual_max,
        c(extra_p, dtype=float),
        c(extra_cov, dtype=float),
        offsets([0 if e is None else e[0].shape[0] for e in extra]),
        c(prev_p, dtype=float),
        c(prev_cov, dtype=float),
        offsets([c_.p.shape[0] for c_ in previous]),
        np.array([t - c_.time_s for t, c_ in zip(times_s, previous, strict=True)], dtype=float),
        2.0 * cfg.init_max_position_std_m**2,
        gate2,
        cfg.max_speed_mps,
        cfg.initial_accel_std_mps2,
    )
    return (*out[0], *out[1])


@_jit
def _ordered_ranges(z, R, snr, free, lo, hi, rr, cap, max_rr_sq, r_out, v_out):  # pragma: no cover - compiled
    """One pair's free detections (rows lo:hi), strongest first, at most ``cap``: ridge ranges and variances.

    :func:`ridge_range` on the rows ``Tracker._initiate`` keeps, with its operations in its order (so the
    numbers are the same to the last bit); ``rr`` the range-rate column (-1: none). Returns how many were written.
    """
    idx = np.flatnonzero(free[lo:hi]) + lo
    order = idx[np.argsort(-snr[idx], kind="mergesort")][:cap]
    for q in range(order.size):
        i = order[q]
        if rr >= 0:
            slope = R[i, 0, rr] / R[i, rr, rr]
            v_out[q] = R[i, 0, 0] - slope * R[i, 0, rr] + (slope * slope) * max_rr_sq / 3.0
            r_out[q] = z[i, 0] - slope * z[i, rr]
        else:
            r_out[q], v_out[q] = z[i, 0], R[i, 0, 0]
    return order.size


@_jit
def _inside(p, area):  # pragma: no cover - compiled
    return p[0] >= area[0] and p[0] <= area[1] and p[1] >= area[2] and p[1] <= area[3]


_GATE_MARGIN = 1e-6  # relative slack of the tuple gate over the residual bound: far above the costs' rounding


@_jit
def _xy_inside(x, y, area):  # pragma: no cover - compiled
    return x >= area[0] and x <= area[1] and y >= area[2] and y <= area[3]


@_jit
def _gate_constants(gtx, grx, area):  # pragma: no cover - compiled
    """Per-group bounds on the bistatic range h_g(p) = |p - tx_g| + |p - rx_g| for the tuple gate.

    Returns ``focal (G, G)``: |h_g(p) - h_f(p)| <= focal[g, f] at every p (triangle inequality, foci paired either
    way: min(|tx_g - tx_f| + |rx_g - rx_f|, |tx_g - rx_f| + |rx_g - tx_f|)); ``near (G,)``: h_g >= |tx_g - rx_g|
    everywhere; ``far (G,)``: h_g <= far[g] inside the area (h_g is convex: its maximum on the rectangle is at a
    corner).
    """
    G = gtx.shape[0]
    focal = np.empty((G, G))
    near = np.empty(G)
    far = np.empty(G)
    for g in range(G):
        near[g] = math.hypot(gtx[g, 0] - grx[g, 0], gtx[g, 1] - grx[g, 1])
        far[g] = 0.0
        for cx in (area[0], area[1]):
            for cy in (area[2], area[3]):
                h = math.hypot(cx - gtx[g, 0], cy - gtx[g, 1]) + math.hypot(cx - grx[g, 0], cy - grx[g, 1])
                far[g] = max(far[g], h)
        for f in range(G):
            same = math.hypot(gtx[g, 0] - gtx[f, 0], gtx[g, 1] - gtx[f, 1]) + math.hypot(
                grx[g, 0] - grx[f, 0], grx[g, 1] - grx[f, 1]
            )
            crossed = math.hypot(gtx[g, 0] - grx[f, 0], gtx[g, 1] - grx[f, 1]) + math.hypot(
                grx[g, 0] - gtx[f, 0], grx[g, 1] - gtx[f, 1]
            )
            focal[g, f] = min(same, crossed)
    return focal, near, far


@_jit
def _residual_lower_bound(r, v, members, focal, near, far):  # pragma: no cover - compiled
    """A lower bound on min over the area of the tuple's cost sum_k (r_k - h_k(p))^2 / v_k (nu = 2 or 3).

    One range alone: h_k in [near, far] over the area, so its term is >= dist(r_k, [near, far])^2 / v_k. Two ranges
    k, l: |h_k - h_l| <= focal, so |res_k - res_l| >= m = |r_k - r_l| - focal, and min a^2 / v_k + b^2 / v_l
    subject to |a - b| >= m > 0 is m^2 / (v_k + v_l). The cost is a sum of its terms, so any partition of the
    tuple into a pair and a single (or three singles) bounds it; the largest is returned. A tuple whose Gauss-Newton
    fit ``Tracker._initiate`` keeps (inside the area, cost <= the residual bound) has a bound below that residual
    bound, so rejecting the others changes nothing (tests/unit/test_initiation_speed.py).
    """
    nu = r.shape[0]
    s0 = _single_bound(r[0], v[0], near[members[0]], far[members[0]])
    s1 = _single_bound(r[1], v[1], near[members[1]], far[members[1]])
    s2 = _single_bound(r[2], v[2], near[members[2]], far[members[2]]) if nu == 3 else 0.0
    p01 = _pair_bound(r[0], v[0], r[1], v[1], focal[members[0], members[1]])
    if nu == 2:
        return max(s0 + s1 + s2, p01 + s2)
    p02 = _pair_bound(r[0], v[0], r[2], v[2], focal[members[0], members[2]])
    p12 = _pair_bound(r[1], v[1], r[2], v[2], focal[members[1], members[2]])
    return _partition_bound(s0, s1, s2, p01, p02, p12)


@_jit
def _partition_bound(s0, s1, s2, p01, p02, p12):  # pragma: no cover - compiled
    """A 3-tuple's bound from its terms: the largest over its partitions, three singles or a pair and a single."""
    best = s0 + s1 + s2
    best = max(best, p01 + s2)
    best = max(best, p02 + s1)
    return max(best, p12 + s0)


@_jit
def _bound_terms(rs, vs, counts, a, b, c, focal, near, far):  # pragma: no cover - compiled
    """:func:`_residual_lower_bound`'s terms for the 3-subset of groups (a, b, c), per detection and pair of them.

    Returns the single terms ``(n_a,)``, ``(n_b,)``, ``(n_c,)``, the pair terms ``(n_a, n_b)``, ``(n_a, n_c)``,
    ``(n_b, n_c)`` (the same functions of the same numbers, so a tuple's bound from them has the same bits) and
    whether all are finite (then every term is >= 0 and a tuple's bound is >= each term and each sum of two singles:
    a detection or pair above the threshold rules out every tuple with it).
    """
    na, nb, nc = counts[a], counts[b], counts[c]
    sa, sb, sc = np.empty(na), np.empty(nb), np.empty(nc)
    for i in range(na):
        sa[i] = _single_bound(rs[a, i], vs[a, i], near[a], far[a])
    for j in range(nb):
        sb[j] = _single_bound(rs[b, j], vs[b, j], near[b], far[b])
    for h in range(nc):
        sc[h] = _single_bound(rs[c, h], vs[c, h], near[c], far[c])
    pab, pac, pbc = np.empty((na, nb)), np.empty((na, nc)), np.empty((nb, nc))
    for i in range(na):
        for j in range(nb):
            pab[i, j] = _pair_bound(rs[a, i], vs[a, i], rs[b, j], vs[b, j], focal[a, b])
        for h in range(nc):
            pac[i, h] = _pair_bound(rs[a, i], vs[a, i], rs[c, h], vs[c, h], focal[a, c])
    for j in range(nb):
        for h in range(nc):
            pbc[j, h] = _pair_bound(rs[b, j], vs[b, j], rs[c, h], vs[c, h], focal[b, c])
    finite = (
        np.isfinite(sa).all() and np.isfinite(sb).all() and np.isfinite(sc).all()
        and np.isfinite(pab).all() and np.isfinite(pac).all() and np.isfinite(pbc).all()
    )  # fmt: skip
    return sa, sb, sc, pab, pac, pbc, finite


@_jit
def _single_bound(r, v, near, far):  # pragma: no cover - compiled
    """One range's term bound: dist(r, [near, far])^2 / v (:func:`_residual_lower_bound`)."""
    d = near - r if r < near else (r - far if r > far else 0.0)
    return d * d / v


@_jit
def _pair_bound(r_k, v_k, r_l, v_l, focal):  # pragma: no cover - compiled
    """Two ranges' terms bound: max(|r_k - r_l| - focal, 0)^2 / (v_k + v_l) (:func:`_residual_lower_bound`)."""
    m = abs(r_k - r_l) - focal
    return m * m / (v_k + v_l) if m > 0.0 else 0.0


@_jit
def _same_bits(a, b):  # pragma: no cover - compiled
    """Whether a and b are the same float (``==`` with the sign of zero; NaN never)."""
    return a == b and math.copysign(1.0, a) == math.copysign(1.0, b)


@_jit
def gauss_newton_exact(ranges, w, tx, rx, px, py, n_iter):  # pragma: no cover - compiled
    """``localization.compiled._gauss_newton`` from (px, py), stopped early where that changes no bit.

    The iteration p_{i+1} = p_i + (A_i + reg I)^-1 g_i is a fixed function of p_i, so once p_{i+1} == p_i every later
    p is p_i, and once p_{i+1} == p_{i-1} the sequence alternates with period 2 and p_n is p_{i-1} or p_i by the
    parity of n - i. Either way the n_iter-th point is known, and its sums were evaluated already (the sums are a
    fixed function of p too). Returns ``(x, y, cost, A00, A01, A11, iterations run)``.
    """
    ox = oy = np.nan
    o00 = o01 = o11 = ocost = np.nan  # the sums at p_{it-1}
    it = 0
    while it < n_iter:
        a00, a01, a11, g0, g1, cost = normal_equations(ranges, w, tx, rx, px, py)
        reg = 1e-9 * (a00 + a11 + 1e-12)
        b00, b11 = a00 + reg, a11 + reg
        det = b00 * b11 - a01 * a01
        nx = px + (b11 * g0 - a01 * g1) / det
        ny = py + (b00 * g1 - a01 * g0) / det
        if _same_bits(nx, px) and _same_bits(ny, py):
            return px, py, cost, a00, a01, a11, it  # a fixed point: p_n = p_it, whose sums are these
        if _same_bits(nx, ox) and _same_bits(ny, oy):  # p_{it+1} = p_{it-1}: a 2-cycle
            if (n_iter - it) % 2 == 1:
                return ox, oy, ocost, o00, o01, o11, it
            return px, py, cost, a00, a01, a11, it
        ox, oy, o00, o01, o11, ocost = px, py, a00, a01, a11, cost
        px, py = nx, ny
        it += 1
    a00, a01, a11, _, _, cost = normal_equations(ranges, w, tx, rx, px, py)
    return px, py, cost, a00, a01, a11, it


@_jit
def _best_fit(ranges, w, tx, rx, starts, n_iter):  # pragma: no cover - compiled
    """One tuple's fit from every start: the least cost's ``(x, y, cost, A00, A01, A11)`` (the first of equals).

    ``ellipse_intersection``'s choice of start, before its covariance.
    """
    bc = np.inf
    bx = by = i00 = i01 = i11 = 0.0
    for s in range(starts.shape[0]):
        x, y, c, a00, a01, a11, _ = gauss_newton_exact(ranges, w, tx, rx, starts[s, 0], starts[s, 1], n_iter)
        if c < bc:
            bc, bx, by, i00, i01, i11 = c, x, y, a00, a01, a11
    return bx, by, bc, i00, i01, i11


@_jit
def _range_only_candidates(rs, vs, counts, gtx, grx, nu, area, starts, residual_max):  # pragma: no cover
    """:func:`range_only_candidates` of one environment's groups (ranges ``rs[g, :counts[g]]``), compiled.

    Same rows in the same order: the nu-subsets of groups in lexicographic order, each one's detection tuples in
    ``meshgrid(..., indexing="ij")`` order; two receivers of one transmitter by the closed form
    (``two_ellipse_intersections``), otherwise Gauss-Newton (``ellipse_intersection``) with the residual test.
    The Gauss-Newton rows give the same bits as ``ellipse_intersection`` on every tuple with fewer operations:
    tuples whose cost cannot reach the residual bound anywhere in the area (:func:`_residual_lower_bound`) are
    rejected before the fit, and each start stops at an exact fixed point or 2-cycle (:func:`gauss_newton_exact`).
    """
    G = counts.shape[0]
    combos = []
    if nu == 2:
        for a in range(G):
            for b in range(a + 1, G):
                combos.append((a, b, -1))  # noqa: PERF401 (a typed numba list)
    else:
        for a in range(G):
            for b in range(a + 1, G):
                for c in range(b + 1, G):
                    combos.append((a, b, c))  # noqa: PERF401 (a typed numba list)
    shared = nu == 2
    if shared:
        for a, b, _ in combos:
            if gtx[a, 0] != gtx[b, 0] or gtx[a, 1] != gtx[b, 1]:
                shared = False
    n_rows = 0
    for a, b, c in combos:
        n_rows += counts[a] * counts[b] * (counts[c] if c >= 0 else 1)
    if shared:
        ps = np.empty((2 * n_rows, 2))
        cs = np.empty((2 * n_rows, 2, 2))
        k = 0
        for a, b, _ in combos:
            n = counts[a] * counts[b]
            q = np.empty((n, 2))
            v = np.empty((n, 2))
            for i in range(counts[a]):
                for j in range(counts[b]):
                    q[i * counts[b] + j, 0], q[i * counts[b] + j, 1] = rs[a, i], rs[b, j]
                    v[i * counts[b] + j, 0], v[i * counts[b] + j, 1] = vs[a, i], vs[b, j]
            rx = np.empty((2, 2))
            rx[0], rx[1] = grx[a], grx[b]
            p, cov, ok = two_ellipse_intersections(q, v, gtx[a].copy(), rx)
            for n_ in range(n):
                for s in range(2):
                    if ok[n_, s] and _inside(p[n_, s], area):
                        ps[k] = p[n_, s]
                        cs[k] = cov[n_, s]
                        k += 1
        return ps[:k], cs[:k]
    # Gauss-Newton on each tuple that the residual's lower bound does not rule out (module docstring)
    focal, near, far = _gate_constants(gtx, grx, area)
    threshold = residual_max * (1.0 + _GATE_MARGIN) if nu > 2 else np.inf  # nu = 2: no residual test
    ps = np.empty((n_rows, 2))
    cs = np.empty((n_rows, 2, 2))
    r = np.empty(nu)
    w = np.empty(nu)
    v = np.empty(nu)
    t = np.empty((nu, 2))
    x = np.empty((nu, 2))
    members = np.empty(nu, np.int64)
    k = 0
    for a, b, c in combos:
        members[0], members[1] = a, b
        if c >= 0:
            members[2] = c
        for q in range(nu):  # the subset's nodes (the same for each of its tuples)
            for d in range(2):
                t[q, d], x[q, d] = gtx[members[q], d], grx[members[q], d]
        nc = counts[c] if c >= 0 else 1
        if nu == 3:  # the bound's terms, once per detection and detection pair (_bound_terms)
            sa, sb, sc, pab, pac, pbc, finite = _bound_terms(rs, vs, counts, a, b, c, focal, near, far)
        else:  # nu = 2: no residual test
            sa = sb = sc = np.zeros(0)
            pab = pac = pbc = np.zeros((0, 0))
            finite = False
        for i in range(counts[a]):
            if nu == 3 and finite and sa[i] > threshold:
                continue  # every tuple with this detection: its bound >= sa[i] (terms >= 0, finite)
            for j in range(counts[b]):
                if nu == 3 and finite and (pab[i, j] > threshold or sa[i] + sb[j] > threshold):
                    continue  # every tuple with these two: its bound >= either
                for h in range(nc):
                    r[0], v[0] = rs[a, i], vs[a, i]
                    r[1], v[1] = rs[b, j], vs[b, j]
                    if c >= 0:
                        r[2], v[2] = rs[c, h], vs[c, h]
                    # nu = 2: no residual test (threshold inf: no bound exceeds it)
                    if nu == 3:  # _residual_lower_bound from its terms: the same operations, the same bits
                        bound = _partition_bound(sa[i], sb[j], sc[h], pab[i, j], pac[i, h], pbc[j, h])
                        if bound > threshold:
                            continue  # no point of the area meets the ranges within the residual bound
                    for q in range(nu):
                        w[q] = 1.0 / v[q]
                    px, py, cost, i00, i01, i11 = _best_fit(r, w, t, x, starts, 15)
                    if not (_xy_inside(px, py, area) and (nu == 2 or cost <= residual_max)):
                        continue
                    reg = 1e-9 * (i00 + i11 + 1e-12)  # ellipse_intersection's covariance, same operations
                    i00 += reg
                    i11 += reg
                    det = i00 * i11 - i01 * i01
                    ps[k, 0], ps[k, 1] = px, py
                    cs[k, 0, 0], cs[k, 0, 1], cs[k, 1, 0], cs[k, 1, 1] = i11 / det, -i01 / det, -i01 / det, i00 / det
                    k += 1
    return ps[:k], cs[:k]


@_jit
def range_only_initiation(
    z, R, snr, free, group_start, group_tx, group_rx, env_group_start, rr, cap, max_rr_sq, per_rx, area, starts,
    residual_max, extra_p, extra_cov, extra_start, prev_p, prev_cov, prev_start, dts, max_spread, gate2, max_speed,
    accel_std,
):  # pragma: no cover - compiled  # fmt: skip
    """``Tracker._initiate`` of several environments in one call (the single tracker: E = 1).

    The unused detections of every environment are concatenated: pair-group g owns rows
    ``group_start[g]:group_start[g + 1]`` of z ``(M, m)``, R, snr and free ``(M,)``, with its transmitter and receiver
    positions ``group_tx[g]``, ``group_rx[g]`` ``(2,)`` and its range-rate column ``rr[g]``; environment e owns the
    groups ``env_group_start[e]:env_group_start[e + 1]`` (those with a free detection) and the previous scan's
    unpaired candidates ``prev_start[e]:prev_start[e + 1]`` of prev_p, prev_cov, ``dts[e]`` after them.
    ``per_rx[nu]`` the detections kept per receiver for nu-tuples, ``residual_max`` the chi-square residual bound of
    3-tuples; ``extra_start[e]:extra_start[e + 1]`` of extra_p ``(K, 2)``, extra_cov ``(K, 2, 2)`` environment e's
    candidates of other kinds (array receivers, fused positions: ``Tracker._initiate``), placed before its
    range-only ones; the rest as ``compiled.initiate``.

    Returns: the new tracks' x ``(n, 6)``, P ``(n, 6, 6)`` with env offsets ``(E + 1,)``, and the unpaired
    candidates ``(C, 2)``, ``(C, 2, 2)`` with env offsets.
    """
    E = env_group_start.shape[0] - 1
    xs = []
    Ps = []
    rest_p = []
    rest_c = []
    for e in range(E):
        g0, g1 = env_group_start[e], env_group_start[e + 1]
        G = g1 - g0
        pr = np.zeros((0, 2))
        cr = np.zeros((0, 2, 2))
        if G >= 2:
            nu = min(3, G)
            rs = np.empty((G, cap))
            vs = np.empty((G, cap))
            counts = np.empty(G, np.int64)
            for g in range(G):
                n = _ordered_ranges(
                    z, R, snr, free, group_start[g0 + g], group_start[g0 + g + 1], rr[g0 + g], cap, max_rr_sq,
                    rs[g], vs[g],
                )  # fmt: skip
                counts[g] = min(n, per_rx[nu])
            pr, cr = _range_only_candidates(
                rs, vs, counts, group_tx[g0:g1], group_rx[g0:g1], nu, area, starts, residual_max
            )
        k0, k1 = extra_start[e], extra_start[e + 1]
        p = np.empty((k1 - k0 + pr.shape[0], 2))
        cov = np.empty((k1 - k0 + pr.shape[0], 2, 2))
        p[: k1 - k0] = extra_p[k0:k1]
        cov[: k1 - k0] = extra_cov[k0:k1]
        p[k1 - k0 :] = pr
        cov[k1 - k0 :] = cr
        a0, a1 = prev_start[e], prev_start[e + 1]
        x, P, rp, rc = initiate(
            p, cov, prev_p[a0:a1], prev_cov[a0:a1], dts[e], area, max_spread, cap, gate2, max_speed, accel_std
        )
        xs.append(x)
        Ps.append(P)
        rest_p.append(rp)
        rest_c.append(rc)
    return _stack(xs, Ps, 6), _stack(rest_p, rest_c, 2)


@_jit
def _stack(means, covs, d):  # pragma: no cover - compiled
    """Concatenate per-environment ``(n_e, d)``, ``(n_e, d, d)`` arrays; returns them and the env offsets."""
    start = np.zeros(len(means) + 1, np.int64)
    for e in range(len(means)):
        start[e + 1] = start[e] + means[e].shape[0]
    m = np.empty((start[-1], d))
    c = np.empty((start[-1], d, d))
    for e in range(len(means)):
        m[start[e] : start[e + 1]] = means[e]
        c[start[e] : start[e + 1]] = covs[e]
    return m, c, start
