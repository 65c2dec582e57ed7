r"""Propagation paths of one transmitter-receiver pair through point scatterers (seed 003 sections 3.1 and V).

Seed 003 keeps every path with at most three reflections and at most one target (section V):

    =====  ==========================  ========  ============================================
    code   path                        bounces   depends on the targets
    =====  ==========================  ========  ============================================
    0      tx-rx (direct blast)        0         no
    1      tx-target-rx                1         yes (the target's "direct" path)
    2      tx-clutter-rx               1         no
    3      tx-target-clutter-rx        2         yes
    4      tx-clutter-target-rx        2         yes
    5      tx-clutter-clutter-rx       2         no
    6      tx-clutter-target-clutter-rx 3        yes
    7      tx-target-clutter-clutter-rx 3        yes
    8      tx-clutter-clutter-target-rx 3        yes
    =====  ==========================  ========  ============================================

(:class:`PathKind`). Scatterers (vegetation, poles: the seed's "clutter discretes") are points with an isotropic
RCS; the seed's specular reflection point on a line scatterer becomes, for a point, the point itself. Every leg must
be line of sight: a leg that crosses a wall segment (buildings are opaque) removes the path. A path never visits the
same scatterer twice in a row; tx-c-target-c-rx may use the same scatterer on both sides of the target.

Per path we return (:class:`Paths`):

* ``length_m``: total path length L = sum of the legs [m]; its delay is L / c.
* ``range_rate_mps``: dL/dt [m/s]. Only the target moves, so only its two adjacent legs change:
  dL/dt = v . (u_in + u_out), u the unit vectors pointing from the neighbouring node / scatterer to the target (the
  convention of ``uwb_env.tracking.measurement.range_rate``: positive when the path lengthens). 0 for static paths.
* ``doa_rad``: direction of arrival at the receiver, atan2 of the last leg from the receiver towards the last
  scatterer / target / transmitter, counter-clockwise from +x [rad].
* ``gain``: the power ratio P_r / P_t of the path (below).
* ``target``: index of the target on the path (-1 if none); ``kind``: the code above; ``scatterer``: ``(P, 2)``
  the first and second scatterer visited (-1 where none).

Radar equation of a path through n point scatterers (derivation). The transmitter radiates P_t with gain G_t, so
the power density at distance L_0 is P_t G_t / (4 pi L_0^2). A point of RCS sigma_1 intercepts sigma_1 times that
density and re-radiates it isotropically, so at distance L_1 from it the density is
P_t G_t sigma_1 / ((4 pi)^2 L_0^2 L_1^2); every further scatterer multiplies by sigma_i / (4 pi L_i^2). After n
scatterers the density at the receiver is P_t G_t prod_i sigma_i / ((4 pi)^(n+1) prod_j L_j^2), and an antenna of
gain G_r has the effective area G_r lambda^2 / (4 pi):

    P_r / P_t = G_t G_r lambda^2 prod_{i=1..n} sigma_i / ((4 pi)^(n+2) prod_{j=0..n} L_j^2)
              = G_t G_r lambda^2 / (4 pi)^3  *  prod_i sigma_i / (4 pi)^(n-1)  /  prod_j L_j^2.

n = 0 is the Friis equation G_t G_r (lambda / (4 pi L_0))^2; n = 1 is the bistatic radar equation
G_t G_r lambda^2 sigma / ((4 pi)^3 L_t^2 L_r^2) (``uwb_env.channel.radar_equation`` in free space). Each bounce
beyond the first costs sigma / (4 pi L^2): for a 1 m^2 scatterer 20 m away that is -37 dB, which is why
:func:`static_paths` and :func:`target_paths` accept ``min_gain`` (drop paths below it; :func:`gain_floor` turns an
integrated-SNR floor into a gain) and ``max_length_m`` (drop paths beyond the receiver's delay window).

Static (target-free) paths do not change during an episode: compute :func:`scatterer_geometry` and
:func:`static_paths` once, and :func:`target_paths` every scan; :func:`propagation_paths` does both at once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum

import numba as nb
import numpy as np

from uwb_env.scene.geometry import segments_cross
from uwb_env.typing import BoolArray, FloatArray, IntArray

_jit = nb.njit(cache=True, fastmath=False, nogil=True)
_FOUR_PI = 4.0 * math.pi


class PathKind(IntEnum):
    """Path type codes (module docstring table)."""

    DIRECT = 0
    TARGET = 1
    CLUTTER = 2
    TARGET_CLUTTER = 3
    CLUTTER_TARGET = 4
    CLUTTER_CLUTTER = 5
    CLUTTER_TARGET_CLUTTER = 6
    TARGET_CLUTTER_CLUTTER = 7
    CLUTTER_CLUTTER_TARGET = 8


PATH_BOUNCES = np.array([0, 1, 1, 2, 2, 2, 3, 3, 3], dtype=np.int64)
"""``(9,)`` number of reflections of each :class:`PathKind`."""

STATIC_KINDS = (PathKind.DIRECT, PathKind.CLUTTER, PathKind.CLUTTER_CLUTTER)
"""The path kinds that involve no target."""


@dataclass(frozen=True, slots=True)
class Paths:
    """Flat arrays over the P paths of one transmitter-receiver pair (module docstring).

    Attributes:
        length_m: ``(P,)`` total length [m]. range_rate_mps: ``(P,)`` d length / dt [m/s].
        doa_rad: ``(P,)`` direction of arrival at the receiver [rad]. gain: ``(P,)`` P_r / P_t (linear).
        target: ``(P,)`` int64 target index, -1 for static paths. kind: ``(P,)`` int64 :class:`PathKind` code.
        scatterer: ``(P, 2)`` int64 first and second scatterer visited, -1 where none.
    """

    length_m: FloatArray
    range_rate_mps: FloatArray
    doa_rad: FloatArray
    gain: FloatArray
    target: IntArray
    kind: IntArray
    scatterer: IntArray

    def __len__(self) -> int:
        return int(self.length_m.shape[0])

    def select(self, mask: BoolArray | IntArray) -> Paths:
        """The paths picked by a boolean mask or an index array."""
        return Paths(
            self.length_m[mask],
            self.range_rate_mps[mask],
            self.doa_rad[mask],
            self.gain[mask],
            self.target[mask],
            self.kind[mask],
            self.scatterer[mask],
        )

    @staticmethod
    def concatenate(parts: tuple[Paths, ...] | list[Paths]) -> Paths:
        """One path list from several (e.g. the episode's static paths and the scan's target paths)."""
        return Paths(
            *(np.concatenate([getattr(p, f) for p in parts]) for f in Paths.__slots__)  # 7 fields
        )

    @staticmethod
    def empty() -> Paths:
        """No path."""
        z = np.zeros(0)
        i = np.zeros(0, dtype=np.int64)
        return Paths(z, z, z, z, i, i, np.zeros((0, 2), dtype=np.int64))


@dataclass(frozen=True, slots=True)
class ScattererGeometry:
    """The target-independent legs of one pair, computed once per episode by :func:`scatterer_geometry`.

    Attributes:
        tx, rx: ``(2,)`` node positions [m]. scatterers: ``(C, 2)`` [m]. scatterer_rcs: ``(C,)`` [m^2].
        wall_a, wall_b: ``(W, 2)`` wall segment end points [m].
        tx_rx: distance [m]; tx_rx_visible: line of sight of the direct leg.
        tx_sc, sc_rx: ``(C,)`` distances tx-scatterer and scatterer-rx [m]; tx_sc_visible, sc_rx_visible ``(C,)``.
        sc_sc: ``(C, C)`` scatterer-scatterer distances [m]; sc_sc_visible ``(C, C)`` (False on the diagonal).
        sc_doa: ``(C,)`` atan2 of the leg from rx towards each scatterer [rad]; tx_doa: the same towards tx.
    """

    tx: FloatArray
    rx: FloatArray
    scatterers: FloatArray
    scatterer_rcs: FloatArray
    wall_a: FloatArray
    wall_b: FloatArray
    tx_rx: float
    tx_rx_visible: bool
    tx_sc: FloatArray
    tx_sc_visible: BoolArray
    sc_rx: FloatArray
    sc_rx_visible: BoolArray
    sc_sc: FloatArray
    sc_sc_visible: BoolArray
    sc_doa: FloatArray
    tx_doa: float


def leg_visibility(
    p0: FloatArray, p1: FloatArray, wall_a: FloatArray, wall_b: FloatArray
) -> tuple[FloatArray, BoolArray]:
    """Distances and line of sight of every leg between two point sets.

    Args:
        p0: ``(N, 2)``, p1: ``(M, 2)`` points [m]; wall_a, wall_b: ``(W, 2)`` opaque wall segments [m].

    Returns:
        ``(N, M)`` distances [m] and ``(N, M)`` True where the segment p0[i] -> p1[j] crosses no wall
        (``uwb_env.scene.geometry.segments_cross``; touching a wall counts as crossing).
    """
    p0 = np.asarray(p0, dtype=float).reshape(-1, 2)
    p1 = np.asarray(p1, dtype=float).reshape(-1, 2)
    d = p1[None, :, :] - p0[:, None, :]
    dist = np.sqrt(d[..., 0] ** 2 + d[..., 1] ** 2)
    n, m = dist.shape
    if wall_a.shape[0] == 0 or n * m == 0:
        return dist, np.ones((n, m), dtype=bool)
    a = np.broadcast_to(p0[:, None, :], (n, m, 2)).reshape(-1, 2)
    b = np.broadcast_to(p1[None, :, :], (n, m, 2)).reshape(-1, 2)
    return dist, ~segments_cross(a, b, wall_a, wall_b).any(axis=1).reshape(n, m)


def scatterer_geometry(
    tx: FloatArray,
    rx: FloatArray,
    scatterers: FloatArray,
    scatterer_rcs: FloatArray,
    wall_a: FloatArray,
    wall_b: FloatArray,
) -> ScattererGeometry:
    """Precompute the static legs of one pair (once per episode).

    Args:
        tx, rx: ``(2,)`` [m]; scatterers: ``(C, 2)`` [m]; scatterer_rcs: ``(C,)`` [m^2] (or a scalar);
        wall_a, wall_b: ``(W, 2)`` opaque walls [m].
    """
    tx = np.asarray(tx, dtype=float).reshape(2)
    rx = np.asarray(rx, dtype=float).reshape(2)
    sc = np.asarray(scatterers, dtype=float).reshape(-1, 2)
    rcs = np.broadcast_to(np.asarray(scatterer_rcs, dtype=float), (sc.shape[0],)).copy()
    wa = np.asarray(wall_a, dtype=float).reshape(-1, 2)
    wb = np.asarray(wall_b, dtype=float).reshape(-1, 2)
    d_tr, v_tr = leg_visibility(tx[None], rx[None], wa, wb)
    d_ts, v_ts = leg_visibility(tx[None], sc, wa, wb)
    d_sr, v_sr = leg_visibility(sc, rx[None], wa, wb)
    d_ss, v_ss = leg_visibility(sc, sc, wa, wb)
    v_ss &= ~np.eye(sc.shape[0], dtype=bool)
    return ScattererGeometry(
        tx=tx,
        rx=rx,
        scatterers=sc,
        scatterer_rcs=rcs,
        wall_a=wa,
        wall_b=wb,
        tx_rx=float(d_tr[0, 0]),
        tx_rx_visible=bool(v_tr[0, 0]),
        tx_sc=d_ts[0],
        tx_sc_visible=v_ts[0],
        sc_rx=d_sr[:, 0],
        sc_rx_visible=v_sr[:, 0],
        sc_sc=d_ss,
        sc_sc_visible=v_ss,
        sc_doa=np.arctan2(sc[:, 1] - rx[1], sc[:, 0] - rx[0]),
        tx_doa=math.atan2(tx[1] - rx[1], tx[0] - rx[0]),
    )


def gain_constant(n_bounces: IntArray, wavelength_m: float, tx_gain: float = 1.0, rx_gain: float = 1.0) -> FloatArray:
    """G_t G_r lambda^2 / (4 pi)^(n + 2): the path gain times prod L_j^2 / prod sigma_i (module docstring)."""
    return tx_gain * rx_gain * wavelength_m**2 / _FOUR_PI ** (np.asarray(n_bounces, dtype=float) + 2.0)


def gain_floor(
    snr_floor: float, noise_psd_w_per_hz: float, pulse_energy_j: float, n_pulses: int, n_elements: int = 1
) -> float:
    """Path gain whose integrated E/N0 (B pulses, L elements combined) equals ``snr_floor``.

    SNR = gain x E_pulse x B x L / N0, so gain_min = snr_floor N0 / (E_pulse B L). Paths below it are invisible in a
    delay-Doppler image (use it as ``min_gain``).
    """
    return snr_floor * noise_psd_w_per_hz / (pulse_energy_j * n_pulses * n_elements)


def static_paths(
    geom: ScattererGeometry,
    *,
    wavelength_m: float,
    tx_gain: float = 1.0,
    rx_gain: float = 1.0,
    max_bounces: int = 3,
    min_gain: float = 0.0,
    max_length_m: float = math.inf,
) -> Paths:
    """The target-free paths of a pair: tx-rx, tx-c-rx and tx-c-c-rx (computed once per episode).

    Args:
        geom: the pair's :class:`ScattererGeometry`; wavelength_m: carrier wavelength [m]; tx_gain, rx_gain: linear
        antenna gains; max_bounces: keep kinds with at most this many reflections (0..3); min_gain: drop paths whose
        P_r / P_t is below it; max_length_m: drop paths longer than this [m].

    Returns:
        :class:`Paths` in the order direct, single clutter (by scatterer), double clutter (row-major (c1, c2));
        range rates are 0.
    """
    c = geom.scatterers.shape[0]
    k = gain_constant(PATH_BOUNCES, wavelength_m, tx_gain, rx_gain)
    rcs = geom.scatterer_rcs
    parts: list[Paths] = []
    if geom.tx_rx_visible:
        g = np.array([k[PathKind.DIRECT] / geom.tx_rx**2])
        parts.append(
            _static_part(np.array([geom.tx_rx]), np.array([geom.tx_doa]), g, PathKind.DIRECT, -np.ones((1, 2)))
        )
    if max_bounces >= 1 and c:
        ok = geom.tx_sc_visible & geom.sc_rx_visible
        length = geom.tx_sc + geom.sc_rx
        g = k[PathKind.CLUTTER] * rcs / (geom.tx_sc * geom.sc_rx) ** 2
        idx = np.stack([np.arange(c), -np.ones(c, dtype=np.int64)], axis=1)
        parts.append(_static_part(length, geom.sc_doa, g, PathKind.CLUTTER, idx, ok))
    if max_bounces >= 2 and c:
        ok = geom.tx_sc_visible[:, None] & geom.sc_sc_visible & geom.sc_rx_visible[None, :]
        length = geom.tx_sc[:, None] + geom.sc_sc + geom.sc_rx[None, :]
        with np.errstate(divide="ignore"):
            g = (
                k[PathKind.CLUTTER_CLUTTER]
                * rcs[:, None]
                * rcs[None, :]
                / (geom.tx_sc[:, None] * geom.sc_sc * geom.sc_rx[None, :]) ** 2
            )
        i1, i2 = np.meshgrid(np.arange(c), np.arange(c), indexing="ij")
        doa = np.broadcast_to(geom.sc_doa[None, :], (c, c))
        idx = np.stack([i1.ravel(), i2.ravel()], axis=1)
        parts.append(_static_part(length.ravel(), doa.ravel(), g.ravel(), PathKind.CLUTTER_CLUTTER, idx, ok.ravel()))
    if not parts:
        return Paths.empty()
    out = Paths.concatenate(parts)
    return out.select((out.gain >= min_gain) & (out.length_m <= max_length_m))


def _static_part(
    length: FloatArray, doa: FloatArray, gain: FloatArray, kind: int, idx: FloatArray, ok: BoolArray | None = None
) -> Paths:
    """Wrap static arrays as :class:`Paths` (rows where ``ok``)."""
    n = length.shape[0]
    p = Paths(
        length.astype(float),
        np.zeros(n),
        doa.astype(float),
        gain.astype(float),
        -np.ones(n, dtype=np.int64),
        np.full(n, int(kind), dtype=np.int64),
        idx.astype(np.int64),
    )
    return p if ok is None else p.select(ok)


def target_paths(
    geom: ScattererGeometry,
    targets_pos: FloatArray,
    targets_vel: FloatArray,
    target_rcs: FloatArray,
    *,
    wavelength_m: float,
    tx_gain: float = 1.0,
    rx_gain: float = 1.0,
    max_bounces: int = 3,
    min_gain: float = 0.0,
    max_length_m: float = math.inf,
) -> Paths:
    """The paths through one target of a pair (kinds 1, 3, 4, 6, 7, 8), for one scan.

    Args:
        geom: the pair's :class:`ScattererGeometry`; targets_pos: ``(K, 2)`` [m]; targets_vel: ``(K, 2)`` [m/s];
        target_rcs: ``(K,)`` [m^2] (or a scalar); other arguments as in :func:`static_paths`.

    Returns:
        :class:`Paths`, grouped by target then kind (1, 3, 4, 6, 7, 8), scatterers in row-major order.

    Notes:
        The target-dependent legs (target to tx, rx and every scatterer: K (C + 2) segments) are tested against the
        walls by :func:`_target_legs` (the crossing test of ``segments_cross``, compiled); the K (1 + 2 C + 3 C^2)
        candidate paths, their gains and the pruning run in one compiled pass.
    """
    pos = np.asarray(targets_pos, dtype=float).reshape(-1, 2)
    vel = np.asarray(targets_vel, dtype=float).reshape(-1, 2)
    n_t = pos.shape[0]
    if n_t == 0 or max_bounces < 1:
        return Paths.empty()
    rcs = np.broadcast_to(np.asarray(target_rcs, dtype=float), (n_t,)).copy()
    nodes = np.ascontiguousarray(np.stack([geom.tx, geom.rx]))
    d_nk, v_nk, pv_n = _target_legs(pos, vel, nodes, geom.wall_a, geom.wall_b)  # (2, K)
    d_ck, v_ck, pv_c = _target_legs(pos, vel, geom.scatterers, geom.wall_a, geom.wall_b)  # (C, K)
    d_kc, v_kc, pv_c = d_ck.T.copy(), v_ck.T.copy(), pv_c.T.copy()
    doa_k = np.arctan2(pos[:, 1] - geom.rx[1], pos[:, 0] - geom.rx[0])
    k = gain_constant(PATH_BOUNCES, wavelength_m, tx_gain, rx_gain)
    c = geom.scatterers.shape[0]
    n_max = n_t * (1 + 2 * c + 3 * c * c)
    out_f = np.empty((4, n_max))
    out_i = np.empty((4, n_max), dtype=np.int64)
    n = _enumerate_target_paths(
        d_nk[0],
        v_nk[0],
        d_nk[1],
        v_nk[1],
        pv_n[0],
        pv_n[1],
        doa_k,
        rcs,
        d_kc,
        v_kc,
        pv_c,
        geom.tx_sc,
        geom.tx_sc_visible,
        geom.sc_rx,
        geom.sc_rx_visible,
        geom.sc_sc,
        geom.sc_sc_visible,
        geom.sc_doa,
        geom.scatterer_rcs,
        k,
        max_bounces,
        min_gain,
        max_length_m,
        out_f,
        out_i,
    )
    return Paths(
        out_f[0, :n].copy(),
        out_f[1, :n].copy(),
        out_f[2, :n].copy(),
        out_f[3, :n].copy(),
        out_i[0, :n].copy(),
        out_i[1, :n].copy(),
        out_i[2:, :n].T.copy(),
    )


@_jit
def _target_legs(pos, vel, points, wall_a, wall_b):  # pragma: no cover - compiled
    """Legs point -> target: distances ``(N, K)``, line of sight ``(N, K)`` and v_k . u ``(N, K)`` [m/s].

    u the unit vector from the point to the target. Line of sight is ``scene.geometry.segments_cross`` negated:
    p0 + t d = a + u e with t, u in [0, 1] (|d x e| < 1e-12: parallel, no crossing).
    """
    n, k_n, w_n = points.shape[0], pos.shape[0], wall_a.shape[0]
    dist = np.empty((n, k_n))
    vis = np.empty((n, k_n), dtype=np.bool_)
    proj = np.empty((n, k_n))
    for i in range(n):
        px, py = points[i, 0], points[i, 1]
        for k in range(k_n):
            dx, dy = pos[k, 0] - px, pos[k, 1] - py
            d = math.sqrt(dx * dx + dy * dy)
            dist[i, k] = d
            proj[i, k] = (dx * vel[k, 0] + dy * vel[k, 1]) / max(d, 1e-12)
            ok = True
            for w in range(w_n):
                ex, ey = wall_b[w, 0] - wall_a[w, 0], wall_b[w, 1] - wall_a[w, 1]
                denom = dx * ey - dy * ex
                if abs(denom) < 1e-12:
                    continue
                wx, wy = wall_a[w, 0] - px, wall_a[w, 1] - py
                t = (wx * ey - wy * ex) / denom
                u = (wx * dy - wy * dx) / denom
                if t >= 0.0 and t <= 1.0 and u >= 0.0 and u <= 1.0:
                    ok = False
                    break
            vis[i, k] = ok
    return dist, vis, proj


@_jit
def _emit(out_f, out_i, n, length, rdot, doa, gain, tgt, kind, c1, c2, min_gain, max_length):  # pragma: no cover
    """Append one path to the output buffers when it passes the gain and length cuts; returns the new count."""
    if gain < min_gain or length > max_length:
        return n
    out_f[0, n] = length
    out_f[1, n] = rdot
    out_f[2, n] = doa
    out_f[3, n] = gain
    out_i[0, n] = tgt
    out_i[1, n] = kind
    out_i[2, n] = c1
    out_i[3, n] = c2
    return n + 1


@_jit
def _enumerate_target_paths(
    d_tk,
    v_tk,
    d_rk,
    v_rk,
    pv_t,
    pv_r,
    doa_k,
    rcs_k,
    d_kc,
    v_kc,
    pv_c,
    d_tc,
    v_tc,
    d_cr,
    v_cr,
    d_cc,
    v_cc,
    doa_c,
    rcs_c,
    kconst,
    max_bounces,
    min_gain,
    max_length,
    out_f,
    out_i,
):  # pragma: no cover - compiled
    """Every target path of the module docstring's table (kinds 1, 3, 4, 6, 7, 8) with its gain; see target_paths.

    pv_t[k], pv_r[k], pv_c[k, c]: v_k projected on the unit vectors from tx, rx, scatterer c to target k [m/s].
    """
    n = 0
    n_t = d_tk.shape[0]
    n_c = d_tc.shape[0]
    for k in range(n_t):
        s = rcs_k[k]
        if v_tk[k] and v_rk[k]:  # 1: tx-k-rx
            g = kconst[1] * s / (d_tk[k] * d_rk[k]) ** 2
            n = _emit(
                out_f, out_i, n, d_tk[k] + d_rk[k], pv_t[k] + pv_r[k], doa_k[k], g, k, 1, -1, -1, min_gain, max_length
            )
        if max_bounces < 2:
            continue
        for c in range(n_c):  # 3: tx-k-c-rx
            if v_tk[k] and v_kc[k, c] and v_cr[c]:
                g = kconst[3] * s * rcs_c[c] / (d_tk[k] * d_kc[k, c] * d_cr[c]) ** 2
                n = _emit(
                    out_f, out_i, n, d_tk[k] + d_kc[k, c] + d_cr[c], pv_t[k] + pv_c[k, c], doa_c[c], g, k, 3, c, -1,
                    min_gain, max_length,
                )  # fmt: skip
        for c in range(n_c):  # 4: tx-c-k-rx
            if v_tc[c] and v_kc[k, c] and v_rk[k]:
                g = kconst[4] * s * rcs_c[c] / (d_tc[c] * d_kc[k, c] * d_rk[k]) ** 2
                n = _emit(
                    out_f, out_i, n, d_tc[c] + d_kc[k, c] + d_rk[k], pv_c[k, c] + pv_r[k], doa_k[k], g, k, 4, c, -1,
                    min_gain, max_length,
                )  # fmt: skip
        if max_bounces < 3:
            continue
        for c1 in range(n_c):  # 6: tx-c1-k-c2-rx (c1 == c2 allowed: the target lies between)
            if not (v_tc[c1] and v_kc[k, c1]):
                continue
            a = kconst[6] * s * rcs_c[c1] / (d_tc[c1] * d_kc[k, c1]) ** 2
            for c2 in range(n_c):
                if v_kc[k, c2] and v_cr[c2]:
                    g = a * rcs_c[c2] / (d_kc[k, c2] * d_cr[c2]) ** 2
                    length = d_tc[c1] + d_kc[k, c1] + d_kc[k, c2] + d_cr[c2]
                    n = _emit(
                        out_f, out_i, n, length, pv_c[k, c1] + pv_c[k, c2], doa_c[c2], g, k, 6, c1, c2, min_gain,
                        max_length,
                    )  # fmt: skip
        if v_tk[k]:  # 7: tx-k-c1-c2-rx
            for c1 in range(n_c):
                if not v_kc[k, c1]:
                    continue
                a = kconst[7] * s * rcs_c[c1] / (d_tk[k] * d_kc[k, c1]) ** 2
                for c2 in range(n_c):
                    if v_cc[c1, c2] and v_cr[c2]:
                        g = a * rcs_c[c2] / (d_cc[c1, c2] * d_cr[c2]) ** 2
                        length = d_tk[k] + d_kc[k, c1] + d_cc[c1, c2] + d_cr[c2]
                        n = _emit(
                            out_f, out_i, n, length, pv_t[k] + pv_c[k, c1], doa_c[c2], g, k, 7, c1, c2, min_gain,
                            max_length,
                        )  # fmt: skip
        if v_rk[k]:  # 8: tx-c1-c2-k-rx
            for c1 in range(n_c):
                if not v_tc[c1]:
                    continue
                a = kconst[8] * s * rcs_c[c1] / d_tc[c1] ** 2
                for c2 in range(n_c):
                    if v_cc[c1, c2] and v_kc[k, c2]:
                        g = a * rcs_c[c2] / (d_cc[c1, c2] * d_kc[k, c2] * d_rk[k]) ** 2
                        length = d_tc[c1] + d_cc[c1, c2] + d_kc[k, c2] + d_rk[k]
                        n = _emit(
                            out_f, out_i, n, length, pv_c[k, c2] + pv_r[k], doa_k[k], g, k, 8, c1, c2, min_gain,
                            max_length,
                        )  # fmt: skip
    return n


def propagation_paths(
    tx: FloatArray,
    rx: FloatArray,
    targets_pos: FloatArray,
    targets_vel: FloatArray,
    scatterers: FloatArray,
    wall_a: FloatArray,
    wall_b: FloatArray,
    max_bounces: int = 3,
    *,
    target_rcs: FloatArray | float,
    scatterer_rcs: FloatArray | float,
    wavelength_m: float,
    tx_gain: float = 1.0,
    rx_gain: float = 1.0,
    min_gain: float = 0.0,
    max_length_m: float = math.inf,
) -> Paths:
    """Every path of one pair for one scan: :func:`static_paths` followed by :func:`target_paths`.

    Args:
        tx, rx: ``(2,)`` [m]; targets_pos ``(K, 2)`` [m]; targets_vel ``(K, 2)`` [m/s]; scatterers ``(C, 2)`` [m];
        wall_a, wall_b ``(W, 2)`` opaque walls [m]; max_bounces: 0..3; target_rcs ``(K,)`` and scatterer_rcs
        ``(C,)`` [m^2]; wavelength_m [m]; tx_gain, rx_gain linear; min_gain, max_length_m: pruning (see
        :func:`static_paths`).

    Returns:
        :class:`Paths`. In a closed loop compute the static part once per episode instead (module docstring).
    """
    geom = scatterer_geometry(tx, rx, scatterers, scatterer_rcs, wall_a, wall_b)
    kw = {
        "wavelength_m": wavelength_m,
        "tx_gain": tx_gain,
        "rx_gain": rx_gain,
        "max_bounces": max_bounces,
        "min_gain": min_gain,
        "max_length_m": max_length_m,
    }
    return Paths.concatenate(
        [static_paths(geom, **kw), target_paths(geom, targets_pos, targets_vel, target_rcs, **kw)]  # type: ignore[arg-type]
    )
