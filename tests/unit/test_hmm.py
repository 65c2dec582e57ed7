"""Seed 004's kernels: symmetric KL, HMM forward-backward and Baum-Welch, delay estimates, grid localization."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate, stats

from uwb_env.detection import hmm
from uwb_env.localization import grid
from uwb_env.sensing.signal import cir
from uwb_env.sensing.signal.cir import C_M_PER_NS, CirConfig, RoomConfig, bin_energy, point_grid, simulate_room


def _random_params(rng: np.random.Generator) -> hmm.HmmParams:
    p01, p10 = rng.uniform(0.05, 0.5, 2)
    pi1 = rng.uniform(0.05, 0.95)
    return hmm.HmmParams(
        [1 - pi1, pi1], [[1 - p01, p01], [p10, 1 - p10]], rng.normal(0, 1.5, 2), rng.uniform(0.3, 3.0, 2)
    )


def _sample(rng: np.random.Generator, p: hmm.HmmParams, B: int, N: int) -> tuple[np.ndarray, np.ndarray]:
    """Sequences of O (log-normal emissions) and their states."""
    x = np.empty((B, N), dtype=int)
    x[:, 0] = rng.random(B) < p.pi[1]
    for k in range(1, N):
        x[:, k] = rng.random(B) < p.P[x[:, k - 1], 1]
    y = rng.normal(p.mean[x], np.sqrt(p.var[x]))
    return np.exp(y), x


def test_symmetric_kl_matches_numerical_integration():
    for mu_p, s_p, mu_q, s_q in [(0.0, 1.0, 0.0, 1.0), (1.0, 0.5, -0.3, 2.0), (3.0, 1.2, 2.5, 0.7)]:
        p, q = stats.norm(mu_p, s_p), stats.norm(mu_q, s_q)
        lo, hi = min(mu_p, mu_q) - 12 * max(s_p, s_q), max(mu_p, mu_q) + 12 * max(s_p, s_q)
        d_pq = integrate.quad(lambda x, a=p, b=q: a.pdf(x) * (a.logpdf(x) - b.logpdf(x)), lo, hi, limit=200)[0]
        d_qp = integrate.quad(lambda x, a=q, b=p: a.pdf(x) * (a.logpdf(x) - b.logpdf(x)), lo, hi, limit=200)[0]
        closed = hmm.gaussian_symmetric_kl(mu_p, s_p**2, mu_q, s_q**2)
        assert closed == pytest.approx(d_pq + d_qp, rel=1e-7, abs=1e-10)
        assert closed >= 0.0


def test_kl_observations_uses_sample_moments():
    rng = np.random.default_rng(0)
    cal, tst = rng.normal(1.0, 0.2, (10, 5)), rng.normal(1.5, 0.4, (10, 5))
    O = hmm.kl_observations(cal, tst)
    ref = hmm.gaussian_symmetric_kl(cal.mean(0), cal.var(0, ddof=1), tst.mean(0), tst.var(0, ddof=1))
    np.testing.assert_allclose(O, ref)
    assert np.all(hmm.kl_observations(cal, cal) == 0.0)


def test_forward_backward_equals_brute_force_enumeration():
    rng = np.random.default_rng(1)
    for _ in range(3):
        p = _random_params(rng)
        N = 5
        O, _ = _sample(rng, p, 2, N)
        y = hmm.log_observations(O)
        log_b = hmm.log_emissions(y, p)  # (B, N, 2)
        gamma, ll = hmm.posteriors(O, p)
        for b in range(2):
            joint = np.zeros((2,) * N)
            for xs in itertools.product((0, 1), repeat=N):
                lp = np.log(p.pi[xs[0]]) + log_b[b, 0, xs[0]]
                for k in range(1, N):
                    lp += np.log(p.P[xs[k - 1], xs[k]]) + log_b[b, k, xs[k]]
                joint[xs] = np.exp(lp)
            Z = joint.sum()
            assert ll[b] == pytest.approx(np.log(Z), rel=1e-10)
            for k in range(N):
                marg = joint.sum(axis=tuple(a for a in range(N) if a != k)) / Z
                np.testing.assert_allclose(gamma[b, k], marg, rtol=1e-9, atol=1e-12)


def test_forward_backward_with_absorbing_state_is_finite():
    p = hmm.HmmParams([1.0, 0.0], [[0.9, 0.1], [0.0, 1.0]], [-1.0, 2.0], [1.0, 1.0])
    gamma, ll = hmm.posteriors(np.exp(np.array([[-1.0, -1.2, 2.1, 1.9, 2.2]])), p)
    assert np.all(np.isfinite(gamma)) and np.isfinite(ll).all()
    assert gamma[0, 0, 1] == 0.0  # pi_1 = 0
    assert np.all(np.diff(gamma[0, :, 1]) >= -1e-12)  # no way back from the absorbing state


@settings(max_examples=12, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), fix=st.booleans(), fix_pi=st.booleans())
def test_baum_welch_likelihood_never_decreases(seed, fix, fix_pi):
    rng = np.random.default_rng(seed)
    truth = _random_params(rng)
    O, _ = _sample(rng, truth, 20, 30)
    init = _random_params(rng)
    res = hmm.baum_welch(
        O, init, n_iter=12, fix_p10=float(init.P[1, 0]) if fix else None, fix_pi=fix_pi, var_floor=1e-6
    )
    if fix_pi:
        assert all(np.array_equal(p.pi, init.pi) for p in res.params)
    assert res.loglik.size == 13
    assert np.all(np.diff(res.loglik) >= -1e-7 * np.abs(res.loglik[:-1]))
    # the reported likelihood is that of the reported parameters
    _, ll = hmm.posteriors(O, res.final)
    assert ll.sum() == pytest.approx(res.loglik[-1], rel=1e-10)


def test_supervised_params_count_the_known_states():
    O = np.exp(np.array([[0.0, 0.0, 2.0, 2.0], [0.0, 2.0, 2.0, 2.0]]))
    p = hmm.supervised_params(O, np.array([2, 1]), eps=0.05)
    np.testing.assert_allclose(p.pi, [1.0, 0.0])
    np.testing.assert_allclose(p.P, [[1 / 3, 2 / 3], [0.05, 0.95]])
    np.testing.assert_allclose(p.mean, [0.0, 2.0])


def test_delay_recovers_planted_change_point():
    rng = np.random.default_rng(3)
    B, N = 40, 40
    k_star = rng.integers(3, 30, B)
    state = np.arange(N)[None] >= k_star[:, None]
    O = np.exp(rng.normal(np.where(state, 3.0, -1.0), 0.4))  # clean: levels 10 std apart
    p = hmm.HmmParams([0.9, 0.1], [[0.9, 0.1], [0.01, 0.99]], [0.0, 1.0], [2.0, 2.0])  # a poor start
    res = hmm.baum_welch(O, p, n_iter=10)
    k_hat = hmm.hmm_delay(hmm.changed_posterior(O, res.final))
    np.testing.assert_array_equal(k_hat, k_star)
    assert res.final.mean == pytest.approx([-1.0, 3.0], abs=0.15)
    # first threshold crossing too, at any threshold between the levels
    np.testing.assert_array_equal(hmm.first_crossing(O, [np.exp(1.0)])[0], k_star)


def test_first_crossing_and_errors_by_hand():
    O = np.array([[0.1, 5.0, 0.2, 7.0], [0.1, 0.2, 0.3, 0.4]])
    np.testing.assert_array_equal(hmm.first_crossing(O, [1.0, 6.0, 10.0]), [[1, -1], [3, -1], [-1, -1]])
    np.testing.assert_allclose(hmm.delay_errors(np.array([1, -1]), np.array([3, 2]), 4), [-2.0, 2.0])
    assert hmm.hmm_delay(np.array([[0.1, 0.4, 0.51, 0.2], [0.5, 0.5, 0.5, 0.5]])).tolist() == [2, -1]


def test_zetik_finds_an_added_echo():
    rng = np.random.default_rng(4)
    S = 200
    bins = np.arange(S) // 10 - 5
    cal = 0.01 * (rng.standard_normal((1, 10, S)) + 1j * rng.standard_normal((1, 10, S)))
    cal[..., 60] += 5.0  # the direct path, static
    test = 0.01 * (rng.standard_normal((1, 10, S)) + 1j * rng.standard_normal((1, 10, S)))
    test[..., 60] += 5.0
    test[..., 123] += 1.0  # the person's echo in bin 12 - 5 = 7
    assert hmm.zetik_delay(cal, test, slice(0, 40), bins, 0.9).tolist() == [7]


# ------------------------------------------------------------------------------------------------ localization
def test_grid_recovers_known_position_with_exact_delays():
    radios = np.array([[-2.5, -2.0], [2.5, -2.0], [2.5, 2.0], [-2.5, 2.0]])
    i, j = np.triu_indices(4, 1)
    tx, rx = radios[i], radios[j]
    xs, ys, pix = grid.pixel_grid((-3.0, 3.0), (-2.5, 2.5), 0.05)
    d_k = 0.05  # fine bins: exact delays pin the position to a pixel or two
    bins = grid.bistatic_bins(pix, tx, rx, d_k)
    N = int(bins.max()) + 1
    for z in ([0.775, -0.425], [-1.525, 1.125], [0.025, 0.025]):
        k_true = grid.bistatic_bins(np.array([z]), tx, rx, d_k)[0]
        alpha = (np.arange(N)[None] >= k_true[:, None]).astype(float)  # a step at the true bin
        for info in (grid.soft_information(alpha), grid.range_only_information(k_true, N)):
            est, _ = grid.locate_on_grid(grid.presence_image(info, bins, 0.2), xs, ys, 0.0)
            assert np.linalg.norm(est - z) < 0.08


def test_bistatic_bins_match_eq16():
    tx, rx = np.array([[0.0, 0.0]]), np.array([[4.0, 0.0]])
    z = np.array([[2.0, 1.5], [2.0, 0.0], [0.0, 3.0]])
    excess = np.array([2 * 2.5 - 4.0, 0.0, 3.0 + 5.0 - 4.0])
    np.testing.assert_array_equal(grid.bistatic_bins(z, tx, rx, 0.3)[:, 0], np.ceil(excess / 0.3 - 1e-9))


def test_p_norm_by_hand():
    v = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 0.5, 0.0], [1.0, 1.0, 1.0], [0.01, 0.01, 0.01]])
    np.testing.assert_allclose(grid.p_norm(v, 1.0), [0, 1, 1, 3, 0.03])
    np.testing.assert_allclose(grid.p_norm(v, 0.0), [0, 1, 2, 3, 3])
    np.testing.assert_allclose(grid.p_norm(v, 0.2), [0, 1, (2 * 0.5**0.2) ** 5, 3**5, 0.01 * 3**5])
    # p < 1 favours agreement: three weak links beat one sure link
    assert grid.p_norm(v[4], 0.2) > grid.p_norm(v[1], 0.2)
    assert grid.p_norm(v[4], 1.0) < grid.p_norm(v[1], 1.0)


def test_soft_and_range_only_information():
    alpha = np.array([[0.0, 0.2, 0.1, 0.9, 1.0]])
    np.testing.assert_allclose(grid.soft_information(alpha), [[0.0, 0.2, 0.0, 0.8, 0.1]])
    np.testing.assert_allclose(grid.soft_information(np.array([0.3, 0.3])), [0.3, 0.0])  # alpha_{-1} = 0
    np.testing.assert_array_equal(grid.range_only_information(np.array([2, -1]), 4), [[0, 0, 1, 0], [0, 0, 0, 0]])
    info = np.array([[0.0, 1.0, 0.0], [0.5, 0.0, 0.0]])  # (M = 2, N = 3)
    bins = np.array([[1, 0], [1, 5], [-1, 0]])  # a pixel's bin outside the window gives 0
    np.testing.assert_allclose(grid.presence_image(info, bins, 1.0), [1.5, 1.0, 0.5])


# ---------------------------------------------------------------------------------------------------- the CIRs
def test_simulated_person_changes_its_bin():
    cfg = CirConfig(n_cal=6, n_test=6)
    radios = np.array([[-2.0, -1.5], [2.0, -1.5], [2.0, 1.5], [-2.0, 1.5]])
    room = RoomConfig("t", (4.6, 3.6), radios, point_grid(2, 1, 1.2), clutter_rate=0.0)
    ld = simulate_room(np.random.default_rng(5), room, cfg)
    tx, rx = room.links()
    np.testing.assert_array_equal(ld.k_true, grid.bistatic_bins(room.points, tx, rx, C_M_PER_NS * cfg.bin_ns).T)
    O = hmm.kl_observations(bin_energy(ld.cal, cfg)[:, None], bin_energy(ld.test, cfg))
    k = np.arange(cfg.n_bins)
    before = (k[None, None] < ld.k_true[..., None] - 1) & (k >= 1)
    at = k[None, None] == ld.k_true[..., None]
    assert np.median(O[at]) > 10 * np.median(O[before])


def test_simulated_person_change_persists_after_its_delay():
    """The seed's premise (section 2.3): the person changes r_k from k_* on, for many bins, not only at k_*."""
    cfg = CirConfig()
    radios = np.array([[-2.8, -2.3], [2.8, -2.3], [2.8, 2.3], [-2.8, 2.3]])
    room = RoomConfig("t", (6.0, 5.0), radios, point_grid(3, 2, 0.9), clutter_rate=0.0)
    ld = simulate_room(np.random.default_rng(7), room, cfg)
    O = hmm.kl_observations(bin_energy(ld.cal, cfg)[:, None], bin_energy(ld.test, cfg))
    k = np.arange(cfg.n_bins)
    before = (k[None, None] < ld.k_true[..., None] - 1) & (k >= 1)
    later = k[None, None] >= ld.k_true[..., None] + 2  # past the echo's own bin
    assert np.median(O[later]) > 20 * np.median(O[before])  # 33x when written
    assert np.mean(O[later] > np.percentile(O[before], 95)) > 0.7  # 0.80 when written


