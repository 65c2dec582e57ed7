r"""Seed 003 section 4.1: background-subtracted delay-Doppler images, iterative peaks, 2-D quadratic fits.

Input: magnitude images |A_k| ``(n_delay, n_doppler)`` of one pair (``uwb_env.sensing.signal.chirp_chain``), row i
at delay tau_0 + i dtau, column j at Doppler (j - n_doppler // 2) dnu, periodic in Doppler (the pulse train
measures nu modulo 1 / T1). :class:`DelayDopplerAxes` carries that geometry; this module imports no sensing code.

Background (seed): A_bar = (1/J) sum_j |A_j| over J images taken before tracking; A_k = |A_k| - A_bar.

Noise power. sigma^2 = E|noise|^2 per cell. :func:`background_model` estimates it from the J images: in a noise-only
cell the mean of J exponential powers |A_j|^2 is Gamma(J, sigma^2 / J), whose median is sigma^2 x m_J,
m_J = gammaincinv(J, 1/2) / J (1 - 1 / (3 J) roughly); :func:`estimate_noise_power` divides the median over cells
of the per-cell mean power by m_J, then repeats without the cells that noise alone would not reach (static returns).

Threshold (per cell, for a false-alarm probability per cell). A cell with a static return of amplitude c has
|A| ~ Rice(c, sigma) with mean m(c) = sigma sqrt(pi)/2 [(1 + K) I0e(K/2) + K I1e(K/2)], K = c^2 / sigma^2
(I0e, I1e scaled Bessel functions), and A_k = |A| - A_bar. We invert m to estimate c from A_bar, and treat the
background's own fluctuation (var |A| / J, var |A| = c^2 + sigma^2 - m^2) as extra noise power:
sigma_eff^2 = sigma^2 + 2 var|A| / J. The cell's threshold on |A| is X = F^-1_Rice(1 - Pfa; c, sigma_eff), so

    T(cell) = X(c_hat) - A_bar(cell)                                                              (threshold on A_k)

and A_k > T exactly when |A_k| > X. A cell whose A_bar is within 2 standard deviations of a noise cell's
(A_bar <= sigma (sqrt(pi) / 2 + 2 sqrt((1 - pi/4) / J))) is taken as noise, c_hat = 0 and X = sigma sqrt(ln(1 / Pfa)):
its per-cell Pfa is then exact whatever A_bar (inverting the Rice mean there would turn the background's own
fluctuation into c_hat ~ sigma J^(-1/4) and halve the Pfa); a weak static return below that gate sees a higher
Pfa. A strong static return (c >> sigma) gives A_k ~ N(c - c_hat, sigma^2 / 2) with c - c_hat ~ N(0, sigma^2 / (2 J)),
so X - c_hat = Q^-1(Pfa) sigma sqrt((1 + 1/J) / 2): 3.4 sigma at Pfa 1e-6, where a noise cell's X - A_bar is
2.8 sigma (one uniform threshold on A_k would raise the false alarms on clutter 30-fold). Measured on synthetic
images with sigma^2 estimated (``tests/unit/test_chirp_chain.py``; J = 4-16, Pfa 1e-2-1e-3): 0.93-1.02 x Pfa in
noise cells, 0.80-1.34 x Pfa on static returns. Oversampled images have correlated cells: the per-cell Pfa holds,
and the false peaks per image are 0.4-0.5 x Pfa x cells (measured on the default chirp image, 182 x 100 cells:
0.93 false peaks per image at Pfa 1e-4, 0.07 at 1e-5).

Peaks (seed: iterative). Repeatedly take the largest remaining local maximum of A_k above T, accept it, and
suppress the cells within one resolution cell of it (``guard``: 1 / B_w in delay, 1 / (B T1) in Doppler, circular),
up to ``max_peaks``. Restricting the candidates to local maxima (3 x 3, circular in Doppler) is the seed's iteration
without re-detecting the shoulder of a suppressed peak. Rows closer than the fit half-window to the delay edges are
not searched. The rectangular slow-time window has -13.3 dB Doppler sidelobes (at +-1.43 cells): a peak more than
13 dB above the threshold brings sidelobe peaks (their truth origin is noise); widen ``guard_doppler`` to drop them.

Quadratic fit (seed: f = s_t^2 t^2 + 2 s_t s_n t n + s_n^2 n^2, a quadratic form; we fit the full quadratic)
q(d) = c0 + g . d + d^T H d / 2 by least squares on a (2 h_r + 1) x (2 h_c + 1) window (the pseudo-inverse of the
6-column design matrix is precomputed; all peaks in one matrix product). The peak is at d* = -H^-1 g (rejected
unless H is negative definite and d* inside the window), with value q* = c0 + g . d* / 2.

What we fit, and the covariance from its curvature. Near the peak the matched-filter power of a point return is
|A|^2 = a0^2 (1 - d^T M d + O(d^4)), M the signal's delay-Doppler second-moment matrix, and the Fisher information
is J = 2 SNR M with SNR = a0^2 / sigma^2 (Kershaw and Evans; ``chirp_chain.pulse_train_information``).

* Default, ``log=True`` (the seed's "Gaussian curve fitting", a quadratic fitted to the log): we fit
  ln(A_k + A_bar(peak)), the log of the peak magnitude with the background level at the peak added back (so the
  window keeps the background subtraction and the log sees the magnitude). ln|A| = ln a0 - d^T M d / 2 + O(d^4), so
  H = -M, a0 = exp(q*) and

      R_(tau, nu) = J^-1 = -(sigma^2 / (2 a0^2)) H^-1.

  The compressed chirp is Gaussian in delay, so this is exact there whatever the sampling (measured 0.5-1.3 % on
  the band-limited pulse at the default sampling); the train's Dirichlet kernel in Doppler leaves a fourth-order bias
  of (pi^2 / 30) h^2 (h the column spacing in 1 / (B T1) units: 2 % at the default 4x interpolation; measured
  2-4 %). Window values at or below 0 are floored at 1e-3 a0 before the log. Monte Carlo (one path, 3 x 3 window):
  the spread of (range, range-rate) is 1.00-1.04 x the CRLB std at 30 dB image SNR and up to 1.11 x at 20 dB;
  the R reported is 0.97-1.05 x the CRLB.
* ``log=False`` (the magnitude, as printed in the seed): |A| = a0 (1 - d^T M d / 2), so H = -a0 M,
  a0 = q* + A_bar(peak) and R_(tau, nu) = -(sigma^2 / (2 a0)) H^-1. Its fourth-order terms are larger: for a
  Gaussian of standard deviation s cells the fitted curvature is low by ~h^2 / (4 s^2) along that axis and the
  window's other rows lower it further (12-21 % low at the default chirp image, against 0.5-4 % for the log fit).
* (Fitting the power: H_P = -2 a0^2 M and R = -sigma^2 H_P^-1.)
* A peak flatter than the matched one (a target whose range walks across the dwell, which the filter does not
  follow: ``uwb_env.waveforms.chirp``): the error is -H_s^-1 grad n to first order, the signal's fitted curvature
  H_s = -M_fit but the noise gradient that of the matched filter, var(grad n) ~ M_0. The sandwich
  R = (sigma^2 / (2 a0^2)) M_fit^-1 M_0 M_fit^-1 (``matched=M_0``) is then the covariance; the curvature-only R
  above assumes M_fit = M_0 and, for a 160 MHz chirp's peak walked over 2-5 cells, reports 0.24-0.4 of the spread.

The measurement is z = (c tau, -lambda nu) (bistatic range [m]; range-rate folded into
(-lambda / (2 T1), lambda / (2 T1)]), so R = U R_(tau, nu) U^T, U = diag(c, -lambda).

Truth origin (evaluation only): a peak within one resolution cell (c / B_w in range, lambda / (B T1) in folded
range-rate) of a target's tx-target-rx path gets that target's index; else of a path through a target and a
scatterer, :data:`ORIGIN_GHOST`; else of a static path, :data:`ORIGIN_CLUTTER`; else :data:`ORIGIN_NOISE`.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numba as nb
import numpy as np
import scipy.special
import scipy.stats

from uwb_env.constants import SPEED_OF_LIGHT_MPS
from uwb_env.typing import BoolArray, FloatArray, IntArray

ORIGIN_CLUTTER = -1
"""Truth origin of a peak on a static (target-free) path."""
ORIGIN_GHOST = -2
"""Truth origin of a peak on a target's multipath (through a scatterer)."""
ORIGIN_NOISE = -3
"""Truth origin of a peak on no path."""

