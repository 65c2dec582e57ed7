"""Seed 001's kernels with known answers: advance normalization, interval ToAs, ToA association, wall compensation,
two-ellipse intersection; the through-wall scenario's chain on its signal path."""

from __future__ import annotations

import numpy as np
import pytest

from uwb_env import scenarios
from uwb_env.config import SignalConfig
from uwb_env.constants import SPEED_OF_LIGHT_MPS as C
from uwb_env.detection.registry import NORMALIZATIONS, toa_estimator
from uwb_env.detection.toa_association import (
    STILL_S,
    advance_normalization,
    all_couples,
    associate_toas,
    interval_toas,
)
from uwb_env.localization.couples import array_frame, compensate_walls, couple_covariance, couple_positions

TX = np.array([0.0, 0.0])
RX = np.array([[-0.4, 0.0], [0.4, 0.0]])
M_S = 0.8 / C + 0.5e-9  # eq. 5: 2 d / c + t_corr, d = 0.4 m


def _ranges(p: np.ndarray) -> np.ndarray:
    """``(L, 2)`` bistatic ranges of positions ``p`` (L, 2) for Rx1, Rx2."""
    return np.linalg.norm(p - TX, axis=-1)[:, None] + np.linalg.norm(p[:, None] - RX[None], axis=-1)


# ------------------------------------------------------------------------------------------ advance normalization
def test_advance_normalization_divides_each_segment_by_its_hierarchical_maximum():
    """x = [1, 4, 2, 3, 0.5, 1, 0, 0]: n_0 = 1 (4) normalizes [0, 1]; n_1 = 3 (3) normalizes (1, 3]; n_2 = 5 (1)."""
    x = np.array([1.0, 4.0, 2.0, 3.0, 0.5, 1.0, 0.0, 0.0])
    np.testing.assert_allclose(advance_normalization(x), [0.25, 1.0, 2 / 3, 1.0, 0.5, 1.0, 0.0, 0.0], rtol=1e-15)


def test_advance_normalization_lifts_the_far_echo_to_one_and_is_batched():
    """A near echo 100 and a far echo 2 over a floor 0.1: both peak at 1; the floor after the far echo becomes 1."""
    x = np.full((2, 50), 0.1)
    x[0, 10], x[0, 30] = 100.0, 2.0
    x[1, 20] = 5.0
    y = advance_normalization(x)
    assert y.shape == (2, 50)
    np.testing.assert_allclose(y[0, [10, 30]], [1.0, 1.0])
    np.testing.assert_allclose(y[0, 9], 0.001)  # before the near echo: over 100
    np.testing.assert_allclose(y[0, 20], 0.05)  # between the echoes: over 2
    np.testing.assert_allclose(y[0, 40], 1.0)  # the tail's own maximum is the floor
    np.testing.assert_allclose(y[1, 20], 1.0)
    np.testing.assert_array_equal(NORMALIZATIONS.get("none")(x), x)


def test_advance_normalization_lets_a_maximum_own_a_target_extent_after_it():
    """w = 1 on x = [1, 4, 2, 3, 0.5, 1, 0, 0]: divisors max(x[n - 1:]) = [4, 4, 4, 3, 3, 1, 1, 0]."""
    x = np.array([1.0, 4.0, 2.0, 3.0, 0.5, 1.0, 0.0, 0.0])
    np.testing.assert_allclose(advance_normalization(x, 1), [0.25, 1.0, 0.5, 1.0, 0.5 / 3, 1.0, 0.0, 0.0], rtol=1e-15)
    np.testing.assert_array_equal(advance_normalization(x, 0), advance_normalization(x))


def test_advance_normalization_keeps_an_echos_tail_under_its_peak():
    """An echo 10 decaying 8, 6, 4, 2 over a floor 0.1: sample by sample (w = 0) the monotone tail is its own
    hierarchy of maxima, a plateau of ones; with w = 5 the tail is divided by the peak (0.8 ... 0.2) and the floor
    beyond the echo's extent is lifted to 1 as before."""
    x = np.full(30, 0.1)
    x[5:10] = [10.0, 8.0, 6.0, 4.0, 2.0]
    np.testing.assert_allclose(advance_normalization(x)[5:10], 1.0)
    y = advance_normalization(x, 5)
    np.testing.assert_allclose(y[5:10], [1.0, 0.8, 0.6, 0.4, 0.2])
    np.testing.assert_allclose(y[:5], 0.01)
    np.testing.assert_allclose(y[15:], 1.0)
    np.testing.assert_array_equal(NORMALIZATIONS.get("advance")(x, 5), y)
    np.testing.assert_array_equal(NORMALIZATIONS.get("none")(x, 5), x)


