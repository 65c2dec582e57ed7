"""Per-scan metrics: the assignment and OSPA against hand-computed values and a brute-force search."""

from __future__ import annotations

import itertools
import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from uwb_env.metrics import assign, distances, ospa


def test_ospa_by_hand():
    """Two tracks, one target: the matched pair at 3 m and one unmatched track at the cut-off c = 10 m.

    OSPA_2 = ((3^2 + 10^2) / 2)^(1/2) = sqrt(54.5).
    """
    tracks = np.array([[0.0, 0.0], [50.0, 50.0]])
    targets = np.array([[3.0, 0.0]])
    assert ospa(tracks, targets, cutoff_m=10.0) == math.sqrt(54.5)
    assert ospa(targets, tracks, cutoff_m=10.0) == math.sqrt(54.5)  # symmetric
    assert ospa(tracks[:0], targets[:0], cutoff_m=10.0) == 0.0
    assert ospa(tracks, targets[:0], cutoff_m=10.0) == 10.0
    # order 1: (3 + 10) / 2
    assert ospa(tracks, targets, cutoff_m=10.0, order=1.0) == 6.5


def test_assign_respects_the_gate_and_prefers_the_global_optimum():
    """Greedy would give target 0 to track 0 (1 m) and leave track 1 (3.5 m from target 0) out of target 1's gate;
    the optimum (total 2 + 3.5) matches both."""
    tracks = np.array([[1.0, 0.0], [-3.5, 0.0]])
    targets = np.array([[0.0, 0.0], [3.0, 0.0]])
    ti, gi = assign(tracks, targets, gate_m=4.0)
    assert sorted(zip(ti.tolist(), gi.tolist(), strict=True)) == [(0, 1), (1, 0)]
    ti, gi = assign(tracks, targets, gate_m=1.5)  # only (track 0, target 0) is inside
    assert ti.tolist() == [0] and gi.tolist() == [0]
    ti, gi = assign(tracks[:1], targets, gate_m=0.5)  # the single-row shortcut: nothing inside
    assert ti.size == gi.size == 0


def _brute_ospa(a, b, c, p):
    m, n = len(a), len(b)
    if m > n:
        a, b, m, n = b, a, n, m
    d = np.minimum(distances(a, b), c) ** p
    best = min(sum(d[i, j] for i, j in enumerate(perm)) for perm in itertools.permutations(range(n), m))
    return ((best + c**p * (n - m)) / n) ** (1 / p)


points = st.lists(
    st.tuples(st.floats(-20, 20, allow_nan=False), st.floats(-20, 20, allow_nan=False)), min_size=1, max_size=4
)


@settings(max_examples=150, deadline=None)
@given(points, points, st.sampled_from([1.0, 2.0]))
def test_ospa_equals_the_brute_force_minimum(a, b, p):
    """Hungarian (or the single-row shortcut) OSPA equals the minimum over every injection, to rounding."""
    a, b = np.array(a), np.array(b)
    assert math.isclose(ospa(a, b, 10.0, p), _brute_ospa(a, b, 10.0, p), rel_tol=1e-12, abs_tol=1e-12)


@settings(max_examples=150, deadline=None)
@given(points, points)
def test_assign_is_a_gated_minimum_cost_matching(a, b):
    """Every match is inside the gate, no index repeats, and no gated matching has more pairs (max cardinality)."""
    a, b = np.array(a), np.array(b)
    gate = 8.0
    ti, gi = assign(a, b, gate)
    d = distances(a, b)
    assert np.all(d[ti, gi] <= gate)
    assert len(set(ti.tolist())) == ti.size and len(set(gi.tolist())) == gi.size
    m, n = d.shape
    most = max(
        sum(d[i, j] <= gate for i, j in zip(rows, perm, strict=True))
        for rows in itertools.permutations(range(m), min(m, n))
        for perm in itertools.permutations(range(n), min(m, n))
    )
    assert ti.size == most
