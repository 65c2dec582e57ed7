r"""Receive beams of a uniform linear array and the SNR gain they give a target at direction theta.

Both fidelities read this module (``SensingConfig.array_beams``), so the parametric model and the signal path agree
on what the array does.

Array (``uwb_env.sensing.signal.chirp_chain``): element l = 0 .. L-1 sits at l d along the array axis; a plane wave
from theta (psi = theta - boresight off boresight) reaches it with the phase exp(-j 2 pi l d sin(psi) / lambda).
Beam m combines the elements as sum_l conj(w_ml) y_l with w_ml = exp(-j 2 pi l d u_m / lambda) (steered at
u_m = sin(psi_m)); its amplitude response is the array factor

    AF_m(psi) = sum_l exp(-j l x_m),   x_m = 2 pi d (sin psi - u_m) / lambda,
    |AF_m|^2 = sin^2(L x_m / 2) / sin^2(x_m / 2),

L at its centre, and its noise gain is sum_l |w_ml|^2 = L. Relative to the L coherent elements that the radar
constant assumes (``uwb_env.channel.radar_equation``: SNR proportional to L), a target at psi in beam m keeps

    g_m(psi) = |AF_m(psi)|^2 / L^2,          and a receiver that detects on every beam   g(psi) = max_m g_m(psi).

Beam sets (``kind``):

* ``dft``: the element-space DFT, w_ml = exp(j 2 pi l m / L): L orthogonal beams (their noises are independent)
  at u_m = m lambda / (L d) folded into [-lambda / (2 d), lambda / (2 d)); beams with |u_m| > 1 look into
  invisible space and are dropped. For L = 3, d = lambda / 2: psi_m = 0, +-41.8 deg; g = 1 at the centres and 4/9
  (-3.5 dB) midway (|psi| = 19.5 deg); g = 0.94 at the +-50 deg edge of the urban field of view. The radar keeps the
  strongest of a cell's detections over its beams (``sensing.signal.chirp_sensor``).
* ``boresight``: seed 003 eq. 6, the plain element sum (w = 1, one beam at boresight: nulls at +-41.8 deg for
  L = 3, d = lambda / 2; g = 0.1-0.4 25-35 deg off boresight, where the urban vehicles drive).
* ``steered``: a beam steered at every target, g = 1 everywhere (the parametric idealisation; no signal path
  can form it without knowing the targets).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from uwb_env.typing import FloatArray

BEAM_KINDS = ("dft", "boresight", "steered")

ComplexArray = npt.NDArray[np.complex128]


def beam_sines(kind: str, n_elements: int, spacing_m: float, wavelength_m: float) -> FloatArray | None:
    """``(M,)`` beam directions u_m = sin(psi_m) off boresight (module docstring), None for ``steered``.

    Args:
        kind: ``dft``, ``boresight`` or ``steered``; n_elements: L >= 1; spacing_m: d [m]; wavelength_m: lambda [m].
    """
    if kind not in BEAM_KINDS:
        raise ValueError(f"array_beams = {kind!r}: must be one of {BEAM_KINDS}")
    if kind == "steered":
        return None
    if kind == "boresight" or n_elements <= 1:
        return np.zeros(1)
    half = wavelength_m / (2.0 * spacing_m)  # the u-period of the array is lambda / d
    u = np.arange(n_elements) * wavelength_m / (n_elements * spacing_m)
    u = (u + half) % (2.0 * half) - half  # folded into [-lambda / (2 d), lambda / (2 d))
    return np.sort(u[np.abs(u) <= 1.0])


def beam_weights(sines: FloatArray, n_elements: int, spacing_m: float, wavelength_m: float) -> ComplexArray:
    """``(M, L)`` weights w_ml = exp(-j 2 pi l d u_m / lambda): beam m is sum_l conj(w_ml) y_l."""
    return np.exp(-2j * math.pi * spacing_m / wavelength_m * np.outer(sines, np.arange(n_elements)))


def beam_gains(
    off_boresight_rad: FloatArray, sines: FloatArray | None, n_elements: int, spacing_m: float, wavelength_m: float
) -> FloatArray:
    """``(M, ...)`` g_m(psi) = |AF_m(psi)|^2 / L^2 of every beam at off-boresight angles ``(...)`` [rad].

    ``sines`` None (``steered``) gives one row of ones.
    """
    psi = np.asarray(off_boresight_rad, dtype=float)
    if sines is None or n_elements <= 1:
        return np.ones((1, *psi.shape))
    x = 2.0 * math.pi * spacing_m / wavelength_m * (np.sin(psi)[None] - np.reshape(sines, (-1,) + (1,) * psi.ndim))
    half = 0.5 * x
    s = np.sin(half)
    small = np.abs(s) < 1e-12
    ratio = np.where(small, float(n_elements), np.sin(n_elements * half) / np.where(small, 1.0, s))
    return (ratio / n_elements) ** 2


def beam_gain(
    off_boresight_rad: FloatArray, sines: FloatArray | None, n_elements: int, spacing_m: float, wavelength_m: float
) -> FloatArray:
    """g(psi) = max_m g_m(psi) ``(...)``: the SNR factor, relative to L coherent elements, of a target at psi.

    Args:
        off_boresight_rad: ``(...)`` psi [rad]; sines: ``(M,)`` :func:`beam_sines` (None: ``steered``, g = 1);
        n_elements: L; spacing_m: d [m]; wavelength_m: lambda [m].
    """
    return beam_gains(off_boresight_rad, sines, n_elements, spacing_m, wavelength_m).max(axis=0)


def ml_direction(y: npt.NDArray[np.complex128], steering: ComplexArray, grid_rad: FloatArray) -> FloatArray:
    r"""Maximum-likelihood direction of one source per snapshot from its beam-space vector ``(n, M)`` [rad].

    The beams of ``kind = "dft"`` are orthogonal with equal noise gains (module docstring), so the beam-space noise
    is white and the ML estimate of one deterministic source in it is the beam-space "Bartlett" maximiser

        theta_hat = argmax_theta |b(theta)^H y|^2 / ||b(theta)||^2,

    b(theta) the beams' response ``steering`` ``(G, M)`` on ``grid_rad`` ``(G,)`` (ascending, evenly spaced), refined
    between grid points by the vertex of the parabola through the best point and its two neighbours (an edge point is
    kept). Its variance reaches the ULA CRLB (``uwb_env.sensing.parametric.azimuth_variance``) at high SNR.
    """
    y = np.asarray(y, dtype=complex).reshape(-1, steering.shape[1])
    power = np.abs(y @ steering.conj().T) ** 2 / np.sum(np.abs(steering) ** 2, axis=1)[None]  # (n, G)
    best = np.argmax(power, axis=1)
    step = float(grid_rad[1] - grid_rad[0]) if grid_rad.shape[0] > 1 else 0.0
    inner = (best > 0) & (best < grid_rad.shape[0] - 1)
    rows = np.arange(y.shape[0])
    lo, mid, hi = (power[rows, np.clip(best + d, 0, grid_rad.shape[0] - 1)] for d in (-1, 0, 1))
    curvature = lo - 2.0 * mid + hi
    shift = np.where(inner & (curvature < 0.0), 0.5 * (lo - hi) / np.where(curvature < 0.0, curvature, -1.0), 0.0)
    return grid_rad[best] + shift * step
