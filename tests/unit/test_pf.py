"""Seed 002's particle filter (``uwb_env.tracking.pf``) and the navigation error outage (``uwb_env.metrics``).

Mobility models against their moments, walls never crossed, the perception likelihood against a hand computation,
determinism, the lookahead hooks (pure, moment-exact), and a tracking run on ``indoor-monostatic`` against the
seed's Fig. 2 80 % point.
"""

from __future__ import annotations

import copy
import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uwb_env import scenarios
from uwb_env.channel.walls import leg_crossings
from uwb_env.config import MaterialConfig, PfConfig, TrackerConfig
from uwb_env.constants import SPEED_OF_LIGHT_MPS
from uwb_env.metrics import error_at_outage, navigation_error_outage
from uwb_env.rng import RngStreams
from uwb_env.scene.geometry import segments_cross
from uwb_env.scene.layout import SceneLayout
from uwb_env.scene.truth import sample_truth
from uwb_env.sensing.protocol import make_sensor
from uwb_env.sensing.records import Detections, ScanPlan
from uwb_env.tracking.expectation import reduction_model
from uwb_env.tracking.pf import (
    ParticleFilterTracker,
    Prediction,
    blocked_moves,
    ellipse_samples,
    leg_delays,
    mobility_std,
    move_particles,
    pair_log_likelihood,
    sdl_coefficients,
    sdl_displacements,
    sdl_velocity,
    sdl_velocity_moments,
    sdl_window_steps,
    skdu_displacements,
    systematic_resample,
)
from uwb_env.tracking.protocol import MultiTargetTracker
from uwb_env.tracking.registry import make_tracker


def layout(
    radars: list[tuple[float, float]],
    walls: list[tuple[tuple[float, float], tuple[float, float]]] = (),  # type: ignore[assignment]
    delay_s: float = 0.0,
    area: tuple[float, float, float, float] = (0.0, 10.0, 0.0, 10.0),
) -> SceneLayout:
    """A monostatic layout: radars, walls (each ``delay_s`` excess delay, 10 dB), the area."""
    n, w = len(radars), len(walls)
    pos = np.array(radars, float).reshape(n, 2)
    return SceneLayout(
        tx_pos=pos,
        rx_pos=pos.copy(),
        wall_start=np.array([a for a, _ in walls], float).reshape(w, 2),
        wall_end=np.array([b for _, b in walls], float).reshape(w, 2),
        wall_loss_db=np.full(w, 10.0),
        wall_delay_s=np.full(w, delay_s),
        clutter_points=np.zeros((0, 2)),
        area=np.array(area, float),
        rx_has_array=np.zeros(n, bool),
        rx_n_elements=np.ones(n),
        rx_boresight_rad=np.full(n, np.nan),
        rx_fov_rad=np.full(n, np.nan),
        rx_spacing_m=np.full(n, np.nan),
    )


def detections(radar: int, z: list[float], var: list[float], rho: list[float], nfa: float = 0.9) -> Detections:
    """One monostatic radar's detections: bistatic ranges ``z``, variances ``var``, clutter intensities ``rho``."""
    n = len(z)
    return Detections(
        tx=radar,
        rx=radar,
        waveform=0,
        time_s=0.0,
        z=np.array(z, float).reshape(n, 1),
        R=np.array(var, float).reshape(n, 1, 1),
        snr=np.full(n, 100.0),
        origin=np.full(n, -1),
        measurement_names=("bistatic_range",),
        clutter_intensity=np.array(rho, float),
        expected_false_alarms=nfa,
    )


def pf_config(**pf: object) -> TrackerConfig:
    return TrackerConfig(kind="pf", pf=PfConfig(**pf))  # type: ignore[arg-type]


# ------------------------------------------------------------------------------------------------- mobility models
def _mean_and_var_within_sampling_error(d: np.ndarray, mean: np.ndarray, var: float) -> None:
    n = d.shape[0]
    m = d.mean(axis=0)
    assert np.all(np.abs(m - mean) < 5.0 * math.sqrt(var / n)), (m, mean)
    c = d - m
    v = (c**2).mean(axis=0)
    se = np.sqrt(((c**4).mean(axis=0) - v**2) / n)  # SE of a sample variance
    assert np.all(np.abs(v - var) < 5.0 * se), (v, var, se)
    assert abs((c[:, 0] * c[:, 1]).mean()) < 5.0 * var / math.sqrt(n)  # isotropic: no x-y correlation


