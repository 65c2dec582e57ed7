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
      its normalised residual passes the chi-square test; covariance (J^T V^-1 J)^-1.
For chirps the range is the ridge-corrected one, r - (R_rd / R_dd) rdot, whose variance R_rr - R_rd^2 / R_dd is
the delay-Doppler ridge's (see uwb_env.sensing): the single-chirp range-rate is too coarse to use otherwise.

Candidates less precise than ``max_std`` are dropped (they could only start tracks whose gates swallow others'
detections). Candidates of one scan that are the same point seen by two receivers (mutual nearest neighbours
within the gate) are fused, information-weighted. Two-point differencing (seed 003 section 4.2.1) pairs a
candidate with one of the previous scan's when each velocity component satisfies |dx / T| <= v_max + 2 sigma_v.
"""

from __future__ import annotations

import itertools

import numpy as np
from scipy.stats import chi2

from uwb_env.localization.compiled import ellipse_intersection_fast, two_ellipse_intersections
from uwb_env.typing import BoolArray, FloatArray


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
