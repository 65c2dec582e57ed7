"""False alarms per waveform (ClutterConfig.reference_bandwidth_hz) and the chain's peak cap per image cell.

urban-intersection-wideband: the 160 MHz chirps have 4x the resolution cells of the seed's 40 MHz ones, so 4x the
false alarms at the same per-cell Pfa, in the parametric draws and in the clutter map; the chirp signal chain caps its
peaks per image cell (ChirpSignalConfig.scale_max_peaks).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from uwb_env import scenarios
from uwb_env.rng import RngStreams
from uwb_env.scene.truth import sample_truth
from uwb_env.sensing import ScanPlan
from uwb_env.sensing.batch import sense_many
from uwb_env.sensing.parametric import ParametricSensor, false_alarm_scale
from uwb_env.sensing.signal.chirp_sensor import ChirpSignalSensor, peak_caps

WIDE = "urban-intersection-wideband"
NARROW = (0, 1, 2, 3, 4, 5)  # the library's 40 MHz chirps
BROAD = (6, 7)  # its 160 MHz ones


def _episode(cfg, seed: int = 0):
    sensor = ParametricSensor(cfg)
    rngs = RngStreams.from_seed(seed)
    return sensor, sensor.new_episode(sample_truth(cfg, rngs.truth, sensor.layout), rngs)


def _false_alarms(sensor, ep, w: int) -> list[list[np.ndarray]]:
    """Per scan, per pair: the apparent SNRs of the false alarms (origin -1) of a plan sending ``w``."""
    plan = ScanPlan.all_listening(w, sensor.n_tx, sensor.n_rx)
    return [
        [np.sort(d.snr[d.origin == -1]) for d in sensor.sense(ep, k, plan)] for k in range(1, ep.target_hit.shape[1])
    ]


@pytest.fixture(scope="module")
def wide():
    """The wideband scenario without multipath ghosts (origin -1 is then a false alarm), one episode."""
    return _episode(scenarios.get(WIDE, **{"sensing.ghost_rate": 0.0}))


def test_false_alarm_scale_is_the_bandwidth_over_the_reference():
    assert scenarios.get(WIDE).sensing.clutter.reference_bandwidth_hz == 40e6
    np.testing.assert_array_equal(false_alarm_scale(scenarios.get(WIDE)), [1, 1, 1, 1, 1, 1, 4, 4])
    # default: no reference, no scaling (every other scenario)
    assert scenarios.get("urban-intersection").sensing.clutter.reference_bandwidth_hz == 0.0
    np.testing.assert_array_equal(false_alarm_scale(scenarios.get("urban-intersection")), np.ones(6))


def test_160mhz_plan_has_4x_the_false_alarms_of_a_40mhz_plan(wide):
    sensor, ep = wide
    n40 = np.array([[len(s) for s in scan] for scan in _false_alarms(sensor, ep, 2)])  # (S, P)
    n160 = np.array([[len(s) for s in scan] for scan in _false_alarms(sensor, ep, 6)])
    expected = sensor.expected_clutter[sensor.pairs[:, 0], sensor.pairs[:, 1]]  # (P,) at the reference bandwidth
    # Poisson means per pair and scan: within 4 standard errors of the mean over the episode's scans
    for n, f in ((n40, 1.0), (n160, 4.0)):
        se = np.sqrt(f * expected / n.shape[0])
        assert np.all(np.abs(n.mean(axis=0) - f * expected) < 4.0 * se), (n.mean(axis=0), f * expected)
    # the 40 MHz false alarms are the 160 MHz ones thinned with p = 1/4: binomial, ratio 4 within 4 standard errors
    p = n40.sum() / n160.sum()
    assert abs(p - 0.25) < 4.0 * math.sqrt(0.25 * 0.75 / n160.sum())
    # the records' expected false alarms follow
    d40 = sensor.sense(ep, 5, ScanPlan.all_listening(2, sensor.n_tx, sensor.n_rx))
    d160 = sensor.sense(ep, 5, ScanPlan.all_listening(6, sensor.n_tx, sensor.n_rx))
    for a, b in zip(d40, d160, strict=True):
        assert b.expected_false_alarms == pytest.approx(4.0 * a.expected_false_alarms, rel=1e-12)


def test_a_narrower_waveforms_false_alarms_are_a_subset_of_a_wider_ones(wide):
    """Common random numbers: drawn at the largest rate, thinned per waveform (apparent SNR: waveform-independent)."""
    sensor, ep = wide
    assert ep.clutter_keep is not None
    assert np.all(ep.clutter_keep[6] | ~ep.clutter_keep[0])  # keep_40 implies keep_160
    np.testing.assert_array_equal(ep.clutter_keep[6], ep.clutter_keep[7])
    for w in NARROW[1:]:
        np.testing.assert_array_equal(ep.clutter_keep[w], ep.clutter_keep[0])
    for s40, s160 in zip(_false_alarms(sensor, ep, 0), _false_alarms(sensor, ep, 7), strict=True):
        for a, b in zip(s40, s160, strict=True):
            assert np.isin(a, b).all()
    # two 40 MHz waveforms: the same false alarms
    for s0, s5 in zip(_false_alarms(sensor, ep, 0), _false_alarms(sensor, ep, 5), strict=True):
        for a, b in zip(s0, s5, strict=True):
            np.testing.assert_array_equal(a, b)


def test_batched_sensing_and_partial_plans_thin_as_sense_does(wide):
    """sensing.batch.sense_many (the batched vector env) gives sense's thinned detections; so does one receiver."""
    sensor, ep = wide
    assert sensor._validate(ScanPlan.all_listening(6, sensor.n_tx, sensor.n_rx))[2]  # batched path, which thins
    scans = np.array([3, 40, 90, 3])
    plans = [ScanPlan.all_listening(w, sensor.n_tx, sensor.n_rx) for w in (0, 6, 7, 2)]
    batched = sense_many(sensor, [ep] * 4, scans, plans, np.zeros(4))
    for k, plan, got in zip(scans.tolist(), plans, batched, strict=True):
        want = sensor.sense(ep, k, plan)
        for a, b in zip(got, want, strict=True):
            np.testing.assert_array_equal(a.z, b.z)
            np.testing.assert_array_equal(a.clutter_intensity, b.clutter_intensity)
        part = sensor.sense(ep, k, ScanPlan(plan.waveform, np.array([True, False])))
        assert len(part) == 1 and part[0].rx == want[0].rx
        np.testing.assert_array_equal(part[0].z, want[0].z)


