r"""Folded (ambiguous) range-rate in the tracker: unwrap around the prediction, or marginalise when unresolved.

A chirp train measures the bistatic range-rate modulo its period P = lambda / T1 (``uwb_env.waveforms.chirp``). The
tracker handles the ambiguity per track, model and pair:

* **resolved** -- the predicted range-rate is known to better than the period, sqrt(S_dd) <= P / k (k =
  :data:`RESOLVED_STDS` = 6: the +-3 sigma interval fits in one period): the measurement is used in full and its
  innovation is folded into [-P/2, P/2), which picks the alias nearest the prediction;
* **unresolved** -- otherwise (a new track's two-point velocity, a long coast): the folded range-rate says nothing
  a Gaussian update could use, so the component is marginalised. Exactly: its likelihood factor is the uniform 1/P
  (the truth's alias is anywhere in the period), and it moves neither the mean nor the covariance. This is done
  without changing the measurement dimension: the cross-covariance column C[:, d] and the off-diagonal S0[d, :]
  are zeroed, the innovation nu_d is set to 0 and S0_dd to P^2 / (2 pi), so the Gaussian factor of that component
  is N(0; 0, P^2/(2 pi) + R_dd) = 1/P to within R_dd / P^2 (1e-4 here), K[:, d] = 0 and P+ = P - C S^-1 C^T is
  the range-only update. The clutter map of the sensor already uses 1/P for a false alarm's folded range-rate, so
  the PDA likelihood ratio of a marginalised component is exactly 1.
"""

from __future__ import annotations

import math

import numpy as np

from uwb_env.tracking.measurement import angular_mask, wrap_residual
from uwb_env.typing import BoolArray, FloatArray
from uwb_env.waveforms.chirp import fold_periodic

RESOLVED_STDS = 6.0


def unresolved(S0: FloatArray, d: int, period: FloatArray | float) -> BoolArray:
    """``(...)`` True where the predicted range-rate std sqrt(S0_dd) exceeds period / RESOLVED_STDS.

    Args: S0 ``(..., m, m)`` predicted measurement covariance without R; d the range-rate column; period [m/s], a
    scalar or broadcasting against ``S0[..., d, d]`` (inf: unambiguous, never unresolved).
    """
    return S0[..., d, d] > (period / RESOLVED_STDS) ** 2


def marginalise(
    S0: FloatArray, C: FloatArray, d: int, period: FloatArray | float, mask: BoolArray
) -> tuple[FloatArray, FloatArray]:
    """``(S0, C)`` with the range-rate component of the ``mask``-ed rows marginalised (module docstring), copies.

    Args: S0 ``(..., m, m)``, C ``(..., n, m)``, mask ``(...)``; period [m/s], a scalar or broadcasting to ``mask``.
    """
    S0, C = S0.copy(), C.copy()
    S0[mask, d, :] = 0.0
    S0[mask, :, d] = 0.0
    S0[mask, d, d] = np.broadcast_to(period, mask.shape)[mask] ** 2 / (2.0 * math.pi)
    C[mask, :, d] = 0.0
    return S0, C


def fold_innovations(nu: FloatArray, d: int, period: float, mask: BoolArray) -> FloatArray:
    """Innovations ``(N, r, M, m)`` with the range-rate folded, and zeroed for the ``mask``-ed (N, r) (in place)."""
    nu[..., d] = fold_periodic(nu[..., d], period)
    nu[mask, :, d] = 0.0
    return nu


def gated_innovations(
    det, z_hat: FloatArray, S0: FloatArray, C: FloatArray, g2: float
) -> tuple[FloatArray, FloatArray, FloatArray, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Innovations of one pair's detections against (N, r) predicted measurements, folded, and the pre-gate.

    ``det`` a ``Detections`` (z (M, m), R (M, m, m), measurement names, range-rate period); ``z_hat`` (N, r, m),
    ``S0`` (N, r, m, m), ``C`` (N, r, 6, m) the filter's moments; ``g2`` the chi-square gate. With a folded range-rate
    the unresolved (track, model)s are marginalised over it (:func:`marginalise`) and the innovations folded.
    Returns ``(S0, C, nu (N, r, M, m), (ti, ri, mi))``, the last the triples passing the exact pre-gate
    nu_k^2 <= g2 (S0 + R)_kk for every component k (nu^T S^-1 nu >= nu_k^2 / S_kk for a positive definite S).
    """
    names = det.measurement_names
    nu = wrap_residual(det.z[None, None] - z_hat[:, :, None], angular_mask(names))  # (N, r, M, m)
    period = det.range_rate_period_mps
    if math.isfinite(period) and "range_rate" in names:  # folded range-rate
        d = names.index("range_rate")
        blind = unresolved(S0, d, period)
        S0, C = marginalise(S0, C, d, period, blind)
        nu = fold_innovations(nu, d, period, blind)
    s_diag = np.diagonal(S0, axis1=-2, axis2=-1)[:, :, None] + np.diagonal(det.R, axis1=-2, axis2=-1)[None, None]
    return S0, C, nu, np.nonzero(np.all(nu * nu <= g2 * s_diag, axis=-1))
