"""Musicki's clutter-map refinement (``clutter_map_count = "unassociated"``): the tracker's clutter probabilities.

Known answers: a detection with target probability 0.7 adds 0.3 to its cell; one a track fully uses adds nothing; the
single-track IPDA closed form of P(clutter); weights in [0, 1]; the map is read before its scan updates it, and the
update comes after the tracker's step in ``Simulator.step``.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uwb_env import scenarios
from uwb_env.config import MotionModelConfig, SignalConfig, TrackerConfig
from uwb_env.detection.clutter_map import ClutterMap, cell_index, map_density, map_update
from uwb_env.rng import RngStreams
from uwb_env.scene import sample_truth
from uwb_env.sensing import ScanPlan
from uwb_env.sensing.records import Detections
from uwb_env.sensing.signal import SignalSensor
from uwb_env.sim import Simulator
from uwb_env.tracking.tracker import Tracker
from uwb_env.tracking.trackset import TrackSet

AREA = (0.0, 2.0, 0.0, 2.0)
N = 10.0
FLOOR = 0.05
UNASSOCIATED = {
    "sensing.fidelity": "signal",
    "sensing.signal.clutter_map": True,
    "sensing.signal.clutter_map_count": "unassociated",
}


# ----------------------------------------------------------------------------------------- the weighted update
def test_a_detection_with_target_probability_07_adds_03_to_its_cell():
    m = ClutterMap.over(AREA, 1.0, N, FLOOR)  # 2 x 2 cells of 1 m^2
    z = np.array([[0.5, 0.5], [1.5, 0.5], [1.5, 1.5]])
    beta = np.array([0.7, 0.0, 1.0])  # P(some track made it)
    m.update(z, 1.0 - beta)
    # a = 1 / N = 0.1: cell 0 gets 0.1 * 0.3, cell 1 0.1 * 1, cell 3 (fully used) nothing
    np.testing.assert_allclose(m.counts, [0.03, 0.1, 0.0, 0.0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(m.density(z), [max(0.03, FLOOR), 0.1, FLOOR], rtol=0, atol=1e-15)
    m.update(z[:1], np.array([0.3]))  # a second scan: (1 - a) 0.03 + a 0.3 = 0.057
    assert m.counts[0] == pytest.approx(0.9 * 0.03 + 0.1 * 0.3, abs=1e-15)
    assert m.counts[1] == pytest.approx(0.9 * 0.1, abs=1e-15)


def test_a_detection_fully_used_by_a_track_adds_nothing_only_forgetting():
    m = ClutterMap.over(AREA, 1.0, N, FLOOR)
    m.update(np.array([[0.5, 0.5]]))
    before = m.counts.copy()
    m.update(np.array([[0.5, 0.5], [1.5, 1.5]]), np.zeros(2))
    np.testing.assert_array_equal(m.counts, (1.0 - 1.0 / N) * before)


@settings(max_examples=80, deadline=None)
@given(
    beta=st.lists(st.floats(0.0, 1.0), min_size=0, max_size=12),
    seed=st.integers(0, 10_000),
)
def test_weighted_update_is_linear_and_stays_between_none_and_all(beta, seed):
    rng = np.random.default_rng(seed)
    b = np.array(beta, dtype=float)
    z = rng.uniform(0.0, 2.0, (b.size, 2))
    counts = rng.uniform(0.0, 1.0, 4)
    cells = cell_index(ClutterMap.over(AREA, 1.0, N, FLOOR).grid, z)
    w = 1.0 - b
    assert np.all((w >= 0.0) & (w <= 1.0))
    weighted = map_update(counts, cells, N, w)
    every = map_update(counts, cells, N)
    none = map_update(counts, cells, N, np.zeros(b.size))
    assert np.all(weighted >= none - 1e-15) and np.all(weighted <= every + 1e-15)
    # linear in the weights: counting 1 - beta = counting all less counting beta (the forgetting once)
    np.testing.assert_allclose(weighted, every - (map_update(counts, cells, N, b) - none), rtol=0, atol=1e-14)


# --------------------------------------------------------------------------------- the tracker's probabilities
def _one_model_tracker(pd: float = 0.9, fixed_existence: bool = False) -> Tracker:
    ncv = MotionModelConfig(name="ncv", kind="ncv", accel_noise_std_mps2=0.5)
    cfg = TrackerConfig(
        models=(ncv,),
        transition=((1.0,),),
        default_models=("ncv",),
        detection_probability=pd,
        fixed_existence=fixed_existence,
    )
    return Tracker(cfg, np.array([[0.0, 0.0]]), np.array([[0.2, 0.0], [-0.2, 0.0]]), np.array([-3.0, 3.0, 0.0, 6.0]))


def _set_tracks(tr: Tracker, xy: np.ndarray, pos_var: float, existence: np.ndarray) -> None:
    n = xy.shape[0]
    x = np.zeros((n, 1, 6))
    x[:, 0, 0], x[:, 0, 2] = xy[:, 0], xy[:, 1]
    P = np.broadcast_to(np.diag([pos_var, 1.0, pos_var, 1.0, 0.01, 0.01]), (n, 1, 6, 6)).copy()
    tr.tracks = TrackSet(
        ids=np.arange(n),
        confirmed=np.ones(n, bool),
        age=np.full(n, 5),
        born=np.zeros(n, np.int64),
        existence=np.asarray(existence, float),
        mu=np.ones((n, 1)),
        active=np.ones((n, 1), bool),
        x=x,
        P=P,
    )


def _positions(z: np.ndarray, r_var: float, rho: np.ndarray | float) -> Detections:
    m = z.shape[0]
    return Detections(
        tx=0,
        rx=-1,
        waveform=0,
        time_s=0.0,
        z=z,
        R=np.broadcast_to(r_var * np.eye(2), (m, 2, 2)).copy(),
        snr=np.zeros(m),
        origin=np.full(m, -1),
        measurement_names=("x", "y"),
        clutter_intensity=np.broadcast_to(np.asarray(rho, float), (m,)).copy(),
        expected_false_alarms=1.0,
    )


def test_single_track_single_detection_is_the_ipda_closed_form():
    tr = _one_model_tracker(pd=0.9)
    psi = 0.5
    _set_tracks(tr, np.array([[0.0, 2.0]]), 0.04, np.array([psi]))
    det = _positions(np.array([[0.1, 2.0], [2.5, 5.5]]), 0.01, 0.05)  # the second far outside the gate
    owned = tr.association_probabilities(det)
    # S = P_pos + R = 0.05 I; nu = (0.1, 0): d^2 = 0.2; lambda = N(nu; 0, S) / (P_G rho)
    pg, pd, rho = 0.99, 0.9, 0.05
    lam = math.exp(-0.5 * 0.2) / (2.0 * math.pi * 0.05) / (pg * rho)
    # IPDA: P(track exists and made z) = P_D P_G psi lambda / (1 - P_D P_G psi + P_D P_G psi lambda)
    closed = pd * pg * psi * lam / (1.0 - pd * pg * psi + pd * pg * psi * lam)
    assert closed == pytest.approx(0.97906, abs=1e-5)  # lambda = 58.19, P_D P_G psi = 0.4455
    assert owned[0] == pytest.approx(closed, rel=1e-12)
    assert owned[1] == 0.0  # gated out: clutter for sure


def test_two_tracks_share_one_detection_and_no_track_means_clutter():
    tr = _one_model_tracker()
    det = _positions(np.array([[0.0, 2.0]]), 0.01, 0.05)
    assert tr.association_probabilities(det).tolist() == [0.0]  # no track
    _set_tracks(tr, np.array([[-0.05, 2.0], [0.05, 2.0]]), 0.04, np.array([0.9, 0.9]))
    owned = tr.association_probabilities(det)
    one = _one_model_tracker()
    _set_tracks(one, np.array([[-0.05, 2.0]]), 0.04, np.array([0.9]))
    # LMIPDA: the other track as clutter lowers each claim, and the two together claim no more than one
    assert 0.0 < owned[0] <= 1.0
    assert owned[0] >= one.association_probabilities(det)[0] - 1e-12


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 100_000),
    n_tracks=st.integers(0, 4),
    n_dets=st.integers(0, 6),
    log_rho=st.floats(-4.0, 2.0),
    fixed=st.booleans(),
)
def test_clutter_probabilities_are_probabilities(seed, n_tracks, n_dets, log_rho, fixed):
    rng = np.random.default_rng(seed)
    tr = _one_model_tracker(pd=float(rng.uniform(0.05, 0.99)), fixed_existence=fixed)
    _set_tracks(tr, rng.uniform([-1.0, 1.0], [1.0, 3.0], (n_tracks, 2)), 0.05, rng.uniform(0.0, 1.0, n_tracks))
    z = rng.uniform([-1.0, 1.0], [1.0, 3.0], (n_dets, 2))
    det = _positions(z, 0.02, 10.0 ** rng.uniform(log_rho - 1.0, log_rho + 1.0, n_dets))
    owned = tr.association_probabilities(det)
    assert owned.shape == (n_dets,)
    # sum over tracks of P(exists, made it): >= 0; LMIPDA's per-track claims (each sees the others as clutter) can
    # sum past 1 where tracks overlap (1.05 at seed 4), hence the clip of clutter_probabilities
    assert np.all(owned >= 0.0) and np.all(owned <= n_tracks + 1e-12)
    tr.record_association()
    tr.step([det], 0.0, 1)
    (w,) = tr.clutter_probabilities()
    np.testing.assert_allclose(w, np.clip(1.0 - owned, 0.0, 1.0), rtol=0, atol=1e-12)
    assert np.all((w >= 0.0) & (w <= 1.0))


class _Probe(Tracker):
    """Records, per pair update, the association probabilities and the compiled kernel's taken flags."""

    def _update(self, det):
        owned = self.association_probabilities(det)
        taken = super()._update(det)
        self.seen.append((owned, taken))
        return taken


