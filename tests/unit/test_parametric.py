"""Parametric sensing: Monte Carlo statistics against Pd and R, Poisson clutter, determinism, CRN, errors."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from tests.conftest import tiny_config
from uwb_env import scenarios
from uwb_env.config import MaterialConfig, UniformLinearArrayConfig, WallConfig
from uwb_env.rng import RngStreams
from uwb_env.scene import sample_truth
from uwb_env.sensing import ParametricSensor, ScanPlan, detection_probability


def run(cfg, seed, plans, scans=None):
    """Sense every scan; returns (sensor, episode, list of per-scan detection tuples)."""
    sensor = ParametricSensor(cfg)
    rngs = RngStreams.from_seed(seed)
    truth = sample_truth(cfg, rngs.truth, sensor.layout)
    ep = sensor.new_episode(truth, rngs)
    scans = range(1, cfg.n_scans + 1) if scans is None else scans
    return sensor, ep, [sensor.sense(ep, k, plans[k % len(plans)], k * 0.1) for k in scans]


@pytest.mark.parametrize(("swerling", "power_dbm"), [(0, 14.0), (1, 18.0), (3, 16.0), (1, 10.0)])
def test_empirical_detection_rate_matches_pd(swerling, power_dbm):
    """Detections of the target per pair over N scans vs sum of Pd(mean SNR); tolerance 4 binomial sigmas."""
    cfg = tiny_config(n_scans=20000, swerling=swerling, power_dbm=power_dbm)
    plan = ScanPlan.all_listening(0, 1, 2)
    sensor, ep, out = run(cfg, 11, [plan])
    for r in range(2):
        hits = sum(int((d[r].origin == 0).sum()) for d in out)
        # every scan's Pd in one call (as in the tests below): the same numbers as scan by scan (Swerling III: within
        # 1 ulp; the sums the check reads are equal), 4.4 s -> 1 s for Swerling 0
        snr = np.array([sensor.mean_snr(ep.geometry, k, plan)[0, r, 0] for k in range(1, cfg.n_scans + 1)])
        p = detection_probability(snr, 1e-3, swerling)
        assert 0.1 < p.mean() < 0.97, "the check must be informative"
        assert abs(hits - p.sum()) < 4 * math.sqrt((p * (1 - p)).sum())


@pytest.mark.parametrize(
    ("waveform", "arrays"),
    [
        ("chirp", (None, None)),
        ("impulse", (None, None)),
        ("chirp", (UniformLinearArrayConfig(3, 0.0375, 45.0, 80.0), None)),
    ],
)
def test_measurement_errors_have_the_reported_covariance(waveform, arrays):
    """Whitened residuals L^-1 (z - h) of a steady target must have identity covariance (4-sigma bounds)."""
    cfg = tiny_config(n_scans=20000, swerling=0, power_dbm=25.0, waveform=waveform, arrays=arrays, measure_doa=True)
    plan = ScanPlan.all_listening(1, 1, 2)
    sensor, ep, out = run(cfg, 5, [plan])
    g = ep.geometry
    for r in range(2):
        rows = [(k, d[r]) for k, d in zip(range(1, cfg.n_scans + 1), out, strict=True)]
        res, covs = [], []
        for k, det in rows:
            i = np.flatnonzero(det.origin == 0)
            if i.size:
                h = [g.bistatic_range[k, 0, r, 0]]
                if waveform == "chirp":
                    h.append(g.range_rate[k, 0, r, 0])
                if "azimuth" in det.measurement_names:
                    h.append(g.azimuth[k, r, 0])
                res.append(det.z[i[0]] - np.array(h))
                covs.append(det.R[i[0]])
        res, covs = np.array(res), np.array(covs)
        n, m = res.shape
        assert n > 15000 and m == (2 if waveform == "chirp" else 1) + (arrays[r] is not None)
        # the reported R is the waveform's CRLB at the (steady) true SNR
        snr = sensor.mean_snr(g, 1, plan)[0, r, 0]
        np.testing.assert_allclose(
            covs[0][:2, :2] if waveform == "chirp" else covs[0][:1, :1],
            sensor.library[1].covariance(np.array([snr]))[0],
            rtol=1e-3,
        )
        w = np.linalg.solve(np.linalg.cholesky(covs), res[..., None])[..., 0]
        sample = w.T @ w / n
        tol = 4 * math.sqrt(2.0 / n)
        np.testing.assert_allclose(np.diag(sample), 1.0, atol=tol)
        np.testing.assert_allclose(sample[~np.eye(m, dtype=bool)], 0.0, atol=4 * math.sqrt(1.0 / n))
        np.testing.assert_allclose(w.mean(axis=0), 0.0, atol=4 * math.sqrt(1.0 / n))


def test_clutter_counts_are_poisson_with_the_density_times_area():
    """Whole area inside the gate: mean lambda A = 10 per pair and scan, dispersion index ~ chi2(N - 1)."""
    cfg = tiny_config(n_scans=3000, clutter_density=1e-3)
    sensor, _, out = run(cfg, 3, [ScanPlan.all_listening(0, 1, 2)])
    np.testing.assert_allclose(sensor.expected_clutter, 10.0, rtol=1e-12)
    for r in range(2):
        x = np.array([int((d[r].origin == -1).sum()) for d in out])
        n = x.size
        assert abs(x.mean() - 10.0) < 4 * math.sqrt(10.0 / n)
        dispersion = ((x - x.mean()) ** 2).sum() / x.mean()
        assert abs(dispersion - (n - 1)) < 4 * math.sqrt(2 * (n - 1))
        assert out[0][r].expected_false_alarms == pytest.approx(10.0)


def test_clutter_is_thinned_to_the_gate():
    cfg = tiny_config(n_scans=3000, clutter_density=1e-3, max_range_m=60.0, blind_zone_excess_m=5.0, waveform="impulse")
    sensor, _, out = run(cfg, 4, [ScanPlan.all_listening(0, 1, 2)])
    for r in range(2):
        x = np.array([int((d[r].origin == -1).sum()) for d in out])
        lam = sensor.expected_clutter[0, r]
        assert 2.0 < lam < 9.0
        # 1 m grid integration of the gate area: allow 1 % on top of the 4-sigma sampling bound
        assert abs(x.mean() - lam) < 4 * math.sqrt(lam / x.size) + 0.01 * lam
        z = np.concatenate([d[r].z[d[r].origin == -1, 0] for d in out])
        # impulse ranging noise is millimetres: the false alarms stay inside baseline + blind zone .. 2 x max range
        assert z.min() >= 20.0 + 5.0 - 0.05 and z.max() <= 120.0 + 0.05


def test_clutter_range_density_matches_the_clutter_map():
    """Histogram of false-alarm ranges vs the precomputed map (quadrature): chi-square over 10 m bins, 5 sigma."""
    cfg = tiny_config(n_scans=4000, clutter_density=1e-3, max_range_m=80.0, waveform="impulse")
    sensor, _, out = run(cfg, 6, [ScanPlan.all_listening(0, 1, 2)])
    edges, dens = sensor.range_density(0, 1)
    z = np.concatenate([d[1].z[d[1].origin == -1, 0] for d in out])
    coarse = np.arange(20.0, 161.0, 10.0)
    counts, _ = np.histogram(z, coarse)
    fine_mass = dens * np.diff(edges)
    expected = np.array([fine_mass[(edges[:-1] >= a) & (edges[:-1] < b)].sum() for a, b in itertools.pairwise(coarse)])
    expected *= len(out)
    keep = expected > 50
    chi2 = (((counts - expected) ** 2 / expected)[keep]).sum()
    dof = int(keep.sum())
    assert dof >= 8
    assert chi2 < dof + 5 * math.sqrt(2 * dof)
    assert fine_mass.sum() == pytest.approx(sensor.expected_clutter[0, 1], rel=1e-9)


def test_clutter_intensity_is_the_map_times_the_range_rate_density():
    cfg = tiny_config(n_scans=50, clutter_density=1e-3)
    sensor, _, out = run(cfg, 8, [ScanPlan.all_listening(0, 1, 2)])
    edges, dens = sensor.range_density(0, 0)
    d = next(x[0] for x in out if len(x[0]) > 3)
    # chirp noise lies along the delay-Doppler ridge: the map is read at r - (R_rd / R_dd) rdot
    r = d.z[:, 0] - d.R[:, 0, 1] / d.R[:, 1, 1] * d.z[:, 1]
    b = np.clip(np.searchsorted(edges, r, side="right") - 1, 0, dens.size - 1)
    inside = (r >= 0) & (r < edges[-1])
    # the train's range-rate is folded into one ambiguity interval, lambda / T1: a false alarm's density there is
    # its aliases inside +-30 m/s (uniform truth) over 60 m/s, counted by brute force
    period = sensor.library[d.waveform].range_rate_ambiguity_mps
    assert np.all(np.abs(d.z[:, 1]) <= period / 2)
    k = np.arange(-20, 21)
    aliases = (np.abs(d.z[:, 1:2] + k[None] * period) <= 30.0).sum(axis=1)
    expected = np.where(inside, dens[b], 0.0) * aliases / 60.0
    np.testing.assert_allclose(d.clutter_intensity, expected, rtol=1e-9)


def test_target_range_rate_is_measured_folded_with_the_train_noise():
    """Target detections: the measured range-rate minus the truth, folded, is N(0, R_dd) (pulse-train CRLB)."""
    cfg = tiny_config(n_scans=400, clutter_density=0.0)
    sensor, episode, out = run(cfg, 8, [ScanPlan.all_listening(0, 1, 2)])
    geom = episode.geometry
    res, sd = [], []
    for k, scan in enumerate(out, start=1):
        for d in scan:
            tgt = d.origin >= 0
            truth = geom.range_rate[k, d.tx, d.rx, d.origin[tgt]]
            period = sensor.library[d.waveform].range_rate_ambiguity_mps
            err = d.z[tgt, 1] - truth
            res.append(err - period * np.round(err / period))
            sd.append(np.sqrt(d.R[tgt, 1, 1]))
            assert np.all(np.abs(d.z[:, 1]) <= period / 2)
    normalised = np.concatenate(res) / np.concatenate(sd)
    assert normalised.size > 500
    assert abs(normalised.mean()) < 4 / math.sqrt(normalised.size)
    assert normalised.var() == pytest.approx(1.0, abs=5 * math.sqrt(2 / normalised.size))


def test_same_seed_same_detections_and_different_seed_differs():
    cfg = scenarios.get("urban-intersection")
    plans = [ScanPlan.all_listening(w, 1, 2) for w in range(4)]
    _, _, a = run(cfg, 21, plans, range(1, 60))
    _, _, b = run(cfg, 21, plans, range(1, 60))
    _, _, c = run(cfg, 22, plans, range(1, 60))
    for da, db in zip(a, b, strict=True):
        for x, y in zip(da, db, strict=True):
            np.testing.assert_array_equal(x.z, y.z)
            np.testing.assert_array_equal(x.R, y.R)
            np.testing.assert_array_equal(x.origin, y.origin)
    assert any(not np.array_equal(x.z, y.z) for da, dc in zip(a, c, strict=True) for x, y in zip(da, dc, strict=True))


def test_plans_share_truth_clutter_and_noise_common_random_numbers():
    cfg = scenarios.get("urban-intersection")
    sensor = ParametricSensor(cfg)
    short, long_ = ScanPlan.all_listening(0, 1, 2), ScanPlan.all_listening(3, 1, 2)
    one_rx = ScanPlan(np.array([0]), np.array([True, False]))
    results = []
    for plan in (short, long_, one_rx):
        rngs = RngStreams.from_seed(9)
        truth = sample_truth(cfg, rngs.truth, sensor.layout)
        ep = sensor.new_episode(truth, rngs)
        results.append((truth, [sensor.sense(ep, k, plan) for k in range(1, 141)]))
    (t0, d0), (t1, d1), (t2, d2) = results
    np.testing.assert_array_equal(t0.states, t1.states)
    np.testing.assert_array_equal(t0.states, t2.states)
    for a, b, c in zip(d0, d1, d2, strict=True):
        # the same false alarms whatever the waveform (measured through it) or the other receivers do
        assert (a[0].origin < 0).sum() == (b[0].origin < 0).sum()
        np.testing.assert_array_equal(a[0].z[a[0].origin < 0], c[0].z[c[0].origin < 0])
        np.testing.assert_array_equal(a[0].z, c[0].z)
        assert len(c) == 1 and c[0].rx == 0


@pytest.mark.parametrize("doa", [False, True])
def test_records_are_sorted_by_range_with_names_and_origin(doa):
    cfg = scenarios.get("urban-intersection", **{"sensing.measure_doa": doa})
    _, _, out = run(cfg, 2, [ScanPlan.all_listening(2, 1, 2)], range(1, 40))
    names = ("bistatic_range", "range_rate", "azimuth") if doa else ("bistatic_range", "range_rate")  # the seed's
    m = len(names)
    n_target = 0
    for dets in out:
        assert [(d.tx, d.rx) for d in dets] == [(0, 0), (0, 1)]
        for d in dets:
            assert np.all(np.diff(d.z[:, 0]) >= 0)
            assert d.measurement_names == names
            assert d.z.shape[1] == m and d.R.shape == (len(d), m, m) and d.snr.shape == (len(d),)
            assert np.isfinite(d.z).all() and np.isfinite(d.R).all() and (d.snr > 0).all()
            n_target += int((d.origin >= 0).sum())
    assert n_target > 25  # seed 003 regime: Pd ~0.5-0.8 on ~70 covered links of scans 1-39


def target_hits(cfg, rx):
    _, _, out = run(cfg, 1, [ScanPlan.all_listening(0, 1, 2)])
    return sum(int((dets[rx].origin >= 0).sum()) for dets in out)


def test_blocked_out_of_range_and_blind_targets_are_never_detected():
    wall = (WallConfig((30.0, -50.0), (30.0, 90.0), MaterialConfig("building", math.inf)),)
    loud = {"n_scans": 300, "power_dbm": 60.0}
    for rx in (0, 1):
        assert target_hits(tiny_config(**loud, walls=wall), rx) == 0  # opaque wall between nodes and target
        assert target_hits(tiny_config(**loud, max_range_m=50.0), rx) == 0  # legs of 72 m and 57-61 m
        assert target_hits(tiny_config(**loud), rx) == 300  # the same target in the open: always seen
    # (10, 0.5) lies 2.5 cm off rx1's baseline (blind) but 11.9 m of excess range from rx2's
    blind = tiny_config(**loud, target_xy=(10.0, 0.5), blind_zone_excess_m=1.0)
    assert target_hits(blind, 0) == 0
    assert target_hits(blind, 1) == 300


def test_lossy_wall_attenuates_both_legs_and_biases_range():
    lossy = (WallConfig((30.0, -50.0), (30.0, 90.0), MaterialConfig("drywall", 3.0, 1e-9)),)
    plan = ScanPlan.all_listening(0, 1, 2)
    walled, ep_w, _ = run(tiny_config(n_scans=2, walls=lossy), 1, [plan])
    free, ep_f, _ = run(tiny_config(n_scans=2), 1, [plan])
    ratio = free.mean_snr(ep_f.geometry, 1, plan) / walled.mean_snr(ep_w.geometry, 1, plan)
    np.testing.assert_allclose(ratio, 10**0.6, rtol=1e-9)  # both legs cross the wall: 2 x 3 dB
    # seed 002's excess delay: a positive bias of c x (delay per crossing) x 2 crossings
    bias = ep_w.geometry.bistatic_range[1, 0, 0, 0] - ep_f.geometry.bistatic_range[1, 0, 0, 0]
    assert bias == pytest.approx(2e-9 * 299_792_458.0, rel=1e-9)


@pytest.mark.parametrize(
    ("plan", "match"),
    [
        (ScanPlan(np.array([4]), np.array([True, True])), r"ScanPlan.waveform\[0\] = 4: must be in \[0, 2\)"),
        (ScanPlan(np.array([-1]), np.array([True, True])), r"ScanPlan.waveform\[0\] = -1"),
        (ScanPlan(np.array([0, 1]), np.array([True, True])), r"ScanPlan.waveform has shape \(2,\): must be \(1,\)"),
        (ScanPlan(np.array([0.5]), np.array([True, True])), r"must hold integers"),
        (ScanPlan(np.array([0]), np.array([True, True, True])), r"ScanPlan.active_rx has shape \(3,\): must be \(2,\)"),
        (ScanPlan(np.array([0]), np.array([1, 0])), r"ScanPlan.active_rx = .*: must be a boolean mask"),
        (ScanPlan(np.array([0]), np.array([False, False])), r"at least one receiver must listen"),
    ],
)
def test_invalid_scan_plans_raise(plan, match):
    cfg = tiny_config(n_scans=3)
    sensor = ParametricSensor(cfg)
    rngs = RngStreams.from_seed(0)
    ep = sensor.new_episode(sample_truth(cfg, rngs.truth), rngs)
    with pytest.raises(ValueError, match=match):
        sensor.sense(ep, 1, plan)


def test_plan_arrays_are_immutable():
    plan = ScanPlan.all_listening(0, 1, 2)
    with pytest.raises(ValueError, match="read-only"):
        plan.waveform[0] = 3


@pytest.mark.parametrize("name", scenarios.names())
def test_every_scenario_senses_without_nan(name):
    cfg = scenarios.get(name)
    sensor = ParametricSensor(cfg)
    plans = [ScanPlan.all_listening(w, sensor.n_tx, sensor.n_rx) for w in range(len(sensor.library))]
    _, _, out = run(cfg, 0, plans)
    n_target = 0
    for dets in out:
        for d in dets:
            assert np.isfinite(d.z).all() and np.isfinite(d.R).all()
            np.testing.assert_allclose(d.R, np.swapaxes(d.R, 1, 2))
            if len(d):
                assert (np.linalg.eigvalsh(d.R) > 0).all()
            n_target += int((d.origin >= 0).sum())
    assert n_target > 0.3 * cfg.n_scans


def test_each_transmitter_measures_with_its_own_waveform():
    """Monostatic network, a plan mixing three waveforms: every pair's R is its transmitter's waveform model at
    the reported SNR, and the detections equal those of single-waveform plans for the same pairs."""
    cfg = scenarios.get("indoor-monostatic")
    sensor = ParametricSensor(cfg)
    rngs = RngStreams.from_seed(4)
    ep = sensor.new_episode(sample_truth(cfg, rngs.truth, sensor.layout), rngs)
    mixed = ScanPlan(np.arange(10) % 3, np.ones(10, bool))
    singles = [ScanPlan.all_listening(w, 10, 10) for w in range(3)]
    for k in (5, 40, 77):
        out = sensor.sense(ep, k, mixed)
        ref = [sensor.sense(ep, k, s) for s in singles]
        for d in out:
            w = d.tx % 3
            assert d.waveform == w
            if len(d):
                np.testing.assert_allclose(d.R, sensor.library[w].covariance(d.snr), rtol=1e-12)
            same = next(x for x in ref[w] if x.tx == d.tx and x.rx == d.rx)
            np.testing.assert_array_equal(d.z, same.z)
            np.testing.assert_array_equal(d.origin, same.origin)


def test_clutter_residue_ratio_turns_snr_into_scnr_for_detection_only():
    """kappa > 0: Pd at SCNR = SNR / (1 + kappa SNR_dp), SNR_dp the direct path's; the covariance keeps the SNR."""
    from uwb_env import scenarios
    from uwb_env.channel.radar_equation import direct_path_snr
    from uwb_env.sensing import ParametricSensor
    from uwb_env.sensing.pd import detection_probability
    from uwb_env.units import dbm_to_watts

    base = scenarios.get("indoor-rsn", **{"sensing.clutter_residue_ratio": 0.0})
    kappa = 1e-3
    cfg = scenarios.get("indoor-rsn", **{"sensing.clutter_residue_ratio": kappa, "sensing.clutter_residue_looks": 0.0})
    s0, s1 = ParametricSensor(base), ParametricSensor(cfg)
    pos = np.array([[2.0, 2.0], [9.0, 1.5]])  # both covered by the pair (tx, rx3)
    wf = s1.library.waveforms[1]
    tx, rx = cfg.transmitters[0], cfg.receivers[2]
    dp = direct_path_snr(
        wf.scan_energy_j(dbm_to_watts(tx.power_dbm)),
        wf.center_freq_hz,
        wf.rms_bandwidth_hz,
        tx.antenna_gain_db,
        rx.antenna_gain_db,
        rx.noise_figure_db,
        float(s1.layout.baselines[0, 2]),
        cfg.channel,
    )
    pd0, R0 = s0.expected_measurements(0, 2, pos, np.array([1]), 1.0, 0)
    pd1, R1 = s1.expected_measurements(0, 2, pos, np.array([1]), 1.0, 0)
    # recover the SNR from the noise-limited covariance (R = c^2 / (8 pi^2 beta^2 SNR)) and apply the SCNR by hand
    snr = 299_792_458.0**2 / (8 * np.pi**2 * wf.rms_bandwidth_hz**2 * R0[0, :, 0, 0])
    expected = detection_probability(snr / (1.0 + kappa * dp), cfg.sensing.false_alarm_probability, 0)
    np.testing.assert_allclose(pd1[0], expected, rtol=1e-9)
    np.testing.assert_allclose(R1, R0)  # the covariance is the thermal SNR's
    assert np.all(pd0 > 0) and np.all(pd1 < pd0)


