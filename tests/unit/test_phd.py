"""Seed 000's particle PHD tracker (``uwb_env.tracking.phd``): numbers, not smoke.

- the PHD update conserves mass as the equations say, and the particle PHD's expected number of targets matches a
  linear-Gaussian GM-PHD with the same (measurement-driven) birth within Monte Carlo error;
- EM recovers the components of a known mixture;
- the association / state machine on scripted estimates;
- determinism under the tracker's generator;
- one run on indoor-rsn's parametric detections (ranges fused by the network chain) tracks the person.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from uwb_env import scenarios
from uwb_env.config import PhdConfig, TrackerConfig
from uwb_env.rng import RngStreams
from uwb_env.scene.motion_models import model_transition
from uwb_env.scene.truth import sample_truth
from uwb_env.sensing.protocol import make_sensor
from uwb_env.sensing.records import Detections, ScanPlan
from uwb_env.sim import at_least
from uwb_env.tracking.expectation import gaussian_expected_update, reduction_model
from uwb_env.tracking.phd import (
    CONFIRMED,
    SILENT,
    UNCONFIRMED,
    PhdTracker,
    em_mixture,
    phd_update,
    systematic_resample,
)
from uwb_env.tracking.protocol import MultiTargetTracker, Prediction
from uwb_env.tracking.registry import make_tracker

AREA = np.array([0.0, 100.0, 0.0, 100.0])


def positions(z: np.ndarray, R: np.ndarray, kappa: float, time_s: float = 0.0) -> Detections:
    """One scan's fused position measurements (as the signal path's network chain hands them)."""
    n = z.shape[0]
    return Detections(
        tx=0,
        rx=-1,
        waveform=0,
        time_s=time_s,
        z=np.asarray(z, float).reshape(n, 2),
        R=np.asarray(R, float).reshape(n, 2, 2),
        snr=np.ones(n),
        origin=np.full(n, -1),
        measurement_names=("x", "y"),
        clutter_intensity=np.full(n, kappa),
        expected_false_alarms=0.0,
    )


def tracker(phd: PhdConfig, pd: float = 0.9) -> PhdTracker:
    cfg = TrackerConfig(kind="phd", phd=phd, detection_probability=pd)
    return PhdTracker(cfg, np.zeros((1, 2)), np.zeros((1, 2)), AREA)


# ------------------------------------------------------------------------------------------------------- update
def test_update_conserves_the_phd_mass() -> None:
    """sum w' + sum newborn = sum (1 - Pd) w + sum_z (C(z) + nu_b) / L(z) (seed eq. 33 plus the birth)."""
    rng = np.random.default_rng(1)
    pos, w = rng.normal(5.0, 1.0, (500, 2)), rng.random(500) / 250
    pd = rng.uniform(0.5, 0.95, 500)
    z = rng.normal(5.0, 1.0, (4, 2))
    R = np.array([[[0.04, 0.01], [0.01, 0.09]]] * 4)
    kappa = np.array([0.01, 0.02, 0.05, 0.1])
    w1, newborn, held = phd_update(pos, w, pd, z, R, kappa, 0.03)
    # the direct sum of the seed's equation, measurement by measurement
    Rinv = np.linalg.inv(R[0])
    g = np.array([[math.exp(-0.5 * (zz - p) @ Rinv @ (zz - p)) for zz in z] for p in pos]) / (
        2 * math.pi * math.sqrt(np.linalg.det(R[0]))
    )
    C = (pd * w) @ g
    L = kappa + C + 0.03
    np.testing.assert_allclose(w1, w * (1 - pd) + pd * w * (g @ (1 / L)), rtol=1e-12)
    np.testing.assert_allclose(newborn, 0.03 / L, rtol=1e-12)
    np.testing.assert_allclose(held, C / L, rtol=1e-12)
    assert w1.sum() + newborn.sum() == pytest.approx(((1 - pd) * w).sum() + ((C + 0.03) / L).sum(), rel=1e-12)


def test_systematic_resampling_counts() -> None:
    """Each particle is copied floor(n w_i) or ceil(n w_i) times (systematic resampling's defining property)."""
    w = np.array([0.5, 0.25, 0.125, 0.0625, 0.0625])
    for seed in range(20):
        counts = np.bincount(systematic_resample(w, 37, np.random.default_rng(seed)), minlength=5)
        assert counts.sum() == 37
        assert np.all(counts >= np.floor(37 * w)) and np.all(counts <= np.ceil(37 * w))


