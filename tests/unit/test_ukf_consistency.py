"""Issue 15: the UKF covariance update is P - K S K^T, in both back ends, the PDA update and the lookahead.

The Joseph form with the statistically linearised H = C^T P^-1 alone, (I - K H) P (I - K H)^T + K R K^T, equals
P - K S K^T - K (S0 - H P H^T) K^T for the UKF: it subtracted the unscented transform's linearisation error a
second time. Checked here:

* one UKF update against the textbook equations written out in this file (sigma points, weights, z_hat, S, C,
  K = C S^-1, P+ = P - K S K^T), range + range-rate with a correlation of -0.999, both back ends; the EKF update
  against the textbook Joseph form; the PDA mixture of such updates through ``Tracker._update``; the lookahead's
  expected update;
* NEES / NIS Monte Carlo consistency of the UKF and the EKF for every measurement set of the project, both back
  ends (``_track_numpy``: the numpy kernels ``Tracker._update`` calls; ``_track_compiled``: the compiled
  ``predict_models`` + ``receiver_update`` of the default back end, one track per run, P_D = P_G = 1);
* that the old formula fails: the first scan of a new track from a broad prior, where the linearisation error is
  not small, is consistent with the fixed update and 2.4 times overconfident with the old one.

Statistics: each run is scored at one slot (scan, or scan and receiver for the NIS), runs spread round-robin over
the slots, so the N scores are independent and for a consistent filter N times their mean is chi-square with N n
degrees of freedom (n = 4 for the position-velocity NEES, m for the NIS); the mean must lie in the two-sided 95 %
interval chi2.ppf([0.025, 0.975], N n) / N. Seeds are fixed, so the tests are deterministic; about one such check in
twenty fails by chance with a new seed.

Geometry: one transmitter and three receivers (three bistatic pairs, updated one after the other in every scan as
the tracker does), an NCV target about 190 m away. With a single pair a bistatic range (or range and range-rate)
does not make the position observable, and an EKF or UKF of an unobservable nonlinear system is inconsistent
whatever its covariance update.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.stats import chi2

from uwb_env import scenarios
from uwb_env.config import MotionModelConfig, TrackerConfig
from uwb_env.scene.motion_models import ncv_transition, process_noise
from uwb_env.sensing.records import Detections
from uwb_env.tracking import Tracker, UnscentedWeights, compiled, ekf_moments, joseph_update, kf_predict, ukf_moments
from uwb_env.tracking.expectation import ReductionModel
from uwb_env.tracking.kernels import linearised_h, symmetrise
from uwb_env.tracking.measurement import angular_mask, measure, wrap_residual
from uwb_env.tracking.reference import ReferenceTracker
from uwb_env.tracking.reference import expected_update as reference_expected_update
from uwb_env.tracking.tracker import ZERO_ACCELERATION_STD
from uwb_env.waveforms.chirp import ChirpWaveform

RR = ("bistatic_range", "range_rate")
TX = np.array([0.0, 0.0])
RXS = np.array([[40.0, -10.0], [-30.0, 60.0], [100.0, 150.0]])
X_TRUE = np.array([150.0, 6.0, 120.0, -3.0, 0.0, 0.0])  # [x, vx, y, vy, ax, ay]
PERIOD_S, ACCEL_STD = 0.25, 0.5
F, G = ncv_transition(PERIOD_S)
Q = process_noise(G, ACCEL_STD)
Q[4, 4] = Q[5, 5] = ZERO_ACCELERATION_STD**2  # the tracker's NCV: acceleration carried as ~0


def _correlated(std_a: float, std_b: float, rho: float) -> np.ndarray:
    return np.array([[std_a**2, rho * std_a * std_b], [rho * std_a * std_b, std_b**2]])


R_SINGULAR = _correlated(0.5, 0.5, -0.999)  # range [m], range-rate [m/s]: nearly singular, like a chirp's


def _prior(std_pos: float, std_vel: float) -> np.ndarray:
    return np.diag([std_pos**2, std_vel**2, std_pos**2, std_vel**2, ZERO_ACCELERATION_STD**2, ZERO_ACCELERATION_STD**2])


# ------------------------------------------------------------------------------------- textbook equations
def _h_and_jacobian(X: np.ndarray, tx: np.ndarray, rx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Bistatic range and range-rate of states ``X (k, 6)`` and their Jacobians ``(k, 2, 6)``, written out."""
    p, v = X[:, [0, 2]], X[:, [1, 3]]
    z = np.zeros((X.shape[0], 2))
    J = np.zeros((X.shape[0], 2, 6))
    for node in (tx, rx):
        d = p - node
        n = np.linalg.norm(d, axis=1)
        u = d / n[:, None]
        uv = np.sum(u * v, axis=1)
        z[:, 0] += n
        z[:, 1] += uv
        J[:, 0, [0, 2]] += u
        J[:, 1, [0, 2]] += (v - u * uv[:, None]) / n[:, None]  # (I - u u^T) v / |d|
        J[:, 1, [1, 3]] += u
    return z, J