# ------------------------------------------------------------------------------------------ steps 1-3
def test_interval_toas_give_interval_start_minus_t_lim():
    """Row 0: detections at 10-13 and 16 (W_p = 15, T_LIM = 3): the window first holds 3 at 12 -> ToA 9, the interval
    lasts to 26 (the window [12, 26] still holds 12, 13, 16) -> weight 15; a lone false alarm at 40 is dropped.
    Row 1: detections every other sample from 30: 3 in the window at 34 -> ToA 31."""
    dec = np.zeros((2, 60), dtype=bool)
    dec[0, 10:14] = True
    dec[0, 16] = True
    dec[0, 40] = True
    dec[1, 30:45:2] = True
    d = np.arange(120.0).reshape(2, 60)
    row, toa, weight, peak = interval_toas(dec, d, 15, 3)
    np.testing.assert_array_equal(row, [0, 1])
    np.testing.assert_array_equal(toa, [9.0, 31.0])
    np.testing.assert_array_equal(weight, [15, 21])
    np.testing.assert_array_equal(peak, [26.0, 114.0])
    sig = SignalConfig(toa_interval_samples=15, toa_interval_threshold=3)
    got = toa_estimator("interval").estimate(dec, d, sig, 1.0)
    for g, r in zip(got, (row, toa, weight, peak), strict=True):
        np.testing.assert_array_equal(g, r)


# ------------------------------------------------------------------------------------------ steps 4-7
def test_association_keeps_true_pairs_and_rejects_ghost_pairs():
    """Two persons at (-1, 2) and (1.5, 4): their couples come back exactly (eq. 11); of the four Rx1 x Rx2
    combinations the two ghosts differ by more than m (|TOA^2 - TOA^1| > 2 d / c + t_corr) and form no couple."""
    p = np.array([[-1.0, 2.0], [1.5, 4.0]])
    r = _ranges(p)
    t = r / C
    a1, a2, centre, width, order, done = associate_toas(t[::-1, 0], t[:, 1], M_S)  # any input order
    np.testing.assert_allclose(a1, t[:, 0], rtol=0, atol=1e-18)
    np.testing.assert_allclose(a2, t[:, 1], rtol=0, atol=1e-18)
    np.testing.assert_allclose(centre, t.mean(axis=1), rtol=1e-15)
    np.testing.assert_allclose(width, M_S - np.abs(t[:, 0] - t[:, 1]), rtol=1e-12)
    np.testing.assert_array_equal(order, [1, 2])  # person 1 is nearer Rx1 (its Rx1 ToA the smaller), 2 nearer Rx2
    assert not done.any()
    g1, g2 = all_couples(t[:, 0], t[:, 1])
    ghost = np.abs(g1 - g2) > M_S
    np.testing.assert_array_equal(ghost, [False, True, True, False])


def test_close_toas_of_one_receiver_merge_into_one_couple():
    """Rx1 ToAs 10 and 11 ns widened by m = 3 ns merge into [8.5, 12.5]; Rx2 at 10.5 ns gives [9, 12]: h_A = 3 on
    [9, 12] -> one couple with C = 10.5, W = 3, O = 1 (Rx1's region opened first) -> eq. 11 gives (10.5, 10.5) ns."""
    a1, a2, centre, width, order, _ = associate_toas(np.array([10e-9, 11e-9]), np.array([10.5e-9]), 3e-9)
    np.testing.assert_allclose(centre, [10.5e-9], rtol=1e-12)
    np.testing.assert_allclose(width, [3e-9], rtol=1e-12)
    np.testing.assert_allclose(a1, [10.5e-9], rtol=1e-12)
    np.testing.assert_allclose(a2, [10.5e-9], rtol=1e-12)
    assert order.tolist() == [1]


def test_step6_completes_an_isolated_toa_from_the_previous_couple():
    """Previous couple C = 20 ns, W = 2 ns, O = 1 (m = 3 ns): an isolated Rx1 ToA at 20.4 ns this scan (Rx2 silent)
    gets the couple back, ToAs 19.5 / 20.5 ns (eq. 11); a ToA 5 ns away gets nothing; step 6 off: nothing."""
    prev = (np.array([20e-9]), np.array([2e-9]), np.array([1]))
    a1, a2, _, _, _, done = associate_toas(np.array([20.4e-9, 40e-9]), np.zeros(0), 3e-9, *prev)
    np.testing.assert_allclose(a1, [19.5e-9], rtol=1e-12)
    np.testing.assert_allclose(a2, [20.5e-9], rtol=1e-12)
    assert done.tolist() == [True]
    assert associate_toas(np.array([25e-9]), np.zeros(0), 3e-9, *prev)[0].size == 0
    assert associate_toas(np.array([20.4e-9]), np.zeros(0), 3e-9)[0].size == 0


