"""Seed 001's exponential background as an MTI (``uwb_env.channel.background_mti``): closed forms, the chain, the
parametric model of through-wall, and the chain's step-6 stillness bound per clock."""

from __future__ import annotations

import math

import numpy as np
import pytest

from uwb_env import scenarios
from uwb_env.channel.background_mti import (
    MtiTable,
    amplitude_fluctuation,
    canceller_response,
    canceller_weights,
    delay_step_s,
    envelope_std_s,
    retained_fraction,
    retained_fraction_history,
)
from uwb_env.detection.envelope import exponential_background, square_law_envelope
from uwb_env.sensing.parametric import ParametricSensor
from uwb_env.sensing.signal.synthesis import pulse_envelope_std_s, unit_pulses
from uwb_env.waveforms.library import WaveformLibrary

ALPHA = 0.9


def test_canceller_weights_sum_to_zero_and_match_the_recursion():
    """h_0 = 1, h_j = -(1 - a) a^(j-1): b_{k-1} = (1 - a) sum a^(j-1) x_{k-j} of b <- a b + (1 - a) x (the chain's)."""
    h = canceller_weights(ALPHA)
    assert h[0] == 1.0 and abs(h.sum()) < 1e-8
    rng = np.random.default_rng(0)
    x = rng.standard_normal(400)
    b = 0.0
    for xi in x[:-1]:
        b = exponential_background(b, xi, ALPHA)
    residue = x[-1] - b  # d_k = x_k - b_{k-1}: the chain subtracts, then updates
    assert residue == pytest.approx(h @ x[::-1][: h.size], abs=1e-6)


def test_wide_envelope_gives_the_classic_mti_response_a_geometric_series():
    """Envelope much wider than the walk, no LPF: g = |sum_j h_j e^{i j theta}|^2 = |1 - z|^2 / |1 - a z|^2."""
    fc = 1.25e9
    delta = np.linspace(0.0, 2.0 / fc, 41)
    g = retained_fraction(delta, ALPHA, envelope_std_s=1.0, carrier_hz=fc)
    theta = 2.0 * math.pi * fc * delta
    z = np.exp(1j * theta)
    closed = np.abs((1.0 - z) / (1.0 - ALPHA * z)) ** 2
    np.testing.assert_allclose(g, closed, atol=1e-8)
    np.testing.assert_allclose(canceller_response(theta, ALPHA), closed, atol=1e-12)
    assert canceller_response(math.pi, ALPHA) == pytest.approx(4.0 / (1.0 + ALPHA) ** 2)


def test_baseband_gaussian_pulse_matches_its_direct_sum():
    """f_c = 0, no LPF: g = (1 - (1 - a) sum a^(j-1) exp(-(j delta)^2 / (2 s^2)))^2, summed directly."""
    s = 0.2e-9
    for delta in (0.0, 0.01e-9, 0.05e-9, 0.2e-9, 1e-9):
        j = np.arange(1, 2000)
        direct = (1.0 - (1.0 - ALPHA) * np.sum(ALPHA ** (j - 1) * np.exp(-0.5 * (j * delta / s) ** 2))) ** 2
        assert retained_fraction(delta, ALPHA, s, 0.0) == pytest.approx(direct, abs=1e-7)


def test_still_target_is_cancelled_and_a_fast_one_kept():
    """g(0) = 0 (coherent), nu 2 / (1 + a) with a fluctuating amplitude; -> 1 once the echo outruns its envelope."""
    s, fc, lpf = 0.22e-9, 1.25e9, 0.2e-9
    assert retained_fraction(0.0, ALPHA, s, fc, lpf) == pytest.approx(0.0, abs=1e-12)
    nu = amplitude_fluctuation(3)
    assert nu == pytest.approx(1.0 - (0.75 * math.sqrt(math.pi)) ** 2 / 2.0)
    assert retained_fraction(0.0, ALPHA, s, fc, lpf, nu) == pytest.approx(nu * 2.0 / (1.0 + ALPHA), rel=1e-6)
    far = delay_step_s(3.0, 0.074)  # 0.22 m of bistatic range per scan: 3 envelope stds
    assert retained_fraction(far, ALPHA, s, fc, lpf) == pytest.approx(1.0, abs=0.01)
    assert amplitude_fluctuation(0) == 0.0 and amplitude_fluctuation(1) == pytest.approx(1.0 - math.pi / 4.0)
    with pytest.raises(ValueError, match="swerling"):
        amplitude_fluctuation(2)


