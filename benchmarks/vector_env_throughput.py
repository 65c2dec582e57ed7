"""Env-steps/s of the batched vector env beside the single env and Gymnasium's sync / async vector envs (issue 19).

On ``UrbanWaveform`` (parametric), with random and myopic actions (myopic: the argmin of the lookahead costs, which
the batched env computes for all N at once and the others env by env). The machines are shared and noisy, so the
variants are measured in interleaved rounds (each round times every variant for ``--seconds``) and the table gives
each one's median over the rounds and its ratio to the single env's median in the same run.

    python benchmarks/vector_env_throughput.py                       # N = 1, 16, 64, 256; 3 rounds
    python benchmarks/vector_env_throughput.py --n 64 --rounds 5 --no-async
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import gymnasium as gym
import numpy as np

import uwb_env
from uwb_env.envs import ENV_IDS

gym.register_envs(uwb_env)
ENV_ID = next(i for i in ENV_IDS if i.startswith("uwb_env/UrbanWaveform"))


def _single_runner(policy: str) -> Callable[[float], float]:
    env = gym.make(ENV_ID).unwrapped
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    n_actions = env.action_space.n

    def act() -> int:
        return int(np.argmin(env.lookahead_costs())) if policy == "myopic" else int(rng.integers(n_actions))

    def run(seconds: float) -> float:
        n, t0 = 0, time.perf_counter()
        while time.perf_counter() - t0 < seconds:
            if env.step(act())[3]:
                env.reset()
            n += 1
        return n / (time.perf_counter() - t0)

    return run


def _vector_runner(mode: str, num_envs: int, policy: str) -> Callable[[float], float]:
    venv = gym.make_vec(ENV_ID, num_envs=num_envs, vectorization_mode=mode)
    venv.reset(seed=0)
    rng = np.random.default_rng(0)
    n_actions = venv.single_action_space.n

    def act() -> np.ndarray:
        if policy == "random":
            return rng.integers(0, n_actions, num_envs)
        if mode == "vector_entry_point":
            return np.argmin(venv.lookahead_costs(), axis=1)
        return np.array([np.argmin(c) for c in venv.call("lookahead_costs")])

    def run(seconds: float) -> float:
        n, t0 = 0, time.perf_counter()
        while time.perf_counter() - t0 < seconds:
            venv.step(act())
            n += num_envs
        return n / (time.perf_counter() - t0)

    return run


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, nargs="+", default=[1, 16, 64, 256], help="numbers of envs")
    ap.add_argument("--policy", nargs="+", default=["random", "myopic"], choices=["random", "myopic"])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--seconds", type=float, default=2.0, help="per variant and round")
    ap.add_argument("--no-async", action="store_true", help="skip Gymnasium's async vector env")
    ap.add_argument("--no-sync", action="store_true", help="skip Gymnasium's sync vector env")
    args = ap.parse_args()
    for policy in args.policy:
        variants: dict[str, Callable[[float], float]] = {"single env": _single_runner(policy)}
        for n in args.n:
            variants[f"batched N={n}"] = _vector_runner("vector_entry_point", n, policy)
            if not args.no_sync and n <= 64:
                variants[f"sync N={n}"] = _vector_runner("sync", n, policy)
            if not args.no_async and n in (16,):  # a process per env: 2 cores here
                variants[f"async N={n}"] = _vector_runner("async", n, policy)
        for run in variants.values():  # warm-up: compile and fill caches
            run(0.3)
        rates: dict[str, list[float]] = {k: [] for k in variants}
        for _ in range(args.rounds):
            for name, run in variants.items():
                rates[name].append(run(args.seconds))
        base = float(np.median(rates["single env"]))
        print(f"\n{ENV_ID} (parametric), {policy} actions, median of {args.rounds} interleaved rounds")
        print(f"{'variant':<18} {'env-steps/s':>12} {'x single':>9}")
        for name, r in rates.items():
            med = float(np.median(r))
            print(f"{name:<18} {med:>12.0f} {med / base:>9.2f}")


if __name__ == "__main__":
    main()