def test_object_paths_geometry():
    cfg = CirConfig()
    radios = np.array([[-2.0, 0.0], [2.0, 0.0], [2.0, 1.5], [-2.0, 1.5]])
    room = RoomConfig("t", (6.0, 5.0), radios, point_grid(1, 1), diffuse_ratio_db=0.0)
    tx, rx = radios[0], radios[1]
    rng = np.random.default_rng(0)
    static = cir._static_paths(rng, room, cfg, tx, rx)
    delays, amps, _ = static
    # a person on the line of sight: the direct path loses body_loss_db; nothing earlier than tau_* = 0 changes
    tau, d, a = cir.object_paths(rng, room, cfg, tx, rx, [0.0, 0.0], 0.5, 2.5, 0.4, static)
    assert tau == pytest.approx(0.0)
    direct = np.flatnonzero((d == 0.0) & (np.abs(a - amps[0] * (10 ** (-room.body_loss_db / 20) - 1)) < 1e-12))
    assert direct.size == 1
    assert np.all(d >= tau - 1e-12)
    # off the line of sight: no change earlier than the person's delay; the diffuse paths later than it all change
    z = np.array([0.5, 1.8])
    tau, d, a = cir.object_paths(rng, room, cfg, tx, rx, z, 0.5, 2.5, 0.4, static)
    exc = (np.linalg.norm(z - tx) + np.linalg.norm(z - rx) - 4.0) / C_M_PER_NS
    assert tau == pytest.approx(exc)
    assert np.all(d >= tau - 1e-12)
    later = delays[5:][delays[5:] > tau]
    assert np.all(np.isin(later, d))
    # an object outside the room: its echo and tail only, no static path perturbed
    tau, d, a = cir.object_paths(rng, room, cfg, tx, rx, [0.0, 3.5], 0.1, 0.1, 0.3, static, 0.3, inside=False)
    assert not np.any(np.isin(d, delays))
    assert np.all(d >= tau - 1e-12)


