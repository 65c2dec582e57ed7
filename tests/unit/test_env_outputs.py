"""``uwb_env.envs.outputs``: numpy's summation order, and the batched summaries equal to the per-env reference.

The reference is what ``UWBSchedulingEnv`` computed before the summaries were batched: ``metrics.cover_summary``
and ``features.track_features`` on one environment, sums by ``ndarray.sum``. Batched, each environment's numbers
must be the same to the bit (the batched vector env is compared with single envs by equality).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uwb_env.envs.features import track_features
from uwb_env.envs.outputs import observations, one_env, pairwise_sum, rewards_and_infos, scan_summaries
from uwb_env.metrics import cover_summary


@settings(max_examples=300, deadline=None)
@given(n=st.integers(0, 1200), seed=st.integers(0, 2**32 - 1), spread=st.floats(0.0, 12.0))
def test_pairwise_sum_is_numpys_sum_to_the_bit(n: int, seed: int, spread: float) -> None:
    rng = np.random.default_rng(seed)
    a = rng.standard_normal(n) * 10.0 ** rng.uniform(-spread, spread, n)
    assert pairwise_sum(a) == a.sum()


def test_pairwise_sum_differs_from_a_plain_loop() -> None:
    """From 8 terms on numpy's order is not the loop's: the reason for the kernel (a case found by search)."""
    rng = np.random.default_rng(0)
    for _ in range(1000):
        a = rng.random(9) * 10.0 ** rng.uniform(-6, 3, 9)
        loop = 0.0
        for v in a:
            loop += v
        if loop != a.sum():
            assert pairwise_sum(a) == a.sum()
            return
    raise AssertionError("no case where the loop and numpy differ: the test lost its point")


def _random_env(rng: np.random.Generator, r: int = 4) -> tuple[np.ndarray, ...]:
    n = int(rng.integers(0, 14))
    confirmed = rng.random(n) < 0.6
    existence = rng.random(n)
    mu = rng.random((n, r))
    mu /= mu.sum(axis=1, keepdims=True)
    x = rng.normal(0.0, 20.0, (n, 6))
    A = rng.normal(0.0, 1.0, (n, 6, 6))
    P = A @ np.swapaxes(A, 1, 2) + 0.1 * np.eye(6)
    k = int(rng.integers(0, 4))
    targets = x[:k, 0:3:2] + rng.normal(0.0, 3.0, (k, 2)) if k <= n else rng.normal(0.0, 20.0, (k, 2))
    return confirmed, existence, mu, x, P, np.ascontiguousarray(targets)


def test_batched_summaries_equal_the_per_env_reference() -> None:
    rng = np.random.default_rng(7)
    envs = [_random_env(rng) for _ in range(40)]
    gate, n_slots, n_targets, centre, half, v_max = 5.0, 8, 3, np.array([1.0, -2.0]), np.array([60.0, 40.0]), 20.0
    cat = [np.concatenate([e[i] for e in envs]) for i in range(5)]
    track_start = np.concatenate([[0], np.cumsum([e[0].size for e in envs])])
    target_start = np.concatenate([[0], np.cumsum([e[5].shape[0] for e in envs])])
    targets = np.concatenate([e[5] for e in envs])
    summ = scan_summaries(track_start, *cat, target_start, targets, gate, 2 * gate, centre, half, v_max, n_slots, 3)
    energy = rng.random(len(envs))
    scan = np.arange(len(envs))
    reward, info = rewards_and_infos(summ, scan, energy, 100.0, 0.5)
    for e, (confirmed, existence, mu, x, P, tg) in enumerate(envs):
        trace, mu_sum, ti, gi, errors, ospa_m = cover_summary(confirmed, x, P, mu, tg, gate, 2 * gate, 2.0)
        n_conf = trace.size
        mean_trace = float(trace.sum()) / n_conf if n_conf else 0.0  # the env's formulas before batching
        missed = tg.shape[0] - gi.size
        assert reward[e] == -mean_trace - 100.0 * missed - 0.5 * float(energy[e])
        got = one_env(info, e)
        padded = np.zeros(n_targets)
        padded[: errors.size] = errors
        assert got["covariance_trace"] == mean_trace and got["missed_targets"] == missed
        assert got["target_covariance_trace"] == (float(trace[ti].sum()) / ti.size if ti.size else 0.0)
        assert np.array_equal(got["position_errors_m"], padded) and got["position_errors_count"] == errors.size
        assert got["ospa_m"] == float(ospa_m) and got["confirmed_tracks"] == n_conf
        assert got["false_tracks"] == n_conf - ti.size and got["scan_index"] == e
        assert np.array_equal(got["model_probabilities"], mu_sum / n_conf if n_conf else mu_sum)
        assert type(got["missed_targets"]) is int and type(got["covariance_trace"]) is float
        feats = track_features(existence, confirmed, mu, x, P, centre, half, v_max, n_slots)
        assert np.array_equal(summ[-1][e], feats)


def test_observations_layout_and_bound() -> None:
    feats = np.zeros((2, 3, 14))
    feats[1, 0, 3] = 0.5
    obs = observations(feats, np.array([-1, 2]), 4, {"ready_receivers": np.array([[1.0, 0.0], [0.0, 1.0]])}, "box",
                       10.0, np.array([1, 1]))  # fmt: skip
    assert obs.dtype == np.float32 and obs.shape == (2, 3 * 14 + 4 + 2)
    assert obs[0, 42:46].tolist() == [0, 0, 0, 0] and obs[1, 42:46].tolist() == [0, 0, 1, 0]
    assert obs[1, 3] == 0.5 and obs[1, -2:].tolist() == [0.0, 1.0]
    parts = observations(feats, np.array([-1, 2]), 4, {}, "dict", 10.0, np.array([1, 1]))
    assert list(parts) == ["tracks", "previous_action"] and parts["tracks"].shape == (2, 3, 14)
    feats[1, 2, 5] = np.nan
    with pytest.raises(FloatingPointError, match=r"\['tracks'\].*scan 9"):
        observations(feats, np.array([0, 0]), 4, {}, "box", 10.0, np.array([3, 9]))
