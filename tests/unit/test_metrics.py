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


@settings(max_examples=300, deadline=None)
@given(
    st.integers(1, 7),
    st.integers(1, 7),
    st.integers(0, 2**32 - 1),
    st.sampled_from(["uniform", "integer", "gated"]),
)
def test_hungarian_matches_scipy(n, k, seed, kind):
    """The compiled Hungarian reaches scipy's optimal total cost on random, tied (integer) and gated (1e12) costs."""
    from scipy.optimize import linear_sum_assignment

    from uwb_env.metrics import _min_cost_matching

    rng = np.random.default_rng(seed)
    cost = {"uniform": rng.uniform(0, 10, (n, k)), "integer": rng.integers(0, 3, (n, k)).astype(float)}.get(kind)
    if cost is None:
        d = rng.uniform(0, 10, (n, k))
        cost = np.where(d <= 4.0, d, 1e12)
    i, j = _min_cost_matching(cost)
    i0, j0 = linear_sum_assignment(cost)
    assert i.size == j.size == min(n, k)
    assert len(set(i.tolist())) == i.size and len(set(j.tolist())) == j.size
    assert np.all(np.diff(i) > 0)  # rows ascending, like scipy
    big, big0 = cost[i, j] >= 1e12, cost[i0, j0] >= 1e12
    assert big.sum() == big0.sum()  # as many pairs outside the gate
    # and the in-gate part optimal too (to the rounding of potentials of order 1e12: ulp(1e12) = 1.2e-4)
    assert math.isclose(
        cost[i, j][~big].sum(), cost[i0, j0][~big0].sum(), rel_tol=1e-12, abs_tol=1e-3 if kind == "gated" else 1e-9
    )


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 6), st.integers(0, 4), st.integers(0, 2**32 - 1))
def test_cover_summary_equals_assign_and_ospa(n, k, seed):
    """The compiled per-scan summary: traces, model probabilities, assignment, errors and OSPA of the numpy code."""
    from uwb_env.metrics import cover_summary

    rng = np.random.default_rng(seed)
    confirmed = rng.uniform(size=n) < 0.7
    x = rng.uniform(-8, 8, (n, 6))
    A = rng.normal(size=(n, 6, 6))
    P = A @ np.swapaxes(A, -1, -2)
    mu = rng.dirichlet(np.ones(3), size=n) if n else np.zeros((0, 3))
    targets = rng.uniform(-8, 8, (k, 2))
    trace, mu_sum, ti, gi, errors, o = cover_summary(confirmed, x, P, mu, targets, 5.0, 10.0, 2.0)
    c = np.flatnonzero(confirmed)
    pos = x[c][:, [0, 2]]
    np.testing.assert_array_equal(trace, P[c, 0, 0] + P[c, 2, 2])
    np.testing.assert_allclose(mu_sum, mu[c].sum(axis=0), rtol=1e-14, atol=1e-15)
    ti0, gi0 = assign(pos, targets, 5.0)
    assert sorted(zip(ti.tolist(), gi.tolist(), strict=True)) == sorted(zip(ti0.tolist(), gi0.tolist(), strict=True))
    np.testing.assert_array_equal(errors, np.linalg.norm(pos[ti] - targets[gi], axis=1))
    assert math.isclose(o, ospa(pos, targets, 10.0), rel_tol=1e-12, abs_tol=1e-12)