# ------------------------------------------------------------------------------------- the signal sensor's HMM
def test_single_capture_statistic_is_chi2_in_an_unchanged_room():
    rng = np.random.default_rng(12)
    B, S, E = 400, 400, 16
    s = np.zeros(S)
    s[100:300] = 3.0 * np.sin(np.arange(200) * 0.7)  # a background, the same in scan and reference
    scan = s + rng.standard_normal((B, S))
    ref = s + rng.standard_normal((B, S)) / np.sqrt(E)
    O = hmm.single_capture_observations(scan, ref, np.full(B, 20.0), 16.0, 24, 1.0, 1.0 / E)  # whole samples per bin
    assert np.all(np.isnan(O[:, -1]))  # past the scan's end: missing
    y = np.log(O[:, :-1])
    # chi^2_1 up to the Gaussian approximation of a 16-sample bin energy (skewness 0.7): E[O] = 1 to within 3 % (its
    # standard error 1.5 %; 0.985 when written), E[log O] within 0.1 of chi^2_1's (-1.30 against -1.27)
    assert np.mean(O[:, :-1]) == pytest.approx(1.0, abs=0.03)
    assert np.mean(y) == pytest.approx(hmm.CHI2_1_LOG_MEAN, abs=0.1)
    assert np.var(y) == pytest.approx(hmm.CHI2_1_LOG_VAR, rel=0.08)
    # the exact chi^2_1 density of log O for state 0
    p = hmm.single_capture_params(0.02, 0.01, 3.0, 4.0)
    yy = np.array([[-3.0, 0.0, 3.8]])
    np.testing.assert_allclose(hmm.log_emissions(yy, p)[0, :, 0], stats.chi2(1).logpdf(np.exp(yy[0])) + yy[0])


