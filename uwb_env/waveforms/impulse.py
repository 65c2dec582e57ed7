r"""UWB impulse-radio waveforms (seeds 000 and 002): RMS bandwidth, ToA CRLB, pulse integration.

The pulse is band-pass with a Gaussian power spectrum |P(f)|^2 around ``fc`` (the high-order limit of the
Gaussian-derivative pulses of seed 000 section II-B), -10 dB wide ``B``:
    |P(f)|^2 ~ exp(-(f - fc)^2 / (2 sigma_f^2)),  sigma_f = B / (2 sqrt(2 ln 10)).

ToA CRLB of the envelope (non-coherent receivers, seeds 000 and 002): var(tau) = 1 / (8 pi^2 beta^2 SNR) with
beta = sigma_f the RMS bandwidth about the centre frequency and SNR = E/N0 of the scan. Coherent integration of
Ns pulses multiplies the SNR by Ns (seed 000 eq. 11); the scan takes Ns / PRF seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from uwb_env.config import ImpulseWaveformConfig
from uwb_env.constants import SPEED_OF_LIGHT_MPS
from uwb_env.typing import FloatArray
from uwb_env.units import linear_to_db
from uwb_env.waveforms.toa_models import energy_detector_toa_std

_TEN_DB_HALF_WIDTH = 2.0 * math.sqrt(2.0 * math.log(10.0))


def gaussian_pulse_rms_bandwidth(bandwidth_hz: float) -> float:
    """RMS bandwidth [Hz] about fc of a Gaussian-spectrum pulse of -10 dB width ``bandwidth_hz``."""
    return bandwidth_hz / _TEN_DB_HALF_WIDTH


def toa_crlb_variance(rms_bandwidth_hz: float, snr: FloatArray) -> FloatArray:
    """ToA variance bound [s^2] = 1 / (8 pi^2 beta^2 SNR), ``snr`` (N,) E/N0 linear."""
    return 1.0 / (8.0 * math.pi**2 * rms_bandwidth_hz**2 * np.asarray(snr, dtype=float))


@dataclass(frozen=True, slots=True)
class ImpulseWaveform:
    """A UWB impulse waveform of the library (built from ImpulseWaveformConfig)."""

    config: ImpulseWaveformConfig

    measurement_dim: int = 1
    measurement_names: tuple[str, ...] = ("bistatic_range",)

    @property
    def name(self) -> str:
        """Waveform name."""
        return self.config.name

    @property
    def center_freq_hz(self) -> float:
        """Centre frequency [Hz]."""
        return self.config.center_freq_hz

    @property
    def wavelength_m(self) -> float:
        """Wavelength at the centre frequency [m]."""
        return SPEED_OF_LIGHT_MPS / self.config.center_freq_hz

    @property
    def rms_bandwidth_hz(self) -> float:
        """RMS bandwidth beta about the centre frequency [Hz]."""
        return gaussian_pulse_rms_bandwidth(self.config.bandwidth_hz)

    @property
    def dwell_time_s(self) -> float:
        """Scan (frame) duration Ns / PRF [s] (seed 000 section II-B)."""
        return self.config.n_pulses / self.config.prf_hz

    def scan_energy_j(self, tx_power_w: float) -> float:
        """Transmitted energy per scan [J]: average power x frame time = P Ns / PRF."""
        return tx_power_w * self.dwell_time_s

    @property
    def unit_covariance(self) -> FloatArray | None:
        """``(1, 1)`` covariance at SNR = 1 when R scales as 1 / SNR (the CRLB model), else None."""
        if self.config.toa_error_model != "crlb":
            return None
        return self.covariance(np.ones(1))[0]

    def range_variance(self, snr: FloatArray) -> FloatArray:
        """``(N,)`` bistatic-range variance [m^2] at scan E/N0 ``snr`` (N,) for the configured ToA model."""
        snr = np.asarray(snr, dtype=float)
        if self.config.toa_error_model == "crlb":
            return SPEED_OF_LIGHT_MPS**2 * toa_crlb_variance(self.rms_bandwidth_hz, snr)
        per_pulse_db = linear_to_db(np.maximum(snr, 1e-300) / self.config.n_pulses)
        sigma_t = energy_detector_toa_std(per_pulse_db, self.config.n_pulses, self.config.energy_detector)
        return (SPEED_OF_LIGHT_MPS * sigma_t) ** 2

    def covariance(self, snr: FloatArray) -> FloatArray:
        """``(N, 1, 1)`` bistatic-range covariance at scan E/N0 ``snr`` (N,)."""
        return self.range_variance(snr)[..., None, None]
