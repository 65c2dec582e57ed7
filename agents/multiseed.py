r"""Runs over several training seeds: the folder layout, campaign schemes per seed, learning curves across seeds.

Torch-free (the campaign and the plots use it without the ``rl`` extra).

A multi-seed run (``uwb-env-train ... --seeds N --out runs/x``) is a folder of single runs, one per training seed:

    runs/x/seed-<s>/            exactly what ``uwb-env-train ... --seed s --out runs/x/seed-<s>`` writes
    runs/x/learning_curves.png  the evaluation curves across seeds (:func:`plot_learning_curves`)

In a campaign, ``rl:runs/x`` (or ``rllib:runs/x``, with an optional ``@TRACKER``) stands for every seed's scheme,
``rl:runs/x/seed-0``, ``rl:runs/x/seed-1``, ... (:func:`expand_seed_schemes`); the summary groups them back
(:func:`seed_groups`) for its across-seeds section (``uwb_env.agents.summary``).

Learning curves (:func:`learning_curves`): each seed's ``eval.csv`` (written during training by
``SchedulerEvalCallback``: ``timesteps``, the policy's mean ``return`` and mean covariance trace ``trace_m2`` on
fixed evaluation episodes, and the same for ``myopic`` and ``round_robin`` on those episodes). At each evaluation
step common to the seeds, the curve is the interquartile mean across seeds with a 95 % stratified-bootstrap band
(``uwb_env.agents.rliable``; at one step the seeds are the runs of a single task), as in Agarwal et al. (2021),
Fig. 9's sample-efficiency curves.
"""

from __future__ import annotations

import argparse
import csv
import math
import pathlib
import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from uwb_env.agents import rliable
from uwb_env.agents.storage import atomic_write, read_error

SEED_FOLDER = "seed-{seed}"
_SEED_DIR = re.compile(r"seed-(\d+)")
SCHEME_PREFIXES = ("rl:", "rllib:")
CURVE_METRICS = {"return": "mean return", "trace_m2": "mean covariance trace [m^2]"}
REFERENCES = {"myopic": "myopic", "round_robin": "round-robin"}  # eval.csv column prefix -> label
CURVE_SEED = 0  # the bootstrap's seed for the curves' bands
CURVE_REPS = 2000


def seed_folder(out: pathlib.Path, seed: int) -> pathlib.Path:
    """``<out>/seed-<seed>``: where a multi-seed run keeps the run of one training seed."""
    return pathlib.Path(out) / SEED_FOLDER.format(seed=seed)


def seed_runs(run_dir: pathlib.Path) -> list[tuple[int, pathlib.Path]]:
    """The ``(seed, folder)`` of every ``seed-<s>/`` under ``run_dir`` holding a run (its ``run.yaml``), by seed."""
    run_dir = pathlib.Path(run_dir)
    if not run_dir.is_dir():
        return []
    found = [(int(m.group(1)), p) for p in run_dir.iterdir()
             if (m := _SEED_DIR.fullmatch(p.name)) and (p / "run.yaml").is_file()]  # fmt: skip
    return sorted(found)


def is_multi_seed(run_dir: pathlib.Path) -> bool:
    """A folder of per-seed runs (``seed-<s>/run.yaml``), not itself a run (no ``run.yaml``)."""
    run_dir = pathlib.Path(run_dir)
    return not (run_dir / "run.yaml").is_file() and bool(seed_runs(run_dir))


def expand_seed_schemes(schemes: Sequence[str]) -> list[str]:
    """Each ``rl:DIR[@TRACKER]`` (or ``rllib:``) whose ``DIR`` is a multi-seed run -> one scheme per seed, by seed.

    ``rl:runs/x@imm-lmipda`` -> ``rl:runs/x/seed-0@imm-lmipda``, ``rl:runs/x/seed-1@imm-lmipda``, ...; every other
    scheme is kept as it is. A run listed twice by the expansion (``rl:runs/x`` and ``rl:runs/x/seed-0``) raises
    ``ValueError`` naming it; a scheme the arguments list twice is left to ``Campaign``, which refuses it.
    """
    out: list[str] = []
    for scheme in schemes:
        scheduler, at, tracker = scheme.partition("@")
        prefix = next((p for p in SCHEME_PREFIXES if scheduler.startswith(p)), None)
        path = pathlib.Path(scheduler[len(prefix) :]) if prefix else None
        if path is not None and is_multi_seed(path):
            out += [f"{prefix}{folder}{at}{tracker}" for _, folder in seed_runs(path)]
        else:
            out.append(scheme)
    twice = sorted({s for s in out if out.count(s) > 1 and list(schemes).count(s) < 2})  # the Campaign names the rest
    if twice:
        raise ValueError(f"schemes: {twice} listed twice once multi-seed runs are expanded (list each run once)")
    return out


