"""Tracker statistics: NEES / NIS consistency, IMM vs NCV in the turn, Monte Carlo tracking, robustness."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import chi2

from tests.conftest import tiny_config
from uwb_env import scenarios
from uwb_env.config import TrackerConfig, apply_overrides, open_loop_tracker
from uwb_env.scene.motion_models import ncv_transition, process_noise
from uwb_env.sensing import Detections
from uwb_env.sim import Simulator, round_robin, run_episode
from uwb_env.tracking import Tracker, UnscentedWeights, ekf_moments, joseph_update, kf_predict, ukf_moments
from uwb_env.tracking.measurement import angular_mask, measure, wrap_residual
from uwb_env.typing import FloatArray


@pytest.mark.parametrize(("names", "filt"), [(("x", "y"), "ekf"), (("bistatic_range", "azimuth"), "ukf")])
def test_nees_and_nis_of_ncv_tracked_with_ncv_are_consistent(names, filt):
    """200 independent runs x 40 scans. Per scan, the run-averaged NEES (4-D position-velocity) and NIS must lie
    in their two-sided 95 % chi-square intervals in at least 85 % of the scans (95 % expected), and their grand
    means inside the interval of the 40-scan average."""
    runs, steps, T, sigma_w = 200, 40, 0.25, 0.5
    rng = np.random.default_rng(7)
    F, G = ncv_transition(T)
    Q = process_noise(G, sigma_w)
    Q[4, 4] = Q[5, 5] = 1e-4  # acceleration carried as ~0, as the tracker does
    tx, rx = np.array([0.0, 0.0]), np.array([40.0, -10.0])
    R = np.diag([1.0, 1.0]) if names == ("x", "y") else np.diag([0.5**2, 0.01**2])
    m = len(names)
    ang = angular_mask(names)
    truth = np.zeros((runs, 6))
    truth[:, [0, 2]] = [150.0, 120.0]
    truth[:, [1, 3]] = [6.0, -3.0]
    P = np.tile(np.diag([4.0, 1.0, 4.0, 1.0, 1e-4, 1e-4]), (runs, 1, 1))
    x = truth + np.einsum("nij,nj->ni", np.linalg.cholesky(P), rng.standard_normal((runs, 6)))
    nees, nis = [], []
    for _ in range(steps):
        truth = truth @ F.T + rng.standard_normal((runs, 2)) @ G.T * sigma_w
        x, P = kf_predict(x, P, F, Q)
        z = measure(names, truth, tx, rx)[0] + rng.standard_normal((runs, m)) @ np.linalg.cholesky(R).T
        if filt == "ukf":
            z_hat, S0, C = ukf_moments(names, x, P, tx, rx, UnscentedWeights(6), ang)
        else:
            z_hat, S0, C = ekf_moments(names, x, P, tx, rx)
        nu = wrap_residual(z - z_hat, ang)
        S = S0 + R
        nis.append(np.einsum("ni,ni->n", nu, np.linalg.solve(S, nu[..., None])[..., 0]).mean())
        x, P = joseph_update(x, P, C, S0, np.broadcast_to(R, S.shape), nu)
        e = (truth - x)[:, :4]
        nees.append(np.einsum("ni,ni->n", e, np.linalg.solve(P[:, :4, :4], e[..., None])[..., 0]).mean())
    for values, dof in ((np.array(nees), 4), (np.array(nis), m)):
        lo, hi = chi2.ppf([0.025, 0.975], dof * runs) / runs
        assert np.mean((values > lo) & (values < hi)) >= 0.85
        glo, ghi = chi2.ppf([0.025, 0.975], dof * runs * steps) / (runs * steps)
        # scans of one run are correlated: widen the grand-mean interval by the number of scans' square root
        half = (ghi - glo) / 2 * math.sqrt(steps)
        assert abs(values.mean() - dof) < half


def _turn_errors(tracker_cfg: TrackerConfig, seeds) -> FloatArray:
    # a beam steered at the target (full array gain), no false alarms: the comparison is about the motion models
    cfg = scenarios.get(
        "urban-intersection", **{"sensing.clutter.density_per_m2": 0.0, "sensing.array_beams": "steered"}
    )
    sim = Simulator(cfg, tracker_cfg)
    pol = round_robin(sim.sensor)
    err = []
    for seed in seeds:
        acc = run_episode(sim, seed, pol)
        # target 0 (first leg 0-5 s, decelerates 5-10 s) turns at 10-20 s: scans 40..80 (scan k at index k - 1)
        err.append(np.array(acc.errors)[39:80, 0])
    return np.concatenate(err)  # nan where no confirmed track covers the target


def test_vs_imm_tracks_the_turning_target_closer_than_a_single_ncv_filter():
    """Seed 003's reason for VS-IMM: through the turn, with range and range-rate only (the seed's measurement set).

    Measured (seeds 0-11): VS-IMM holds the turning vehicle in 0.92 of the turn's scans, one NCV UKF in 0.85; on the
    scans both hold, VS-IMM's mean position error is 0.88 m against 1.37 m (RMSE 1.85 vs 1.99 m: both lose the
    vehicle for a few scans at the turn's entry). Before the parametric model had the range walk's accuracy loss
    (``ParametricSensor.walk_factors``: range std up to 10 % larger at 20 m/s for the 40 MHz chirps, which the
    signal chain's spread shows), the NCV filter's gates were too tight on the approach and it lost the turn
    (held 0.51 on seeds 0-3): that margin was an artefact of an overconfident R.
    """
    cfg = scenarios.get("urban-intersection")
    seeds = range(12)
    imm = _turn_errors(cfg.tracker, seeds)
    ncv = _turn_errors(open_loop_tracker(cfg.tracker), seeds)
    held_imm, held_ncv = np.mean(~np.isnan(imm)), np.mean(~np.isnan(ncv))
    both = ~np.isnan(imm) & ~np.isnan(ncv)
    assert held_imm >= 0.85
    assert held_imm > held_ncv
    assert np.mean(np.abs(imm[both])) <= 0.8 * np.mean(np.abs(ncv[both]))


WITH_AZIMUTH = {"sensing.measure_doa": True}
"""Issue 3's measurement set: each receiver's array also measures the azimuth. The scenario's default became seed
003's (range + range-rate only, SNR 0.2) later (issue 15), under which the two tests below measure something else:
the compact node (transmitter and both receivers within 12 m, nearly on one line) has ellipses symmetric about that
line, so range-only initiation also confirms the mirror image of a vehicle (11-40 m off, 3-99 scans: 0.30 false
tracks per run over runs 0-39, 0.05 with azimuth), and the eastbound vehicle of ``urban-crossing`` is held in 0-32 %
of the scans before the crossing, so its identity count there is about detection (kept in 60 % of runs 0-29; no
swap). The mirror tracks are what a tracker Pd with the receive arrays' angular gain (behind the array Pd ~ 0) would
refuse; that is not built."""


@pytest.mark.slow
def test_urban_tracking_monte_carlo_100_runs():
    """Issue 3: both targets confirmed in >= 90 % of 100 runs, < 0.1 false confirmed tracks per run (measured 100 %,
    0.07), on issue 3's measurement set (``WITH_AZIMUTH``)."""
    cfg = scenarios.get("urban-intersection", **WITH_AZIMUTH)
    sim = Simulator(cfg)
    pol = round_robin(sim.sensor)
    accs = [run_episode(sim, seed, pol) for seed in range(100)]
    assert np.mean([a.confirmed_targets().all() for a in accs]) >= 0.9
    assert np.mean([a.false_tracks() for a in accs]) < 0.1


@pytest.mark.slow
def test_crossing_targets_keep_their_identities_100_runs():
    """The track holding each vehicle before the crossing holds it after, in >= 90 % of 100 runs (measured 100 %),
    on issue 3's measurement set (``WITH_AZIMUTH``)."""
    cfg = scenarios.get("urban-crossing", **WITH_AZIMUTH)
    sim = Simulator(cfg)
    pol = round_robin(sim.sensor)
    kept = []
    for seed in range(100):
        acc = run_episode(sim, seed, pol)
        n = len(acc.held)
        kept.append(acc.identity_kept(slice(8, int(0.45 * n)), slice(int(0.55 * n), n)).all())
    assert np.mean(kept) >= 0.9


def _check_tracks(tracks) -> None:
    assert np.isfinite(tracks.x).all()
    assert np.isfinite(tracks.P).all()
    assert np.isfinite(tracks.existence).all()
    assert ((tracks.existence >= 0) & (tracks.existence <= 1)).all()
    np.testing.assert_allclose(tracks.mu.sum(-1), 1.0, atol=1e-9)
    if len(tracks):
        act = tracks.active
        ev = np.linalg.eigvalsh(tracks.P[act])
        assert (ev > 0).all()


DENSE = {"sensing.false_alarm_probability": 0.1, "sensing.clutter.density_per_m2": 0.05}  # 500 per pair and scan
EXTREMES = [
    {"sensing.false_alarm_probability": 0.1, "sensing.clutter.density_per_m2": 0.01},  # dense clutter
    {"transmitters.0.power_dbm": -40.0},  # Pd near 0
    {"transmitters.0.power_dbm": 60.0},  # Pd near 1, tiny noise
    {"targets.0.trajectory.start_position_m": (10.0, 0.3), "sensing.blind_zone_excess_m": 0.2},  # at the blind zone
    {"tracker.detection_probability": 0.999, "tracker.gate_probability": 0.9999},
]


@pytest.mark.parametrize("overrides", EXTREMES)
def test_no_nan_or_non_pd_covariance_with_extreme_settings(overrides):
    cfg = apply_overrides(tiny_config(n_scans=150, clutter_density=1e-3, speed=3.0), overrides)
    sim = Simulator(cfg)
    pol = round_robin(sim.sensor)
    for seed in range(2):
        sim.reset(seed)
        while not sim.done:
            _check_tracks(sim.step(pol(sim.k + 1)).tracks)


@pytest.mark.slow
def test_no_nan_over_100k_scans_with_extreme_settings():
    n = 0
    for i, overrides in enumerate([*EXTREMES[1:], DENSE] * 5):
        n_scans = 40 if overrides is DENSE else 5000  # 500 false alarms per pair and scan: ~1 s per scan
        cfg = apply_overrides(tiny_config(n_scans=n_scans, clutter_density=1e-3, speed=3.0), overrides)
        sim = Simulator(cfg)
        pol = round_robin(sim.sensor)
        sim.reset(i)
        while not sim.done:
            _check_tracks(sim.step(pol(sim.k + 1)).tracks)
            n += 1
    assert n >= 80_000


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 10_000), n_scans=st.integers(2, 6), log_noise=st.floats(-4, 3))
def test_tracker_survives_random_valid_measurement_sets(seed, n_scans, log_noise):
    rng = np.random.default_rng(seed)
    names = ("bistatic_range", "range_rate", "azimuth")
    tr = Tracker(
        TrackerConfig(),
        np.array([[0.0, 0.0]]),
        np.array([[20.0, 0.0], [0.0, 20.0]]),
        np.array([-100.0, 100.0, -100.0, 100.0]),
    )
    for k in range(1, n_scans + 1):
        dets = []
        for r in range(2):
            n = int(rng.integers(0, 8))
            z = np.column_stack([rng.uniform(25, 250, n), rng.normal(0, 30, n), rng.uniform(-np.pi, np.pi, n)])
            A = rng.standard_normal((n, 3, 3)) * 10.0**log_noise
            Rm = A @ np.swapaxes(A, 1, 2) + 10.0**log_noise * np.eye(3)
            dets.append(
                Detections(
                    0, r, 0, 0.25 * k, z, Rm, np.full(n, 10.0), np.full(n, -1), names, rng.uniform(1e-9, 1e-3, n), 5.0
                )
            )
        _check_tracks(tr.step(dets, 0.25 * k, k))
