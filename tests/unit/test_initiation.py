"""Initiation kernels: exact candidates without noise, covariance scaling, fusion, the two-point velocity gate."""

from __future__ import annotations

import numpy as np
import pytest

from uwb_env.localization.ellipse import ellipse_intersection
from uwb_env.tracking.initiation import (
    fuse_candidates,
    range_azimuth_candidates,
    range_only_candidates,
    ridge_range,
    two_point_pairs,
)

TX = np.array([0.0, 0.0])
RXS = np.array([[20.0, 0.0], [0.0, 20.0], [40.0, -5.0], [-10.0, 30.0]])


def bistatic(p, rx):
    return np.linalg.norm(p - TX, axis=-1) + np.linalg.norm(p - rx, axis=-1)


def test_range_azimuth_candidate_is_exact_and_its_covariance_is_first_order():
    p = np.array([[60.0, 40.0], [5.0, -30.0], [-20.0, 10.0]])
    rx = RXS[0]
    r = bistatic(p, rx)
    th = np.arctan2(p[:, 1] - rx[1], p[:, 0] - rx[0])
    pos, cov, ok = range_azimuth_candidates(r, np.full(3, 0.04), th, np.full(3, 1e-6), TX, rx)
    assert ok.all()
    np.testing.assert_allclose(pos, p, atol=1e-9)
    # Monte Carlo of the mapping at small noise agrees with J diag J^T (first order), within 5 %
    rng = np.random.default_rng(1)
    n = 20000
    rr = r[0] + 0.2 * rng.standard_normal(n)
    tt = th[0] + 1e-3 * rng.standard_normal(n)
    mc, _, _ = range_azimuth_candidates(rr, np.full(n, 0.04), tt, np.full(n, 1e-6), TX, rx)
    np.testing.assert_allclose(np.cov(mc.T), cov[0], rtol=0.05, atol=1e-4 * np.abs(cov[0]).max())


def test_range_inside_the_baseline_is_not_a_candidate():
    _, _, ok = range_azimuth_candidates(np.array([15.0]), np.ones(1), np.array([0.3]), np.ones(1) * 1e-4, TX, RXS[0])
    assert not ok[0]


@pytest.mark.parametrize("nu", [3, 4])
def test_ellipse_intersection_recovers_a_known_position_and_covariance_scales_with_noise(nu):
    p = np.array([17.0, 11.0])
    rx = RXS[:nu]
    r = bistatic(p[None], rx)[None]
    tx = np.zeros((1, nu, 2))
    starts = np.array([[0.0, 0.0], [30.0, 30.0]])
    pos, cov1, cost = ellipse_intersection(r, np.full((1, nu), 0.01), tx, rx[None], starts)
    np.testing.assert_allclose(pos[0], p, atol=1e-8)
    assert cost[0] < 1e-12
    _, cov4, _ = ellipse_intersection(r, np.full((1, nu), 0.04), tx, rx[None], starts)
    np.testing.assert_allclose(cov4, 4.0 * cov1, rtol=1e-9)  # covariance scales with the range variance


def test_range_only_candidates_reject_inconsistent_tuples():
    p = np.array([17.0, 11.0])
    groups = [
        (np.array([bistatic(p, RXS[i]), bistatic(p, RXS[i]) + 25.0]), np.full(2, 0.01), TX, RXS[i]) for i in range(3)
    ]
    pos, _ = range_only_candidates(
        groups, 3, np.array([-50.0, 50.0, -50.0, 50.0]), np.array([[0.0, 0.0], [30.0, 30.0], [10.0, -20.0]])
    )
    assert pos.shape[0] >= 1
    assert np.min(np.linalg.norm(pos - p, axis=1)) < 1e-6
    # every accepted tuple fits its ranges: the clean one only, or near-consistent ghosts far from noise
    assert pos.shape[0] < 8


def test_ridge_range_removes_the_range_rate_coupling():
    R = np.array([[[225.0, -1.5e4], [-1.5e4, 1.0e6 + 1.5e4**2 / 225.0 * 0.999]]])
    z = np.array([[100.0, 3000.0]])
    r, var = ridge_range(z, R, ("bistatic_range", "range_rate"), 40.0)
    slope = R[0, 0, 1] / R[0, 1, 1]
    assert r[0] == pytest.approx(100.0 - slope * 3000.0)
    assert var[0] == pytest.approx(R[0, 0, 0] - slope * R[0, 0, 1] + slope**2 * 40.0**2 / 3)
    assert var[0] < R[0, 0, 0]


def test_fuse_candidates_mutual_pairs_only_information_weighted():
    p = np.array([[0.0, 0.0], [0.3, 0.0], [50.0, 50.0]])
    cov = np.stack([np.eye(2), 3 * np.eye(2), np.eye(2)])
    fp, fc = fuse_candidates(p, cov, 9.21)
    assert fp.shape[0] == 2
    fused = fp[np.argmin(np.linalg.norm(fp, axis=1))]
    np.testing.assert_allclose(fused, [0.3 * 1 / 4, 0.0])  # (1 * 0 + 1/3 * 0.3) / (1 + 1/3)
    np.testing.assert_allclose(fc[np.argmin(np.linalg.norm(fp, axis=1))], 0.75 * np.eye(2))


def test_two_point_gate_is_the_seeds_velocity_box():
    """|dx / T| <= v_max + 2 sigma_v per axis (seed 003 section 4.2.1); each candidate used once."""
    T, vmax = 0.25, 20.0
    cov = np.stack([np.eye(2) * 1e-6] * 3)
    prev = np.array([[0.0, 0.0], [100.0, 0.0], [200.0, 0.0]])
    cur = np.array([[4.9, 0.0], [100.0, 5.2], [200.0, 2.0]])  # 19.6 m/s ok, 20.8 m/s rejected, 8 m/s ok
    i, j = two_point_pairs(cur, cov, prev, cov, T, vmax)
    assert sorted(zip(i.tolist(), j.tolist(), strict=True)) == [(0, 0), (2, 2)]
    # position noise widens the gate by 2 sigma_v: sigma_v^2 = (s^2 + s^2) / T^2 = 0.5^2 -> gate 21 m/s
    s2 = (0.5 * T) ** 2 / 2
    noisy = np.stack([np.eye(2) * s2] * 3)
    i2, j2 = two_point_pairs(cur, noisy, prev, noisy, T, vmax)
    assert sorted(zip(i2.tolist(), j2.tolist(), strict=True)) == [(0, 0), (1, 1), (2, 2)]