@pytest.mark.parametrize("looks", [1.0, 4.0, 12.0])
def test_residue_quadrature_matches_a_fine_integral_over_the_gamma_level(looks):
    """E_X[Pd(SNR / (1 + c X))], X ~ Gamma(m, 1/m): 12 Gauss-Laguerre nodes vs a 20000-point integral of the pdf."""
    from scipy.stats import gamma

    from uwb_env import scenarios
    from uwb_env.sensing import ParametricSensor
    from uwb_env.sensing.pd import detection_probability

    cfg = scenarios.get("indoor-rsn", **{"sensing.clutter_residue_ratio": 1e-4, "sensing.clutter_residue_looks": looks})
    s = ParametricSensor(cfg)
    assert s._residue_weights.sum() == pytest.approx(1.0)
    assert s._residue_nodes @ s._residue_weights == pytest.approx(1.0, rel=1e-9)  # E[X] = 1
    x = np.linspace(1e-6, 12.0, 20000)
    pdf = gamma.pdf(x, looks, scale=1.0 / looks)
    for c, snr in ((10.0, 200.0), (100.0, 3000.0), (1e3, 2e4)):
        quad = detection_probability(snr / (1.0 + c * s._residue_nodes), 1e-3, 0) @ s._residue_weights
        fine = np.trapezoid(detection_probability(snr / (1.0 + c * x), 1e-3, 0) * pdf, x)
        assert quad == pytest.approx(fine, abs=1e-4)