def test_table_interpolates_the_retained_fraction_and_is_even_in_range_rate():
    s, fc = envelope_std_s(1e9), 1.25e9
    table = MtiTable.build(np.array([fc]), np.array([s]), ALPHA, 0.074, 0.2e-9, 0.0)
    rdot = np.array([0.0, 0.033, 0.1, 0.257, 1.6])
    direct = retained_fraction(delay_step_s(rdot, 0.074), ALPHA, s, fc, 0.2e-9)
    np.testing.assert_allclose(table(0, rdot), direct, atol=0.02)
    np.testing.assert_allclose(table(0, -rdot), table(0, rdot))
    assert envelope_std_s(1e9) == pulse_envelope_std_s(1e9)


def _chain_residue(
    rdot: float,
    phases: np.ndarray,
    swerling3: np.random.Generator | None = None,
    tau: np.ndarray | None = None,
    upsample: int = 1,
) -> np.ndarray:
    """The through-wall chain's residue power over the echo's own at the echo's sample, after 200 scans.

    ``tau`` ``(n,)``: the echo's delays per scan instead of a constant ``rdot``; then ``(phases, n)``, every scan's.
    ``upsample``: the chain sampled this many times faster than its clock (the same window and LPF in seconds).

    The chain's own steps (``SignalSensor.detect`` / ``in_sensor``, ``background = "exponential-coherent"``): the
    synthesis' pulse (``unit_pulses``) with a held carrier phase (``coherent_echoes``), delayed rdot T / c more
    every scan, minus the exponential average of the previous raw scans, its square-law envelope with the chain's
    LPF; the echo alone through the same envelope is the reference.
    """
    cfg = scenarios.get("through-wall")
    sig = cfg.sensing.signal
    fs = sig.sample_rate_hz * upsample
    t = np.arange(sig.n_samples * upsample) / fs
    wf = WaveformLibrary(cfg.waveforms)[0]
    fc, s = wf.center_freq_hz, pulse_envelope_std_s(wf.rms_bandwidth_hz)
    lpf = sig.envelope_lpf_s * fs
    every = tau is not None
    if tau is None:
        n = 200
        tau = 40e-9 + delay_step_s(rdot, cfg.sensing.scan_period_s) * (np.arange(n) - (n - 1))
    n = tau.size
    out = []
    for phase in phases:  # carrier phases: a few
        amp = np.ones(n) if swerling3 is None else np.sqrt(swerling3.gamma(2.0, 0.5, n))
        b = np.zeros(t.size)  # the empty room's reference holds no echo
        per_scan = []
        for i in range(n):  # scans
            x = amp[i] * unit_pulses(t, tau[i], phase, fc, s, fs)
            d2 = square_law_envelope(x - b, lpf)
            b = exponential_background(b, x, sig.background_alpha)
            if every or i == n - 1:
                echo = square_law_envelope(unit_pulses(t, tau[i], phase, fc, s, fs), lpf)
                k = round(float(tau[i]) * fs)
                per_scan.append(d2[k] / echo[k])
        out.append(per_scan if every else per_scan[-1])
    return np.array(out)


def _model_residue(rdot: float, fluctuation: float = 0.0) -> float:
    """``retained_fraction`` with through-wall's scan period, average, first waveform's envelope and LPF."""
    cfg = scenarios.get("through-wall")
    sig = cfg.sensing.signal
    wf = WaveformLibrary(cfg.waveforms)[0]
    return retained_fraction(
        delay_step_s(rdot, cfg.sensing.scan_period_s),
        sig.background_alpha,
        pulse_envelope_std_s(wf.rms_bandwidth_hz),
        wf.center_freq_hz,
        sig.envelope_lpf_s,
        fluctuation,
    )


@pytest.mark.parametrize("rdot", [0.0, 0.05, 0.1, 0.2, 1.6])
def test_the_chains_residue_of_a_coherent_echo_matches_the_model(rdot):
    """Eight carrier phases (the model averages over the phase): within 3 standard errors of their mean + 0.03."""
    measured = _chain_residue(rdot, np.arange(8) * 2.0 * math.pi / 8)
    model = _model_residue(rdot)
    se = measured.std(ddof=1) / math.sqrt(measured.size)
    assert abs(measured.mean() - model) <= 3.0 * se + 0.03, (measured.mean(), model, se)


@pytest.mark.parametrize("rdot", [0.0, 0.1])
def test_the_chains_residue_of_a_swerling3_echo_matches_the_model(rdot):
    """Amplitudes drawn per scan (Swerling III, the persons'): the fluctuation's floor nu 2 / (1 + a) at rest."""
    rng = np.random.default_rng(7)
    measured = _chain_residue(rdot, rng.uniform(0.0, 2.0 * math.pi, 48), swerling3=rng)
    model = _model_residue(rdot, amplitude_fluctuation(3))
    se = measured.std(ddof=1) / math.sqrt(measured.size)
    assert abs(measured.mean() - model) <= 3.0 * se + 0.01, (measured.mean(), model, se)


