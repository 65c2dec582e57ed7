"""How far each open-loop schedule is from the ceiling, on the expected covariance recursion along the truth.

Run: python scripts/ceiling_gap.py [--env uwb_env/UrbanWideband-v2] [--runs 10] [--horizon 4] [--first-seed 0]
     [--position-std M] [--linearisation ekf] [--json PATH]

For each seed (``env.reset(seed)``) the episode's truth recursion (``uwb_env.ceiling.TruthRecursion``, clairvoyant,
on the model) is walked along the greedy schedule (myopic on the truth: the plan of least expected cost after the
next scan, scan after scan): the common operating point. At every window start k = 0, H, 2H, ... (k + H <= the last
scan), from that state, the ceiling (``optimal_schedule``: the exact optimum over all A^H sequences) and the window
costs (``schedule_cost``) of

    fixed-a      plan a for the H scans, every valid a
    round-robin  the valid plans in turn, in phase with the episode's scan index (plan (scan - 1) mod A)
    greedy       myopic on the truth from the window's start (the operating point's own schedule)

Per window the relative gap (cost / optimum - 1; windows with optimum 0, no target alive, are skipped); per episode
the mean over its windows; reported: the mean over the distinct episode truths with the t-interval's 95 % half-width
(seeds that draw the same truth give the same windows and count once; where every seed draws the same truth, as on
the registered scenarios' fixed paths, the mean and interval are over that episode's windows), and the search's
work (nodes scored / the unpruned tree's A + ... + A^H, leaves / A^H, nodes expanded, ms per window).
"""

from __future__ import annotations

import argparse
import json
import pathlib
import time

import gymnasium as gym
import numpy as np

import uwb_env  # noqa: F401  (registers the envs)
from uwb_env.agents.summary import mean_ci
from uwb_env.ceiling import LINEARISATIONS, TruthRecursion, advance, greedy_schedule, optimal_schedule, schedule_cost


def window_gaps(env: gym.Env, seed: int, horizon: int, **recursion: object) -> dict[str, np.ndarray]:
    """One seed: per window, every scheme's relative gap to the optimum and the search's work (module docstring)."""
    env.reset(seed=seed)
    rec = TruthRecursion.from_env(env, **recursion)
    acts = rec.actions
    state = rec.initial_state()
    reference, _, _ = greedy_schedule(rec, state, rec.n_scans)  # the operating point
    names = [f"fixed-{a}" for a in acts] + ["round-robin", "greedy"]
    gaps: dict[str, list[float]] = {n: [] for n in names}
    work: dict[str, list[float]] = {k: [] for k in ("scored", "leaves", "expanded", "ms", "optimum_m2")}
    for k in range(0, rec.n_scans - horizon + 1, horizon):
        t0 = time.perf_counter()
        best = optimal_schedule(rec, state, horizon)
        ms = 1e3 * (time.perf_counter() - t0)
        if best.cost > 0:
            scans = np.arange(k + 1, k + horizon + 1)
            seqs = np.concatenate(
                [np.repeat(acts[:, None], horizon, axis=1), acts[(scans - 1) % acts.size][None]]
            )  # fixed, round-robin
            costs = np.append(schedule_cost(rec, seqs, state), greedy_schedule(rec, state, horizon)[1])
            if (costs < best.cost * (1 - 1e-9)).any():
                raise AssertionError(
                    f"seed {seed} scan {k}: a schedule beats the ceiling ({costs.min()} < {best.cost})"
                )
            for name, c in zip(names, costs, strict=True):
                gaps[name].append(c / best.cost - 1.0)
            work["scored"].append(best.scored / best.full_scored)
            work["leaves"].append(best.leaves / best.full_leaves)
            work["expanded"].append(best.expanded)
            work["ms"].append(ms)
            work["optimum_m2"].append(best.cost)
        for a in reference[0, k : k + horizon]:  # on along the operating point
            state, _ = advance(rec, state, np.array([a]))
    return {n: np.array(v) for n, v in (gaps | work).items()}


def main() -> None:
    """The command line (module docstring): prints the gaps and the search's work."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--env", default="uwb_env/UrbanWideband-v2")
    ap.add_argument("--runs", type=int, default=10, help="seeds first-seed .. first-seed + runs - 1")
    ap.add_argument("--horizon", type=int, default=4)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--position-std", type=float, default=None, help="P0's candidate std [m] (default: the tracker's)")
    ap.add_argument("--linearisation", choices=LINEARISATIONS, default="ekf")
    ap.add_argument("--json", type=pathlib.Path, default=None, help="write the per-window results here")
    args = ap.parse_args()
    if args.runs < 1:
        ap.error(f"--runs={args.runs}: must be >= 1")
    if args.horizon < 1:
        ap.error(f"--horizon={args.horizon}: must be >= 1")
    env = gym.make(args.env).unwrapped
    episodes: dict[bytes, dict[str, np.ndarray]] = {}  # by truth: seeds with the same truth give the same windows
    t0 = time.perf_counter()
    for seed in range(args.first_seed, args.first_seed + args.runs):
        env.reset(seed=seed)
        truth = env.sim.truth
        key = np.where(truth.alive[..., None], truth.states, 0.0).tobytes() + truth.alive.tobytes()
        if key not in episodes:
            episodes[key] = window_gaps(
                env, seed, args.horizon, position_std_m=args.position_std, linearisation=args.linearisation
            )
    wall = time.perf_counter() - t0
    runs = list(episodes.values())
    by_episode = len(runs) >= 2
    unit = f"{len(runs)} distinct truths" if by_episode else f"{runs[0]['greedy'].size} windows of one truth"
    print(
        f"{args.env}: {args.runs} seeds from {args.first_seed} ({len(runs)} distinct episode truths), windows of "
        f"H = {args.horizon} scans, {args.linearisation} recursion ({wall:.0f} s)"
    )
    if not by_episode:
        print(
            "The truth does not depend on the seed here (fixed paths): the sample is the episode's windows, "
            "consecutive and not independent, so the interval describes their spread."
        )
    print(f"{'schedule':<14}{'mean gap to the ceiling [%]':>30}{'95 % CI over ' + unit:>44}")
    work = ("scored", "leaves", "expanded", "ms", "optimum_m2")
    for name in runs[0]:
        if name in work:
            continue
        values = [r[name].mean() for r in runs] if by_episode else runs[0][name]
        m, half, _ = mean_ci(100 * np.asarray(values))
        print(f"{name:<14}{m:>30.2f}{f'[{m - half:.2f}, {m + half:.2f}]':>44}")
    pooled = {k: np.concatenate([r[k] for r in runs]) for k in work}
    print(
        f"search: nodes scored {100 * pooled['scored'].mean():.1f} % of the tree's A + ... + A^H, "
        f"leaves {100 * pooled['leaves'].mean():.1f} % of A^H (max {100 * pooled['leaves'].max():.1f} %), "
        f"{pooled['expanded'].mean():.0f} nodes expanded, {np.median(pooled['ms']):.1f} ms per window (median), "
        f"{pooled['ms'].size} windows"
    )
    if args.json is not None:
        out = {"args": {k: str(v) for k, v in vars(args).items()}, "episodes": [
            {k: v.tolist() for k, v in r.items()} for r in runs
        ]}  # fmt: skip
        args.json.write_text(json.dumps(out))
