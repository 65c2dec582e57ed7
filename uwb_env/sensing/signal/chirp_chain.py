r"""Seed 003's signal chain for Gaussian chirp pulse trains: synthesis, matched filter, delay-Doppler images.

Signal (seed 003 eqs. 1-3). One pulse is the unit-energy Gaussian chirp

    s(t) = (pi kappa^2)^(-1/4) exp((j gamma - 1 / (2 kappa^2)) t^2),   gamma = +-pi B_w / (2 kappa)

(``uwb_env.waveforms.chirp.chirp_rate``; + up-sweep, - down-sweep), transmitted B times at t_b = b T1,
b = -(B-1)/2 .. (B-1)/2 (centred on the scan time, as eq. 1). Eq. 1 divides the train by B^(1/2) to give it unit
energy; here every pulse has unit energy and the amplitudes carry the energy per pulse. Its Fourier transform
(S(f) = int s(t) e^{-j 2 pi f t} dt) is

    S(f) = (pi kappa^2)^(-1/4) sqrt(pi / a) exp(-pi^2 f^2 / a),   a = 1 / (2 kappa^2) - j gamma,

a Gaussian power spectrum |S|^2 of standard deviation sigma_f = sqrt(1 / (2 kappa^2) + 2 gamma^2 kappa^2) / (2 pi),
i.e. B_w / (2 sqrt 2) = 14.1 MHz for the seed's 40 MHz (the amplitude falls to e^{-1/2} at +-B_w / 2).

Received signal (eqs. 2-3), element l of a uniform linear array, path p of amplitude A_p (complex: sqrt of the
received energy per pulse times e^{j phi_p}, phi_p the seed's random phase), bistatic length L_p and range-rate
rdot_p at the scan time, direction of arrival theta_p:

    tau_p(b) = (L_p + rdot_p b T1) / c                   delay of pulse b (range walk across the dwell)
    nu_p     = -rdot_p / lambda                           Doppler (a closing path raises the frequency)
    y_{l,b}(t) = sum_p A_p e^{-j 2 pi l d sin(theta_p - boresight) / lambda} e^{j 2 pi nu_p b T1}
                   s(t - tau_p(b)) e^{j 2 pi nu_p (t - tau_p(b))}  +  e_{l,b}(t)

with t the fast time since pulse b left. The slow-time phase e^{j 2 pi nu b T1} is the carrier phase
e^{-j 2 pi fc tau_p(b)} of the range walk (up to a constant absorbed into phi_p). The intra-pulse Doppler
e^{j 2 pi nu t} is kept exactly: it costs nothing in the frequency domain (below) and it is what couples range
and Doppler in a chirp (nu kappa ~ 1e-4 cycles only, but it shifts the compressed peak by pi nu / gamma: the up / down
sweep offset tested in ``tests/unit/test_chirp_chain.py``). Element l sits at l d along the array axis, which
points from boresight clockwise by 90 degrees, so its extra path length is l d sin(theta - boresight); the envelope
delay across the array (d / c = 0.125 ns << 1 / B_w) is neglected. e is complex white Gaussian noise of two-sided
PSD N0: E[e(t) e*(t')] = N0 delta(t - t').

Sampling. The receiver band-limits to |f| < fs / 2 and samples at fs = ``sample_rate_factor`` x B_w (default 2:
80 MHz). The Gaussian spectrum is then cut at +-2.83 sigma_f: 0.47 % of the pulse energy falls outside
(integrated-SNR loss 0.02 dB; the band-limited delay curvature <omega^2> is 4.1 % below the unlimited one, see
:func:`pulse_train_information`). The cut leaves the compressed pulse a ringing tail of relative amplitude
~ |S(fs/2)|^2 / (pi t) (-56 dB at 100 ns): below the noise for targets, above it for the direct blast
(static, removed by the background). A slower rate (1.25 B_w) would lose 7.7 % of the energy and ring at -25 dB.

Frequency-domain synthesis (exact for the band-limited sampled signal). On the DFT grid f_k = k fs / N,
k = -N/2 .. N/2 - 1, the spectrum of pulse b is

    Y_{l,b}(f_k) = sum_p A_{p,l} e^{j 2 pi nu_p b T1} S(f_k - nu_p) e^{-j 2 pi f_k (tau_p(b) - tau_0)}  +  W_{l,b,k},

tau_0 the window's first delay, W_{l,b,k} ~ CN(0, N N0 / fs) (the DFT of N white samples of variance N0 fs, in
continuous-transform units). Its inverse transform y(tau_0 + n / fs) = fs IDFT(Y)_n is the sampled baseband,
periodic in N / fs (:func:`received_spectrum`, :func:`baseband_samples`; the test compares it with eq. 1 evaluated
at the sample times: they differ only by the aliasing of the spectrum's tails beyond +-fs/2).

Matched filter (eq. 5, h(t) = s*(-t)), applied in the frequency domain: Z = S*(f) Y. Because
S*(f) S(f - nu) = |S(f)|^2 exp(pi^2 (2 f nu - nu^2) / a), a path's contribution is |S(f_k)|^2 times
exp(beta f_k + const) with beta = 2 pi^2 nu / a - j 2 pi (tau_p(b) - tau_0): a geometric sequence in k, summed over
paths in one compiled pass (P x B x N complex multiply-adds; :func:`matched_filter_spectra`). Static paths (no
target: nu = 0, no walk) give the same spectrum in every pulse and every scan: :func:`static_spectrum` computes it
once per episode. The compressed output z(tau_0 + n / (m fs)) = m fs IDFT_{mN}(Z zero-padded) is interpolated
m = ``delay_oversample`` times (exact trigonometric interpolation of the band-limited output). Its noise is
CN(0, eta N0) per sample and a path's peak is A eta, eta = (fs / N) sum_k |S_k|^2 (0.9953 at 2 B_w).

FFT length. The compressed pulse |z| ~ exp(-sigma_w^2 t^2 / 2) (sigma_w = 2 pi sigma_f: 11 ns standard deviation)
falls below ``tail`` (1e-8) at g = sqrt(2 ln(1 / tail)) / sigma_w = 68 ns. The image covers the delays
[L_tx-rx / c - g, (L_tx-rx + max_excess_range) / c + g]; paths whose delay is within g / 2 of it are synthesised
(the others dropped: at the edge of the image margin they would leave < tail^(1/4) of their amplitude, and nothing
at its inner region), and the FFT period N / fs >= image span + 2 g keeps every synthesised tail (g) plus range walk
(< g / 2) from wrapping into the image. For 300 m beyond the baseline: 1.27 us -> N = 108 at 80 MHz (the next
2^a 3^b 5^c length).

Array (eq. 6). ``weights`` w (L,) combine the elements coherently, sum_l conj(w_l) y_l. Eq. 6 is the plain sum
(w = 1: a beam at boresight, gain L there; with d = lambda / 2 and L = 3 its nulls are at +-41.8 degrees off
boresight, inside the seed's +-50 degree field of view); :func:`steering_weights` steers elsewhere, and
``weights=None`` keeps the L element images (for a direction-of-arrival estimate). The combined noise is
CN(0, sum |w_l|^2 ...), drawn once per output channel (exactly the distribution of the combined element noises).

Slow time (Doppler). The B compressed pulses are Fourier transformed over b (rectangular window, zero-padded to
``doppler_oversample`` x B bins, fftshifted): a path's peak is B A eta, the noise power per cell B eta N0 sum|w|^2
(:func:`image_noise_power`), so the image SNR is B L E_rx eta / N0 at boresight. The pulse train measures Doppler
modulo 1 / T1: the axis spans [-1 / (2 T1), 1 / (2 T1)) and the range-rate -lambda nu is folded into a
lambda / T1 wide interval (7.5 m/s at T1 = 10 ms, lambda = 7.5 cm; :func:`fold_range_rate`). Zero-Doppler
(static) energy leaks through the rectangular window's sidelobes into the interpolated Doppler bins: it is static
and the background model removes its mean; ``clutter_map`` (optional, not in the seed) subtracts a coherent
per-delay reference instead.

Performance: per scan the cost is P_target x B x N x (1 + n_out) complex multiply-adds, the noise draw, two short
FFTs and a magnitude (``benchmarks/chirp_signal_throughput.py``: 1,170-1,270 scans/s, whole chain, 2 pairs).

Usage (one transmitter, its receivers as "pairs"; ``uwb_env.channel.multipath`` for the paths,
``uwb_env.detection.delay_doppler`` for the detection):

    per episode, per waveform:  grid = chirp_grid(waveform, baselines_m, max_excess_range_m)
    per episode, per pair:      geom = scatterer_geometry(...); static = static_paths(geom, ...)
    per episode:                A_s = path_amplitudes(static gains, E_pulse, rng=...)   (phases fixed)
                                amp, noise_gain = output_amplitudes(A_s, element_phases(doa, ...), weights)
                                Z_s = static_spectrum(grid, pair, static lengths, amp)
                                J background scans: images = |delay_doppler_images(grid, matched_filter_spectra(
                                    grid, [], ..., static=Z_s, ...))|; per pair background_model(images[:, pair]),
                                detection_threshold(background, Pfa)
    per scan:                   moving = target_paths(geom, positions, velocities, rcs, ...) per pair
                                amp, noise_gain = output_amplitudes(path_amplitudes(...), element_phases(...), weights)
                                Z = matched_filter_spectra(grid, pair, lengths, range_rates, amp, static=Z_s, ...)
                                mag = |delay_doppler_images(grid, Z)|; per pair detect_delay_doppler(mag[pair, 0],
                                background, grid.axes(pair), threshold=...); truth_origin(...) for evaluation
"""

