"""Per-waveform false-alarm factors (ImpulseWaveformConfig.false_alarm_factor) in the parametric sensor.

A chain whose false detections are residues of the static background grows them with the waveform's energy
(through-wall, seed 001's chain): the parametric model then draws each waveform's false alarms at the scenario's
density times the waveform's factor, with common random numbers across plans (drawn at the largest rate, thinned),
and reports the same factor in the records' clutter intensity and expected false alarms.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from uwb_env import scenarios
from uwb_env.config import ImpulseWaveformConfig
from uwb_env.rng import RngStreams
from uwb_env.scene.truth import sample_truth
from uwb_env.sensing import ScanPlan
from uwb_env.sensing.parametric import ParametricSensor, false_alarm_scale

FACTORS = (1.0, 0.5, 2.0)


def _scaled_through_wall():
    cfg = scenarios.get("through-wall", **{"sensing.clutter.density_per_m2": 0.2})
    waveforms = tuple(dataclasses.replace(w, false_alarm_factor=f) for w, f in zip(cfg.waveforms, FACTORS, strict=True))
    return dataclasses.replace(cfg, waveforms=waveforms)


@pytest.fixture(scope="module")
def episode():
    cfg = _scaled_through_wall()
    sensor = ParametricSensor(cfg)
    rngs = RngStreams.from_seed(3)
    return sensor, sensor.new_episode(sample_truth(cfg, rngs.truth, sensor.layout), rngs)


def test_the_scale_is_the_factor_times_the_bandwidth_rule():
    np.testing.assert_array_equal(false_alarm_scale(_scaled_through_wall()), FACTORS)
    wide = scenarios.get("urban-intersection-wideband")
    np.testing.assert_array_equal(false_alarm_scale(wide), [1, 1, 1, 1, 1, 1, 4, 4])  # chirps: the bandwidth rule


def test_bad_factor_is_refused_naming_the_field():
    for bad in (0.0, -1.0, 101.0):
        with pytest.raises(ValueError, match="false_alarm_factor"):
            ImpulseWaveformConfig("w", center_freq_hz=1e9, bandwidth_hz=1e9, false_alarm_factor=bad)


def test_each_waveform_draws_its_factor_of_false_alarms_thinned_from_one_draw(episode):
    sensor, ep = episode
    counts = {}
    for w, f in enumerate(FACTORS):
        plan = ScanPlan.all_listening(w, sensor.n_tx, sensor.n_rx)
        counts[w] = np.array(
            [[int(np.sum(d.origin == -1)) for d in sensor.sense(ep, k, plan)] for k in range(1, ep.target_hit.shape[1])]
        )  # (S, P)
        expected = f * sensor.expected_clutter[sensor.pairs[:, 0], sensor.pairs[:, 1]]  # (P,)
        se = np.sqrt(expected / counts[w].shape[0])  # Poisson mean over the scans
        assert np.all(np.abs(counts[w].mean(axis=0) - expected) < 4.0 * se), (w, counts[w].mean(axis=0), expected)
        d = sensor.sense(ep, 7, plan)[0]
        assert d.expected_false_alarms == pytest.approx(f * sensor.expected_clutter[d.tx, d.rx], rel=1e-12)
    # common random numbers: the half-rate waveform keeps ~1/4 of the double-rate one's false alarms (binomial)
    p = counts[1].sum() / counts[2].sum()
    assert abs(p - 0.25) < 4.0 * math.sqrt(0.25 * 0.75 / counts[2].sum())
    assert np.all(ep.clutter_keep[2] | ~ep.clutter_keep[0]) and np.all(ep.clutter_keep[0] | ~ep.clutter_keep[1])


def test_clutter_intensity_scales_with_the_factor(episode):
    sensor, _ = episode
    z = np.linspace(1.0, 14.0, 27)[:, None]  # bistatic ranges [m] over the pair's span
    R = np.tile(np.eye(1) * 0.02, (3, z.shape[0], 1, 1))
    t, r = (int(x) for x in sensor.pairs[0])
    rho = sensor.clutter_intensity_at(t, r, z, R, np.array([0, 1, 2]))
    assert np.sum(rho[0] > 0) >= 3
    np.testing.assert_allclose(rho[1], 0.5 * rho[0], rtol=1e-12)
    np.testing.assert_allclose(rho[2], 2.0 * rho[0], rtol=1e-12)