def test_sigma_m_follows_the_seeds_ninety_percent_rule():
    """sigma_m: with probability 0.9 the Gaussian part of a move stays within v T of its mean (seed 002 sec. V)."""
    pf = PfConfig()
    sigma = mobility_std(pf, 0.2)
    assert sigma == pytest.approx(0.2 / math.sqrt(2.0 * math.log(10.0)))  # 0.0932 m
    assert 1.0 - math.exp(-(0.2**2) / (2.0 * sigma**2)) == pytest.approx(0.9)
    assert mobility_std(PfConfig(mobility_std_m=0.3), 0.2) == 0.3
    noise = sdl_displacements(200_000, np.zeros(2), 0.2, sigma, np.random.default_rng(1))
    inside = (np.linalg.norm(noise, axis=1) < 0.2).mean()
    assert inside == pytest.approx(0.9, abs=5.0 * math.sqrt(0.09 / 200_000))


def test_skdu_displacements_have_the_seeds_moments():
    """SKDU (eq. 16 in 15): E[d] = 0, Cov[d] = (v^2 T^2 / 2 + sigma_m^2) I, and |mu_m - p| = v T exactly."""
    v, dt, sigma = 1.0, 0.2, 0.0932
    d = skdu_displacements(200_000, v, dt, sigma, np.random.default_rng(2))
    _mean_and_var_within_sampling_error(d, np.zeros(2), 0.5 * (v * dt) ** 2 + sigma**2)
    step = skdu_displacements(1000, v, dt, 0.0, np.random.default_rng(3))
    np.testing.assert_allclose(np.linalg.norm(step, axis=1), v * dt)
    heading = np.arctan2(step[:, 1], step[:, 0])  # uniform on [-pi, pi]: mean 0, variance pi^2 / 3
    assert abs(heading.mean()) < 5.0 * math.sqrt(math.pi**2 / 3 / 1000)


def test_sdl_displacements_have_the_seeds_moments():
    """SDL (eq. 18 in 15): E[d] = v_el T, Cov[d] = sigma_m^2 I."""
    vel, dt, sigma = np.array([0.8, -0.6]), 0.2, 0.0932
    d = sdl_displacements(200_000, vel, dt, sigma, np.random.default_rng(4))
    _mean_and_var_within_sampling_error(d, vel * dt, sigma**2)


def test_sdl_velocity_is_the_window_average_of_the_estimates():
    """v_el = (p^_{k-1} - p^_{k-1-N_v}) / (N_v T), None before N_v + 1 estimates (eq. 17 as read)."""
    est = np.array([[0.0, 0.0], [0.3, 0.0], [0.5, 0.1], [0.6, 0.4]])
    times = np.array([0.2, 0.4, 0.6, 0.8])
    np.testing.assert_allclose(sdl_velocity(est, times, 2), (est[3] - est[1]) / 0.4)
    np.testing.assert_allclose(sdl_velocity(est, times, 3), (est[3] - est[0]) / 0.6)
    assert sdl_velocity(est, times, 4) is None


@pytest.mark.parametrize("estimator", ["difference", "lsq"])
def test_sdl_velocity_estimators_against_their_closed_form(estimator):
    """Estimates p^_i = p_0 + v t_i + N(0, s^2 I), i = 0..N_v, T apart: v_el is unbiased, and its per-axis variance is
    2 s^2 / (N_v T)^2 (difference) or s^2 / S_tt = 12 s^2 / (T^2 n (n^2 - 1)), n = N_v + 1 (least squares), which
    ``sdl_velocity_moments`` also returns from the estimates' covariances. N_v = 5, T = 0.1 s, s = 0.3 m: 0.72 and
    0.51 (m/s)^2 -- the least-squares slope has 29 % less variance."""
    nv, dt, s, v = 5, 0.1, 0.3, np.array([0.8, -0.6])
    times = 0.1 * np.arange(nv + 1) + 3.0
    n = nv + 1
    var = {"difference": 2.0 * s**2 / (nv * dt) ** 2, "lsq": 12.0 * s**2 / (dt**2 * n * (n * n - 1))}[estimator]
    assert var == pytest.approx({"difference": 0.72, "lsq": 0.5143}[estimator], rel=1e-3)
    covs = np.repeat((s**2 * np.eye(2))[None], n, axis=0)
    _, cov, t_ref = sdl_velocity_moments(np.zeros((n, 2)), times, nv, estimator, covs)  # type: ignore[misc]
    np.testing.assert_allclose(cov, var * np.eye(2), rtol=1e-12)
    assert t_ref == pytest.approx(3.25)
    rng = np.random.default_rng(11)
    trials = 40_000
    a = sdl_coefficients(times, nv, estimator)
    assert a is not None and a.sum() == pytest.approx(0.0, abs=1e-9) and a @ times == pytest.approx(1.0)
    est = np.array([1.0, 2.0]) + times[None, :, None] * v + s * rng.standard_normal((trials, n, 2))
    vel = np.einsum("i,tij->tj", a, est)  # the same linear map as sdl_velocity, vectorised over the trials
    np.testing.assert_allclose(sdl_velocity(est[0], times, nv, estimator), vel[0], rtol=1e-12)
    _mean_and_var_within_sampling_error(vel - v, np.zeros(2), var)


