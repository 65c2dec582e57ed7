r"""Gaussian-windowed linear chirp pulse train: delay-Doppler Fisher information and range / range-rate CRLB.

Seed 003 eq. 1 transmits B Gaussian chirps every T1, s(t) = sum_b p(t - b T1) / sqrt(B) with the unit-energy pulse
p(t) = (pi kappa^2)^{-1/4} exp((+-j gamma - 1/(2 kappa^2)) t^2) and b = -(B-1)/2 .. (B-1)/2. The seed's printed
R(psi) mixes J and J^{-1}, has range-rate units of (rad/s)^2 m^2/s^2 and is the bound of ONE pulse: it is
dimensionally inconsistent and ignores the train. We derive it again (Kershaw and Evans 1994, "Optimal waveform
selection for tracking systems", IEEE Trans. IT 40(5), extended to the train).

Fisher information of one pulse.
    Received complex envelope mu(t; tau, omega) = a s(t - tau) e^{j omega t} in complex white noise of PSD N0,
    unknown phase. With SNR = E / N0 (E the received energy of the scan), the Fisher information of
    theta = (tau, omega) is J_ij = 2 SNR Re<d_i s, d_j s> minus the phase-nuisance terms, which vanish here because
    the pulse is centred (<t> = 0, <omega> = 0). For p(t):

        |p|^2 is Gaussian with <t^2> = kappa^2 / 2,
        p'(t) = (-t / kappa^2 + 2 j gamma t) p(t)  =>  <omega^2> = int |p'|^2 = 1/(2 kappa^2) + 2 gamma^2 kappa^2,
        Re <-p', j t p> = -2 gamma <t^2> = -gamma kappa^2,

    so   J_1 = 2 SNR [[1/(2 kappa^2) + 2 gamma^2 kappa^2, -gamma kappa^2], [-gamma kappa^2, kappa^2 / 2]],
    det J_1 = SNR^2, and
    J_1^{-1} = (1 / SNR) [[kappa^2, 2 gamma kappa^2], [2 gamma kappa^2, 1/kappa^2 + 4 gamma^2 kappa^2]].

The pulse train (what the seed transmits and what its delay-Doppler image processes).
    The pulses do not overlap (T1 >> kappa), so the moments of |s|^2 add over the pulses with weight 1/B: the spectrum
    moment <omega^2> and the cross term are those of one pulse (int p' p* dt = 0 for the centred chirp, so the offset
    b T1 of pulse b adds nothing to <t omega>), and the time spread gains the spread of the pulse centres,
    <t^2> = kappa^2 / 2 + T_b,  T_b = T1^2 (B^2 - 1) / 12 (the variance of b T1 over the B pulses). Hence

        J = 2 SNR [[A, -gamma kappa^2], [-gamma kappa^2, kappa^2 / 2 + T_b]],   A = 1/(2 kappa^2) + 2 gamma^2 kappa^2,
        det J = 4 SNR^2 D,  D = 1/4 + A T_b,
        J^{-1} = 1 / (2 SNR D) [[kappa^2 / 2 + T_b, gamma kappa^2], [gamma kappa^2, A]],

    which is J_1^{-1} for B = 1 (T_b = 0, D = 1/4). Bistatic range r = c tau and range-rate
    rdot = -lambda omega / (2 pi) (a closing target raises the frequency), so U = diag(c, -lambda / (2 pi)) and
    R = U J^{-1} U^T.

What the train does (urban-intersection: kappa 0.5 / 1.375 us, 40 MHz, 4 GHz, B = 25, T1 = 10 ms, T_b = 5.2e-3 s^2).
    * Range-rate: var(omega) = A / (2 SNR D) ~ 1 / (2 SNR T_b): the Doppler resolution of the dwell, 1 / (B T1) =
      4 Hz, replaces the pulse's 1 / kappa (MHz). At SNR = 15 the range-rate std is 0.03 m/s instead of 4e5 m/s.
    * Range: with omega pinned by the train the delay-Doppler ridge of the chirp no longer leaks into delay:
      var(tau) ~ 1 / (2 SNR A) = 1 / (SNR pi^2 B_w^2) for gamma kappa >> 1/kappa (B_w the swept bandwidth), i.e. the
      bandwidth sets the range accuracy (0.61 m at SNR 15) and it barely depends on kappa -- a longer pulse only brings
      more energy.
    * Up- against down-sweep: the only difference is the sign of gamma kappa^2 in J. Its correlation coefficient is
      gamma kappa^2 / sqrt((kappa^2/2 + T_b) A) = 1.4e-5 for the long chirp, so R_up and R_down agree to 1e-5 and the
      scheduler cannot tell them apart by their bound. The other physical difference is the range-Doppler coupling of
      a chirp compressed without Doppler compensation (:func:`range_doppler_coupling_m`): the peak moves by
      c pi rdot / (lambda gamma), +-5.5 mm at 20 m/s for the long chirp, 1/100 of the range std. In this geometry
      up- and down-sweep are the same waveform to within a centimetre; the library adds pulse-repetition diversity
      for a real trade-off (see ``uwb_env.scenarios.urban_intersection``).
    * Doppler ambiguity: the train samples the Doppler phase once per T1, so the image measures f modulo 1 / T1 and
      the range-rate modulo lambda / T1 (:attr:`ChirpWaveform.range_rate_ambiguity_mps`, 7.5 m/s at T1 = 10 ms). The
      bound above is local (the curvature of the likelihood peak nearest the truth); which alias is right is not in
      it. The chain reports the folded range-rate; the tracker unwraps the innovation around its prediction.
    * Range migration: the bound assumes the target stays in its range cell for the dwell. Seed 003's matched filter
      (eq. 5) compresses each pulse at one delay and sums the pulses at the Doppler's phase ramp; it does not follow
      the range walk rdot b T1 of pulse b (no keystone). The coherent sum then loses
      :func:`range_migration_gain` = [mean_b exp(-(rdot T1 b)^2 / (4 sigma_r^2))]^2 of the power, sigma_r the
      compressed pulse's range spread (:func:`compressed_range_spread_m`, 2.39 m at 40 MHz): at most 0.8 dB for the
      seed's chirps at 20 m/s, but 2.7 dB at 10 m/s and 7.5 dB at 20 m/s for a 160 MHz chirp with 4x finer range.
      Bandwidth buys range accuracy and costs detection of fast radial movers, and a shorter PRI (7 ms: 0.30x less
      walk) buys some of it back -- a trade-off that depends on the target's range-rate, i.e. a scheduling problem.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from uwb_env.config import ChirpWaveformConfig
from uwb_env.constants import SPEED_OF_LIGHT_MPS
from uwb_env.typing import FloatArray


def chirp_rate(pulse_duration_s: float, bandwidth_hz: float, sweep: str) -> float:
    """Gamma [rad/s^2] sweeping ``bandwidth_hz`` over t in [-kappa, kappa]: gamma = +-pi B / (2 kappa)."""
    sign = 1.0 if sweep == "up" else -1.0
    return sign * math.pi * bandwidth_hz / (2.0 * pulse_duration_s)


def pulse_train_time_spread(n_pulses: int, pri_s: float) -> float:
    """T_b = T1^2 (B^2 - 1) / 12 [s^2]: the variance of the pulse centres b T1, b = -(B-1)/2 .. (B-1)/2."""
    return pri_s**2 * (n_pulses**2 - 1) / 12.0


def gaussian_chirp_fim(
    kappa: float, gamma: float, snr: FloatArray, n_pulses: int = 1, pri_s: float = 0.0
) -> FloatArray:
    """Delay-Doppler Fisher information of a train of ``n_pulses`` Gaussian chirps every ``pri_s`` (module docstring).

    Args:
        kappa: pulse duration parameter [s]; gamma: chirp rate [rad/s^2]; snr: ``(N,)`` E/N0 of the whole train
        (linear); n_pulses, pri_s: B and T1 [s] (the default is one pulse).

    Returns:
        ``(N, 2, 2)`` J for (tau [s], omega [rad/s]).
    """
    snr = np.asarray(snr, dtype=float)
    spread = kappa**2 / 2.0 + pulse_train_time_spread(n_pulses, pri_s)
    base = np.array([[1.0 / (2 * kappa**2) + 2 * gamma**2 * kappa**2, -gamma * kappa**2], [-gamma * kappa**2, spread]])
    return 2.0 * snr[..., None, None] * base


def gaussian_chirp_range_rate_covariance(
    kappa: float, gamma: float, wavelength_m: float, snr: FloatArray, n_pulses: int = 1, pri_s: float = 0.0
) -> FloatArray:
    """CRLB covariance of (bistatic range [m], range-rate [m/s]), closed form R = U J^-1 U^T (module docstring).

    Args:
        kappa [s], gamma [rad/s^2], wavelength_m [m], snr ``(N,)`` E/N0 of the train (linear, > 0); n_pulses, pri_s:
        B and T1 [s] (the default is one pulse).

    Returns:
        ``(N, 2, 2)`` R.
    """
    inv = 1.0 / np.asarray(snr, dtype=float)
    q = wavelength_m / (2.0 * math.pi)
    c = SPEED_OF_LIGHT_MPS
    a = 1.0 / (2 * kappa**2) + 2 * gamma**2 * kappa**2
    spread = kappa**2 / 2.0 + pulse_train_time_spread(n_pulses, pri_s)
    d2 = 2.0 * (0.25 + a * pulse_train_time_spread(n_pulses, pri_s))  # 2 D
    base = np.array(
        [
            [c**2 * spread / d2, -c * q * gamma * kappa**2 / d2],
            [-c * q * gamma * kappa**2 / d2, q**2 * a / d2],
        ]
    )
    return inv[..., None, None] * base


def compressed_range_spread_m(kappa: float, gamma: float) -> float:
    """sigma_r [m]: std in bistatic range of the compressed pulse's power |chi(tau, 0)|^2 = exp(-tau^2 (a + gamma^2/a)).

    a = 1 / (2 kappa^2). chi(tau, 0) of the Gaussian chirp is real (its phase terms cancel), so the amplitude at a
    range offset d is exp(-d^2 / (4 sigma_r^2)) with sigma_r = c / sqrt(2 (a + gamma^2 / a)).
    """
    a = 1.0 / (2.0 * kappa**2)
    return SPEED_OF_LIGHT_MPS / math.sqrt(2.0 * (a + gamma**2 / a))


def range_migration_gain(
    range_rate_mps: FloatArray, range_spread_m: FloatArray | float, pri_s: FloatArray | float, n_pulses: int
) -> FloatArray:
    """Power gain (<= 1) of the train's coherent sum for a target walking in range across the dwell (module docstring).

    Pulse b = -(B-1)/2 .. (B-1)/2 sees the target d_b = rdot T1 b from the scan's range; the filter sums the B
    compressed amplitudes exp(-d_b^2 / (4 sigma_r^2)) at the centre delay (where the symmetric sum peaks):
    G = [mean_b exp(-d_b^2 / (4 sigma_r^2))]^2. No walk (rdot = 0 or B = 1) gives 1.

    Args: range_rate_mps [m/s], range_spread_m sigma_r [m], pri_s T1 [s] (arrays broadcast); n_pulses B.
    Returns the broadcast shape.
    """
    b = np.arange(n_pulses) - 0.5 * (n_pulses - 1)
    walk = np.asarray(range_rate_mps * np.asarray(pri_s) / (2.0 * np.asarray(range_spread_m)), dtype=float)
    amp = np.exp(-np.square(walk[..., None] * b)).mean(axis=-1)
    return amp * amp


def range_migration_accuracy(
    range_rate_mps: FloatArray, range_spread_m: float, pri_s: float, n_pulses: int
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """What the range walk does to the train's peak: ``(gain, c_range, c_rate, walk_m)``, each of the input shape.

    ``gain`` is :func:`range_migration_gain` (the peak power: detection).

    The filter compresses pulse b at the centre delay, where the walked echo sits d_b = rdot T1 b away, so pulse b
    contributes g_b = exp(-d_b^2 / (4 sigma_r^2)) of its amplitude. To first order the peak's delay error is
    -n'(0) / s''(0), with the noise derivative n' that of the matched (unwalked) filter and the signal curvature
    s''(0) the walked one: var(range) = var_0 / c_range^2, c_range = mean_b g_b (1 - d_b^2 / (2 sigma_r^2)) (-> the
    continuous limit exp(-D^2 / (4 sigma_r^2)), D the half-walk). In Doppler, the pulses weigh g_b in the curvature of
    the uniformly weighted (DFT) filter: var(rdot) = var_0 / c_rate^2, c_rate = sum_b g_b b^2 / sum_b b^2. Both are
    1 without walk; var_0 is the unwalked bound at the unwalked SNR (the walk lowers the peak by ``gain`` but leaves
    the noise derivative alone). The first order fails when the walked peak is flat (c_range << 1): the estimate
    then wanders over the walk, ``walk_m`` = D = |rdot| T1 (B-1) / 2, and var(range) <= var_0 + D^2 / 3 bounds it
    (the sensor takes the smaller). Checked against the chain's spread at 160 MHz, 20 dB (std / bound, chain vs
    this): 1.43 / 1.32 at 5 m/s, 2.89 / 3.00 at 10, 10.5 / 11.9 at 15, 14.3 / 22.7 at 19.5 m/s (the cap is
    conservative); range-rate 1.27 / 1.18, 2.02 / 1.85, 6.8 / 3.5, 8.2 / 6.7 (the joint delay-Doppler fit couples
    the walked delay error into the Doppler, which this first order misses at 15 m/s).

    Args: range_rate_mps [m/s] (any shape), range_spread_m sigma_r [m], pri_s T1 [s], n_pulses B.
    """
    b = np.arange(n_pulses) - 0.5 * (n_pulses - 1)
    rdot = np.asarray(range_rate_mps, dtype=float)
    d = rdot[..., None] * pri_s * b
    u = np.square(d) / (4.0 * range_spread_m**2)
    g = np.exp(-u)
    c_range = (g * (1.0 - 2.0 * u)).mean(axis=-1)
    b2 = np.square(b)
    c_rate = (g * b2).sum(axis=-1) / max(float(b2.sum()), 1.0) if n_pulses > 1 else np.ones(rdot.shape)
    return np.square(g.mean(axis=-1)), c_range, c_rate, np.abs(rdot) * pri_s * 0.5 * (n_pulses - 1)


def fold_periodic(values: FloatArray, period: FloatArray | float) -> FloatArray:
    """Values folded into [-period / 2, period / 2); unchanged where the period is inf. Every argument broadcasts.

    What a pulse train measures of a Doppler (period 1 / T1 [Hz]) or of a range-rate (period lambda / T1 [m/s]).
    """
    period = np.asarray(period, dtype=float)
    finite = np.isfinite(period)
    safe = np.where(finite, period, 1.0)
    return np.where(finite, values - safe * np.floor(values / safe + 0.5), values)


def range_doppler_coupling_m(kappa: float, gamma: float, wavelength_m: float, range_rate_mps: FloatArray) -> FloatArray:
    """Range offset [m] of the compressed peak of a chirp with Doppler, compressed by the un-shifted replica.

    The ambiguity function of p is |chi(tau, omega)|^2 = exp(-a tau^2 - (2 gamma tau + omega)^2 / (4 a)) / ...
    with a = 1 / (2 kappa^2); for a given Doppler omega it peaks at tau* = -gamma omega / (2 (a^2 + gamma^2)).
    With omega = -2 pi rdot / lambda the peak sits c tau* = c pi gamma rdot / (lambda (a^2 + gamma^2)) away from the
    true bistatic range: positive for an up-sweep and a receding target, opposite for a down-sweep.

    Args: kappa [s], gamma [rad/s^2], wavelength_m [m], range_rate_mps ``(N,)`` [m/s]. Returns ``(N,)`` [m].
    """
    a = 1.0 / (2.0 * kappa**2)
    omega = -2.0 * math.pi * np.asarray(range_rate_mps, dtype=float) / wavelength_m
    return -SPEED_OF_LIGHT_MPS * gamma * omega / (2.0 * (a**2 + gamma**2))


@dataclass(frozen=True, slots=True)
class ChirpWaveform:
    """A Gaussian chirp of the library, with its CRLB, energy and dwell (built from ChirpWaveformConfig)."""

    config: ChirpWaveformConfig

    measurement_dim: int = 2
    measurement_names: tuple[str, ...] = ("bistatic_range", "range_rate")

    @property
    def name(self) -> str:
        """Waveform name."""
        return self.config.name

    @property
    def gamma(self) -> float:
        """Chirp rate [rad/s^2] (negative for a down-sweep)."""
        c = self.config
        return chirp_rate(c.pulse_duration_s, c.bandwidth_hz, c.sweep)

    @property
    def wavelength_m(self) -> float:
        """Carrier wavelength [m]."""
        return SPEED_OF_LIGHT_MPS / self.config.carrier_hz

    @property
    def center_freq_hz(self) -> float:
        """Carrier frequency [Hz]."""
        return self.config.carrier_hz

    @property
    def rms_bandwidth_hz(self) -> float:
        """RMS bandwidth sqrt(<omega^2>) / (2 pi) [Hz] of the chirp's (Gaussian) spectrum."""
        k, g = self.config.pulse_duration_s, self.gamma
        return math.sqrt(1.0 / (2 * k**2) + 2 * g**2 * k**2) / (2 * math.pi)

    @property
    def dwell_time_s(self) -> float:
        """Time the scan occupies the transmitter: n_pulses x PRI [s]."""
        return self.config.n_pulses * self.config.pri_s

    def scan_energy_j(self, tx_power_w: float) -> float:
        """Transmitted energy per scan [J]: n_pulses x P_peak x kappa sqrt(pi) (integral of the window)."""
        return self.config.n_pulses * tx_power_w * self.config.pulse_duration_s * math.sqrt(math.pi)

    @property
    def range_spread_m(self) -> float:
        """sigma_r [m] of the compressed pulse (:func:`compressed_range_spread_m`)."""
        return compressed_range_spread_m(self.config.pulse_duration_s, self.gamma)

    def migration_gain(self, range_rate_mps: FloatArray) -> FloatArray:
        """:func:`range_migration_gain` of this train for bistatic range-rates ``range_rate_mps`` [m/s]."""
        c = self.config
        return range_migration_gain(range_rate_mps, self.range_spread_m, c.pri_s, c.n_pulses)

    @property
    def range_rate_ambiguity_mps(self) -> float:
        """Period [m/s] of the measured bistatic range-rate: lambda / T1 (the Doppler is sampled once per PRI).

        ``inf`` for a single pulse, whose Doppler (from the chirp's own curvature) is unambiguous.
        """
        c = self.config
        return self.wavelength_m / c.pri_s if c.n_pulses > 1 else math.inf

    @property
    def doppler_resolution_hz(self) -> float:
        """Doppler resolution [Hz] of the dwell, 1 / (B T1) (one pulse: 1 / kappa)."""
        c = self.config
        return 1.0 / (c.n_pulses * c.pri_s) if c.n_pulses > 1 else 1.0 / c.pulse_duration_s

    def fisher_information(self, snr: FloatArray) -> FloatArray:
        """``(N, 2, 2)`` delay-Doppler Fisher information of the train at E/N0 ``snr`` (N,)."""
        c = self.config
        return gaussian_chirp_fim(c.pulse_duration_s, self.gamma, snr, c.n_pulses, c.pri_s)

    @property
    def unit_covariance(self) -> FloatArray:
        """``(2, 2)`` covariance at SNR = 1; the CRLB scales as 1 / SNR, so R(snr) = unit_covariance / snr."""
        return self.covariance(np.ones(1))[0]

    def covariance(self, snr: FloatArray) -> FloatArray:
        """``(N, 2, 2)`` (range, range-rate) CRLB covariance of the train at E/N0 ``snr`` (N,)."""
        c = self.config
        return gaussian_chirp_range_rate_covariance(
            c.pulse_duration_s, self.gamma, self.wavelength_m, snr, c.n_pulses, c.pri_s
        )
