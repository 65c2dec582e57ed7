"""Joint-plan lookahead on UrbanDistributed-v0: decisions/s of myopic and lookahead-3, and myopic env steps/s.

Run: python benchmarks/joint_lookahead.py [--episodes N] [--repeats K] [--depth D] [--beam B] [--compare S]

Decisions: the tracker states of ``--episodes`` seeded myopic episodes (every 5th scan from scan 20, where tracks
exist), each asked for the myopic costs (``lookahead_costs``: one expected update per plan, 64 joint plans of 8
chirps x 2 transmitters) and the depth-D beam-B sequence costs (``sequence_costs``: 64 + (D - 1) B 64 plan
evaluations; then beams 16 and 64 and depth 2 exhaustive, once), CPU time per decision; both with the shared-prefix
evaluation (``lookahead._PlanTable.pair_groups``: the first transmitter's pairs updated once per waveform, 8 groups,
not once per joint plan) and without it (every plan's own update), interleaved, with their costs compared to the bit.

Env: myopic steps/s (``env.step`` plus the myopic decision) on UrbanDistributed-v0 and UrbanWaveform-v3 in the same
run (their ratio), ``--episodes`` seeded episodes after one untimed warm-up, ``--repeats`` times; and the share of
the distributed env's step spent in the tracker's range-only initiation (``initiation.initiate_compiled``; its
3-tuples across the two nodes, ``uwb_env.tracking.initiation``). Reported: median and best over the repeats (a
shared 2-core box varies by +-10 % and sometimes 2x: the best is the least disturbed).

``--compare S [--schemes ...]``: the schedulers paired on seeds 0..S-1, against the first: the return, the mean
trace on targets, their paired differences with standard errors, and how often each sends different waveforms from
the two transmitters. By default what choosing per transmitter is worth: ``myopic`` (argmin over the 64 joint
plans) against ``myopic-common`` (over the 8 plans where both transmitters send one waveform), with ``lookahead-3``
(beam 4) and ``round-robin``.
"""

from __future__ import annotations

import argparse
import copy
import statistics
import time

import gymnasium as gym
import numpy as np

import uwb_env  # noqa: F401
from uwb_env import lookahead
from uwb_env.agents import make_scheduler
from uwb_env.tracking import tracker as tracker_module

_SHARED = lookahead._PlanTable.pair_groups


def _plain(self, pairs):  # every plan its own update (the evaluation without shared prefixes)
    return None


def tracked_states(episodes: int) -> list:
    """Deep copies of UrbanDistributed-v0 along seeded myopic episodes, every 5th scan from 20 (with tracks)."""
    env = gym.make("uwb_env/UrbanDistributed-v0")
    agent = make_scheduler("myopic")
    states = []
    for seed in range(episodes):
        obs, _ = env.reset(seed=seed)
        agent.reset(seed)
        while not env.unwrapped.sim.done:
            obs, *_ = env.step(agent.act(obs, env))
            k = env.unwrapped.sim.k
            if k >= 20 and k % 5 == 0 and len(env.unwrapped.sim.tracker.tracks):
                states.append(copy.deepcopy(env.unwrapped))
    return states


def decisions_per_s(states: list, fn, repeats: int) -> tuple[list[float], list[np.ndarray]]:
    """CPU-time decisions/s of ``fn(env)`` over the states, ``repeats`` times; and the last round's outputs.

    One untimed pass first: a state's first call fills its caches (the tracker's prediction, the sensor's links).
    """
    for e in states:
        fn(e)
    rates, out = [], []
    for _ in range(repeats):
        t0 = time.process_time()
        out = [fn(e) for e in states]
        rates.append(len(states) / (time.process_time() - t0))
    return rates, out


def env_steps_per_s(env_id: str, episodes: int, repeats: int) -> tuple[list[float], float]:
    """Myopic steps/s (CPU time) per repeat, and the share of the last repeat spent in range-only initiation."""
    env = gym.make(env_id)
    agent = make_scheduler("myopic")
    spent = [0.0]
    inner = tracker_module.initiate_compiled

    def timed(*args, **kwargs):
        t = time.process_time()
        try:
            return inner(*args, **kwargs)
        finally:
            spent[0] += time.process_time() - t

    def play(seed: int) -> int:
        obs, _ = env.reset(seed=seed)
        agent.reset(seed)
        steps = 0
        while not env.unwrapped.sim.done:
            obs, *_ = env.step(agent.act(obs, env))
            steps += 1
        return steps

    play(1000)  # warm-up: numba kernels load from their cache
    rates, share = [], 0.0
    tracker_module.initiate_compiled = timed
    try:
        for _ in range(repeats):
            spent[0] = 0.0
            t0 = time.process_time()
            steps = sum(play(seed) for seed in range(episodes))
            total = time.process_time() - t0
            rates.append(steps / total)
            share = spent[0] / total
    finally:
        tracker_module.initiate_compiled = inner
    return rates, share


