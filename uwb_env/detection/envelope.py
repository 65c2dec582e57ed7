r"""In-sensor front end of seed 000 section IV: envelope, direct-path ToA, alignment, clutter removal, rectification.

Every kernel works on a batch of scans, arrays ``(..., N)`` of N samples (one row per transmitter-receiver pair),
in sample units (multiply by Ts = 1 / fs for seconds).

* Envelope (IV-B): square-law then low-pass, eps = h * r^2, with a Gaussian low-pass h of std ``lpf_std`` samples
  (it must pass the envelope's band and reject the 2 fc component of r^2).
* Direct-path ToA (IV-C): jump back from the strongest sample and search forward for the first crossing of a fraction
  of it (the jump-back-search-forward criterion), with linear interpolation between the samples around the crossing.
* Alignment (IV-C and footnote 11): the current scan is moved onto the reference's time base by the difference of
  the direct-path ToAs, refined by the peak of the cross-correlation around the direct path (parabolic
  interpolation); the fractional shift is applied in the frequency domain (the seed's "interpolation at a higher
  sampling rate").
* Clutter removal: d = eps - eps_er (eq. 13), or seed 001's exponential-averaging background
  b_k = alpha b_{k-1} + (1 - alpha) eps_k; ghost mitigation by half-wave rectification (IV-D).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.ndimage import gaussian_filter1d

from uwb_env.typing import FloatArray


def square_law_envelope(scans: FloatArray, lpf_std: float) -> FloatArray:
    """``(..., N)`` envelope h * r^2 of real scans ``(..., N)``; ``lpf_std`` the low-pass std [samples]."""
    return gaussian_filter1d(np.square(scans), lpf_std, axis=-1, mode="nearest", truncate=4.0)


def direct_path_toa(envelope: FloatArray, threshold_ratio: float, jump_back: int) -> FloatArray:
    """``(...,)`` direct-path ToA [samples, fractional] by jump back and search forward.

    From the strongest sample k*, jump back ``jump_back`` samples and search forward for the first sample above
    ``threshold_ratio`` x eps[k*]; the crossing is interpolated linearly between that sample and the one before.
    """
    n = envelope.shape[-1]
    k_max = np.argmax(envelope, axis=-1)
    peak = np.take_along_axis(envelope, k_max[..., None], axis=-1)[..., 0]
    level = threshold_ratio * peak
    idx = np.arange(n)
    start = np.maximum(k_max - jump_back, 1)
    above = (envelope > level[..., None]) & (idx >= start[..., None]) & (idx <= k_max[..., None])
    k = np.argmax(above, axis=-1)  # first crossing (k* itself at the latest)
    e1 = np.take_along_axis(envelope, k[..., None], axis=-1)[..., 0]
    e0 = np.take_along_axis(envelope, (k - 1)[..., None], axis=-1)[..., 0]
    frac = np.clip((level - e0) / np.maximum(e1 - e0, 1e-300), 0.0, 1.0)
    return (k - 1) + frac


def fractional_shift(x: FloatArray, shift: FloatArray) -> FloatArray:
    """``(..., N)`` signals ``x`` delayed by ``shift`` (...,) samples (negative: advanced), y[k] = x[k - shift].

    Band-limited (frequency-domain) interpolation; the scan is zero-padded by more than the largest shift (to a
    power of two) so the circular wrap cannot bring the end of the scan round to its start.
    """
    n = x.shape[-1]
    shift = np.asarray(shift, dtype=float)
    m = 1 << (math.ceil(math.log2(n + 2.0 * float(np.max(np.abs(shift), initial=0.0)) + 16.0)))
    spec = np.fft.rfft(x, m, axis=-1)
    phase = (-2.0 * np.pi / m) * np.arange(m // 2 + 1) * shift[..., None]
    spec *= np.cos(phase) + 1j * np.sin(phase)
    return np.fft.irfft(spec, m, axis=-1)[..., :n]


def parabolic_peak(y_minus: FloatArray, y0: FloatArray, y_plus: FloatArray) -> FloatArray:
    """Offset in [-0.5, 0.5] of the vertex of the parabola through (-1, y-), (0, y0), (1, y+)."""
    den = y_minus - 2.0 * y0 + y_plus
    with np.errstate(divide="ignore", invalid="ignore"):
        off = np.where(den < 0.0, 0.5 * (y_minus - y_plus) / den, 0.0)
    return np.clip(off, -0.5, 0.5)


def fine_alignment(current: FloatArray, reference: FloatArray, center: FloatArray, half_window: int, max_lag: int):
    """``(...,)`` residual delay [samples] of ``current`` relative to ``reference`` (both ``(..., N)``).

    The cross-correlation sum_k c[k] r[k - lag] over the window ``center`` +- ``half_window`` is evaluated for integer
    lags in [-max_lag, max_lag] and its peak refined by a parabola.
    """
    n = current.shape[-1]
    lags = np.arange(-max_lag, max_lag + 1)
    k = np.rint(np.asarray(center))[..., None].astype(np.int64) + np.arange(-half_window, half_window + 1)
    k = np.clip(k, max_lag, n - 1 - max_lag)  # (..., W)
    c = np.take_along_axis(current, k, axis=-1)  # (..., W)
    r = np.take_along_axis(
        reference[..., None, :], np.clip(k[..., None, :] - lags[:, None], 0, n - 1), axis=-1
    )  # (..., L, W)
    xc = np.einsum("...w,...lw->...l", c, r)
    best = np.clip(np.argmax(xc, axis=-1), 1, lags.size - 2)
    y = [np.take_along_axis(xc, (best + d)[..., None], axis=-1)[..., 0] for d in (-1, 0, 1)]
    return lags[best] + parabolic_peak(*y)


def align_to_reference(
    current: FloatArray,
    reference: FloatArray,
    toa_current: FloatArray,
    toa_reference: FloatArray,
    half_window: int,
    max_lag: int = 2,
) -> tuple[FloatArray, FloatArray]:
    """Move the current envelopes onto the reference's time base: direct-path ToAs, then cross-correlation.

    Args: current, reference ``(..., N)``; their direct-path ToAs ``(...,)`` [samples]; the correlation window
    half-width and the largest residual lag [samples].

    Returns ``(aligned current (..., N), total delay removed (...,) [samples])``.
    """
    coarse = toa_current - toa_reference
    shifted = fractional_shift(current, -coarse)
    fine = fine_alignment(shifted, reference, toa_reference, half_window, max_lag)
    return fractional_shift(current, -(coarse + fine)), coarse + fine


def exponential_background(background: FloatArray, envelope: FloatArray, alpha: float) -> FloatArray:
    """Seed 001's exponential-averaging background: alpha b + (1 - alpha) eps."""
    return alpha * background + (1.0 - alpha) * envelope


def rectified_difference(envelope: FloatArray, background: FloatArray) -> FloatArray:
    """Clutter removal (seed 000 eq. 13) and ghost mitigation: max(eps - background, 0)."""
    return np.maximum(envelope - background, 0.0)
