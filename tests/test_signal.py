"""Signal-level fidelity end to end (issue 5): determinism, common random numbers, accuracy, ToA spread vs CRLB."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from uwb_env import scenarios
from uwb_env.rng import RngStreams
from uwb_env.scene import sample_truth
from uwb_env.sensing import ScanPlan
from uwb_env.sensing.signal import SignalSensor
from uwb_env.sim import Simulator, run_episode
from uwb_env.waveforms.impulse import toa_crlb_variance

# seed 000's chains on a point person (its ToAs are the centre's to the CRLB): the accuracy tests below; the
# scenario's default person is extended since issue 18 (BODY, the tests at the end)
CFG = scenarios.get("indoor-rsn", **{"sensing.fidelity": "signal", "sensing.signal.target_model": "point"})
BODY = scenarios.get("indoor-rsn", **{"sensing.fidelity": "signal"})


@pytest.fixture(scope="module")
def sensor() -> SignalSensor:
    return SignalSensor(CFG)


def _episode(sensor: SignalSensor, seed: int):
    rngs = RngStreams.from_seed(seed)
    return sensor.new_episode(sample_truth(CFG, rngs.truth, sensor.layout), rngs)


def test_same_seed_same_detections_and_streams_do_not_depend_on_the_plan(sensor):
    all_rx = ScanPlan.all_listening(0, 1, 6)
    some = ScanPlan(np.array([0]), np.array([True, False, True, False, True, False]))
    a, b = _episode(sensor, 4), _episode(sensor, 4)
    for k in range(1, 8):
        da, db = sensor.sense(a, k, all_rx)[0], sensor.sense(b, k, all_rx)[0]
        np.testing.assert_array_equal(da.z, db.z)
        np.testing.assert_array_equal(da.R, db.R)
    # the receivers both plans listen to get the same samples whatever the others do
    x, y = _episode(sensor, 9), _episode(sensor, 9)
    for k in range(1, 5):
        s_all, p_all = sensor.synthesise(x, k, all_rx)
        s_some, p_some = sensor.synthesise(y, k, some)
        np.testing.assert_array_equal(s_all[np.isin(p_all, p_some)], s_some)


def test_localizations_are_near_the_walking_person(sensor):
    ep = _episode(sensor, 2)
    plan = ScanPlan.all_listening(0, 1, 6)
    hits = 0
    for k in range(1, 62):
        det = sensor.sense(ep, k, plan)[0]
        truth = ep.truth.states[k, 0, [0, 2]]
        err = np.linalg.norm(det.z - truth, axis=1) if len(det) else np.array([np.inf])
        hits += err.min() < 0.1
        assert det.measurement_names == ("x", "y") and det.rx == -1
        assert np.all(np.linalg.eigvalsh(det.R) > 0)
        # origin labels (evaluation only) agree with the geometry
        assert np.all(np.linalg.norm(det.z[det.origin == 0] - truth, axis=1) < 0.3)
    assert hits >= 55  # measured: 60 of 61 (the rest: the person in several blind zones at once)


def test_tracked_rmse_of_three_runs_is_far_below_the_seeds_real_data_figure():
    sim = Simulator(CFG)
    plan = ScanPlan.all_listening(0, 1, 6)
    rmse = [run_episode(sim, seed, lambda k: plan, 2.0).rmse() for seed in range(3)]
    assert max(rmse) < 0.1  # measured 0.018-0.024 m; seed 000 reports 0.36 m on real data


@pytest.mark.slow
def test_median_rmse_of_twenty_runs_is_at_most_the_seeds_036_m():
    sim = Simulator(CFG)
    plan = ScanPlan.all_listening(0, 1, 6)
    rmse = [run_episode(sim, seed, lambda k: plan, 2.0).rmse() for seed in range(20)]
    assert np.median(rmse) <= 0.36


def test_body_localizations_spread_over_the_walking_persons_body():
    """The default extended person (issue 18): the network chain's positions lie within the body's spread of its
    centre, not at it (the point's: 60 of 61 within 0.1 m, test above)."""
    body = SignalSensor(BODY)
    rngs = RngStreams.from_seed(2)
    ep = body.new_episode(sample_truth(BODY, rngs.truth, body.layout), rngs)
    plan = ScanPlan.all_listening(0, 1, 6)
    errors = []
    for k in range(1, 62):
        det = body.sense(ep, k, plan)[0]
        truth = ep.truth.states[k, 0, [0, 2]]
        errors.append(np.linalg.norm(det.z - truth, axis=1).min() if len(det) else np.inf)
    errors = np.array(errors)
    assert np.sum(errors < 0.5) >= 55  # measured 60 of 61
    assert np.sum(errors < 0.1) <= 10  # measured 4: the near surfaces, 0.13 m towards the transmitter on average


def test_tracked_rmse_with_the_body_is_the_seeds_order():
    """Three runs with the extended person and the trackers' range std of its measured spread (0.23 m): RMSE of
    seed 000's order (0.36 m on real data), from the body's spread, not from added noise (measured 0.174-0.181 m)."""
    sim = Simulator(BODY)
    plan = ScanPlan.all_listening(0, 1, 6)
    rmse = [run_episode(sim, seed, lambda k: plan, 2.0).rmse() for seed in range(3)]
    assert all(0.15 < r < 0.30 for r in rmse)


@pytest.mark.slow
def test_median_rmse_of_twenty_runs_with_the_body_is_within_the_seeds_range():
    """Issue 18's check: 20 runs of the default (extended) person, median RMSE within 0.15-0.65 m (seed 000's real
    data: 0.36 / 0.61 / 0.54 m for its three tracks)."""
    sim = Simulator(BODY)
    plan = ScanPlan.all_listening(0, 1, 6)
    rmse = [run_episode(sim, seed, lambda k: plan, 2.0).rmse() for seed in range(20)]
    assert 0.15 <= np.median(rmse) <= 0.65


def test_high_snr_toa_spread_is_within_30_percent_of_the_crlb(sensor):
    """400 scans of one pair with an echo at 50 dB: the std of the range error vs c sqrt(CRLB).

    The std of a sample of 400 has a relative sampling error of 1 / sqrt(2 x 399) = 3.5 %; measured ratio 1.06.
    """
    ep = _episode(sensor, 0)
    rng = np.random.default_rng(5)
    B, p, w, excess = 400, 0, 0, 3.0
    snr = 10.0**5.0
    scans = sensor.controlled_scans(rng, p, w, excess, np.full(B, snr))
    ref = np.broadcast_to(ep.reference[w, p], scans.shape)
    *_, (row, _, _, _), ranges = sensor.in_sensor(
        scans,
        ref,
        np.full(B, ep.reference_toa[w, p]),
        np.full(B, ep.reference_peak[w, p]),
        np.full(B, p),
        np.broadcast_to(ep.reference_scan[w, p], scans.shape),
    )
    err = ranges - (sensor.baseline[p] + excess)
    hit = np.abs(err) < 0.3
    assert np.unique(row[hit]).size == B  # detected in every scan
    crlb = 299_792_458.0 * math.sqrt(toa_crlb_variance(sensor.library.waveforms[w].rms_bandwidth_hz, snr))
    assert 0.7 < err[hit].std() / crlb < 1.3
    # bias: the 3-point parabola on the sampled envelope peaks of the echo and the direct path (at different
    # sub-sample offsets) is biased by a small fraction of a sample (1 sample = 1.8 mm); measured 0.6 mm
    assert abs(err[hit].mean()) < 0.1 * 299_792_458.0 / CFG.sensing.signal.sample_rate_hz


def test_signal_fidelity_refuses_scenarios_it_cannot_synthesise():
    with pytest.raises(ValueError, match="impulse waveforms only"):
        SignalSensor(scenarios.get("urban-intersection", **{"sensing.fidelity": "signal"}))
    with pytest.raises(ValueError, match=r"SignalConfig\.cfar"):
        scenarios.get("indoor-rsn", **{"sensing.signal.cfar": "xx"})


@pytest.mark.parametrize("env_id", ["uwb_env/IndoorSensorSubset-v1", "uwb_env/IndoorJoint-v1"])
def test_environments_run_on_the_signal_path(env_id):
    """A point person (``target_model = "point"``, the behaviour before issue 18): held by scan 15 with the myopic
    lookahead, whose choice with nothing tracked (every cost equal: plan 0, receivers 1-3) finds it by scan 6."""
    env = gym.make(env_id, fidelity="signal", **{"sensing.signal.target_model": "point"})
    check_env(env.unwrapped, skip_render_check=True)
    obs, _ = env.reset(seed=1)
    rewards = []
    for _ in range(15):
        obs, r, *_ = env.step(int(np.argmin(env.unwrapped.lookahead_costs())))
        assert np.all(np.isfinite(obs)) and math.isfinite(r)
        rewards.append(r)
    assert env.unwrapped.cfg.sensing.fidelity == "signal"
    assert rewards[-1] > -10.0  # the person is held with a small covariance by scan 15


@pytest.mark.parametrize("env_id", ["uwb_env/IndoorSensorSubset-v1", "uwb_env/IndoorJoint-v1"])
def test_environments_run_on_the_signal_path_with_the_body(env_id):
    """The default extended person: the env runs; three receivers hold the body less often than the point (its echo
    is ~3 dB weaker at Pd 0.5 and all three must detect for a position), so plan 0 (receivers 1-3, the far side of
    the room from the person's start), which the plain argmin keeps while nothing is tracked, does not find it in
    45 scans; cycling the plans while the costs tie, the person is held from scan 25-29 (seeds 1-3; measured)."""
    env = gym.make(env_id, fidelity="signal")
    assert env.unwrapped.cfg.sensing.signal.target_model == "extended"
    check_env(env.unwrapped, skip_render_check=True)
    obs, _ = env.reset(seed=1)
    rewards = []
    for k in range(30):
        costs = env.unwrapped.lookahead_costs()
        obs, r, *_ = env.step(int(np.argmin(costs)) if np.ptp(costs) > 0 else k % costs.size)
        assert np.all(np.isfinite(obs)) and math.isfinite(r)
        rewards.append(r)
    assert rewards[-1] > -10.0  # held by scan 30 (from scan 25 with seed 1)


def test_parametric_detection_probability_is_calibrated_on_the_signal_path():
    """indoor-rsn's kappa, looks and Pfa (fitted by scripts/calibrate_parametric.py) predict the signal path's Pd of
    the scenario's person: since issue 18 the extended body (Swerling III centres) against the parametric Swerling III
    person (it was a non-fluctuating point echo against Swerling 0, at 34 / 38 / 30 / 42 dB).

    1200 scans per point (200 per pair): binomial std <= 0.0144; the report's largest difference over the whole
    grid is 0.027, so we allow 0.05 + 3 std here.
    """
    from uwb_env.agents.studies.calibrate_parametric import measure, parametric_pd

    body = SignalSensor(BODY)
    assert BODY.sensing.signal.target_model == "extended" and BODY.sensing.detection_gain_db == 0.0
    pfa = BODY.sensing.false_alarm_probability
    kappa = BODY.sensing.clutter_residue_ratio
    quadrature = (body.model._residue_nodes, body.model._residue_weights)
    swerling = BODY.targets[0].swerling
    for w, snr_db in ((0, 36.0), (0, 40.0), (1, 32.0), (2, 44.0)):
        c = measure(body, w, snr_db, 1200, 3.0, 77)
        snr = 10.0 ** (snr_db / 10.0)
        model = float(np.mean(parametric_pd(snr, body.dp_snr[w], kappa, pfa, quadrature, swerling)))
        assert 0.1 < model < 0.9  # on the slope, where the check is informative
        assert abs(c["pd"] - model) < 0.05 + 3 * 0.0144


def test_range_output_hands_each_pairs_toas_to_the_tracker():
    """signal.output = "ranges": one bistatic-range record per active pair; the tracker fuses them (RMSE ~ 9 mm).

    On a point person, whose ToAs are the centre's to the CRLB (the default extended person's are spread over its
    body: tests/unit/test_extended_target.py)."""
    cfg = scenarios.get(
        "indoor-rsn",
        **{"sensing.fidelity": "signal", "sensing.signal.output": "ranges", "sensing.signal.target_model": "point"},
    )
    sim = Simulator(cfg)
    sim.reset(3)
    plan = ScanPlan(np.array([0]), np.array([True, True, False, True, True, True]))
    dets = sim.step(plan).detections
    assert [(d.tx, d.rx) for d in dets] == [(0, 0), (0, 1), (0, 3), (0, 4), (0, 5)]
    for d in dets:
        assert d.measurement_names == ("bistatic_range",)
        assert np.all(np.diff(d.z[:, 0]) >= 0)  # sorted: the order reveals nothing
        truth = sim.truth.states[1, 0, [0, 2]]
        expected = np.linalg.norm(truth - sim.sensor.layout.tx_pos[0]) + np.linalg.norm(
            truth - sim.sensor.layout.rx_pos[d.rx]
        )
        assert np.all(np.abs(d.z[d.origin == 0, 0] - expected) < 0.05)
    all_rx = ScanPlan.all_listening(0, 1, 6)
    rmse = [run_episode(sim, seed, lambda k: all_rx, 2.0).rmse() for seed in range(2)]
    assert max(rmse) < 0.05


# seed 000's CFAR chain on the monostatic scans (the scenario's signal path now estimates ToAs with seed 002's energy
# detector, tests/unit/test_energy_detector.py); these tests are about the coherent background and the CFAR chain,
# on a point echo of known delay (the scenario's default person is extended since issue 18: tests/unit/
# test_extended_target.py)
MONO = scenarios.get(
    "indoor-monostatic",
    **{
        "sensing.fidelity": "signal",
        "sensing.signal.toa_estimator": "peak",
        "sensing.signal.false_ranges_per_scan": 0.84,
        "sensing.signal.target_model": "point",
    },
)


@pytest.fixture(scope="module")
def mono() -> SignalSensor:
    return SignalSensor(MONO)


def _mono_chain(sensor: SignalSensor, ep, scans: np.ndarray, p: int, w: int = 0):
    B = scans.shape[0]
    return sensor.in_sensor(
        scans,
        np.broadcast_to(ep.reference[w, p], scans.shape),
        np.full(B, ep.reference_toa[w, p]),
        np.full(B, ep.reference_peak[w, p]),
        np.full(B, p),
        np.broadcast_to(ep.reference_scan[w, p], scans.shape),
    )


def test_coherent_background_removes_the_leakage_and_the_multipath(mono):
    """Empty monostatic scans: the raw difference is noise plus the 0.5 % multipath fluctuation; the envelope
    difference of seed 000 leaves a residue proportional to the 70 dB leakage and its multipath."""
    rng = np.random.default_rng(1)
    rngs = RngStreams.from_seed(1)
    ep = mono.new_episode(sample_truth(MONO, rngs.truth, mono.layout), rngs)
    p, B = 3, 50
    empty = mono.controlled_scans(rng, p, 0, 3.0, np.zeros(B))
    _, d_coherent, *_ = _mono_chain(mono, ep, empty, p)
    envelope_cfg = scenarios.get(
        "indoor-monostatic",
        **{
            "sensing.fidelity": "signal",
            "sensing.signal.background": "empty_room",
            "sensing.signal.toa_estimator": "peak",
        },
    )
    envelope = SignalSensor(envelope_cfg)
    _, d_envelope, *_ = envelope.in_sensor(
        empty,
        np.broadcast_to(ep.reference[0, p], empty.shape),
        np.full(B, ep.reference_toa[0, p]),
        np.full(B, ep.reference_peak[0, p]),
        np.full(B, p),
    )
    # noise-level difference (the envelope of unit noise has mean ~1) against a residue hundreds of times larger
    assert np.median(d_coherent.max(axis=1)) < 30.0  # measured ~13
    assert np.median(d_envelope.max(axis=1)) > 300.0  # measured ~1,000-3,000
    with pytest.raises(ValueError, match="coherent"):
        mono.in_sensor(empty, empty, np.zeros(B), np.zeros(B), np.full(B, p))


def test_coherent_chain_detects_a_weak_echo_and_drops_a_shadowed_path(mono):
    """An echo of 22 dB between two multipaths is found; a multipath cut by 20 dB (a person on its leg) lowers the
    envelope there and leaves no detection (the rectification rule), though its raw difference is the path's whole
    amplitude.

    The rule's price: an echo on top of a multipath (delays 4 ns = 1.2 m apart here) whose carrier phase lowers the
    envelope is dropped too, about half of the echoes within a pulse width of a path (measured Pd 0.5 at 6.0 m
    excess, 22 dB; 0.98-1.0 at 2, 3, 4 and 8 m)."""
    rng = np.random.default_rng(2)
    rngs = RngStreams.from_seed(2)
    ep = mono.new_episode(sample_truth(MONO, rngs.truth, mono.layout), rngs)
    p, B, excess = 5, 200, 3.0
    scans = mono.controlled_scans(rng, p, 0, excess, np.full(B, 10.0**2.2))
    *_, (row, _, _, _), ranges = _mono_chain(mono, ep, scans, p)
    hit = np.abs(ranges - excess) < 0.3
    assert np.unique(row[hit]).size >= 0.9 * B  # measured 0.97-1.0 over the pairs (binomial std 0.01)
    # the strongest multipath (first, 4 ns = 1.2 m beyond the leakage) shadowed by 20 dB in every scan
    path = 1 + int(np.argmax(mono.path_amplitude[p, 1:]))
    cut = mono.path_waveforms[p, path] * mono.path_amplitude[p, path] * (1.0 - 10.0 ** (-20.0 / 20.0))
    shadowed = mono.controlled_scans(rng, p, 0, excess, np.zeros(B)) - math.sqrt(2.0 * mono.dp_snr[0, p]) * cut
    *_, ranges_s = _mono_chain(mono, ep, shadowed, p)
    path_range = 299_792_458.0 * mono.path_delay_s[p, path]
    assert np.sum(np.abs(ranges_s - path_range) < 0.3) <= 0.05 * B


@pytest.mark.slow
def test_monostatic_signal_path_holds_the_person():
    """indoor-monostatic on the signal path with the CFAR chain, 10 runs: the person held by a confirmed track in most
    scans, few false tracks (measured over 20 runs in the closing note)."""
    sim = Simulator(MONO)
    plan = ScanPlan.all_listening(0, 10, 10)
    acc = [run_episode(sim, seed, lambda k: plan, 2.0) for seed in range(10)]
    assert np.mean([a.coverage()[0] for a in acc]) > 0.7
    assert np.mean([a.false_tracks() for a in acc]) < 2.0
