"""Campaign summaries: per-run metrics, t-intervals, paired differences with sign-rank tests, tables and plots.

Reads the run records a campaign wrote (:mod:`uwb_env.agents.campaign`) and writes ``runs.csv``, ``summary.md`` and
seed 003's Figs. 4-6 (``confirmed_tracks.png``, ``position_rmse.png``, ``model_probabilities.png``).

Across training seeds (:func:`across_seeds`): the schemes that are seeds of one multi-seed run (``rl:DIR/seed-<s>``,
``uwb_env.agents.multiseed.seed_groups``) get a section of their own, in the convention of rliable (Agarwal et al.,
"Deep reinforcement learning at the edge of the statistical precipice", NeurIPS 2021; ``uwb_env.agents.rliable``):

* **runs = training seeds, one task = the campaign's environment, a run's score = its mean over the paired
  episodes**, as rliable scores a run on a game by its mean evaluation return. The episodes are not taken as the
  tasks: every episode is played by the same trained policy of a seed, so a seed's scores over the episodes are
  not independent runs. Stratifying over episodes would resample seeds independently per episode, average a bad
  seed away inside every replicate, and give intervals that leave out the seed-to-seed spread they are meant to
  show. The mean over episodes uses the episodes where every seed of the group and the baseline have a finite
  value (so the seeds and the baseline are compared on the same episodes).
* **IQM across seeds** (25 % trimmed mean of the per-seed scores: with 5 seeds, the mean of the middle 3) with the
  95 % percentile interval of the stratified bootstrap (one stratum: the seeds resampled with replacement),
  10,000 replicates from ``numpy.random.default_rng([BOOTSTRAP_SEED, k])``, ``k`` the metric's index in
  ``METRICS``.
* **Probability of improvement** over the baseline scheme: the fraction of seeds whose score is better than the
  baseline's score on the same episodes, ties counted 1/2 (the Mann-Whitney ``U / (n m)`` with the baseline one
  run: the schedulers it is meant for, myopic and round-robin, are deterministic given the episode seed), and its
  bootstrap interval. "Better" is :data:`HIGHER_IS_BETTER`: higher for the return and the (true) confirmed tracks,
  lower for the errors, the traces, the costs, the false tracks and the energy.
"""

from __future__ import annotations

import csv
import math
import pathlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats

from uwb_env.agents import rliable
from uwb_env.agents.campaign import (
    METRICS,
    Campaign,
    check_backend,
    check_workers,
    finished_seeds,
    load_runs,
    preflight,
    run_campaign,
)
from uwb_env.agents.multiseed import seed_groups
from uwb_env.agents.storage import FolderLock, atomic_write, atomic_write_text, read_error

HIGHER_IS_BETTER = {"rmse_m": False, "ospa_m": False, "confirmed": True, "true_confirmed": True, "false": False,
                    "trace_m2": False, "target_trace_m2": False, "target_cost_m2": False, "energy_j": False,
                    "return": True}  # fmt: skip
"""Which way each metric of ``METRICS`` improves (the probability of improvement's sign convention)."""
BOOTSTRAP_SEED = 0  # the across-seeds intervals' generator: numpy.random.default_rng([BOOTSTRAP_SEED, metric index])
BOOTSTRAP_REPS = 10_000
CONFIDENCE = 0.95


class CampaignInterrupted(Exception):
    """A campaign stopped by Ctrl-C (or SIGTERM): ``summary`` of the finished paired runs (``None``: none yet)."""

    def __init__(self, out: pathlib.Path, finished: int, total: int, summary: str | None) -> None:
        super().__init__(f"{out}: interrupted with {finished} of {total} paired runs finished; run again to resume")
        self.summary = summary


def evaluate(
    campaign: Campaign,
    out: pathlib.Path,
    workers: int = 1,
    progress: bool = True,
    backend: str = "local",
    address: str | None = None,
) -> str:
    """Run (or resume) the campaign and summarise it, holding the folder's lock throughout; the summary.

    On ``KeyboardInterrupt`` the workers are stopped at once (:func:`~uwb_env.agents.campaign.run_campaign`), the
    paired runs that every scheme finished are summarised, and :class:`CampaignInterrupted` carries that summary.
    """
    check_workers(workers)
    check_backend(backend, address)
    preflight(campaign)  # every argument checked before the folder is created or locked
    with FolderLock(out, "campaign"):
        try:
            run_campaign(campaign, out, workers, progress, backend, address)
        except KeyboardInterrupt:
            seeds = finished_seeds(campaign, out, preflight(campaign))
            text = summarise(campaign, out, seeds) if seeds else None
            raise CampaignInterrupted(out, len(seeds), campaign.runs, text) from None
        return summarise(campaign, out)


