"""What a scan gives the agent: reward terms, info and track features of E environments in one compiled pass.

``scan_summaries`` runs ``metrics.cover_summary`` (the tracks against the alive targets) and
``features.track_features`` (the observation's track slots) for each environment's block of tracks, and reduces the
covariance traces with numpy's own summation order (:func:`pairwise_sum`), so one environment's numbers are the same
to the bit whether it is summarised alone (``UWBSchedulingEnv``, E = 1) or in a batch (``UWBVectorEnv``).
:func:`rewards_and_infos` turns the summaries into rewards and the info arrays (``UWBSchedulingEnv`` docstring).
"""

from __future__ import annotations

import functools
from typing import Any

import numba as nb
import numpy as np

from uwb_env.envs.features import track_features
from uwb_env.metrics import cover_summary
from uwb_env.typing import FloatArray, IntArray

_jit = nb.njit(cache=True, nogil=True)
_PW_BLOCK = 128


@_jit
def _block(a, lo, n):  # pragma: no cover - compiled
    """The pairwise sum of numpy on a block of n <= 128 terms: a loop below 8, else 8 interleaved partial sums."""
    if n < 8:
        s = 0.0
        for i in range(lo, lo + n):
            s += a[i]
        return s
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    i = 8
    while i < n - n % 8:
        r0 += a[lo + i]
        r1 += a[lo + i + 1]
        r2 += a[lo + i + 2]
        r3 += a[lo + i + 3]
        r4 += a[lo + i + 4]
        r5 += a[lo + i + 5]
        r6 += a[lo + i + 6]
        r7 += a[lo + i + 7]
        i += 8
    s = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    for k in range(i, n):
        s += a[lo + k]
    return s


@_jit
def pairwise_sum(a):  # pragma: no cover - compiled
    """``a.sum()`` of a 1-D float64 array, in numpy's order (to the bit).

    numpy sums pairwise: 8 partial sums per block of at most 128, blocks halved recursively; a plain loop differs
    from it in the last bits from 8 terms on (``tests/unit/test_env_outputs.py``).
    """
    # numpy recurses: sum(lo, n) = sum(lo, n2) + sum(lo + n2, n - n2), n2 = n // 2 rounded down to a multiple of
    # 8, down to blocks of <= 128. The same tree, walked with an explicit stack (numba's cache cannot hold a
    # recursive function: it crashed on reload).
    los = np.empty(64, np.int64)
    ns = np.empty(64, np.int64)
    stage = np.zeros(64, np.int64)
    left = np.zeros(64)
    los[0], ns[0], sp = 0, a.shape[0], 1
    value = 0.0
    while sp > 0:
        top = sp - 1
        lo, n = los[top], ns[top]
        if n <= _PW_BLOCK:
            value = _block(a, lo, n)
            sp -= 1
            continue
        n2 = n // 2
        n2 -= n2 % 8
        if stage[top] == 0:  # the left half first
            stage[top] = 1
            los[sp], ns[sp], stage[sp] = lo, n2, 0
            sp += 1
        elif stage[top] == 1:  # then the right half
            left[top] = value
            stage[top] = 2
            los[sp], ns[sp], stage[sp] = lo + n2, n - n2, 0
            sp += 1
        else:
            value = left[top] + value
            sp -= 1
    return value


@_jit
def scan_summaries(
    track_start, confirmed, existence, mu, x, P, target_start, targets, gate_m, cutoff_m, centre, half, v_max,
    n_slots, n_targets,
):  # pragma: no cover - compiled  # fmt: skip
    """One scan's summaries of E environments, each from its own tracks and alive targets.

    Environment e owns the tracks ``track_start[e]:track_start[e + 1]`` and the alive targets' (x, y) [m]
    ``target_start[e]:target_start[e + 1]``; ``x (N, 6)``, ``P (N, 6, 6)`` are the IMM-combined estimates.
    Returns per environment: the mean position-covariance trace of the confirmed tracks and of those covering a
    target [m^2] (0 without any), missed targets, confirmed and false track counts, the covered targets' position
    errors ``(E, n_targets)`` padded with 0 and their count, OSPA [m] (order 2, cut-off ``cutoff_m``), the mean model
    probabilities ``(E, r)`` (zeros without a confirmed track), and the observation's track slots
    ``(E, n_slots, 10 + r)``.
    """
    E = track_start.shape[0] - 1
    r = mu.shape[1]
    mean_trace = np.zeros(E)
    target_trace = np.zeros(E)
    missed = np.zeros(E, np.int64)
    n_conf = np.zeros(E, np.int64)
    n_false = np.zeros(E, np.int64)
    errors = np.zeros((E, n_targets))
    n_errors = np.zeros(E, np.int64)
    ospa = np.zeros(E)
    mu_mean = np.zeros((E, r))
    feats = np.zeros((E, n_slots, 10 + r))
    for e in range(E):
        a0, a1 = track_start[e], track_start[e + 1]
        t0, t1 = target_start[e], target_start[e + 1]
        trace, mu_sum, ti, gi, err, o = cover_summary(
            confirmed[a0:a1], x[a0:a1], P[a0:a1], mu[a0:a1], targets[t0:t1], gate_m, cutoff_m, 2.0
        )
        n = trace.shape[0]
        n_conf[e] = n
        if n:
            mean_trace[e] = pairwise_sum(trace) / n
            for j in range(r):
                mu_mean[e, j] = mu_sum[j] / n
        if ti.shape[0]:
            target_trace[e] = pairwise_sum(trace[ti]) / ti.shape[0]
        missed[e] = (t1 - t0) - gi.shape[0]
        n_false[e] = n - ti.shape[0]
        n_errors[e] = err.shape[0]
        errors[e, : err.shape[0]] = err
        ospa[e] = o
        feats[e] = track_features(
            existence[a0:a1], confirmed[a0:a1], mu[a0:a1], x[a0:a1], P[a0:a1], centre, half, v_max, n_slots
        )
    return mean_trace, target_trace, missed, n_conf, n_false, errors, n_errors, ospa, mu_mean, feats