def test_association_probabilities_agree_with_the_compiled_update_on_through_wall_scans():
    cfg = scenarios.get("through-wall", **UNASSOCIATED)
    sim = Simulator(cfg)
    probe = _Probe.from_layout(cfg.tracker, sim.sensor.layout, sim._pd)
    probe.seen = []
    probe.record_association()
    sim.tracker, sim._clutter_probabilities = probe, probe.clutter_probabilities
    plan = ScanPlan.all_listening(0, sim.sensor.n_tx, sim.sensor.n_rx)
    sim.reset(43)
    while not sim.done:
        sim.step(plan)
    owned = np.concatenate([o for o, _ in probe.seen])
    taken = np.concatenate([t for _, t in probe.seen])
    assert owned.size > 100 and taken.sum() > 20
    clear = np.abs(owned - 0.5) > 1e-9
    # the kernel marks a detection taken when this same probability exceeds 1/2
    np.testing.assert_array_equal(taken[clear], owned[clear] > 0.5)


# ------------------------------------------------------------------------------------ the sensor and simulator
def _episode(sensor: SignalSensor, seed: int):
    rngs = RngStreams.from_seed(seed)
    return sensor.new_episode(sample_truth(sensor.cfg, rngs.truth, sensor.layout), rngs)


def test_sense_reads_the_map_and_leaves_the_update_to_after_tracking():
    s = SignalSensor(scenarios.get("through-wall", **UNASSOCIATED))
    assert s.needs_association
    plan = ScanPlan.all_listening(0, s.n_tx, s.n_rx)
    ep = _episode(s, 43)
    cmap = ep.clutter_map
    assert cmap is not None
    for k in range(1, 30):
        before = cmap.counts.copy()
        (det,) = s.sense(ep, k, plan, 0.0)
        np.testing.assert_array_equal(cmap.counts, before)  # sense reads only
        assert cmap.scans == k - 1 and ep.map_pending is not None
        w = np.linspace(0.0, 1.0, len(det))
        s.after_tracking(ep, (det,), (w,))
        np.testing.assert_array_equal(cmap.counts, map_update(before, cell_index(cmap.grid, det.z), 50.0, w))
        assert cmap.scans == k and ep.map_pending is None
    s.after_tracking(ep, (), ())  # nothing pending: nothing happens
    assert cmap.scans == 29
    (det,) = s.sense(ep, 30, plan, 0.0)
    before = cmap.counts.copy()
    s.after_tracking(ep, (), ())  # the tracker got nothing (receivers warming up): no track used them, weight 1
    np.testing.assert_array_equal(cmap.counts, map_update(before, cell_index(cmap.grid, det.z), 50.0))