from __future__ import annotations

import cmath
import math
from dataclasses import dataclass

import numba as nb
import numpy as np
import numpy.typing as npt
import scipy.fft

from uwb_env.config import ChirpWaveformConfig
from uwb_env.constants import SPEED_OF_LIGHT_MPS
from uwb_env.detection.delay_doppler import DelayDopplerAxes
from uwb_env.typing import BoolArray, FloatArray, IntArray
from uwb_env.waveforms.chirp import chirp_rate, fold_periodic

ComplexArray = npt.NDArray[np.complex128]

_jit = nb.njit(cache=True, fastmath=False, nogil=True)
_C = SPEED_OF_LIGHT_MPS


# --------------------------------------------------------------------------------------------------- the pulse
def chirp_pulse(t_s: FloatArray, kappa_s: float, gamma: float) -> ComplexArray:
    """Eq. 1's unit-energy Gaussian chirp s(t) = (pi kappa^2)^(-1/4) exp((j gamma - 1/(2 kappa^2)) t^2).

    Args:
        t_s: ``(...)`` times [s]; kappa_s: pulse duration kappa [s]; gamma: chirp rate [rad/s^2] (signed).

    Returns:
        ``(...)`` complex samples [1/sqrt(s)].
    """
    t = np.asarray(t_s, dtype=float)
    return (math.pi * kappa_s**2) ** -0.25 * np.exp((1j * gamma - 0.5 / kappa_s**2) * t * t)


