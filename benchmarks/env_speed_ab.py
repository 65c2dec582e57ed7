"""Myopic env steps/s of two source trees, interleaved in one run (a before/after on a shared, noisy machine).

Run: python benchmarks/env_speed_ab.py --trees OLD NEW [--envs ID ...] [--episodes N] [--repeats K]

Each tree is a directory holding a ``uwb_env`` package (and ``uwb_env/agents``), e.g. a copy of the repository's
``uwb_env`` with ``agents`` copied into it, put first on ``PYTHONPATH``. For every repeat and env, every tree runs
in its own process in turn: one untimed warm-up episode (numba kernels load from their cache), then ``--episodes``
seeded myopic episodes (``env.step`` plus the myopic decision, resets included), CPU time. Reported per env and
tree: the median and best steps/s over the repeats, and the ratio of each tree's median to the first tree's (the
paired comparison: both trees saw the same load, repeat by repeat).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys

_CHILD = """
import sys, time
import gymnasium as gym
import uwb_env
from uwb_env.agents import make_scheduler
env_id, episodes = sys.argv[1], int(sys.argv[2])
env = gym.make(env_id)
agent = make_scheduler("myopic")
def play(seed):
    obs, _ = env.reset(seed=seed)
    agent.reset(seed)
    steps = 0
    while not env.unwrapped.sim.done:
        obs, *_ = env.step(agent.act(obs, env))
        steps += 1
    return steps
play(1000)
t0 = time.process_time()
steps = sum(play(seed) for seed in range(episodes))
print(steps / (time.process_time() - t0))
"""


def steps_per_s(tree: str, env_id: str, episodes: int) -> float:
    """One process of ``tree``: myopic steps/s (CPU time) over ``episodes`` seeded episodes of ``env_id``."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([os.path.abspath(tree), os.environ.get("PYTHONPATH", "")])}
    out = subprocess.run(
        [sys.executable, "-c", _CHILD, env_id, str(episodes)],
        env=env,
        cwd=tree,  # python -c puts the working directory first on sys.path: the tree's own package
        capture_output=True,
        text=True,
        check=True,
    )
    return float(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--trees", nargs=2, required=True, help="OLD NEW: directories holding a uwb_env package")
    ap.add_argument("--envs", nargs="+", default=["uwb_env/UrbanDistributed-v0", "uwb_env/UrbanWaveform-v3"])
    ap.add_argument("--episodes", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    rates: dict[tuple[str, str], list[float]] = {}
    for _ in range(args.repeats):
        for env_id in args.envs:
            for tree in args.trees:
                rates.setdefault((env_id, tree), []).append(steps_per_s(tree, env_id, args.episodes))
    for env_id in args.envs:
        ref = statistics.median(rates[(env_id, args.trees[0])])
        for tree in args.trees:
            r = rates[(env_id, tree)]
            print(
                f"{env_id:30s} {tree:24s} median {statistics.median(r):7.0f} best {max(r):7.0f} steps/s "
                f"({' '.join(f'{x:.0f}' for x in r)}); x{statistics.median(r) / ref:.2f} of the first tree"
            )


if __name__ == "__main__":
    main()
