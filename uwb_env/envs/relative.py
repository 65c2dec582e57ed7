r"""Track slots relative to the sensors: features that carry over between scenes (issue 20, item 2).

The absolute slots of :mod:`uwb_env.envs.features` give a track's position and velocity in the scene's frame; a policy
trained on them keys on coordinates and turn handedness (on seed 003's intersection mirrored, the urban policy fell to
round-robin level). The slots here are functions of the geometry between each track and each node only: they are
equal, to rounding, for a scene and any rotated, translated or mirrored copy of it (the mirror also swaps the
CT-left and CT-right model probabilities, which enter as their sum and absolute difference).

Slot order as :func:`uwb_env.envs.features.slot_order`: confirmed tracks first, then by decreasing existence, ties by
track index; the first ``n_slots`` tracks fill the slots, the rest of the slots stay zero. Inputs are the
IMM-combined estimate of each track, state ``[x, vx, y, vy, ax, ay]``: position p = (x[0], x[2]), velocity
v = (x[1], x[3]), position covariance C = P[[0, 2]][:, [0, 2]].

Per node (a transmitter or a receiver at position n), with d = p - n, the range r = |d| and the unit radial u = d / r:

    range rate         dr/dt = u . v
    bearing            beta, the angle from the track's velocity direction to the direction -u in which the track
                       sees the node: cos beta = -u . v / |v|, |sin beta| = |u x v| / |v|
    off boresight      |alpha| / pi, alpha the angle between a receiver array's boresight b and d (receivers only:
                       ``rx_boresight_rad`` rotates and mirrors with the scene; 0 for a receiver without an array)
    radial frame       var_r = u^T C u, var_c = w^T C w, rho = u^T C w / sqrt(var_r var_c), w = (-u_y, u_x)

Per formed (tx, rx) pair with baseline L = |tx - rx|: the half bistatic range minus half the baseline,
(r_t + r_r - L) / 2 (the semi-major axis of the track's bistatic ellipse minus its focal half-distance; 0 on the
baseline segment), its rate (u_t + u_r) . v / 2 and the position variance g^T C g / |g|^2 along the gradient
g = u_t + u_r (the direction in which the pair's range measurement constrains the track; g^T C g is the linearised
variance of the measured bistatic range, Bar-Shalom, Li & Kirubarajan 2001, section 5.6). Halved so that a pair's
range and rate are on a node's scale (|rate| <= |v|, range <= the larger of the two node ranges): the env's
observation bound holds for them whenever it holds for the node features.

Handedness is dropped on purpose: a mirror flips the sign of sin beta, of the off-boresight angle alpha and of the
radial / cross-radial correlation rho (w = u rotated by +90 degrees becomes -w in the mirror image), and swaps the
CT-left and CT-right models. The slots keep |sin beta|, |alpha|, |rho|, and for each left / right pair of models
mu_left + mu_right and |mu_left - mu_right|: whether a node lies to the left or the right of a track's heading, and
which way it turns, are not in the observation -- only how sharply it turns and how far off its heading the node
lies. This is what makes the slots mirror-invariant (``tests/unit/test_relative_features.py`` checks it on random
scenes, rotations by any angle, mirrors about any line and translations).

Degenerate geometry gives defined, finite values (no NaN): a track exactly on a node (r = 0) has no radial
direction, so u = 0 there -- range rate 0, cos beta = |sin beta| = 0, off boresight 0, and var_r = var_c = trace(C) / 2
(the variance along a direction averaged over all directions), rho = 0 (the average correlation). A track at rest
(|v| = 0) has cos beta = |sin beta| = 0. A pair whose gradient vanishes (g = 0: the track on a monostatic pair's node,
or on the segment between tx and rx, where u_t = -u_r) takes trace(C) / 2 as its variance. A zero position variance
(not positive definite P) gives log10(0) = -inf, as in :mod:`uwb_env.envs.features`, which the env's observation bound
rejects.

Layout of one slot, with T transmitters and R receivers (scenario order), Q formed pairs (``pairs`` order), and the
models grouped by :func:`model_groups` into a non-turn models (model order) and b left / right pairs (order of the
left model), ``N0 = 4 + 7 T + 8 R`` and ``M0 = N0 + 3 Q``:

    =============================  ==================================================================================
    index                          feature
    =============================  ==================================================================================
    0                              present: 1 in a filled slot (0 in an empty one, as every other feature)
    1                              existence probability
    2                              confirmed (0 / 1)
    3                              speed |v| / v_max
    4 + 7 t + k, t < T             transmitter t, k = 0..6:
                                   r / range_scale, (u . v) / v_max, cos beta, |sin beta|,
                                   log10(var_r) / 4, log10(var_c) / 4, |rho|
    4 + 7 T + 8 j + k, j < R       receiver j, k = 0..6 as a transmitter's, k = 7: |alpha| / pi
    N0 + 3 q + k, q < Q            pair q = (t, j), k = 0..2: (r_t + r_j - |tx_t - rx_j|) / (2 range_scale),
                                   ((u_t + u_j) . v) / (2 v_max), log10(g^T C g / |g|^2) / 4
    M0 + i, i < a                  mu of the i-th non-turn model
    M0 + a + 2 c, c < b            mu_left + mu_right of turn pair c
    M0 + a + 2 c + 1               |mu_left - mu_right| of turn pair c
    =============================  ==================================================================================

Width ``F = 4 + 7 T + 8 R + 3 Q + a + 2 b`` (:func:`relative_feature_count`; :func:`relative_feature_names` names
every column). Scales: ranges over ``range_scale_m`` (a length of the scene that rotations and mirrors keep, e.g.
the largest distance between two nodes), rates and speed over ``v_max`` [m/s] (the tracker's ``max_speed_mps``),
variances as log10(var [m^2]) / 4 (-1 at 1 cm^2, 0.5 at 100 m^2), as the absolute slots.

:func:`relative_track_features` is the compiled kernel (one loop over slots, nodes and pairs: callable from compiled
code such as ``outputs.scan_summaries``); :func:`relative_track_features_reference` its numpy twin, batched over
tracks, nodes and pairs.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numba as nb
import numpy as np

from uwb_env.config import ScenarioConfig
from uwb_env.envs.features import compiled_slot_order, slot_order
from uwb_env.scene.layout import SceneLayout
from uwb_env.typing import BoolArray, FloatArray, IntArray

_jit = nb.njit(cache=True, fastmath=False, nogil=True, error_model="numpy")  # 0 variance: -inf, caught by the env

N_SLOT_HEAD = 4
"""present, existence, confirmed, speed / v_max."""
N_TX_FEATURES = 7
"""Per transmitter: range, range rate, cos / |sin| bearing, log radial / cross variance, |corr|."""
N_RX_FEATURES = 8
"""Per receiver: a transmitter's seven, then |angle off boresight| / pi."""
N_PAIR_FEATURES = 3
"""Per formed pair: half the bistatic range minus half the baseline, its rate, log variance along its gradient."""