def chirp_spectrum(freq_hz: FloatArray, kappa_s: float, gamma: float) -> ComplexArray:
    """Fourier transform S(f) = (pi kappa^2)^(-1/4) sqrt(pi / a) exp(-pi^2 f^2 / a), a = 1/(2 kappa^2) - j gamma.

    Args:
        freq_hz: ``(...)`` baseband frequencies [Hz]; kappa_s [s]; gamma [rad/s^2].

    Returns:
        ``(...)`` complex S(f) [1/sqrt(Hz)] (int |S|^2 df = 1).
    """
    a = 0.5 / kappa_s**2 - 1j * gamma
    f = np.asarray(freq_hz, dtype=float)
    return (math.pi * kappa_s**2) ** -0.25 * np.sqrt(math.pi / a) * np.exp(-(math.pi**2) * f * f / a)


def spectral_width_rad_s(kappa_s: float, gamma: float) -> float:
    """sigma_w = sqrt(<omega^2>) = sqrt(1/(2 kappa^2) + 2 gamma^2 kappa^2) [rad/s] of the (unlimited) pulse."""
    return math.sqrt(0.5 / kappa_s**2 + 2.0 * gamma**2 * kappa_s**2)


def fold_range_rate(range_rate_mps: FloatArray, wavelength_m: float, pri_s: float) -> FloatArray:
    """Range-rate as the pulse train measures it: -lambda nu with nu folded into [-1/(2 T1), 1/(2 T1)).

    Args:
        range_rate_mps: ``(...)`` [m/s]; wavelength_m [m]; pri_s: T1 [s].

    Returns:
        ``(...)`` folded range-rate in [-lambda / (2 T1), lambda / (2 T1)) [m/s] (``waveforms.chirp.fold_periodic``).
    """
    return fold_periodic(np.asarray(range_rate_mps, dtype=float), wavelength_m / pri_s)


# --------------------------------------------------------------------------------------------------- the grid
_FAST = sorted(2**a * 3**b * 5**c for a in range(16) for b in range(8) for c in range(6) if 2**a * 3**b * 5**c < 2**16)


def _fast_length(n: int) -> int:
    """Smallest 2^a 3^b 5^c >= n (even)."""
    return next(m for m in _FAST if m >= n and m % 2 == 0)


