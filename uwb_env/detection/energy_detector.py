r"""Seed 002's energy-detector (ED) ToA estimator (section III): BPZF, square law, integrate and dump, threshold.

The ED integrates the squared band-pass-filtered signal over T_int and takes the first energy bin above a threshold.

Every kernel works on a batch of sampled scans ``(B, N)`` (one row per radar pair) in sample units (seconds x fs).

* Band-pass zonal filter (BPZF): the scan's spectrum is kept in [f_lo, f_hi] (an ideal, zonal band-pass done with
  the FFT) and zeroed elsewhere. White noise of per-sample variance sigma^2 leaves it with variance
  sigma^2 x 2 (f_hi - f_lo) / fs.
* Energy bins: z_n = sum over the samples of bin n of y_k^2, bin n = [s + n M, s + (n + 1) M) with M = T_int fs
  samples (fractional) from the window start s (fractional). The cumulative energy S(x) = sum_{k < floor x} y_k^2 +
  (x - floor x) y_{floor x}^2 is linear within a sample, so z_n = S(s + (n + 1) M) - S(s + n M) is exact for
  integer edges and splits a sample's energy in proportion to its overlap otherwise. N_bin = floor(T_a / T_int)
  bins; a bin that runs past the end of the scan is NaN (it is no bin of the window).
* Noise energy of a bin: band-limited noise of bandwidth W over T_int has about 2 W T_int + 1 degrees of freedom
  (Slepian's count; the +1 is the bin's edges, where the noise's correlation is cut), so z_n (noise only) ~
  Gamma(shape W T_int + 1/2, mean M sigma_f^2) with sigma_f^2 its per-sample variance (the shape matches the
  measured variance within 1 %, ``tests/unit/test_energy_detector.py``); :func:`noise_energy_threshold` inverts it
  for a false-alarm probability over the window.
* Pulse accumulation. Seed 002's ED sums the energies of the N_pulse received pulses r_p = s + n_p (eq. 1), where
  the signal path synthesises their coherent sum. Per sample, sum_p r_p^2 = N rbar^2 + sum_p (r_p - rbar)^2 and the
  second term is sum_p (n_p - nbar)^2, independent of the mean (Cochran): in the scan's units (noise variance 1
  after coherent integration, scan = sqrt(N) rbar / sigma_1) the accumulated energy is the scan's energy plus noise
  energy of N - 1 further degrees of freedom per (filtered) sample. So a non-coherent bin energy is exactly
  z_n + Gamma(shape (N - 1) (W T_int + 1/2), mean (N - 1) M sigma_f'^2) (sigma_f'^2 the BPZF's kept fraction of
  unit noise; :func:`accumulated_noise_energy`): the same signal, N times the noise degrees of freedom -- the
  non-coherent integration loss that makes the ED need a higher per-pulse SNR than a coherent receiver.
* Threshold-crossing ToA: the first bin n_hat with z_n > xi. The normalised threshold of the threshold-based ED-ToA
  literature (Dardari, Chong & Win 2008, the estimator of the seed's [12]) is xi = z_min + alpha (z_max - z_min)
  over the window's bins, alpha in (0, 1). Seed 002 instead picks xi per SNR by an exhaustive a-posteriori search of
  the ToA RMSE, which needs the true ToA and the SNR; it is replaced here by the normalised threshold with one alpha
  (a configuration value), chosen offline by the same exhaustive search over alpha on synthetic scans
  (:func:`search_threshold_ratio`: alpha 0.8-0.99 at every SNR for a single-pulse echo). An optional absolute floor
  xi_0, the noise bin energy at a false-alarm probability over the window (noise power knowledge, as the seed's
  footnote 8 alternative [26]), makes it a detector too: xi = max(xi, xi_0), and a window whose z_max does not
  exceed xi_0 yields no ToA.

ToA at the bin's centre, tau_hat = s + (n_hat + 1/2) M. Why the centre and its bias: at high SNR the crossing bin is
the bin that holds the echo, so with the echo's delay tau uniform within a bin (no prior) the centre gives the
error tau_hat - tau uniform on [-T_int / 2, T_int / 2): zero mean and std T_int / sqrt(12), seed 002's high-SNR
asymptote; the bin's start would add a bias of -T_int / 2.

Bias of an echo of duration D (times in seconds, T = T_int). A noiseless rectangular echo [tau, tau + D), D <= T,
starting u into bin k, puts energy proportional to T - u in bin k and D - (T - u) in bin k + 1 when T - u < D. Bin k
is the first crossing unless it holds at most alpha times the largest bin (z_min = 0: some bin is empty); that
happens when T - u <= alpha (D - (T - u)), i.e. T - u <= alpha D / (1 + alpha) (< D / 2: bin k + 1 is then the
largest), and the estimate is bin k + 1's centre, T later. Averaged over u uniform in [0, T):

    E[tau_hat - tau] = alpha D / (1 + alpha)        (relative to the echo's start; D -> 0: unbiased)

the error lying in [-T/2, T/2) or, for the late fraction, [T/2, 3T/2). Relative to the echo's centre tau + D/2 the
bias is -D (1 - alpha) / (2 (1 + alpha)). For a symmetric echo of energy profile Gaussian with std s_e about its
centre (the signal path's pulse: s_e = s / sqrt 2, s the pulse envelope's std, 0.2 ns at 1.7 GHz), centred u into
bin k, bin k - 1 holds q = Phi(-u / s_e) and is the first crossing when q > alpha (1 - q), i.e.
u < s_e Phi^-1(1 / (1 + alpha)), so E[tau_hat - tau] = -s_e Phi^-1(1 / (1 + alpha)) (s_e << T): -0.11 ns (-3.4 cm of
range) at alpha = 0.4, -0.006 ns at the default 0.95, negligible against T_int / sqrt(12) (0.35 m of range at
4 ns), and not corrected.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.stats import gamma

from uwb_env.typing import BoolArray, FloatArray, IntArray


def zonal_bandpass(x: FloatArray, fs_hz: float, f_lo_hz: float, f_hi_hz: float) -> FloatArray:
    """``(..., N)`` real signals ``x`` with their spectrum kept in [f_lo, f_hi] and zeroed elsewhere (FFT)."""
    n = x.shape[-1]
    spec = np.fft.rfft(x, axis=-1)
    f = np.fft.rfftfreq(n, 1.0 / fs_hz)
    spec[..., (f < f_lo_hz) | (f > f_hi_hz)] = 0.0
    return np.fft.irfft(spec, n, axis=-1)


def zonal_noise_variance(n: int, fs_hz: float, f_lo_hz: float, f_hi_hz: float) -> float:
    """Per-sample variance (per unit input variance) of white noise of ``n`` samples after :func:`zonal_bandpass`.

    A real white sequence has equal power in its rfft bins (the DC and Nyquist bins half as much counted twice
    over); the kept fraction of the ``n`` degrees of freedom is the variance that remains.
    """
    f = np.fft.rfftfreq(n, 1.0 / fs_hz)
    keep = (f >= f_lo_hz) & (f <= f_hi_hz)
    dof = np.full(f.size, 2.0)
    dof[0] = 1.0
    if n % 2 == 0:
        dof[-1] = 1.0
    return float(dof[keep].sum() / n)


def bin_energies(y: FloatArray, start: FloatArray, bin_len: float, n_bins: int) -> FloatArray:
    """``(B, n_bins)`` energies sum y_k^2 of consecutive bins of ``bin_len`` samples from ``start`` (B,) [samples].

    Fractional edges split a sample's energy in proportion (module docstring); bins that begin before sample 0 are
    clipped at 0, bins that end past the scan are NaN.
    """
    y = np.asarray(y, dtype=float)
    n = y.shape[-1]
    e = np.square(y)
    cum = np.concatenate([np.zeros((*e.shape[:-1], 1)), np.cumsum(e, axis=-1)], axis=-1)  # (B, N + 1)
    edges = np.asarray(start, dtype=float)[..., None] + bin_len * np.arange(n_bins + 1)  # (B, n_bins + 1)
    x = np.clip(edges, 0.0, float(n))
    i = np.minimum(np.floor(x).astype(np.int64), n - 1)
    frac = x - i
    s = np.take_along_axis(cum, i, axis=-1) + frac * np.take_along_axis(e, i, axis=-1)
    z = np.diff(s, axis=-1)
    return np.where(edges[..., 1:] <= n + 1e-9, z, np.nan)


def valid_extremes(z: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``(B,)`` z_min and z_max over each row's valid (non-NaN) bins of ``z`` (B, n_bins); +inf, -inf if none."""
    bad = np.isnan(z)
    return np.where(bad, np.inf, z).min(axis=-1), np.where(bad, -np.inf, z).max(axis=-1)


