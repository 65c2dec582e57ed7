r"""Tracking metrics against truth: per-scan assignment, OSPA, run-level track statistics.

Per scan, confirmed tracks are assigned to alive targets by the Hungarian algorithm on position distance, with a
gate ``association_distance_m`` (a pair farther apart is not a match). Over a run:

* a target is **held** in a scan when a confirmed track is assigned to it; its coverage is the fraction of its
  alive scans in which it is held, and it is **confirmed in the run** when it is held in at least one scan;
* a confirmed track is **false** when it is assigned to a target in fewer than half of the scans it is confirmed;
* a target keeps its **identity** across a window when the same track id holds it before and after (the most
  frequent id on each side) and no other target is held by that id.

OSPA (Schuhmacher, Vo and Vo 2008) of order p with cut-off c between the confirmed tracks and the targets.
"""

from __future__ import annotations

import math
from collections import Counter, defaultdict
from dataclasses import dataclass, field

import numba as nb
import numpy as np

from uwb_env.typing import BoolArray, FloatArray, IntArray


@nb.njit(cache=True, nogil=True)
def _hungarian(cost):  # pragma: no cover - compiled
    """Minimum-cost assignment of every row of ``cost`` (n, m), n <= m: the column of each row ``(n,)``.

    Kuhn-Munkres with row and column potentials, one shortest augmenting path per row, O(n^2 m) (the e-maxx
    formulation of the Hungarian algorithm).
    """
    n, m = cost.shape
    u = np.zeros(n + 1)
    v = np.zeros(m + 1)
    owner = np.zeros(m + 1, np.int64)  # owner[j]: the 1-based row holding column j (0: free; column 0 is virtual)
    way = np.zeros(m + 1, np.int64)
    minv = np.empty(m + 1)
    used = np.empty(m + 1, np.bool_)
    for i in range(1, n + 1):
        owner[0] = i
        j0 = 0
        minv[:] = np.inf
        used[:] = False
        while True:
            used[j0] = True
            i0 = owner[j0]
            delta = np.inf
            j1 = 0
            for j in range(1, m + 1):
                if not used[j]:
                    cur = cost[i0 - 1, j - 1] - u[i0] - v[j]
                    if cur < minv[j]:
                        minv[j] = cur
                        way[j] = j0
                    if minv[j] < delta:
                        delta = minv[j]
                        j1 = j
            for j in range(m + 1):
                if used[j]:
                    u[owner[j]] += delta
                    v[j] -= delta
                else:
                    minv[j] -= delta
            j0 = j1
            if owner[j0] == 0:
                break
        while j0 != 0:  # augment along the path
            j1 = way[j0]
            owner[j0] = owner[j1]
            j0 = j1
    col = np.empty(n, np.int64)
    for j in range(1, m + 1):
        if owner[j] > 0:
            col[owner[j] - 1] = j - 1
    return col


@nb.njit(cache=True, nogil=True)
def _matching(cost):  # pragma: no cover - compiled
    """Minimum-cost matching of min(N, K) pairs on ``cost`` (N, K): (row idx, col idx), rows ascending.

    The Hungarian algorithm (``_hungarian``) on the cost or its transpose: the optimum of
    ``scipy.optimize.linear_sum_assignment`` (tested), without the solver's call overhead at a scan's sizes.
    """
    n, k = cost.shape
    if n <= k:
        return np.arange(n), _hungarian(cost)
    rows = _hungarian(np.ascontiguousarray(cost.T))
    order = np.argsort(rows)
    return rows[order], order


def _min_cost_matching(cost: FloatArray) -> tuple[IntArray, IntArray]:
    """``_matching`` on any float array ``cost`` (N, K)."""
    return _matching(np.ascontiguousarray(cost, dtype=float))


@nb.njit(cache=True, nogil=True)
def _distances(a, b):  # pragma: no cover - compiled
    """``distances`` in compiled code."""
    d = np.empty((a.shape[0], b.shape[0]))
    for i in range(a.shape[0]):
        for j in range(b.shape[0]):
            dx, dy = a[i, 0] - b[j, 0], a[i, 1] - b[j, 1]
            d[i, j] = math.sqrt(dx * dx + dy * dy)
    return d


@nb.njit(cache=True, nogil=True)
def _gated_assignment(d, gate_m):  # pragma: no cover - compiled
    """``assign`` on the distance matrix ``d`` (N, K), N, K >= 1: pairs beyond the gate cost 1e12 and are dropped."""
    i, j = _matching(np.where(d <= gate_m, d, 1e12))
    keep = np.array([d[i[c], j[c]] <= gate_m for c in range(i.size)])
    return i[keep], j[keep]


