r"""Batched filter kernels (arrays in, arrays out, no state), over any leading batch axes.

Shapes: states ``x (..., n)``, covariances ``P (..., n, n)``, measurements ``(..., m)``; row-vector convention.

Prediction is exact Kalman (the motion models are linear). A nonlinear measurement is summarised by its predicted
mean ``z_hat``, its covariance without the noise ``S0`` and the state-measurement cross-covariance ``C``, from
either the unscented transform (Julier-Uhlmann sigma points, seed 003 section 4.2.3) or the EKF linearisation.
Updates are the linear-MMSE (Kalman) update P+ = P - K S K^T, K = C S^-1, S = S0 + R, written in Joseph form
with the (statistically) linearised H = C^T P^-1 and the linearisation error Omega = S0 - H P H^T
(= S0 - C^T P^-1 C) counted as measurement noise (:func:`joseph_update`): for the EKF H is the Jacobian, Omega = 0
and this is the textbook Joseph form; for the UKF, Omega is the part of the unscented S0 that H does not explain
(positive semi-definite with non-negative covariance weights, as :class:`UnscentedWeights`' defaults: the Schur
complement of the sigma points' weighted Gram matrix [[P, C], [C^T, S0]]).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from uwb_env.tracking.measurement import measure, wrap_residual
from uwb_env.typing import FloatArray


def symmetrise(P: FloatArray) -> FloatArray:
    """(P + P^T) / 2 over the last two axes."""
    return 0.5 * (P + np.swapaxes(P, -1, -2))


def kf_predict(x: FloatArray, P: FloatArray, F: FloatArray, Q: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Kalman prediction: x F^T, F P F^T + Q; F and Q broadcast against the batch axes of x (..., n), P (..., n, n)."""
    xp = np.einsum("...ij,...j->...i", F, x)
    Pp = F @ P @ np.swapaxes(F, -1, -2) + Q
    return xp, symmetrise(Pp)


@dataclass(frozen=True, slots=True)
class UnscentedWeights:
    """Scaled unscented transform weights (Julier-Uhlmann; alpha = 1, beta = 2, kappa = 0 by default).

    With alpha = 1 and kappa = 0 the central mean weight is 0 and every covariance weight is >= 0, so the
    transformed covariance is always positive semi-definite (the original kappa = 3 - n is negative for n = 6).
    """

    n: int
    alpha: float = 1.0
    beta: float = 2.0
    kappa: float = 0.0

    @property
    def lam(self) -> float:
        """Lambda = alpha^2 (n + kappa) - n."""
        return self.alpha**2 * (self.n + self.kappa) - self.n

    @property
    def mean(self) -> FloatArray:
        """``(2n + 1,)`` mean weights."""
        w = np.full(2 * self.n + 1, 0.5 / (self.n + self.lam))
        w[0] = self.lam / (self.n + self.lam)
        return w

    @property
    def cov(self) -> FloatArray:
        """``(2n + 1,)`` covariance weights."""
        w = self.mean.copy()
        w[0] += 1.0 - self.alpha**2 + self.beta
        return w


def sigma_points(x: FloatArray, P: FloatArray, weights: UnscentedWeights) -> FloatArray:
    """``(..., 2n + 1, n)`` sigma points x, x +- sqrt(n + lambda) L_i, L the Cholesky factor of P."""
    n = x.shape[-1]
    L = np.linalg.cholesky(P) * np.sqrt(n + weights.lam)
    Lt = np.swapaxes(L, -1, -2)  # rows are the columns of L
    return np.concatenate([x[..., None, :], x[..., None, :] + Lt, x[..., None, :] - Lt], axis=-2)


def _circular_mean(z: FloatArray, w: FloatArray, angular: np.ndarray) -> FloatArray:
    zm = w @ z
    if angular.any():
        za = z[..., angular]
        zm[..., angular] = np.arctan2(w @ np.sin(za), w @ np.cos(za))
    return zm


