"""Folded range-rate in the tracker (tracking.ambiguity): marginalised = range-only update, resolved = unwrapped."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import multivariate_normal

from uwb_env.tracking import ambiguity
from uwb_env.tracking.kernels import UnscentedWeights, joseph_update, ukf_moments

TX, RX = np.array([0.0, 0.0]), np.array([40.0, 0.0])
NAMES = ("bistatic_range", "range_rate")
W = UnscentedWeights(6)
PERIOD = 7.5


def _state(vel_std: float) -> tuple[np.ndarray, np.ndarray]:
    x = np.array([[30.0, 8.0, 60.0, 5.0, 0.0, 0.0]])  # bistatic range-rate 11.7 m/s: beyond P / 2
    P = np.diag([4.0, vel_std**2, 4.0, vel_std**2, 0.5, 0.5])[None]
    P[0, 0, 1] = P[0, 1, 0] = 0.5 * 2.0 * vel_std  # correlation 0.5
    return x, P


def test_unresolved_update_is_the_range_only_update_and_its_likelihood_factor_is_one_over_p():
    x, P = _state(vel_std=6.0)  # a new track's two-point velocity: range-rate std >> P / 6
    z_hat, S0, C = ukf_moments(NAMES, x, P, TX, RX, W, np.zeros(2, bool))
    blind = ambiguity.unresolved(S0, 1, PERIOD)
    assert blind.all()
    S0m, Cm = ambiguity.marginalise(S0, C, 1, PERIOD, blind)
    R = np.diag([0.36, 1e-3])[None]
    z = np.array([[z_hat[0, 0] + 1.3, 2.9]])
    nu = z - z_hat
    nu[0, 1] = 0.0  # fold_innovations zeroes the marginalised component
    xu, Pu = joseph_update(x, P, Cm, S0m, R, nu)
    # the range-only update
    _, S01, C1 = ukf_moments(NAMES[:1], x, P, TX, RX, W, np.zeros(1, bool))
    x1, P1 = joseph_update(x, P, C1, S01, R[:, :1, :1], (z - z_hat)[:, :1])
    np.testing.assert_allclose(xu, x1, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(Pu, P1, rtol=1e-9, atol=1e-12)
    # likelihood: range-only Gaussian times 1 / P (to R_dd / P^2)
    full = multivariate_normal(np.zeros(2), S0m[0] + R[0]).pdf(nu[0])
    one = multivariate_normal(0.0, S01[0, 0, 0] + R[0, 0, 0]).pdf((z - z_hat)[0, 0])
    assert full == pytest.approx(one / PERIOD, rel=1e-4)


def test_resolved_track_unwraps_the_folded_measurement_to_the_nearest_alias():
    x, P = _state(vel_std=0.1)
    z_hat, S0, C = ukf_moments(NAMES, x, P, TX, RX, W, np.zeros(2, bool))
    blind = ambiguity.unresolved(S0, 1, PERIOD)
    assert not blind.any()
    true_rdot = z_hat[0, 1] + 0.2
    folded = true_rdot - PERIOD * math.floor(true_rdot / PERIOD + 0.5)
    assert abs(folded - true_rdot) > 1.0  # the measurement really is folded
    z = np.array([[z_hat[0, 0] + 0.4, folded]])
    nu = ambiguity.fold_innovations((z - z_hat)[:, None, None, :].copy(), 1, PERIOD, blind[:, None])[:, 0, 0]
    assert nu[0, 1] == pytest.approx(0.2, abs=1e-9)
    R = np.diag([0.36, 1e-3])[None]
    xu, Pu = joseph_update(x, P, C, S0, R, nu)
    xt, Pt = joseph_update(x, P, C, S0, R, np.array([[0.4, 0.2]]))  # as if unambiguous
    np.testing.assert_allclose(xu, xt, atol=1e-9)
    np.testing.assert_allclose(Pu, Pt, atol=1e-12)


def test_threshold_is_six_stds_per_period():
    S0 = np.zeros((2, 2, 2))
    S0[0, 1, 1] = (PERIOD / 6) ** 2 * 0.99
    S0[1, 1, 1] = (PERIOD / 6) ** 2 * 1.01
    np.testing.assert_array_equal(ambiguity.unresolved(S0, 1, PERIOD), [False, True])