# ------------------------------------------------------------------------------------------------ layout
@lru_cache(maxsize=64)
def _model_groups(model_names: tuple[str, ...]) -> tuple[IntArray, IntArray]:
    index = {name: i for i, name in enumerate(model_names)}
    if len(index) != len(model_names):
        raise ValueError(f"model_names={model_names!r}: must be distinct")
    singles, turns = [], []
    for i, name in enumerate(model_names):
        if "left" in name:
            twin = name.replace("left", "right")
            if twin not in index:
                raise ValueError(
                    f"model_names={model_names!r}: {name!r} has no mirror twin {twin!r} (a left-turn model needs its"
                    " right-turn twin, or the features would keep the scene's handedness)"
                )
            turns.append((i, index[twin]))
        elif "right" in name:
            twin = name.replace("right", "left")
            if twin not in index:
                raise ValueError(
                    f"model_names={model_names!r}: {name!r} has no mirror twin {twin!r} (a right-turn model needs its"
                    " left-turn twin, or the features would keep the scene's handedness)"
                )
        else:
            singles.append(i)
    single_models = np.array(singles, dtype=np.int64)
    turn_pairs = np.array(turns, dtype=np.int64).reshape(-1, 2)
    single_models.flags.writeable = False
    turn_pairs.flags.writeable = False
    return single_models, turn_pairs


