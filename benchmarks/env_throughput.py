"""Environment steps per second on UrbanWaveform-v3 (parametric), one process, per scheduler.

Run: python benchmarks/env_throughput.py [--episodes N] [--repeats K] [--agents random myopic ...]

Each agent plays N seeded episodes of 140 scans after one untimed warm-up episode (numba kernels load from their
cache on first use), K times over. The myopic figure includes ``lookahead_costs`` every step. Reported: the
steps/s of every repeat, their median and their best (the least disturbed by other work on the machine: on a
shared 2-core box single runs vary by +-10 % and occasionally by 2x).
"""

from __future__ import annotations

import argparse
import statistics
import time

import gymnasium as gym

import uwb_env  # noqa: F401
from uwb_env.agents import make_scheduler, scheduler_names


def episode_seconds(env: gym.Env, agent, seed: int) -> tuple[int, float]:
    """Play one seeded episode; returns (steps, seconds)."""
    obs, _ = env.reset(seed=seed)
    agent.reset(seed)
    done, steps = False, 0
    t0 = time.perf_counter()
    while not done:
        obs, _, terminated, truncated, _ = env.step(agent.act(obs, env))
        done = terminated or truncated
        steps += 1
    return steps, time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--episodes", type=int, default=5)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--env", default="uwb_env/UrbanWaveform-v3")
    ap.add_argument("--agents", nargs="+", default=["random", "myopic"], help=f"scheduler names: {scheduler_names()}")
    args = ap.parse_args()
    env = gym.make(args.env)
    for name in args.agents:
        agent = make_scheduler(name)
        episode_seconds(env, agent, 1000)  # warm-up, not timed
        rates = []
        for _ in range(args.repeats):
            runs = [episode_seconds(env, agent, seed) for seed in range(args.episodes)]
            rates.append(sum(s for s, _ in runs) / sum(t for _, t in runs))
        steps = sum(s for s, _ in runs)
        print(
            f"{args.env} {name:12s} median {statistics.median(rates):6.0f} best {max(rates):6.0f} steps/s "
            f"({steps} steps x {args.repeats}: {' '.join(f'{r:.0f}' for r in rates)})"
        )


if __name__ == "__main__":
    main()
