"""Campaign summaries: per-run metrics, t-intervals, paired differences with sign-rank tests, tables and plots.

Reads the run records a campaign wrote (:mod:`uwb_env.agents.campaign`) and writes ``runs.csv``, ``summary.md`` and
seed 003's Figs. 4-6 (``confirmed_tracks.png``, ``position_rmse.png``, ``model_probabilities.png``).
"""

from __future__ import annotations

import math
import pathlib
from collections.abc import Sequence

import numpy as np
from scipy import stats

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
from uwb_env.agents.storage import FolderLock, atomic_write, atomic_write_text


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
