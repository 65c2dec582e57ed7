"""The range-only 3-tuple initiation's exact speed-ups (``uwb_env.tracking.initiation``).

``gauss_newton_exact`` stops a start at an exact fixed point or 2-cycle: its results equal the fixed-iteration
``localization.compiled._gauss_newton`` to the bit. ``_residual_lower_bound`` rejects tuples before the fit: it
never rejects a tuple that the fit keeps. Together ``_range_only_candidates`` returns what the numpy reference
``range_only_candidates`` (every tuple through ``ellipse_intersection``) returns, bit for bit.
"""

from __future__ import annotations

import itertools

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import chi2

from uwb_env.localization.compiled import _gauss_newton, ellipse_intersection
from uwb_env.tracking.initiation import (
    _GATE_MARGIN,
    _gate_constants,
    _range_only_candidates,
    _residual_lower_bound,
    gauss_newton_exact,
    range_only_candidates,
)

# UrbanDistributed-v0's layout: two nodes, each a transmitter with two receivers, about 250 m apart
TX = np.array([[2085.0, 1470.5], [2040.0, 1715.0]])
RX = np.array([[2088.0, 1475.0], [2078.0, 1467.0], [2037.0, 1710.5], [2047.0, 1718.5]])
GTX, GRX = TX[[0, 0, 1, 1]], RX
AREA = np.array([1900.0, 2200.0, 1300.0, 1750.0])
STARTS = np.array([[2050.0, 1525.0], [1975.0, 1412.5], [2125.0, 1412.5], [1975.0, 1637.5], [2125.0, 1637.5]])
RESIDUAL_MAX = float(chi2.ppf(0.99, 1))


def _h(p: np.ndarray, tx: np.ndarray, rx: np.ndarray) -> np.ndarray:
    """Bistatic ranges ``(..., G)`` of points ``(..., 2)`` for the groups' nodes ``(G, 2)``."""
    p = np.asarray(p)[..., None, :]
    return np.linalg.norm(p - tx, axis=-1) + np.linalg.norm(p - rx, axis=-1)


def _scan(rng: np.random.Generator, n_targets: int, n_clutter: int, std: float) -> tuple[np.ndarray, ...]:
    """One scan's ranges per group ``(G, n)`` (targets then clutter) and variances, like the env's (5 per group)."""
    targets = rng.uniform([1950.0, 1350.0], [2150.0, 1700.0], (n_targets, 2))
    r = _h(targets, GTX, GRX).T + rng.normal(0.0, std, (4, n_targets))
    points = rng.uniform(AREA[[0, 2]], AREA[[1, 3]], (4, n_clutter, 2))  # each group's own false alarms
    clutter = np.linalg.norm(points - GTX[:, None], axis=-1) + np.linalg.norm(points - GRX[:, None], axis=-1)
    rs = np.concatenate([r, clutter], axis=1)
    return rs, np.full(rs.shape, std**2)