def seed_of(scheme: str) -> tuple[str, int] | None:
    """``rl:runs/x/seed-3@kf`` -> ``("rl:runs/x@kf", 3)``: the group a per-seed scheme belongs to; else ``None``."""
    scheduler, at, tracker = scheme.partition("@")
    prefix = next((p for p in SCHEME_PREFIXES if scheduler.startswith(p)), None)
    if prefix is None:
        return None
    path = pathlib.PurePath(scheduler[len(prefix) :])
    m = _SEED_DIR.fullmatch(path.name)
    if m is None:
        return None
    return f"{prefix}{path.parent}{at}{tracker}", int(m.group(1))


def seed_groups(schemes: Sequence[str], minimum: int = 2) -> dict[str, list[tuple[int, str]]]:
    """Per-seed schemes grouped by their run: ``{group: [(seed, scheme), ...]}`` by seed, groups of ``minimum``+."""
    groups: dict[str, list[tuple[int, str]]] = {}
    for s in schemes:
        if (found := seed_of(s)) is not None:
            groups.setdefault(found[0], []).append((found[1], s))
    return {g: sorted(members) for g, members in groups.items() if len(members) >= minimum}


# ------------------------------------------------------------------------------------------- learning curves
def read_eval_csv(path: pathlib.Path) -> dict[str, np.ndarray]:
    """A run's ``eval.csv`` as columns (floats); ``ValueError`` naming the file when it is damaged."""
    path = pathlib.Path(path)
    need = ["timesteps", *CURVE_METRICS, *(f"{r}_{m}" for r in REFERENCES for m in CURVE_METRICS)]
    with read_error(path, f"an evaluation log (CSV with columns {need})"):
        rows = list(csv.reader(path.read_text().splitlines()))
        if not rows:
            raise ValueError("an empty file")
        header, body = rows[0], [r for r in rows[1:] if r]
        missing = [c for c in need if c not in header]
        if missing:
            raise ValueError(f"columns {missing} are missing (has {header})")
        if any(len(r) != len(header) for r in body):
            raise ValueError(f"a row has not {len(header)} fields")
        table = np.array([[float(v) for v in r] for r in body], dtype=float).reshape(len(body), len(header))
    return {c: table[:, header.index(c)] for c in need}


@dataclass(frozen=True)
class Curve:
    """One metric's learning curves across seeds.

    ``timesteps`` (K,) the evaluation steps every seed has; ``per_seed`` (seeds, K) each seed's value there;
    ``iqm``, ``low``, ``high`` (K,) the IQM across seeds and its bootstrap interval (nan where a seed's value is
    nan); ``references`` the myopic and round-robin values on the same evaluation episodes (mean over the seeds'
    files: each file holds the same numbers, the schedulers being deterministic on fixed seeds).
    """

    metric: str
    timesteps: np.ndarray
    per_seed: np.ndarray
    iqm: np.ndarray
    low: np.ndarray
    high: np.ndarray
    references: dict[str, float]


@dataclass(frozen=True)
class LearningCurves:
    """The seeds, each seed's full evaluation log, and one :class:`Curve` per metric of :data:`CURVE_METRICS`."""

    seeds: tuple[int, ...]
    logs: dict[int, dict[str, np.ndarray]]
    curves: dict[str, Curve]
    confidence: float