def test_sdl_window_in_time():
    """N_v = round(sdl_window_s / T): the seed's N_v = 5 at T = 0.2 s spans 1 s, and so does the window at any T."""
    pf = PfConfig()
    assert [sdl_window_steps(pf, t) for t in (0.5, 0.2, 0.1, 0.05, 2.0)] == [2, 5, 10, 20, 1]
    assert sdl_window_steps(PfConfig(sdl_window_s=0.0, sdl_window=7), 0.1) == 7


def test_sdl_particles_draw_their_velocity_from_the_learnt_one():
    """With the learnt velocity's covariance C, Cov[d] = C T^2 + sigma_m^2 I about v_el T (full 2 x 2)."""
    vel, dt, sigma = np.array([0.8, -0.6]), 0.2, 0.05
    cov_v = np.array([[0.3, 0.1], [0.1, 0.2]])
    n = 200_000
    d = sdl_displacements(n, vel, dt, sigma, np.random.default_rng(12), cov_v)
    expected = cov_v * dt**2 + sigma**2 * np.eye(2)  # [[0.0145, 0.004], [0.004, 0.0105]]
    assert np.all(np.abs(d.mean(axis=0) - vel * dt) < 5.0 * np.sqrt(np.diag(expected) / n))
    np.testing.assert_allclose(np.cov(d.T), expected, rtol=0.02)


def test_sdl_tracker_velocity_covariance_adds_the_manoeuvre_over_the_lag():
    """The tracker's learnt velocity: least squares over the 1 s window, covariance sum a_i^2 P_i + (sigma_a tau)^2 I,
    tau from the window's mean time to the middle of the next move; none before the window spans N_v steps."""
    trk = ParticleFilterTracker(pf_config(mobility="sdl", sdl_accel_std_mps2=0.5), layout([(0.0, 0.0)]))
    times = 0.2 * np.arange(6)
    trk._estimate_times = list(times)
    trk._estimates = [np.array([t, 2.0 * t]) for t in times]  # 1 m/s along x, 2 m/s along y
    trk._estimate_covs = [np.diag([0.04, 0.09])] * 6
    v, cov = trk._velocity(0.2)  # type: ignore[misc]
    np.testing.assert_allclose(v, [1.0, 2.0])
    stt = float(((times - times.mean()) ** 2).sum())  # 0.7 s^2
    tau = 1.0 + 0.1 - 0.5
    np.testing.assert_allclose(cov, np.diag([0.04, 0.09]) / stt + (0.5 * tau) ** 2 * np.eye(2), rtol=1e-12)
    assert trk._velocity(0.1) is None  # at T = 0.1 s the 1 s window needs 11 estimates
    seed = ParticleFilterTracker(pf_config(mobility="sdl", sdl_velocity_spread=False), layout([(0.0, 0.0)]))
    seed._estimate_times, seed._estimates, seed._estimate_covs = trk._estimate_times, trk._estimates, trk._estimate_covs
    np.testing.assert_array_equal(seed._velocity(0.2)[1], np.zeros((2, 2)))  # type: ignore[index]


point = st.tuples(st.floats(-5.0, 5.0), st.floats(-5.0, 5.0))


@settings(max_examples=60, deadline=None)
@given(
    walls=st.lists(st.tuples(point, point), min_size=1, max_size=5),
    seed=st.integers(0, 2**31 - 1),
    redraws=st.integers(0, 3),
    step_m=st.floats(0.1, 8.0),
)
def test_moves_never_cross_a_wall(walls, seed, redraws, step_m):
    """Property: whatever the walls and the draws, no particle's move crosses a wall segment."""
    rng = np.random.default_rng(seed)
    a = np.array([w[0] for w in walls], float)
    b = np.array([w[1] for w in walls], float)
    pos = rng.uniform(-5.0, 5.0, (50, 2))
    new, d = move_particles(pos, lambda n: step_m * rng.standard_normal((n, 2)), a, b, redraws)
    np.testing.assert_allclose(new, pos + d)
    moved = np.any(d != 0.0, axis=1)
    assert not segments_cross(pos[moved], new[moved], a, b).any()