def test_step6_stillness_bound_is_one_sample_of_the_seeds_clock():
    """STILL_S = 1.5 samples at 4.5 GHz = 0.333 ns: "moved by at most one sample" (0.222 ns) is still, two samples
    (0.444 ns) is motion; 0.10 m of bistatic range, below a radially walking person's 0.8 m/s x 2 x 0.074 s."""
    assert STILL_S == pytest.approx(1.0 / 3.0 * 1e-9, rel=1e-12)
    assert 1 / 4.5e9 < STILL_S < 2 / 4.5e9
    assert STILL_S * C == pytest.approx(0.0999, abs=1e-4)
    assert STILL_S * C < 0.8 * 2 * 0.074


def test_step6_does_not_complete_an_isolated_toa_that_has_not_moved():
    """A static residue: the previous couple sat at 20 ns in both receivers (C = 20 ns, W = m = 3 ns, O = 1: eq. 11
    gives ToAs 20 / 20 ns). This scan only Rx1 holds a ToA: at 20.0 ns (unmoved) or 20.2 ns (one sample, 0.222 ns)
    it is not completed; at 20.4 ns (moved 0.4 ns > STILL_S) it gets the couple (20, 20) ns back; the seed's literal
    step 6 (still_s = 0) completes the unmoved one too. The same for an isolated Rx2 ToA."""
    prev = (np.array([20e-9]), np.array([3e-9]), np.array([1]))
    for t in (20.0e-9, 20.2e-9):
        for rx in range(2):
            toas = [np.zeros(0), np.zeros(0)]
            toas[rx] = np.array([t])
            assert associate_toas(*toas, 3e-9, *prev)[0].size == 0
    a1, a2, centre, width, order, done = associate_toas(np.array([20.4e-9]), np.zeros(0), 3e-9, *prev)
    np.testing.assert_allclose([a1[0], a2[0]], [20e-9, 20e-9], rtol=1e-12)
    np.testing.assert_allclose([centre[0], width[0]], [20e-9, 3e-9], rtol=1e-12)  # eq. 10: C, W, O repeated
    assert order.tolist() == [1]
    assert done.tolist() == [True]
    a1, a2, *_, done = associate_toas(np.array([20.0e-9]), np.zeros(0), 3e-9, *prev, still_s=0.0)
    np.testing.assert_allclose([a1[0], a2[0]], [20e-9, 20e-9], rtol=1e-12)
    assert done.tolist() == [True]


def test_step6_stillness_compares_the_toa_with_its_own_receivers_toa_in_the_couple():
    """Previous couple (19.5, 20.5) ns (C = 20, W = 2, O = 1, m = 3 ns). An isolated Rx2 ToA at 20.5 ns is 0.5 ns from
    the centre (eq. 9 holds) but has not moved from the couple's Rx2 ToA: not completed. An isolated Rx1 ToA at
    20.5 ns moved 1.0 ns from the couple's Rx1 ToA 19.5 ns: completed with (19.5, 20.5) ns. O = 2 mirrors it."""
    prev = (np.array([20e-9]), np.array([2e-9]), np.array([1]))
    assert associate_toas(np.zeros(0), np.array([20.5e-9]), 3e-9, *prev)[0].size == 0
    a1, a2, *_, done = associate_toas(np.array([20.5e-9]), np.zeros(0), 3e-9, *prev)
    np.testing.assert_allclose([a1[0], a2[0]], [19.5e-9, 20.5e-9], rtol=1e-12)
    assert done.tolist() == [True]
    mirrored = (np.array([20e-9]), np.array([2e-9]), np.array([2]))  # ToAs (20.5, 19.5) ns
    assert associate_toas(np.array([20.5e-9]), np.zeros(0), 3e-9, *mirrored)[0].size == 0
    a1, a2, *_ = associate_toas(np.zeros(0), np.array([20.5e-9]), 3e-9, *mirrored)
    np.testing.assert_allclose([a1[0], a2[0]], [20.5e-9, 19.5e-9], rtol=1e-12)