_jit = nb.njit(cache=True, fastmath=False, nogil=True)
_C = SPEED_OF_LIGHT_MPS


@dataclass(frozen=True, slots=True)
class DelayDopplerAxes:
    """Geometry of one pair's delay-Doppler image.

    Attributes:
        delay_start_s: delay of row 0 [s]. delay_step_s: row spacing [s]. doppler_step_hz: column spacing [Hz];
        column j is the Doppler (j - n_doppler // 2) doppler_step_hz and the axis wraps after n_doppler columns.
        n_doppler: columns. wavelength_m: carrier wavelength [m]. delay_resolution_s: one resolution cell in delay
        (1 / B_w) [s]. doppler_resolution_hz: one in Doppler (1 / (B T1)) [Hz].
    """

    delay_start_s: float
    delay_step_s: float
    doppler_step_hz: float
    n_doppler: int
    wavelength_m: float
    delay_resolution_s: float
    doppler_resolution_hz: float

    @property
    def doppler_span_hz(self) -> float:
        """Unambiguous Doppler interval n_doppler x step = 1 / T1 [Hz]."""
        return self.n_doppler * self.doppler_step_hz

    @property
    def guard_cells(self) -> tuple[int, int]:
        """One resolution cell in image cells (delay rows, Doppler columns), at least 1."""
        return (
            max(1, round(self.delay_resolution_s / self.delay_step_s)),
            max(1, round(self.doppler_resolution_hz / self.doppler_step_hz)),
        )