# --------------------------------------------------------------------------------------------- GM-PHD reference
class GmPhd:
    """Linear-Gaussian GM-PHD (Vo and Ma 2006) with the tracker's models: NCV, constant Pd, p_S and kappa, position
    measurements, and the measurement-driven birth of Ristic et al. (newborn mass nu_b / L(z) in N([z, 0], ...))."""

    def __init__(self, phd: PhdConfig, pd: float) -> None:
        self.phd, self.pd = phd, pd
        self.w, self.m, self.P = np.zeros(0), np.zeros((0, 4)), np.zeros((0, 4, 4))
        self.H = np.zeros((2, 4))
        self.H[0, 0] = self.H[1, 2] = 1.0

    def predict(self, dt: float) -> None:
        F, G = model_transition("ncv", dt)
        F, G = F[:4, :4], G[:4]
        Q = self.phd.accel_noise_std_mps2**2 * G @ G.T
        self.w = self.w * self.phd.survival_probability
        self.m = self.m @ F.T
        self.P = F @ self.P @ F.T + Q

    def update(self, z: np.ndarray, R: np.ndarray, kappa: float) -> None:
        H, pd, nu_b = self.H, self.pd, self.phd.birth_intensity_per_m2
        ws, ms, Ps = [self.w * (1 - pd)], [self.m], [self.P]
        S = H @ self.P @ H.T + R  # (n, 2, 2)
        K = self.P @ H.T @ np.linalg.inv(S)
        Pu = self.P - K @ H @ self.P
        for zz in z:
            nu = zz - self.m @ H.T
            q = np.exp(-0.5 * np.einsum("ni,ni->n", nu, np.linalg.solve(S, nu[:, :, None])[:, :, 0])) / (
                2 * math.pi * np.sqrt(np.linalg.det(S))
            )
            L = kappa + (pd * self.w * q).sum() + nu_b
            ws += [pd * self.w * q / L, np.array([nu_b / L])]
            ms += [self.m + np.einsum("nij,nj->ni", K, nu), np.array([[zz[0], 0.0, zz[1], 0.0]])]
            Pb = np.zeros((1, 4, 4))
            Pb[0][np.ix_([0, 2], [0, 2])] = R
            Pb[0, 1, 1] = Pb[0, 3, 3] = self.phd.birth_velocity_std_mps**2
            Ps += [Pu, Pb]
        self.w, self.m, self.P = np.concatenate(ws), np.concatenate(ms), np.concatenate(Ps)


def test_particle_phd_matches_gm_phd_on_a_linear_case() -> None:
    """Expected number of targets per scan: particle PHD (mean over seeds) = GM-PHD within 4 standard errors.

    Measurement noise (0.3 m) and clutter / birth intensities are chosen so that C(z), kappa and nu_b are of the
    same order and every mass is a non-trivial fraction (a test with masses near 0 or 1 would test nothing).
    """
    phd = PhdConfig(particles_per_target=1000, particles_per_birth=500, birth_intensity_per_m2=0.3, pd_grid_m=0.0)
    pd, kappa, dt = 0.8, 0.5, 0.1
    R = np.array([[0.09, 0.02], [0.02, 0.09]])
    truth = np.array([50.0, 50.0]) + np.arange(6)[:, None] * dt * np.array([1.0, 0.5])
    noise = np.random.default_rng(7)
    scans = []
    for k, p in enumerate(truth):
        z = [p + noise.multivariate_normal(np.zeros(2), R)] if k != 3 else []  # a missed detection at scan 3
        z.append(noise.uniform(45.0, 55.0, 2))  # one false alarm per scan
        scans.append(np.array(z))
    gm = GmPhd(phd, pd)
    gm_mass = []
    for k, z in enumerate(scans):
        if k:
            gm.predict(dt)
        gm.update(z, R, kappa)
        gm_mass.append(gm.w.sum())
    runs = []
    for seed in range(12):
        trk = tracker(phd, pd)
        trk.reset(np.random.default_rng(seed))
        masses = []
        for k, z in enumerate(scans):
            trk.step([positions(z, np.broadcast_to(R, (len(z), 2, 2)), kappa)], k * dt, k)
            assert trk.expected_targets == pytest.approx(trk.weights.sum(), rel=1e-12)
            masses.append(trk.expected_targets)
        runs.append(masses)
    runs = np.array(runs)
    mean, se = runs.mean(axis=0), runs.std(axis=0, ddof=1) / math.sqrt(runs.shape[0])
    gm_mass = np.array(gm_mass)
    assert np.all((gm_mass > 0.5) & (gm_mass < 3.0))  # non-trivial masses
    assert np.all(se < 0.02)  # the Monte Carlo error is small enough for the comparison to mean something
    assert np.all(np.abs(mean - gm_mass) <= 4.0 * se + 5e-4), (mean, gm_mass, se)


