"""Numpy twins of the compiled tracking kernels: what the tests and benchmarks compare the production path with.

Nothing in the production path imports this module. ``ReferenceTracker`` is the VS-IMM / LMIPDA ``Tracker`` with
every compiled kernel replaced by the numpy reference kernels of ``uwb_env.tracking.kernels`` (IMM mixing and
prediction, the LMIPDA / PDA receiver update, initiation's candidate selection, fusion and two-point pairing); both
give the same tracks to rounding error (tests/unit/test_compiled.py). ``expected_update`` is the numpy twin of the
lookahead's compiled expected update (``uwb_env.tracking.expectation``).
"""

from __future__ import annotations

import numpy as np

from uwb_env.sensing.records import Detections
from uwb_env.tracking import ambiguity
from uwb_env.tracking.expectation import ReductionModel
from uwb_env.tracking.imm import imm_mix
from uwb_env.tracking.initiation import fuse_candidates, two_point_pairs
from uwb_env.tracking.kernels import (
    UnscentedWeights,
    ekf_moments,
    joseph_update,
    kf_predict,
    linearisation_error,
    linearised_h,
    mixture_reduce,
    symmetrise,
    ukf_moments,
)
from uwb_env.tracking.lmipda import associate
from uwb_env.tracking.measurement import angular_mask
from uwb_env.tracking.tracker import _PV, Tracker, _Candidates
from uwb_env.typing import BoolArray, FloatArray, IntArray

_WEIGHTS = UnscentedWeights(6)


