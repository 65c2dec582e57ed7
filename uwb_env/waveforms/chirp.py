r"""Gaussian-windowed linear chirp: delay-Doppler Fisher information and range / range-rate CRLB.

Seed 003 eq. 1 transmits s(t) = (pi kappa^2)^{-1/4} exp((+-j gamma - 1/(2 kappa^2)) t^2) (unit energy).
The seed's printed R(psi) mixes J and J^{-1} and has range-rate units of (rad/s)^2 m^2/s^2: it is dimensionally
inconsistent. We derive it again (Kershaw and Evans 1994, "Optimal waveform selection for tracking systems",
IEEE Trans. IT 40(5)).

Derivation.
    Received complex envelope mu(t; tau, omega) = a s(t - tau) e^{j omega t} in complex white noise of PSD N0,
    unknown phase. With SNR = E / N0 (E the received energy of the scan), the Fisher information of
    theta = (tau, omega) is J_ij = 2 SNR Re<d_i s, d_j s> minus the phase-nuisance terms, which vanish here because
    the pulse is centred (<t> = 0, <omega> = 0). For this s(t):

        |s|^2 is Gaussian with <t^2> = kappa^2 / 2,
        s'(t) = (-t / kappa^2 + 2 j gamma t) s(t)  =>  <omega^2> = int |s'|^2 = 1/(2 kappa^2) + 2 gamma^2 kappa^2,
        Re <-s', j t s> = -2 gamma <t^2> = -gamma kappa^2,

    so   J = 2 SNR [[1/(2 kappa^2) + 2 gamma^2 kappa^2, -gamma kappa^2], [-gamma kappa^2, kappa^2 / 2]],
    det J = SNR^2 (exactly, for every kappa and gamma), and

         J^{-1} = (1 / SNR) [[kappa^2, 2 gamma kappa^2], [2 gamma kappa^2, 1/kappa^2 + 4 gamma^2 kappa^2]]
    in units [[s^2, s], [s, (rad/s)^2]].

    Bistatic range r = c tau and range-rate rdot = -lambda omega / (2 pi) (a closing target raises the
    frequency), so U = diag(c, -lambda / (2 pi)) and R = U J^{-1} U^T:

        R_rr = c^2 kappa^2 / SNR                                   [m^2]
        R_dd = (lambda / 2 pi)^2 (1/kappa^2 + 4 gamma^2 kappa^2) / SNR   [(m/s)^2]
        R_rd = -c (lambda / 2 pi) 2 gamma kappa^2 / SNR            [m^2/s]

    Checks: gamma = 0 gives var(tau) = 1 / (2 SNR <omega^2>), the classic RMS-bandwidth bound; the correlation
    rho = -2 gamma kappa^2 / sqrt(1 + 4 gamma^2 kappa^4) is negative for an up-sweep (gamma > 0) and positive for a
    down-sweep, as the seed states; R_rr grows as kappa^2; det R = (c lambda / 2 pi)^2 / SNR^2 > 0 always.

    The coherent pulse train of the seed (n_pulses pulses every pri_s) only sets the integrated energy here: the
    tracker's measurement is the delay-Doppler peak of one compressed chirp, as in Kershaw and Evans.
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


def gaussian_chirp_fim(kappa: float, gamma: float, snr: FloatArray) -> FloatArray:
    """Delay-Doppler Fisher information of the Gaussian chirp.

    Args:
        kappa: pulse duration parameter [s]; gamma: chirp rate [rad/s^2]; snr: ``(N,)`` E/N0 (linear).

    Returns:
        ``(N, 2, 2)`` J for (tau [s], omega [rad/s]).
    """
    snr = np.asarray(snr, dtype=float)
    base = np.array(
        [[1.0 / (2 * kappa**2) + 2 * gamma**2 * kappa**2, -gamma * kappa**2], [-gamma * kappa**2, kappa**2 / 2.0]]
    )
    return 2.0 * snr[..., None, None] * base


def gaussian_chirp_range_rate_covariance(
    kappa: float, gamma: float, wavelength_m: float, snr: FloatArray
) -> FloatArray:
    """CRLB covariance of (bistatic range [m], bistatic range-rate [m/s]), closed form (module docstring).

    Args:
        kappa [s], gamma [rad/s^2], wavelength_m [m], snr ``(N,)`` E/N0 (linear, > 0).

    Returns:
        ``(N, 2, 2)`` R.
    """
    inv = 1.0 / np.asarray(snr, dtype=float)
    q = wavelength_m / (2.0 * math.pi)
    base = np.array(
        [
            [SPEED_OF_LIGHT_MPS**2 * kappa**2, -SPEED_OF_LIGHT_MPS * q * 2 * gamma * kappa**2],
            [-SPEED_OF_LIGHT_MPS * q * 2 * gamma * kappa**2, q**2 * (1.0 / kappa**2 + 4 * gamma**2 * kappa**2)],
        ]
    )
    return inv[..., None, None] * base


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

    def fisher_information(self, snr: FloatArray) -> FloatArray:
        """``(N, 2, 2)`` delay-Doppler Fisher information at E/N0 ``snr`` (N,)."""
        return gaussian_chirp_fim(self.config.pulse_duration_s, self.gamma, snr)

    @property
    def unit_covariance(self) -> FloatArray:
        """``(2, 2)`` covariance at SNR = 1; the CRLB scales as 1 / SNR, so R(snr) = unit_covariance / snr."""
        return self.covariance(np.ones(1))[0]

    def covariance(self, snr: FloatArray) -> FloatArray:
        """``(N, 2, 2)`` (range, range-rate) CRLB covariance at E/N0 ``snr`` (N,)."""
        return gaussian_chirp_range_rate_covariance(self.config.pulse_duration_s, self.gamma, self.wavelength_m, snr)
