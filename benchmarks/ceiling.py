"""The ceiling's search (``uwb_env.ceiling.optimal_schedule``): time per window vs the horizon H, and its pruning.

Run: python benchmarks/ceiling.py [--env uwb_env/UrbanWideband-v2] [--horizons 1 2 3 4 5 6] [--windows 10]
     [--brute-max 5] [--seed 0]

On the episode's truth recursion (EKF form, ``TruthRecursion.from_env``), walked along the greedy-on-truth schedule,
``--windows`` window starts spread over the episode; per H: the median wall time per window of the full search
(bound and dominance), of the bound alone (``dominance=False``) and of brute force (all A^H sequences scored with
``schedule_cost``, only for H <= ``--brute-max``), and the means of leaves / A^H and of nodes scored / the unpruned
tree's A + ... + A^H, for the full search and the bound alone. Every window's three optima are checked equal.
One warm-up search first (numba compilation or cache load).
"""

from __future__ import annotations

import argparse
import statistics
import time

import gymnasium as gym
import numpy as np

import uwb_env  # noqa: F401  (registers the envs)
from uwb_env.ceiling import TruthRecursion, advance, brute_force_schedule, greedy_schedule, optimal_schedule


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--env", default="uwb_env/UrbanWideband-v2")
    ap.add_argument("--horizons", type=int, nargs="+", default=[1, 2, 3, 4, 5, 6])
    ap.add_argument("--windows", type=int, default=10)
    ap.add_argument("--brute-max", type=int, default=5)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    if min(args.horizons) < 1 or args.windows < 1:
        ap.error(f"--horizons={args.horizons}, --windows={args.windows}: must be >= 1")
    env = gym.make(args.env).unwrapped
    env.reset(seed=args.seed)
    rec = TruthRecursion.from_env(env)
    A = rec.actions.size
    reference, _, _ = greedy_schedule(rec, rec.initial_state(), rec.n_scans)
    last = rec.n_scans - max(args.horizons)
    starts = np.unique(np.linspace(1, last, args.windows).astype(int))
    states, state = [], rec.initial_state()
    for k, a in enumerate(reference[0][:last], 1):
        state, _ = advance(rec, state, np.array([a]))
        if k in starts:
            states.append(state)
    optimal_schedule(rec, states[0], 2)  # warm-up
    print(f"{args.env} seed {args.seed}: A = {A}, {len(states)} windows from scans {starts.tolist()}")
    print(
        f"{'H':>2}{'A^H':>9}{'full ms':>10}{'bound ms':>10}{'brute ms':>10}"
        f"{'leaves/A^H':>12}{'bound only':>12}{'scored/tree':>13}{'bound only':>12}"
    )
    for H in args.horizons:
        t_full, t_bound, t_brute, lv_full, lv_bound, sc_full, sc_bound = [], [], [], [], [], [], []
        for s in states:
            t0 = time.perf_counter()
            full = optimal_schedule(rec, s, H)
            t1 = time.perf_counter()
            bound = optimal_schedule(rec, s, H, dominance=False)
            t2 = time.perf_counter()
            t_full.append(t1 - t0)
            t_bound.append(t2 - t1)
            if abs(full.cost - bound.cost) > 1e-9 * full.cost:
                raise AssertionError(f"H={H} scan {s.scan}: dominance changed the optimum {bound.cost} -> {full.cost}")
            if H <= args.brute_max:
                t3 = time.perf_counter()
                _, cost = brute_force_schedule(rec, s, H)
                t_brute.append(time.perf_counter() - t3)
                if abs(full.cost - cost) > 1e-9 * cost:
                    raise AssertionError(f"H={H} scan {s.scan}: search {full.cost} != brute force {cost}")
            lv_full.append(full.leaves / full.full_leaves)
            lv_bound.append(bound.leaves / bound.full_leaves)
            sc_full.append(full.scored / full.full_scored)
            sc_bound.append(bound.scored / bound.full_scored)
        brute = f"{1e3 * statistics.median(t_brute):10.1f}" if t_brute else f"{'-':>10}"
        print(
            f"{H:>2}{A**H:>9}{1e3 * statistics.median(t_full):10.1f}{1e3 * statistics.median(t_bound):10.1f}{brute}"
            f"{np.mean(lv_full):12.4f}{np.mean(lv_bound):12.4f}{np.mean(sc_full):13.4f}{np.mean(sc_bound):12.4f}"
        )


if __name__ == "__main__":
    main()