def normalized_threshold(z: FloatArray, alpha: float) -> FloatArray:
    """``(B,)`` xi = z_min + alpha (z_max - z_min) over each row's valid (non-NaN) bins ``z`` (B, n_bins).

    A row without a valid bin gets +inf (no crossing).
    """
    lo, hi = valid_extremes(z)
    with np.errstate(invalid="ignore"):
        return np.where(np.isfinite(lo), lo + alpha * (hi - lo), np.inf)


def noise_energy_threshold(pfa_window: float, n_bins: int, mean: float, shape: float) -> float:
    """Bin energy that noise alone exceeds in some bin of ``n_bins`` with probability ``pfa_window``.

    Noise bin energy ~ Gamma(``shape``, ``mean`` / ``shape``) (module docstring: shape W T_int + 1/2 for one
    filtered scan); ``pfa_window`` >= 1 gives 0 (no floor).
    """
    if pfa_window >= 1.0:
        return 0.0
    pfa_bin = -math.expm1(math.log1p(-pfa_window) / n_bins)  # 1 - (1 - P)^(1 / n_bins)
    return float(gamma.isf(pfa_bin, shape, scale=mean / shape))


def accumulated_noise_energy(uniform: FloatArray, extra_pulses: FloatArray, mean: float, shape: float) -> FloatArray:
    """Noise energy that non-coherent accumulation of ``extra_pulses`` (B,) more pulses adds to bins (B, n_bins).

    Gamma(``extra_pulses`` x ``shape``, ``mean`` / ``shape``) by inversion of ``uniform`` (B, n_bins) draws in (0, 1)
    (one bin of one pulse: noise energy of mean ``mean`` and Gamma ``shape``); 0 where ``extra_pulses`` is 0.
    Drawing uniforms keeps the random stream independent of the number of pulses (common random numbers).
    """
    k = np.asarray(extra_pulses, dtype=float)[..., None] * shape
    out = gamma.ppf(uniform, np.maximum(k, 1e-12), scale=mean / shape)
    return np.where(k > 0.0, out, 0.0)


