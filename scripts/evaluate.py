r"""Monte Carlo campaign: one environment x schemes x N seeded runs, paired by common random numbers.

Run (also installed as ``uwb-env-evaluate``):

    uwb-env-evaluate --preset seed003 --runs 100 --out results/seed003
    uwb-env-evaluate --env uwb_env/UrbanWaveform-v1 --schemes myopic round-robin random fixed-0 --baseline myopic

A **scheme** is ``SCHEDULER[@TRACKER]``: the scheduler is one of ``agents.scheduler_names()`` (``myopic``,
``round-robin``, ``random``, ``fixed-K``, ``lookahead-D``), the tracker ``scenario`` (default: the scenario's
VS-IMM / LMIPDA) or ``open-loop`` (seed 003's baseline, one NCV UKF: ``uwb_env.config.open_loop_tracker``).
Every scheme plays the same seeds ``seed0 .. seed0 + N - 1``; ``env.reset(seed)`` draws truth, clutter and noise
from named streams and the truth never depends on actions, so differences between schemes are paired.

Output folder:

    campaign.json               the campaign's definition; a resumed campaign must match it (runs may grow)
    runs/<scheme>/seed-<s>.csv  the per-scan record of one run, written atomically when it finishes
    runs.csv                    per-run metrics (below), every scheme and seed
    summary.md                  per scheme mean [95 % t-interval]; paired differences against the baseline
    confirmed_tracks.png, position_rmse.png, model_probabilities.png   seed 003 Figs. 4-6, one curve per scheme

Runs whose file exists are not recomputed: an interrupted campaign resumes where it stopped, and gives the same
summary as an uninterrupted one (tested).

Per-run metrics: ``rmse_m`` position RMSE of the confirmed tracks assigned to alive targets within the env's cover
gate (5 m), pooled over the run; ``ospa_m`` mean OSPA (cut-off 10 m, order 2); ``confirmed`` confirmed tracks per
scan; ``true_confirmed`` of them assigned to a target; ``false`` confirmed tracks per scan not assigned;
``trace_m2`` mean over scans with a confirmed track of the mean position-covariance trace (the reward's term; a
confirmed false track coasting through a shadow, where Pd ~ 0 and only the survival probability lowers its
existence, grows its covariance to hundreds of m^2 and dominates it in a few runs); ``target_trace_m2`` the same
over the confirmed tracks assigned to targets only;
``energy_j`` transmitted energy of the run; ``return`` the sum of rewards.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import multiprocessing
import os
import pathlib
import re
import sys
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Any

import numpy as np
import yaml
from scipy import stats
from tqdm import tqdm

from agents import check_scheduler_name, make_scheduler, scheduler_names
from uwb_env import scenarios
from uwb_env.config import apply_overrides, open_loop_tracker
from uwb_env.envs import ENV_IDS, UWBSchedulingEnv

TRACKERS = ("scenario", "open-loop")
METRICS = {
    "rmse_m": "position RMSE [m]",
    "ospa_m": "OSPA [m]",
    "confirmed": "confirmed tracks / scan",
    "true_confirmed": "true confirmed tracks / scan",
    "false": "false tracks / scan",
    "trace_m2": "mean covariance trace [m^2]",
    "target_trace_m2": "covariance trace on targets [m^2]",
    "energy_j": "energy / run [J]",
    "return": "return",
}
PRESETS: dict[str, dict[str, Any]] = {
    "seed003": {
        "env": "uwb_env/UrbanWaveform-v1",
        "schemes": ["myopic", "round-robin", "round-robin@open-loop"],
        "baseline": "round-robin@open-loop",
        "reference": {"confirmed": "+15 %", "true_confirmed": "+15 %", "rmse_m": "-60 %"},
        "title": "Seed 003: closed loop (myopic + VS-IMM) vs open loop (round-robin + one NCV UKF)",
    },
    "schedulers": {
        "env": "uwb_env/UrbanWaveform-v1",
        "schemes": ["myopic", "lookahead-3", "round-robin", "random"] + [f"fixed-{w}" for w in range(6)],
        "baseline": "myopic",
        "reference": {},
        "title": "Waveform schedulers on urban-intersection (VS-IMM / LMIPDA tracker)",
    },
    "seed003-ablation": {
        "env": "uwb_env/UrbanWaveform-v1",
        "schemes": ["myopic", "round-robin", "myopic@open-loop", "round-robin@open-loop"],
        "baseline": "myopic",
        "reference": {},
        "title": (
            "Seed 003 ablation: the closed loop with waveform scheduling (-> round-robin) or VS-IMM (-> one NCV UKF) "
            "removed; spatial diversity (-> one receiver) is the same campaign with --set pairs=[[0,0]]"
        ),
    },
}
RECORD = ("scan", "alive", "confirmed", "true_confirmed", "false", "missed", "sq_error_sum", "ospa_m", "trace_m2",
          "target_trace_m2", "energy_j", "reward", "action")  # fmt: skip


# ------------------------------------------------------------------------------------------------- definition
@dataclasses.dataclass(frozen=True)
class Campaign:
    """What a campaign runs (``campaign.json``)."""

    env: str
    schemes: tuple[str, ...]
    baseline: str
    runs: int
    seed0: int = 0
    overrides: dict[str, Any] = dataclasses.field(default_factory=dict)
    env_kwargs: dict[str, Any] = dataclasses.field(default_factory=dict)  # e.g. include_lookahead for an RL agent
    title: str = ""
    reference: dict[str, str] = dataclasses.field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.env not in ENV_IDS:
            raise ValueError(f"env={self.env!r}: must be one of {sorted(ENV_IDS)}")
        if self.runs < 2:
            raise ValueError(f"runs={self.runs}: must be >= 2 (a confidence interval needs two runs)")
        if len(set(self.schemes)) != len(self.schemes):
            raise ValueError(f"schemes={list(self.schemes)}: a scheme is listed twice")
        for s in self.schemes:
            parse_scheme(s)
        if self.baseline not in self.schemes:
            raise ValueError(f"baseline={self.baseline!r}: must be one of the schemes {list(self.schemes)}")
        bad = set(self.reference) - set(METRICS)
        if bad:
            raise ValueError(f"reference metrics {sorted(bad)}: must be among {list(METRICS)}")

    def seeds(self) -> range:
        """The common random numbers: the same episode seeds for every scheme."""
        return range(self.seed0, self.seed0 + self.runs)

    def definition(self) -> dict[str, Any]:
        """Everything that fixes a run's result (``runs`` may grow on resume)."""
        out = {"env": self.env, "schemes": list(self.schemes), "seed0": self.seed0, "overrides": self.overrides}
        if self.env_kwargs:  # only when set, so campaigns written before the field existed still resume
            out["env_kwargs"] = self.env_kwargs
        return out