def learning_curves(
    run_dir: pathlib.Path, reps: int = CURVE_REPS, confidence: float = 0.95, seed: int = CURVE_SEED
) -> LearningCurves:
    """The curves of a multi-seed run (seeds without an ``eval.csv`` yet are left out).

    At each evaluation step every seed has, the IQM across seeds (``rliable.iqm_per_task``: the steps are the
    columns, the seeds the runs) and its stratified-bootstrap percentile interval, drawn from
    ``numpy.random.default_rng(seed)``. ``ValueError`` when no seed has a log, or the seeds share no step.
    """
    run_dir = pathlib.Path(run_dir)
    logs = {s: read_eval_csv(p / "eval.csv") for s, p in seed_runs(run_dir) if (p / "eval.csv").is_file()}
    if not logs:
        raise ValueError(
            f"{run_dir}: no seed-<s>/eval.csv (a multi-seed run's evaluations, written every eval_freq steps)"
        )
    seeds = tuple(sorted(logs))
    common = logs[seeds[0]]["timesteps"]
    for s in seeds[1:]:
        common = np.intersect1d(common, logs[s]["timesteps"])
    if common.size == 0:
        raise ValueError(f"{run_dir}: the seeds {list(seeds)} share no evaluation step (compare their eval.csv)")
    curves = {}
    for metric in CURVE_METRICS:
        per_seed = np.stack([_at(logs[s], metric, common) for s in seeds])  # (seeds, K)
        iqm, low, high = (np.full(common.size, np.nan) for _ in range(3))
        ok = np.all(np.isfinite(per_seed), axis=0)
        if ok.any():
            est = rliable.stratified_bootstrap_ci(per_seed[:, ok], rliable.iqm_per_task, reps, confidence, seed)
            iqm[ok], low[ok], high[ok] = est.point, est.low, est.high
        refs = {label: float(np.nanmean([np.nanmean(logs[s][f"{col}_{metric}"]) for s in seeds]))
                for col, label in REFERENCES.items()}  # fmt: skip
        curves[metric] = Curve(metric, common, per_seed, iqm, low, high, refs)
    return LearningCurves(seeds, logs, curves, confidence)


def _at(log: dict[str, np.ndarray], metric: str, steps: np.ndarray) -> np.ndarray:
    """A log's ``metric`` at ``steps`` (the last row of a step logged twice)."""
    t = log["timesteps"]
    last = {float(v): i for i, v in enumerate(t)}
    return log[metric][[last[float(s)] for s in steps]]


def plot_learning_curves(
    run_dir: pathlib.Path, path: pathlib.Path | None = None, curves: LearningCurves | None = None
) -> pathlib.Path:
    """Write the curves of :func:`learning_curves` (default ``<run_dir>/learning_curves.png``, atomically).

    One panel per metric: each seed a thin line, the IQM across seeds bold with its 95 % band, myopic and
    round-robin as horizontal references. ``curves``: already computed (default: computed here).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    lc = learning_curves(run_dir) if curves is None else curves
    path = pathlib.Path(run_dir) / "learning_curves.png" if path is None else pathlib.Path(path)
    fig, axes = plt.subplots(1, len(CURVE_METRICS), figsize=(6 * len(CURVE_METRICS), 4), dpi=110, squeeze=False)
    for ax, (metric, label) in zip(axes[0], CURVE_METRICS.items(), strict=True):
        c = lc.curves[metric]
        for s in lc.seeds:
            ax.plot(lc.logs[s]["timesteps"], lc.logs[s][metric], lw=0.7, alpha=0.45, label=f"seed {s}")
        ax.fill_between(c.timesteps, c.low, c.high, color="C0", alpha=0.2,
                        label=f"{100 * lc.confidence:.0f} % stratified bootstrap CI")  # fmt: skip
        ax.plot(c.timesteps, c.iqm, color="C0", lw=2.2, label=f"IQM across {len(lc.seeds)} seeds")
        for (name, value), style in zip(c.references.items(), ("--", ":"), strict=True):
            if math.isfinite(value):
                ax.axhline(value, color="k", ls=style, lw=1.2, label=name)
        ax.set_xlabel("environment steps")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(f"{run_dir}: evaluation during training, {len(lc.seeds)} training seeds", fontsize=9)
    fig.tight_layout()
    atomic_write(path, lambda f: fig.savefig(f, format="png"))
    plt.close(fig)
    return path


def curves_main(argv: Sequence[str] | None = None) -> None:
    """``python scripts/learning_curves.py RUN_DIR [--out PNG]``: plot a multi-seed run's learning curves."""
    ap = argparse.ArgumentParser(prog="learning_curves", description=plot_learning_curves.__doc__)
    ap.add_argument("run_dir", type=pathlib.Path, help="a multi-seed run (seed-<s>/ folders)")
    ap.add_argument("--out", type=pathlib.Path, help="the PNG (default RUN_DIR/learning_curves.png)")
    args = ap.parse_args(argv)
    try:
        lc = learning_curves(args.run_dir)
    except ValueError as e:
        ap.error(str(e))
    path = plot_learning_curves(args.run_dir, args.out, lc)
    for metric, c in lc.curves.items():
        refs = ", ".join(f"{k} {v:.4g}" for k, v in c.references.items())
        last = f"IQM {c.iqm[-1]:.4g} [{c.low[-1]:.4g}, {c.high[-1]:.4g}]"
        print(f"{metric} at {int(c.timesteps[-1])} steps: {last} over seeds {list(lc.seeds)}; {refs}")
    print(f"wrote {path}")