@settings(max_examples=40, deadline=None)
@given(walls=st.lists(st.tuples(point, point), min_size=1, max_size=6), seed=st.integers(0, 2**31 - 1))
def test_compiled_wall_kernels_equal_the_geometry_module(walls, seed):
    """``blocked_moves`` is ``segments_cross`` exactly; ``leg_delays`` is ``leg_crossings @ delay`` to rounding."""
    rng = np.random.default_rng(seed)
    a = np.array([w[0] for w in walls], float)
    b = np.array([w[1] for w in walls], float)
    p0, p1 = rng.uniform(-6.0, 6.0, (40, 2)), rng.uniform(-6.0, 6.0, (40, 2))
    np.testing.assert_array_equal(blocked_moves(p0, p1, a, b), segments_cross(p0, p1, a, b).any(axis=1))
    delay = rng.uniform(0.0, 2e-9, len(walls))
    node = rng.uniform(-6.0, 6.0, 2)
    expected = leg_crossings(node[None], p1, a, b)[0] @ delay  # the same walls; the sums' order may differ
    np.testing.assert_allclose(leg_delays(node, p1, a, b, delay), expected, rtol=1e-12, atol=0.0)


def test_sdl_particles_stay_in_a_closed_room():
    """The tracker's SDL particles, pushed by 60 scans of detections outside, never leave a closed room."""
    room = [
        ((0.0, 0.0), (10.0, 0.0)),
        ((10.0, 0.0), (10.0, 10.0)),
        ((10.0, 10.0), (0.0, 10.0)),
        ((0.0, 10.0), (0.0, 0.0)),
    ]
    lay = layout([(5.0, 5.0), (-20.0, 5.0)], room, area=(0.0, 10.0, 0.0, 10.0))
    trk = ParticleFilterTracker(pf_config(mobility="sdl", mobility_std_m=0.5, sdl_window=2), lay)
    trk.reset(np.random.default_rng(5))
    for k in range(1, 61):  # the "target" seen by radar 1 outside the room, walking away from it
        trk.step([detections(1, [2.0 * (19.0 - 0.2 * k)], [1.0], [0.0])], 0.2 * k, k)
        pos = trk.particles[0]  # type: ignore[index]
        assert (pos > 0.0).all() and (pos < 10.0).all()
    assert 0.0 < trk.tracks.x[0, 0, 0] < 10.0


# ------------------------------------------------------------------------------------------------------ perception
def test_likelihood_against_a_hand_computation():
    """One radar at the origin, a 1 ns wall at x = 2, two detections, Pd 0.8 (module docstring of pf).

    Particle (3, 4): 5 m away through the wall, h = 2 x 5 + 2 c 1 ns; particle (1, 1): LOS, h = 2 sqrt 2.
    lambda_j = max(clutter_intensity_j, 0.9 / span), span = 2 |(10, 10)| (the farthest corner of the area).
    """
    lay = layout([(0.0, 0.0), (9.0, 9.0)], [((2.0, -5.0), (2.0, 5.0))], delay_s=1e-9)
    trk = ParticleFilterTracker(pf_config(), lay, pd_model=lambda t, r, p: np.full(p.shape[0], 0.8))
    det = detections(0, [10.5, 3.0], [0.25, 4.0], [0.0, 0.05])
    pos = np.array([[3.0, 4.0], [1.0, 1.0]])
    got = trk.log_likelihood(pos, [det, detections(1, [], [], [])])
    lam = np.array([0.9 / (2.0 * math.hypot(10.0, 10.0)), 0.05])
    for p, h in zip(pos, (10.0 + 2.0 * SPEED_OF_LIGHT_MPS * 1e-9, 2.0 * math.sqrt(2.0)), strict=True):
        gauss = [
            math.exp(-0.5 * (z - h) ** 2 / v) / math.sqrt(2.0 * math.pi * v) for z, v in ((10.5, 0.25), (3.0, 4.0))
        ]
        hand = math.log(0.2 + 0.8 * (gauss[0] / lam[0] + gauss[1] / lam[1]))
        radar1_silent = math.log(1.0 - 0.8)  # radar 1 listened and saw nothing: 1 - Pd
        assert got[(p == pos).all(axis=1)][0] == pytest.approx(hand + radar1_silent, rel=1e-12)
    no_bias = ParticleFilterTracker(pf_config(wall_bias=False), lay, lambda t, r, p: np.full(p.shape[0], 0.8))
    h0 = 10.0
    g = math.exp(-0.5 * (10.5 - h0) ** 2 / 0.25) / math.sqrt(2.0 * math.pi * 0.25)
    g2 = math.exp(-0.5 * (3.0 - h0) ** 2 / 4.0) / math.sqrt(2.0 * math.pi * 4.0)
    assert no_bias.log_likelihood(pos[:1], [det])[0] == pytest.approx(math.log(0.2 + 0.8 * (g / lam[0] + g2 / lam[1])))