def test_simulator_updates_the_map_after_the_tracker_with_its_clutter_probabilities():
    cfg = scenarios.get("through-wall", **UNASSOCIATED)
    sim = Simulator(cfg)
    assert sim.tracker._record
    plan = ScanPlan.all_listening(0, sim.sensor.n_tx, sim.sensor.n_rx)
    sim.reset(47)
    floor = cfg.sensing.signal.false_position_density_per_m2
    partial = 0
    while not sim.done:
        cmap = sim.episode.clutter_map
        before = cmap.counts.copy()
        res = sim.step(plan)
        (det,) = res.detections
        cells = cell_index(cmap.grid, det.z)
        # read before this scan's update ...
        np.testing.assert_array_equal(det.clutter_intensity, map_density(before, cells, cmap.grid.cell_area_m2, floor))
        # ... updated after the tracker's step with 1 - P(some track made it)
        (w,) = sim.tracker.clutter_probabilities()
        np.testing.assert_array_equal(cmap.counts, map_update(before, cells, 50.0, w))
        partial += int(np.sum((w > 0.01) & (w < 0.99)))
    assert partial > 20  # the weights are not just 0 / 1


def test_mode_off_changes_nothing_in_the_simulator():
    for over in ({}, {"sensing.signal.clutter_map": True}, {"sensing.signal.clutter_map_count": "all"}):
        sim = Simulator(scenarios.get("through-wall", **{"sensing.fidelity": "signal", **over}))
        assert not sim._feedback and not sim.tracker._record and sim._clutter_probabilities is None
    with pytest.raises(RuntimeError, match="record_association"):
        sim.tracker.clutter_probabilities()
    # the parametric sensor has no such hook
    assert not Simulator(scenarios.get("through-wall"))._feedback


def test_bad_inputs_name_the_field():
    with pytest.raises(ValueError, match="clutter_map_count"):
        SignalConfig(clutter_map_count="unused")
    cfg = scenarios.get("through-wall", **UNASSOCIATED)
    with pytest.raises(ValueError, match="unassociated"):
        Simulator(cfg, tracker=dataclasses.replace(cfg.tracker, kind="pf"))
    s = SignalSensor(cfg)
    ep = _episode(s, 1)
    plan = ScanPlan.all_listening(0, s.n_tx, s.n_rx)
    (det,) = s.sense(ep, 1, plan, 0.0)
    with pytest.raises(ValueError, match="records"):
        s.after_tracking(ep, (det,), ())
    (det,) = s.sense(ep, 2, plan, 0.0)
    if len(det):
        with pytest.raises(ValueError, match=r"\[0, 1\]"):
            s.after_tracking(ep, (det,), (np.full(len(det), 1.5),))