def save_figure(fig, path: pathlib.Path) -> None:
    """``fig.savefig`` as PNG, atomically."""
    atomic_write(path, lambda f: fig.savefig(f, format="png"))


def finite_mean(values: np.ndarray) -> float:
    """Mean of the finite values (nan when there is none)."""
    v = values[np.isfinite(values)]
    return float(v.mean()) if v.size else math.nan


def target_cost(rec: dict[str, np.ndarray]) -> float:
    """Mean over scans with an alive target of (sum of covered targets' traces + missed penalties) / alive [m^2].

    ``true_confirmed`` tracks cover as many targets one-to-one (``metrics.cover_summary``), so a scan's covered
    targets' summed trace is ``target_trace_m2 * true_confirmed`` (0 when nan: no covered target).
    """
    alive = rec["alive"]
    held = np.where(rec["true_confirmed"] > 0, rec["target_trace_m2"], 0.0) * rec["true_confirmed"]
    on = alive > 0
    return float(np.mean((held[on] + rec["missed_penalty"][on]) / alive[on])) if on.any() else math.nan


def run_metrics(rec: dict[str, np.ndarray]) -> dict[str, float]:
    """The per-run metrics of the module docstring from one run's record."""
    matched = rec["true_confirmed"].sum()
    return {
        "rmse_m": float(np.sqrt(rec["sq_error_sum"].sum() / matched)) if matched else math.nan,
        "ospa_m": float(rec["ospa_m"].mean()),
        "confirmed": float(rec["confirmed"].mean()),
        "true_confirmed": float(rec["true_confirmed"].mean()),
        "false": float(rec["false"].mean()),
        "trace_m2": finite_mean(rec["trace_m2"]),  # scans with a confirmed track
        "target_trace_m2": finite_mean(rec["target_trace_m2"]),  # scans with a track on a target
        "target_cost_m2": target_cost(rec),
        "energy_j": float(rec["energy_j"].sum()),
        "return": float(rec["reward"].sum()),
    }


def mean_ci(values: np.ndarray, level: float = 0.95) -> tuple[float, float, int]:
    """Mean, half-width of the t-interval, and the number of finite values."""
    v = values[np.isfinite(values)]
    if v.size < 2:
        return (float(v.mean()) if v.size else math.nan), math.nan, int(v.size)
    half = stats.t.ppf(0.5 + level / 2, v.size - 1) * v.std(ddof=1) / math.sqrt(v.size)
    return float(v.mean()), float(half), int(v.size)


def sign_rank(d: np.ndarray) -> tuple[int, int, str]:
    """Signs and sign-rank p of paired differences ``d`` (runs,).

    How many are above and below 0, and the two-sided p of Wilcoxon's signed-rank test (zero differences dropped;
    ``-`` when fewer than 6 are non-zero: the test cannot reach 5 %).

    Beside the t-interval of the mean: per-run metrics such as the covariance trace have heavy tails (a few runs with
    a diverging false track), which widen the interval of the mean while the runs agree on the sign.
    """
    d = d[np.isfinite(d)]
    nz = d[d != 0]
    above, below = int((nz > 0).sum()), int((nz < 0).sum())
    if nz.size < 6:
        return above, below, "-"
    from scipy.stats import wilcoxon

    return above, below, f"{wilcoxon(nz).pvalue:.2g}"


def relative(difference: float, baseline: float) -> str:
    """The relative column: ``difference / |baseline|`` in percent (``-`` for a zero or non-finite baseline).

    Dividing by the baseline's magnitude keeps the sign of the difference: a return of -50 against a baseline of
    -100 is +50 % (better), where ``difference / baseline`` would print -50 %.
    """
    if not baseline or not math.isfinite(baseline):
        return "-"
    return f"{100 * difference / abs(baseline):+.1f} %"