@dataclass(frozen=True, slots=True)
class BackgroundModel:
    """Seed 003's background: mean magnitude over J images taken before tracking, and the noise power per cell.

    Attributes:
        mean_magnitude: ``(n_delay, n_doppler)`` A_bar. noise_power: sigma^2 = E|noise|^2 per cell.
        n_images: J.
    """

    mean_magnitude: FloatArray
    noise_power: float
    n_images: int


@dataclass(frozen=True, slots=True)
class PeakFit:
    """Quadratic fits around peaks (module docstring), in image cells.

    Attributes:
        offset: ``(n, 2)`` vertex d* relative to the peak cell (rows, columns). amplitude: ``(n,)`` a0, the fitted
        peak magnitude (background included). hessian: ``(n, 2, 2)`` H of the fitted quantity [per cell^2].
        ok: ``(n,)`` H negative definite and d* inside the window. log: whether ln-magnitude was fitted.
    """

    offset: FloatArray
    amplitude: FloatArray
    hessian: FloatArray
    ok: BoolArray
    log: bool


@dataclass(slots=True)
class DelayDopplerDetections:
    """Measurements of one pair's image (sorted by decreasing peak value, as detected).

    Attributes:
        range_m: ``(n,)`` bistatic range c tau [m]. range_rate_mps: ``(n,)`` -lambda nu, folded [m/s].
        R: ``(n, 2, 2)`` covariance of (range, range-rate) [m^2, m^2/s, m^2/s^2]. snr: ``(n,)`` a0^2 / sigma^2.
        delay_s, doppler_hz: ``(n,)`` the peaks [s], [Hz] (folded). row, col: ``(n,)`` peak cells.
        origin: ``(n,)`` truth origin (target index, or ORIGIN_*; ORIGIN_NOISE until :func:`truth_origin` is run).
    """

    range_m: FloatArray
    range_rate_mps: FloatArray
    R: FloatArray
    snr: FloatArray
    delay_s: FloatArray
    doppler_hz: FloatArray
    row: IntArray
    col: IntArray
    origin: IntArray

    def __len__(self) -> int:
        return int(self.range_m.shape[0])

    @property
    def z(self) -> FloatArray:
        """``(n, 2)`` measurements (bistatic range [m], range-rate [m/s])."""
        return np.stack([self.range_m, self.range_rate_mps], axis=1)