# ------------------------------------------------------------------------------------------ localization
def test_two_ellipse_intersection_is_exact_and_needs_the_triangle_inequality():
    p = np.array([[1.0, 3.0], [-2.0, 1.5], [0.0, 4.0], [0.3, 0.1]])
    r = _ranges(p)
    e, n, beta = array_frame(TX, RX[0], RX[1], np.array([0.0, 3.0]))
    np.testing.assert_allclose(beta, [-0.4, 0.4])
    z, ok = couple_positions(r[:, 0], r[:, 1], TX, e, n, beta)
    assert ok.all()
    np.testing.assert_allclose(z, p, atol=1e-12)
    # |r1 - r2| > |Rx1 Rx2| = 0.8 m: no intersection (a ghost couple of two far-apart persons)
    z, ok = couple_positions(np.array([4.0]), np.array([5.0]), TX, e, n, beta)
    assert not ok[0]
    assert np.isnan(z).all()


def test_wall_compensation_removes_two_crossings_in_closed_form():
    """A wall at y = 0.36 with 0.8 ns per crossing: a person behind it measures r + 2 c 0.8 ns on both pairs
    (0.4797 m); compensation subtracts exactly that and the intersection returns the person."""
    p = np.array([[1.0, 3.0], [-2.0, 1.5], [0.0, 4.0]])
    bias = 2.0 * C * 0.8e-9
    np.testing.assert_allclose(bias, 0.47966793, rtol=1e-7)
    r = _ranges(p) + bias
    e, n, beta = array_frame(TX, RX[0], RX[1], np.array([0.0, 3.0]))
    p0, _ = couple_positions(r[:, 0], r[:, 1], TX, e, n, beta)
    assert np.all(np.linalg.norm(p0 - p, axis=1) > 0.2)  # uncompensated: biased away from the array
    wall_a, wall_b = np.array([[-3.0, 0.36]]), np.array([[3.0, 0.36]])
    rc = compensate_walls(r, p0, TX, RX, wall_a, wall_b, np.array([0.8e-9]))
    np.testing.assert_allclose(r - rc, bias, rtol=1e-12)
    z, _ = couple_positions(rc[:, 0], rc[:, 1], TX, e, n, beta)
    np.testing.assert_allclose(z, p, atol=1e-9)


def test_couple_covariance_is_sigma2_inverse_jtj():
    """Broadside at (0, 3): J rows (u_t + u_k); the cross-range variance exceeds the down-range one by far."""
    p = np.array([[0.0, 3.0]])
    cov = couple_covariance(p, TX, RX, 0.1**2)[0]
    ut = np.array([0.0, 1.0])
    J = np.stack([ut + (p[0] - rx) / np.linalg.norm(p[0] - rx) for rx in RX])
    np.testing.assert_allclose(cov, 0.01 * np.linalg.inv(J.T @ J), rtol=1e-6, atol=1e-15)
    # cross-range: J_x = +-d / l (l = |p - Rx| = sqrt(9.16)), var = sigma^2 l^2 / (2 d^2) = 0.01 x 9.16 / 0.32
    np.testing.assert_allclose(cov[0, 0], 0.28625, rtol=1e-6)
    assert cov[0, 0] > 200 * cov[1, 1]


# ------------------------------------------------------------------------------------------ scenario, config
def test_through_wall_scenario_holds_the_seeds_values():
    cfg = scenarios.get("through-wall")
    assert [r.position_m for r in cfg.receivers] == [(-0.4, 0.0), (0.4, 0.0)]
    assert cfg.transmitters[0].position_m == (0.0, 0.0)
    assert cfg.walls[0].start_m[1] == pytest.approx(0.36)
    sig = cfg.sensing.signal
    assert (sig.sample_rate_hz, sig.n_samples, sig.toa_interval_samples) == (4.5e9, 511, 15)
    assert sig.n_samples / sig.sample_rate_hz == pytest.approx(113.6e-9, rel=1e-3)  # the seed's 114 ns
    assert cfg.sensing.scan_period_s == 0.074
    assert len(cfg.targets) == 2
    # the room's static paths lie behind the wall: seed 002's -3 dB less two crossings of the brick
    assert sig.multipath_power_ratio_db == pytest.approx(-3.0 - 2.0 * cfg.walls[0].material.loss_db)