def test_seed_perception_model_uses_sigma_p_on_the_one_way_distance():
    """likelihood "seed": variance (2 sigma_p)^2 in bistatic range, whatever the detection's R; "both": the sum."""
    h = np.array([10.0])
    z, r = np.array([11.0]), np.array([0.3])
    for kind, var in (("seed", 4 * 0.8**2), ("both", 0.3 + 4 * 0.8**2), ("snr", 0.3)):
        trk = ParticleFilterTracker(pf_config(likelihood=kind), layout([(0.0, 0.0)]), None)
        got = trk.log_likelihood(np.array([[5.0, 0.0]]), [detections(0, [11.0], [0.3], [1.0])])
        pd = trk.cfg.detection_probability
        assert got[0] == pytest.approx(pair_log_likelihood(h, z, np.array([var]), np.array([pd]), np.ones(1))[0])
        assert got[0] == pytest.approx(math.log(1 - pd + pd * math.exp(-0.5 / var) / math.sqrt(2 * math.pi * var)))
    assert r.size == 1


def test_ellipse_samples_lie_on_their_iso_range_ellipses():
    """Bistatic and monostatic: |p - tx| + |p - rx| = z for every sample (no range spread)."""
    tx = np.array([[0.0, 0.0], [1.0, 1.0]])
    rx = np.array([[4.0, 3.0], [1.0, 1.0]])
    z = np.array([9.0, 6.0])
    pick = np.arange(200) % 2
    p = ellipse_samples(tx, rx, z, pick, 0.0, np.random.default_rng(11))
    np.testing.assert_allclose(np.linalg.norm(p - tx[pick], axis=1) + np.linalg.norm(p - rx[pick], axis=1), z[pick])
    trk = ParticleFilterTracker(pf_config(init_std_m=0.2, n_particles=4000), layout([(0.0, 0.0)], area=(-9, 9, -9, 9)))
    trk.reset(np.random.default_rng(12))
    trk.step([detections(0, [10.0], [0.04], [0.0])], 0.2, 1)
    pos, _, w = trk.particles  # type: ignore[misc]
    assert np.sqrt(w @ (np.linalg.norm(pos, axis=1) - 5.0) ** 2) < 0.25  # on the 5 m ring, weighted


def test_systematic_resampling_counts():
    """Systematic resampling gives particle i floor(N w_i) or ceil(N w_i) copies."""
    w = np.array([0.5, 0.25, 0.125, 0.125, 0.0])
    idx = systematic_resample(w, np.random.default_rng(6))
    counts = np.bincount(idx, minlength=5)
    assert np.all(counts >= np.floor(5 * w)) and np.all(counts <= np.ceil(5 * w)) and counts.sum() == 5


# ----------------------------------------------------------------------------------------------------- the seam
def test_registry_builds_the_pf_and_it_honours_the_protocol():
    cfg = scenarios.get("indoor-monostatic")
    lay = SceneLayout.from_config(cfg)
    trk = make_tracker(dataclasses.replace(cfg.tracker, kind="pf"), lay)
    assert isinstance(trk, ParticleFilterTracker) and isinstance(trk, MultiTargetTracker)
    assert (trk.kind, trk.filter, trk.model_names) == ("pf", "ukf", ("skdu",))
    sdl = make_tracker(dataclasses.replace(cfg.tracker, kind="pf", pf=PfConfig(mobility="sdl")), lay)
    assert sdl.model_names == ("sdl",)
    assert len(trk.tracks) == 0 and trk.scored_prediction(0.2, 1) is None


@pytest.mark.parametrize(
    "bad",
    [
        dict(n_particles=0),
        dict(mobility="ncv"),
        dict(likelihood="x"),
        dict(resample_threshold=1.5),
        dict(speed_mps=-1.0),
        dict(sdl_window=0),
        dict(sdl_window_s=-1.0),
        dict(sdl_estimator="mean"),
        dict(sdl_velocity_spread=1),
        dict(sdl_accel_std_mps2=-0.1),
        dict(wall_bias=1),
        dict(perception_std_m=0.0),
    ],
)
def test_pf_config_rejects_bad_values(bad):
    with pytest.raises(ValueError, match="PfConfig"):
        PfConfig(**bad)


def _episode_tracker(rng: np.random.Generator | None, n: int = 300, scans: int = 6, **pf: object):
    lay = layout([(0.0, 0.0), (10.0, 0.0), (0.0, 10.0)])
    trk = ParticleFilterTracker(pf_config(n_particles=n, **pf), lay, None)
    trk.reset(rng)
    target = np.array([4.0, 3.0])
    out = []
    for k in range(1, scans + 1):
        target = target + np.array([0.2, 0.0])
        dets = [
            detections(i, [2.0 * float(np.linalg.norm(target - s))], [0.04], [0.0]) for i, s in enumerate(lay.tx_pos)
        ]
        out.append(trk.step(dets, 0.2 * k, k).x.copy())
    return trk, np.array(out)


