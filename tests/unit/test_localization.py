"""Network kernels (seed 000 section V): ellipse intersection, residual, Algorithm-2 clustering, Pd of a tuple."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from uwb_env.localization import cluster_positions, geometry_covariance, locate, ls_ellipse_intersection
from uwb_env.sim import at_least

TX = np.array([5.75, -0.3])
RX = np.array([[-0.3, 1.5], [-0.3, 4.5], [3.5, 6.3], [8.0, 6.3], [11.8, 4.5], [11.8, 1.5]])


def _ranges(p: np.ndarray, rx: np.ndarray) -> np.ndarray:
    return np.linalg.norm(p - TX) + np.linalg.norm(p - rx, axis=-1)


@pytest.mark.parametrize("nu", [3, 4, 6])
def test_closed_form_recovers_a_known_position_exactly_without_noise(nu):
    p = np.array([[7.3, 2.1], [2.0, 4.4]])
    rx = RX[:nu]
    q = np.stack([_ranges(pi, rx) for pi in p])
    z, res = ls_ellipse_intersection(q, rx, TX)
    np.testing.assert_allclose(z, p, atol=1e-9)
    np.testing.assert_allclose(res, 0.0, atol=1e-9)


def test_residual_flags_inconsistent_tuples_and_noise_spreads_the_solution_with_its_std():
    """nu = 3: a 1 m range error on one receiver gives a residual far above one of noise-free ranges; the spread of
    LS solutions over noisy ranges scales linearly with the range std (the solver is linear near the truth)."""
    p = np.array([6.0, 3.0])
    rx = RX[[0, 2, 4]]
    q = _ranges(p, rx)
    _, res = ls_ellipse_intersection(np.stack([q, q + np.array([1.0, 0, 0])]), rx, TX)
    assert res[0] < 1e-9 < 0.05 < res[1]
    rng = np.random.default_rng(0)
    e = rng.standard_normal((20000, 3))
    spreads = []
    for std in (0.01, 0.04):
        z, _ = ls_ellipse_intersection(q + std * e, rx, TX)
        spreads.append(np.cov(z.T))
    np.testing.assert_allclose(spreads[1], 16.0 * spreads[0], rtol=0.02)


def test_geometry_covariance_is_the_crlb_of_the_ranges():
    """(J^T J)^-1 sigma^2 by hand for far nodes (unit vectors along the axes); one receiver is singular, not NaN."""
    p = np.array([0.0, 0.0])
    tx = np.array([0.0, -1e6])  # far transmitter: u_t = (0, 1)
    rx = np.array([[-1e6, 0.0], [0.0, 1e6]])  # u_r = (1, 0) and (0, -1) -> rows (1, 1) and (0, 0)
    cov = geometry_covariance(p, tx[None], rx[:1], 0.01)
    # one receiver: one row (1, 1): information 100 * [[1, 1], [1, 1]] is singular -> huge but finite
    assert np.isfinite(cov).all() and cov.max() > 1e6
    rx = np.array([[-1e6, 0.0], [1e6, 0.0]])  # rows (1, 1) and (-1, 1)
    cov = geometry_covariance(p, np.stack([tx, tx]), rx, 0.01)
    np.testing.assert_allclose(cov, 0.01 * np.linalg.inv(np.array([[2.0, 0.0], [0.0, 2.0]])), rtol=1e-6)


def test_clustering_linkages_on_a_hand_example():
    # points on a line: 0, 1, 2.2 and 10
    z = np.array([[0.0, 0.0], [1.0, 0.0], [2.2, 0.0], [10.0, 0.0]])
    # single: 0-1 (1.0), then {0,1}-2.2 at min distance 1.2 -> one cluster of three, threshold 1.5
    idx, c = cluster_positions(z, 1.5, "single")
    assert idx.tolist() == [0, 0, 0, 1]
    np.testing.assert_allclose(c, [[3.2 / 3, 0.0], [10.0, 0.0]])
    # centroid: {0,1} centroid 0.5 -> 2.2 is 1.7 away: stays apart
    idx, _ = cluster_positions(z, 1.5, "centroid")
    assert idx.tolist() == [0, 0, 1, 2]
    # complete: max distance {0,1}-2.2 = 2.2: apart at 1.5, together at 2.5
    assert cluster_positions(z, 1.5, "complete")[0].tolist() == [0, 0, 1, 2]
    assert cluster_positions(z, 2.5, "complete")[0].tolist() == [0, 0, 0, 1]
    with pytest.raises(ValueError, match="linkage"):
        cluster_positions(z, 1.0, "ward")


def test_locate_keeps_the_target_and_drops_light_and_inconsistent_tuples():
    p = np.array([6.0, 3.0])
    rxs = [0, 2, 4, 5]
    ranges = [*_ranges(p, RX[rxs]).tolist(), 9.0, 12.0]  # + two clutter detections on receivers 0 and 2
    receiver = np.array([*rxs, 0, 2])
    weights = np.array([12.0, 12, 12, 12, 5, 12])
    tx = np.broadcast_to(TX, (receiver.size, 2))
    z, cov, used = locate(
        np.array(ranges),
        weights,
        receiver,
        tx,
        RX[receiver],
        np.array([0, 11.5, 0, 6]),
        3,
        30.0,
        0.15,
        0.5,
        "centroid",
        0.05,
    )
    assert z.shape == (1, 2)
    np.testing.assert_allclose(z[0], p, atol=1e-9)
    assert used[0].tolist() == [0, 1, 2, 3]
    assert np.all(np.linalg.eigvalsh(cov[0]) > 0)


def test_at_least_matches_enumeration():
    rng = np.random.default_rng(1)
    pd = rng.uniform(0, 1, (5, 4))
    for n in (1, 3, 5):
        brute = np.zeros(4)
        for hits in itertools.product([0, 1], repeat=5):
            if sum(hits) >= n:
                brute += np.prod([pd[i] if h else 1 - pd[i] for i, h in enumerate(hits)], axis=0)
        np.testing.assert_allclose(at_least(pd, n), brute, rtol=1e-12)


def test_monostatic_tuples_are_solved_by_gauss_newton_with_the_same_residual():
    """Radars at different places (tx = rx): no common transmitter, so Gauss-Newton; exact without noise."""
    radars = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 8.0], [10.0, 8.0]])
    p = np.array([3.0, 5.0])
    q = 2.0 * np.linalg.norm(p - radars, axis=1)
    z, cov, used = locate(
        np.r_[q, 7.0],
        np.full(5, 12.0),
        np.r_[np.arange(4), 0],
        radars[np.r_[np.arange(4), 0]],
        radars[np.r_[np.arange(4), 0]],
        np.array([0, 10, 0, 8]),
        3,
        30.0,
        0.15,
        0.5,
        "centroid",
        0.05,
    )
    np.testing.assert_allclose(z, [p], atol=1e-6)
    assert sorted(used[0].tolist()) == [0, 1, 2, 3]
    # monostatic gradient rows are 2 u: covariance (sum 4 u u^T)^-1 sigma^2
    u = (p - radars) / np.linalg.norm(p - radars, axis=1)[:, None]
    np.testing.assert_allclose(cov[0], 0.0025 * np.linalg.inv(4 * u.T @ u), rtol=1e-6)


def test_compiled_ellipse_intersection_equals_the_numpy_reference():
    """Random 2- and 3-receiver tuples (including ones with no intersection): each start's Gauss-Newton solution
    is the same to rounding; over several starts the best cost is the same (two receivers' ellipses meet twice
    with cost ~0 at both, so which mirror point wins the argmin is a matter of rounding)."""
    from uwb_env.localization.compiled import ellipse_intersection_fast
    from uwb_env.localization.ellipse import ellipse_intersection

    rng = np.random.default_rng(12)
    starts = np.array([[0.0, 0.0], [-60.0, -60.0], [60.0, -60.0], [-60.0, 60.0], [60.0, 60.0]])
    for nu in (2, 3):
        N = 300
        tx = np.broadcast_to(np.array([0.0, 0.0]), (N, nu, 2))
        rx = rng.uniform(-20, 20, (N, nu, 2))
        target = rng.uniform(-150, 150, (N, 2))
        q = np.linalg.norm(target[:, None] - tx, axis=-1) + np.linalg.norm(target[:, None] - rx, axis=-1)
        q = q + rng.normal(scale=0.5, size=q.shape)
        q[:5] = 1.0  # shorter than the baselines: no intersection
        var = rng.uniform(0.1, 2.0, (N, nu))
        for s in range(starts.shape[0]):
            ref = ellipse_intersection(q, var, tx, rx, starts[s : s + 1])
            got = ellipse_intersection_fast(q, var, tx, rx, starts[s : s + 1])
            # compared where Gauss-Newton has converged (one more iteration moves it by < 1 nm): elsewhere an
            # ill-conditioned tuple amplifies rounding, in both implementations alike
            more = ellipse_intersection(q, var, tx, rx, starts[s : s + 1], n_iter=16)
            conv = np.all(np.abs(more[0] - ref[0]) < 1e-9, axis=1)
            assert conv.mean() > 0.8
            np.testing.assert_allclose(got[0][conv], ref[0][conv], rtol=1e-7, atol=1e-7)
            np.testing.assert_allclose(got[1][conv], ref[1][conv], rtol=1e-5, atol=1e-9)
            np.testing.assert_allclose(got[2][conv], ref[2][conv], rtol=1e-5, atol=1e-9)
        ref = ellipse_intersection(q, var, tx, rx, starts)
        got = ellipse_intersection_fast(q, var, tx, rx, starts)
        assert np.mean(np.isclose(got[2], ref[2], rtol=1e-5, atol=1e-8)) > 0.97


def test_two_ellipse_intersections_lie_on_both_ellipses_and_include_the_target():
    """Closed form: every returned point satisfies both range equations to 1e-9 m; the true target is one of them."""
    from uwb_env.localization.compiled import two_ellipse_intersections

    rng = np.random.default_rng(3)
    tx = np.array([2085.0, 1470.5])
    rx = np.array([[2088.0, 1475.0], [2078.0, 1467.0]])  # seed 003's network
    targets = rng.uniform([1950.0, 1480.0], [2070.0, 1660.0], (200, 2))
    q = np.linalg.norm(targets - tx, axis=1)[:, None] + np.linalg.norm(targets[:, None] - rx[None], axis=2)
    pos, cov, ok = two_ellipse_intersections(q, np.full((200, 2), 0.36), tx, rx)
    assert ok.all(axis=1).mean() > 0.95  # two crossings for almost every target
    h = np.linalg.norm(pos - tx, axis=-1)[..., None] + np.linalg.norm(pos[..., None, :] - rx, axis=-1)
    np.testing.assert_allclose(h[ok], np.repeat(q[:, None], 2, axis=1)[ok], atol=1e-9)
    err = np.where(ok, np.linalg.norm(pos - targets[:, None], axis=-1), np.inf).min(axis=1)
    assert err.max() < 1e-6
    # the covariance is the information of the two ranges at the point (J^T V^-1 J)^-1
    i, k = np.argwhere(ok)[0]
    p = pos[i, k]
    J = np.stack([(p - tx) / np.linalg.norm(p - tx) + (p - r) / np.linalg.norm(p - r) for r in rx])
    np.testing.assert_allclose(np.linalg.inv(J.T @ J / 0.36), cov[i, k], rtol=1e-4)  # but the 1e-9 trace regulariser
