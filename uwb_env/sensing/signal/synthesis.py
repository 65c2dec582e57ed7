r"""Kernels that synthesise sampled UWB impulse-radio scans (seed 000 eqs. 10-12; seed 002's multipath background).

Units: a scan is in units of the noise standard deviation after pulse integration, so the noise samples are
N(0, 1) and a path of integrated E/N0 = SNR carries sum_k p_k^2 = 2 SNR (its matched-filter output SNR is then
2 E / N0, the convention of the ToA CRLB; derivation: N0 = 2 / fs makes the per-sample noise variance
(N0 / 2) fs = 1, and sum_k p_k^2 = fs int p^2 dt = fs E = 2 E / N0).

The pulse is the Gaussian-spectrum pulse of ``uwb_env.waveforms.impulse``: a carrier at fc under the envelope
exp(-t^2 / (2 s^2)) with s = 1 / (2 sqrt(2) pi sigma_f), whose power spectrum exp(-(f - fc)^2 / (2 sigma_f^2)) has
the waveform's RMS bandwidth sigma_f. Its energy is int p^2 = sqrt(pi) s / 2 for unit amplitude (fc s >> 1/(2 pi)).
"""

from __future__ import annotations

import math

import numpy as np

from uwb_env.typing import FloatArray


def pulse_envelope_std_s(rms_bandwidth_hz: float) -> float:
    """Time-domain std s [s] of the Gaussian pulse envelope of RMS bandwidth sigma_f."""
    return 1.0 / (2.0 * math.sqrt(2.0) * math.pi * rms_bandwidth_hz)


def unit_pulses(
    t_s: FloatArray, delay_s: FloatArray, phase: FloatArray, fc_hz: float, s: float, fs_hz: float
) -> FloatArray:
    """``(..., N)`` pulses delayed by ``delay_s`` (...,) with carrier phase ``phase`` (...,), each sum_k p_k^2 = 1.

    p(t) = A exp(-(t - tau)^2 / (2 s^2)) cos(2 pi fc (t - tau) + phase), A = (fs sqrt(pi) s / 2)^(-1/2).
    """
    dt = t_s - np.asarray(delay_s)[..., None]
    amp = 1.0 / math.sqrt(fs_hz * math.sqrt(math.pi) * s / 2.0)
    return amp * np.exp(-0.5 * (dt / s) ** 2) * np.cos(2.0 * math.pi * fc_hz * dt + np.asarray(phase)[..., None])


def exponential_profile(
    rng: np.random.Generator, n_paths: int, spacing_s: float, decay_s: float, power_ratio: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Seed 002's multipath: ``n_paths`` paths ``spacing_s`` apart after the direct path, powers ~ exp(-tau / decay).

    Each path's amplitude is Rayleigh with mean power from the profile, scaled so the expected total power is
    ``power_ratio`` times the direct path's; its carrier phase is uniform. Returns ``(excess delays (L,) [s],
    amplitudes (L,) relative to the direct path, phases (L,))``.
    """
    tau = spacing_s * np.arange(1, n_paths + 1)
    mean_power = np.exp(-tau / decay_s)
    mean_power *= power_ratio / mean_power.sum() if n_paths else 1.0
    amplitude = np.sqrt(mean_power * rng.standard_exponential(n_paths))
    return tau, amplitude, rng.uniform(0.0, 2.0 * math.pi, n_paths)


def points_on_ellipse(tx: FloatArray, rx: FloatArray, major_m: FloatArray, angle: FloatArray) -> FloatArray:
    """``(..., 2)`` points at ``angle`` of the ellipses of foci ``tx``, ``rx`` (2,), major axis ``major_m`` (...,)."""
    centre = 0.5 * (tx + rx)
    focal = 0.5 * float(np.linalg.norm(rx - tx))
    a = 0.5 * np.asarray(major_m)
    b = np.sqrt(np.maximum(a * a - focal * focal, 0.0))
    axis = (rx - tx) / (2.0 * focal) if focal > 0.0 else np.array([1.0, 0.0])  # monostatic: a circle
    normal = np.array([-axis[1], axis[0]])
    return centre + (a * np.cos(angle))[..., None] * axis + (b * np.sin(angle))[..., None] * normal


def segment_distance(p: FloatArray, a: FloatArray, b: FloatArray) -> FloatArray:
    """Distance from points ``p`` (..., 2) to the segments ``a``-``b`` (..., 2) (broadcast)."""
    ab = b - a
    t = np.clip(np.sum((p - a) * ab, axis=-1) / np.maximum(np.sum(ab * ab, axis=-1), 1e-300), 0.0, 1.0)
    return np.linalg.norm(p - (a + t[..., None] * ab), axis=-1)


def ar1_step(state: FloatArray, rho: float, std: float, innovation: FloatArray) -> FloatArray:
    """One step of a stationary AR(1) of marginal std ``std``: rho x + sqrt(1 - rho^2) std e."""
    return rho * state + math.sqrt(1.0 - rho * rho) * std * innovation