def test_the_chains_cfar_holds_its_design_false_alarm_rate_on_noise():
    """The CFAR compares powers: on the amplitude envelope of the background-subtracted scan, the noise beyond the
    room's last static path (bistatic range > 28 m) is detected at about the design Pfa 1e-2 (4.5e-3 - 7e-3
    measured: the envelope's correlated samples); on the square-law envelope itself (power^2) it was 5.9e-2."""
    from uwb_env.sensing.records import ScanPlan
    from uwb_env.sim import Simulator

    cfg = scenarios.get("through-wall", **{"sensing.fidelity": "signal", "n_scans": 30})
    sim = Simulator(cfg)
    sim.reset(3)
    s, ep = sim.sensor, sim.episode
    plan = ScanPlan.all_listening(0, 1, 2)
    axis = s.baseline[0] + 299792458.0 * (np.arange(511) - ep.reference_peak[0, 0]) / cfg.sensing.signal.sample_rate_hz
    far = axis > 28.0
    rates = []
    for k in range(1, cfg.n_scans + 1):
        scans, active = s.synthesise(ep, k, plan)
        rates.append(s.detect(ep, k, plan, scans, active).decisions[:, far].mean())
    assert 2e-3 < np.mean(rates) < 1.5e-2, np.mean(rates)


def test_bad_seed001_config_raises_naming_the_field():
    with pytest.raises(ValueError, match=r"SignalConfig.toa_interval_threshold = 16: must be an integer in \[1"):
        SignalConfig(toa_interval_threshold=16)
    with pytest.raises(ValueError, match=r"SignalConfig.toa_association = True: must be False unless network"):
        SignalConfig(toa_association=True)
    with pytest.raises(ValueError, match=r"SignalConfig.normalization = 'adv'.*did you mean 'advance'"):
        SignalConfig(normalization="adv")
    with pytest.raises(ValueError, match=r"sensing.signal.normalization = 'x': must be one of \('none', 'advance'\)"):
        NORMALIZATIONS.get("x")
    from uwb_env.sensing.signal.sensor import SignalSensor

    rsn = scenarios.get("indoor-rsn", **{"sensing.signal.network": "couples"})
    with pytest.raises(ValueError, match="exactly two receivers per transmitter"):
        SignalSensor(rsn)


def test_the_signal_chain_finds_both_persons_on_a_seeded_run():
    """Scan by scan on run 0: the association's couples hold each person (within 0.75 m) in >= 35 % of the scans."""
    from uwb_env.sensing.records import ScanPlan
    from uwb_env.sim import Simulator

    cfg = scenarios.get("through-wall", **{"sensing.fidelity": "signal", "n_scans": 40})
    sim = Simulator(cfg)
    sim.reset(0)
    plan = ScanPlan.all_listening(0, 1, 2)
    hits = []
    while not sim.done:
        res = sim.step(plan)
        z = res.detections[0].z
        truth = sim.truth.states[res.scan_index][:, [0, 2]]
        hits.append((np.linalg.norm(z[:, None] - truth[None], axis=-1) < 0.75).any(axis=0))
    rate = np.mean(hits, axis=0)
    assert np.all(rate >= 0.35), rate


def test_common_range_error_moves_the_position_down_range_only():
    """Broadside at (0, 3): J g = 1 gives g = (0, 1 / (1 + 3 / sqrt(9.16))); a common part adds sigma_c^2 g g^T."""
    p = np.array([[0.0, 3.0]])
    base = couple_covariance(p, TX, RX, 0.1**2)[0]
    cov = couple_covariance(p, TX, RX, 0.1**2, 0.2**2)[0]
    gy = 1.0 / (1.0 + 3.0 / np.sqrt(9.16))
    np.testing.assert_allclose(cov - base, 0.04 * np.array([[0.0, 0.0], [0.0, gy * gy]]), atol=1e-9)


def test_interval_estimator_adds_the_configured_offset():
    """The registry's interval estimator: eq. 3's ToA plus toa_interval_offset_s x fs (0.93 ns at 4.5 GHz = 4.185)."""
    dec = np.zeros((1, 60), dtype=bool)
    dec[0, 10:14] = True
    d = np.ones((1, 60))
    sig = SignalConfig(toa_interval_samples=15, toa_interval_threshold=3, toa_interval_offset_s=0.93e-9)
    _, toa, _, _ = toa_estimator("interval").estimate(dec, d, sig, 4.5e9)
    np.testing.assert_allclose(toa, [9.0 + 4.185], rtol=1e-12)