def model_groups(
    model_names: tuple[str, ...] | list[str], turn_rates_rps: FloatArray | None = None
) -> tuple[IntArray, IntArray]:
    """The tracker's models grouped for the mirror: ``(a,)`` non-turn model indices, ``(b, 2)`` (left, right) pairs.

    A model whose name contains "left" pairs with the one named with "right" in its place (``ct_left`` and
    ``ct_right``, seed 003's set, ``uwb_env.tracking.imm.SEED003_MODELS``); every other model is a non-turn model.
    With ``turn_rates_rps`` (``(r,)`` [rad/s], the tracker config's ``turn_rate_rps``, positive = left) every model
    that turns must be in a pair, and a pair's rates must be opposite and non-zero. Read-only arrays (cached).

    Raises:
        ValueError: repeated names, a left (right) model without its right (left) twin, a turning model outside a
            pair or a pair whose turn rates are not opposite.
    """
    names = tuple(model_names)
    if not all(isinstance(n, str) for n in names):
        raise TypeError(f"model_names={model_names!r}: must be strings")
    single_models, turn_pairs = _model_groups(names)
    if turn_rates_rps is not None:
        rates = np.asarray(turn_rates_rps, dtype=float)
        if rates.shape != (len(names),):
            raise ValueError(f"turn_rates_rps has shape {rates.shape}: must be ({len(names)},), one per model")
        for i in single_models:
            if rates[i] != 0.0:
                raise ValueError(
                    f"turn_rates_rps[{i}]={float(rates[i])!r} ({names[i]!r}): a turning model needs a mirror twin named"
                    " with 'left' / 'right'"
                )
        for left, right in turn_pairs:
            if rates[left] == 0.0 or rates[left] != -rates[right]:
                pair_rates = (float(rates[left]), float(rates[right]))
                raise ValueError(
                    f"turn_rates_rps of ({names[left]!r}, {names[right]!r}) = {pair_rates!r}: must be opposite and"
                    " non-zero"
                )
    return single_models, turn_pairs


@_jit
def relative_feature_count(n_tx: int, n_rx: int, n_pairs: int, n_single_models: int, n_turn_pairs: int) -> int:
    """Width F of one slot (module docstring's layout); compiled, so the kernels below call it too."""
    return (
        N_SLOT_HEAD
        + N_TX_FEATURES * n_tx
        + N_RX_FEATURES * n_rx
        + N_PAIR_FEATURES * n_pairs
        + n_single_models
        + 2 * n_turn_pairs
    )


_NODE_NAMES = ("range", "range_rate", "cos_bearing", "abs_sin_bearing", "log_var_radial", "log_var_cross", "abs_corr")
_PAIR_NAMES = ("half_bistatic_range", "half_bistatic_rate", "log_var_gradient")


def relative_feature_names(n_tx: int, n_rx: int, pairs: IntArray, model_names: tuple[str, ...]) -> list[str]:
    """The F column names of one slot, in the module docstring's order (e.g. ``"rx1.abs_off_boresight"``)."""
    single_models, turn_pairs = model_groups(model_names)
    names = ["present", "existence", "confirmed", "speed"]
    names += [f"tx{t}.{f}" for t in range(n_tx) for f in _NODE_NAMES]
    names += [f"rx{j}.{f}" for j in range(n_rx) for f in (*_NODE_NAMES, "abs_off_boresight")]
    names += [f"pair{q}(tx{t},rx{j}).{f}" for q, (t, j) in enumerate(np.asarray(pairs)) for f in _PAIR_NAMES]
    names += [f"mu.{model_names[i]}" for i in single_models]
    for left, right in turn_pairs:
        names += [f"mu.{model_names[left]}+{model_names[right]}", f"mu.|{model_names[left]}-{model_names[right]}|"]
    return names


