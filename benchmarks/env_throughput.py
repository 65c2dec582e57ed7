"""Environment steps per second on UrbanWaveform-v0 (parametric), one process, per scheduler.

Run: python benchmarks/env_throughput.py [--episodes N] [--agents random myopic ...]

Each agent plays N seeded episodes of 140 scans after one untimed warm-up episode (numba kernels load from their
cache on first use). The myopic figure includes ``lookahead_costs`` every step.
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym

import uwb_env  # noqa: F401
from agents import make_scheduler, scheduler_names


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--episodes", type=int, default=5)
    ap.add_argument("--env", default="uwb_env/UrbanWaveform-v0")
    ap.add_argument("--agents", nargs="+", default=["random", "myopic"], help=f"scheduler names: {scheduler_names()}")
    args = ap.parse_args()
    env = gym.make(args.env)
    for name in args.agents:
        agent = make_scheduler(name)
        steps, elapsed = 0, 0.0
        for seed in range(-1, args.episodes):  # seed -1: warm-up, not timed
            episode_seed = 1000 if seed < 0 else seed
            obs, _ = env.reset(seed=episode_seed)
            agent.reset(episode_seed)
            done = False
            t0 = time.perf_counter()
            while not done:
                obs, _, done, _, _ = env.step(agent.act(obs, env))
                steps += seed >= 0
            if seed >= 0:
                elapsed += time.perf_counter() - t0
        print(f"{args.env} {name:12s} {steps / elapsed:8.0f} steps/s ({steps} steps)")


if __name__ == "__main__":
    main()