# ------------------------------------------------------------------------------------------------------------ EM
def test_em_recovers_known_mixture_components() -> None:
    """Weighted particles of a two-component 4-D mixture: means within 4 standard errors, masses within 4 SE."""
    rng = np.random.default_rng(3)
    mu = np.array([[2.0, 1.0, 3.0, 0.0], [4.0, -1.0, 3.5, 0.5]])
    cov = np.array([np.diag([0.04, 0.25, 0.09, 0.25]), np.diag([0.09, 0.16, 0.04, 0.36])])
    cov[0, 0, 2] = cov[0, 2, 0] = 0.02
    n = np.array([3000, 1500])
    X = np.concatenate([rng.multivariate_normal(mu[k], cov[k], n[k]) for k in range(2)])
    total = 1.7  # a PHD mass: EM's masses must add up to it
    w = np.full(X.shape[0], total / X.shape[0])
    seeds = mu + np.array([0.3, 0.0, -0.3, 0.0])  # 1-1.5 std off in position, velocity unknown
    seeds[:, [1, 3]] = 0.0
    mass, means, covs = em_mixture(X, w, seeds, (0, 2), 50, 1e-10)
    order = np.argsort(means[:, 0])
    mass, means, covs = mass[order], means[order], covs[order]
    assert mass.sum() == pytest.approx(total, rel=1e-9)
    frac = n / n.sum()
    se_frac = np.sqrt(frac * (1 - frac) / n.sum())
    np.testing.assert_array_less(np.abs(mass / total - frac), 4 * se_frac)
    se_mean = np.sqrt(np.diagonal(cov, axis1=1, axis2=2) / n[:, None])
    np.testing.assert_array_less(np.abs(means - mu), 4 * se_mean)
    np.testing.assert_allclose(covs, cov, atol=0.02)