def test_with_the_seeds_window_steps_4_5_keep_exactly_the_couples_within_m():
    """Seed 001's W_p = 15 samples at 4.5 GHz span 1.0 m of bistatic range, more than m c = 0.8 m + c t_corr = 0.95 m:
    the interval ToAs of one receiver lie at least W_p apart, their widened intervals never merge, and steps 4-5 keep
    exactly the Rx1 x Rx2 combinations with |TOA^1 - TOA^2| <= m -- the ones whose ellipses can intersect at all
    (up to t_corr). 200 random scans of 1-6 ToAs per receiver, spaced >= W_p."""
    rng = np.random.default_rng(12345)
    wp = 15 / 4.5e9
    assert wp > M_S
    for _ in range(200):
        t = [np.cumsum(wp + rng.exponential(5e-9, rng.integers(1, 7))) for _ in range(2)]
        a1, a2, *_ = associate_toas(t[0], t[1], M_S)
        g1, g2 = all_couples(t[0], t[1])
        keep = np.abs(g1 - g2) <= M_S
        got = sorted(zip(a1.round(15).tolist(), a2.round(15).tolist(), strict=True))
        want = sorted(zip(g1[keep].round(15).tolist(), g2[keep].round(15).tolist(), strict=True))
        assert got == want


# ------------------------------------------------------------------------------- parametric path: wall compensation
def _parametric_range_errors(
    compensate: bool, seeds: int = 3, floor_m: float | None = 5e-5
) -> tuple[np.ndarray, np.ndarray]:
    """Person detections of the parametric through-wall path (every waveform, every scan of ``seeds`` runs): their
    range minus the free-space bistatic range of the person's position [m], and their reported range std [m].

    ``floor_m``: ``sensing.min_range_std_m``; by default the receiver-timing floor (5e-5 m), not the scenario's
    0.13 m body spread, so that the wall compensation's bias is resolved to 1 mm (the CRLB's mm-level noise); None
    keeps the scenario's."""
    from uwb_env.rng import RngStreams
    from uwb_env.scene import sample_truth
    from uwb_env.sensing import ParametricSensor, ScanPlan

    over = {"sensing.compensate_walls": compensate}
    if floor_m is not None:
        over["sensing.min_range_std_m"] = floor_m
    cfg = scenarios.get("through-wall", **over)
    assert cfg.sensing.fidelity == "parametric"
    sensor = ParametricSensor(cfg)
    err, std = [], []
    for seed in range(seeds):
        rngs = RngStreams.from_seed(seed)
        truth = sample_truth(cfg, rngs.truth, sensor.layout)
        ep = sensor.new_episode(truth, rngs)
        for w in range(len(cfg.waveforms)):
            plan = ScanPlan.all_listening(w, 1, 2)
            for k in range(1, cfg.n_scans + 1):
                for d in sensor.sense(ep, k, plan, 0.0):
                    i = np.flatnonzero(d.origin >= 0)
                    p = truth.states[k][d.origin[i]][:, [0, 2]]
                    r = np.linalg.norm(p - TX, axis=-1) + np.linalg.norm(p - RX[d.rx], axis=-1)
                    err.append(d.z[i, 0] - r)
                    std.append(np.sqrt(d.R[i, 0, 0]))
    return np.concatenate(err), np.concatenate(std)


def test_parametric_through_wall_ranges_are_wall_compensated():
    """The scenario's parametric radar removes the brick's delay (``sensing.compensate_walls``, on by default).

    3 runs x 3 waveforms x 117 scans: ~4200 person detections. Compensated, their whitened range errors
    (z - r) / sigma have mean within 4 / sqrt(N) of 0 (the sampling error of N unit-variance errors) and the mean
    error is below 1 mm; without the compensation every range carries the two crossings' 2 c 0.8 ns = 0.480 m (the
    bias the tracker's free-space model took for distance), their mean within 4 standard errors of it.
    """
    assert scenarios.get("through-wall").sensing.compensate_walls
    err, std = _parametric_range_errors(True)
    n = err.size
    assert n > 3000
    white = err / std
    assert abs(white.mean()) < 4.0 / np.sqrt(n)
    assert 0.8 < white.std() < 1.25  # the reported R holds for the compensated ranges
    assert abs(err.mean()) < 1e-3
    raw, _ = _parametric_range_errors(False)
    bias = 2.0 * C * 0.8e-9
    assert raw.size == n  # the compensation moves ranges, never detections
    assert abs(raw.mean() - bias) < 4.0 * raw.std() / np.sqrt(n)
    np.testing.assert_allclose(raw - err, bias, atol=1e-9)  # every person behind the wall: two crossings exactly


