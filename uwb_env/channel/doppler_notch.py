r"""The zero-Doppler clutter notch of a pulse train: static clutter masks targets whose folded Doppler is near zero.

Seed 003 section 4.1 subtracts the average magnitude image of the scene (background averaging) from each
delay-Doppler image. Static scatterers (vegetation, the direct path) sit at zero Doppler; their echoes' phases
fluctuate from scan to scan (seed 003 eq. 2: random phases; wind in the vegetation), so the subtraction leaves a
residue at zero Doppler in every delay cell that holds clutter. The train samples the Doppler once per PRI T1, so a
target whose bistatic Doppler f = -rdot / lambda is near a multiple of 1 / T1 -- a blind speed, rdot = k lambda / T1
-- folds onto the clutter line and competes with the residue. A radar avoids its blind speeds by changing its PRI;
this is the waveform trade-off the scheduler can exploit (``uwb_env.scenarios.urban_intersection``).

Model (parametric path; its constants are calibrated on the signal path):

    SCNR = SNR / (1 + eta CNR(r) G(f_fold)),

    CNR(r)  = sum_c SNR_c exp(-(r - r_c)^2 / (2 sigma_r^2))   static scatterers' echoes over the compressed pulse,
              SNR_c from the bistatic radar equation of each visible scatterer (RCS sigma_c) like a target's,
              sigma_r = c / sqrt(2 (a + gamma^2 / a)), a = 1 / (2 kappa^2): the Gaussian chirp's |chi(tau, 0)|^2
              (``uwb_env.waveforms.chirp.compressed_range_spread_m``),
    G(f)    = exp(-f^2 / (2 sigma_f^2)),  sigma_f^2 = sigma_D^2 + s^2: the train's Doppler main lobe,
              |D_B(f)|^2 / B^2 ~ exp(-f^2 / (2 sigma_D^2)) with sigma_D = sqrt(3/2) / (pi T1 sqrt(B^2 - 1)) (curvature
              of the Dirichlet kernel at 0), widened by the clutter's own Doppler spread s,
    f_fold  = the target's Doppler folded into [-1/(2 T1), 1/(2 T1)),
    eta     = the fraction of the clutter power the background subtraction leaves (``ClutterConfig.residue_fraction``).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from uwb_env.typing import FloatArray, IntArray
from uwb_env.waveforms.chirp import fold_periodic


def train_doppler_spread_hz(n_pulses: int, pri_s: float, clutter_spread_hz: float = 0.0) -> float:
    """sigma_f [Hz]: the Gaussian fit of the train's Doppler main lobe (module docstring) and the clutter spread."""
    sigma_d = math.sqrt(1.5) / (math.pi * pri_s * math.sqrt(max(n_pulses**2 - 1, 1)))
    return math.sqrt(sigma_d**2 + clutter_spread_hz**2)


def clutter_cnr_profile(
    scatterer_range_m: FloatArray, scatterer_snr: FloatArray, grid_m: FloatArray, range_spread_m: float
) -> FloatArray:
    """CNR(r) on ``grid_m`` (G,) from scatterers at bistatic ranges ``(C,)`` with echo SNRs ``(C,)`` (0: invisible).

    Returns ``(G,)``: sum_c SNR_c exp(-(r - r_c)^2 / (2 sigma_r^2)).
    """
    d = (grid_m[:, None] - scatterer_range_m[None, :]) / range_spread_m
    return np.exp(-0.5 * d * d) @ scatterer_snr


def fold_doppler_hz(doppler_hz: FloatArray, prf_hz: FloatArray | float) -> FloatArray:
    """Doppler folded into [-PRF / 2, PRF / 2) (``waveforms.chirp.fold_periodic``)."""
    return fold_periodic(doppler_hz, prf_hz)


def doppler_notch_gain(
    cnr: FloatArray, range_rate_mps: FloatArray, wavelength_m: FloatArray | float, pri_s: FloatArray | float,
    sigma_f_hz: FloatArray | float, residue_fraction: float,
) -> FloatArray:  # fmt: skip
    """SCNR / SNR = 1 / (1 + eta CNR G(f_fold)) (module docstring); every argument broadcasts.

    Args: cnr: CNR at the target's bistatic range; range_rate_mps [m/s]; wavelength_m [m]; pri_s [s]; sigma_f_hz
    [Hz]; residue_fraction eta.
    """
    f = fold_doppler_hz(-np.asarray(range_rate_mps) / wavelength_m, 1.0 / np.asarray(pri_s))
    g = np.exp(-0.5 * (f / sigma_f_hz) ** 2)
    return 1.0 / (1.0 + residue_fraction * cnr * g)