def test_signal_scan_with_hmm_toa_estimator_ranges_near_the_truth():
    """indoor-rsn, a point echo of 30 dB at 1.5-6 m of excess range on every pair (8 scans each): the HMM's range
    (the centre of its 1 ns bin, 0.3 m) is within 0.3 m of the bistatic range in most scans."""
    from uwb_env import scenarios
    from uwb_env.config import SignalConfig
    from uwb_env.detection.registry import toa_estimator
    from uwb_env.rng import RngStreams
    from uwb_env.scene import sample_truth
    from uwb_env.sensing import ScanPlan
    from uwb_env.sensing.signal import SignalSensor

    assert toa_estimator("hmm").replaces_cfar
    with pytest.raises(ValueError, match="hmm_p01"):
        SignalConfig(toa_estimator="hmm", hmm_p01=0.0)
    over = {"sensing.fidelity": "signal", "sensing.signal.target_model": "point", "sensing.signal.toa_estimator": "hmm"}
    cfg = scenarios.get("indoor-rsn", **over)
    s = SignalSensor(cfg)
    rngs = RngStreams.from_seed(5)
    ep = s.new_episode(sample_truth(cfg, rngs.truth, s.layout), rngs)
    rng = np.random.default_rng(6)
    B, err, n = 8, [], 0
    for p in range(s.pairs.shape[0]):
        for excess in (1.5, 3.0, 4.5, 6.0):
            scans = s.controlled_scans(rng, p, 0, excess, np.full(B, 1e3))
            *_, (row, _, _, _), ranges = s.in_sensor(
                scans,
                np.broadcast_to(ep.reference[0, p], scans.shape),
                np.full(B, ep.reference_toa[0, p]),
                np.full(B, ep.reference_peak[0, p]),
                np.full(B, p),
                np.broadcast_to(ep.reference_scan[0, p], scans.shape),
            )
            assert np.all(np.diff(row) > 0)  # at most one ToA per scan
            err.append(ranges - s.baseline[p] - excess)
            n += B
    e = np.concatenate(err)
    assert e.size > 0.9 * n  # 0.94 when written
    assert np.mean(np.abs(e) < 0.3) > 0.8  # 0.87 when written
    assert np.median(np.abs(e)) < 0.3  # 0.25: the first changed bin is often the one with the pulse's leading edge
    # the whole sense path runs with it
    plan = ScanPlan.all_listening(0, s.n_tx, s.n_rx)
    assert len(s.sense(ep, 1, plan)) > 0
