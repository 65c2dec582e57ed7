r"""The observation's track slots: one compiled pass (``track_features``) and its numpy reference.

Slot order: confirmed tracks first, then by decreasing existence, ties by track index (a stable sort: the order of
``np.lexsort((-existence, ~confirmed))``); the first ``n_slots`` fill the slots, the rest stay zero. Each slot is

    [present, existence, confirmed, (x - cx) / hx, (y - cy) / hy, vx / v_max, vy / v_max,
     log10(var_x) / 4, log10(var_y) / 4, corr_xy, mu_1 .. mu_r]

from the IMM-combined estimate (x, P) of the track (``UWBSchedulingEnv`` module docstring). The compiled kernel
saves the dozen small numpy calls of the reference, which cost more than the arithmetic at these sizes
(``tests/test_envs.py`` checks the two agree).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from uwb_env.typing import BoolArray, FloatArray

_jit = nb.njit(cache=True, fastmath=False, nogil=True, error_model="numpy")  # 0 variance: inf, caught by the env


def slot_order(existence: FloatArray, confirmed: BoolArray) -> np.ndarray:
    """Track indices in slot order (module docstring), numpy."""
    return np.lexsort((-existence, ~confirmed))


def track_features_reference(
    existence: FloatArray,
    confirmed: BoolArray,
    mu: FloatArray,
    x: FloatArray,
    P: FloatArray,
    centre: FloatArray,
    half: FloatArray,
    v_max: float,
    n_slots: int,
) -> FloatArray:
    """``(n_slots, 10 + r)`` slot features of N tracks (numpy reference of ``track_features``).

    existence, confirmed ``(N,)``, mu ``(N, r)``, combined x ``(N, 6)``, P ``(N, 6, 6)``; centre, half ``(2,)`` [m]
    of the area, v_max [m/s].
    """
    feats = np.zeros((n_slots, 10 + mu.shape[1]))
    if existence.size:
        order = slot_order(existence, confirmed)[:n_slots]
        x, P = x[order], P[order]
        vx, vy = P[:, 0, 0], P[:, 2, 2]
        f = feats[: order.size]
        f[:, 0] = 1.0
        f[:, 1] = existence[order]
        f[:, 2] = confirmed[order]
        f[:, 3:5] = (x[:, 0:3:2] - centre) / half  # (x, y)
        f[:, 5:7] = x[:, 1:4:2] / v_max  # (vx, vy)
        f[:, 7] = np.log10(vx) / 4.0
        f[:, 8] = np.log10(vy) / 4.0
        f[:, 9] = P[:, 0, 2] / np.sqrt(vx * vy)
        f[:, 10:] = mu[order]
    return feats


@_jit
def compiled_slot_order(existence, confirmed):  # pragma: no cover - compiled
    """``(N,)`` track indices in slot order (:func:`slot_order`), a stable insertion sort (N is a few tens at most)."""
    N = existence.shape[0]
    order = np.arange(N)
    for i in range(1, N):
        j = i
        k = order[i]
        while j > 0:
            o = order[j - 1]
            before = (confirmed[k] and not confirmed[o]) or (
                confirmed[k] == confirmed[o] and existence[k] > existence[o]
            )
            if not before:
                break
            order[j] = o
            j -= 1
        order[j] = k
    return order


@_jit
def track_features(existence, confirmed, mu, x, P, centre, half, v_max, n_slots):  # pragma: no cover - compiled
    """``(n_slots, 10 + r)`` slot features (module docstring); arguments as ``track_features_reference``."""
    N, r = mu.shape
    feats = np.zeros((n_slots, 10 + r))
    order = compiled_slot_order(existence, confirmed)
    for s in range(min(N, n_slots)):
        n = order[s]
        vx, vy = P[n, 0, 0], P[n, 2, 2]
        feats[s, 0] = 1.0
        feats[s, 1] = existence[n]
        feats[s, 2] = 1.0 if confirmed[n] else 0.0
        feats[s, 3] = (x[n, 0] - centre[0]) / half[0]
        feats[s, 4] = (x[n, 2] - centre[1]) / half[1]
        feats[s, 5] = x[n, 1] / v_max
        feats[s, 6] = x[n, 3] / v_max
        feats[s, 7] = math.log10(vx) / 4.0
        feats[s, 8] = math.log10(vy) / 4.0
        feats[s, 9] = P[n, 0, 2] / math.sqrt(vx * vy)
        for j in range(r):
            feats[s, 10 + j] = mu[n, j]
    return feats