def seed_span(seeds: Sequence[int]) -> str:
    """``0..9`` for consecutive seeds, else the list."""
    seeds = list(seeds)
    if seeds and seeds == list(range(seeds[0], seeds[-1] + 1)):
        return f"{seeds[0]}..{seeds[-1]}"
    return ", ".join(map(str, seeds))


def summarise(campaign: Campaign, out: pathlib.Path, seeds: Sequence[int] | None = None) -> str:
    """Write ``runs.csv``, ``summary.md`` and the plots (each atomically); return the Markdown summary.

    ``seeds``: the paired runs to summarise (default: every seed of the campaign; an interrupted campaign
    summarises the seeds every scheme finished, and says so in the summary).
    """
    seeds = list(campaign.seeds() if seeds is None else seeds)
    if not seeds:
        raise ValueError(f"{out}: no paired run has finished yet: nothing to summarise")
    runs = load_runs(campaign, out, seeds)
    per_run = {s: [run_metrics(r) for r in rs] for s, rs in runs.items()}
    metrics = {s: {m: np.array([r[m] for r in rs]) for m in METRICS} for s, rs in per_run.items()}
    table = ["scheme,seed," + ",".join(METRICS) + "\n"]
    for s in campaign.schemes:
        for i, seed in enumerate(seeds):
            table.append(f"{s},{seed}," + ",".join(f"{metrics[s][m][i]:.17g}" for m in METRICS) + "\n")
    atomic_write_text(out / "runs.csv", "".join(table))
    base = campaign.baseline
    lines = [f"# {campaign.title or campaign.env}", ""]
    if len(seeds) < campaign.runs:
        lines += [f"**Interrupted: {len(seeds)} of {campaign.runs} paired runs finished; run again to resume.**", ""]
    lines.append(f"{campaign.env}, {len(seeds)} paired runs (seeds {seed_span(seeds)})")
    if campaign.overrides:
        lines.append(f"overrides: {campaign.overrides}")
    if campaign.env_kwargs:
        lines.append(f"environment arguments: {campaign.env_kwargs}")
    lines += ["", "## Mean and 95 % confidence interval per scheme", ""]
    lines.append("| metric | " + " | ".join(campaign.schemes) + " |")
    lines.append("| --- |" + " --- |" * len(campaign.schemes))
    for m, label in METRICS.items():
        cells = []
        for s in campaign.schemes:
            mean, half, _ = mean_ci(metrics[s][m])
            cells.append(f"{mean:.4g} ± {half:.2g}")
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    lines += ["", f"## Paired differences against `{base}` (scheme - baseline, 95 % CI)", ""]
    lines += ["relative = difference / |baseline mean| (positive: the scheme's value is higher)", ""]
    ref = campaign.reference
    head = "| scheme | metric | difference [95 % CI] | relative | CI excludes 0 | runs above / below | sign-rank p |"
    lines += [head + (" seed reports |" if ref else ""), "|" + " --- |" * (7 + bool(ref))]
    for s in campaign.schemes:
        if s == base:
            continue
        for m, label in METRICS.items():
            d = metrics[s][m] - metrics[base][m]
            mean, half, _ = mean_ci(d)
            b, _, _ = mean_ci(metrics[base][m])  # the baseline's mean over its finite runs (nan: none)
            rel = relative(mean, b)
            excl = "yes" if math.isfinite(half) and abs(mean) > half else "no"
            above, below, p = sign_rank(d)
            row = (
                f"| {s} | {label} | {mean:+.4g} [{mean - half:+.4g}, {mean + half:+.4g}] | {rel} | {excl} "
                f"| {above} / {below} | {p} |"
            )
            lines.append(row + (f" {ref.get(m, '')} |" if ref else ""))
    lines += across_seeds_lines(campaign.schemes, base, metrics)
    text = "\n".join(lines) + "\n"
    atomic_write_text(out / "summary.md", text)
    plot(campaign, runs, out)
    return text


