"""Interleaved A/B of env steps per second across source trees (a shared, noisy machine: rounds alternate trees).

Run: python benchmarks/ab_throughput.py TREE[=ENV_ID] ... [--rounds 3] [--episodes 3] [--agents myopic random]

Each round plays, for every tree in turn, a fresh process with ``PYTHONPATH=TREE`` that times ``--episodes`` seeded
episodes per agent after one untimed warm-up episode (``env_throughput.py``'s loop; ENV_ID defaults to
``uwb_env/UrbanWaveform-v3``). Reported per tree and agent over the rounds: the median and best steps/s of wall
time and of the process's CPU time (``time.process_time``: less disturbed by other jobs on the machine).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys

HARNESS = r"""
import json, sys, time
import gymnasium as gym
import uwb_env
from uwb_env.agents import make_scheduler
env_id, episodes, agents = sys.argv[1], int(sys.argv[2]), sys.argv[3].split(",")
env = gym.make(env_id)
out = {}
for name in agents:
    agent = make_scheduler(name)
    for seeds in ([1000], range(episodes)):  # warm-up, then timed
        steps, wall, cpu = 0, 0.0, 0.0
        for seed in seeds:
            obs, _ = env.reset(seed=seed)
            agent.reset(seed)
            done = False
            t0, c0 = time.perf_counter(), time.process_time()
            while not done:
                obs, _, term, trunc, _ = env.step(agent.act(obs, env))
                done = term or trunc
                steps += 1
            wall += time.perf_counter() - t0
            cpu += time.process_time() - c0
    out[name] = (steps / wall, steps / cpu)
print(json.dumps(out))
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("trees", nargs="+", help="TREE or TREE=ENV_ID")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--episodes", type=int, default=3)
    ap.add_argument("--agents", nargs="+", default=["myopic", "random"])
    args = ap.parse_args()
    specs = [[*t.split("=", 1), "uwb_env/UrbanWaveform-v3"][:2] for t in args.trees]
    rates: dict[tuple[str, str], list[tuple[float, float]]] = {}
    for _ in range(args.rounds):
        for tree, env_id in specs:
            cmd = [sys.executable, "-c", HARNESS, env_id, str(args.episodes), ",".join(args.agents)]
            env = {**os.environ, "PYTHONPATH": tree}
            out = subprocess.run(cmd, cwd=tree, env=env, capture_output=True, text=True, check=True).stdout
            for agent, r in json.loads(out.splitlines()[-1]).items():
                rates.setdefault((tree, agent), []).append(tuple(r))
    for tree, env_id in specs:
        for agent in args.agents:
            wall = [w for w, _ in rates[(tree, agent)]]
            cpu = [c for _, c in rates[(tree, agent)]]
            print(
                f"{tree:18s} {env_id:26s} {agent:7s} wall median {statistics.median(wall):5.0f} best {max(wall):5.0f}"
                f" | cpu median {statistics.median(cpu):5.0f} best {max(cpu):5.0f} steps/s"
                f" (cpu rounds: {' '.join(f'{x:.0f}' for x in cpu)})"
            )


if __name__ == "__main__":
    main()