def test_clutter_map_scales_per_waveform(wide):
    sensor, ep = wide
    z = np.array([[120.0, 1.0], [180.0, -3.0], [250.0, 6.0]])
    R = np.tile(np.diag([0.4, 0.02]), (2, 3, 1, 1))
    for t, r in sensor.pairs.tolist():
        rho = sensor.clutter_intensity_at(t, r, z, R, np.array([2, 6]))
        assert np.all(rho[0] > 0)
        np.testing.assert_allclose(rho[1], 4.0 * rho[0], rtol=1e-12)
    # the detections' own clutter_intensity: the same map, 4x for the 160 MHz plan's false alarms
    for w, f in ((2, 1.0), (6, 4.0)):
        for d in sensor.sense(ep, 10, ScanPlan.all_listening(w, sensor.n_tx, sensor.n_rx)):
            if len(d):
                rho = sensor.clutter_intensity_at(d.tx, d.rx, d.z, d.R[None], np.array([w]))[0]
                np.testing.assert_allclose(d.clutter_intensity, rho, rtol=1e-9)
                base = sensor.clutter_intensity_at(d.tx, d.rx, d.z, d.R[None], np.array([2]))[0]
                np.testing.assert_allclose(d.clutter_intensity, f * base, rtol=1e-9)


def test_40mhz_library_with_the_reference_set_draws_exactly_as_without():
    """urban-intersection (UrbanWaveform-v3): every waveform at the reference bandwidth, nothing thinned, bit-equal."""
    base = _episode(scenarios.get("urban-intersection"))
    ref = _episode(scenarios.get("urban-intersection", **{"sensing.clutter.reference_bandwidth_hz": 40e6}))
    assert ref[1].clutter_keep is None and base[1].clutter_keep is None
    for w in range(6):
        plan = ScanPlan.all_listening(w, base[0].n_tx, base[0].n_rx)
        for k in range(1, 141, 7):
            for a, b in zip(base[0].sense(base[1], k, plan), ref[0].sense(ref[1], k, plan), strict=True):
                for f in ("z", "R", "snr", "origin", "clutter_intensity"):
                    np.testing.assert_array_equal(getattr(a, f), getattr(b, f))
                assert a.expected_false_alarms == b.expected_false_alarms


