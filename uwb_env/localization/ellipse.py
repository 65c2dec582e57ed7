r"""Least-squares intersection of iso-range ellipses (seed 000 section V-A).

A detection of pair (t, r_i) with bistatic range q_i puts the target on the ellipse |z - t| + |z - r_i| = q_i
(eq. 16). Two solvers, both batched over tuples:

* :func:`ls_ellipse_intersection`, the seed's closed form for receivers sharing one transmitter. With coordinates
  centred on the transmitter (r_i' = r_i - t), squaring eq. 16 gives eq. 17 in the form
      |z| = (q_i^2 - |r_i'|^2) / (2 q_i) + (r_i' / q_i) . z,
  and subtracting the equation of a reference receiver k removes the unknown |z| (eqs. 19-21):
      (r_i' / q_i - r_k' / q_k) . z = (q_k^2 - |r_k'|^2) / (2 q_k) - (q_i^2 - |r_i'|^2) / (2 q_i),
  nu - 1 linear equations A z = g (eq. 22) solved by least squares (eq. 23). The seed multiplies each row by
  q_i q_k (A in m^2, g in m^3); we keep the rows divided by it, so every row's residual is a difference of two
  estimates of |z| in metres. The seed's residual error ||A z - g|| (eq. 25) is identically zero for nu = 3 (A is
  square), so as the reliability measure we take the RMS residual of the ellipse equations themselves at the
  solution, sqrt(mean_i (|z - t| + |z - r_i| - q_i)^2) [m], which is zero only when all nu ellipses meet there.
* :func:`ellipse_intersection`, Gauss-Newton weighted least squares on the ranges for any transmitters and
  receivers (used by track initiation), with the covariance (J^T V^-1 J)^-1.
"""

from __future__ import annotations

import numpy as np

from uwb_env.typing import FloatArray


def ls_ellipse_intersection(q: FloatArray, rx: FloatArray, tx: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The seed's closed-form LS position of each tuple and its ellipse residual.

    Args:
        q: ``(M, nu)`` bistatic ranges [m]; rx: ``(M, nu, 2)`` or ``(nu, 2)`` receiver positions; tx: ``(2,)``.

    Returns:
        positions ``(M, 2)`` [m]; residual ``(M,)`` [m] (module docstring; nan where the geometry is singular).
    """
    q = np.asarray(q, dtype=float)
    t = np.asarray(tx, dtype=float)
    r = np.broadcast_to(np.asarray(rx, dtype=float) - t, (*q.shape, 2))
    c = (q * q - np.sum(r * r, axis=-1)) / (2.0 * q)  # (M, nu)
    u = r / q[..., None]  # (M, nu, 2)
    A = u[:, 1:] - u[:, :1]  # (M, nu - 1, 2), reference k = the tuple's first receiver
    g = c[:, :1] - c[:, 1:]
    AtA = np.einsum("mki,mkj->mij", A, A)
    Atg = np.einsum("mki,mk->mi", A, g)
    det = AtA[:, 0, 0] * AtA[:, 1, 1] - AtA[:, 0, 1] * AtA[:, 1, 0]
    scale = np.maximum(AtA[:, 0, 0] * AtA[:, 1, 1], 1e-300)
    ok = np.abs(det) > 1e-12 * scale
    safe = np.where(ok, det, 1.0)
    z = np.stack(
        [
            (AtA[:, 1, 1] * Atg[:, 0] - AtA[:, 0, 1] * Atg[:, 1]) / safe,
            (AtA[:, 0, 0] * Atg[:, 1] - AtA[:, 1, 0] * Atg[:, 0]) / safe,
        ],
        axis=-1,
    )
    res = np.linalg.norm(z[:, None], axis=-1) + np.linalg.norm(z[:, None] - r, axis=-1) - q
    residual = np.where(ok, np.sqrt(np.mean(res * res, axis=-1)), np.nan)
    return z + t, residual


def ellipse_intersection(
    ranges: FloatArray, variances: FloatArray, tx: FloatArray, rx: FloatArray, starts: FloatArray, n_iter: int = 15
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Weighted least-squares (Gauss-Newton) intersection of iso-range ellipses, batched over tuples.

    Args:
        ranges, variances: ``(N, nu)`` bistatic ranges [m] and variances of each tuple; tx, rx: ``(N, nu, 2)`` the
        nodes of each range; starts: ``(S, 2)`` initial points tried for every tuple.

    Returns:
        position ``(N, 2)``, covariance ``(N, 2, 2)`` = (J^T V^-1 J)^-1, normalised residual ``(N,)`` (chi-square
        with nu - 2 degrees of freedom if the model holds).
    """
    N = ranges.shape[0]
    p = np.broadcast_to(starts[None], (N, starts.shape[0], 2)).copy()  # (N, S, 2)
    w = 1.0 / variances[:, None, :]  # (N, 1, nu)

    def residual_and_jacobian(p: FloatArray) -> tuple[FloatArray, FloatArray]:
        dt = p[:, :, None, :] - tx[:, None]  # (N, S, nu, 2)
        dr = p[:, :, None, :] - rx[:, None]
        lt = np.maximum(np.linalg.norm(dt, axis=-1), 1e-9)
        lr = np.maximum(np.linalg.norm(dr, axis=-1), 1e-9)
        res = ranges[:, None, :] - (lt + lr)
        J = dt / lt[..., None] + dr / lr[..., None]  # d h / d p
        return res, J

    for _ in range(n_iter):  # fixed Gauss-Newton iterations, batched over tuples and starts
        res, J = residual_and_jacobian(p)
        A = np.einsum("nsk,nski,nskj->nsij", np.broadcast_to(w, res.shape), J, J)
        A = A + 1e-9 * (np.trace(A, axis1=-2, axis2=-1)[..., None, None] + 1e-12) * np.eye(2)  # degenerate geometry
        g = np.einsum("nsk,nski,nsk->nsi", np.broadcast_to(w, res.shape), J, res)
        p = p + np.linalg.solve(A, g[..., None])[..., 0]
    res, J = residual_and_jacobian(p)
    cost = np.sum(res**2 * w, axis=-1)  # (N, S)
    best = np.argmin(cost, axis=1)
    idx = np.arange(N)
    Jb = J[idx, best]
    info = np.einsum("nk,nki,nkj->nij", w[:, 0], Jb, Jb)
    # relative regularisation: a degenerate geometry (parallel gradients) yields a huge, not singular, covariance
    info = info + 1e-9 * (np.trace(info, axis1=-2, axis2=-1)[:, None, None] + 1e-12) * np.eye(2)
    return p[idx, best], np.linalg.inv(info), cost[idx, best]