# --------------------------------------------------------------------------------------------------- background
def background_model(magnitudes: FloatArray, *, noise_power: float | None = None) -> BackgroundModel:
    """A_bar and sigma^2 from J magnitude images ``(J, n_delay, n_doppler)`` (module docstring).

    ``noise_power`` overrides the estimate (e.g. the known B eta N0 sum|w|^2 of the synthesis).
    """
    a = np.asarray(magnitudes, dtype=float)
    j = a.shape[0]
    if noise_power is None:
        noise_power = estimate_noise_power((a * a).mean(axis=0), j)
    return BackgroundModel(a.mean(axis=0), float(noise_power), j)


def estimate_noise_power(mean_power: FloatArray, n_images: int, *, outlier_probability: float = 1e-3) -> float:
    """sigma^2 from per-cell mean powers over J images, robust to a minority of cells with static returns.

    In a noise-only cell the mean of J powers is Gamma(J, sigma^2 / J). Pass 1: sigma_1^2 = median / m_J,
    m_J = gammaincinv(J, 1/2) / J. Pass 2: drop cells above sigma_1^2 x gammaincinv(J, 1 - p_out) / J (static
    returns; a fraction p_out of noise cells), and take the median of the rest over the median of the Gamma truncated
    at the same point, gammaincinv(J, (1 - p_out) / 2) / J.

    Args:
        mean_power: ``(...)`` per-cell mean of |A_j|^2; n_images: J; outlier_probability: p_out.

    Returns:
        sigma^2.
    """
    j = n_images
    p = np.asarray(mean_power, dtype=float).ravel()
    s1 = float(np.median(p)) / (float(scipy.special.gammaincinv(j, 0.5)) / j)
    cut = s1 * float(scipy.special.gammaincinv(j, 1.0 - outlier_probability)) / j
    kept = p[p <= cut]
    return float(np.median(kept)) / (float(scipy.special.gammaincinv(j, 0.5 * (1.0 - outlier_probability))) / j)


def subtract_background(magnitude: FloatArray, background: BackgroundModel) -> FloatArray:
    """Seed 003: A_k = |A_k| - A_bar, ``(..., n_delay, n_doppler)``."""
    return magnitude - background.mean_magnitude


def _rice_mean_ratio(rho: FloatArray) -> FloatArray:
    """E|c + n| / sigma for c / sigma = rho, E|n|^2 = sigma^2."""
    k = rho * rho
    return 0.5 * math.sqrt(math.pi) * ((1.0 + k) * scipy.special.i0e(0.5 * k) + k * scipy.special.i1e(0.5 * k))