def test_chain_caps_peaks_per_image_cell():
    cfg = scenarios.get(WIDE, **{"sensing.fidelity": "signal"})
    s = ChirpSignalSensor(cfg)
    np.testing.assert_array_equal(s.max_peaks, [10] * 6 + [38] * 2)
    cells = np.array([g.n_delay * g.n_doppler for g in s.grids])
    per_cell = s.max_peaks / cells
    assert np.ptp(per_cell) / per_cell.mean() < 0.02  # the same cap per image cell (rounding apart)
    np.testing.assert_array_equal(peak_caps(s.grids, 10, scale=False), np.full(8, 10))
    # a 40 MHz library keeps max_peaks everywhere
    np.testing.assert_array_equal(peak_caps(s.grids[:6], 10), np.full(6, 10))
    # the chain's false-peak expectation (its clutter map) is per waveform too: ~4x for 160 MHz
    rngs = RngStreams.from_seed(0)
    ep = s.new_episode(sample_truth(cfg, rngs.truth, s.layout), rngs)
    ratio = ep.expected_false_peaks[6] / ep.expected_false_peaks[2]
    assert np.all((ratio > 3.9) & (ratio < 4.1))


def test_detection_sees_the_walked_ridge_of_a_wide_band():
    """Pd's range-walk gain: G x the resolution cells the walk spans (capped at 1); G where it spans less than one."""
    sensor = ParametricSensor(scenarios.get(WIDE))
    rdot = np.array([0.0, 5.0, 10.0, 18.0, 25.0])
    for w in range(len(sensor.library)):
        cfg = sensor.library[w].config
        g = sensor.migration_gain(np.full(rdot.size, w), rdot)
        g_pd = sensor.detection_migration_gain(np.full(rdot.size, w), rdot)
        cells = rdot * cfg.pri_s * (cfg.n_pulses - 1) / (299_792_458.0 / cfg.bandwidth_hz)
        want = np.where(cells > 1.0, np.minimum(g * cells, 1.0), g)
        np.testing.assert_allclose(g_pd, want, rtol=2e-3)
        if w in NARROW:  # 40 MHz: the walk stays within one range cell at vehicle speeds
            np.testing.assert_array_equal(g_pd, g)
        else:  # 160 MHz at 18 m/s (10 ms): G -6.4 dB, 2.3 cells -> -2.8 dB for detection
            assert np.all(g_pd >= g) and g_pd[3] > 1.5 * g[3]
    # the lookahead's sensor model uses the same gain for Pd (and G for R)
    pos = np.array([[2050.0, 1500.0]])
    for speed in (0.0, 18.0):
        vel = np.array([[speed, 0.0]])
        pd_v, _ = sensor.expected_measurements(0, 0, pos, np.array([2, 6]), 10.0, 1, velocities=vel)
        assert np.all((pd_v >= 0.0) & (pd_v <= 1.0))