def rewards_and_infos(
    summaries: tuple[np.ndarray, ...],
    scan_index: IntArray,
    energy_j: FloatArray,
    missed_target_penalty_m2: float,
    energy_cost_per_j: float,
) -> tuple[FloatArray, dict[str, np.ndarray]]:
    """``(E,)`` rewards and the info arrays (``UWBSchedulingEnv`` docstring) of E environments' ``scan_summaries``.

    Reward: minus the mean trace, minus the penalty per missed target, minus the energy cost. Raises
    ``FloatingPointError`` on a non-finite reward (no NaN reaches an agent).
    """
    mean_trace, target_trace, missed, n_conf, n_false, errors, n_errors, ospa, mu_mean, _ = summaries
    penalty = missed_target_penalty_m2 * missed
    cost = energy_cost_per_j * energy_j
    reward = -mean_trace - penalty - cost
    if not np.isfinite(reward).all():
        e = int(np.flatnonzero(~np.isfinite(reward))[0])
        raise FloatingPointError(
            f"reward is {reward[e]} at scan {int(scan_index[e])} (env {e}): mean trace {mean_trace[e]}"
        )
    info: dict[str, Any] = {
        "scan_index": scan_index.astype(np.int64),
        "covariance_trace": mean_trace,
        "target_covariance_trace": target_trace,
        "missed_targets": missed,
        "missed_penalty": penalty.astype(float),
        "energy_j": energy_j.astype(float),
        "energy_cost": cost.astype(float),
        "position_errors_m": errors,
        "position_errors_count": n_errors,
        "ospa_m": ospa,
        "confirmed_tracks": n_conf,
        "false_tracks": n_false,
        "model_probabilities": mu_mean,
    }
    return reward, info


def one_env(info: dict[str, np.ndarray], e: int = 0) -> dict[str, Any]:
    """Environment e's info as the single env gives it: Python scalars, arrays for the array entries."""
    return {k: (v[e].copy() if v.ndim > 1 else v[e].item()) for k, v in info.items()}


@functools.lru_cache(maxsize=64)
def _digit_offsets(action_dims: tuple[int, ...]) -> tuple[IntArray, IntArray, IntArray]:
    """``(D,)`` each action digit's first column in the concatenated one-hots, its stride and its size (cached).

    Digit d of action a is ``a // stride[d] % dims[d]``, stride[d] the product of the later dims (C order).
    """
    dims = np.array(action_dims, dtype=np.int64)
    strides = np.ones_like(dims)
    strides[:-1] = np.cumprod(dims[::-1])[::-1][1:]
    offsets = np.concatenate([[0], np.cumsum(dims)[:-1]]).astype(np.int64)
    for a in (offsets, strides, dims):
        a.flags.writeable = False
    return offsets, strides, dims


def observations(
    feats: FloatArray,
    previous: IntArray,
    n_actions: int,
    extra: dict[str, FloatArray],
    kind: str,
    bound: float,
    scan_index: IntArray,
    action_dims: tuple[int, ...] | None = None,
) -> Any:
    """E observations (``UWBSchedulingEnv`` docstring) from the track slots ``feats`` ``(E, n_slots, F)``.

    ``previous`` ``(E,)`` the previous action's plan index (-1: none), one-hot over the ``n_actions`` plans, or,
    with ``action_dims`` (per-tx: ``(W,) * T``), its digits ``numpy.unravel_index(previous, action_dims)`` one-hot per
    dimension and concatenated (``sum(action_dims)`` entries); ``extra``: the optional parts after it, in order
    (lookahead costs, scaled, ``(E, A)``; ready receivers ``(E, R)``). ``kind`` ``"box"``: ``(E, size)`` float32;
    ``"dict"``: the parts as float32 ``(E, ...)`` arrays. A value outside ``[-bound, bound]`` or not finite raises
    ``FloatingPointError`` naming the parts and the scan (nothing is clipped).
    """
    E = feats.shape[0]
    has = previous >= 0
    if action_dims is None:
        prev = np.zeros((E, n_actions))
        prev[np.flatnonzero(has), previous[has]] = 1.0
    else:
        prev = np.zeros((E, sum(action_dims)))
        offsets, strides, dims = _digit_offsets(tuple(action_dims))
        digits = previous[has][:, None] // strides % dims  # (E_has, D): numpy.unravel_index (C order)
        prev[np.flatnonzero(has)[:, None], offsets[None] + digits] = 1.0
    parts = {"tracks": feats, "previous_action": prev, **extra}
    flat = np.concatenate([v.reshape(E, -1) for v in parts.values()], axis=1)
    ok = (np.abs(flat) <= bound).all(axis=1)  # also catches NaN
    if not ok.all():
        e = int(np.flatnonzero(~ok)[0])
        bad = [name for name, v in parts.items() if not np.all(np.abs(v[e]) <= bound)]
        raise FloatingPointError(
            f"observation part(s) {bad} outside [-{bound}, {bound}] or not finite at scan {int(scan_index[e])}"
        )
    if kind == "dict":
        return {k: v.astype(np.float32) for k, v in parts.items()}
    return flat.astype(np.float32)
