"""Waveform library: Gaussian chirps (seed 003) and UWB impulses (seeds 000, 002) with CRLB covariances."""

from uwb_env.waveforms.chirp import (
    ChirpWaveform,
    chirp_rate,
    fold_periodic,
    gaussian_chirp_fim,
    gaussian_chirp_range_rate_covariance,
    pulse_train_time_spread,
    range_doppler_coupling_m,
)
from uwb_env.waveforms.impulse import ImpulseWaveform, gaussian_pulse_rms_bandwidth, toa_crlb_variance
from uwb_env.waveforms.library import Waveform, WaveformLibrary, build_waveform
from uwb_env.waveforms.toa_models import energy_detector_coefficients, energy_detector_toa_std

__all__ = [
    "ChirpWaveform",
    "ImpulseWaveform",
    "Waveform",
    "WaveformLibrary",
    "build_waveform",
    "chirp_rate",
    "energy_detector_coefficients",
    "energy_detector_toa_std",
    "fold_periodic",
    "gaussian_chirp_fim",
    "gaussian_chirp_range_rate_covariance",
    "gaussian_pulse_rms_bandwidth",
    "pulse_train_time_spread",
    "range_doppler_coupling_m",
    "toa_crlb_variance",
]