def ukf_moments(
    names: tuple[str, ...],
    x: FloatArray,
    P: FloatArray,
    tx: FloatArray,
    rx: FloatArray,
    weights: UnscentedWeights,
    angular: np.ndarray,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Unscented ``(z_hat (..., m), S0 (..., m, m), C (..., n, m))`` of the named measurement."""
    chi = sigma_points(x, P, weights)
    Z, _ = measure(names, chi, tx, rx)
    z_hat = _circular_mean(Z, weights.mean, angular)
    dZ = wrap_residual(Z - z_hat[..., None, :], angular)
    dX = chi - x[..., None, :]
    wdZ = dZ * weights.cov[:, None]
    S0 = np.swapaxes(dZ, -1, -2) @ wdZ
    C = np.swapaxes(dX, -1, -2) @ wdZ
    return z_hat, symmetrise(S0), C


def ekf_moments(
    names: tuple[str, ...], x: FloatArray, P: FloatArray, tx: FloatArray, rx: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Linearised ``(z_hat, S0 = H P H^T, C = P H^T)`` of the named measurement."""
    z_hat, H = measure(names, x, tx, rx)
    C = P @ np.swapaxes(H, -1, -2)
    return z_hat, symmetrise(H @ C), C


def linearised_h(P: FloatArray, C: FloatArray) -> FloatArray:
    """Statistically linearised measurement matrix H = C^T P^-1 ``(..., m, n)`` (the Jacobian for the EKF)."""
    return np.swapaxes(np.linalg.solve(P, C), -1, -2)


def linearisation_error(S0: FloatArray, C: FloatArray, H: FloatArray) -> FloatArray:
    """Omega = S0 - H C = S0 - C^T P^-1 C ``(..., m, m)``, symmetrised, for H = C^T P^-1 (:func:`linearised_h`).

    The measurement covariance the statistically linearised H leaves unexplained: 0 (to rounding) for the EKF,
    where S0 = H P H^T; for the UKF the unscented transform's linearisation error, positive semi-definite.
    """
    return symmetrise(S0 - H @ C)


def joseph_update(
    x: FloatArray,
    P: FloatArray,
    C: FloatArray,
    S0: FloatArray,
    R: FloatArray,
    nu: FloatArray,
    H: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray]:
    """Single-measurement Kalman update P+ = P - K S K^T, K = C S^-1, S = S0 + R, in Joseph form.

    P+ = (I - K H) P (I - K H)^T + K (R + Omega) K^T with H = C^T P^-1 and Omega = S0 - H P H^T
    (:func:`linearisation_error`). Expanding, with H P = C^T and K S = C, this is exactly P - K S K^T; without
    Omega (the textbook Joseph form with the statistical H) the UKF would subtract K Omega K^T a second time and be
    overconfident. The Joseph form is kept because every term is positive semi-definite whatever the gain and
    the update is insensitive to first order to rounding in K: the only cancellation left is the small (m, m)
    Omega, added to the positive definite R, whereas P - K S K^T cancels in the (n, n) state covariance, which a
    precise (nearly singular) range / range-rate R shrinks by orders of magnitude in one direction. For the EKF
    Omega is rounding noise and the update is the textbook Joseph form.

    Args:
        x (..., n), P (..., n, n), C (..., n, m), S0 (..., m, m), R (..., m, m), nu (..., m) innovation;
        H (..., m, n) optionally precomputed by :func:`linearised_h`.

    Returns:
        updated x (..., n) and P (..., n, n).
    """
    S = S0 + R
    K = np.swapaxes(np.linalg.solve(S, np.swapaxes(C, -1, -2)), -1, -2)  # C S^-1 (S symmetric)
    if H is None:
        H = linearised_h(P, C)
    n = x.shape[-1]
    A = np.eye(n) - K @ H
    Pu = A @ P @ np.swapaxes(A, -1, -2) + K @ (R + linearisation_error(S0, C, H)) @ np.swapaxes(K, -1, -2)
    return x + (K @ nu[..., None])[..., 0], symmetrise(Pu)


def mixture_reduce(weights: FloatArray, x: FloatArray, P: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Moment-match a Gaussian mixture over axis -1 of ``weights (..., J)``; x (..., J, n), P (..., J, n, n).

    P = sum_j w_j (P_j + (x_j - xbar)(x_j - xbar)^T): each term is PSD (the PDA "spread of innovations" term is
    the second part).
    """
    w = weights[..., None]
    xbar = (w * x).sum(axis=-2)
    d = x - xbar[..., None, :]
    Pm = (w[..., None] * P).sum(axis=-3) + np.swapaxes(w * d, -1, -2) @ d
    return xbar, symmetrise(Pm)


def gaussian_log_likelihood(nu: FloatArray, S: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``(log N(nu; 0, S), d^2)`` for innovations nu (..., m), S (..., m, m), via Cholesky."""
    L = np.linalg.cholesky(S)
    y = np.linalg.solve(L, nu[..., None])[..., 0]
    d2 = np.sum(y * y, axis=-1)
    logdet = 2.0 * np.sum(np.log(np.diagonal(L, axis1=-2, axis2=-1)), axis=-1)
    m = nu.shape[-1]
    return -0.5 * (d2 + logdet + m * np.log(2.0 * np.pi)), d2
