r"""Bistatic radar equation, bistatic radar constant and geometry (seed 000 eqs. 1-8).

SNR = E_r N_s / N0 = Gamma sigma / ((l_t l_r / d0^2)^rho)                  (seed 000 eq. 2, generalised to rho)

with the bistatic radar constant, per unit RCS [1/m^2] (seed 000 eq. 3 with the 802.15.4a path loss of eq. 9):

Gamma = (E_scan / N0) G_t G_r L  int p(f) (4 pi f^2 / c^2) g(f, d0)^2 df,   g = one-way path gain at d0,

where E_scan is the transmitted energy of the scan (pulse integration included), p(f) the normalised power
spectrum of the waveform (Gaussian, centre fc, RMS width beta), N0 = k T0 F, and L the number of array elements
combined coherently. In free space this is seed 000 eq. 1: E = int E(f) Gt Gr sigma (c/f)^2 / ((4 pi)^3 (lt lr)^2).
SNR here is E/N0 of the integrated scan, the convention of every waveform CRLB and Pd formula in uwb_env.
"""

from __future__ import annotations

import numpy as np

from uwb_env.channel.path_loss import path_gain
from uwb_env.config import ChannelConfig
from uwb_env.constants import BOLTZMANN_J_PER_K, REFERENCE_TEMPERATURE_K, SPEED_OF_LIGHT_MPS
from uwb_env.typing import FloatArray
from uwb_env.units import db_to_linear


def noise_psd(noise_figure_db: float) -> float:
    """One-sided noise PSD N0 = k T0 F [W/Hz]."""
    return BOLTZMANN_J_PER_K * REFERENCE_TEMPERATURE_K * db_to_linear(noise_figure_db)


def _spectrum(center_freq_hz: float, rms_bandwidth_hz: float, n_grid: int) -> tuple[FloatArray, FloatArray]:
    """Frequency grid over fc +- 5 beta (positive frequencies) and the normalised Gaussian power spectrum on it."""
    lo = max(center_freq_hz - 5.0 * rms_bandwidth_hz, center_freq_hz * 1e-3)
    f = np.linspace(lo, center_freq_hz + 5.0 * rms_bandwidth_hz, n_grid)
    p = np.exp(-0.5 * ((f - center_freq_hz) / rms_bandwidth_hz) ** 2)
    return f, p / np.trapezoid(p, f)


def bistatic_radar_constant(
    scan_energy_j: float,
    center_freq_hz: float,
    rms_bandwidth_hz: float,
    tx_gain_db: float,
    rx_gain_db: float,
    noise_figure_db: float,
    n_elements: int,
    channel: ChannelConfig,
    n_grid: int = 801,
) -> float:
    """Gamma [1/m^2] such that SNR = Gamma sigma / (l_t l_r / d0^2)^rho (module docstring).

    The spectrum integral runs over fc +- 5 beta (positive frequencies only) with the trapezoidal rule.
    """
    f, p = _spectrum(center_freq_hz, rms_bandwidth_hz, n_grid)
    g0 = path_gain(f, channel.reference_distance_m, center_freq_hz, channel)
    integral = np.trapezoid(p * 4.0 * np.pi * f**2 / SPEED_OF_LIGHT_MPS**2 * g0**2, f)
    gains = db_to_linear(tx_gain_db + rx_gain_db) * n_elements
    return float(scan_energy_j / noise_psd(noise_figure_db) * gains * integral)