def test_parametric_through_wall_ranges_carry_the_chains_spread():
    """With the scenario's ``sensing.min_range_std_m`` (0.13 m, ``through_wall.PERSON_RANGE_STD_M``: the chain's
    per-receiver range error about the body centre, scripts/calibrate_through_wall.py) the person detections'
    range errors have std 0.13 m within 5 % (~4200 detections: the std's sampling error is 1 %) and mean within 4
    standard errors of 0, and their reported std is 0.13 m (the CRLB, under 1 cm, is floored)."""
    from uwb_env.scenarios.through_wall import PERSON_RANGE_STD_M

    assert scenarios.get("through-wall").sensing.min_range_std_m == PERSON_RANGE_STD_M == 0.13
    err, std = _parametric_range_errors(True, floor_m=None)
    assert err.size > 3000
    assert abs(err.std() / 0.13 - 1.0) < 0.05
    assert abs(err.mean()) < 4.0 * 0.13 / np.sqrt(err.size)
    np.testing.assert_allclose(std, 0.13, rtol=1e-9)


def test_parametric_wall_compensation_counts_the_walls_crossed_to_the_estimate():
    """``ParametricSensor._wall_compensation``: 2 c tau behind the wall, 0 in front of it, evaluated at the
    detection's uncompensated estimate (a target just before the wall measured 0.5 m long is compensated as behind
    it: the residual stays in the measurement)."""
    from uwb_env.sensing import ParametricSensor

    sensor = ParametricSensor(scenarios.get("through-wall"))
    tau = 0.8e-9
    pos = np.array([[0.5, 3.0], [0.5, 0.2], [0.5, 3.0]])
    tx, rx = np.array([0, 0, 0]), np.array([0, 1, 1])
    r = np.linalg.norm(pos - TX, axis=-1) + np.linalg.norm(pos - RX[rx], axis=-1)
    z = r + np.array([2.0, 0.0, 2.0]) * C * tau
    np.testing.assert_allclose(sensor._wall_compensation(z, tx, rx, pos), np.array([2.0, 0.0, 2.0]) * C * tau)
    z_near = np.linalg.norm(pos[1] - TX) + np.linalg.norm(pos[1] - RX[1]) + 0.5
    assert sensor._wall_compensation(np.array([z_near]), tx[:1], rx[1:2], pos[1:2])[0] == pytest.approx(2 * C * tau)


def test_parametric_wall_compensation_is_off_by_default():
    from uwb_env.config import SensingConfig

    assert not SensingConfig().compensate_walls
    assert not any(scenarios.get(n).sensing.compensate_walls for n in ("urban-intersection", "indoor-rsn"))


def test_parametric_through_wall_tracks_are_unbiased_down_range():
    """Tracks of the parametric path (waveform 0, 10 runs): the mean down-range error of the confirmed tracks held
    within 1 m of a person, per run, is that of the same runs without the wall (the tracker's own lag: ~-1 cm) within
    4 standard errors of the paired difference (2 cm at least); without the compensation the tracks sat ~0.22 m
    behind the persons (half the 0.48 m range bias)."""
    import dataclasses

    from uwb_env.sensing import ScanPlan
    from uwb_env.sim import Simulator

    def down_range_means(cfg) -> np.ndarray:
        sim, out = Simulator(cfg), []
        for seed in range(10):
            sim.reset(seed)
            err = []
            while not sim.done:
                res = sim.step(ScanPlan.all_listening(0, 1, 2))
                truth = sim.truth.states[res.scan_index][sim.truth.alive[res.scan_index]][:, 0:3:2]
                if len(res.tracks) == 0 or truth.shape[0] == 0:
                    continue
                x, _ = res.tracks.combined()
                for p in x[np.asarray(res.tracks.confirmed)][:, [0, 2]]:
                    d = np.linalg.norm(truth - p, axis=1)
                    j = int(np.argmin(d))
                    if d[j] <= 1.0:
                        err.append((p - truth[j]) @ ((truth[j] - TX) / np.linalg.norm(truth[j] - TX)))
            out.append(np.mean(err))
        return np.array(out)

    cfg = scenarios.get("through-wall")
    on, free = down_range_means(cfg), down_range_means(dataclasses.replace(cfg, walls=()))
    diff = on - free
    assert abs(diff.mean()) < max(4.0 * diff.std(ddof=1) / np.sqrt(diff.size), 0.02)
    assert abs(on.mean()) < 0.03
    off = down_range_means(scenarios.get("through-wall", **{"sensing.compensate_walls": False}))
    assert off.mean() > 0.15