# ------------------------------------------------------------------------------------------------- state machine
def estimates(*points: tuple[float, float], mass: float = 1.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    x = np.zeros((len(points), 6))
    x[:, [0, 2]] = np.array(points, float).reshape(-1, 2)
    P = np.broadcast_to(np.diag([0.01, 0.1, 0.01, 0.1, 1e-4, 1e-4]), (len(points), 6, 6)).copy()
    return np.full(len(points), mass), x, P


def test_state_machine_on_scripted_estimates() -> None:
    """Unconfirmed -> confirmed after 3 updated scans; confirmed -> silent; silent -> confirmed on a valid
    association; silent -> dead after silent_max_scans misses; unconfirmed -> dead at its first miss."""
    trk = tracker(PhdConfig(confirm_updates=3, silent_max_scans=2))
    script = [
        ([(10, 10)], [UNCONFIRMED]),
        ([(10.1, 10)], [UNCONFIRMED]),
        ([(10.2, 10), (30, 30)], [CONFIRMED, UNCONFIRMED]),  # confirmed on its 3rd updated scan; a new track
        ([], [SILENT]),  # the new one dies without an update; the confirmed one turns silent
        ([], [SILENT]),
        ([(10.3, 10.1)], [CONFIRMED]),  # back to confirmed, same id
        ([], [SILENT]),
        ([], [SILENT]),
        ([], []),  # third miss > silent_max_scans = 2: dead
    ]
    first_id = None
    for k, (points, want) in enumerate(script):
        t = trk._associate(*estimates(*points, mass=0.8), k)
        assert trk.status.tolist() == want, (k, trk.status)
        assert t.confirmed.tolist() == [s != UNCONFIRMED for s in want]
        if want:
            first_id = t.ids[0] if first_id is None else first_id
            assert t.ids[0] == first_id  # one labelled track throughout
            assert t.mu.shape == (len(t), 1) and np.all(t.mu == 1.0) and np.all(t.active)
    assert trk.tracks.existence.size == 0


def test_association_gates_pairs_when_the_hypothesis_is_too_costly() -> None:
    """Minimum-cost hypothesis over max_hypothesis_cost_m: each pair is kept only inside its chi-square gate."""
    trk = tracker(PhdConfig(confirm_updates=1, max_hypothesis_cost_m=1.0))
    trk._associate(*estimates((10, 10), (20, 20)), 0)
    ids = trk.tracks.ids.copy()
    # near pair (0.1 m) plus a far one (3 m): cost 3.1 m > 1 m; the far estimate starts a new track
    t = trk._associate(*estimates((10.1, 10), (23, 20)), 1)
    assert t.ids[0] == ids[0] and trk.status[0] == CONFIRMED
    assert t.ids[1] == ids[1] and trk.status[1] == SILENT
    assert t.ids[2] not in ids and t.x[2, 0, 0] == 23.0
    # both within the cost: valid as a whole
    t = trk._associate(*estimates((10.2, 10), (20.3, 20), (23.1, 20)), 2)
    assert trk.status.tolist() == [CONFIRMED, CONFIRMED, CONFIRMED] and len(t) == 3


# ----------------------------------------------------------------------------------------------- protocol, rng
def scripted_scans(n: int = 12) -> list[list[Detections]]:
    noise = np.random.default_rng(5)
    R = np.broadcast_to(np.diag([0.02, 0.02]), (3, 2, 2))
    out = []
    for k in range(n):
        p = np.array([20.0 + 1.5 * 0.1 * k, 30.0])
        z = np.stack([p + noise.normal(0, 0.1, 2), *noise.uniform(10, 40, (2, 2))])
        out.append([positions(z, R, 0.002, 0.1 * k)])
    return out


def run(trk: PhdTracker, seed: int | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    trk.reset(None if seed is None else np.random.default_rng(seed))
    for k, dets in enumerate(scripted_scans()):
        t = trk.step(dets, 0.1 * k, k)
    return trk.particles.copy(), t.x.copy(), t.ids.copy()


def test_determinism_under_the_generator() -> None:
    trk = tracker(PhdConfig())
    a, b = run(trk, 11), run(trk, 11)
    for u, v in zip(a, b, strict=True):
        np.testing.assert_array_equal(u, v)
    c = run(trk, 12)
    assert a[0].shape != c[0].shape or not np.array_equal(a[0], c[0])
    d, e = run(trk, None), run(trk, None)  # reset(None): default_rng(0)
    np.testing.assert_array_equal(d[0], e[0])
    np.testing.assert_array_equal(d[0], run(trk, 0)[0])


def test_protocol_and_lookahead_hooks() -> None:
    layout = make_sensor(scenarios.get("indoor-rsn")).layout
    cfg = TrackerConfig(kind="phd")
    trk = make_tracker(cfg, layout)
    assert isinstance(trk, PhdTracker) and isinstance(trk, MultiTargetTracker)
    assert (trk.kind, trk.filter, trk.model_names) == ("phd", "ukf", ("ncv",))
    assert trk.scored_prediction(0.1, 1) is None
    for k, dets in enumerate(scripted_scans(6)):
        dets = [dataclasses.replace(d, z=d.z - np.array([15.0, 27.0])) for d in dets]  # into the room
        trk.step(dets, 0.1 * k, k)
    t = trk.tracks
    assert t.confirmed.any()
    pred = trk.scored_prediction(0.6, 6)
    assert isinstance(pred, Prediction)
    keep = t.confirmed
    F, _ = model_transition("ncv", 0.1)
    np.testing.assert_allclose(pred.x, t.x[keep, 0] @ F.T)
    assert pred.P.shape == (keep.sum(), 6, 6) and pred.mu.shape == (keep.sum(), 1) and pred.active.tolist() == [True]
    assert np.all(np.linalg.eigvalsh(pred.P) > 0)
    again = trk.scored_prediction(0.6, 6)
    np.testing.assert_array_equal(again.x, pred.x)  # pure
    two = trk.predict_gaussians(pred, 0.1, 7)
    np.testing.assert_allclose(two.x, pred.x @ F.T)
    assert np.all(np.diagonal(two.P, axis1=1, axis2=2) >= np.diagonal(pred.P, axis1=1, axis2=2) - 1e-12)
    # expected update: the UKF Gaussian update of expectation.gaussian_expected_update
    N, A = pred.x.shape[0], 3
    names = ("bistatic_range",)
    R = np.full((A, N, 1, 1), 0.01)
    pd = np.full((A, N), 0.9)
    red = reduction_model(1.0, 1, cfg.gate_probability)
    args = (pred.x, pred.P, names, layout.tx_pos[0], layout.rx_pos[2], R, pd, red, np.zeros((A, N)), np.full(A, np.inf))
    Pa = trk.expected_update(np.broadcast_to(pred.P, (A, N, 6, 6)).copy(), *args)
    ref = gaussian_expected_update("ukf", np.broadcast_to(pred.P, (A, N, 6, 6)).copy(), *args)
    np.testing.assert_array_equal(Pa, ref)
    assert np.all(np.trace(Pa, axis1=2, axis2=3) < np.trace(pred.P, axis1=1, axis2=2))


# --------------------------------------------------------------------------------------------------- indoor-rsn
def test_tracks_the_person_on_indoor_rsn() -> None:
    """Parametric detections (bistatic ranges per pair) fused by the network chain: after the first confirmation,
    the median distance from the person to the nearest confirmed track is below 0.6 m (seed 000: RMSE 36 cm)."""
    cfg = scenarios.get("indoor-rsn")
    sensor = make_sensor(cfg)
    lay, tc = sensor.layout, dataclasses.replace(cfg.tracker, kind="phd")
    plan = ScanPlan.all_listening(0, sensor.n_tx, sensor.n_rx)

    def pd_model(tx: int, rx: int, pos: np.ndarray) -> np.ndarray:  # the simulator's rx = -1 rule
        per_pair = np.array(
            [
                sensor.detection_probability_at(t, r, pos, 0, tc.assumed_rcs_m2, tc.assumed_swerling)
                for t, r in sensor.pairs.tolist()
            ]
        )
        return np.minimum(at_least(per_pair, cfg.sensing.signal.nu), tc.max_detection_probability)

    trk = make_tracker(tc, lay, pd_model)
    for seed in (0, 1):
        rngs = RngStreams.from_seed(seed)
        truth = sample_truth(cfg, rngs.truth, lay)
        episode = sensor.new_episode(truth, rngs)
        trk.reset(rngs.tracker)
        errors: list[float] = []
        for k in range(1, cfg.n_scans + 1):
            dets = sensor.sense(episode, k, plan, k * cfg.sensing.scan_period_s)
            assert dets[0].measurement_names == ("bistatic_range",)
            t = trk.step(dets, k * cfg.sensing.scan_period_s, k)
            if errors or t.confirmed.any():
                p = truth.states[k][0, [0, 2]]
                d = np.linalg.norm(t.x[t.confirmed, 0][:, [0, 2]] - p, axis=-1)
                errors.append(float(d.min()) if d.size else math.inf)
        assert len(errors) >= 50  # confirmed within the first 11 scans
        assert np.median(errors) < 0.6, (seed, np.median(errors))
        assert np.mean(np.array(errors) < 0.6) > 0.8


def test_silent_tracks_are_predicted_with_the_ncv_model() -> None:
    """A confirmed track without detections turns silent and its head moves on by F (the NCV model)."""
    trk = tracker(PhdConfig(confirm_updates=3, silent_max_scans=5), pd=0.95)
    trk.reset(np.random.default_rng(2))
    R = np.diag([0.01, 0.01])[None]
    for k in range(10):
        trk.step([positions(np.array([[20.0 + 0.15 * k, 30.0]]), R, 1e-3)], 0.1 * k, k)
    assert trk.status.tolist() == [CONFIRMED]
    x0, P0 = trk.tracks.x[0, 0].copy(), trk.tracks.P[0, 0].copy()
    assert x0[1] == pytest.approx(1.5, abs=0.1)  # the velocity is estimated
    F, _ = model_transition("ncv", 0.1)
    for k in (10, 11):
        trk.step([positions(np.zeros((0, 2)), np.zeros((0, 2, 2)), 1e-3)], 0.1 * k, k)
        x0, P0 = F @ x0, F @ P0 @ F.T
        assert trk.status.tolist() == [SILENT] and trk.tracks.confirmed.tolist() == [True]
        np.testing.assert_allclose(trk.tracks.x[0, 0], x0, atol=1e-12)
        assert np.all(np.diagonal(trk.tracks.P[0, 0]) >= np.diagonal(P0) - 1e-12)  # F P F^T + Q
    assert trk.tracks.existence[0] < 1.0


def test_pd_model_is_the_fused_measurement_pd_on_a_grid() -> None:
    """P_D is asked of ``pd_model(0, -1, cells)`` once per occupied grid cell and matches it to the grid's
    resolution (a plane of slopes 0.01 and 0.005 per metre: error <= (0.01 + 0.005) x half a cell)."""
    calls = []

    def f(pos: np.ndarray) -> np.ndarray:
        return 0.9 - 0.01 * pos[:, 0] + 0.005 * pos[:, 1]

    def pd_model(tx: int, rx: int, pos: np.ndarray) -> np.ndarray:
        calls.append((tx, rx, pos.shape[0]))
        return f(pos)

    cfg = TrackerConfig(kind="phd", phd=PhdConfig(pd_grid_m=0.25))
    trk = PhdTracker(cfg, np.zeros((1, 2)), np.zeros((1, 2)), AREA, pd_model)
    pos = np.random.default_rng(4).normal([20.0, 30.0], 0.5, (3000, 2))
    pd = trk._pd(pos)
    assert len(calls) == 1 and calls[0][:2] == (0, -1) and calls[0][2] < 200
    np.testing.assert_allclose(pd, f(pos), atol=(0.01 + 0.005) * 0.125 + 1e-12)
    exact = PhdTracker(
        TrackerConfig(kind="phd", phd=PhdConfig(pd_grid_m=0.0)), np.zeros((1, 2)), np.zeros((1, 2)), AREA, pd_model
    )
    np.testing.assert_allclose(exact._pd(pos), f(pos), rtol=1e-15)


def test_simulator_and_lookahead_run_the_phd_through_the_registry() -> None:
    """``TrackerConfig.kind = "phd"``: the simulator builds the PHD (registry), the person is held without a break
    from its confirmation on (5 consecutive updates after the first peak; round-robin's weak waveform misses some
    scans, so within the first 12 scans),
    and the lookahead scores plans with its Gaussians (fewer listening receivers: a larger expected trace)."""
    from uwb_env.lookahead import lookahead_costs
    from uwb_env.sim import Simulator, round_robin, run_episode

    sim = Simulator(scenarios.get("indoor-rsn", **{"tracker.kind": "phd"}))
    assert isinstance(sim.tracker, PhdTracker)
    acc = run_episode(sim, 3, round_robin(sim.sensor))
    first = next(k for k, e in enumerate(acc.errors) if np.isfinite(e).all())
    assert 5 <= first < 12  # scan index first + 1: not before the fifth update
    errors = np.concatenate(acc.errors[first:])
    assert np.all(np.isfinite(errors)) and np.median(errors) < 0.1
    plans = [ScanPlan.all_listening(0, 1, 6), ScanPlan(np.zeros(1, np.int64), np.array([1, 0, 1, 0, 1, 0], bool))]
    costs = lookahead_costs(sim.sensor, sim.tracker, plans, sim.k * 0.1 + 0.1, sim.k + 1)
    assert np.all(costs > 0) and costs[1] > costs[0]


def test_occupied_cells_hand_each_position_its_cell_centre() -> None:
    """tracking.pd_grid: the centre of each position's cell, once per occupied cell."""
    from uwb_env.tracking.pd_grid import occupied_cells

    pos = np.array([[0.10, 0.10], [0.20, 0.05], [0.30, 0.10], [-0.10, 0.60], [0.24, 0.24]])
    centres, inverse = occupied_cells(pos, np.zeros(2), 0.25)
    np.testing.assert_allclose(centres[inverse], [[0.125, 0.125], [0.125, 0.125], [0.375, 0.125], [-0.125, 0.625],
                                                  [0.125, 0.125]])  # fmt: skip
    assert centres.shape == (3, 2)
    assert np.all(np.abs(centres[inverse] - pos) <= 0.125 + 1e-12)