@functools.lru_cache(maxsize=32)
def _rice_threshold_table(false_alarm_probability: float, n_images: int) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Grid of c / sigma ``(801,)`` on [0, 40], the Rice mean ratio m(c) / sigma and X(c) / sigma (module docstring)."""
    rho = np.linspace(0.0, 40.0, 801)
    mean = _rice_mean_ratio(rho)
    var = rho * rho + 1.0 - mean * mean
    s_eff = np.sqrt(1.0 + 2.0 * var / n_images)  # sigma_eff / sigma
    x = scipy.stats.rice.isf(false_alarm_probability, rho / (s_eff / math.sqrt(2.0)), scale=s_eff / math.sqrt(2.0))
    for a in (rho, mean, x):
        a.flags.writeable = False
    return rho, mean, x


def detection_threshold(background: BackgroundModel, false_alarm_probability: float) -> FloatArray:
    """``(n_delay, n_doppler)`` threshold T on A_k = |A_k| - A_bar for a false-alarm probability per cell.

    Rice model per cell with the static amplitude estimated from A_bar and the background's own fluctuation
    (module docstring). X(c) is tabulated on c / sigma in [0, 40] and interpolated; beyond, the Gaussian limit.
    """
    sigma = math.sqrt(background.noise_power)
    j = background.n_images
    rho, mean, x = _rice_threshold_table(float(false_alarm_probability), int(j))
    ratio = background.mean_magnitude / sigma
    far = rho[-1] + math.sqrt((1.0 + 1.0 / j) / 2.0) * float(scipy.stats.norm.isf(false_alarm_probability))
    # X: the cell's threshold on |A| / sigma; noise-consistent cells (A_bar below the noise mean + 2 std of a J-image
    # mean) get c_hat = 0 and the exact noise threshold sqrt(ln(1 / Pfa))
    gate = mean[0] + 2.0 * math.sqrt((1.0 - math.pi / 4.0) / j)
    x_clutter = np.where(ratio > mean[-1], far + (ratio - mean[-1]), np.interp(ratio, mean, x))
    x_cell = np.where(ratio <= gate, math.sqrt(math.log(1.0 / false_alarm_probability)), x_clutter)
    return sigma * x_cell - background.mean_magnitude


# --------------------------------------------------------------------------------------------------- peaks
@_jit
def _peaks(img, thr, guard_r, guard_c, max_peaks, edge):  # pragma: no cover - compiled
    """Local maxima above thr (circular in columns), accepted by decreasing value outside the accepted guards."""
    n_r, n_c = img.shape
    cand_v = np.empty(n_r * n_c)
    cand_r = np.empty(n_r * n_c, dtype=np.int64)
    cand_c = np.empty(n_r * n_c, dtype=np.int64)
    n = 0
    for r in range(edge, n_r - edge):
        for c in range(n_c):
            v = img[r, c]
            if v <= thr[r, c]:
                continue
            is_max = True
            for dr in range(-1, 2):
                rr = r + dr
                if rr < 0 or rr >= n_r:
                    continue
                for dc in range(-1, 2):
                    if dr == 0 and dc == 0:
                        continue
                    w = img[rr, (c + dc) % n_c]
                    # ties: the first cell in raster order wins
                    if w > v or (w == v and (dr < 0 or (dr == 0 and dc < 0))):
                        is_max = False
                        break
                if not is_max:
                    break
            if is_max:
                cand_v[n] = v
                cand_r[n] = r
                cand_c[n] = c
                n += 1
    order = np.argsort(-cand_v[:n], kind="mergesort")
    out_r = np.empty(max_peaks, dtype=np.int64)
    out_c = np.empty(max_peaks, dtype=np.int64)
    m = 0
    for i in order:
        if m >= max_peaks:
            break
        r, c = cand_r[i], cand_c[i]
        free = True
        for q in range(m):
            dc = abs(c - out_c[q])
            dc = min(dc, n_c - dc)
            if abs(r - out_r[q]) <= guard_r and dc <= guard_c:
                free = False
                break
        if free:
            out_r[m] = r
            out_c[m] = c
            m += 1
    return out_r[:m], out_c[:m]


def find_peaks(
    image: FloatArray,
    threshold: FloatArray | float,
    *,
    guard_delay: int,
    guard_doppler: int,
    max_peaks: int = 10,
    edge: int = 1,
) -> tuple[IntArray, IntArray]:
    """Seed 003's iterative peak detection on A_k (module docstring).

    Args:
        image: ``(n_delay, n_doppler)`` A_k; threshold: ``(n_delay, n_doppler)`` or scalar T; guard_delay,
        guard_doppler: suppression half-widths [cells] (one resolution cell: ``DelayDopplerAxes.guard_cells``);
        max_peaks: most peaks returned; edge: rows at each delay edge not searched (>= the fit half-window).

    Returns:
        ``(n,)`` rows and ``(n,)`` columns of the accepted peaks, by decreasing value.
    """
    img = np.ascontiguousarray(image, dtype=float)
    thr = np.ascontiguousarray(np.broadcast_to(np.asarray(threshold, dtype=float), img.shape))
    return _peaks(img, thr, int(guard_delay), int(guard_doppler), int(max_peaks), int(edge))


@functools.lru_cache(maxsize=16)
def _design_pinv(half_window: tuple[int, int]) -> tuple[IntArray, IntArray, FloatArray]:
    """Window offsets (rows, cols) ``(n_w,)`` and the ``(6, n_w)`` least-squares pseudo-inverse of the quadratic."""
    hr, hc = half_window
    dr, dc = np.meshgrid(np.arange(-hr, hr + 1), np.arange(-hc, hc + 1), indexing="ij")
    dr, dc = dr.ravel(), dc.ravel()
    x = np.stack([np.ones(dr.size), dr, dc, 0.5 * dr**2, dr * dc, 0.5 * dc**2], axis=1).astype(float)
    return dr, dc, np.linalg.pinv(x)


def fit_peaks(
    image: FloatArray,
    rows: IntArray,
    cols: IntArray,
    *,
    level: FloatArray | None = None,
    half_window: tuple[int, int] = (1, 1),
    log: bool = True,
) -> PeakFit:
    """Least-squares q(d) = c0 + g . d + d^T H d / 2 on a window around each peak (circular in Doppler).

    Args:
        image: ``(n_delay, n_doppler)`` A_k; rows, cols: ``(n,)`` peak cells (at least ``half_window[0]`` rows from
        the delay edges); level: ``(n,)`` background level A_bar at each peak added back to the window (default 0);
        half_window: (h_r, h_c) >= (1, 1) cells; log: fit ln(A_k + level) (default) or A_k (module docstring).

    Returns:
        :class:`PeakFit` in cells.
    """
    dr, dc, pinv = _design_pinv(tuple(half_window))
    n_c = image.shape[1]
    rows = np.asarray(rows, dtype=np.int64)
    cols = np.asarray(cols, dtype=np.int64)
    lev = np.zeros(rows.shape[0]) if level is None else np.asarray(level, dtype=float)
    win = image[rows[:, None] + dr[None, :], (cols[:, None] + dc[None, :]) % n_c]  # (n, n_w)
    if log:
        top = image[rows, cols] + lev
        win = np.log(np.maximum(win + lev[:, None], 1e-3 * np.maximum(top, 1e-300)[:, None]))
    coef = win @ pinv.T  # (n, 6): c0, g_r, g_c, H_rr, H_rc, H_cc
    g = coef[:, 1:3]
    h = np.stack([coef[:, 3], coef[:, 4], coef[:, 4], coef[:, 5]], axis=1).reshape(-1, 2, 2)
    det = h[:, 0, 0] * h[:, 1, 1] - h[:, 0, 1] ** 2
    ok = (h[:, 0, 0] < 0.0) & (det > 0.0)
    safe = np.where(ok, det, 1.0)
    off = (
        -np.stack([h[:, 1, 1] * g[:, 0] - h[:, 0, 1] * g[:, 1], -h[:, 0, 1] * g[:, 0] + h[:, 0, 0] * g[:, 1]], axis=1)
        / safe[:, None]
    )
    ok &= (np.abs(off[:, 0]) <= half_window[0]) & (np.abs(off[:, 1]) <= half_window[1])
    off = np.where(ok[:, None], off, 0.0)
    value = coef[:, 0] + 0.5 * np.einsum("ni,ni->n", g, off)
    amplitude = np.exp(value) if log else value + lev
    return PeakFit(off, amplitude, h, ok & (amplitude > 0.0), log)


def measure_peaks(
    fit: PeakFit,
    rows: IntArray,
    cols: IntArray,
    background: BackgroundModel,
    axes: DelayDopplerAxes,
    matched: FloatArray | None = None,
) -> DelayDopplerDetections:
    """Range, folded range-rate, R from the curvature and SNR of fitted peaks (module docstring).

    Args:
        fit: :func:`fit_peaks` (only rows with ``fit.ok`` are measured); rows, cols: ``(n,)`` the peak cells;
        background: the pair's :class:`BackgroundModel`; axes: its :class:`DelayDopplerAxes`; matched: the
        waveform's matched second-moment matrix M_0 ``(2, 2)`` in (tau [s], nu [Hz]) (``chirp_chain.
        pulse_train_information``), for the sandwich R of peaks flatter than the matched one (module docstring);
        None: R from the curvature alone.

    Returns:
        :class:`DelayDopplerDetections` of the good fits (origin = ORIGIN_NOISE).
    """
    ok = fit.ok
    r, c = np.asarray(rows)[ok], np.asarray(cols)[ok]
    off, h = fit.offset[ok], fit.hessian[ok]
    a0 = fit.amplitude[ok]
    delay = axes.delay_start_s + (r + off[:, 0]) * axes.delay_step_s
    span = axes.doppler_span_hz
    nu = (c - axes.n_doppler // 2 + off[:, 1]) * axes.doppler_step_hz
    nu = np.mod(nu + 0.5 * span, span) - 0.5 * span
    # R_(tau, nu) = -(sigma^2 / (2 a0^p)) D H_cells^-1 D, D = diag(dtau, dnu), p = 2 (log fit) or 1 (magnitude)
    det = h[:, 0, 0] * h[:, 1, 1] - h[:, 0, 1] ** 2
    hinv = np.stack([h[:, 1, 1], -h[:, 0, 1], -h[:, 0, 1], h[:, 0, 0]], axis=1).reshape(-1, 2, 2) / det[:, None, None]
    u = np.array([_C * axes.delay_step_s, -axes.wavelength_m * axes.doppler_step_hz])  # U D
    scale = background.noise_power / (2.0 * (a0 * a0 if fit.log else a0))
    if matched is None:
        cov = -scale[:, None, None] * hinv * (u[:, None] * u[None, :])
    else:  # sandwich: (sigma^2 / (2 a0^2)) M_fit^-1 M_0 M_fit^-1, M_fit = -H (log) or -H / a0, in cells
        d = np.array([axes.delay_step_s, axes.doppler_step_hz])
        m0 = np.asarray(matched, dtype=float) * (d[:, None] * d[None, :])
        m_fit_inv = -hinv * (1.0 if fit.log else a0[:, None, None])
        cells = (background.noise_power / (2.0 * a0 * a0))[:, None, None] * (m_fit_inv @ m0 @ m_fit_inv)
        cov = cells * (u[:, None] * u[None, :])
    n = r.shape[0]
    return DelayDopplerDetections(
        range_m=_C * delay,
        range_rate_mps=-axes.wavelength_m * nu,
        R=cov,
        snr=a0 * a0 / background.noise_power,
        delay_s=delay,
        doppler_hz=nu,
        row=r.astype(np.int64),
        col=c.astype(np.int64),
        origin=np.full(n, ORIGIN_NOISE, dtype=np.int64),
    )


def detect_delay_doppler(
    magnitude: FloatArray,
    background: BackgroundModel,
    axes: DelayDopplerAxes,
    *,
    false_alarm_probability: float | None = None,
    threshold: FloatArray | None = None,
    max_peaks: int = 10,
    half_window: tuple[int, int] = (1, 1),
    guard: tuple[int, int] | None = None,
    log: bool = True,
    matched: FloatArray | None = None,
) -> DelayDopplerDetections:
    """The whole section 4.1 chain on one pair's magnitude image: subtract, threshold, peaks, fits, measurements.

    Args:
        magnitude: ``(n_delay, n_doppler)`` |A_k|; background: :class:`BackgroundModel`; axes:
        :class:`DelayDopplerAxes`; false_alarm_probability: per cell (sets the threshold with
        :func:`detection_threshold`) unless ``threshold`` ``(n_delay, n_doppler)`` is given (precompute it once per
        episode: it depends only on the background); max_peaks; half_window: fit window; guard: suppression
        (rows, cols), default one resolution cell; log: fit the log-magnitude (default) or the magnitude; matched:
        M_0 of :func:`measure_peaks` (the sandwich R).

    Returns:
        :class:`DelayDopplerDetections` (origin unset: :func:`truth_origin`).
    """
    if threshold is None:
        if false_alarm_probability is None:
            raise ValueError("detect_delay_doppler: give false_alarm_probability or threshold")
        threshold = detection_threshold(background, false_alarm_probability)
    a_k = subtract_background(magnitude, background)
    gr, gc = axes.guard_cells if guard is None else guard
    rows, cols = find_peaks(a_k, threshold, guard_delay=gr, guard_doppler=gc, max_peaks=max_peaks, edge=half_window[0])
    fit = fit_peaks(a_k, rows, cols, level=background.mean_magnitude[rows, cols], half_window=half_window, log=log)
    return measure_peaks(fit, rows, cols, background, axes, matched)


def truth_origin(
    range_m: FloatArray,
    range_rate_mps: FloatArray,
    path_length_m: FloatArray,
    path_range_rate_mps: FloatArray,
    path_target: IntArray,
    path_direct: BoolArray,
    axes: DelayDopplerAxes,
) -> IntArray:
    """Truth origin of each peak (evaluation only; module docstring).

    Args:
        range_m, range_rate_mps: ``(n,)`` the peaks (range-rate folded); path_length_m, path_range_rate_mps:
        ``(P,)`` the pair's paths (unfolded); path_target: ``(P,)`` target index or -1; path_direct: ``(P,)`` True
        for tx-target-rx paths; axes: the pair's axes (resolution cells, wavelength, Doppler span).

    Returns:
        ``(n,)`` int64: target index, ORIGIN_GHOST, ORIGIN_CLUTTER or ORIGIN_NOISE.
    """
    lam = axes.wavelength_m
    span = lam * axes.doppler_span_hz  # range-rate period [m/s]
    cell_r = _C * axes.delay_resolution_s
    cell_v = lam * axes.doppler_resolution_hz
    dr = (np.asarray(range_m)[:, None] - np.asarray(path_length_m)[None, :]) / cell_r
    dv = np.asarray(range_rate_mps)[:, None] - np.asarray(path_range_rate_mps)[None, :]
    dv = (np.mod(dv + 0.5 * span, span) - 0.5 * span) / cell_v
    match = (np.abs(dr) <= 1.0) & (np.abs(dv) <= 1.0)  # (n, P)
    dist = np.where(match, dr * dr + dv * dv, np.inf)
    tgt = np.asarray(path_target)
    direct = np.asarray(path_direct, dtype=bool) & (tgt >= 0)
    out = np.full(dr.shape[0], ORIGIN_NOISE, dtype=np.int64)
    out[(match & (tgt < 0)[None, :]).any(axis=1)] = ORIGIN_CLUTTER
    out[(match & (tgt >= 0)[None, :]).any(axis=1)] = ORIGIN_GHOST
    d_direct = np.where(direct[None, :], dist, np.inf)
    hit = np.isfinite(d_direct).any(axis=1)
    if dr.shape[1]:
        best = np.argmin(d_direct, axis=1)
        out[hit] = tgt[best[hit]]
    return out
