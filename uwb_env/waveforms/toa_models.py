r"""Seed 002's three-region ToA error model of an energy-detector (threshold) ToA estimator (eq. 9, Table).

    log10 sigma = log10(T_a / sqrt 12)          SNR <= SNR_LB   (ToA uniform over the observation window)
    20 log10(sigma / 1 ns) = A + B SNR_dB       SNR_LB < SNR < SNR_UB   (transition)
    log10 sigma = log10(T_int / sqrt 12)        SNR >= SNR_UB   (uniform within one energy bin)

SNR is per pulse, gamma = P_r / (PRF N0) (seed 002 eq. 1). The seed's garbled middle line is read as
z0 = 20 log10(sigma / ns): with its Table (T_int = 4 ns, T_a = 100 ns) it joins both asymptotes to within its
rounding. As the seed says, A and B follow from T_int, T_a, SNR_LB and SNR_UB: we compute them by continuity
(B ~ -1.75 vs the Table's rounded -1.73). The Table's thresholds (N_pulse, SNR_LB, SNR_UB) = (32, -4, 12),
(128, -1, 15), (512, 2, 18) dB move 3 dB per factor 4 in N_pulse; other N_pulse follow that law.
"""

from __future__ import annotations

import math

import numpy as np

from uwb_env.config import EnergyDetectorToaConfig
from uwb_env.typing import FloatArray

SEED002_TABLE = {32: (-4.0, 12.0, 21.93, -1.73), 128: (-1.0, 15.0, 27.13, -1.73), 512: (2.0, 18.0, 32.33, -1.73)}
"""Seed 002's Table (N_pulse: SNR_LB [dB], SNR_UB [dB], A, B) for T_int = 4 ns, T_a = 100 ns."""


def energy_detector_thresholds_db(n_pulses: int) -> tuple[float, float]:
    """(SNR_LB, SNR_UB) [dB]: the Table's values at 128 pulses, shifted 3 dB per factor 4 in ``n_pulses``."""
    shift = 3.0 * math.log(n_pulses / 128.0, 4.0)
    return -1.0 + shift, 15.0 + shift


def energy_detector_coefficients(n_pulses: int, cfg: EnergyDetectorToaConfig) -> tuple[float, float]:
    """(A, B) of the transition line z0 = A + B SNR_dB, from continuity with both asymptotes."""
    lb, ub = energy_detector_thresholds_db(n_pulses)
    z_lo = 20.0 * math.log10(cfg.observation_window_s / math.sqrt(12.0) / 1e-9)
    z_hi = 20.0 * math.log10(cfg.integration_time_s / math.sqrt(12.0) / 1e-9)
    b = (z_hi - z_lo) / (ub - lb)
    return z_lo - b * lb, b


def energy_detector_toa_std(snr_per_pulse_db: FloatArray, n_pulses: int, cfg: EnergyDetectorToaConfig) -> FloatArray:
    """ToA standard deviation [s] of the energy detector at per-pulse SNR ``snr_per_pulse_db`` (N,) [dB]."""
    snr_db = np.asarray(snr_per_pulse_db, dtype=float)
    lb, ub = energy_detector_thresholds_db(n_pulses)
    a, b = energy_detector_coefficients(n_pulses, cfg)
    middle = 1e-9 * 10.0 ** ((a + b * snr_db) / 20.0)
    lo = cfg.observation_window_s / math.sqrt(12.0)
    hi = cfg.integration_time_s / math.sqrt(12.0)
    return np.where(snr_db <= lb, lo, np.where(snr_db >= ub, hi, middle))