# ------------------------------------------------------------------------------------------ the tracker on persons
def _position_nees(fidelity: str, seeds: range) -> np.ndarray:
    """Position NEES (2 dof) of the confirmed tracks within 1.5 m of a person, every scan of ``seeds`` runs."""
    from uwb_env.sensing.records import ScanPlan
    from uwb_env.sim import Simulator

    sim = Simulator(scenarios.get("through-wall", **{"sensing.fidelity": fidelity}))
    out = []
    for seed in seeds:
        sim.reset(seed)
        while not sim.done:
            res = sim.step(ScanPlan.all_listening(0, 1, 2))
            if len(res.tracks) == 0:
                continue
            truth = sim.truth.states[res.scan_index][:, [0, 2]]
            x, P = res.tracks.combined()
            c = np.flatnonzero(res.tracks.confirmed)
            e = x[c][:, None, [0, 2]] - truth[None]  # (N, K, 2)
            j = np.argmin(np.linalg.norm(e, axis=-1), axis=1)
            e = e[np.arange(c.size), j]
            near = np.linalg.norm(e, axis=-1) < 1.5
            Pp = P[c][:, [0, 2]][:, :, [0, 2]]
            out.append(np.einsum("ni,nij,nj->n", e, np.linalg.inv(Pp), e)[near])
    return np.concatenate(out)


@pytest.mark.parametrize("fidelity", ["signal", "parametric"])
def test_person_tracks_are_consistent_in_the_median(fidelity):
    """With a walking person's NCV acceleration std (``through_wall.PERSON_ACCEL_STD_MPS2`` = 2 m/s^2) the confirmed
    tracks' position NEES has the median of chi^2 with 2 dof, 1.386, within [1.0, 2.1] (4 runs, ~800 scans of tracks;
    measured 1.52 signal / 1.59 parametric). Seed 003's 0.5 m/s^2 gave 3.2: tracks fell behind a person turning
    back (2.5 m/s^2 for 1 s) and were held overconfident. The median, not the mean: the body's range errors are
    heavy-tailed (the limbs' leading edges), so the mean is 3-5 with either value."""
    from uwb_env.scenarios.through_wall import PERSON_ACCEL_STD_MPS2

    ncv = [m for m in scenarios.get("through-wall").tracker.models if m.kind == "ncv"]
    assert [m.accel_noise_std_mps2 for m in ncv] == [PERSON_ACCEL_STD_MPS2] == [2.0]
    nees = _position_nees(fidelity, range(4))
    assert nees.size > 600
    assert 1.0 < np.median(nees) < 2.1, np.median(nees)


@pytest.mark.slow
def test_seed001_check_on_fresh_runs():
    """Issue 18's check on runs it was not tuned on (seeds 300-319): the scenario's chain (the seed's association,
    exponential average at alpha 0.4, the 10-scan confirmation time-out of ThroughWall-v5) has no ghost track in >= 90 %
    of the runs and holds both persons (>= 50 % of their scans each) in >= 90 % (measured on runs 0-19 and 100-199:
    100 % / 100 %)."""
    from uwb_env.agents.studies.seed001_through_wall import DEFAULT_CHAIN, run

    rec = [run(seed, {}, chains=(DEFAULT_CHAIN,))[DEFAULT_CHAIN] for seed in range(300, 320)]
    assert np.mean([r["ghost_tracks"] == 0 for r in rec]) >= 0.9
    assert np.mean([r["both_tracked"] for r in rec]) >= 0.9


@pytest.mark.slow
def test_seed001_check_in_a_room_with_a_strong_static_path_on_the_walks():
    """Room 7 (``background_seed`` 7) holds a strong static path at 7.36 m of bistatic range in both receivers (on the
    array's axis, (0, 3.67) m), about 1 m from the second person's walk: its residue when the person's shadow crosses
    its legs (and, before ``SignalSensor.new_episode`` started the running background on the room as it is, its
    scan-0 fluctuation) makes still couples that can confirm a ghost track. Runs 400-459 with ThroughWall-v5: no ghost
    track in 90 %, both persons tracked in 100 % (v4's 5-scan time-out: 97 % / 98 %). Asserted on runs 420-439 (19 of
    20 measured), the check's >= 90 % on both counts."""
    from uwb_env.agents.studies.seed001_through_wall import DEFAULT_CHAIN, run

    room = {"sensing.signal.background_seed": 7}
    rec = [run(seed, room, chains=(DEFAULT_CHAIN,))[DEFAULT_CHAIN] for seed in range(420, 440)]
    assert np.mean([r["ghost_tracks"] == 0 for r in rec]) >= 0.9
    assert np.mean([r["both_tracked"] for r in rec]) >= 0.9