def plot(campaign: Campaign, runs: dict[str, list[dict[str, np.ndarray]]], out: pathlib.Path) -> None:
    """Seed 003 Figs. 4-6 with one curve per scheme: confirmed tracks, position RMSE, model probabilities."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    def stack(s: str, col: str) -> np.ndarray:
        return np.stack([r[col] for r in runs[s]])  # (runs, scans)

    for name, ylabel in (("confirmed_tracks", "confirmed tracks"), ("position_rmse", "position RMSE [m]")):
        fig, ax = plt.subplots(figsize=(7, 4), dpi=110)
        for s in campaign.schemes:
            scans = runs[s][0]["scan"]
            if name == "confirmed_tracks":
                y = stack(s, "confirmed").mean(axis=0)
                first = s == campaign.schemes[0]
                ax.plot(scans, stack(s, "alive").mean(axis=0), "k:", lw=1, label="alive targets" if first else None)
            else:
                n = stack(s, "true_confirmed").sum(axis=0)
                y = np.sqrt(
                    np.divide(stack(s, "sq_error_sum").sum(axis=0), n, out=np.full(n.shape, np.nan), where=n > 0)
                )
            ax.plot(scans, y, label=s)
        ax.set_xlabel("scan")
        ax.set_ylabel(ylabel)
        ax.set_title(f"{ylabel}, mean over {len(runs[campaign.schemes[0]])} runs")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        save_figure(fig, out / f"{name}.png")
        plt.close(fig)
    multi = [s for s in campaign.schemes if sum(c.startswith("mu:") for c in runs[s][0]) > 1]
    fig, axes = plt.subplots(max(len(multi), 1), 1, figsize=(7, 2.6 * max(len(multi), 1)), dpi=110, squeeze=False)
    for ax, s in zip(axes[:, 0], multi, strict=False):
        has = stack(s, "confirmed") > 0  # runs with a confirmed track at that scan
        n = has.sum(axis=0)
        for col in (c for c in runs[s][0] if c.startswith("mu:")):
            mu = np.divide((stack(s, col) * has).sum(axis=0), n, out=np.full(n.shape, np.nan), where=n > 0)
            ax.plot(runs[s][0]["scan"], mu, label=col[3:])
        ax.set_ylim(0, 1)
        ax.set_ylabel("model probability")
        ax.set_title(s, fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, ncol=4)
    axes[-1, 0].set_xlabel("scan")
    fig.tight_layout()
    save_figure(fig, out / "model_probabilities.png")
    plt.close(fig)


# ------------------------------------------------------------------------------------------ across training seeds
@dataclass(frozen=True)
class SeedAggregate:
    """One metric of one multi-seed group (see the module docstring).

    ``per_seed`` (seeds,): each seed's mean over the ``episodes`` paired episodes; ``baseline``: the baseline's
    mean over them; ``iqm``: the IQM across seeds with its bootstrap interval; ``improvement``: the probability
    that a seed beats the baseline, with its interval (``None`` for both when fewer than 2 seeds have a score, and
    ``improvement`` ``None`` when the baseline is one of the group's seeds).
    """

    metric: str
    seeds: tuple[int, ...]
    per_seed: np.ndarray
    episodes: int
    baseline: float
    iqm: rliable.Estimate | None
    improvement: rliable.Estimate | None


def across_seeds(
    schemes: Sequence[str],
    baseline: str,
    metrics: Mapping[str, Mapping[str, np.ndarray]],
    reps: int = BOOTSTRAP_REPS,
    confidence: float = CONFIDENCE,
    seed: int = BOOTSTRAP_SEED,
) -> dict[str, dict[str, SeedAggregate]]:
    """``{group: {metric: SeedAggregate}}`` for every multi-seed group among ``schemes`` (2 seeds or more).

    ``metrics[scheme][metric]``: the per-run values (runs,), paired by index across schemes (``runs.csv``).
    """
    out: dict[str, dict[str, SeedAggregate]] = {}
    for group, members in seed_groups(schemes).items():
        seeds = tuple(s for s, _ in members)
        rows = {}
        for k, m in enumerate(METRICS):
            values = np.stack([np.asarray(metrics[scheme][m], dtype=float) for _, scheme in members])  # (seeds, runs)
            base = np.asarray(metrics[baseline][m], dtype=float)
            paired = np.all(np.isfinite(values), axis=0) & np.isfinite(base)
            episodes = int(paired.sum())
            per_seed = values[:, paired].mean(axis=1) if episodes else np.full(len(seeds), np.nan)
            base_mean = float(base[paired].mean()) if episodes else math.nan
            iqm = improvement = None
            if episodes and len(seeds) >= 2:
                rng = np.random.default_rng([seed, k])
                iqm = rliable.stratified_bootstrap_ci(per_seed, rliable.iqm, reps, confidence, rng)
                if baseline not in {scheme for _, scheme in members}:
                    sign = 1.0 if HIGHER_IS_BETTER[m] else -1.0
                    improvement = rliable.probability_of_improvement_ci(
                        sign * per_seed, np.array([sign * base_mean]), reps, confidence, rng
                    )
            rows[m] = SeedAggregate(m, seeds, per_seed, episodes, base_mean, iqm, improvement)
        out[group] = rows
    return out


def across_seeds_lines(
    schemes: Sequence[str], baseline: str, metrics: Mapping[str, Mapping[str, np.ndarray]]
) -> list[str]:
    """The ``summary.md`` section of :func:`across_seeds` (no lines without a multi-seed group)."""
    lines: list[str] = []
    for group, rows in across_seeds(schemes, baseline, metrics).items():
        seeds = next(iter(rows.values())).seeds
        pct = f"{100 * CONFIDENCE:.0f} %"
        lines += ["", f"## Across training seeds: `{group}` (seeds {seed_span(seeds)})", ""]
        lines += [
            f"Per seed: its mean over the paired episodes (those finite for every seed and `{baseline}`). "
            f"IQM: the 25 % trimmed mean across the {len(seeds)} seeds, with the {pct} stratified bootstrap "
            f"interval ({BOOTSTRAP_REPS:,} replicates over seeds; rliable, Agarwal et al. 2021). "
            f"P(improvement): the probability that a seed beats `{baseline}` on the metric (ties 1/2), "
            "higher being better for the return and the confirmed tracks, lower for the rest.",
            "",
        ]
        head = " | ".join(f"seed {s}" for s in seeds)
        lines.append(f"| metric | better | {head} | IQM [{pct} CI] | {baseline} | IQM vs {baseline} "
                     f"| P(improvement) [{pct} CI] | episodes |")  # fmt: skip
        lines.append("| --- |" + " --- |" * (len(seeds) + 6))
        for m, r in rows.items():
            cells = " | ".join(f"{v:.4g}" for v in r.per_seed)
            iqm = f"{r.iqm.point:.4g} [{r.iqm.low:.4g}, {r.iqm.high:.4g}]" if r.iqm else "-"
            rel = relative(r.iqm.point - r.baseline, r.baseline) if r.iqm else "-"
            poi = r.improvement
            poi_text = f"{poi.point:.2f} [{poi.low:.2f}, {poi.high:.2f}]" if poi else "-"
            better = "higher" if HIGHER_IS_BETTER[m] else "lower"
            lines.append(f"| {METRICS[m]} | {better} | {cells} | {iqm} | {r.baseline:.4g} | {rel} | {poi_text} "
                         f"| {r.episodes} |")  # fmt: skip
    return lines


def read_runs_csv(path: pathlib.Path) -> tuple[list[str], dict[str, dict[str, np.ndarray]]]:
    """A campaign's ``runs.csv``: the schemes in order and ``{scheme: {metric: values by seed}}``.

    ``ValueError`` naming the file when a column of ``METRICS`` is missing, a value is not a number, or the schemes
    were not played on the same seeds.
    """
    path = pathlib.Path(path)
    with read_error(path, f"a campaign's runs.csv (scheme, seed, {', '.join(METRICS)})"):
        rows = list(csv.DictReader(path.read_text().splitlines()))
        missing = [c for c in ("scheme", "seed", *METRICS) if rows and c not in rows[0]]
        if not rows or missing:
            raise ValueError(f"no rows, or columns {missing} missing")
        schemes = list(dict.fromkeys(r["scheme"] for r in rows))
        seeds = {s: [int(r["seed"]) for r in rows if r["scheme"] == s] for s in schemes}
        if any(v != seeds[schemes[0]] for v in seeds.values()):
            raise ValueError("the schemes were not played on the same seeds (the runs are not paired)")
        metrics = {s: {m: np.array([float(r[m]) for r in rows if r["scheme"] == s]) for m in METRICS}
                   for s in schemes}  # fmt: skip
    return schemes, metrics