@nb.njit(cache=True, nogil=True)
def _ospa(d, cutoff_m, order):  # pragma: no cover - compiled
    """``ospa`` on the distance matrix ``d`` (m, n) of the two sets (either may be empty)."""
    m, n = d.shape
    if m == 0 and n == 0:
        return 0.0
    if m == 0 or n == 0:
        return cutoff_m
    c = np.minimum(d, cutoff_m) ** order
    i, j = _matching(c)
    cost = 0.0
    for a in range(i.size):
        cost += c[i[a], j[a]]
    cost += cutoff_m**order * abs(m - n)
    return (cost / max(m, n)) ** (1.0 / order)


@nb.njit(cache=True, nogil=True)
def cover_summary(confirmed, x, P, mu, targets, gate_m, cutoff_m, order):  # pragma: no cover - compiled
    """One scan's tracks against its targets, in one compiled pass (the environments' reward and ``info``).

    Args: confirmed ``(N,)``, combined x ``(N, 6)``, P ``(N, 6, 6)``, mu ``(N, r)``; targets ``(K, 2)`` [m];
    gate_m (``assign``), cutoff_m and order (``ospa``).

    Returns: position-covariance traces of the confirmed tracks ``(n,)`` [m^2], their summed model probabilities
    ``(r,)``, the cover assignment (confirmed-track idx ``(c,)``, target idx ``(c,)``, errors ``(c,)`` [m]) as
    ``assign``, and the OSPA [m] as ``ospa`` (both from one distance matrix).
    """
    conf = np.flatnonzero(confirmed)
    n, r = conf.size, mu.shape[1]
    trace = np.empty(n)
    mu_sum = np.zeros(r)
    pos = np.empty((n, 2))
    for a in range(n):
        t = conf[a]
        trace[a] = P[t, 0, 0] + P[t, 2, 2]
        pos[a, 0], pos[a, 1] = x[t, 0], x[t, 2]
        for j in range(r):
            mu_sum[j] += mu[t, j]
    d = _distances(pos, targets)
    if n == 0 or targets.shape[0] == 0:
        ti, gi = np.zeros(0, np.int64), np.zeros(0, np.int64)
    else:
        ti, gi = _gated_assignment(d, gate_m)
    errors = np.array([d[ti[c], gi[c]] for c in range(ti.size)])
    return trace, mu_sum, ti, gi, errors, _ospa(d, cutoff_m, order)


def distances(track_pos: FloatArray, target_pos: FloatArray) -> FloatArray:
    """``(N, K)`` Euclidean distances [m] between positions ``(N, 2)`` and ``(K, 2)``."""
    return _distances(np.ascontiguousarray(track_pos, dtype=float), np.ascontiguousarray(target_pos, dtype=float))


def assign(track_pos: FloatArray, target_pos: FloatArray, gate_m: float) -> tuple[IntArray, IntArray]:
    """Hungarian assignment of tracks ``(N, 2)`` to targets ``(K, 2)`` within ``gate_m``: (track idx, target idx)."""
    if track_pos.shape[0] == 0 or target_pos.shape[0] == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    return _gated_assignment(distances(track_pos, target_pos), float(gate_m))


def ospa(track_pos: FloatArray, target_pos: FloatArray, cutoff_m: float, order: float = 2.0) -> float:
    """OSPA distance [m] between two finite sets of positions (0 when both are empty)."""
    return float(_ospa(distances(track_pos, target_pos), float(cutoff_m), float(order)))