def test_empirical_detection_rate_with_a_fluctuating_clutter_residue_matches_the_quadrature_pd():
    """kappa > 0 and 4 looks: drawn detections vs sum over scans of E_X[Pd_SW0(SNR / (1 + kappa SNR_dp X))]."""
    from uwb_env.config import apply_overrides

    base = tiny_config(n_scans=20000, swerling=0, power_dbm=30.0)
    plan = ScanPlan.all_listening(0, 1, 2)
    s0, ep0, _ = run(base, 5, [plan], scans=[1])
    snr0 = float(np.median([s0.mean_snr(ep0.geometry, k, plan)[0, 0, 0] for k in range(1, base.n_scans + 1)]))
    kappa = snr0 / 15.0 / float(s0.direct_path_snr[0, 0, 0])  # SCNR ~ 12 dB: Pd on its slope
    cfg = apply_overrides(base, {"sensing.clutter_residue_ratio": kappa, "sensing.clutter_residue_looks": 4.0})
    sensor, ep, out = run(cfg, 5, [plan])
    x, w = sensor._residue_nodes, sensor._residue_weights
    for r in range(2):
        hits = sum(int((d[r].origin == 0).sum()) for d in out)
        snr = np.array([sensor.mean_snr(ep.geometry, k, plan)[0, r, 0] for k in range(1, cfg.n_scans + 1)])
        gain = 1.0 / (1.0 + kappa * sensor.direct_path_snr[0, 0, r] * x)
        p = detection_probability((snr[:, None] * gain).ravel(), 1e-3, 0).reshape(-1, x.size) @ w
        assert 0.1 < p.mean() < 0.97, "the check must be informative"
        assert abs(hits - p.sum()) < 4 * math.sqrt((p * (1 - p)).sum())