def _textbook_ukf(x, P, R, z, tx, rx):
    """Julier-Uhlmann UKF update (alpha = 1, beta = 2, kappa = 0): x+, P+ = P - K S K^T, z_hat, S, C."""
    n = x.size
    alpha, beta, kappa = 1.0, 2.0, 0.0
    lam = alpha**2 * (n + kappa) - n
    wm = np.full(2 * n + 1, 1.0 / (2 * (n + lam)))
    wm[0] = lam / (n + lam)
    wc = wm.copy()
    wc[0] += 1.0 - alpha**2 + beta
    L = np.linalg.cholesky((n + lam) * P)
    X = np.vstack([x, x + L.T, x - L.T])  # rows: x, x + L[:, i], x - L[:, i]
    Z, _ = _h_and_jacobian(X, tx, rx)
    z_hat = wm @ Z
    dZ, dX = Z - z_hat, X - x
    S = (wc[:, None] * dZ).T @ dZ + R
    C = (wc[:, None] * dX).T @ dZ
    K = C @ np.linalg.inv(S)
    return x + K @ (z - z_hat), P - K @ S @ K.T, z_hat, S, C


def _textbook_ekf(x, P, R, z, tx, rx):
    """EKF update in Joseph form: x+, P+, z_hat, S, C = P H^T."""
    z_hat, J = _h_and_jacobian(x[None], tx, rx)
    H = J[0]
    S = H @ P @ H.T + R
    K = P @ H.T @ np.linalg.inv(S)
    A = np.eye(x.size) - K @ H
    return x + K @ (z - z_hat[0]), A @ P @ A.T + K @ R @ K.T, z_hat[0], S, P @ H.T


def _old_joseph_update(x, P, C, S0, R, nu):
    """The update before the fix: (I - K H) P (I - K H)^T + K R K^T with H = C^T P^-1, K = C (S0 + R)^-1."""
    S = S0 + R
    K = np.swapaxes(np.linalg.solve(S, np.swapaxes(C, -1, -2)), -1, -2)
    A = np.eye(x.shape[-1]) - K @ linearised_h(P, C)
    return x + (K @ nu[..., None])[..., 0], symmetrise(A @ P @ np.swapaxes(A, -1, -2) + K @ R @ np.swapaxes(K, -1, -2))