def direct_path_snr(
    scan_energy_j: float,
    center_freq_hz: float,
    rms_bandwidth_hz: float,
    tx_gain_db: float,
    rx_gain_db: float,
    noise_figure_db: float,
    distance_m: FloatArray,
    channel: ChannelConfig,
    n_grid: int = 801,
) -> FloatArray:
    """Integrated E/N0 of the direct Tx -> Rx path at ``distance_m`` [m].

    One-way Friis with the 802.15.4a path loss:
    SNR = (E_scan / N0) G_t G_r int p(f) g(f, d) df, p the normalised spectrum (as in :func:`bistatic_radar_constant`).
    """
    f, p = _spectrum(center_freq_hz, rms_bandwidth_hz, n_grid)
    d = np.asarray(distance_m, dtype=float)
    g = path_gain(f, d[..., None], center_freq_hz, channel)
    gains = db_to_linear(tx_gain_db + rx_gain_db)
    return scan_energy_j / noise_psd(noise_figure_db) * gains * np.trapezoid(p * g, f, axis=-1)


def leg_lengths(tx_pos: FloatArray, rx_pos: FloatArray, tgt_pos: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Transmitter-target and receiver-target distances.

    Args: tx_pos (T, 2), rx_pos (R, 2), tgt_pos (K, 2) [m].
    Returns: l_t (T, K), l_r (R, K) [m].
    """
    lt = np.linalg.norm(tgt_pos[None] - tx_pos[:, None], axis=-1)
    lr = np.linalg.norm(tgt_pos[None] - rx_pos[:, None], axis=-1)
    return lt, lr


def bistatic_range(tx_pos: FloatArray, rx_pos: FloatArray, tgt_pos: FloatArray) -> FloatArray:
    """Bistatic range l_t + l_r for all (tx, rx, target) triples, ``(T, R, K)`` [m]."""
    lt, lr = leg_lengths(tx_pos, rx_pos, tgt_pos)
    return lt[:, None, :] + lr[None, :, :]


def bistatic_range_rate(tx_pos: FloatArray, rx_pos: FloatArray, tgt_pos: FloatArray, tgt_vel: FloatArray) -> FloatArray:
    """d/dt (l_t + l_r) = v . (u_t + u_r), u the unit vectors from the nodes to the target; ``(T, R, K)`` [m/s].

    Args: tx_pos (T, 2), rx_pos (R, 2), tgt_pos (K, 2) [m], tgt_vel (K, 2) [m/s].
    """
    dt = tgt_pos[None] - tx_pos[:, None]
    dr = tgt_pos[None] - rx_pos[:, None]
    vt = np.einsum("tkd,kd->tk", dt, tgt_vel) / np.linalg.norm(dt, axis=-1)
    vr = np.einsum("rkd,kd->rk", dr, tgt_vel) / np.linalg.norm(dr, axis=-1)
    return vt[:, None, :] + vr[None, :, :]


def bistatic_snr(
    gamma: FloatArray,
    rcs_m2: FloatArray,
    lt: FloatArray,
    lr: FloatArray,
    rho: float,
    d0: float,
    loss_db: FloatArray | float = 0.0,
) -> FloatArray:
    """SNR = Gamma sigma / (l_t l_r / d0^2)^rho / L_walls.

    Args:
        gamma: ``(T, R)`` radar constants [1/m^2]; rcs_m2: ``(K,)`` or ``(T, R, K)`` [m^2];
        lt: ``(T, K)``, lr: ``(R, K)`` [m]; loss_db: ``(T, R, K)`` obstruction loss (inf = blocked).

    Returns:
        ``(T, R, K)`` linear E/N0.
    """
    product = (lt[:, None, :] * lr[None, :, :]) / d0**2
    return gamma[:, :, None] * rcs_m2 / product**rho * 10.0 ** (-np.asarray(loss_db) / 10.0)


def snr_on_iso_range(gamma: FloatArray, beta_rad: FloatArray, bistatic_range_m: float, baseline_m: float) -> FloatArray:
    """Seed 000 eq. 7 (free space, unit RCS): SNR = 4 Gamma (1 + cos beta)^2 / ((l_t + l_r)^2 - l^2)^2."""
    return 4.0 * gamma * (1.0 + np.cos(beta_rad)) ** 2 / (bistatic_range_m**2 - baseline_m**2) ** 2