@pytest.mark.parametrize("period", [7.49, 10.7, 60.0])
def test_folded_uniform_density_is_the_histogram_of_folded_uniform_draws(period):
    from uwb_env.sensing.parametric import fold_range_rate, folded_uniform_density

    rng = np.random.default_rng(5)
    x = fold_range_rate(rng.uniform(-30.0, 30.0, 400_000), period)
    edges = np.linspace(-period / 2, period / 2, 41)
    hist, _ = np.histogram(x, edges, density=True)
    mid = 0.5 * (edges[1:] + edges[:-1])
    dens = folded_uniform_density(mid, period, 30.0)
    inner = np.abs(np.diff(folded_uniform_density(edges, period, 30.0))) == 0  # bins without a step inside
    np.testing.assert_allclose(hist[inner], dens[inner], rtol=0.03)  # ~1 % sampling error per bin
    f = np.linspace(-period / 2, period / 2, 200_001)[:-1]
    assert np.mean(folded_uniform_density(f, period, 30.0)) * period == pytest.approx(1.0, abs=1e-4)  # a density


def test_a_waveforms_own_detection_gain_scales_its_pd_only():
    """ImpulseWaveformConfig.detection_gain_db (issue 18: an energy detector's accumulation loss per N_pulse): the
    detector of that waveform sees g_w x SNR, added to SensingConfig.detection_gain_db; the SNR itself (and so the
    measurement covariance) is unchanged; the compiled mean link agrees with the numpy reference."""
    import dataclasses

    from uwb_env.config import ImpulseWaveformConfig

    with pytest.raises(ValueError, match="detection_gain_db"):
        ImpulseWaveformConfig("w", 4e9, 1e9, detection_gain_db=-31.0)
    base = scenarios.get("indoor-monostatic")
    flat = dataclasses.replace(
        base,
        waveforms=tuple(dataclasses.replace(w, detection_gain_db=0.0) for w in base.waveforms),
        sensing=dataclasses.replace(base.sensing, detection_gain_db=0.0),
    )
    gains_db = (-3.0, 0.0, -7.5)
    gained = dataclasses.replace(
        flat,
        waveforms=tuple(
            dataclasses.replace(w, detection_gain_db=g) for w, g in zip(flat.waveforms, gains_db, strict=True)
        ),
        sensing=dataclasses.replace(flat.sensing, detection_gain_db=1.0),
    )
    a, b = ParametricSensor(flat), ParametricSensor(gained)
    ratio = b.detection_gain / a.detection_gain
    for w, g in enumerate(gains_db):
        np.testing.assert_allclose(ratio[w], 10.0 ** ((g + 1.0) / 10.0), rtol=1e-12)
    pos = np.array([[3.0, 3.0], [5.0, 2.0]])
    _, ok, snr_a, pd_a = a._mean_link_reference(0, 0, pos, np.arange(3), 1.0, 3)
    _, _, snr_b, pd_b = b._mean_link_reference(0, 0, pos, np.arange(3), 1.0, 3)
    assert ok.all()
    np.testing.assert_array_equal(snr_b, snr_a)  # the SNR (and so R) is the echo's; the gain acts in Pd only
    assert np.all(pd_b[[0, 2]] < pd_a[[0, 2]]) and np.all(pd_b[1] > pd_a[1])  # -2 / -6.5 dB and +1 dB
    np.testing.assert_allclose(b._mean_link(0, 0, pos, np.arange(3), 1.0, 3)[3], pd_b, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize(("swerling", "power_dbm"), [(1, 10.0), (1, -40.0), (0, 14.0)])
def test_empirical_detection_rate_with_a_noise_window_matches_the_windowed_pd(swerling, power_dbm):
    """noise_window_cells n (issue 15): a covered target is detected by its echo's test OR a noise peak among the n
    cells of the truth-matching window; drawn detections vs sum over scans of 1 - (1 - Pd_echo) (1 - Pfa)^n (4
    binomial sigmas), and the sensor model (compiled and numpy reference) gives the same Pd. At -40 dBm the echo is
    buried (SNR ~ 1e-4) and the rate is the n-cell term itself."""
    from uwb_env.config import apply_overrides
    from uwb_env.sensing.pd import windowed_detection_probability

    cells = 50.0
    cfg = apply_overrides(
        tiny_config(n_scans=20000, swerling=swerling, power_dbm=power_dbm), {"sensing.noise_window_cells": cells}
    )
    plan = ScanPlan.all_listening(0, 1, 2)
    sensor, ep, out = run(cfg, 13, [plan])
    for r in range(2):
        hits = sum(int((d[r].origin == 0).sum()) for d in out)
        snr = np.array([sensor.mean_snr(ep.geometry, k, plan)[0, r, 0] for k in range(1, cfg.n_scans + 1)])
        p = windowed_detection_probability(detection_probability(snr, 1e-3, swerling), 1e-3, cells)
        assert 0.03 < p.mean() < 0.97, "the check must be informative"
        assert abs(hits - p.sum()) < 4 * math.sqrt((p * (1 - p)).sum())
        if power_dbm < -30.0:
            assert p.mean() == pytest.approx(1.0 - (1.0 - 1e-3) ** (cells + 1.0), rel=1e-3)
    xy = np.array([[60.0, 40.0], [30.0, 80.0]])
    for r in range(2):
        pd = sensor.detection_probability_at(0, r, xy, 0, rcs_m2=1.0, swerling=swerling)
        _, ok, snr, ref = sensor._mean_link_reference(0, r, xy, np.array([0]), 1.0, swerling)
        np.testing.assert_allclose(pd, ref[0], rtol=1e-12)
        expect = windowed_detection_probability(detection_probability(snr[0], 1e-3, swerling), 1e-3, cells)
        np.testing.assert_allclose(pd, np.where(ok, expect, 0.0), rtol=1e-12)
