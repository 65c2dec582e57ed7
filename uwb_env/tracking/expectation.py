r"""The expected posterior covariance of Gaussians under one transmitter-receiver pair's update (the lookahead's hook).

For predicted Gaussians ``x (N, 6)``, ``P (N, 6, 6)`` and every candidate plan a (``uwb_env.lookahead``)::

    H       = C^T P^-1                 statistical linearisation of the filter (unscented transform; the Jacobian for
                                       the EKF) at the predicted state
    Omega   = S0 - H P H^T             its linearisation error (0 for the EKF)
    S       = H P_a H^T + Omega + R_a,   K = P_a H^T S^-1
    P_a    <- P_a - P_D,a q_2 K S K^T

with q_2 the information-reduction factor of PDA in clutter (Kershaw and Evans; ``tracking.reduction``) or a constant.
A plan whose folded range-rate the prediction does not resolve gets no information from it (``tracking.ambiguity``).

``gaussian_expected_update`` is what every tracker's ``expected_update`` delegates to with the linearisation it
filters with (``"ukf"`` or ``"ekf"``); the particle trackers apply it to their moment-matched Gaussians. It runs the
compiled kernel (``tracking.compiled.expected_update``); ``uwb_env.tracking.reference`` holds the numpy twin the
tests compare it with.
"""

from __future__ import annotations

import numpy as np

from uwb_env.tracking import compiled
from uwb_env.tracking.kernels import UnscentedWeights
from uwb_env.tracking.reduction import gate_volume_factor, interpolate, reduction_table, table_grid
from uwb_env.typing import FloatArray

FILTERS = ("ukf", "ekf")
_WEIGHTS = compiled.weights_arrays(UnscentedWeights(6))  # (wm, wc, sigma_scale): alpha = 1, beta = 2, kappa = 0
_KINDS: dict[tuple[str, ...], np.ndarray] = {}


def filter_args(filter: str, names: tuple[str, ...]) -> tuple[np.ndarray, FloatArray, FloatArray, float, bool]:
    """``(kinds, wm, wc, sigma_scale, use_ukf)``: the measurement and filter arguments of the compiled kernels."""
    if filter not in FILTERS:
        raise ValueError(f"filter={filter!r}: must be one of {FILTERS}")
    kinds = _KINDS.get(names)
    if kinds is None:
        kinds = _KINDS[names] = compiled.kind_codes(names)
    wm, wc, sigma_scale = _WEIGHTS
    return kinds, wm, wc, sigma_scale, filter == "ukf"


class ReductionModel:
    """q_2 of one pair's update: a constant, or the PDA table of the measurement dimension (tracking.reduction)."""

    def __init__(self, q2: float | str, m: int, gate_probability: float) -> None:
        self.constant = 1.0 if q2 == "pda" else float(q2)
        if q2 == "pda":
            self.table = reduction_table(m, float(gate_probability))
            self.volume = gate_volume_factor(m, gate_probability)
        else:
            self.table, self.volume = _NO_TABLE, 0.0

    def compiled_args(self, rho: FloatArray) -> tuple[float, FloatArray, FloatArray, FloatArray, float]:
        """``(q2, rho, table, grid, gate_volume)`` of ``compiled.expected_update``."""
        return self.constant, rho, self.table, _GRID, self.volume

    def factor(self, pd: FloatArray, rho: FloatArray, S: FloatArray) -> FloatArray:
        """``(A, N)`` q_2 at P_D, clutter density rho and innovation covariance S ``(A, N, m, m)``."""
        if self.table.size == 0:
            return np.full(pd.shape, self.constant)
        lam = rho * self.volume * np.sqrt(np.linalg.det(S))
        return interpolate(self.table, pd, np.log1p(lam))


_MODELS: dict[tuple[float | str, int, float], ReductionModel] = {}
_NO_TABLE = np.zeros((0, 0))
_GRID = table_grid()


def reduction_model(q2: float | str, m: int, gate_probability: float) -> ReductionModel:
    """The (cached, read-only) ``ReductionModel`` of q2, measurement dimension m and gate probability."""
    key = (q2, m, gate_probability)
    model = _MODELS.get(key)
    if model is None:
        model = _MODELS[key] = ReductionModel(q2, m, gate_probability)
    return model


def gaussian_expected_update(
    filter: str,
    Pa: FloatArray,
    x: FloatArray,
    P: FloatArray,
    names: tuple[str, ...],
    tx_pos: FloatArray,
    rx_pos: FloatArray,
    R: FloatArray,
    pd: FloatArray,
    reduction: ReductionModel,
    rho: FloatArray,
    period: FloatArray,
) -> FloatArray:
    """One pair's expected update of ``Pa (A, N, 6, 6)`` in place (module docstring); returns ``Pa``.

    ``x (N, 6)``, ``P (N, 6, 6)``: the predicted Gaussians (where H is linearised); ``R (A, N, m, m)``,
    ``pd (A, N)``, ``rho (A, N)`` the clutter density at the predicted measurement (q_2 = "pda"), ``period (A,)``
    each plan's range-rate period (inf: unambiguous).
    """
    kinds, wm, wc, sigma_scale, use_ukf = filter_args(filter, names)
    if not compiled.expected_update(
        Pa, x, P, kinds, tx_pos, rx_pos, wm, wc, sigma_scale, use_ukf, R, pd, *reduction.compiled_args(rho), period
    ):
        raise np.linalg.LinAlgError("lookahead: a covariance is not positive definite")
    return Pa


class GaussianLookahead:
    """The protocol's ``expected_update`` for a tracker whose ``filter`` names its linearisation (``"ukf"``/``"ekf"``).

    Every tracker of the project inherits it: the IMM tracker for its combined Gaussians, the particle trackers for
    their moment-matched ones (``uwb_env.tracking.protocol``).
    """

    filter: str

    def expected_update(
        self,
        Pa: FloatArray,
        x: FloatArray,
        P: FloatArray,
        names: tuple[str, ...],
        tx_pos: FloatArray,
        rx_pos: FloatArray,
        R: FloatArray,
        pd: FloatArray,
        reduction: ReductionModel,
        rho: FloatArray,
        period: FloatArray,
    ) -> FloatArray:
        """One pair's expected update of ``Pa (A, N, 6, 6)`` (``gaussian_expected_update`` with ``self.filter``)."""
        return gaussian_expected_update(self.filter, Pa, x, P, names, tx_pos, rx_pos, R, pd, reduction, rho, period)