def parse_scheme(scheme: str) -> tuple[str, str]:
    """``"SCHEDULER[@TRACKER]"`` -> (scheduler, tracker), both checked."""
    scheduler, _, tracker = scheme.partition("@")
    tracker = tracker or "scenario"
    if tracker not in TRACKERS:
        raise ValueError(f"scheme {scheme!r}: tracker {tracker!r} must be one of {TRACKERS}")
    check_scheduler_name(scheduler)  # raises with the allowed names
    return scheduler, tracker


def make_env(campaign: Campaign, tracker: str) -> UWBSchedulingEnv:
    """The campaign's environment (the registered id's arguments, the overrides, the scheme's tracker)."""
    kwargs = {**ENV_IDS[campaign.env], **campaign.env_kwargs}
    cfg = apply_overrides(scenarios.get(kwargs.pop("scenario")), campaign.overrides)
    if tracker == "open-loop":
        cfg = dataclasses.replace(cfg, tracker=open_loop_tracker(cfg.tracker))
    return UWBSchedulingEnv(cfg, **kwargs)


# ------------------------------------------------------------------------------------------------------ runs
def play(env: UWBSchedulingEnv, scheduler: Any, seed: int) -> tuple[np.ndarray, tuple[str, ...]]:
    """One episode: the per-scan record ``(n_scans, len(RECORD) + r)`` and its column names."""
    obs, _ = env.reset(seed=seed)
    scheduler.reset(seed)
    rows, done = [], False
    while not done:
        action = scheduler.act(obs, env)
        obs, reward, done, _, info = env.step(action)
        e = info["position_errors_m"]
        conf = info["confirmed_tracks"]
        rows.append(
            [
                info["scan_index"],
                conf - info["false_tracks"] + info["missed_targets"],
                conf,
                conf - info["false_tracks"],
                info["false_tracks"],
                info["missed_targets"],
                float(e @ e),
                info["ospa_m"],
                info["covariance_trace"] if conf else math.nan,
                info["target_covariance_trace"] if conf > info["false_tracks"] else math.nan,
                info["energy_j"],
                reward,
                action,
                *info["model_probabilities"],
            ]
        )
    names = RECORD + tuple(f"mu:{m}" for m in env.sim.tracker.model_names)
    return np.array(rows, dtype=float), names