def _reference(rs: np.ndarray, vs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    groups = [(rs[g], vs[g], GTX[g], GRX[g]) for g in range(4)]
    return range_only_candidates(groups, 3, AREA, STARTS)


def test_gauss_newton_exact_equals_fixed_iterations() -> None:
    """Every start of 300 tuples (targets and clutter, 2 and 3 ranges), n_iter 0-40: the same bits."""
    rng = np.random.default_rng(11)
    rs, vs = _scan(rng, 2, 3, 0.3)
    iterations = []
    for a, b, c in [(0, 1, 2), (0, 2, 3), (1, 2, 3), (0, 1, -1), (1, 2, -1)]:
        members = [a, b] if c < 0 else [a, b, c]
        for idx in itertools.product(range(5), repeat=len(members)):
            r = np.array([rs[g, i] for g, i in zip(members, idx, strict=True)])
            w = 1.0 / np.array([vs[g, i] for g, i in zip(members, idx, strict=True)])
            tx, rx = GTX[members].copy(), GRX[members].copy()
            for s, n_iter in itertools.product(range(5), (0, 1, 2, 15, 40)):
                ref = _gauss_newton(r, w, tx, rx, STARTS[s], n_iter)
                got = gauss_newton_exact(r, w, tx, rx, STARTS[s, 0], STARTS[s, 1], n_iter)
                assert np.array(got[:6]).tobytes() == np.array(ref).tobytes(), (members, idx, s, n_iter)
                if n_iter == 15:
                    iterations.append(got[6])
    assert len(iterations) == 5 * (3 * 125 + 2 * 25)
    assert np.mean(iterations) < 15.0  # stopped early somewhere (the saving), never beyond n_iter
    assert max(iterations) <= 15


def test_gauss_newton_exact_nan_runs_every_iteration() -> None:
    """A NaN range: no early stop (NaN equals nothing), the fixed-iteration result (NaN) to the bit."""
    r, w = np.array([300.0, np.nan, 310.0]), np.ones(3)
    tx, rx = GTX[[0, 1, 2]].copy(), GRX[[0, 1, 2]].copy()
    got = gauss_newton_exact(r, w, tx, rx, STARTS[0, 0], STARTS[0, 1], 15)
    ref = _gauss_newton(r, w, tx, rx, STARTS[0], 15)
    assert got[6] == 15 and np.array(got[:6]).tobytes() == np.array(ref).tobytes()


def test_constructed_fixes_land_on_the_truth() -> None:
    """Exact ranges of hand-placed targets: every 3-tuple's fix within 1e-6 m of the truth, the reference's bits."""
    truths = np.array([[2000.0, 1600.0], [2100.0, 1400.0], [1960.0, 1500.0], [2150.0, 1700.0]])
    for p in truths:
        rs = _h(p, GTX, GRX)[:, None]  # (4 groups, 1 detection): exact bistatic ranges
        vs = np.full((4, 1), 0.09)
        pos, cov = _range_only_candidates(rs, vs, np.ones(4, np.int64), GTX, GRX, 3, AREA, STARTS, RESIDUAL_MAX)
        assert pos.shape == (4, 2)  # C(4, 3) receiver subsets, every one kept
        assert np.max(np.linalg.norm(pos - p, axis=1)) < 1e-6
        assert np.all(np.linalg.eigvalsh(cov) > 0.0)
        p_ref, c_ref = _reference(rs, vs)
        assert pos.tobytes() == p_ref.tobytes() and cov.tobytes() == c_ref.tobytes()


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_targets=st.integers(0, 3), std=st.sampled_from([0.05, 0.3, 1.0]))
def test_candidates_equal_reference_on_two_nodes(seed: int, n_targets: int, std: float) -> None:
    """Scans of targets and clutter on the two-node layout: the gated, early-stopped candidates are the reference's."""
    rs, vs = _scan(np.random.default_rng(seed), n_targets, 5 - n_targets, std)
    pos, cov = _range_only_candidates(rs, vs, np.full(4, 5, np.int64), GTX, GRX, 3, AREA, STARTS, RESIDUAL_MAX)
    p_ref, c_ref = _reference(rs, vs)
    assert pos.tobytes() == p_ref.tobytes() and cov.tobytes() == c_ref.tobytes()


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    offsets=st.lists(st.floats(-20.0, 20.0), min_size=3, max_size=3),
    scale=st.sampled_from([0.0, 0.01, 0.1, 1.0]),
    log_var=st.floats(-4.0, 2.0),
)
def test_gate_never_rejects_a_kept_tuple(seed: int, offsets: list[float], scale: float, log_var: float) -> None:
    """Property: a tuple the full fit keeps (inside the area, cost <= bound) passes the gate; over random layouts.

    Ranges are a random point's plus offsets of up to 20 m times 0-1, so tuples on both sides of the bound are drawn;
    the bound is also checked against the cost at the fit (a lower bound of the minimum is below any point's cost).
    """
    rng = np.random.default_rng(seed)
    tx, rx = rng.uniform(AREA[[0, 2]], AREA[[1, 3]], (3, 2)), rng.uniform(AREA[[0, 2]], AREA[[1, 3]], (3, 2))
    tx[1] = tx[0]  # two receivers of one transmitter, as in a node
    p = rng.uniform(AREA[[0, 2]], AREA[[1, 3]])
    r = _h(p, tx, rx) + scale * np.array(offsets)
    v = np.full(3, 10.0**log_var) * rng.uniform(0.5, 2.0, 3)
    focal, near, far = _gate_constants(tx, rx, AREA)
    bound = _residual_lower_bound(r, v, np.arange(3), focal, near, far)
    pos, _, cost = ellipse_intersection(r[None], v[None], tx[None], rx[None], STARTS)
    inside = AREA[0] <= pos[0, 0] <= AREA[1] and AREA[2] <= pos[0, 1] <= AREA[3]
    if inside:
        assert bound <= cost[0] * (1.0 + _GATE_MARGIN) + 1e-12
    if inside and cost[0] <= RESIDUAL_MAX:
        assert bound <= RESIDUAL_MAX * (1.0 + _GATE_MARGIN)


def test_gate_bounds_hand_computed() -> None:
    """The bound's terms on hand-built numbers: a node's two receivers 10 m apart, a third receiver far away."""
    tx = np.array([[0.0, 0.0], [0.0, 0.0], [300.0, 0.0]])
    rx = np.array([[5.0, 0.0], [-5.0, 0.0], [300.0, 10.0]])
    area = np.array([-100.0, 100.0, -100.0, 100.0])
    focal, near, far = _gate_constants(tx, rx, area)
    assert focal[0, 1] == 10.0  # same transmitter: |rx_0 - rx_1|
    assert near.tolist() == [5.0, 5.0, 10.0]
    corner = np.hypot(100.0, 100.0) + np.hypot(105.0, 100.0)  # (-100, +-100) from tx (0, 0) and rx (5, 0)
    assert np.isclose(far[0], corner, rtol=0, atol=1e-12)
    # ranges 100 and 130 m with variances 1 and 3: |r_0 - r_1| - 10 = 20 m, bound 20^2 / (1 + 3) = 100
    v = np.array([1.0, 3.0, 2.0])
    third = 0.5 * (near[2] + far[2])  # inside [near, far]: no single term
    assert _residual_lower_bound(np.array([100.0, 130.0, third]), v, np.arange(3), focal, near, far) == 100.0
    # a range 4 m short of its baseline alone: (5 - 1)^2 / 1 = 16
    assert _residual_lower_bound(np.array([1.0, 12.0, third]), v, np.arange(3), focal, near, far) == 16.0
    # consistent ranges of a point in the area: no bound
    r = _h(np.array([20.0, 30.0]), tx, rx)
    assert _residual_lower_bound(r, v, np.arange(3), focal, near, far) == 0.0