def measurement_moments(
    filter: str, names: tuple[str, ...], x: FloatArray, P: FloatArray, tx: FloatArray, rx: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(z_hat, S0, C)`` of the named measurement by ``filter`` (UKF or EKF), numpy kernels."""
    if filter == "ukf":
        return ukf_moments(names, x, P, tx, rx, _WEIGHTS, angular_mask(names))
    return ekf_moments(names, x, P, tx, rx)


def expected_update(
    Pa: FloatArray,
    x: FloatArray,
    P: FloatArray,
    names: tuple[str, ...],
    tx_pos: FloatArray,
    rx_pos: FloatArray,
    filter: str,
    R: FloatArray,
    pd: FloatArray,
    model: ReductionModel,
    rho: FloatArray,
    period: FloatArray | None = None,
) -> FloatArray:
    """One pair's expected update of ``Pa`` (A, N, 6, 6), numpy twin of ``expectation.gaussian_expected_update``.

    H is linearised at the predicted ``x (N, 6)``, ``P (N, 6, 6)`` by ``filter`` (``"ukf"`` or ``"ekf"``);
    ``R (A, N, m, m)``, ``pd (A, N)``, ``rho (A, N)`` the clutter density at the predicted measurement (for
    q_2 = "pda");
    ``period (A,)`` each plan's range-rate period (None or inf: unambiguous): a plan whose folded range-rate the
    prediction does not resolve gets no information from it (``tracking.ambiguity.marginalise``).
    """
    _, S0, C = measurement_moments(filter, names, x, P, tx_pos, rx_pos)
    S0, C = S0[None], C[None]  # (1 or A, N, ...): per plan where a plan's period marginalises its range-rate
    if period is not None and "range_rate" in names and np.isfinite(period).any():
        d = names.index("range_rate")
        A = Pa.shape[0]
        S0, C = np.broadcast_to(S0, (A, *S0.shape[1:])), np.broadcast_to(C, (A, *C.shape[1:]))
        blind = ambiguity.unresolved(S0, d, period[:, None])
        S0, C = ambiguity.marginalise(S0, C, d, period[:, None], blind)
    H = linearised_h(P, C)  # (1 or A, N, m, 6)
    omega = linearisation_error(S0, C, H)
    PHt = Pa @ np.swapaxes(H, -1, -2)  # (A, N, 6, m)
    S = H @ PHt + omega + R
    K = np.swapaxes(np.linalg.solve(S, np.swapaxes(PHt, -1, -2)), -1, -2)
    gain = model.factor(pd, rho, S) * pd
    return symmetrise(Pa - gain[..., None, None] * (K @ np.swapaxes(PHt, -1, -2)))


class ReferenceTracker(Tracker):
    """``Tracker`` on the numpy reference kernels (module docstring)."""

    def _mix_predict(
        self, mu: FloatArray, Pi: FloatArray, x: FloatArray, P: FloatArray, F: FloatArray, Q: FloatArray, a: IntArray
    ) -> None:
        cbar, x0, P0 = imm_mix(mu[:, a], np.broadcast_to(Pi, (mu.shape[0], a.size, a.size)), x[:, a], P[:, a])
        x[:, a], P[:, a] = kf_predict(x0, P0, F[None], Q[None])
        mu[:, a] = cbar / cbar.sum(axis=-1, keepdims=True)

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
        """The lookahead's hook on the numpy twin (``expected_update``)."""
        return expected_update(Pa, x, P, names, tx_pos, rx_pos, self.cfg.filter, R, pd, reduction, rho, period)

    def measurement_moments(
        self, names: tuple[str, ...], x: FloatArray, P: FloatArray, tx: FloatArray, rx: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``(z_hat, S0, C)`` of the named measurement by the tracker's filter, numpy kernels."""
        return measurement_moments(self.cfg.filter, names, x, P, tx, rx)

    def _update(self, det: Detections) -> BoolArray:
        """LMIPDA + PDA update of every track with one pair's detections (numpy twin of ``compiled.receiver_update``).

        Returns which measurements now belong to some track (kept from initiation). Only (track, model,
        measurement) triples that pass the gate are evaluated in full: a cheap exact pre-gate first, since
        nu^T S^-1 nu >= nu_k^2 / S_kk for every component k of a positive definite S.
        """
        cfg, t = self.cfg, self.tracks
        names = det.measurement_names
        m = len(names)
        # all tracks share the scan's model set (see _predict): work on the active models only
        a = self._active_index(t.active[0])
        tx, rx = self.tx_pos[det.tx], self.rx_pos[det.rx]
        X, PP, MU = t.x[:, a], t.P[:, a], t.mu[:, a]
        N, r = len(t), a.size
        z_hat, S0, C = self.measurement_moments(names, X, PP, tx, rx)
        g2 = self._gates[m]
        S0, C, nu, triples = ambiguity.gated_innovations(det, z_hat, S0, C, g2)  # folded, pre-gated
        assoc = associate(det, nu, S0, triples, g2, MU, t.existence, self._pd(det, t), cfg)
        t.existence = assoc.psi
        t.mu[:, a] = assoc.mu
        taken = np.zeros(len(det), bool)
        if assoc.cols.size == 0:
            return taken
        ti, ri, mi, j = assoc.ti, assoc.ri, assoc.mi, assoc.j
        H = linearised_h(PP, C)  # (N, r, m, 6), once per track and model
        xu, Pu = joseph_update(X[ti, ri], PP[ti, ri], C[ti, ri], S0[ti, ri], det.R[mi], nu[ti, ri, mi], H[ti, ri])
        xs = np.broadcast_to(X[:, :, None], (N, r, assoc.cols.size + 1, 6)).copy()
        Ps = np.broadcast_to(PP[:, :, None], (N, r, assoc.cols.size + 1, 6, 6)).copy()
        xs[ti, ri, j + 1] = xu
        Ps[ti, ri, j + 1] = Pu
        t.x[:, a], t.P[:, a] = mixture_reduce(assoc.beta, xs, Ps)
        # A measurement is taken (kept from initiation) when it belongs to some track with probability > 1/2
        taken[assoc.cols] = assoc.owned > 0.5
        return taken

    def _azimuth_candidates(
        self, det: Detections, free: BoolArray, tx: FloatArray, rx: FloatArray
    ) -> tuple[FloatArray, FloatArray] | None:
        return None  # the range / azimuth path of Tracker._initiate (ridge_range, range_azimuth_candidates)

    def _form_tracks(self, p: FloatArray, cov: FloatArray, time_s: float, scan_index: int) -> None:
        """Numpy twin of ``Tracker._form_tracks`` (``compiled.initiate``)."""
        cfg, prev = self.cfg, self._previous
        max_spread = 2.0 * cfg.init_max_position_std_m**2
        dt = time_s - prev.time_s
        inside = (
            (p[:, 0] >= self.area[0])
            & (p[:, 0] <= self.area[1])
            & (p[:, 1] >= self.area[2])
            & (p[:, 1] <= self.area[3])
        )
        spread = np.trace(cov, axis1=1, axis2=2)
        inside &= spread <= max_spread
        p, cov, spread = p[inside], cov[inside], spread[inside]
        if p.shape[0] > cfg.init_max_candidates:  # keep the most precise
            best = np.argsort(spread, kind="stable")[: cfg.init_max_candidates]
            p, cov = p[best], cov[best]
        p, cov = fuse_candidates(p, cov, self._gates[2])
        i, j = (
            two_point_pairs(p, cov, prev.p, prev.cov, dt, cfg.max_speed_mps)
            if np.isfinite(dt)
            else (np.zeros(0, np.int64), np.zeros(0, np.int64))
        )
        if i.size:
            self._append_tracks(*self._new_track_states(p[i], cov[i], prev.p[j], prev.cov[j], dt), scan_index)
        rest = np.ones(p.shape[0], bool)
        rest[i] = False
        self._previous = _Candidates(p[rest], cov[rest], time_s)

    def _new_track_states(
        self, p: FloatArray, cov: FloatArray, p0: FloatArray, cov0: FloatArray, dt: float
    ) -> tuple[FloatArray, FloatArray]:
        """States ``(x (n, 6), P (n, 6, 6))`` of tentative tracks from two-point differencing.

        The numpy twin of ``compiled.new_track_states``.

        Position now, velocity from the difference.

        The differenced velocity v_hat = (p - p0) / T, covariance Sigma = (cov + cov0) / T^2, is fused with the
        prior N(0, (v_max / 2)^2 I): v = K v_hat, Cov(v) = (Sigma^-1 + prior^-1)^-1, K = Cov(v) Sigma^-1, and
        Cov(p, v) = cov K^T / T (a valid joint covariance since Cov(v) <= Sigma).
        """
        n, cfg = p.shape[0], self.cfg
        v_hat = (p - p0) / dt
        sigma = (cov + cov0) / dt**2
        sigma_inv = np.linalg.inv(sigma)
        cov_v = np.linalg.inv(sigma_inv + np.eye(2) / (0.5 * cfg.max_speed_mps) ** 2)
        K = cov_v @ sigma_inv
        x = np.zeros((n, 6))
        x[:, 0], x[:, 2] = p[:, 0], p[:, 1]
        v = np.einsum("nij,nj->ni", K, v_hat)
        x[:, 1], x[:, 3] = v[:, 0], v[:, 1]
        cross = cov @ np.swapaxes(K, -1, -2) / dt
        block = np.concatenate(  # (n, 4, 4) in the order (x, y, vx, vy), scattered once into the state order
            [np.concatenate([cov, cross], axis=2), np.concatenate([np.swapaxes(cross, -1, -2), cov_v], axis=2)],
            axis=1,
        )
        P = np.zeros((n, 6, 6))
        P[:, _PV[:, None], _PV[None, :]] = block
        P[:, 4, 4] = P[:, 5, 5] = cfg.initial_accel_std_mps2**2
        return x, P