def test_determinism_under_the_same_stream():
    """Same generator seed, same tracks; reset(None) is a fixed default; another seed, other particles."""
    _, a = _episode_tracker(np.random.default_rng(7))
    _, b = _episode_tracker(np.random.default_rng(7))
    _, c = _episode_tracker(np.random.default_rng(8))
    _, d = _episode_tracker(None)
    _, e = _episode_tracker(None)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(d, e)
    assert not np.array_equal(a, c)
    assert np.linalg.norm(a[-1, 0, 0, [0, 2]] - np.array([5.2, 3.0])) < 0.5  # and it tracks


@pytest.mark.parametrize("mobility", ["skdu", "sdl", "sdl-seed"])
def test_scored_prediction_is_pure_and_the_next_clouds_moments(mobility):
    """scored_prediction draws nothing, and equals the weighted moments of the cloud one scan of no data later.

    SKDU: velocity d / T of mean 0 and variance q / T^2; SDL (window 2, full after 3 scans): mean v_el, variance
    sigma_m^2 / T^2 plus the learnt velocity's spread (none in the seed's SDL).
    """
    extra = {"sdl-seed": dict(sdl_velocity_spread=False, sdl_estimator="difference")}.get(mobility, {})
    trk, _ = _episode_tracker(
        np.random.default_rng(9),
        n=40_000,
        scans=4,
        mobility=mobility[:4].rstrip("-"),
        sdl_window=2,
        sdl_window_s=0.0,
        **extra,
    )
    state = copy.deepcopy(trk._rng.bit_generator.state)
    x_before = trk.tracks.x.copy()
    pred = trk.scored_prediction(1.0, 5)
    assert trk._rng.bit_generator.state == state
    assert np.array_equal(trk.tracks.x, x_before)
    est = np.asarray(trk._estimates)  # the last 3 estimates (window 2), 0.2 s apart
    covs = np.asarray(trk._estimate_covs)
    trk.step([], 1.0, 5)  # no pair listened: the particles move, the weights stay
    pos, vel, w = trk.particles  # type: ignore[misc]
    s = np.column_stack((pos[:, 0], vel[:, 0], pos[:, 1], vel[:, 1]))
    m = w @ s
    cov = ((s - m) * w[:, None]).T @ (s - m)
    n_eff = 1.0 / np.sum(w**2)
    se = np.sqrt(np.diag(cov) / n_eff)
    assert np.all(np.abs(m - pred.x[0, :4]) < 5 * se)
    np.testing.assert_allclose(np.diag(cov), np.diag(pred.P[0])[:4], rtol=0.08)
    sigma2 = mobility_std(trk.pf, 0.2) ** 2
    if mobility == "skdu":
        q = 0.5 * 0.2**2 + sigma2  # per-axis variance of one move
        np.testing.assert_allclose(pred.x[0, [1, 3]], 0.0)
    else:
        q = sigma2
        v_el = (est[-1] - est[-3]) / 0.4  # 3 estimates 0.2 s apart: least squares = the difference
        np.testing.assert_allclose(pred.x[0, [1, 3]], v_el)
        assert abs(v_el[0] - 1.0) < 0.3  # the target walks at 1 m/s along x
        if mobility == "sdl":  # Cov(v_el) = (P_first + P_last) / 0.4^2, lag 0.8 + 0.1 - 0.6 s, sigma_a 1 m/s^2
            cov_v = (covs[-1] + covs[-3]) / 0.16 + 0.3**2 * np.eye(2)
            q = q + np.diag(cov_v) * 0.2**2
    np.testing.assert_allclose(pred.P[0, [1, 3], [1, 3]], q / 0.2**2)