def compare(seeds: int, schemes: list[str]) -> None:
    """Paired episodes of ``schemes`` on UrbanDistributed-v0, differences against the first (module docstring)."""
    env = gym.make("uwb_env/UrbanDistributed-v0")
    out: dict[str, np.ndarray] = {}
    mixed = {}
    for name in schemes:
        agent = make_scheduler(name)
        rows, n_mixed, n_total = [], 0, 0
        for seed in range(seeds):
            obs, _ = env.reset(seed=seed)
            agent.reset(seed)
            ret, traces = 0.0, []
            while not env.unwrapped.sim.done:
                a = agent.act(obs, env)
                w = env.unwrapped.plans[env.unwrapped.plan_index(a)].waveform
                n_mixed += int(w[0] != w[1])
                n_total += 1
                obs, reward, _, _, info = env.step(a)
                ret += reward
                if info["target_covariance_trace"] > 0.0:
                    traces.append(info["target_covariance_trace"])
            rows.append((ret, float(np.mean(traces)) if traces else 0.0))
        out[name], mixed[name] = np.array(rows), 100.0 * n_mixed / n_total
    ref = schemes[0]
    print(f"{seeds} paired seeds on UrbanDistributed-v0, differences against {ref} (mean +- standard error):")
    print(
        f"  {'scheme':14s} {'return':>10s} {'diff':>18s} {'trace on targets':>17s} {'diff':>20s} {'mixed plans':>11s}"
    )
    for name, v in out.items():
        d = v - out[ref]
        se = d.std(axis=0, ddof=1) / np.sqrt(seeds) if seeds > 1 else np.zeros(2)
        print(
            f"  {name:14s} {v[:, 0].mean():10.1f} {d[:, 0].mean():+9.1f} +- {se[0]:6.1f} {v[:, 1].mean():13.4f} m^2 "
            f"{d[:, 1].mean():+9.4f} +- {se[1]:.4f} {mixed[name]:10.1f} %"
        )


def _summary(rates: list[float]) -> str:
    return f"median {statistics.median(rates):7.0f} best {max(rates):7.0f} ({' '.join(f'{r:.0f}' for r in rates)})"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--episodes", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--depth", type=int, default=3)
    ap.add_argument("--beam", type=int, default=4)
    ap.add_argument("--compare", type=int, default=0, help="paired seeds of the --schemes (0: skip)")
    ap.add_argument("--schemes", nargs="+", default=["myopic", "myopic-common", "lookahead-3", "round-robin"])
    args = ap.parse_args()
    if args.compare:
        compare(args.compare, args.schemes)
    states = tracked_states(args.episodes)
    n_tracks = [len(e.sim.tracker.tracks) for e in states]
    print(
        f"UrbanDistributed-v0: {len(states[0].plans)} joint plans, {len(states)} tracker states "
        f"({min(n_tracks)}-{max(n_tracks)} tracks, mean {np.mean(n_tracks):.1f})"
    )
    results = {}
    for label, groups in (("shared prefixes", _SHARED), ("every plan", _plain)) * args.repeats:
        lookahead._PlanTable.pair_groups = groups
        lookahead._PLAN_TABLES.clear()
        try:
            my, my_out = decisions_per_s(states, lambda e: e.lookahead_costs(), 1)
            la, la_out = decisions_per_s(states, lambda e: e.sequence_costs(args.depth, args.beam), 1)
        finally:
            lookahead._PlanTable.pair_groups = _SHARED
            lookahead._PLAN_TABLES.clear()
        r = results.setdefault(label, {"myopic": [], "lookahead": [], "out": (my_out, la_out)})
        r["myopic"] += my
        r["lookahead"] += la
    same = all(
        np.array_equal(a, b)
        for k in (0, 1)
        for a, b in zip(results["shared prefixes"]["out"][k], results["every plan"]["out"][k], strict=True)
    )
    for label, r in results.items():
        print(f"  {label:16s} myopic decisions/s      {_summary(r['myopic'])}")
        print(f"  {label:16s} lookahead-{args.depth} (beam {args.beam}) /s {_summary(r['lookahead'])}")
    print(f"  costs identical with and without shared prefixes: {same}")
    for beam in (16, 64, None):  # wider beams (None: every sequence; depth 2 only, 64^2 sequences)
        depth = args.depth if beam is not None else 2
        rates, _ = decisions_per_s(states, lambda e, d=depth, b=beam: e.sequence_costs(d, b), 1)
        print(f"  lookahead-{depth} beam {beam if beam else 'none (exhaustive)'}: {rates[0]:.0f} decisions/s")
    dist, share = env_steps_per_s("uwb_env/UrbanDistributed-v0", args.episodes, args.repeats)
    base, base_share = env_steps_per_s("uwb_env/UrbanWaveform-v3", args.episodes, args.repeats)
    print(f"myopic env steps/s UrbanDistributed-v0 {_summary(dist)}; range-only initiation {100 * share:.0f} %")
    print(f"myopic env steps/s UrbanWaveform-v3    {_summary(base)}; range-only initiation {100 * base_share:.0f} %")
    print(f"ratio distributed / v3 (medians): {statistics.median(dist) / statistics.median(base):.2f}")


if __name__ == "__main__":
    main()
