r"""Direct localization from ToA couples of a linear array (seed 001 section 2), with wall-effect compensation.

Seed 001's handheld radar has one transmitter and two receivers on a line; with one ToA per receiver a target is the
intersection of two ellipses (the "noniterative direct method" of its [18]), and the walls' delay is removed from the
ToAs first (its "wall effect compensation" phase).

Ellipse intersection (:func:`couple_positions`): with the transmitter T as origin, the array's unit vector e and the
unit normal n towards the monitored side, receiver k at T + beta_k e, and bistatic ranges r_k (= c TOA_k), the
target u = x e + y n at distance rho = |u| from T satisfies |u - beta_k e| = r_k - rho; squaring,

.. math:: 2 \beta_k x - 2 r_k \rho = \beta_k^2 - r_k^2,\qquad k = 1, 2,

two linear equations in (x, rho), so x and rho in closed form and y = +sqrt(rho^2 - x^2) on the monitored side (the
array's mirror image behind it is the other root, discarded). A couple has no intersection (and is dropped) when
rho^2 < x^2, rho <= 0 or r_k < rho.

Wall compensation (:func:`compensate_walls`): our walls (:mod:`uwb_env.channel.walls`, seed 002 section II-D) add
a fixed excess delay tau_w per crossing of a leg, whatever the angle, so the ToA of pair k is biased by the delay of
the walls that the legs T -> target and target -> Rx_k cross: r_k = |p - T| + |p - R_k| + c (tau_T(p) + tau_k(p)).
The crossings are those of a first estimate p_0 (the uncompensated intersection); subtracting them,
r'_k = r_k - c (tau_T(p_0) + tau_k(p_0)), and intersecting again is exact whenever p and p_0 lie on the same side
of every wall -- for seed 001's geometry (a wall parallel to the array, every target behind it) r'_k = r_k - 2 c
tau_w. The seed's own compensation ("target trace correction of the 2nd kind", its [17]) derives the delay from the
wall's permittivity and thickness at each incidence angle; with our angle-independent wall model it reduces to the
above.
"""

from __future__ import annotations

import numpy as np

from uwb_env.channel.walls import leg_crossings, leg_obstruction
from uwb_env.constants import SPEED_OF_LIGHT_MPS
from uwb_env.typing import BoolArray, FloatArray


def array_frame(tx: FloatArray, rx1: FloatArray, rx2: FloatArray, toward: FloatArray) -> tuple[FloatArray, ...]:
    """Frame of a linear array: ``(e (2,), n (2,), beta (2,))``; n points to the half-plane holding ``toward``.

    Args: tx, rx1, rx2, toward: ``(2,)`` [m]. beta: the receivers' signed offsets along e from the transmitter [m].
    """
    tx, rx1, rx2 = (np.asarray(v, dtype=float) for v in (tx, rx1, rx2))
    e = rx2 - rx1
    e = e / np.linalg.norm(e)
    n = np.array([-e[1], e[0]])
    if np.dot(np.asarray(toward, dtype=float) - tx, n) < 0.0:
        n = -n
    return e, n, np.array([np.dot(rx1 - tx, e), np.dot(rx2 - tx, e)])


def couple_positions(
    r1: FloatArray, r2: FloatArray, tx: FloatArray, e: FloatArray, n: FloatArray, beta: FloatArray
) -> tuple[FloatArray, BoolArray]:
    """Intersections ``(L, 2)`` [m] and validity ``(L,)`` of the ellipse couples ``(r1, r2)`` ``(L,)`` [m].

    ``tx`` ``(2,)``, ``e``, ``n``, ``beta`` from :func:`array_frame`. Invalid couples (no intersection) get nan.
    """
    r1, r2 = np.asarray(r1, dtype=float), np.asarray(r2, dtype=float)
    b1, b2 = float(beta[0]), float(beta[1])
    det = 4.0 * (b2 * r1 - b1 * r2)
    c1, c2 = b1 * b1 - r1 * r1, b2 * b2 - r2 * r2
    ok = np.abs(det) > 1e-12
    safe = np.where(ok, det, 1.0)
    x = (-2.0 * r2 * c1 + 2.0 * r1 * c2) / safe
    rho = (2.0 * b1 * c2 - 2.0 * b2 * c1) / safe
    y2 = rho * rho - x * x
    valid = ok & (y2 >= 0.0) & (rho > 0.0) & (r1 >= rho) & (r2 >= rho)
    y = np.sqrt(np.where(valid, y2, 0.0))
    p = np.asarray(tx, dtype=float) + x[:, None] * e + y[:, None] * n
    return np.where(valid[:, None], p, np.nan), valid