def test_through_wall_parametric_pd_takes_the_mti_loss_with_velocities_only():
    """Through-wall: Pd at a still target's velocity is lower, a walking person's is the Pd at the SNR times the MTI's
    retained fraction at its bistatic range-rate (1.49 at 1.6 m/s with the scenario's alpha 0.4: the canceller's
    high-pass gain); without velocities the positions-only Pd is the radar equation's as before; other scenarios have
    no MTI."""
    cfg = scenarios.get("through-wall")
    s = ParametricSensor(cfg)
    assert s._mti is not None
    far = np.array([[0.0, 5.5]])  # low SNR: the loss shows in Pd
    pd0 = s.detection_probability_at(0, 0, far, 0, 1.0, 3)
    still = s.detection_probability_at(0, 0, far, 0, 1.0, 3, velocities=np.zeros((1, 2)))
    walking = s.detection_probability_at(0, 0, far, 0, 1.0, 3, velocities=np.array([[0.0, 0.8]]))
    assert still[0] < pd0[0] - 0.05
    tx, rx = np.array(cfg.transmitters[0].position_m), np.array(cfg.receivers[0].position_m)
    unit = [(far[0] - q) / np.linalg.norm(far[0] - q) for q in (tx, rx)]
    rdot = float(np.array([0.0, 0.8]) @ (unit[0] + unit[1]))  # bistatic range-rate [m/s]
    gain = float(s.mti_gain(0, rdot))
    assert 1.4 < gain < 1.6
    assert walking[0] == pytest.approx(s.detection_probability_at(0, 0, far, 0, gain, 3)[0], abs=0.005)
    alpha = cfg.sensing.signal.background_alpha  # the scenario's (0.4), not the kernels' tests' ALPHA
    assert s.mti_gain(0, 0.0) == pytest.approx(amplitude_fluctuation(3) * 2.0 / (1.0 + alpha), rel=1e-6)
    coherent = scenarios.get("through-wall", **{"sensing.signal.coherent_echoes": False})
    assert ParametricSensor(coherent)._mti is None
    rsn = ParametricSensor(scenarios.get("indoor-rsn"))
    assert rsn._mti is None
    p = np.array([[1.0, 2.0]])
    np.testing.assert_array_equal(
        rsn.detection_probability_at(0, 0, p, 0), rsn.detection_probability_at(0, 0, p, 0, velocities=np.zeros((1, 2)))
    )


def test_coherent_echoes_need_the_exponential_coherent_background():
    with pytest.raises(ValueError, match="coherent_echoes"):
        scenarios.get("indoor-rsn", **{"sensing.signal.coherent_echoes": True})


def test_step6_stillness_bound_follows_the_chains_clock():
    """The sensor passes 1.5 samples of its own clock to ``associate_toas``: STILL_S at seed 001's 4.5 GHz."""
    from uwb_env.detection.toa_association import STILL_S
    from uwb_env.sensing.signal.sensor import SignalSensor

    cfg = scenarios.get("through-wall", **{"sensing.fidelity": "signal"})
    assert SignalSensor(cfg).still_s == STILL_S
    fast = scenarios.get("through-wall", **{"sensing.fidelity": "signal", "sensing.signal.sample_rate_hz": 9e9})
    assert SignalSensor(fast).still_s == pytest.approx(STILL_S / 2.0)


def test_the_history_form_is_the_steady_state_for_a_constant_range_rate_and_starts_at_one():
    s, fc, lpf, nu = 0.22e-9, 1.25e9, 0.2e-9, amplitude_fluctuation(3)
    for rdot in (0.0, 0.05, 0.3):
        tau = 20e-9 + delay_step_s(rdot, 0.074) * np.arange(150)
        g = retained_fraction_history(np.stack([tau, tau], axis=1), ALPHA, s, fc, lpf, nu)
        assert g[0, 0] == pytest.approx(1.0)  # scan 1: the empty room's reference, nothing subtracted
        steady = retained_fraction(delay_step_s(rdot, 0.074), ALPHA, s, fc, lpf, nu)
        assert g[-1, 1] == pytest.approx(steady, abs=1e-3)
    gone = retained_fraction_history(np.array([20e-9, np.nan, 20e-9]), ALPHA, s, fc)
    # no echo in scan 2: scan 3 subtracts only scan 1's, weight (1 - a) a
    assert gone[1] == 0.0 and gone[2] == pytest.approx((1.0 - (1.0 - ALPHA) * ALPHA) ** 2)