def check_geometry(
    tx_pos: FloatArray,
    rx_pos: FloatArray,
    rx_boresight_rad: FloatArray,
    pairs: IntArray,
    range_scale_m: float,
    v_max: float,
    n_slots: int,
) -> None:
    """Raise ``ValueError`` naming the argument unless the scene's arguments of the kernels are valid.

    tx_pos ``(T, 2)``, rx_pos ``(R, 2)`` [m] finite; rx_boresight_rad ``(R,)`` (nan: no array); pairs ``(Q, 2)``
    int64 (tx, rx) indices in range; range_scale_m, v_max finite and > 0; n_slots >= 0. Call once per scene (the
    compiled kernel checks nothing).
    """
    for name, pos in (("tx_pos", tx_pos), ("rx_pos", rx_pos)):
        if pos.ndim != 2 or pos.shape[1] != 2 or not np.isfinite(pos).all():
            raise ValueError(f"{name} has shape {pos.shape}: must be finite (n, 2) positions [m]")
    T, R = tx_pos.shape[0], rx_pos.shape[0]
    if rx_boresight_rad.shape != (R,) or np.isinf(rx_boresight_rad).any():
        raise ValueError(
            f"rx_boresight_rad={rx_boresight_rad!r}: must be ({R},), one angle [rad] per receiver, nan without array"
        )
    if pairs.dtype != np.int64 or pairs.ndim != 2 or pairs.shape[1] != 2:
        raise ValueError(f"pairs has shape {pairs.shape} and dtype {pairs.dtype}: must be (Q, 2) int64 (tx, rx)")
    if pairs.size and (pairs.min() < 0 or pairs[:, 0].max() >= T or pairs[:, 1].max() >= R):
        raise ValueError(f"pairs={pairs.tolist()!r}: tx indices must lie in [0, {T}), rx indices in [0, {R})")
    for name, value in (("range_scale_m", range_scale_m), ("v_max", v_max)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name}={value!r}: must be finite and > 0")
    if n_slots < 0:
        raise ValueError(f"n_slots={n_slots!r}: must be >= 0")


def scene_arguments(
    cfg: ScenarioConfig,
    layout: SceneLayout,
    pairs: IntArray,
    model_names: tuple[str, ...],
    range_scale_m: float | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray, IntArray, IntArray, IntArray, float]:
    """The scene's arguments of :func:`relative_track_features`, checked, in its order.

    Returns ``(tx_pos, rx_pos, rx_boresight_rad, pairs, single_models, turn_pairs, range_scale_m)``, so that
    ``relative_track_features(existence, confirmed, mu, x, P, *scene, v_max, n_slots)`` is the call. ``pairs``
    ``(Q, 2)``: the sensor's formed (tx, rx) pairs; ``model_names``: the tracker's (``tracker.model_names``), grouped
    by :func:`model_groups` and, when they are the scenario's IMM models (``cfg.tracker.models``), checked against
    their turn rates. ``range_scale_m`` [m] defaults to the surveillance area's half-diagonal, which a mirror or a
    quarter turn of the scene keeps (a node's range stays below 4 of it: the tracker deletes a track one area-size
    outside the area).
    """
    models = cfg.tracker.models
    rates = np.array([m.turn_rate_rps for m in models]) if tuple(m.name for m in models) == tuple(model_names) else None
    single_models, turn_pairs = model_groups(model_names, rates)
    if range_scale_m is None:
        x0, x1, y0, y1 = layout.area
        range_scale_m = 0.5 * math.hypot(x1 - x0, y1 - y0)
    scene = (
        np.ascontiguousarray(layout.tx_pos, dtype=np.float64),
        np.ascontiguousarray(layout.rx_pos, dtype=np.float64),
        np.ascontiguousarray(layout.rx_boresight_rad, dtype=np.float64),
        np.ascontiguousarray(pairs, dtype=np.int64).reshape(-1, 2),
        single_models,
        turn_pairs,
        float(range_scale_m),
    )
    check_geometry(scene[0], scene[1], scene[2], scene[3], scene[6], 1.0, 0)
    return scene


# ------------------------------------------------------------------------------------------- numpy reference
def _unit(vec: FloatArray, norm: FloatArray) -> FloatArray:
    """``vec / norm`` along the last axis, 0 where ``norm`` is 0 (no direction)."""
    return np.divide(vec, norm[..., None], out=np.zeros_like(vec), where=norm[..., None] > 0)


def _quad(C: FloatArray, a: FloatArray, b: FloatArray) -> FloatArray:
    """``a^T C b`` of 2-vectors ``(n, m, 2)`` and covariances ``(n, 2, 2)``: ``(n, m)``."""
    return np.einsum("nmi,nij,nmj->nm", a, C, b)


