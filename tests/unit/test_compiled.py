"""The compiled (numba) tracker kernels against the numpy reference kernels, to rounding error."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import uwb_env  # noqa: F401  (registers the ids)
from uwb_env import scenarios
from uwb_env.config import apply_overrides
from uwb_env.lookahead import lookahead_costs
from uwb_env.rng import RngStreams
from uwb_env.scene import sample_truth
from uwb_env.sensing import ParametricSensor, ScanPlan
from uwb_env.sensing.records import Detections
from uwb_env.tracking import Tracker, UnscentedWeights, compiled, imm_combine, imm_mix, kf_predict
from uwb_env.tracking.expectation import ReductionModel
from uwb_env.tracking.initiation import fuse_candidates, range_azimuth_candidates, ridge_range, two_point_pairs
from uwb_env.tracking.reference import ReferenceTracker
from uwb_env.tracking.reference import expected_update as reference_expected_update


def _spd(rng, *shape, n=6, scale=1.0):
    A = rng.normal(size=(*shape, n, n))
    return scale * (A @ np.swapaxes(A, -1, -2) + n * np.eye(n))


def test_predict_models_equals_imm_mix_then_kalman_prediction():
    rng = np.random.default_rng(0)
    N, r = 5, 4
    act = np.array([0, 2, 3])
    mu = rng.dirichlet(np.ones(r), size=N)
    mu[:, 1] = 0.0
    mu /= mu.sum(1, keepdims=True)
    x, P = rng.normal(size=(N, r, 6)), _spd(rng, N, r)
    Pi = rng.dirichlet(np.ones(3), size=3)
    F, Q = np.eye(6) + 0.1 * rng.normal(size=(3, 6, 6)), _spd(rng, 3, scale=0.01)
    cbar, x0, P0 = imm_mix(mu[:, act], np.broadcast_to(Pi, (N, 3, 3)), x[:, act], P[:, act])
    xr, Pr = kf_predict(x0, P0, F[None], Q[None])
    mu2, x2, P2 = mu.copy(), x.copy(), P.copy()
    compiled.predict_models(mu2, Pi, x2, P2, F, Q, act)
    np.testing.assert_allclose(x2[:, act], xr, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(P2[:, act], Pr, rtol=1e-11, atol=1e-11)
    np.testing.assert_allclose(mu2[:, act], cbar / cbar.sum(1, keepdims=True), rtol=1e-14)
    np.testing.assert_array_equal(x2[:, 1], x[:, 1])  # inactive model untouched


def test_combine_equals_moment_matching():
    rng = np.random.default_rng(1)
    w = rng.dirichlet(np.ones(3), size=4)
    x, P = rng.normal(size=(4, 3, 6)), _spd(rng, 4, 3)
    xr, Pr = imm_combine(w, x, P)
    xc, Pc = compiled.combine(w, x, P)
    np.testing.assert_allclose(xc, xr, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(Pc, Pr, rtol=1e-12, atol=1e-12)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(0, 12), n_prev=st.integers(0, 12))
def test_initiation_kernels_equal_the_reference(seed, n, n_prev):
    rng = np.random.default_rng(seed)
    p = rng.uniform(0, 30, size=(n, 2))
    cov = _spd(rng, n, n=2, scale=rng.uniform(0.01, 2.0))
    pf, cf = fuse_candidates(p, cov, 9.21)
    pc, cc = compiled.fuse_candidates(p, cov, 9.21)
    np.testing.assert_allclose(pc, pf, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(cc, cf, rtol=1e-10, atol=1e-10)
    p0 = rng.uniform(0, 30, size=(n_prev, 2))
    cov0 = _spd(rng, n_prev, n=2, scale=0.5)
    for a, b in zip(
        two_point_pairs(p, cov, p0, cov0, 0.5, 20.0),
        compiled.two_point_pairs(p, cov, p0, cov0, 0.5, 20.0),
        strict=True,
    ):
        np.testing.assert_array_equal(a, b)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(0, 14), n_prev=st.integers(0, 10), first=st.booleans())
def test_fused_initiation_equals_the_trackers_numpy_initiation(seed, n, n_prev, first):
    """compiled.initiate (select, fuse, pair, new states) against the numpy tracker's initiation on the same
    candidates (a record of fused positions hands them over as they are)."""
    cfg = scenarios.get("urban-intersection")
    tc, lay = cfg.tracker, ParametricSensor(cfg).layout
    rng = np.random.default_rng(seed)
    a = lay.area
    p = np.column_stack([rng.uniform(a[0] - 5, a[1] + 5, n), rng.uniform(a[2] - 5, a[3] + 5, n)])
    cov = _spd(rng, n, n=2, scale=rng.uniform(0.01, 1.0))
    k = min(n, n_prev)  # some previous candidates near current ones (pairs), the rest anywhere
    p0 = np.vstack([p[:k] + rng.normal(scale=0.5, size=(k, 2)), rng.uniform(0, 30, (n_prev - k, 2))])
    cov0 = _spd(rng, n_prev, n=2, scale=0.3)
    dt = np.inf if first else 0.5
    det = Detections(
        tx=0,
        rx=-1,
        waveform=0,
        time_s=1.0,
        z=p,
        R=cov,
        snr=np.ones(n),
        origin=np.full(n, -1, np.int64),
        measurement_names=("x", "y"),
        clutter_intensity=np.ones(n),
        expected_false_alarms=1.0,
    )
    ref = ReferenceTracker(tc, lay.tx_pos, lay.rx_pos, lay.area)
    ref._previous.p, ref._previous.cov, ref._previous.time_s = p0, cov0, 1.0 - dt
    ref._initiate([(det, np.ones(n, bool))], 1.0, 3)
    x, P, rest_p, rest_cov = compiled.initiate(
        p,
        cov,
        p0,
        cov0,
        dt,
        lay.area,
        2.0 * tc.init_max_position_std_m**2,
        tc.init_max_candidates,
        ref._gates[2],
        tc.max_speed_mps,
        tc.initial_accel_std_mps2,
    )
    np.testing.assert_allclose(x, ref.tracks.x[:, 0], rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(P, ref.tracks.P[:, 0], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(rest_p, ref._previous.p, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(rest_cov, ref._previous.cov, rtol=1e-10, atol=1e-10)


def test_azimuth_candidates_equal_ridge_range_then_bearing_ellipse_point():
    rng = np.random.default_rng(3)
    M = 40
    tx, rx = np.array([0.0, 0.0]), np.array([30.0, 5.0])
    names = ("bistatic_range", "range_rate", "azimuth")
    z = np.column_stack([rng.uniform(10, 400, M), rng.normal(0, 10, M), rng.uniform(-np.pi, np.pi, M)])
    L = rng.normal(size=(M, 3, 3)) * [1.0, 30.0, 0.01]
    R = L @ np.swapaxes(L, -1, -2) + np.diag([0.01, 1.0, 1e-5])
    snr = rng.exponential(20.0, M)
    free = rng.random(M) < 0.7
    cap = 20
    order = np.argsort(-snr[free], kind="stable")[:cap]
    zz, RR = z[free][order], R[free][order]
    r, var = ridge_range(zz, RR, names, 40.0)
    p, cov, ok = range_azimuth_candidates(r, var, zz[:, 2], RR[:, 2, 2], tx, rx)
    pc, cc = compiled.azimuth_candidates(z, R, snr, free, 2, 1, tx, rx, 40.0, cap)
    assert ok.sum() > 5
    np.testing.assert_allclose(pc, p[ok], rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(cc, cov[ok], rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize(
    ("scenario", "overrides"),
    [
        ("urban-intersection", {}),
        ("urban-intersection", {"tracker.filter": "ekf"}),
        ("urban-crossing", {"tracker.fixed_existence": True}),
        ("indoor-rsn", {}),
    ],
)
def test_tracker_back_ends_give_the_same_tracks(scenario, overrides):
    """Whole tracker, both back ends on the same detections: same ids every scan, estimates to rounding."""
    cfg = apply_overrides(scenarios.get(scenario), overrides) if overrides else scenarios.get(scenario)
    sensor = ParametricSensor(cfg)
    lay = sensor.layout
    plans = [ScanPlan.all_listening(w, sensor.n_tx, sensor.n_rx) for w in range(len(sensor.library))]
    rngs = RngStreams.from_seed(11)
    ep = sensor.new_episode(sample_truth(cfg, rngs.truth, lay), rngs)
    trackers = [cls(cfg.tracker, lay.tx_pos, lay.rx_pos, lay.area) for cls in (ReferenceTracker, Tracker)]
    n_scans = min(cfg.n_scans, 60)
    seen = 0
    for k in range(1, n_scans + 1):
        t_s = k * cfg.sensing.scan_period_s
        dets = sensor.sense(ep, k, plans[k % len(plans)], t_s)
        ref, fast = (tr.step(dets, t_s, k) for tr in trackers)
        np.testing.assert_array_equal(fast.ids, ref.ids)
        np.testing.assert_array_equal(fast.confirmed, ref.confirmed)
        np.testing.assert_allclose(fast.existence, ref.existence, rtol=1e-8, atol=1e-12)
        np.testing.assert_allclose(fast.mu, ref.mu, rtol=1e-8, atol=1e-10)
        np.testing.assert_allclose(fast.x, ref.x, rtol=1e-9, atol=1e-7)
        np.testing.assert_allclose(fast.P, ref.P, rtol=1e-7, atol=1e-9)
        seen += len(ref)
    assert seen >= 0.9 * n_scans  # tracks existed for most of the run


def test_weights_arrays_match_the_unscented_weights():
    w = UnscentedWeights(6)
    wm, wc, scale = compiled.weights_arrays(w)
    np.testing.assert_array_equal(wm, w.mean)
    np.testing.assert_array_equal(wc, w.cov)
    assert scale == pytest.approx(np.sqrt(6.0))


@pytest.mark.parametrize(("filt", "q2"), [("ukf", 0.7), ("ekf", 1.0), ("ukf", "pda"), ("ekf", "pda")])
def test_expected_update_equals_the_numpy_lookahead(filt, q2):
    """The lookahead's compiled expected update against its numpy twin (reference.expected_update; P_D = 0 leaves P)."""
    cfg = apply_overrides(scenarios.get("urban-intersection"), {"tracker.filter": filt})
    lay = ParametricSensor(cfg).layout
    tracker = Tracker(cfg.tracker, lay.tx_pos, lay.rx_pos, lay.area)
    rng = np.random.default_rng(2)
    A, N = 4, 5
    x = np.column_stack([rng.uniform(-20, 20, N), rng.normal(size=N), rng.uniform(5, 30, N), rng.normal(size=N)])
    x = np.column_stack([x, rng.normal(scale=0.1, size=(N, 2))])
    P, Pa = _spd(rng, N, scale=0.05), _spd(rng, A, N, scale=0.05)
    names = ("bistatic_range", "range_rate")
    R = _spd(rng, A, N, n=2, scale=0.01)
    pd = rng.uniform(0.0, 1.0, (A, N))
    pd[1, 2] = 0.0
    rho = 10.0 ** rng.uniform(-3, 1, (A, N))  # from almost no clutter to several false alarms per gate
    model = ReductionModel(q2, 2, cfg.tracker.gate_probability)
    # folded range-rates: plans with a period the predictions do and do not resolve, and an unambiguous one
    period = np.resize(np.array([np.inf, 7.5, 0.5, 10.7]), A)
    ref = reference_expected_update(Pa, x, P, names, lay.tx_pos[0], lay.rx_pos[1], filt, R, pd, model, rho, period)
    got = Pa.copy()
    kinds, wm, wc, scale, use_ukf = tracker.compiled_filter_args(names)
    assert use_ukf == (filt == "ukf")
    args = (kinds, lay.tx_pos[0], lay.rx_pos[1], wm, wc, scale, use_ukf, R, pd, *model.compiled_args(rho), period)
    assert compiled.expected_update(got, x, P, *args)
    np.testing.assert_allclose(got, ref, rtol=1e-10, atol=1e-14)
    np.testing.assert_array_equal(got[1, 2], Pa[1, 2])
    assert np.all(
        np.trace(got[..., [0, 2], :][..., [0, 2]], axis1=-2, axis2=-1)
        < np.trace(Pa[..., [0, 2], :][..., [0, 2]], axis1=-2, axis2=-1) + 1e-15
    )


def test_lookahead_costs_agree_across_back_ends():
    """Myopic costs mid-episode with the compiled tracker and its numpy twin holding the same tracks."""
    env = gym.make("uwb_env/UrbanWaveform-v3").unwrapped
    env.reset(seed=5)
    for k in range(30):
        env.step(k % 4)
    k = env.sim.k + 1
    t_s = k * env.cfg.sensing.scan_period_s
    tracker = env.sim.tracker
    fast = lookahead_costs(env.sim.sensor, tracker, env.plans, t_s, k)
    twin = ReferenceTracker(tracker.cfg, tracker.tx_pos, tracker.rx_pos, tracker.area)
    twin.tracks, twin._time = tracker.tracks, tracker._time
    ref = lookahead_costs(env.sim.sensor, twin, env.plans, t_s, k)
    np.testing.assert_allclose(fast, ref, rtol=1e-10)
    assert np.ptp(ref) > 1e-6 * ref.mean()  # the waveforms' costs differ: the check is not on equal numbers