def test_the_chains_residue_of_a_turning_echo_matches_the_history_form():
    """A person turning round: range-rate +1.6 -> -1.6 m/s over 14 scans (a parabolic delay), then back out; the
    chain's residue per scan (eight carrier phases) against ``retained_fraction_history`` on the same delays.

    Per scan at 8 x the chain's clock: the history form is continuous in delay, and the chain reads the residue at the
    echo's nearest sample. With the scenario's fast average (alpha 0.4, the background mostly the last scan's echo
    1.8 samples back at 1.6 m/s) that reading scatters about the form by 0.13 rms per scan at the 4.5 GHz clock (max
    0.26 on the turn; 0.017 rms at 8 x), its mean over the walk +0.06 above it (a residue of ~1.5): the scatter is the
    clock's, not the canceller's, and the mean is asserted at the clock itself."""
    cfg = scenarios.get("through-wall")
    sig, period = cfg.sensing.signal, cfg.sensing.scan_period_s
    wf = WaveformLibrary(cfg.waveforms)[0]
    rdot = np.concatenate([np.full(40, 1.6), np.linspace(1.6, -1.6, 14), np.full(20, -1.6)])
    tau = 30e-9 + np.cumsum(delay_step_s(rdot, period))
    measured = _chain_residue(0.0, np.arange(8) * 2.0 * math.pi / 8, tau=tau, upsample=8)  # (8, n)
    at_clock = _chain_residue(0.0, np.arange(8) * 2.0 * math.pi / 8, tau=tau)
    model = retained_fraction_history(
        tau,
        sig.background_alpha,
        pulse_envelope_std_s(wf.rms_bandwidth_hz),
        wf.center_freq_hz,
        sig.envelope_lpf_s,
    )
    se = measured.std(axis=0, ddof=1) / math.sqrt(measured.shape[0])
    turn = slice(38, 60)
    assert np.all(np.abs(measured.mean(axis=0)[turn] - model[turn]) <= 3.0 * se[turn] + 0.05)
    assert abs(float(np.mean(at_clock.mean(axis=0) - model))) <= 0.1
    # the scenario's fast average (alpha 0.4) cancels a steady echo in the one scan where the turn stops it (0.022,
    # -17 dB; the scan before 0.25); at alpha 0.9 the dip was 0.59 and while walking it kept 1.07, not 1.49
    assert np.sum(model[turn] < 0.1) == 1 and np.sum(model[turn] < 0.3) == 2
    steady = retained_fraction(
        delay_step_s(rdot[turn], period),
        sig.background_alpha,
        pulse_envelope_std_s(wf.rms_bandwidth_hz),
        wf.center_freq_hz,
        sig.envelope_lpf_s,
    )
    assert np.max(np.abs(model[turn] - steady)) > 0.1  # the steady state's constant range-rate misses the turn


@pytest.mark.parametrize(("scenario", "adaptive"), [("through-wall", True), ("indoor-rsn", False)])
def test_an_adaptive_background_starts_on_the_room_as_it_is(scenario, adaptive):
    """Seed 001's running average (through-wall, "exponential-coherent") starts on the static paths with the episode's
    scan-0 fluctuation; a fixed empty-room reference (indoor-rsn) on their nominal gains. Either way what is left is the
    reference's own noise: ``empty_room_scans`` averaged unit-variance scans, std 1 / 4 (16 scans; ~3,000 samples per
    waveform: std error 1.3 %), with a 20 % fluctuation so that the wrong gains would show (0.2 x paths of SNR >> 1)."""
    from uwb_env.rng import RngStreams
    from uwb_env.scene.truth import sample_truth
    from uwb_env.sensing.signal.sensor import SignalSensor

    cfg = scenarios.get(scenario, **{"sensing.fidelity": "signal", "sensing.signal.clutter_fluctuation": 0.2})
    sensor = SignalSensor(cfg)
    rngs = RngStreams.from_seed(3)
    ep = sensor.new_episode(sample_truth(cfg, rngs.truth, sensor.layout), rngs)
    assert np.abs(ep.fluctuation).max() > 0.1  # the draw is large enough to tell the two gains apart
    fluctuated = sensor._background_gain(sensor.path_amplitude, ep.fluctuation)
    gains = {"fluctuated": fluctuated, "nominal": sensor.path_amplitude}
    stds = {}
    for name, gain in gains.items():
        clean = np.sqrt(2.0 * sensor.dp_snr)[..., None] * np.einsum("pl,pln->pn", gain, sensor.path_waveforms)[None]
        stds[name] = float(np.std(ep.reference_scan - clean))
    right, wrong = ("fluctuated", "nominal") if adaptive else ("nominal", "fluctuated")
    noise = 1.0 / math.sqrt(cfg.sensing.signal.empty_room_scans)
    assert stds[right] == pytest.approx(noise, rel=0.05)
    assert stds[wrong] > 2.0 * noise
