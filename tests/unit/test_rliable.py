"""rliable's aggregates on numpy / scipy (Agarwal et al., NeurIPS 2021): closed forms, hand counts, properties."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy import stats

from uwb_env.agents import rliable

finite = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)


def test_iqm_of_one_to_eight_is_the_mean_of_three_to_six():
    assert rliable.iqm(np.arange(1, 9)) == pytest.approx(4.5)  # int(0.25 * 8) = 2 cut at each end
    assert rliable.iqm(np.arange(1, 9).reshape(4, 2)) == pytest.approx(4.5)  # runs x tasks pooled


@pytest.mark.parametrize("n", [5, 6, 7, 9, 10, 11])
def test_iqm_cuts_int_quarter_n_at_each_end_as_scipy(n):
    x = np.random.default_rng(n).normal(size=n) ** 3
    cut = int(0.25 * n)  # 5 -> 1, 7 -> 1, 9 -> 2, 10 -> 2, 11 -> 2
    assert rliable.iqm(x) == pytest.approx(np.sort(x)[cut : n - cut].mean(), rel=1e-12)
    assert rliable.iqm(x) == pytest.approx(stats.trim_mean(x, 0.25), rel=1e-12)


def test_iqm_per_task_and_the_other_aggregates():
    x = np.array([[1.0, 10.0], [2.0, 20.0], [3.0, 30.0], [100.0, 40.0]])  # 4 runs, 2 tasks
    np.testing.assert_allclose(rliable.iqm_per_task(x), [2.5, 25.0])  # middle two runs of each task
    assert rliable.mean(x) == pytest.approx(206 / 8)
    assert rliable.median(x) == pytest.approx((10 + 20) / 2)  # pooled sorted: 1 2 3 10 | 20 30 40 100
    assert rliable.optimality_gap(np.array([0.5, 1.5, 0.8])) == pytest.approx((0.5 + 0 + 0.2) / 3)


def test_probability_of_improvement_by_hand_with_ties():
    x = np.array([1.0, 2.0, 3.0])
    y = np.array([2.0, 2.0])
    # pairs (x, y): 1<2, 1<2 -> 0; 2=2 twice -> 1/2 each; 3>2 twice -> 1 each: (0 + 1 + 2) / 6
    assert rliable.probability_of_improvement(x, y) == pytest.approx(0.5)
    # two tasks averaged: task 0 as above (0.5); task 1: x = 5, 6, 7 vs y = 6, 0: (1 + 1/2 + 1 + 1 + 1 + 0) / 6
    x2 = np.array([[1.0, 5.0], [2.0, 6.0], [3.0, 7.0]])
    y2 = np.array([[2.0, 6.0], [2.0, 0.0]])
    assert rliable.probability_of_improvement(x2, y2) == pytest.approx((0.5 + 4.5 / 6) / 2)
    # equal to Mann-Whitney's U / (n m) per task
    u = stats.mannwhitneyu(x2[:, 1], y2[:, 1]).statistic
    assert u / 6 == pytest.approx(4.5 / 6)


@settings(max_examples=60, deadline=None)
@given(
    arrays(float, st.tuples(st.integers(1, 6), st.integers(1, 4)), elements=st.integers(-3, 3).map(float)),
    st.integers(1, 6),
    st.integers(0, 2**31),
)
def test_improvement_of_x_over_y_plus_y_over_x_is_one(x, m, seed):
    """Small integers, so that ties happen: P(X > Y) + P(Y > X) = 1 with ties counted 1/2 both ways."""
    y = np.random.default_rng(seed).integers(-3, 4, size=(m, x.shape[1])).astype(float)
    total = rliable.probability_of_improvement(x, y) + rliable.probability_of_improvement(y, x)
    assert total == pytest.approx(1.0, abs=1e-12)


@settings(max_examples=80, deadline=None)
@given(arrays(float, st.tuples(st.integers(1, 8), st.integers(1, 5)), elements=finite), st.integers(0, 2**31))
def test_iqm_is_permutation_invariant_and_between_min_and_max(x, seed):
    rng = np.random.default_rng(seed)
    shuffled = rng.permutation(x.ravel()).reshape(x.shape)
    value = rliable.iqm(x)
    assert value == pytest.approx(rliable.iqm(shuffled), rel=1e-12, abs=1e-9)
    assert x.min() - 1e-9 <= value <= x.max() + 1e-9


def test_percentile_interval_of_the_mean_covers_the_true_mean_95_percent_of_the_time():
    """400 samples of 30 N(0, 1) values (a task with 30 runs): the 95 % interval of the mean covers 0.

    The percentile bootstrap of a mean undercovers at small n by O(1/n) (Hall 1992): at n = 30 its coverage is
    ~0.94 (measured here: 0.935). Binomial SE over 400 repetitions sqrt(0.95 x 0.05 / 400) = 0.011: accept 0.91-0.98.
    """
    rng = np.random.default_rng(2021)
    covered = 0
    for _ in range(400):
        sample = rng.normal(size=30)
        est = rliable.stratified_bootstrap_ci(sample, rliable.mean, 1000, 0.95, rng)
        covered += est.low <= 0.0 <= est.high
    assert 0.91 <= covered / 400 <= 0.98


def test_bootstrap_replicates_resample_runs_within_each_task():
    """Two tasks whose runs take disjoint values: every replicate's column t holds only task t's values."""
    x = np.array([[0.0, 10.0], [1.0, 11.0], [2.0, 12.0]])
    samples = rliable.stratified_resample(x, 500, np.random.default_rng(0))
    assert samples.shape == (500, 3, 2)
    assert set(np.unique(samples[..., 0])) == {0.0, 1.0, 2.0}
    assert set(np.unique(samples[..., 1])) == {10.0, 11.0, 12.0}
    # the run indices are drawn independently per task: the columns' indices differ in most replicates
    assert np.mean(samples[..., 1] - 10.0 != samples[..., 0]) > 0.5


def test_bootstrap_of_a_constant_is_the_constant_and_the_interval_is_percentiles():
    est = rliable.stratified_bootstrap_ci(np.full((4, 3), 2.5), rliable.iqm, 200, 0.9, 0)
    assert (est.point, est.low, est.high) == (2.5, 2.5, 2.5)
    # by hand: the replicates are the statistic of stratified resamples drawn from the same generator
    x = np.array([[0.0], [1.0], [4.0]])
    est = rliable.stratified_bootstrap_ci(x, rliable.mean, 300, 0.8, np.random.default_rng(7))
    boot = rliable.stratified_resample(x, 300, np.random.default_rng(7)).mean(axis=(1, 2))
    assert est.low == pytest.approx(np.percentile(boot, 10)) and est.high == pytest.approx(np.percentile(boot, 90))
    assert est.point == pytest.approx(5 / 3)


def test_bootstrap_is_deterministic_for_a_seed_and_takes_dicts_tuples_and_vector_statistics():
    x = np.random.default_rng(1).normal(size=(5, 4))
    a = rliable.stratified_bootstrap_ci(x, rliable.iqm, 500, 0.95, 3)
    b = rliable.stratified_bootstrap_ci(x, rliable.iqm, 500, 0.95, np.random.default_rng(3))
    assert (a.point, a.low, a.high) == (b.point, b.low, b.high)
    c = rliable.stratified_bootstrap_ci(x, rliable.iqm, 500, 0.95, 4)
    assert (a.low, a.high) != (c.low, c.high)
    both = rliable.stratified_bootstrap_ci({"a": x, "b": x + 1.0}, rliable.mean, 500, 0.95, 3)
    assert both["a"].point == pytest.approx(x.mean()) and both["b"].point == pytest.approx(x.mean() + 1.0)
    per_task = rliable.stratified_bootstrap_ci(x, rliable.iqm_per_task, 500, 0.95, 3)
    assert per_task.point.shape == (4,) and np.all(per_task.low <= per_task.point)
    assert np.all(per_task.point <= per_task.high)
    poi = rliable.probability_of_improvement_ci(x + 10.0, x, 500, 0.95, 3)
    assert (poi.point, poi.low, poi.high) == (1.0, 1.0, 1.0)  # every run of x + 10 beats every run of x


def test_improvement_interval_of_two_equal_distributions_straddles_one_half():
    rng = np.random.default_rng(5)
    x, y = rng.normal(size=(10, 3)), rng.normal(size=(8, 3))
    est = rliable.probability_of_improvement_ci(x, y, 2000, 0.95, 11)
    assert est.low < 0.5 < est.high and 0.0 <= est.low and est.high <= 1.0


def test_performance_profile_by_hand():
    x = np.array([[0.1, 1.0], [0.5, 2.0], [0.9, 3.0]])
    # tau = 0.5: task 0 has 1 of 3 runs above, task 1 has 3 of 3 -> (1/3 + 1) / 2; tau = 2.5: (0 + 1/3) / 2
    np.testing.assert_allclose(rliable.performance_profile(x, [0.5, 2.5]), [(1 / 3 + 1) / 2, (1 / 3) / 2])


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: rliable.iqm(np.array([])), r"shape \(0, 1\) is empty"),
        (lambda: rliable.iqm(np.zeros((0, 3))), "is empty"),
        (lambda: rliable.iqm([1.0, math.nan]), "score nan at run 1, task 0 is not finite"),
        (lambda: rliable.as_scores(np.zeros((2, 2, 2))), r"shape \(2, 2, 2\) must be \(runs,\) or \(runs, tasks\)"),
        (lambda: rliable.as_scores(["a", "b"]), "is not an array of numbers"),
        (lambda: rliable.probability_of_improvement(np.zeros((3, 2)), np.zeros((3, 3))), "x has 2 tasks, y 3"),
        (lambda: rliable.probability_of_improvement_ci(np.zeros((3, 2)), np.zeros((3, 1)), 10, 0.9, 0), "2 tasks"),
        (
            lambda: rliable.stratified_bootstrap_ci((np.zeros((3, 2)), np.zeros((3, 1))), rliable.mean, 10, 0.9, 0),
            "tasks differ",
        ),
        (lambda: rliable.stratified_bootstrap_ci(np.ones(3), rliable.mean, 10, 1.0, 0), "confidence=1.0"),
        (
            lambda: rliable.stratified_bootstrap_ci(np.ones(3), rliable.mean, 10, 0.0, 0),
            r"must be a number in \(0, 1\)",
        ),
        (lambda: rliable.stratified_bootstrap_ci(np.ones(3), rliable.mean, 0, 0.9, 0), "reps=0"),
        (lambda: rliable.stratified_bootstrap_ci(np.ones(3), rliable.mean, 10, 0.9, None), "rng=None"),
        (lambda: rliable.stratified_bootstrap_ci({}, rliable.mean, 10, 0.9, 0), "an empty mapping"),
        (lambda: rliable.stratified_bootstrap_ci({"a": [np.inf]}, rliable.mean, 10, 0.9, 0), r"scores\['a'\]"),
        (lambda: rliable.performance_profile(np.ones((2, 2)), []), "taus"),
    ],
)
def test_bad_input_raises_naming_the_field(call, message):
    with pytest.raises(ValueError, match=message):
        call()
