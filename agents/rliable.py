r"""Aggregate RL results across runs the rliable way, on numpy / scipy (no dependency on the archived package).

After R. Agarwal, M. Schwarzer, P. S. Castro, A. Courville and M. G. Bellemare, "Deep reinforcement learning at the
edge of the statistical precipice", NeurIPS 2021 (the ``rliable`` library, google-research/rliable, archived).

Scores are an array of shape ``(runs, tasks)``: ``scores[r, t]`` is run ``r``'s score on task ``t`` (in the paper a
run is one training seed, a task one game, the score the run's mean evaluation return on it, normalised). A 1-D
array is one task, ``(runs,) -> (runs, 1)``.

* :func:`iqm` (interquartile mean): the 25 % trimmed mean of the runs x tasks scores pooled,
  ``scipy.stats.trim_mean(scores, 0.25, axis=None)`` as rliable's ``aggregate_iqm``: ``int(0.25 n)`` scores are cut
  from each end of the ``n = runs x tasks`` sorted scores and the rest averaged. :func:`mean`, :func:`median` and
  :func:`optimality_gap` are rliable's other aggregates; :func:`iqm_per_task` is the IQM over runs task by task
  (a learning curve's columns).
* :func:`stratified_bootstrap_ci`: percentile intervals of any such statistic from rliable's ``StratifiedBootstrap``:
  each replicate draws, for every task independently, ``runs`` run indices with replacement (the tasks are strata;
  the runs are the random unit). All replicates' indices are drawn at once and the statistic is evaluated on the
  ``(reps, runs, tasks)`` stack, so a statistic takes arrays with leading batch axes.
* :func:`probability_of_improvement`: ``P(X > Y)`` averaged over tasks, where on task ``t``
  ``P(X_t > Y_t) = 1/(n m) sum_ij [S(x_it, y_jt)]`` with ``S = 1`` if ``x > y``, ``1/2`` if equal, ``0`` otherwise:
  the Mann-Whitney U statistic over ``n m`` (paper, section 4.3 / rliable's ``probability_of_improvement``). So
  ``P(X > Y) + P(Y > X) = 1``. Its interval comes from :func:`stratified_bootstrap_ci` with the two score arrays
  resampled independently (each within tasks: they are different sets of runs).
* :func:`performance_profile`: the run-score distribution ``F(tau) = 1/T sum_t 1/n sum_r [x_rt > tau]``.

Differences from rliable, on purpose: a generator (or an int seed) is required, never the global RNG; NaN or
infinite scores raise instead of propagating; with several arrays in one bootstrap (probability of improvement) each
is resampled with its own indices, where rliable's arch-based bootstrap reuses one index array for arrays of the
same shape.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
from scipy import stats

TRIM = 0.25  # the interquartile mean's cut at each end
MAX_BATCH_ELEMENTS = 20_000_000  # resampled scores evaluated per batch of replicates (memory bound, not results)

Scores = np.ndarray | tuple[np.ndarray, ...]


@dataclass(frozen=True)
class Estimate:
    """A point estimate and its percentile bootstrap interval (floats, or arrays for a vector statistic)."""

    point: float | np.ndarray
    low: float | np.ndarray
    high: float | np.ndarray
    confidence: float
    reps: int


def as_scores(scores: object, name: str = "scores") -> np.ndarray:
    """``scores`` as a float array ``(runs, tasks)`` (a 1-D array is one task); ``ValueError`` naming ``name``.

    Refused: not numeric, more than 2 dimensions, no run or no task, a NaN or infinite score.
    """
    try:
        x = np.asarray(scores, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: {scores!r} is not an array of numbers (must be (runs, tasks))") from None
    if x.ndim == 1:
        x = x[:, None]
    if x.ndim != 2:
        raise ValueError(f"{name}: shape {x.shape} must be (runs,) or (runs, tasks)")
    if x.shape[0] == 0 or x.shape[1] == 0:
        raise ValueError(f"{name}: shape {x.shape} is empty (must have at least one run and one task)")
    bad = ~np.isfinite(x)
    if bad.any():
        r, t = np.argwhere(bad)[0]
        raise ValueError(
            f"{name}: score {x[r, t]} at run {r}, task {t} is not finite (every score must be a finite number)"
        )
    return x


def _pooled(x: np.ndarray) -> np.ndarray:
    """``(..., runs, tasks) -> (..., runs * tasks)``."""
    return x.reshape(*x.shape[:-2], -1)


def _stack(scores: np.ndarray) -> np.ndarray:
    """A statistic's input: a checked ``(runs, tasks)`` array, or an already batched ``(..., runs, tasks)`` one."""
    x = np.asarray(scores, dtype=float)
    return as_scores(x) if x.ndim < 3 else x