def test_predict_gaussians_moment_maps():
    """SKDU: P_pos + q I, velocity d / dt ~ (0, q / dt^2); SDL (full window): the mean moves by its velocity dt."""
    lay = layout([(0.0, 0.0)])
    x = np.array([[1.0, 0.5, 2.0, -0.5, 0.0, 0.0]])
    P = np.diag([0.1, 0.2, 0.3, 0.4, 1e-4, 1e-4])[None]
    pred = Prediction(x=x, P=P, mu=np.ones((1, 1)), active=np.ones(1, bool))
    skdu = ParticleFilterTracker(pf_config(), lay).predict_gaussians(pred, 0.2, 2)
    q = 0.5 * 0.2**2 + mobility_std(PfConfig(), 0.2) ** 2
    np.testing.assert_allclose(skdu.x[0], [1.0, 0.0, 2.0, 0.0, 0.0, 0.0])
    np.testing.assert_allclose(skdu.P[0, [0, 2], [0, 2]], [0.1 + q, 0.3 + q])
    np.testing.assert_allclose(skdu.P[0, [1, 3], [1, 3]], q / 0.04)
    assert np.all(np.linalg.eigvalsh(skdu.P[0]) > 0)
    sdl_tracker = ParticleFilterTracker(pf_config(mobility="sdl", sdl_window=2, sdl_window_s=0.0), lay)
    np.testing.assert_allclose(sdl_tracker.predict_gaussians(pred, 0.2, 2).P, skdu.P)  # window empty: as SKDU
    sdl_tracker._estimates = [np.zeros(2), np.zeros(2), np.zeros(2)]  # a full window (2 steps), exact estimates
    sdl_tracker._estimate_covs = [np.zeros((2, 2))] * 3
    sdl_tracker._estimate_times = [0.2, 0.4, 0.6]
    sdl = sdl_tracker.predict_gaussians(pred, 0.2, 2)
    np.testing.assert_allclose(sdl.x[0], [1.1, 0.5, 1.9, -0.5, 0.0, 0.0])
    q_sdl = mobility_std(PfConfig(), 0.2) ** 2 + (1.0 * 0.3 * 0.2) ** 2  # sigma_m^2 + (sigma_a tau T)^2, tau 0.3 s
    np.testing.assert_allclose(sdl.P[0, [0, 2], [0, 2]], np.array([0.1, 0.3]) + q_sdl)
    assert np.all(np.linalg.eigvalsh(sdl.P[0]) > 0)


def test_expected_update_shrinks_the_moment_matched_gaussian():
    trk, _ = _episode_tracker(np.random.default_rng(10))
    pred = trk.scored_prediction(1.4, 7)
    Pa = np.repeat(pred.P[None], 2, axis=0).copy()
    R = np.array([0.04, 4.0])[:, None, None, None] * np.ones((2, 1, 1, 1))
    out = trk.expected_update(
        Pa,
        pred.x,
        pred.P,
        ("bistatic_range",),
        trk.tx_pos[0],
        trk.rx_pos[0],
        R,
        np.full((2, 1), 0.9),
        reduction_model(1.0, 1, 0.99),
        np.zeros((2, 1)),
        np.full(2, np.inf),
    )
    tr = np.trace(out[:, 0, :4, :4], axis1=-2, axis2=-1)
    assert tr[0] < tr[1] < np.trace(pred.P[0, :4, :4])


# ------------------------------------------------------------------------------------------------------------ NEO
def test_navigation_error_outage_on_hand_traces():
    """NEO(e_th) = fraction of errors strictly above e_th (seed 002 eq. 21); the 80 % point e_(ceil(0.8 n))."""
    e = np.array([0.5, 0.1, 2.0, 1.0, 0.3, 0.3, 1.5, 0.7, 0.2, 3.0])
    np.testing.assert_array_equal(
        navigation_error_outage(e, [0.0, 0.3, 0.31, 1.0, 2.0, 3.0, 5.0]), [1.0, 0.6, 0.6, 0.3, 0.1, 0.0, 0.0]
    )
    assert error_at_outage(e) == 1.5  # 2 of 10 above it
    assert navigation_error_outage(e, 1.5) == 0.2
    assert error_at_outage(e, 0.5) == 0.5 and error_at_outage(e, 0.05) == 3.0
    assert error_at_outage(np.array([[1.0, np.nan], [2.0, 4.0]]), 0.4) == 2.0  # no estimate: left out
    assert navigation_error_outage(np.arange(1.0, 6.0), np.array([[0.0], [4.5]])).tolist() == [[1.0], [0.2]]
    for bad in (np.array([np.nan]), np.array([-1.0])):
        with pytest.raises(ValueError, match="navigation errors"):
            navigation_error_outage(bad, [1.0])
    with pytest.raises(ValueError, match="level"):
        error_at_outage(e, 1.0)


# ------------------------------------------------------------------------------------------------- tracking run
def line_of_sight(cfg):
    """Seed 002's LOS comparison: the same floor and trajectories, walls transparent to the radio (0 dB, 0 s)."""
    air = MaterialConfig("air", loss_db=0.0, excess_delay_s=0.0)
    return dataclasses.replace(cfg, walls=tuple(dataclasses.replace(w, material=air) for w in cfg.walls))


