r"""CFAR detectors of seed 000 section IV-E on batches of rectified scans ``d`` ``(..., N)``; decisions ``(..., N)``.

The cell under test is compared in power, d_k^2 > alpha * (reference power) (seed 000 eq. 14):

* CA-CFAR: the mean of the ``n_ref`` samples on each side beyond ``n_guard`` guard samples, the set intersected with
  the scan (fewer references at the edges);
* G-CFAR: the mean of every sample of the scan except the cell and its guards;
* OS-CFAR: the ``rank``-th smallest of the 2 ``n_ref`` references (the scan is mirrored at its edges);
* DTB-CFAR (Algorithm 1): eta = alpha_l L_p + alpha_g G_p with G_p the scan's mean power and L_p the mean of a FIFO
  buffer of below-threshold samples, frozen while the signal keeps rising; run in both directions and OR-merged.

Threshold factors for a design false-alarm probability assume independent exponentially distributed cell powers
(square-law detection of Gaussian noise):
    CA:  Pfa = (1 + alpha / N)^(-N)                       =>  alpha = N (Pfa^(-1/N) - 1),  N = 2 n_ref
    OS:  Pfa = prod_{i=0}^{k-1} (N - i) / (N - i + alpha)  (Rohling 1983), solved for alpha.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from scipy.optimize import brentq

from uwb_env.typing import BoolArray, FloatArray


def ca_threshold_factor(pfa: float, n_cells: int) -> float:
    """Alpha of CA-CFAR with ``n_cells`` exponential references for false-alarm probability ``pfa``."""
    return n_cells * (pfa ** (-1.0 / n_cells) - 1.0)


def os_false_alarm(alpha: float, n_cells: int, rank: int) -> float:
    """Pfa of OS-CFAR (rank-th smallest of ``n_cells`` exponential references, threshold factor ``alpha``)."""
    return math.exp(_os_log_false_alarm(alpha, n_cells, rank))


def _os_log_false_alarm(alpha: float, n_cells: int, rank: int) -> float:
    i = np.arange(rank)
    return float(np.sum(np.log(n_cells - i) - np.log(n_cells - i + alpha)))


def os_threshold_factor(pfa: float, n_cells: int, rank: int) -> float:
    """Alpha of OS-CFAR for false-alarm probability ``pfa`` (root of :func:`os_false_alarm`)."""
    if not 1 <= rank <= n_cells:
        raise ValueError(f"rank = {rank}: must be in [1, n_cells = {n_cells}]")
    return brentq(lambda a: _os_log_false_alarm(a, n_cells, rank) - math.log(pfa), 1e-9, 1e9, xtol=1e-12)


def _window_sums(power: FloatArray, lo: np.ndarray, hi: np.ndarray) -> tuple[FloatArray, np.ndarray]:
    """Sums and counts of power[..., lo_k:hi_k] for every k (bounds clipped to the scan)."""
    n = power.shape[-1]
    c = np.concatenate([np.zeros((*power.shape[:-1], 1)), np.cumsum(power, axis=-1)], axis=-1)
    lo, hi = np.clip(lo, 0, n), np.clip(hi, 0, n)
    return c[..., hi] - c[..., lo], np.maximum(hi - lo, 0)


def ca_cfar(d: FloatArray, alpha: float, n_ref: int, n_guard: int) -> BoolArray:
    """Cell-averaging CFAR decisions (seed 000 eq. 14)."""
    p = np.square(d)
    k = np.arange(p.shape[-1])
    s_left, n_left = _window_sums(p, k - n_guard - n_ref, k - n_guard)
    s_right, n_right = _window_sums(p, k + n_guard + 1, k + n_guard + n_ref + 1)
    ref = (s_left + s_right) / np.maximum(n_left + n_right, 1)
    return p > alpha * ref


def g_cfar(d: FloatArray, alpha: float, n_guard: int) -> BoolArray:
    """Global CFAR: the references are the whole scan except the cell and its guard samples."""
    p = np.square(d)
    n = p.shape[-1]
    k = np.arange(n)
    s_local, n_local = _window_sums(p, k - n_guard, k + n_guard + 1)
    ref = (p.sum(axis=-1, keepdims=True) - s_local) / (n - n_local)
    return p > alpha * ref


def os_cfar(d: FloatArray, alpha: float, n_ref: int, n_guard: int, rank: int) -> BoolArray:
    """Ordered-statistics CFAR: the ``rank``-th smallest reference power (edges mirrored)."""
    p = np.square(d)
    half = n_guard + n_ref
    padded = np.pad(p, [(0, 0)] * (p.ndim - 1) + [(half, half)], mode="reflect")
    win = sliding_window_view(padded, 2 * half + 1, axis=-1)  # (..., N, 2 half + 1)
    ref = np.concatenate([win[..., :n_ref], win[..., -n_ref:]], axis=-1)
    kth = np.partition(ref, rank - 1, axis=-1)[..., rank - 1]
    return p > alpha * kth


@nb.njit(cache=True, nogil=True)
def _dtb_pass(p, alpha_l, alpha_g, n_buffer, delta, q_max, out):  # pragma: no cover - compiled
    """One direction of Algorithm 1 on the powers p (N,); decisions OR-ed into out (N,)."""
    n = p.shape[0]
    g_p = p.mean()
    d_eta = delta * g_p
    buf = p[:n_buffer].copy()
    head = 0
    buf_sum = buf.sum()
    freeze = False
    l_frozen = 0.0
    q = 0
    for k in range(n_buffer, n):
        l_p = l_frozen if freeze else buf_sum / n_buffer
        eta = alpha_l * l_p + alpha_g * g_p
        if p[k] > eta:
            out[k] = True
        else:  # the FIFO takes the below-threshold sample
            buf_sum += p[k] - buf[head]
            buf[head] = p[k]
            head = (head + 1) % n_buffer
            l_p = buf_sum / n_buffer
        if p[k] > p[k - 1] + d_eta:
            q += 1
        elif p[k] < p[k - 1] - d_eta:
            q = 0
        if q > q_max and not freeze:
            freeze = True
            l_frozen = l_p
        elif freeze and l_p < l_frozen:
            freeze = False
            q = 0


@nb.njit(cache=True, nogil=True)
def _dtb_batch(p, alpha_l, alpha_g, n_buffer, delta, q_max):  # pragma: no cover - compiled
    out = np.zeros(p.shape, dtype=np.bool_)
    back = np.zeros(p.shape[1], dtype=np.bool_)
    for i in range(p.shape[0]):
        _dtb_pass(p[i], alpha_l, alpha_g, n_buffer, delta, q_max, out[i])
        back[:] = False
        _dtb_pass(p[i, ::-1].copy(), alpha_l, alpha_g, n_buffer, delta, q_max, back)
        out[i] |= back[::-1]
    return out


def dtb_cfar(d: FloatArray, alpha_l: float, alpha_g: float, n_buffer: int, q_max: int, delta: float) -> BoolArray:
    """DTB-CFAR (seed 000 Algorithm 1), both directions OR-merged; ``delta`` is Delta-eta in units of G_p."""
    p = np.square(np.asarray(d, dtype=float))
    flat = np.ascontiguousarray(p.reshape(-1, p.shape[-1]))
    if flat.shape[-1] <= n_buffer:
        raise ValueError(f"dtb_buffer = {n_buffer}: must be shorter than the scan ({flat.shape[-1]} samples)")
    return _dtb_batch(flat, float(alpha_l), float(alpha_g), int(n_buffer), float(delta), int(q_max)).reshape(p.shape)