def iqm(scores: np.ndarray) -> float | np.ndarray:
    """Interquartile mean of the pooled runs x tasks scores: ``trim_mean(scores, 0.25)`` (rliable's ``aggregate_iqm``).

    ``scores``: ``(runs, tasks)`` (or ``(runs,)``), or ``(..., runs, tasks)`` for a batch -> a float, or ``(...)``.
    """
    return stats.trim_mean(_pooled(_stack(scores)), TRIM, axis=-1)[()]


def iqm_per_task(scores: np.ndarray) -> np.ndarray:
    """IQM over the runs of each task: ``(..., runs, tasks) -> (..., tasks)`` (e.g. a learning curve's columns)."""
    return stats.trim_mean(_stack(scores), TRIM, axis=-2)


def mean(scores: np.ndarray) -> float | np.ndarray:
    """Mean of the pooled runs x tasks scores (rliable's ``aggregate_mean``)."""
    return _pooled(_stack(scores)).mean(axis=-1)[()]


def median(scores: np.ndarray) -> float | np.ndarray:
    """Median of the pooled runs x tasks scores (rliable's ``aggregate_median``)."""
    return np.median(_pooled(_stack(scores)), axis=-1)[()]


def optimality_gap(scores: np.ndarray, gamma: float = 1.0) -> float | np.ndarray:
    """``mean(gamma - min(score, gamma))``: how far the pooled scores fall short of ``gamma`` (rliable's)."""
    return (gamma - np.minimum(_pooled(_stack(scores)), gamma)).mean(axis=-1)[()]