def relative_track_features_reference(
    existence: FloatArray,
    confirmed: BoolArray,
    mu: FloatArray,
    model_names: tuple[str, ...],
    x: FloatArray,
    P: FloatArray,
    tx_pos: FloatArray,
    rx_pos: FloatArray,
    rx_boresight_rad: FloatArray,
    pairs: IntArray,
    range_scale_m: float,
    v_max: float,
    n_slots: int,
) -> FloatArray:
    """``(n_slots, F)`` relative slot features (module docstring), numpy, batched over tracks, nodes and pairs.

    existence, confirmed ``(N,)``; mu ``(N, r)`` over ``model_names`` ``(r,)``; combined x ``(N, 6)``, P
    ``(N, 6, 6)``; tx_pos ``(T, 2)``, rx_pos ``(R, 2)`` [m]; rx_boresight_rad ``(R,)`` [rad] (nan: no array); pairs
    ``(Q, 2)`` int64 formed (tx, rx); range_scale_m [m], v_max [m/s].
    """
    check_geometry(tx_pos, rx_pos, rx_boresight_rad, pairs, range_scale_m, v_max, n_slots)
    single_models, turn_pairs = model_groups(model_names)
    N = existence.shape[0]
    for name, arr, shape in (("confirmed", confirmed, (N,)), ("mu", mu, (N, len(model_names))), ("x", x, (N, 6))):
        if arr.shape != shape:
            raise ValueError(f"{name} has shape {arr.shape}: must be {shape} (N = {N} tracks)")
    if P.shape != (N, 6, 6):
        raise ValueError(f"P has shape {P.shape}: must be ({N}, 6, 6) (N = {N} tracks)")
    T, R, Q = tx_pos.shape[0], rx_pos.shape[0], pairs.shape[0]
    feats = np.zeros((n_slots, relative_feature_count(T, R, Q, single_models.size, turn_pairs.shape[0])))
    if not existence.size:
        return feats
    order = slot_order(existence, confirmed)[:n_slots]
    p, v = x[order][:, 0:3:2], x[order][:, 1:4:2]  # (n, 2)
    C = P[order][:, 0:3:2][:, :, 0:3:2]  # (n, 2, 2) position block
    half_trace = 0.5 * (C[:, 0, 0] + C[:, 1, 1])  # (n,) variance along a direction averaged over directions

    d = p[:, None] - np.concatenate([tx_pos, rx_pos])[None]  # (n, T + R, 2)
    r = np.hypot(d[..., 0], d[..., 1])  # (n, T + R)
    u = _unit(d, r)  # 0 on the node
    w = np.stack([-u[..., 1], u[..., 0]], axis=-1)
    speed = np.hypot(v[:, 0], v[:, 1])
    v_hat = _unit(v, speed)[:, None]  # (n, 1, 2)
    on_node = r == 0
    var_r = np.where(on_node, half_trace[:, None], _quad(C, u, u))
    var_c = np.where(on_node, half_trace[:, None], _quad(C, w, w))
    node = np.stack(
        [
            r / range_scale_m,
            (u * v[:, None]).sum(-1) / v_max,
            -(u * v_hat).sum(-1),
            np.abs(u[..., 0] * v_hat[..., 1] - u[..., 1] * v_hat[..., 0]),
            np.log10(var_r) / 4.0,
            np.log10(var_c) / 4.0,
            np.abs(_quad(C, u, w)) / np.sqrt(var_r * var_c),
        ],
        axis=-1,
    )  # (n, T + R, 7)
    b = np.stack([np.cos(rx_boresight_rad), np.sin(rx_boresight_rad)], axis=-1)  # (R, 2)
    d_rx = d[:, T:]
    off = np.arctan2(
        np.abs(b[:, 0] * d_rx[..., 1] - b[:, 1] * d_rx[..., 0]), b[:, 0] * d_rx[..., 0] + b[:, 1] * d_rx[..., 1]
    )
    off = np.where(np.isnan(rx_boresight_rad) | on_node[:, T:], 0.0, off) / np.pi  # (n, R); atan2(0, -0.) = pi

    t_idx, j_idx = pairs[:, 0], T + pairs[:, 1]
    baseline = np.hypot(*(tx_pos[pairs[:, 0]] - rx_pos[pairs[:, 1]]).T)  # (Q,)
    g = u[:, t_idx] + u[:, j_idx]  # (n, Q, 2)
    g_norm = np.hypot(g[..., 0], g[..., 1])
    g_hat = _unit(g, g_norm)
    var_g = np.where(g_norm == 0, half_trace[:, None], _quad(C, g_hat, g_hat))
    pair = np.stack(
        [
            (r[:, t_idx] + r[:, j_idx] - baseline) / (2.0 * range_scale_m),
            (g * v[:, None]).sum(-1) / (2.0 * v_max),
            np.log10(var_g) / 4.0,
        ],
        axis=-1,
    )  # (n, Q, 3)
    left, right = mu[order][:, turn_pairs[:, 0]], mu[order][:, turn_pairs[:, 1]]  # (n, b)
    turns = np.stack([left + right, np.abs(left - right)], axis=-1).reshape(order.size, -1)
    models = np.concatenate([mu[order][:, single_models], turns], axis=1)
    rx_block = np.concatenate([node[:, T:], off[..., None]], axis=-1)  # (n, R, 8)
    feats[: order.size] = np.concatenate(
        [
            np.stack([np.ones(order.size), existence[order], confirmed[order], speed / v_max], axis=1),
            node[:, :T].reshape(order.size, -1),
            rx_block.reshape(order.size, -1),
            pair.reshape(order.size, -1),
            models,
        ],
        axis=1,
    )
    return feats