def compensate_walls(
    r: FloatArray,
    p0: FloatArray,
    tx: FloatArray,
    rx: FloatArray,
    wall_a: FloatArray,
    wall_b: FloatArray,
    wall_delay_s: FloatArray,
) -> FloatArray:
    """Ranges ``r`` ``(L, R)`` [m] less the walls' excess delay on the legs to first estimates ``p0`` ``(L, 2)``.

    ``tx`` ``(2,)``, ``rx`` ``(R, 2)`` the couple's receivers, walls ``(W, 2)`` ends and ``(W,)`` delays [s].
    Returns ``(L, R)`` r_k - c (tau_T(p0) + tau_k(p0)) (module docstring); rows with nan ``p0`` unchanged.
    """
    r = np.asarray(r, dtype=float)
    if wall_a.shape[0] == 0 or r.shape[0] == 0:
        return r.copy()
    finite = np.all(np.isfinite(p0), axis=-1)
    p = np.where(finite[:, None], p0, 0.0)
    zero = np.zeros(wall_delay_s.shape)
    _, d_tx = leg_obstruction(leg_crossings(np.asarray(tx, dtype=float)[None], p, wall_a, wall_b), zero, wall_delay_s)
    _, d_rx = leg_obstruction(leg_crossings(rx, p, wall_a, wall_b), zero, wall_delay_s)  # (R, L)
    delay = d_tx[0][:, None] + d_rx.T  # (L, R)
    return np.where(finite[:, None], r - SPEED_OF_LIGHT_MPS * delay, r)


def couple_covariance(
    p: FloatArray, tx: FloatArray, rx: FloatArray, range_var_m2: float, common_var_m2: float = 0.0
) -> FloatArray:
    """``(L, 2, 2)`` position covariance J^-1 Sigma_r J^-T of couples at ``p`` ``(L, 2)``; ``rx`` ``(2, 2)``.

    J's rows are the gradients of the two bistatic ranges, (p - T)/|p - T| + (p - R_k)/|p - R_k|; the ranges'
    error covariance Sigma_r = ``range_var_m2`` I + ``common_var_m2`` 1 1^T (independent parts, and a part common to
    both receivers -- the same body surface seen by both -- that moves the position down-range only); with no common
    part it is sigma_r^2 (J^T J)^-1.
    """
    dt = p - np.asarray(tx, dtype=float)
    ut = dt / np.maximum(np.linalg.norm(dt, axis=-1, keepdims=True), 1e-9)
    dr = p[:, None] - rx[None]  # (L, 2, 2)
    J = ut[:, None] + dr / np.maximum(np.linalg.norm(dr, axis=-1, keepdims=True), 1e-9)
    info = np.einsum("lki,lkj->lij", J, J)
    info = info + 1e-9 * (np.trace(info, axis1=-2, axis2=-1)[:, None, None] + 1e-12) * np.eye(2)
    cov = range_var_m2 * np.linalg.inv(info)
    if common_var_m2 > 0.0:  # J^-1 1 1^T J^-T = g g^T with J g = 1
        g = np.linalg.solve(info, np.einsum("lki,lk->li", J, np.ones(J.shape[:2]))[..., None])[..., 0]
        cov = cov + common_var_m2 * g[:, :, None] * g[:, None, :]
    return cov