_ENVS: dict[str, UWBSchedulingEnv] = {}


def run_one(campaign: Campaign, scheme: str, seed: int, path: pathlib.Path) -> pathlib.Path:
    """Play one (scheme, seed) and write its record atomically to ``path``."""
    scheduler, tracker = parse_scheme(scheme)
    key = json.dumps([campaign.env, campaign.overrides, campaign.env_kwargs, tracker], sort_keys=True)
    if key not in _ENVS:  # one env per process and tracker: building it compiles nothing twice
        _ENVS[key] = make_env(campaign, tracker)
    record, names = play(_ENVS[key], make_scheduler(scheduler), seed)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    np.savetxt(tmp, record, delimiter=",", header=",".join(names), comments="", fmt="%.17g")
    os.replace(tmp, path)
    return path


def run_path(out: pathlib.Path, scheme: str, seed: int) -> pathlib.Path:
    """Where a run's record lives."""
    return out / "runs" / re.sub(r"[^A-Za-z0-9._-]", "_", scheme.replace("@", "__")) / f"seed-{seed}.csv"


def run_campaign(campaign: Campaign, out: pathlib.Path, workers: int = 1, progress: bool = True) -> None:
    """Play every (scheme, seed) whose record is missing, over ``workers`` processes, keeping results as they come."""
    out.mkdir(parents=True, exist_ok=True)
    meta = out / "campaign.json"
    if meta.exists():
        old = json.loads(meta.read_text())
        for field, value in campaign.definition().items():
            if old.get(field) != value:
                raise ValueError(
                    f"{meta}: field {field!r} is {old.get(field)!r}, this campaign has {value!r}; "
                    "use another --out or the same definition to resume"
                )
    meta.write_text(json.dumps({**dataclasses.asdict(campaign), "schemes": list(campaign.schemes)}, indent=2))
    jobs = [(s, seed) for s in campaign.schemes for seed in campaign.seeds() if not run_path(out, s, seed).exists()]
    bar = tqdm(total=len(jobs), desc="runs", unit="run", disable=not progress)
    if workers <= 1 or len(jobs) <= 1:
        for s, seed in jobs:
            run_one(campaign, s, seed, run_path(out, s, seed))
            bar.update()
    else:
        # The first run plays here: it compiles (or loads) the numba kernels once, and the forked workers inherit
        # them instead of compiling side by side on a fresh install. A run of a trained RL agent never plays here
        # and, when there is one, workers start from a fork server: torch's thread pools do not survive a fork.
        first = next((i for i, (s, _) in enumerate(jobs) if not s.startswith("rl:")), None)
        if first is not None:
            s, seed = jobs.pop(first)
            run_one(campaign, s, seed, run_path(out, s, seed))
            bar.update()
        rl = any(s.startswith("rl:") for s, _ in jobs)
        ctx = multiprocessing.get_context("forkserver") if rl else None
        with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
            futures = [pool.submit(run_one, campaign, s, seed, run_path(out, s, seed)) for s, seed in jobs]
            for f in as_completed(futures):
                f.result()  # re-raise a worker's error here
                bar.update()
    bar.close()


# --------------------------------------------------------------------------------------------------- summary
def load_runs(campaign: Campaign, out: pathlib.Path) -> dict[str, list[dict[str, np.ndarray]]]:
    """Every run's record, per scheme in seed order, as column name -> ``(n_scans,)``."""
    runs: dict[str, list[dict[str, np.ndarray]]] = {}
    for s in campaign.schemes:
        runs[s] = []
        for seed in campaign.seeds():
            path = run_path(out, s, seed)
            with path.open() as f:
                names = f.readline().strip().split(",")
                data = np.loadtxt(f, delimiter=",", ndmin=2)
            runs[s].append({n: data[:, j] for j, n in enumerate(names)})
    return runs