@dataclass(slots=True)
class TrackAccounting:
    """Accumulates, scan by scan, the assignment of confirmed tracks to targets (one run)."""

    n_targets: int
    gate_m: float
    held: list[list[int]] = field(default_factory=list)  # per scan, per target: track id or -1
    alive: list[BoolArray] = field(default_factory=list)
    errors: list[FloatArray] = field(default_factory=list)  # per scan: (K,) position error, nan where not held
    confirmed_scans: dict[int, int] = field(default_factory=lambda: defaultdict(int))
    matched_scans: dict[int, int] = field(default_factory=lambda: defaultdict(int))

    def add(
        self, ids: IntArray, confirmed: BoolArray, track_pos: FloatArray, target_pos: FloatArray, alive: BoolArray
    ) -> tuple[IntArray, IntArray]:
        """Record one scan; returns the (confirmed track idx, target idx) matches."""
        c = np.flatnonzero(confirmed)
        live = np.flatnonzero(alive)
        i, j = assign(track_pos[c], target_pos[live], self.gate_m)
        row = [-1] * self.n_targets
        for a, b in zip(c[i].tolist(), live[j].tolist(), strict=True):  # matches: at most K per scan
            row[b] = int(ids[a])
        self.held.append(row)
        self.alive.append(alive.copy())
        err = np.full(self.n_targets, np.nan)
        err[live[j]] = np.linalg.norm(track_pos[c[i]] - target_pos[live[j]], axis=-1)
        self.errors.append(err)
        for tid in ids[c].tolist():
            self.confirmed_scans[tid] += 1
        for tid in ids[c[i]].tolist():
            self.matched_scans[tid] += 1
        return c[i], live[j]

    def coverage(self) -> FloatArray:
        """``(K,)`` fraction of each target's alive scans in which a confirmed track holds it."""
        held = np.array(self.held) >= 0
        alive = np.array(self.alive)
        return held.sum(axis=0) / np.maximum(alive.sum(axis=0), 1)

    def confirmed_targets(self) -> BoolArray:
        """``(K,)`` whether each target was held by a confirmed track in at least one scan."""
        return (np.array(self.held) >= 0).any(axis=0)

    def false_tracks(self) -> int:
        """Confirmed tracks matched to a target in fewer than half of their confirmed scans."""
        return sum(1 for tid, n in self.confirmed_scans.items() if self.matched_scans.get(tid, 0) < 0.5 * n)

    def identity_kept(self, before: slice, after: slice) -> BoolArray:
        """``(K,)`` same majority track id holding each target before and after, and ids distinct across targets."""
        held = np.array(self.held)
        out = np.zeros(self.n_targets, bool)
        ids_after = []
        for k in range(self.n_targets):  # targets: a small set
            b = [i for i in held[before, k] if i >= 0]
            a = [i for i in held[after, k] if i >= 0]
            if b and a:
                ib, ia = Counter(b).most_common(1)[0][0], Counter(a).most_common(1)[0][0]
                out[k] = ib == ia
                ids_after.append(ia)
            else:
                ids_after.append(-1 - k)
        if len(set(ids_after)) < len(ids_after):
            out[:] = False
        return out

    def rmse(self) -> float:
        """Position RMSE [m] over every held (target, scan)."""
        e = np.concatenate(self.errors) if self.errors else np.zeros(0)
        e = e[np.isfinite(e)]
        return float(np.sqrt(np.mean(e**2))) if e.size else float("nan")


def _navigation_errors(errors: FloatArray) -> FloatArray:
    """The finite, flattened navigation errors [m]; ValueError when none is left or one is negative."""
    e = np.asarray(errors, dtype=float).reshape(-1)
    e = e[np.isfinite(e)]
    if e.size == 0:
        raise ValueError("navigation errors: need at least one finite error")
    if (e < 0).any():
        raise ValueError(f"navigation errors: must be >= 0 (got {float(e.min())})")
    return e


def navigation_error_outage(errors: FloatArray, thresholds: FloatArray) -> FloatArray:
    """Seed 002's navigation error outage (eq. 21): P{e > e_th} for each threshold, the NEO curve.

    Args:
        errors: navigation errors e = |p^ - p| [m] over time indices (and runs), any shape; non-finite entries (no
            estimate at that time) are left out.
        thresholds: the target values e_th [m], any shape.

    Returns:
        The fraction of the errors strictly above each threshold, shaped like ``thresholds``.
    """
    e = np.sort(_navigation_errors(errors))
    th = np.asarray(thresholds, dtype=float)
    return (e.size - np.searchsorted(e, th, side="right")) / e.size


def error_at_outage(errors: FloatArray, level: float = 0.2) -> float:
    """The smallest error e_th [m] with NEO(e_th) <= ``level``: the seed's "in 80 % of the cases the error is below".

    With the n finite errors sorted, e_(1) <= ... <= e_(n), it is e_(k), k = ceil(n (1 - level)) (an empirical
    quantile with no interpolation): at most ``level`` n errors exceed it. ``level`` in (0, 1).
    """
    if not 0.0 < level < 1.0:
        raise ValueError(f"level = {level!r}: must be in (0, 1)")
    e = np.sort(_navigation_errors(errors))
    k = max(math.ceil(e.size * (1.0 - level) - 1e-9), 1)
    return float(e[k - 1])
