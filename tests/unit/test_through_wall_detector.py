"""The through-wall parametric detector: the interval ToA test's false-alarm probability and the parametric-only
Swerling case (``SensingConfig.detection_swerling``), which leaves the signal path unchanged.

Through-wall's own detector takes the persons' Swerling III (``detection_swerling`` None, ThroughWall-v4: the fast
exponential background sums each echo with its displaced predecessors, two looks; v2-v3 overrode it with Swerling I);
the override is tested with Swerling I."""

from __future__ import annotations

import math

import numpy as np
import pytest

from uwb_env import scenarios
from uwb_env.channel.rcs import swerling_weights
from uwb_env.config import SensingConfig
from uwb_env.rng import RngStreams
from uwb_env.scenarios.through_wall import THROUGH_WALL_PFA, interval_test_pfa
from uwb_env.scene import sample_truth
from uwb_env.sensing import ParametricSensor, ScanPlan


def test_interval_test_pfa_is_the_binomial_tail_of_the_chains_window():
    """P(Bin(15, 0.01) >= 4) = 1.25e-5 (the hand value), as the sum of the binomial terms."""
    hand = sum(math.comb(15, k) * 0.01**k * 0.99 ** (15 - k) for k in range(4, 16))
    assert interval_test_pfa(15, 4, 1e-2) == pytest.approx(hand, rel=1e-12)
    assert interval_test_pfa(15, 4, 1e-2) == pytest.approx(1.25e-5, rel=1e-3)
    assert interval_test_pfa(15, 1, 1e-2) == pytest.approx(1.0 - 0.99**15, rel=1e-12)  # one sample is enough
    assert interval_test_pfa(1, 1, 1e-2) == pytest.approx(1e-2, rel=1e-12)  # W_p = 1: the per-sample test


def test_through_wall_parametric_detector_is_the_interval_tests_with_the_persons_swerling_iii():
    cfg = scenarios.get("through-wall")
    sig = cfg.sensing.signal
    assert (sig.toa_interval_samples, sig.toa_interval_threshold, sig.cfar_pfa) == (15, 4, 1e-2)
    assert cfg.sensing.false_alarm_probability == THROUGH_WALL_PFA
    assert THROUGH_WALL_PFA == interval_test_pfa(15, 4, 1e-2)
    assert cfg.sensing.detection_swerling is None  # the persons' own case
    assert all(t.swerling == 3 for t in cfg.targets)  # also the signal path's scattering centres'
    s = ParametricSensor(cfg)
    np.testing.assert_array_equal(s._detect_swerling_w, swerling_weights(np.array([3, 3])))


def test_detection_swerling_is_validated_and_off_by_default():
    assert SensingConfig().detection_swerling is None
    with pytest.raises(ValueError, match=r"SensingConfig.detection_swerling = 2"):
        SensingConfig(detection_swerling=2)
    for name in ("indoor-rsn", "urban-intersection", "indoor-monostatic"):
        s = ParametricSensor(scenarios.get(name))
        assert s._detect_swerling_w is s._swerling_w  # every other scenario: each target's own case


def test_the_parametric_detection_draws_swerling_i_and_the_mti_keeps_the_targets_case():
    """The override changes only the parametric RCS factors (exponential, unit mean: var 1 against III's 1/2); the
    sensor's ``swerling`` (read by the signal path) and the MTI's retained fraction keep the persons' Swerling III."""
    cfg = scenarios.get("through-wall", **{"sensing.detection_swerling": 1})
    own = scenarios.get("through-wall")
    s, o = ParametricSensor(cfg), ParametricSensor(own)
    np.testing.assert_array_equal(s.swerling, [3, 3])
    np.testing.assert_array_equal(s._detect_swerling_w, swerling_weights(np.array([1, 1])))
    np.testing.assert_array_equal(o._detect_swerling_w, swerling_weights(np.array([3, 3])))
    truth = sample_truth(cfg, RngStreams.from_seed(0).truth, s.layout)
    np.testing.assert_array_equal(s.mti_history(s._cached_geometry(truth)), o.mti_history(o._cached_geometry(truth)))
    # the detections differ, the draws' streams do not (same clutter: the origin -1 rows are the same)
    plan = ScanPlan.all_listening(0, s.n_tx, s.n_rx)
    ep_s, ep_o = s.new_episode(truth, RngStreams.from_seed(0)), o.new_episode(truth, RngStreams.from_seed(0))
    hits_s = hits_o = 0
    for k in range(1, cfg.n_scans + 1):
        ds, do = s.sense(ep_s, k, plan, 0.0), o.sense(ep_o, k, plan, 0.0)
        for a, b in zip(ds, do, strict=True):
            np.testing.assert_array_equal(a.z[a.origin < 0], b.z[b.origin < 0])
            hits_s += int(np.sum(a.origin >= 0))
            hits_o += int(np.sum(b.origin >= 0))
    assert hits_s != hits_o


def test_the_signal_path_is_unchanged_by_the_parametric_swerling_case():
    """The chain's detections of a few scans, bit-identical with and without ``detection_swerling``."""
    from uwb_env.sensing.signal import SignalSensor

    out = []
    for ds in (1, None):
        cfg = scenarios.get("through-wall", **{"sensing.fidelity": "signal", "sensing.detection_swerling": ds})
        s = SignalSensor(cfg)
        np.testing.assert_array_equal(s.model.swerling, [3, 3])
        rngs = RngStreams.from_seed(1)
        ep = s.new_episode(sample_truth(cfg, rngs.truth, s.layout), rngs)
        plan = ScanPlan.all_listening(0, s.n_tx, s.n_rx)
        rows = []
        for k in range(1, 6):
            scans, active = s.synthesise(ep, k, plan)
            rows.append((scans, s.detect(ep, k, plan, scans, active).ranges))
        out.append(rows)
    for (a, ra), (b, rb) in zip(*out, strict=True):
        np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(ra, rb)