def finite_mean(values: np.ndarray) -> float:
    """Mean of the finite values (nan when there is none)."""
    v = values[np.isfinite(values)]
    return float(v.mean()) if v.size else math.nan


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
    """Paired differences ``d`` (runs,): how many are above and below 0, and the two-sided p of Wilcoxon's signed-rank
    test (zero differences dropped; ``-`` when fewer than 6 are non-zero: the test cannot reach 5 %).

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


def summarise(campaign: Campaign, out: pathlib.Path) -> str:
    """Write ``runs.csv``, ``summary.md`` and the plots; return the Markdown summary."""
    runs = load_runs(campaign, out)
    per_run = {s: [run_metrics(r) for r in rs] for s, rs in runs.items()}
    metrics = {s: {m: np.array([r[m] for r in rs]) for m in METRICS} for s, rs in per_run.items()}
    with (out / "runs.csv").open("w") as f:
        f.write("scheme,seed," + ",".join(METRICS) + "\n")
        for s in campaign.schemes:
            for i, seed in enumerate(campaign.seeds()):
                f.write(f"{s},{seed}," + ",".join(f"{metrics[s][m][i]:.17g}" for m in METRICS) + "\n")
    base = campaign.baseline
    lines = [f"# {campaign.title or campaign.env}", ""]
    lines.append(f"{campaign.env}, {campaign.runs} paired runs (seeds {campaign.seed0}..{campaign.seeds()[-1]})")
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
            rel = f"{100 * mean / b:+.1f} %" if b and math.isfinite(b) else "-"
            excl = "yes" if math.isfinite(half) and abs(mean) > half else "no"
            above, below, p = sign_rank(d)
            row = (
                f"| {s} | {label} | {mean:+.4g} [{mean - half:+.4g}, {mean + half:+.4g}] | {rel} | {excl} "
                f"| {above} / {below} | {p} |"
            )
            lines.append(row + (f" {ref.get(m, '')} |" if ref else ""))
    text = "\n".join(lines) + "\n"
    (out / "summary.md").write_text(text)
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
        ax.set_title(f"{ylabel}, mean over {campaign.runs} runs")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(out / f"{name}.png")
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
    fig.savefig(out / "model_probabilities.png")
    plt.close(fig)


# ------------------------------------------------------------------------------------------------------- CLI
def parse_overrides(items: Sequence[str], flag: str = "--set") -> dict[str, Any]:
    """``["a.b=1", ...]`` -> ``{"a.b": 1}``: values parsed as YAML, and ``1e-5`` (a string to YAML 1.1) as a float."""
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise ValueError(f"{flag} {item!r}: must be KEY=VALUE, e.g. sensing.clutter.density_per_m2=0")
        parsed = yaml.safe_load(value)
        if isinstance(parsed, str):
            try:
                parsed = float(parsed)
            except ValueError:
                pass
        out[key] = parsed
    return out


def main(argv: Sequence[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--preset", choices=sorted(PRESETS), help="a named campaign (env, schemes, baseline)")
    ap.add_argument("--env", help=f"one of {sorted(ENV_IDS)}")
    ap.add_argument("--schemes", nargs="+", help=f"SCHEDULER[@TRACKER]; schedulers {scheduler_names()}")
    ap.add_argument("--baseline", help="the scheme the others are compared with (default: the last scheme)")
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--seed0", type=int, default=0)
    ap.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                    help="scenario override (dotted path), repeatable")  # fmt: skip
    ap.add_argument("--env-kwarg", dest="env_kwargs", action="append", default=[], metavar="KEY=VALUE",
                    help="env argument, e.g. include_lookahead=true (what an rl: agent was trained on)")  # fmt: skip
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--out", type=pathlib.Path, default=pathlib.Path("results/campaign"))
    ap.add_argument("--no-progress", action="store_true")
    args = ap.parse_args(argv)
    preset = PRESETS[args.preset] if args.preset else {}
    env = args.env or preset.get("env") or "uwb_env/UrbanWaveform-v1"
    schemes = args.schemes or preset.get("schemes") or ["myopic", "round-robin"]
    campaign = Campaign(
        env=env,
        schemes=tuple(schemes),
        baseline=args.baseline or (preset.get("baseline") if not args.schemes else None) or schemes[-1],
        runs=args.runs,
        seed0=args.seed0,
        overrides=parse_overrides(args.overrides),
        env_kwargs=parse_overrides(args.env_kwargs, "--env-kwarg"),
        title=preset.get("title", ""),
        reference=preset.get("reference", {}) if not args.schemes else {},
    )
    run_campaign(campaign, args.out, args.workers, progress=not args.no_progress)
    print(summarise(campaign, args.out))
    print(f"wrote {args.out}/summary.md, runs.csv and confirmed_tracks.png, position_rmse.png, model_probabilities.png")


if __name__ == "__main__":
    sys.exit(main())
