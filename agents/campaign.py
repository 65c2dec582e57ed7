r"""Monte Carlo campaign: one environment x schemes x N seeded runs, paired by common random numbers.

The library behind ``uwb-env-evaluate`` (``uwb_env.agents.cli``; ``scripts/evaluate.py`` runs the same):

    uwb-env-evaluate --preset seed003 --runs 100 --out results/seed003
    uwb-env-evaluate --env uwb_env/UrbanWaveform-v1 --schemes myopic round-robin random fixed-0 --baseline myopic

A **scheme** is ``SCHEDULER[@TRACKER]``: the scheduler is one of ``uwb_env.agents.scheduler_names()`` (``myopic``,
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

import dataclasses
import json
import math
import multiprocessing
import os
import pathlib
import re
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Any

import numpy as np
from tqdm import tqdm

from uwb_env import scenarios
from uwb_env.agents.schedulers import check_scheduler_name, make_scheduler
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