def threshold_crossing(z: FloatArray, threshold: FloatArray) -> tuple[IntArray, BoolArray]:
    """``(B,)`` first bin of ``z`` (B, n_bins) above ``threshold`` (B,), and whether any is (NaN bins never are).

    A row with no bin above its threshold gets index 0 and ``False``.
    """
    above = np.nan_to_num(z, nan=-np.inf) > np.asarray(threshold)[..., None]
    return np.argmax(above, axis=-1), above.any(axis=-1)


def energy_detector_toa(
    z: FloatArray, start: FloatArray, bin_len: float, alpha: float, floor: float = 0.0
) -> tuple[FloatArray, BoolArray, IntArray]:
    """Threshold-crossing ToA [samples] of energy bins ``z`` (B, n_bins) starting at ``start`` (B,).

    Threshold max(z_min + alpha (z_max - z_min), ``floor``); ToA at the crossing bin's centre,
    start + (n_hat + 1/2) ``bin_len``. Returns the ToAs (B,), whether each row crossed, and the bins (B,).
    """
    xi = np.maximum(normalized_threshold(z, alpha), floor)
    k, hit = threshold_crossing(z, xi)
    return np.asarray(start, dtype=float) + (k + 0.5) * bin_len, hit, k


# ------------------------------------------------------------------------------------------- offline calibration
def synthetic_toa_errors(
    rng: np.random.Generator,
    snr_db: float,
    alpha: float,
    integration_time_s: float,
    observation_window_s: float,
    *,
    n_trials: int = 1000,
    n_pulses: int = 1,
    fs_hz: float = 16.4e9,
    center_freq_hz: float = 3.95e9,
    bandwidth_hz: float = 1.7e9,
    start: float = 50.0,
) -> FloatArray:
    """``(n_trials,)`` ToA errors tau_hat - tau [s] of the ED on synthetic scans (offline calibration, tests).

    Each trial: one Gaussian-spectrum pulse (the signal path's, -10 dB band ``bandwidth_hz`` about
    ``center_freq_hz``) of integrated SNR ``snr_db`` (E/N0 of the scan, sum p^2 = 2 SNR) at a delay uniform over
    the observation window that starts at sample ``start``, random carrier phase, unit white noise; BPZF over the
    -10 dB band, T_int bins over floor(T_a / T_int) bins, non-coherent accumulation of ``n_pulses`` pulses, the
    normalised threshold ``alpha`` (no absolute floor).
    """
    from uwb_env.sensing.signal.synthesis import pulse_envelope_std_s, unit_pulses
    from uwb_env.waveforms.impulse import gaussian_pulse_rms_bandwidth

    m = integration_time_s * fs_hz
    n_bins = max(1, math.floor(observation_window_s / integration_time_s + 1e-9))
    n = math.ceil(start + n_bins * m) + 64
    t = np.arange(n) / fs_hz
    s = pulse_envelope_std_s(gaussian_pulse_rms_bandwidth(bandwidth_hz))
    tau = (start + rng.uniform(0.0, n_bins * m, n_trials)) / fs_hz
    pulses = unit_pulses(t, tau, rng.uniform(0.0, 2.0 * math.pi, n_trials), center_freq_hz, s, fs_hz)
    band = (center_freq_hz - 0.5 * bandwidth_hz, center_freq_hz + 0.5 * bandwidth_hz)
    y = zonal_bandpass(
        math.sqrt(2.0 * 10.0 ** (snr_db / 10.0)) * pulses + rng.standard_normal((n_trials, n)), fs_hz, *band
    )
    first = np.full(n_trials, start)
    z = bin_energies(y, first, m, n_bins)
    if n_pulses > 1:
        kept = zonal_noise_variance(n, fs_hz, *band)
        extra = np.full(n_trials, n_pulses - 1.0)
        z = z + accumulated_noise_energy(
            rng.uniform(size=z.shape), extra, m * kept, kept * 0.5 * fs_hz * integration_time_s
        )
    toa, _, _ = energy_detector_toa(z, first, m, alpha)
    return toa / fs_hz - tau


def search_threshold_ratio(
    rng: np.random.Generator,
    snr_db: FloatArray,
    alphas: FloatArray,
    integration_time_s: float,
    observation_window_s: float,
    **kwargs: object,
) -> tuple[FloatArray, FloatArray]:
    """Seed 002's exhaustive a-posteriori threshold search, offline, over the normalised threshold.

    For each SNR of ``snr_db`` (S,) the ``alphas`` (A,) are tried on the same synthetic trials
    (:func:`synthetic_toa_errors`, ``kwargs`` passed on) and the one of least ToA RMSE kept. Returns the best alpha
    (S,) and the RMSE table (S, A) [s].
    """
    rmse = np.empty((len(snr_db), len(alphas)))
    for i, snr in enumerate(np.asarray(snr_db, dtype=float)):
        seed = int(rng.integers(2**63))
        for j, a in enumerate(np.asarray(alphas, dtype=float)):  # common random numbers across the alphas
            e = synthetic_toa_errors(
                np.random.default_rng(seed), snr, a, integration_time_s, observation_window_s, **kwargs
            )
            rmse[i, j] = math.sqrt(float(np.mean(e * e)))
    return np.asarray(alphas, dtype=float)[np.argmin(rmse, axis=1)], rmse
