"""Seed 003's comparison on urban-intersection: closed loop (myopic lookahead + VS-IMM) vs open loop
(round-robin waveforms + one NCV UKF), paired over the same seeds.

Run: python scripts/reproduce_urban.py [--runs N]

Prints per-scheme means and the paired differences (closed - open) with 95 % t-intervals of: confirmed tracks per
scan, position RMSE of confirmed tracks assigned to targets (5 m gate), mean covariance trace. Seed 003 reports
about +15 % confirmed tracks and about -60 % position RMSE for closed loop.
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np
from scipy import stats

from agents import Myopic, RoundRobin
from uwb_env import scenarios
from uwb_env.config import open_loop_tracker
from uwb_env.envs import UWBSchedulingEnv


def play(env: UWBSchedulingEnv, agent, seed: int) -> tuple[float, float, float]:
    """(confirmed tracks per scan, position RMSE [m], mean covariance trace [m^2]) of one episode."""
    obs, _ = env.reset(seed=seed)
    agent.reset(seed)
    conf, sq, traces, done = [], [], [], False
    while not done:
        obs, _, done, _, info = env.step(agent.act(obs, env))
        conf.append(info["confirmed_tracks"] - info["false_tracks"])
        sq.extend(info["position_errors_m"] ** 2)
        if info["confirmed_tracks"]:
            traces.append(info["covariance_trace"])
    return float(np.mean(conf)), float(np.sqrt(np.mean(sq))) if sq else np.nan, float(np.mean(traces))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=20)
    args = ap.parse_args()
    cfg = scenarios.get("urban-intersection")
    closed = UWBSchedulingEnv(cfg)
    open_ = UWBSchedulingEnv(dataclasses.replace(cfg, tracker=open_loop_tracker(cfg.tracker)))
    res = {"closed (myopic + VS-IMM)": [], "open (round-robin + NCV)": []}
    for seed in range(args.runs):
        res["closed (myopic + VS-IMM)"].append(play(closed, Myopic(), seed))
        res["open (round-robin + NCV)"].append(play(open_, RoundRobin(), seed))
    names = ("true confirmed tracks / scan", "position RMSE [m]", "mean covariance trace [m^2]")
    c, o = (np.array(v) for v in res.values())
    print(f"urban-intersection, {args.runs} paired runs")
    print("| metric | closed | open | closed - open (95 % CI) | relative |")
    print("| --- | --- | --- | --- | --- |")
    for j, n in enumerate(names):
        d = c[:, j] - o[:, j]
        ok = np.isfinite(d)
        m, se = d[ok].mean(), d[ok].std(ddof=1) / np.sqrt(ok.sum())
        h = stats.t.ppf(0.975, ok.sum() - 1) * se
        rel = 100 * m / np.nanmean(o[:, j])
        means = f"{np.nanmean(c[:, j]):.4f} | {np.nanmean(o[:, j]):.4f}"
        print(f"| {n} | {means} | {m:+.4f} [{m - h:+.4f}, {m + h:+.4f}] | {rel:+.1f} % |")


if __name__ == "__main__":
    main()
