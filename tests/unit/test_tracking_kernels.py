"""Tracking kernels against closed forms: KF by hand, UKF = KF on linear measurements, Jacobians, IMM, LMIPDA."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uwb_env.scene.motion_models import ncv_transition, process_noise
from uwb_env.tracking import (
    UnscentedWeights,
    ekf_moments,
    imm_combine,
    imm_mix,
    joseph_update,
    kf_predict,
    lmipda,
    measure,
    mixture_reduce,
    restrict_transition,
    switch_model_sets,
    ukf_moments,
)
from uwb_env.tracking.measurement import angular_mask

TX, RX = np.array([0.0, 0.0]), np.array([30.0, -5.0])


def random_spd(rng, n, scale=1.0):
    A = rng.standard_normal((n, n))
    return scale * (A @ A.T + n * np.eye(n))


def test_kf_predict_by_hand():
    """NCV, T = 2: x = (1, 3, -2, 0.5) -> (7, 3, -1, 0.5); P_xx = p + 2 T c + T^2 v + Q."""
    F, G = ncv_transition(2.0)
    Q = process_noise(G, 0.5)
    x = np.array([1.0, 3.0, -2.0, 0.5, 0.0, 0.0])
    P = np.diag([4.0, 1.0, 4.0, 1.0, 0.0, 0.0])
    P[0, 1] = P[1, 0] = 0.5
    xp, Pp = kf_predict(x, P, F, Q)
    np.testing.assert_allclose(xp, [7.0, 3.0, -1.0, 0.5, 0.0, 0.0])
    assert Pp[0, 0] == pytest.approx(4.0 + 2 * 2.0 * 0.5 + 4.0 * 1.0 + 0.25 * 2.0**4 / 4)
    assert Pp[0, 1] == pytest.approx(0.5 + 2.0 * 1.0 + 0.25 * 2.0**3 / 2)
    assert Pp[1, 1] == pytest.approx(1.0 + 0.25 * 2.0**2)


def test_linear_update_equals_textbook_kalman_filter_for_ekf_and_ukf(rng):
    """Position measurement (x, y): EKF and UKF moments are exact, Joseph update = K = P H^T S^-1 textbook."""
    names = ("x", "y")
    x = rng.standard_normal(6) * 10
    P = random_spd(rng, 6)
    R = random_spd(rng, 2, 0.5)
    z = rng.standard_normal(2) * 10
    H = np.zeros((2, 6))
    H[0, 0] = H[1, 2] = 1.0
    S = H @ P @ H.T + R
    K = P @ H.T @ np.linalg.inv(S)
    x_kf = x + K @ (z - H @ x)
    P_kf = (np.eye(6) - K @ H) @ P
    ang = angular_mask(names)
    for z_hat, S0, C in (ekf_moments(names, x, P, TX, RX), ukf_moments(names, x, P, TX, RX, UnscentedWeights(6), ang)):
        np.testing.assert_allclose(z_hat, H @ x, atol=1e-9)
        np.testing.assert_allclose(S0 + R, S, rtol=1e-9)
        xu, Pu = joseph_update(x, P, C, S0, R, z - z_hat)
        np.testing.assert_allclose(xu, x_kf, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(Pu, P_kf, rtol=1e-8, atol=1e-9)


@pytest.mark.parametrize("name", ["bistatic_range", "range_rate", "azimuth"])
def test_jacobians_match_finite_differences(name, rng):
    x = np.array([40.0, 3.0, 25.0, -7.0, 0.5, 0.2]) + rng.standard_normal(6)
    _, J = measure((name,), x, TX, RX)
    h = 1e-6
    fd = np.array(
        [
            (measure((name,), x + h * e, TX, RX)[0] - measure((name,), x - h * e, TX, RX)[0])[0] / (2 * h)
            for e in np.eye(6)
        ]
    )
    np.testing.assert_allclose(J[0], fd, rtol=1e-6, atol=1e-9)


def test_ukf_close_to_ekf_when_uncertainty_is_small():
    names = ("bistatic_range", "range_rate", "azimuth")
    x = np.array([200.0, 5.0, 120.0, -3.0, 0.0, 0.0])
    P = np.diag([0.01, 0.001, 0.01, 0.001, 1e-4, 1e-4])
    a = ekf_moments(names, x, P, TX, RX)
    b = ukf_moments(names, x, P, TX, RX, UnscentedWeights(6), angular_mask(names))
    for u, v in zip(a, b, strict=True):
        np.testing.assert_allclose(u, v, rtol=1e-3, atol=1e-9)


def test_imm_with_one_model_is_the_single_filter(rng):
    x = rng.standard_normal((3, 1, 6))
    P = np.stack([random_spd(rng, 6) for _ in range(3)])[:, None]
    cbar, x0, P0 = imm_mix(np.ones((3, 1)), np.ones((3, 1, 1)), x, P)
    np.testing.assert_allclose(cbar, 1.0)
    np.testing.assert_allclose(x0, x)
    np.testing.assert_allclose(P0, P)
    xc, Pc = imm_combine(np.ones((3, 1)), x, P)
    np.testing.assert_allclose(xc, x[:, 0])
    np.testing.assert_allclose(Pc, P[:, 0])


def test_imm_mixing_and_combination_two_models_by_hand():
    """1-D state: mu = (0.6, 0.4), Pi = [[0.9, 0.1], [0.2, 0.8]], x = (0, 10), P = (1, 4)."""
    mu = np.array([[0.6, 0.4]])
    Pi = np.array([[[0.9, 0.1], [0.2, 0.8]]])
    x = np.array([[[0.0], [10.0]]])
    P = np.array([[[[1.0]], [[4.0]]]])
    cbar, x0, P0 = imm_mix(mu, Pi, x, P)
    c1, c2 = 0.6 * 0.9 + 0.4 * 0.2, 0.6 * 0.1 + 0.4 * 0.8  # 0.62, 0.38
    np.testing.assert_allclose(cbar, [[c1, c2]])
    w11, w21 = 0.54 / c1, 0.08 / c1
    w12, w22 = 0.06 / c2, 0.32 / c2
    m1, m2 = w21 * 10.0, w22 * 10.0
    np.testing.assert_allclose(x0[0, :, 0], [m1, m2])
    np.testing.assert_allclose(P0[0, 0, 0, 0], w11 * (1 + m1**2) + w21 * (4 + (10 - m1) ** 2))
    np.testing.assert_allclose(P0[0, 1, 0, 0], w12 * (1 + m2**2) + w22 * (4 + (10 - m2) ** 2))
    xc, Pc = imm_combine(mu, x, P)
    np.testing.assert_allclose(xc[0], [4.0])
    np.testing.assert_allclose(Pc[0, 0, 0], 0.6 * (1 + 16) + 0.4 * (4 + 36))


def test_restricted_transition_rows_renormalise_on_the_active_set():
    Pi = np.array([[0.99, 0.01, 0, 0], [0.1, 0.7, 0.1, 0.1], [0, 0.01, 0.99, 0], [0, 0.01, 0, 0.99]])
    R = restrict_transition(Pi, np.array([[False, True, True, True], [True, True, False, False]]))
    np.testing.assert_allclose(R.sum(axis=-1), 1.0)
    np.testing.assert_allclose(R[0, 1, 1:], np.array([0.7, 0.1, 0.1]) / 0.9)
    np.testing.assert_allclose(R[0, 0, 1:], [1.0, 0.0, 0.0])  # NCV -> only NCA left
    np.testing.assert_allclose(R[1, 2, :2], [0.0, 1.0])


def test_vs_imm_switch_conserves_probability_and_seeds_added_models(rng):
    x = rng.standard_normal((1, 4, 6))
    P = np.stack([random_spd(rng, 6) for _ in range(4)])[None]
    mu = np.array([[0.7, 0.3, 0.0, 0.0]])
    old = np.array([[True, True, False, False]])
    new = np.array([[False, True, True, True]])
    mu2, x2, P2 = switch_model_sets(old, new, mu, x, P)
    np.testing.assert_allclose(mu2, [[0.0, 0.3, 0.35, 0.35]])  # NCV's 0.7 shared by the two added CT models
    xc, Pc = imm_combine(mu, x, P)
    np.testing.assert_allclose(x2[0, 2], xc[0])
    np.testing.assert_allclose(P2[0, 3], Pc[0])
    np.testing.assert_allclose(x2[0, 1], x[0, 1])


def test_lmipda_single_track_pd1_pg1_no_clutter_is_the_filter_update(rng):
    """One track, P_D = P_G = 1, a vanishing clutter intensity: beta_1 = 1, existence -> 1, PDA = KF update."""
    x = rng.standard_normal((1, 1, 6))
    P = random_spd(rng, 6)[None, None]
    names = ("x", "y")
    z_hat, S0, C = ekf_moments(names, x, P, TX, RX)
    R = np.eye(2)[None]
    z = z_hat[0, 0] + np.array([0.3, -0.2])
    nu = (z - z_hat)[:, :, None]
    log_ratio = np.full((1, 1, 1), 60.0)  # rho -> 0
    psi, _, beta = lmipda(log_ratio, np.ones((1, 1, 1), bool), np.ones((1, 1)), np.array([0.5]), np.ones(1), 1.0)
    np.testing.assert_allclose(beta[0, 0], [0.0, 1.0], atol=1e-20)
    assert psi[0] == pytest.approx(1.0, abs=1e-20)
    xu, Pu = joseph_update(x[:, :, None], P[:, :, None], C[:, :, None], S0[:, :, None], R[None, None], nu)
    xm, Pm = mixture_reduce(beta, np.concatenate([x[:, :, None], xu], 2), np.concatenate([P[:, :, None], Pu], 2))
    np.testing.assert_allclose(xm[0, 0], xu[0, 0, 0])
    np.testing.assert_allclose(Pm[0, 0], Pu[0, 0, 0])


def test_existence_update_matches_the_seed_formula():
    """psi+ = (1 - delta) psi / (1 - delta psi), delta = P_D P_G (1 - sum_i p_i / rho_i) (single track)."""
    pd, pg, psi = 0.8, 0.95, 0.3
    lam = np.array([2.0, 0.5])  # p_i / rho_i
    delta = pd * pg * (1 - lam.sum())
    post, _, beta = lmipda(
        np.log(lam)[None, None], np.ones((1, 1, 2), bool), np.ones((1, 1)), np.array([psi]), np.array([pd]), pg
    )
    assert post[0] == pytest.approx((1 - delta) * psi / (1 - delta * psi))
    np.testing.assert_allclose(beta[0, 0], np.array([1 - pd * pg, pd * pg * 2.0, pd * pg * 0.5]) / (1 - delta))
    # no measurement: delta = P_D P_G and existence drops
    post0, _, _ = lmipda(
        np.zeros((1, 1, 0)), np.zeros((1, 1, 0), bool), np.ones((1, 1)), np.array([psi]), np.array([pd]), pg
    )
    assert post0[0] == pytest.approx((1 - pd * pg) * psi / (1 - pd * pg * psi))


def test_lmipda_second_track_acts_as_clutter():
    """Two tracks claim one measurement: each one's Omega includes the other's claim, so each beta_1 drops."""
    one = lmipda(np.log([[[5.0]]]), np.ones((1, 1, 1), bool), np.ones((1, 1)), np.array([0.9]), np.array([0.9]), 0.99)
    two = lmipda(
        np.log([[[5.0]], [[5.0]]]),
        np.ones((2, 1, 1), bool),
        np.ones((2, 1)),
        np.array([0.9, 0.9]),
        np.full(2, 0.9),
        0.99,
    )
    assert two[2][0, 0, 1] < one[2][0, 0, 1]
    np.testing.assert_allclose(two[2][0], two[2][1])


@settings(max_examples=100, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    n_meas=st.integers(0, 6),
    r=st.integers(1, 4),
    n_tracks=st.integers(1, 4),
    pd=st.floats(0.01, 0.999),
    pg=st.floats(0.5, 0.9999),
)
def test_lmipda_probabilities_stay_on_the_simplex(seed, n_meas, r, n_tracks, pd, pg):
    rng = np.random.default_rng(seed)
    mu = rng.dirichlet(np.ones(r), n_tracks)
    gated = rng.random((n_tracks, r, n_meas)) < 0.7
    log_ratio = rng.normal(0, 5, (n_tracks, r, n_meas))
    psi, mu_post, beta = lmipda(log_ratio, gated, mu, rng.random(n_tracks), np.full(n_tracks, pd), pg)
    assert np.all((psi >= 0) & (psi <= 1))
    np.testing.assert_allclose(mu_post.sum(-1), 1.0, atol=1e-9)
    np.testing.assert_allclose(beta.sum(-1), 1.0, atol=1e-9)
    assert np.all(beta >= 0)


@settings(max_examples=100, deadline=None)
@given(seed=st.integers(0, 10_000), log_scale=st.floats(-6, 6), rng_m=st.floats(5, 500))
def test_joseph_update_keeps_covariances_symmetric_positive_definite(seed, log_scale, rng_m):
    rng = np.random.default_rng(seed)
    x = np.array([rng_m, 2.0, rng_m / 2, -1.0, 0.1, 0.0])
    P = random_spd(rng, 6, 10.0**log_scale)
    names = ("bistatic_range", "range_rate", "azimuth")
    R = random_spd(rng, 3, 10.0 ** (log_scale - 2))
    for moments in (
        ekf_moments(names, x, P, TX, RX),
        ukf_moments(names, x, P, TX, RX, UnscentedWeights(6), angular_mask(names)),
    ):
        _, S0, C = moments
        _, Pu = joseph_update(x, P, C, S0, R, rng.standard_normal(3))
        np.testing.assert_allclose(Pu, Pu.T)
        assert np.all(np.linalg.eigvalsh(Pu) > -1e-9 * np.abs(P).max())
        np.linalg.cholesky(Pu + 1e-12 * np.abs(P).max() * np.eye(6))


def test_pda_mode_claims_as_if_existing_and_still_updates_existence():
    """fixed_existence: one track's beta is IPDA's (beta is conditioned on existence); with two tracks each
    claims with psi = 1, so the other's beta drops as if it were certain; psi is updated either way."""
    lr = np.log([[[3.0, 0.5]]])
    g = np.ones((1, 1, 2), bool)
    ipda = lmipda(lr, g, np.ones((1, 1)), np.array([0.3]), np.array([0.9]), 0.99)
    pda = lmipda(lr, g, np.ones((1, 1)), np.array([0.3]), np.array([0.9]), 0.99, fixed_existence=True)
    np.testing.assert_allclose(pda[2], ipda[2])
    np.testing.assert_allclose(pda[0], ipda[0])
    two_lr = np.log([[[3.0]], [[3.0]]])
    g2 = np.ones((2, 1, 1), bool)
    low = np.array([0.1, 0.1])
    lm = lmipda(two_lr, g2, np.ones((2, 1)), low, np.full(2, 0.9), 0.99)
    pd_ = lmipda(two_lr, g2, np.ones((2, 1)), low, np.full(2, 0.9), 0.99, fixed_existence=True)
    assert pd_[2][0, 0, 1] < lm[2][0, 0, 1]


def test_lmipda_existence_never_exceeds_one_by_rounding():
    """(1 - delta) psi / (1 - delta psi) <= 1 exactly, but not after rounding: a case found by search, where the plain
    expression gives 1 + 2^-52 (a track at psi = 1 - 2^-52 whose measurement's likelihood ratios sum past P_D P_G)."""
    lr0, lr1, w = 1.2072844334691002, 2.6214445811755693, 0.8523409919169496
    psi, pd, pg = 0.9999999999999998, 0.842341338465401, 0.99
    log_ratio = np.array([[[lr0], [lr1]]])
    mu = np.array([[w, 1.0 - w]])
    lam = mu[0, 0] * np.exp(lr0) + mu[0, 1] * np.exp(lr1)  # one track, one measurement: omega = 1, share = lambda
    delta = pd * pg * (mu[0, 0] * (1.0 - np.exp(lr0)) + mu[0, 1] * (1.0 - np.exp(lr1)))
    assert delta < 0 < lam and (1.0 - delta) * psi / (1.0 - delta * psi) > 1.0  # the plain expression overshoots
    psi_post = lmipda(log_ratio, np.ones((1, 2, 1), bool), mu, np.array([psi]), np.array([pd]), pg)[0]
    assert psi_post[0] == 1.0