@dataclass(frozen=True, slots=True)
class ChirpGrid:
    """Sampling of one waveform's chain for a set of pairs (build with :func:`chirp_grid`, once per episode).

    Attributes:
        pulse_duration_s: kappa [s]. chirp_rate: gamma [rad/s^2] (signed). bandwidth_hz: B_w [Hz].
        carrier_hz: fc [Hz]. n_pulses: B. pri_s: T1 [s].
        sample_rate_hz: fs [Hz]. n_fft: N. delay_oversample: m (image delay step 1 / (m fs)).
        doppler_oversample: Doppler bins per 1 / (B T1). n_delay: image rows. guard_s: g [s] (module docstring).
        window_start_s: ``(n_pairs,)`` delay tau_0 of image row 0 [s]. freq_hz: ``(N,)`` f_k in FFT order [Hz].
        spectrum: ``(N,)`` S(f_k). mf_weight: ``(N,)`` |S(f_k)|^2 [1/Hz]. band_energy: eta = (fs / N) sum |S_k|^2.
    """

    pulse_duration_s: float
    chirp_rate: float
    bandwidth_hz: float
    carrier_hz: float
    n_pulses: int
    pri_s: float
    sample_rate_hz: float
    n_fft: int
    delay_oversample: int
    doppler_oversample: int
    n_delay: int
    guard_s: float
    window_start_s: FloatArray
    freq_hz: FloatArray
    spectrum: ComplexArray
    mf_weight: FloatArray
    band_energy: float

    @property
    def wavelength_m(self) -> float:
        """Carrier wavelength lambda = c / fc [m]."""
        return _C / self.carrier_hz

    @property
    def n_pairs(self) -> int:
        """Number of pairs the grid serves."""
        return int(self.window_start_s.shape[0])

    @property
    def n_doppler(self) -> int:
        """Image columns: doppler_oversample x B."""
        return self.doppler_oversample * self.n_pulses

    @property
    def delay_step_s(self) -> float:
        """Image row spacing 1 / (m fs) [s]."""
        return 1.0 / (self.delay_oversample * self.sample_rate_hz)

    @property
    def doppler_step_hz(self) -> float:
        """Image column spacing 1 / (n_doppler T1) [Hz]."""
        return 1.0 / (self.n_doppler * self.pri_s)

    def delay_axis_s(self) -> FloatArray:
        """``(n_pairs, n_delay)`` delay of every image row [s]."""
        return self.window_start_s[:, None] + np.arange(self.n_delay) * self.delay_step_s

    def doppler_axis_hz(self) -> FloatArray:
        """``(n_doppler,)`` Doppler of every image column [Hz], increasing from -1 / (2 T1)."""
        return (np.arange(self.n_doppler) - self.n_doppler // 2) * self.doppler_step_hz

    def axes(self, pair: int) -> DelayDopplerAxes:
        """The image geometry of ``pair`` for ``uwb_env.detection.delay_doppler`` (resolution 1 / B_w, 1 / (B T1))."""
        return DelayDopplerAxes(
            delay_start_s=float(self.window_start_s[pair]),
            delay_step_s=self.delay_step_s,
            doppler_step_hz=self.doppler_step_hz,
            n_doppler=self.n_doppler,
            wavelength_m=self.wavelength_m,
            delay_resolution_s=1.0 / self.bandwidth_hz,
            doppler_resolution_hz=1.0 / (self.n_pulses * self.pri_s),
        )


def chirp_grid(
    waveform: ChirpWaveformConfig,
    baselines_m: FloatArray,
    max_excess_range_m: float,
    *,
    sample_rate_factor: float = 2.0,
    delay_oversample: int = 2,
    doppler_oversample: int = 4,
    tail: float = 1e-8,
    n_fft: int | None = None,
) -> ChirpGrid:
    """Sampling rate, FFT length, delay windows and the pulse spectrum of one waveform (module docstring).

    Args:
        waveform: the chirp; baselines_m: ``(n_pairs,)`` transmitter-receiver distances [m]; max_excess_range_m:
        largest bistatic range beyond the baseline to image [m]; sample_rate_factor: fs / B_w; delay_oversample,
        doppler_oversample: image interpolation factors (integers >= 1); tail: relative amplitude at which the
        compressed pulse is considered ended (sets the guard g); n_fft: override N (>= the no-wrap length).

    Returns:
        :class:`ChirpGrid`.
    """
    kappa = waveform.pulse_duration_s
    gamma = chirp_rate(kappa, waveform.bandwidth_hz, waveform.sweep)
    fs = sample_rate_factor * waveform.bandwidth_hz
    guard = math.sqrt(2.0 * math.log(1.0 / tail)) / spectral_width_rad_s(kappa, gamma)
    span = max_excess_range_m / _C + 2.0 * guard  # image span [s]
    n_min = math.ceil((span + 2.0 * guard) * fs)
    n = _fast_length(n_min) if n_fft is None else int(n_fft)
    if n < n_min:
        raise ValueError(f"n_fft = {n}: must be >= {n_min} so that no synthesised tail wraps into the image")
    freq = np.fft.fftfreq(n, 1.0 / fs)
    spec = chirp_spectrum(freq, kappa, gamma)
    w = np.abs(spec) ** 2
    starts = np.asarray(baselines_m, dtype=float).reshape(-1) / _C - guard
    return ChirpGrid(
        pulse_duration_s=kappa,
        chirp_rate=gamma,
        bandwidth_hz=waveform.bandwidth_hz,
        carrier_hz=waveform.carrier_hz,
        n_pulses=waveform.n_pulses,
        pri_s=waveform.pri_s,
        sample_rate_hz=fs,
        n_fft=n,
        delay_oversample=int(delay_oversample),
        doppler_oversample=int(doppler_oversample),
        n_delay=math.floor(span * delay_oversample * fs) + 1,
        guard_s=guard,
        window_start_s=starts,
        freq_hz=freq,
        spectrum=spec,
        mf_weight=w,
        band_energy=float(w.sum() * fs / n),
    )


def pulse_train_information(grid: ChirpGrid, *, band_limited: bool = True) -> FloatArray:
    r"""Delay-Doppler second-moment matrix M of the pulse train, in (tau [s], nu [Hz]): J = 2 SNR M.

    For the unit-energy train with <t> = <omega> = 0 (Kershaw and Evans; ``uwb_env.waveforms.chirp``):
    M = [[<omega^2>, -2 pi gamma kappa^2 ...]] with

        M_tt = <omega^2> = 1/(2 kappa^2) + 2 gamma^2 kappa^2          [rad^2/s^2]
        M_tn = 2 pi x (-gamma kappa^2)                                [rad^2]   (per pulse; the train adds nothing)
        M_nn = (2 pi)^2 (kappa^2 / 2 + T1^2 (B^2 - 1) / 12)           [rad^2 s^2] (time spread of the train)

    Near the peak the matched-filter power is |A|^2 = P0 (1 - d^T M d + ...), d = (delta tau, delta nu).
    ``band_limited`` replaces <omega^2> by its value for the synthesised spectrum (|S_k|^2 on the DFT grid, cut at
    +-fs/2: 4.1 % lower at fs = 2 B_w). The range walk across the dwell changes M_nn by (sigma_f / fc)^2 ~ 1e-5
    (neglected). Returns ``(2, 2)``.
    """
    k, g = grid.pulse_duration_s, grid.chirp_rate
    if band_limited:
        w = grid.mf_weight
        m_tt = float(((2.0 * math.pi * grid.freq_hz) ** 2 * w).sum() / w.sum())
    else:
        m_tt = spectral_width_rad_s(k, g) ** 2
    m_tn = -2.0 * math.pi * g * k**2
    m_nn = (2.0 * math.pi) ** 2 * (0.5 * k**2 + grid.pri_s**2 * (grid.n_pulses**2 - 1) / 12.0)
    return np.array([[m_tt, m_tn], [m_tn, m_nn]])


def range_rate_crlb(grid: ChirpGrid, snr: FloatArray, *, band_limited: bool = True) -> FloatArray:
    """CRLB of (bistatic range [m], range-rate [m/s]) from the pulse train: U (2 SNR M)^-1 U^T, U = diag(c, -lambda).

    Args:
        grid: the waveform's grid; snr: ``(N,)`` image SNR (peak power over noise power per cell).

    Returns:
        ``(N, 2, 2)`` [[m^2, m^2/s], [m^2/s, m^2/s^2]].
    """
    m = pulse_train_information(grid, band_limited=band_limited)
    u = np.diag([_C, -grid.wavelength_m])
    r = u @ np.linalg.inv(m) @ u.T / 2.0
    return r[None] / np.asarray(snr, dtype=float).reshape(-1)[:, None, None]


def image_noise_power(grid: ChirpGrid, noise_psd_w_per_hz: float, noise_gain: FloatArray | float = 1.0) -> FloatArray:
    """Noise power per delay-Doppler cell, B eta N0 sum|w|^2 (``noise_gain`` = sum |w_l|^2 per output channel)."""
    return grid.n_pulses * grid.band_energy * noise_psd_w_per_hz * np.asarray(noise_gain, dtype=float)


# --------------------------------------------------------------------------------------------------- amplitudes
def path_amplitudes(gain: FloatArray, pulse_energy_j: float, *, rng: np.random.Generator) -> ComplexArray:
    """Complex amplitude per path and pulse, sqrt(E_pulse x gain) e^{j phi}, phi ~ U(-pi, pi] (seed 003 eq. 2).

    Args:
        gain: ``(P,)`` P_r / P_t of each path; pulse_energy_j: transmitted energy per pulse [J]
        (P_peak kappa sqrt(pi) for eq. 1); rng: phase draws.

    Returns:
        ``(P,)`` [sqrt(J)]. Draw static paths' phases once per episode (their geometry is fixed) and target paths'
        every scan.
    """
    g = np.asarray(gain, dtype=float)
    phi = rng.uniform(-math.pi, math.pi, g.shape)
    return np.sqrt(pulse_energy_j * g) * np.exp(1j * phi)


def element_phases(
    doa_rad: FloatArray, boresight_rad: FloatArray | float, n_elements: int, spacing_m: float, wavelength_m: float
) -> ComplexArray:
    """``(P, L)`` array phases exp(-j 2 pi l d sin(theta_p - boresight) / lambda), l = 0 .. L-1 (module docstring).

    Args:
        doa_rad: ``(P,)`` directions of arrival [rad]; boresight_rad: ``(P,)`` or scalar [rad]; n_elements: L;
        spacing_m: d [m]; wavelength_m [m].
    """
    psi = np.asarray(doa_rad, dtype=float) - np.asarray(boresight_rad, dtype=float)
    return np.exp(-2j * math.pi * spacing_m / wavelength_m * np.sin(psi)[..., None] * np.arange(n_elements))


def steering_weights(
    angle_rad: float, boresight_rad: float, n_elements: int, spacing_m: float, wavelength_m: float
) -> ComplexArray:
    """``(L,)`` weights w that steer sum_l conj(w_l) y_l to ``angle_rad`` (w = 1 at boresight: eq. 6's plain sum)."""
    return element_phases(np.array([angle_rad]), boresight_rad, n_elements, spacing_m, wavelength_m)[0]


def output_amplitudes(
    amplitude: ComplexArray, phases: ComplexArray, weights: ComplexArray | None
) -> tuple[ComplexArray, FloatArray]:
    """Per-output-channel path amplitudes and the channels' noise gains.

    Args:
        amplitude: ``(P,)`` path amplitudes; phases: ``(P, L)`` :func:`element_phases`; weights: ``(L,)`` combining
        weights, or None to keep the L elements.

    Returns:
        ``(P, n_out)`` amplitudes (n_out = 1 combined, L per element) and ``(n_out,)`` noise gains sum |w|^2 (1 per
        element).
    """
    a = amplitude[:, None] * phases
    if weights is None:
        return a, np.ones(phases.shape[1])
    w = np.asarray(weights, dtype=complex)
    return (a @ w.conj())[:, None], np.array([float(np.sum(np.abs(w) ** 2))])


# --------------------------------------------------------------------------------------------------- synthesis
def keep_in_window(grid: ChirpGrid, pair: IntArray, length_m: FloatArray) -> BoolArray:
    """``(P,)`` True for paths whose delay lies within half a guard of their pair's image (the ones synthesised).

    With the FFT period >= image span + 2 g, a kept path's tail (g) plus its range walk across the dwell (up to g / 2:
    |rdot| <= c g / ((B - 1) T1), 85 m/s for the seed's waveforms) never wraps into the image.
    """
    tau = np.asarray(length_m, dtype=float) / _C - grid.window_start_s[np.asarray(pair)]
    span = (grid.n_delay - 1) * grid.delay_step_s
    return (tau >= -0.5 * grid.guard_s) & (tau <= span + 0.5 * grid.guard_s)


def received_spectrum(
    grid: ChirpGrid,
    window_start_s: float,
    length_m: FloatArray,
    range_rate_mps: FloatArray,
    amplitude: ComplexArray,
) -> ComplexArray:
    """Noiseless spectrum Y_{l,b}(f_k) of the received pulses, evaluated term by term (reference, not fast).

    Args:
        grid: the waveform's grid; window_start_s: tau_0 [s]; length_m, range_rate_mps: ``(P,)`` [m], [m/s];
        amplitude: ``(P, n_out)`` complex amplitudes (array phases and weights included).

    Returns:
        ``(n_out, B, N)`` Y in FFT order [continuous-transform units, sqrt(J) / Hz].
    """
    b = np.arange(grid.n_pulses) - 0.5 * (grid.n_pulses - 1)
    rdot = np.asarray(range_rate_mps, dtype=float)
    nu = -rdot / grid.wavelength_m
    tau = (np.asarray(length_m)[:, None] + rdot[:, None] * b * grid.pri_s) / _C - window_start_s  # (P, B)
    f = grid.freq_hz
    s = chirp_spectrum(f[None, :] - nu[:, None], grid.pulse_duration_s, grid.chirp_rate)  # (P, N)
    term = (
        np.exp(2j * math.pi * nu[:, None] * b * grid.pri_s)[:, :, None]
        * s[:, None, :]
        * np.exp(-2j * math.pi * f * tau[:, :, None])
    )  # (P, B, N)
    return np.einsum("pl,pbk->lbk", amplitude, term)


def baseband_samples(grid: ChirpGrid, spectrum: ComplexArray) -> ComplexArray:
    """Sampled baseband y(tau_0 + n / fs) = fs IDFT(Y)_n, ``(..., N)`` -> ``(..., N)`` [sqrt(J / s)]."""
    return grid.sample_rate_hz * np.fft.ifft(spectrum, axis=-1)


def static_spectrum(grid: ChirpGrid, pair: IntArray, length_m: FloatArray, amplitude: ComplexArray) -> ComplexArray:
    """Matched-filtered spectrum of the static paths, |S_k|^2 sum_p A_p e^{-j 2 pi f_k (L_p / c - tau_0)}.

    Static paths have nu = 0 and no range walk, so this is the same in every pulse and every scan of an episode.

    Args:
        grid: the waveform's grid; pair: ``(P,)`` pair index of each path; length_m: ``(P,)`` [m]; amplitude:
        ``(P, n_out)``.

    Returns:
        ``(n_pairs, n_out, N)`` complex (add to every pulse: ``matched_filter_spectra(static=...)``).
    """
    pair = np.asarray(pair, dtype=np.int64)
    out = np.zeros((grid.n_pairs, amplitude.shape[1], grid.n_fft), dtype=complex)
    keep = keep_in_window(grid, pair, length_m)
    tau = np.asarray(length_m)[keep] / _C - grid.window_start_s[pair[keep]]
    phase = np.exp(-2j * math.pi * tau[:, None] * grid.freq_hz[None, :])  # (P, N)
    for q in range(grid.n_pairs):  # pairs: a handful
        sel = pair[keep] == q
        out[q] = amplitude[keep][sel].T @ phase[sel]
    return out * grid.mf_weight


@_jit
def _accumulate(out, pair, length, rdot, amp, start, df, pri, wavelength, q):  # pragma: no cover - compiled
    """out[pair, l, b, k] += sum_p amp[p, l] e^{j 2 pi nu b T1 - q nu^2} exp(beta f_k), beta = 2 q nu - j 2 pi tau.

    out: (n_pairs, n_out, B, N) complex, FFT order; q = pi^2 / a (complex); start: (n_pairs,) tau_0 [s].
    """
    n_out, n_b, n = out.shape[1], out.shape[2], out.shape[3]
    half = n // 2
    two_pi = 2.0 * math.pi
    for p in range(length.shape[0]):
        j = pair[p]
        nu = -rdot[p] / wavelength
        for b in range(n_b):
            bc = b - 0.5 * (n_b - 1)
            tau = (length[p] + rdot[p] * bc * pri) / 299792458.0 - start[j]
            beta = 2.0 * q * nu - 1j * two_pi * tau
            c0 = cmath.exp(1j * two_pi * nu * bc * pri - q * nu * nu)
            r = cmath.exp(beta * df)
            v = c0 * cmath.exp(-beta * (half * df))  # k = -N/2
            for k in range(half, n):  # negative frequencies: FFT indices N/2 .. N-1
                for m in range(n_out):
                    out[j, m, b, k] += amp[p, m] * v
                v *= r
            for k in range(half):  # non-negative frequencies: 0 .. N/2-1
                for m in range(n_out):
                    out[j, m, b, k] += amp[p, m] * v
                v *= r


def matched_filter_spectra(
    grid: ChirpGrid,
    pair: IntArray,
    length_m: FloatArray,
    range_rate_mps: FloatArray,
    amplitude: ComplexArray,
    *,
    static: ComplexArray | None,
    noise_psd_w_per_hz: float,
    noise_gain: FloatArray,
    rng: np.random.Generator,
) -> ComplexArray:
    """Matched-filtered spectra Z = S* Y of every pulse and output channel of every pair, for one scan.

    Args:
        grid: the waveform's grid; pair: ``(P,)`` pair index of each (moving) path; length_m ``(P,)`` [m];
        range_rate_mps ``(P,)`` [m/s]; amplitude ``(P, n_out)`` (:func:`output_amplitudes`); static:
        ``(n_pairs, n_out, N)`` :func:`static_spectrum` or None; noise_psd_w_per_hz: N0 [W/Hz] (0: noiseless);
        noise_gain: ``(n_out,)`` sum |w|^2 per channel; rng: noise draws.

    Returns:
        ``(n_pairs, n_out, B, N)`` complex, FFT order. Paths outside their pair's window (+- guard) are skipped.
    """
    n_out = amplitude.shape[1]
    shape = (grid.n_pairs, n_out, grid.n_pulses, grid.n_fft)
    pair = np.asarray(pair, dtype=np.int64)
    keep = keep_in_window(grid, pair, length_m)
    acc = np.zeros(shape, dtype=complex)
    q = math.pi**2 / (0.5 / grid.pulse_duration_s**2 - 1j * grid.chirp_rate)
    _accumulate(
        acc,
        pair[keep],
        np.ascontiguousarray(np.asarray(length_m, dtype=float)[keep]),
        np.ascontiguousarray(np.asarray(range_rate_mps, dtype=float)[keep]),
        np.ascontiguousarray(amplitude[keep]),
        grid.window_start_s,
        grid.sample_rate_hz / grid.n_fft,
        grid.pri_s,
        grid.wavelength_m,
        q,
    )
    acc *= grid.mf_weight
    if static is not None:  # already matched-filtered, the same in every pulse
        acc += static[:, :, None, :]
    if noise_psd_w_per_hz > 0.0:
        scale = np.sqrt(0.5 * grid.n_fft * noise_psd_w_per_hz / grid.sample_rate_hz * np.asarray(noise_gain))
        w = rng.standard_normal((*shape, 2)).view(complex)[..., 0]
        acc += (scale[None, :, None, None] * grid.spectrum.conj()) * w
    return acc


def delay_doppler_images(
    grid: ChirpGrid, spectra: ComplexArray, clutter_map: ComplexArray | None = None
) -> ComplexArray:
    """Compressed pulses -> delay-Doppler images: zero-padded inverse DFT over frequency, crop, DFT over pulses.

    Args:
        grid: the waveform's grid; spectra: ``(n_pairs, n_out, B, N)`` :func:`matched_filter_spectra`;
        clutter_map: optional ``(n_pairs, n_out, N)`` coherent static reference (matched-filtered spectrum, e.g. the
        pulse mean of background scans, :func:`coherent_background`) subtracted from every pulse first.

    Returns:
        ``(n_pairs, n_out, n_delay, n_doppler)`` complex image [sqrt(J)]: row i is the delay
        window_start + i delay_step, column j the Doppler (j - n_doppler // 2) doppler_step (fftshifted).
        A path at the cell of its delay and Doppler has |image| ~ B eta |A|.
    """
    n, m = grid.n_fft, grid.delay_oversample
    z = spectra if clutter_map is None else spectra - clutter_map[:, :, None, :]
    if m > 1:  # zero-pad the band in the middle (FFT order) for trigonometric interpolation
        half = n // 2
        pad = np.zeros((*z.shape[:-1], m * n), dtype=complex)
        pad[..., :half] = z[..., :half]
        pad[..., m * n - half :] = z[..., half:]
        z = pad
    t = scipy.fft.ifft(z, axis=-1, overwrite_x=m > 1)[..., : grid.n_delay]
    # fftshift over Doppler as a modulation of the pulses: X[j - n // 2] = DFT(x_b e^{j 2 pi (n // 2) b / n})
    nd = grid.n_doppler
    shift = (m * grid.sample_rate_hz) * np.exp(2j * math.pi * (nd // 2) * np.arange(grid.n_pulses) / nd)
    return scipy.fft.fft(np.swapaxes(t, -1, -2) * shift, n=nd, axis=-1)


def coherent_background(spectra: ComplexArray) -> ComplexArray:
    """Pulse (and scan) mean of matched-filtered spectra ``(J, n_pairs, n_out, B, N)`` -> ``(n_pairs, n_out, N)``.

    The static part of every pulse is the same, so this estimates it with noise reduced J B times (optional
    ``clutter_map`` of :func:`delay_doppler_images`; not in the seed, which subtracts magnitudes).
    """
    return spectra.mean(axis=(0, 3))