def _broad_state(seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A predicted state and a correlated covariance with metres of position uncertainty (a young track)."""
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((6, 6)) * np.array([2.0, 1.0, 2.0, 1.0, 0.01, 0.01])[:, None]
    P = A @ A.T + np.diag([1.0, 0.25, 1.0, 0.25, 1e-4, 1e-4])
    return np.array([150.0, 6.0, 120.0, -3.0, 0.1, -0.05]), P


def _compiled_update(x, P, z, R, names, tx, rx, use_ukf, pd=1.0, pg=1.0, rho=1e-15):
    """One track, one model: ``compiled.receiver_update`` on measurements ``z (M, m)``, ``R (M, m, m)``."""
    wm, wc, scale = compiled.weights_arrays(UnscentedWeights(6))
    xs, Ps = x[None, None].copy(), P[None, None].copy()
    g2 = np.inf if pg == 1.0 else float(chi2.ppf(pg, len(names)))
    _, _, ok = compiled.receiver_update(
        xs,
        Ps,
        np.ones((1, 1)),
        np.zeros(1, np.int64),
        np.full(1, 0.5),
        np.full(1, pd),
        np.ascontiguousarray(z, dtype=float),
        np.ascontiguousarray(R, dtype=float),
        np.full(z.shape[0], rho),
        compiled.kind_codes(names),
        tx,
        rx,
        wm,
        wc,
        scale,
        use_ukf,
        g2,
        pg,
        True,
        np.inf,
    )
    assert ok
    return xs[0, 0], Ps[0, 0]


# ----------------------------------------------------------------------------------------- single updates
@pytest.mark.parametrize("backend", ["numpy", "compiled"])
def test_ukf_update_equals_the_textbook_equations(backend):
    """Range + range-rate, correlation -0.999, a broad correlated prior: P+ = P - K S K^T to rounding. The old
    formula's covariance is off by K Omega K^T, 80 times too small in the direction the measurement pins down."""
    x, P = _broad_state()
    rx = RXS[0]
    z = _h_and_jacobian(x[None], TX, rx)[0][0] + np.array([0.3, -0.2])
    x_ref, P_ref, z_hat_ref, S_ref, C_ref = _textbook_ukf(x, P, R_SINGULAR, z, TX, rx)
    z_hat, S0, C = ukf_moments(RR, x, P, TX, rx, UnscentedWeights(6), angular_mask(RR))
    np.testing.assert_allclose(z_hat, z_hat_ref, rtol=1e-13)
    np.testing.assert_allclose(S0 + R_SINGULAR, S_ref, rtol=1e-11, atol=1e-12)
    np.testing.assert_allclose(C, C_ref, rtol=1e-11, atol=1e-12)
    if backend == "numpy":
        xu, Pu = joseph_update(x, P, C, S0, R_SINGULAR, z - z_hat)
    else:
        xu, Pu = _compiled_update(x, P, z[None], R_SINGULAR[None], RR, TX, rx, use_ukf=True)
    scale = np.abs(P_ref).max()
    np.testing.assert_allclose(xu, x_ref, rtol=1e-12, atol=1e-10)
    np.testing.assert_allclose(Pu, P_ref, rtol=0, atol=1e-11 * scale)
    np.testing.assert_array_equal(Pu, Pu.T)
    # the pinned-down direction: the smallest eigenvalue of the position-velocity block
    small = np.linalg.eigvalsh(P_ref[:4, :4])[0]
    assert np.linalg.eigvalsh(Pu[:4, :4])[0] == pytest.approx(small, rel=1e-8)
    _, P_old = _old_joseph_update(x, P, C, S0, R_SINGULAR, z - z_hat)
    assert np.linalg.eigvalsh(P_old[:4, :4])[0] < small / 50
    np.testing.assert_allclose(
        P_ref - P_old,
        (C @ np.linalg.inv(S_ref)) @ (S0 - C.T @ np.linalg.solve(P, C)) @ (C @ np.linalg.inv(S_ref)).T,
        rtol=0,
        atol=1e-11 * scale,
    )


@pytest.mark.parametrize("backend", ["numpy", "compiled"])
def test_ekf_update_is_the_textbook_joseph_form(backend):
    """For the EKF S0 = H P H^T: the linearisation error is rounding and the update is what it was."""
    x, P = _broad_state(1)
    rx = RXS[1]
    z = _h_and_jacobian(x[None], TX, rx)[0][0] + np.array([-0.4, 0.25])
    x_ref, P_ref, _, S_ref, _ = _textbook_ekf(x, P, R_SINGULAR, z, TX, rx)
    z_hat, S0, C = ekf_moments(RR, x, P, TX, rx)
    np.testing.assert_allclose(S0 + R_SINGULAR, S_ref, rtol=1e-12)
    if backend == "numpy":
        xu, Pu = joseph_update(x, P, C, S0, R_SINGULAR, z - z_hat)
    else:
        xu, Pu = _compiled_update(x, P, z[None], R_SINGULAR[None], RR, TX, rx, use_ukf=False)
    _, P_old = _old_joseph_update(x, P, C, S0, R_SINGULAR, z - z_hat)
    scale = np.abs(P_ref).max()
    np.testing.assert_allclose(xu, x_ref, rtol=1e-12, atol=1e-10)
    np.testing.assert_allclose(Pu, P_ref, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(Pu, P_old, rtol=0, atol=1e-12 * scale)


def _pda_tracker(filt: str, backend: str, x: np.ndarray, P: np.ndarray, pd: float, pg: float) -> Tracker:
    cfg = TrackerConfig(
        models=(MotionModelConfig("ncv", "ncv", ACCEL_STD),),
        transition=((1.0,),),
        default_models=("ncv",),
        filter=filt,
        detection_probability=pd,
        gate_probability=pg,
        fixed_existence=True,
    )
    kind = ReferenceTracker if backend == "numpy" else Tracker
    tracker = kind(cfg, TX[None], RXS[:1], np.array([-500.0, 500.0, -500.0, 500.0]))
    tracker._append_tracks(x[None], P[None], 0)
    return tracker


@pytest.mark.parametrize("backend", ["numpy", "compiled"])
@pytest.mark.parametrize("filt", ["ukf", "ekf"])
def test_pda_update_mixes_the_single_measurement_updates(filt, backend):
    """Tracker._update with two gated measurements (each its own R) and clutter: x = sum_j beta_j x_j,
    P = sum_j beta_j (P_j + (x_j - x)(x_j - x)^T), with x_0, P_0 the prediction and x_i, P_i = P - K_i S_i K_i^T
    the textbook single-measurement updates; beta of PDA: beta_i ~ P_D N(nu_i; 0, S_i) / (P_G rho_i),
    beta_0 ~ 1 - P_D P_G."""
    pd, pg = 0.9, 0.99
    x, P = _broad_state(2)
    rx = RXS[0]
    textbook = _textbook_ukf if filt == "ukf" else _textbook_ekf
    z0 = _h_and_jacobian(x[None], TX, rx)[0][0]
    z = z0 + np.array([[0.8, -0.7], [-1.5, 1.2]])
    R = np.stack([R_SINGULAR, _correlated(0.7, 0.4, 0.5)])
    rho = np.array([2e-3, 5e-4])
    xs, Ps, lam = [x], [P], []
    for i in range(2):
        xi, Pi, z_hat, S, _ = textbook(x, P, R[i], z[i], TX, rx)
        nu = z[i] - z_hat
        d2 = nu @ np.linalg.solve(S, nu)
        assert d2 < chi2.ppf(pg, 2)  # both gated
        lam.append(np.exp(-0.5 * d2) / np.sqrt(np.linalg.det(2 * np.pi * S)) / (pg * rho[i]))
        xs.append(xi)
        Ps.append(Pi)
    beta = np.array([1.0 - pd * pg, *(pd * pg * np.array(lam))])
    beta /= beta.sum()
    x_ref = np.einsum("j,jk->k", beta, np.array(xs))
    d = np.array(xs) - x_ref
    P_ref = np.einsum("j,jkl->kl", beta, np.array(Ps)) + np.einsum("j,jk,jl->kl", beta, d, d)
    tracker = _pda_tracker(filt, backend, x, P, pd, pg)
    det = Detections(0, 0, 0, 0.0, z, R, np.full(2, 100.0), np.full(2, -1), RR, rho, 1.0)
    tracker._update(det)
    assert 0.05 < beta[1] < 0.95 and 0.05 < beta[2] < 0.95  # a real mixture, with a real spread term
    np.testing.assert_allclose(tracker.tracks.x[0, 0], x_ref, rtol=1e-11, atol=1e-9)
    np.testing.assert_allclose(tracker.tracks.P[0, 0], P_ref, rtol=0, atol=1e-10 * np.abs(P_ref).max())


@pytest.mark.parametrize("backend", ["numpy", "compiled"])
@pytest.mark.parametrize("filt", ["ukf", "ekf"])
def test_lookahead_expected_update_at_the_prediction_is_the_filters_update(filt, backend):
    """lookahead: for P_a = P_pred, P_a - q_2 P_D K S K^T with the filter's own S = S0 + R and K = C S^-1."""
    x, P = _broad_state(3)
    rx = RXS[2]
    textbook = _textbook_ukf if filt == "ukf" else _textbook_ekf
    R = np.stack([R_SINGULAR, _correlated(0.3, 0.8, -0.4)])[:, None]  # (A = 2 plans, N = 1, 2, 2)
    pd = np.array([[1.0], [0.6]])  # plan 0: the filter's update; plan 1: updated with probability 0.6
    q2 = 1.0
    tracker = _pda_tracker(filt, backend, x, P, 0.9, 0.99)
    model = ReductionModel(q2, 2, 0.99)
    rho = np.zeros((2, 1))
    Pa = np.repeat(P[None, None], 2, axis=0)
    if backend == "numpy":
        got = reference_expected_update(Pa, x[None], P[None], RR, TX, rx, filt, R, pd, model, rho)
    else:
        got = Pa.copy()
        kinds, wm, wc, scale, use_ukf = tracker.compiled_filter_args(RR)
        assert compiled.expected_update(
            got,
            x[None],
            P[None],
            kinds,
            TX,
            rx,
            wm,
            wc,
            scale,
            use_ukf,
            R,
            pd,
            *model.compiled_args(rho),
            np.full(2, np.inf),
        )
    for a in range(2):
        _, P_a, _, S, C = textbook(x, P, R[a, 0], np.zeros(2), TX, rx)
        if a == 0:
            P_post = P_a
        expected = P - pd[a, 0] * (C @ np.linalg.solve(S, C.T))
        np.testing.assert_allclose(got[a, 0], expected, rtol=0, atol=1e-10 * np.abs(P).max())
    np.testing.assert_allclose(got[0, 0], P_post, rtol=0, atol=1e-10 * np.abs(P).max())


# ------------------------------------------------------------------------------------------- Monte Carlo
def _simulate(names, R, runs, scans, P0, seed):
    """NCV truth ``(K, N, 6)``, measurements ``(K, receivers, N, m)``, initial estimates ``(N, 6)`` ~ N(truth, P0)."""
    rng = np.random.default_rng(seed)
    L = np.linalg.cholesky(R)
    x0 = X_TRUE + rng.standard_normal((runs, 6)) @ np.linalg.cholesky(P0).T
    truth = np.tile(X_TRUE, (runs, 1))
    states, zs = [], []
    for _ in range(scans):
        truth = truth @ F.T + rng.standard_normal((runs, 2)) @ G.T * ACCEL_STD
        states.append(truth)
        zs.append([measure(names, truth, TX, rx)[0] + rng.standard_normal((runs, len(names))) @ L.T for rx in RXS])
    return np.array(states), np.array(zs), x0


def _track_numpy(names, R, z, x0, P0, filt, update=joseph_update):
    """The numpy back end's kernels (Tracker._update: moments, Joseph update; PDA with beta_1 = 1 is the update),
    every run at once. Returns estimates ``(K, N, 6)``, covariances ``(K, N, 6, 6)``, NIS ``(K, receivers, N)``."""
    runs = x0.shape[0]
    ang = angular_mask(names)
    x, P = x0.copy(), np.tile(P0, (runs, 1, 1))
    Rb = np.broadcast_to(R, (runs, *R.shape))
    xs, Ps, nis = [], [], []
    for zk in z:
        x, P = kf_predict(x, P, F, Q)
        scan_nis = []
        for rx, zr in zip(RXS, zk, strict=True):
            if filt == "ukf":
                z_hat, S0, C = ukf_moments(names, x, P, TX, rx, UnscentedWeights(6), ang)
            else:
                z_hat, S0, C = ekf_moments(names, x, P, TX, rx)
            nu = wrap_residual(zr - z_hat, ang)
            scan_nis.append(np.einsum("ni,ni->n", nu, np.linalg.solve(S0 + R, nu[..., None])[..., 0]))
            x, P = update(x, P, C, S0, Rb, nu)
        xs.append(x)
        Ps.append(P)
        nis.append(scan_nis)
    return np.array(xs), np.array(Ps), np.array(nis)


def _track_compiled(names, R, z, x0, P0, filt):
    """The compiled back end (compiled.predict_models + receiver_update: one track, P_D = P_G = 1, a vanishing
    clutter intensity), run by run. Same returns as ``_track_numpy``."""
    scans, n_rx, runs = z.shape[:3]
    use_ukf = filt == "ukf"
    wm, wc, scale = compiled.weights_arrays(UnscentedWeights(6))
    kinds = compiled.kind_codes(names)
    act, Pi, Fa, Qa = np.zeros(1, np.int64), np.ones((1, 1)), F[None].copy(), Q[None].copy()
    psi, pd, rho, Rm = np.full(1, 0.5), np.ones(1), np.full(1, 1e-15), np.ascontiguousarray(R[None])
    xs, Ps = np.empty((scans, runs, 6)), np.empty((scans, runs, 6, 6))
    z_hat, S0 = np.empty((scans, n_rx, runs, len(names))), np.empty((scans, n_rx, runs, len(names), len(names)))
    for n in range(runs):
        x, P, mu = x0[n][None, None].copy(), P0[None, None].copy(), np.ones((1, 1))
        for k in range(scans):
            compiled.predict_models(mu, Pi, x, P, Fa, Qa, act)
            for j, rx in enumerate(RXS):
                zh, s0, _, _ = compiled.measurement_moments(x, P, act, kinds, TX, rx, wm, wc, scale, use_ukf)
                z_hat[k, j, n], S0[k, j, n] = zh[0, 0], s0[0, 0]
                args = (kinds, TX, rx, wm, wc, scale, use_ukf, np.inf, 1.0, True, np.inf)
                _, taken, ok = compiled.receiver_update(x, P, mu, act, psi, pd, z[k, j, n][None], Rm, rho, *args)
                assert ok and taken[0]
            xs[k, n], Ps[k, n] = x[0, 0], P[0, 0]
    nu = wrap_residual(z - z_hat, angular_mask(names))
    nis = np.einsum("...i,...i->...", nu, np.linalg.solve(S0 + R, nu[..., None])[..., 0])
    return xs, Ps, nis


def _nees(truth, x, P):
    """Position-velocity NEES ``(...)`` of estimates ``x (..., 6)``, ``P (..., 6, 6)``."""
    e = (truth - x)[..., :4]
    return np.einsum("...i,...i->...", e, np.linalg.solve(P[..., :4, :4], e[..., None])[..., 0])


def _round_robin(score):
    """``(N,)`` independent scores from ``(slots..., N)``: run i scored at slot i mod (number of slots)."""
    flat = score.reshape(-1, score.shape[-1])
    i = np.arange(flat.shape[1])
    return flat[i % flat.shape[0], i]


def _band(dof: int, runs: int) -> np.ndarray:
    """Two-sided 95 % interval of the mean of ``runs`` independent chi-square(dof) scores."""
    return chi2.ppf([0.025, 0.975], dof * runs) / runs


def _chirp_sets():
    """(range, range-rate) with the CRLB of each chirp of urban-intersection's library, at scan SNRs from seed 003's
    regime (12-16 dB) to strong echoes (30 dB)."""
    chirps = [w for w in scenarios.get("urban-intersection").waveforms if w.kind == "chirp"]
    snrs = itertools.cycle((15.0, 40.0, 150.0, 1000.0))
    return {
        f"range-rate-{w.name}-snr{snr:g}": (RR, ChirpWaveform(w).covariance(np.array([snr]))[0])
        for w, snr in zip(chirps, snrs, strict=False)
    }


R_AZIMUTH = 0.01**2  # [rad^2]
MEASUREMENT_SETS = {
    "range": (("bistatic_range",), np.array([[0.25]])),
    "range-rate-rho-0.999": (RR, R_SINGULAR),
    "range-rate-well-conditioned": (RR, _correlated(0.5, 0.2, 0.3)),
    **_chirp_sets(),
    "range-azimuth": (("bistatic_range", "azimuth"), np.diag([0.25, R_AZIMUTH])),
    "range-rate-azimuth": (
        (*RR, "azimuth"),
        np.block([[R_SINGULAR, np.zeros((2, 1))], [np.zeros((1, 2)), np.full((1, 1), R_AZIMUTH)]]),
    ),
    "position": (("x", "y"), np.array([[1.0, 0.3], [0.3, 0.5]])),
}


@pytest.mark.parametrize("filt", ["ukf", "ekf"])
@pytest.mark.parametrize("key", list(MEASUREMENT_SETS))
def test_nees_and_nis_are_consistent_for_every_measurement_set(key, filt):
    """A track under way (prior 0.1 m, 0.1 m/s), 1200 runs x 24 scans x 3 receivers, both back ends: the
    round-robin NEES (4 dof) and NIS (m dof) means in their 95 % chi-square intervals."""
    names, R = MEASUREMENT_SETS[key]
    runs, scans = 1200, 24
    P0 = _prior(0.1, 0.1)
    truth, z, x0 = _simulate(names, R, runs, scans, P0, seed=list(MEASUREMENT_SETS).index(key))
    x, P, nis = _track_numpy(names, R, z, x0, P0, filt)
    xc, Pc, nisc = _track_compiled(names, R, z, x0, P0, filt)
    nees, neesc = _round_robin(_nees(truth, x, P)).mean(), _round_robin(_nees(truth, xc, Pc)).mean()
    nis_mean, nisc_mean = _round_robin(nis).mean(), _round_robin(nisc).mean()
    assert neesc == pytest.approx(nees, rel=1e-6)
    assert nisc_mean == pytest.approx(nis_mean, rel=1e-6)
    lo, hi = _band(4, runs)
    assert lo < nees < hi, f"NEES {nees:.3f} outside [{lo:.3f}, {hi:.3f}]"
    lo, hi = _band(len(names), runs)
    assert lo < nis_mean < hi, f"NIS {nis_mean:.3f} outside [{lo:.3f}, {hi:.3f}]"


@pytest.mark.parametrize("backend", ["numpy", "compiled"])
def test_first_scan_of_a_young_track_is_consistent_and_was_not_before_the_fix(backend):
    """A track's first scan from a broad prior (2 m, 1 m/s): range + range-rate with correlation -0.999 from three
    receivers, 4000 runs. The linearisation error the UKF accounts for is then large against the measurement's
    precision along its ridge: the fixed update's NEES is in its 95 % interval, the old formula's ~2.4 times the
    expected 4 (it subtracted K Omega K^T). The EKF, which ignores the linearisation error altogether, is
    ~3 times overconfident here -- a limit of the EKF, not of its update (it is consistent once the track has
    converged, above). The NIS is not a test of this bug: the first receiver's is the same with both formulas."""
    runs = 4000
    P0 = _prior(2.0, 1.0)
    truth, z, x0 = _simulate(RR, R_SINGULAR, runs, 1, P0, seed=0)
    if backend == "numpy":
        x, P, _ = _track_numpy(RR, R_SINGULAR, z, x0, P0, "ukf")
    else:
        x, P, _ = _track_compiled(RR, R_SINGULAR, z, x0, P0, "ukf")
    nees = _nees(truth[0], x[0], P[0]).mean()
    lo, hi = _band(4, runs)
    assert lo < nees < hi, f"NEES {nees:.3f} outside [{lo:.3f}, {hi:.3f}]"
    x_old, P_old, _ = _track_numpy(RR, R_SINGULAR, z, x0, P0, "ukf", update=_old_joseph_update)
    nees_old = _nees(truth[0], x_old[0], P_old[0]).mean()
    assert nees_old > 2.0 * hi, f"old formula NEES {nees_old:.3f}"