def navigation_errors(cfg, pf: PfConfig, seeds, waveform: int = 0) -> np.ndarray:
    """Per-scan navigation errors of the PF on ``cfg`` with every radar on ``waveform``, one episode per seed."""
    sensor = make_sensor(cfg)
    tc = dataclasses.replace(cfg.tracker, kind="pf", pf=pf)
    plan = ScanPlan.all_listening(waveform, sensor.n_tx, sensor.n_rx)
    trk = ParticleFilterTracker.from_layout(
        tc, sensor.layout, lambda t, r, p: sensor.detection_probability_at(t, r, p, waveform, 1.0, 3)
    )
    errors = []
    for seed in seeds:
        rngs = RngStreams.from_seed(seed)
        truth = sample_truth(cfg, rngs.truth, sensor.layout)
        episode = sensor.new_episode(truth, rngs)
        trk.reset(rngs.tracker)
        for k in range(1, cfg.n_scans + 1):
            t = k * cfg.sensing.scan_period_s
            tracks = trk.step(sensor.sense(episode, k, plan, t), t, k)
            est = tracks.x[0, 0, [0, 2]] if len(tracks) else np.full(2, np.nan)
            errors.append(float(np.linalg.norm(est - truth.states[k, 0, [0, 2]])))
    return np.array(errors)


def test_tracking_run_matches_the_seeds_fig2_eighty_percent_point():
    """T = 0.2 s, SKDU, N_pulse = 128, T_int = 4 ns: the seed's LOS 80 % point is 1.0 m, OLOS 2.3 m (Fig. 2).

    LOS with the seed's own perception model (sigma_p = 0.8 m): within a factor 2 of 1.0 m. With walls and the
    default likelihood (each detection's three-region sigma(SNR)): no worse than twice the seed's OLOS figure.
    """
    cfg = scenarios.get("indoor-monostatic")
    los = navigation_errors(line_of_sight(cfg), PfConfig(likelihood="seed"), seeds=(0, 1, 2))
    assert np.isfinite(los).all()  # a track from the first scan
    assert 0.5 <= error_at_outage(los) <= 2.0
    olos = navigation_errors(cfg, PfConfig(), seeds=(0, 1, 2))
    assert error_at_outage(olos) <= 2.0 * 2.3


def test_sdl_with_the_learnt_velocitys_spread_tracks_at_a_tenth_of_a_second():
    """Fig. 4's T = 0.1 s, OLOS, N_pulse = 128, 3 walks: the SDL whose particles draw their velocity from
    N(v_el, C_v) over a 1 s least-squares window has its 80 % point at 1.49 m, best as in the seed; SKDU 2.26 m; the
    literal SDL (N_v = 5 differences, every particle moving by v_el) loses the walker (4.70 m).

    Issue 18 recalibrated the parametric detector on the chain the scenario's signal path runs (the energy detector
    and the extended person: Pd 0.5 at 19.5-25.6 dB where the CFAR chain's point echo had it at 12-17 dB), so the
    walker is detected less often: before, SDL 1.06 m, SKDU 1.54 m, literal 3.98 m."""
    cfg = scenarios.get("indoor-monostatic")
    assert cfg.waveforms[0].n_pulses == 128
    cfg = dataclasses.replace(cfg, n_scans=200, sensing=dataclasses.replace(cfg.sensing, scan_period_s=0.1))
    sdl = error_at_outage(navigation_errors(cfg, PfConfig(mobility="sdl"), seeds=(0, 1, 2)))
    literal = PfConfig(mobility="sdl", sdl_estimator="difference", sdl_window_s=0.0, sdl_velocity_spread=False)
    assert sdl <= 1.5  # measured 1.49 (1.06 on the CFAR chain's point calibration)
    assert sdl < error_at_outage(navigation_errors(cfg, PfConfig(), seeds=(0, 1, 2)))  # SKDU: 2.26
    assert error_at_outage(navigation_errors(cfg, literal, seeds=(0, 1, 2))) >= 2.0 * sdl


def test_simulator_and_lookahead_run_the_pf():
    """The simulator builds the PF from the registry and resets it on the tracker stream (same seed, same tracks);
    the scheduling environment's lookahead scores plans through the PF's seam."""
    from uwb_env.envs.scheduling import UWBSchedulingEnv
    from uwb_env.sim import Simulator, round_robin

    cfg = dataclasses.replace(scenarios.get("indoor-monostatic"), n_scans=15)
    sim = Simulator(cfg, dataclasses.replace(cfg.tracker, kind="pf"))
    assert isinstance(sim.tracker, ParticleFilterTracker)
    runs = []
    for _ in range(2):
        sim.reset(3)
        policy = round_robin(sim.sensor)
        runs.append([sim.step(policy(sim.k + 1)).tracks.x.copy() for _ in range(cfg.n_scans)])
    np.testing.assert_array_equal(np.concatenate(runs[0]), np.concatenate(runs[1]))
    err = np.linalg.norm(runs[0][-1][0, 0, [0, 2]] - sim.truth.states[cfg.n_scans, 0, [0, 2]])
    assert err < 2.0
    env = UWBSchedulingEnv(cfg, tracker="pf", include_lookahead=True)
    obs, _ = env.reset(seed=4)
    for _ in range(3):
        obs, reward, *_ = env.step(env.action_space.sample())
    assert np.isfinite(obs).all() and np.isfinite(reward)