@nb.njit(cache=True, fastmath=False, nogil=True)
def bistatic_range_rate(pos, vel, tx, rx):  # pragma: no cover - compiled
    """Bistatic range ``(N,)`` [m] and range-rate ``(N,)`` [m/s] of points ``pos`` ``(N, 2)`` moving at ``vel``.

    l_t + l_r and (d_t / max(l_t, 1e-9) + d_r / max(l_r, 1e-9)) . v, d = p - node, with numpy's operations in
    numpy's order (``np.linalg.norm``, ``np.einsum``): the same numbers to the bit. ``tx``, ``rx`` ``(2,)``.
    """
    n = pos.shape[0]
    rng = np.empty(n)
    rdot = np.empty(n)
    for i in range(n):
        tx0, tx1 = pos[i, 0] - tx[0], pos[i, 1] - tx[1]
        rx0, rx1 = pos[i, 0] - rx[0], pos[i, 1] - rx[1]
        lt = np.sqrt(tx0 * tx0 + tx1 * tx1)
        lr = np.sqrt(rx0 * rx0 + rx1 * rx1)
        mt = lt if (lt >= 1e-9 or lt != lt) else 1e-9  # np.maximum (NaN propagates)
        mr = lr if (lr >= 1e-9 or lr != lr) else 1e-9
        acc = 0.0  # einsum's accumulator
        acc += (tx0 / mt + rx0 / mr) * vel[i, 0]
        acc += (tx1 / mt + rx1 / mr) * vel[i, 1]
        rng[i] = lt + lr
        rdot[i] = 0.0 + acc
    return rng, rdot


@nb.njit(cache=True, fastmath=False, nogil=True)
def notch_terms(
    cnr_table, step, wavelength_m, pri_s, sigma_f_hz, w, bistatic_range, range_rate_mps
):  # pragma: no cover
    """``(cnr (W, N), exponent (W, N))`` of :func:`doppler_notch_gain` for waveforms ``w`` ``(W,)`` at targets ``(N,)``.

    ``cnr_table`` ``(W_lib, G)`` the pair's CNR on the range grid of ``step`` [m] (nearest cell, clipped);
    ``wavelength_m``, ``pri_s``, ``sigma_f_hz`` ``(W_lib,)``. The exponent is -0.5 (f_fold / sigma_f)^2 with numpy's
    operations in numpy's order (:func:`fold_doppler_hz`); the caller takes its ``np.exp`` (numpy's exp differs from
    libm's in the last bit) and forms 1 / (1 + eta CNR G).
    """
    W, N = w.shape[0], bistatic_range.shape[0]
    last = cnr_table.shape[-1] - 1
    cnr = np.empty((W, N))
    arg = np.empty((W, N))
    for j in range(N):
        g = np.int64(np.rint(bistatic_range[j] / step))
        g = min(max(g, 0), last)
        for i in range(W):
            k = w[i]
            cnr[i, j] = cnr_table[k, g]
            v = -range_rate_mps[j] / wavelength_m[k]
            period = 1.0 / pri_s[k]
            if np.isfinite(period):
                v = v - period * np.floor(v / period + 0.5)
            x = v / sigma_f_hz[k]
            arg[i, j] = -0.5 * (x * x)
    return cnr, arg


def doppler_notch_gain_at(
    cnr_table: FloatArray, step: float, wavelength_m: FloatArray, pri_s: FloatArray, sigma_f_hz: FloatArray,
    residue_fraction: float, w: IntArray, bistatic_range: FloatArray, range_rate_mps: FloatArray,
) -> FloatArray:  # fmt: skip
    """:func:`doppler_notch_gain` ``(W, N)`` of waveforms ``w`` ``(W,)`` at targets ``(N,)`` from one pair's CNR table.

    The CNR at the nearest cell of the ``step`` grid (clipped), then the notch: the same numbers as the numpy
    expression to the bit (:func:`notch_terms`, numpy's ``exp``).
    """
    cnr, arg = notch_terms(cnr_table, step, wavelength_m, pri_s, sigma_f_hz, w, bistatic_range, range_rate_mps)
    return 1.0 / (1.0 + residue_fraction * cnr * np.exp(arg))