def _pairwise_improvement(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``(..., n, T)``, ``(..., m, T)`` -> ``(...)``: mean over tasks of the Mann-Whitney ``U / (n m)``."""
    diff = x[..., :, None, :] - y[..., None, :, :]  # (..., n, m, T)
    per_task = ((diff > 0) + 0.5 * (diff == 0)).mean(axis=(-3, -2))
    return per_task.mean(axis=-1)


def probability_of_improvement(x: np.ndarray, y: np.ndarray) -> float | np.ndarray:
    """``P(X > Y)``: over tasks, the mean of ``P(x_t > y_t) + P(x_t = y_t) / 2`` over all run pairs.

    ``x``: ``(n, tasks)``, ``y``: ``(m, tasks)`` (or batches ``(..., n, tasks)``, ``(..., m, tasks)``); ``n`` and
    ``m`` may differ, the tasks must match. Higher scores are better: for a cost, pass ``-x, -y``.
    Agarwal et al. (2021), section 4.3: the Mann-Whitney U statistic over ``n m``, averaged over tasks.
    """
    x, y = _stack(x), _stack(y)
    if x.shape[-1] != y.shape[-1]:
        raise ValueError(f"probability_of_improvement: x has {x.shape[-1]} tasks, y {y.shape[-1]} (must be equal)")
    return _pairwise_improvement(x, y)[()]


def performance_profile(scores: np.ndarray, taus: np.ndarray) -> np.ndarray:
    """Run-score distribution: ``F(tau) = mean over tasks of the fraction of runs scoring above tau``.

    ``scores``: ``(..., runs, tasks)``; ``taus``: ``(K,)`` thresholds -> ``(..., K)`` (rliable's
    ``run_score_deviation`` profile, Agarwal et al. 2021, section 4.2).
    """
    x = _stack(scores)
    tau = np.asarray(taus, dtype=float).reshape(-1)
    if tau.size == 0 or not np.all(np.isfinite(tau)):
        raise ValueError(f"taus={taus!r}: must be one or more finite thresholds")
    return (x[..., None] > tau).mean(axis=(-3, -2))


def _check_confidence(confidence: object) -> float:
    if isinstance(confidence, bool) or not isinstance(confidence, int | float) or not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence={confidence!r}: must be a number in (0, 1), e.g. 0.95")
    return float(confidence)


def _check_reps(reps: object) -> int:
    if isinstance(reps, bool) or not isinstance(reps, int | np.integer) or reps < 1:
        raise ValueError(f"reps={reps!r}: must be an integer >= 1 (bootstrap replicates, e.g. 2000)")
    return int(reps)


def _generator(rng: object) -> np.random.Generator:
    if isinstance(rng, np.random.Generator):
        return rng
    if isinstance(rng, int | np.integer) and not isinstance(rng, bool) and rng >= 0:
        return np.random.default_rng(int(rng))
    raise ValueError(f"rng={rng!r}: must be a numpy.random.Generator or a seed (an integer >= 0)")


def stratified_resample(x: np.ndarray, reps: int, rng: np.random.Generator) -> np.ndarray:
    """``reps`` stratified bootstrap samples of ``x`` ``(runs, tasks)``: ``(reps, runs, tasks)``.

    Sample ``b``'s entry ``(r, t)`` is ``x[i_brt, t]`` with ``i_brt`` uniform on ``0 .. runs - 1``, all independent:
    the runs are resampled with replacement within each task (rliable's ``StratifiedBootstrap``).
    """
    runs, tasks = x.shape
    idx = rng.integers(0, runs, size=(reps, runs, tasks))
    return x[idx, np.arange(tasks)]


def _bootstrap_one(
    arrays: tuple[np.ndarray, ...],
    statistic: Callable[..., object],
    reps: int,
    confidence: float,
    rng: np.random.Generator,
    name: str,
) -> Estimate:
    tasks = {a.shape[1] for a in arrays}
    if len(tasks) > 1:
        shapes = [a.shape for a in arrays]
        raise ValueError(f"{name}: the arrays' tasks differ {shapes} (each must be (runs, tasks) with equal tasks)")
    point = np.asarray(statistic(*arrays), dtype=float)
    size = sum(a.size for a in arrays) * (2 if len(arrays) == 1 else max(a.shape[0] for a in arrays))
    batch = max(1, MAX_BATCH_ELEMENTS // max(size, 1))
    values = []
    for start in range(0, reps, batch):  # batches of replicates (one batch unless the stack is very large)
        n = min(batch, reps - start)
        samples = [stratified_resample(a, n, rng) for a in arrays]
        values.append(np.asarray(statistic(*samples), dtype=float).reshape(n, *point.shape))
    boot = np.concatenate(values)
    tail = 100.0 * (1.0 - confidence) / 2.0
    low, high = np.percentile(boot, [tail, 100.0 - tail], axis=0)
    as_out = (lambda v: float(v)) if point.ndim == 0 else (lambda v: np.asarray(v))
    return Estimate(as_out(point), as_out(low), as_out(high), confidence, reps)


def stratified_bootstrap_ci(
    scores: Scores | Mapping[str, Scores],
    statistic: Callable[..., object],
    reps: int,
    confidence: float,
    rng: np.random.Generator | int,
) -> Estimate | dict[str, Estimate]:
    """Point estimate and percentile interval of ``statistic`` under the stratified bootstrap (rliable's).

    ``scores``: a ``(runs, tasks)`` array, a tuple of such arrays with the same tasks (``statistic`` then takes
    them in order, e.g. :func:`probability_of_improvement`; each is resampled independently), or a mapping of names
    to either (one :class:`Estimate` per name, drawn in the mapping's order from the same generator).
    ``statistic``: arrays ``(..., runs, tasks)`` -> ``(...)`` or ``(..., k)`` (a scalar or a vector per sample).
    ``reps``: replicates; ``confidence``: in (0, 1), e.g. 0.95 for the 2.5 / 97.5 percentiles;
    ``rng``: a ``numpy.random.Generator`` or an integer seed (required: results are reproducible).
    """
    reps = _check_reps(reps)
    confidence = _check_confidence(confidence)
    gen = _generator(rng)
    if isinstance(scores, Mapping):
        if not scores:
            raise ValueError("scores: an empty mapping (give at least one name -> (runs, tasks) array)")
        return {
            str(k): _bootstrap_one(_arrays(v, f"scores[{k!r}]"), statistic, reps, confidence, gen, f"scores[{k!r}]")
            for k, v in scores.items()
        }
    return _bootstrap_one(_arrays(scores, "scores"), statistic, reps, confidence, gen, "scores")


def _arrays(value: Scores, name: str) -> tuple[np.ndarray, ...]:
    if isinstance(value, tuple):
        if not value:
            raise ValueError(f"{name}: an empty tuple (give one or more (runs, tasks) arrays)")
        return tuple(as_scores(v, f"{name}[{i}]") for i, v in enumerate(value))
    return (as_scores(value, name),)


def probability_of_improvement_ci(
    x: np.ndarray, y: np.ndarray, reps: int, confidence: float, rng: np.random.Generator | int
) -> Estimate:
    """:func:`probability_of_improvement` of ``x`` over ``y`` with its stratified bootstrap interval."""
    x, y = as_scores(x, "x"), as_scores(y, "y")
    if x.shape[1] != y.shape[1]:
        raise ValueError(f"probability_of_improvement: x has {x.shape[1]} tasks, y {y.shape[1]} (must be equal)")
    return stratified_bootstrap_ci((x, y), _pairwise_improvement, reps, confidence, rng)