# ------------------------------------------------------------------------------------------ compiled kernel


@_jit
def _radial_frame(C00, C01, C11, ux, uy):  # pragma: no cover - compiled
    """(var_r, var_c, |rho|) of a position covariance in the frame of unit u = (ux, uy); u = 0: trace / 2, 0."""
    if ux == 0.0 and uy == 0.0:
        h = 0.5 * (C00 + C11)
        return h, h, 0.0
    var_r = C00 * ux * ux + 2.0 * C01 * ux * uy + C11 * uy * uy
    var_c = C00 * uy * uy - 2.0 * C01 * ux * uy + C11 * ux * ux  # w = (-uy, ux)
    cov = -C00 * ux * uy + C01 * (ux * ux - uy * uy) + C11 * ux * uy
    return var_r, var_c, abs(cov) / math.sqrt(var_r * var_c)


@_jit
def relative_track_features(
    existence,
    confirmed,
    mu,
    x,
    P,
    tx_pos,
    rx_pos,
    rx_boresight_rad,
    pairs,
    single_models,
    turn_pairs,
    range_scale_m,
    v_max,
    n_slots,
):  # pragma: no cover - compiled
    """``(n_slots, F)`` relative slot features (module docstring), compiled.

    Arguments as :func:`relative_track_features_reference`, with the models given by :func:`model_groups`
    (``single_models`` ``(a,)``, ``turn_pairs`` ``(b, 2)`` int64) in place of their names. Checks nothing: call
    :func:`check_geometry` once per scene.
    """
    T = tx_pos.shape[0]
    R = rx_pos.shape[0]
    Q = pairs.shape[0]
    a = single_models.shape[0]
    b = turn_pairs.shape[0]
    feats = np.zeros((n_slots, relative_feature_count(T, R, Q, a, b)))
    order = compiled_slot_order(existence, confirmed)
    M = T + R
    bx = np.cos(rx_boresight_rad)  # nan without array
    by = np.sin(rx_boresight_rad)
    baseline = np.empty(Q)
    for q in range(Q):
        t, j = pairs[q, 0], pairs[q, 1]
        baseline[q] = math.hypot(tx_pos[t, 0] - rx_pos[j, 0], tx_pos[t, 1] - rx_pos[j, 1])
    r = np.empty(M)
    ux = np.empty(M)
    uy = np.empty(M)
    rate = np.empty(M)
    for s in range(min(existence.shape[0], n_slots)):
        n = order[s]
        px, vx, py, vy = x[n, 0], x[n, 1], x[n, 2], x[n, 3]
        C00, C01, C11 = P[n, 0, 0], P[n, 0, 2], P[n, 2, 2]
        speed = math.hypot(vx, vy)
        hx = vx / speed if speed > 0.0 else 0.0
        hy = vy / speed if speed > 0.0 else 0.0
        f = feats[s]
        f[0] = 1.0
        f[1] = existence[n]
        f[2] = 1.0 if confirmed[n] else 0.0
        f[3] = speed / v_max
        for m in range(M):
            if m < T:
                dx, dy = px - tx_pos[m, 0], py - tx_pos[m, 1]
                c = 4 + 7 * m
            else:
                dx, dy = px - rx_pos[m - T, 0], py - rx_pos[m - T, 1]
                c = 4 + 7 * T + 8 * (m - T)
            rm = math.hypot(dx, dy)
            r[m] = rm
            ux[m] = dx / rm if rm > 0.0 else 0.0
            uy[m] = dy / rm if rm > 0.0 else 0.0
            rate[m] = ux[m] * vx + uy[m] * vy
            var_r, var_c, corr = _radial_frame(C00, C01, C11, ux[m], uy[m])
            f[c] = rm / range_scale_m
            f[c + 1] = rate[m] / v_max
            f[c + 2] = -(ux[m] * hx + uy[m] * hy)
            f[c + 3] = abs(ux[m] * hy - uy[m] * hx)
            f[c + 4] = math.log10(var_r) / 4.0
            f[c + 5] = math.log10(var_c) / 4.0
            f[c + 6] = corr
            if m >= T and rm > 0.0 and not math.isnan(rx_boresight_rad[m - T]):
                cb, sb = bx[m - T], by[m - T]
                f[c + 7] = math.atan2(abs(cb * dy - sb * dx), cb * dx + sb * dy) / math.pi
        c0 = 4 + 7 * T + 8 * R
        for q in range(Q):
            t = pairs[q, 0]
            j = T + pairs[q, 1]
            gx, gy = ux[t] + ux[j], uy[t] + uy[j]
            g_norm = math.hypot(gx, gy)
            if g_norm == 0.0:
                var_g = 0.5 * (C00 + C11)
            else:
                gx, gy = gx / g_norm, gy / g_norm
                var_g = C00 * gx * gx + 2.0 * C01 * gx * gy + C11 * gy * gy
            c = c0 + 3 * q
            f[c] = (r[t] + r[j] - baseline[q]) / (2.0 * range_scale_m)
            f[c + 1] = (rate[t] + rate[j]) / (2.0 * v_max)
            f[c + 2] = math.log10(var_g) / 4.0
        c = c0 + 3 * Q
        for i in range(a):
            f[c + i] = mu[n, single_models[i]]
        c += a
        for k in range(b):
            left, right = mu[n, turn_pairs[k, 0]], mu[n, turn_pairs[k, 1]]
            f[c + 2 * k] = left + right
            f[c + 2 * k + 1] = abs(left - right)
    return feats


@_jit
def relative_track_features_batched(
    track_start, existence, confirmed, mu, x, P, tx_pos, rx_pos, rx_boresight_rad, pairs, single_models, turn_pairs,
    range_scale_m, v_max, n_slots,
):  # pragma: no cover - compiled  # fmt: skip
    """``(E, n_slots, F)``: :func:`relative_track_features` of E environments in one call (the batched env).

    Environment e owns the tracks ``track_start[e]:track_start[e + 1]`` of the concatenated arrays (as
    ``uwb_env.envs.outputs.scan_summaries``); the scene arguments are shared.
    """
    E = track_start.shape[0] - 1
    F = relative_feature_count(
        tx_pos.shape[0], rx_pos.shape[0], pairs.shape[0], single_models.shape[0], turn_pairs.shape[0]
    )
    feats = np.zeros((E, n_slots, F))
    for e in range(E):
        a0, a1 = track_start[e], track_start[e + 1]
        feats[e] = relative_track_features(
            existence[a0:a1], confirmed[a0:a1], mu[a0:a1], x[a0:a1], P[a0:a1], tx_pos, rx_pos, rx_boresight_rad,
            pairs, single_models, turn_pairs, range_scale_m, v_max, n_slots,
        )  # fmt: skip
    return feats
