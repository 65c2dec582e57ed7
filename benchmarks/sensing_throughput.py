"""Parametric sensing throughput (scans per second) for every scenario, in one process.

Run: python benchmarks/sensing_throughput.py [--episodes N] [--repeats R] [--set KEY=VALUE ...]
(e.g. ``--set sensing.measure_doa=false``: YAML values, dotted keys of the scenario config)

Each episode is what an environment does: draw the truth, ``ParametricSensor.new_episode`` (geometry and all
plan-independent draws), then ``sense()`` every scan with a round-robin waveform plan. The headline figure
"scans/s (episode)" divides the scans by the *whole* time, reset included; "scans/s (sense)" is the per-scan call
alone. Each figure is the median of R repeats (min-max in brackets): this shared 2-core machine is noisy.
"""

from __future__ import annotations

import argparse
import statistics
import time

import yaml

from uwb_env import scenarios
from uwb_env.rng import RngStreams
from uwb_env.scene import sample_truth
from uwb_env.sensing import ParametricSensor, ScanPlan


def measure(name: str, n_episodes: int, overrides: dict | None = None) -> dict[str, float]:
    cfg = scenarios.get(name, **(overrides or {}))
    sensor = ParametricSensor(cfg)
    n_w = len(sensor.library)
    plans = [ScanPlan.all_listening(w, sensor.n_tx, sensor.n_rx) for w in range(n_w)]
    dt = cfg.sensing.scan_period_s
    t_reset = t_sense = 0.0
    n_scans = 0
    for ep in range(n_episodes + 2):
        t0 = time.perf_counter()
        rngs = RngStreams.from_seed(ep)
        truth = sample_truth(cfg, rngs.truth, sensor.layout)
        episode = sensor.new_episode(truth, rngs)
        t1 = time.perf_counter()
        for k in range(1, cfg.n_scans + 1):
            sensor.sense(episode, k, plans[k % n_w], k * dt)
        t2 = time.perf_counter()
        if ep >= 2:  # two warm-up episodes
            t_reset += t1 - t0
            t_sense += t2 - t1
            n_scans += cfg.n_scans
    return {
        "targets": len(cfg.targets),
        "pairs": sensor.pairs.shape[0],
        "scans": n_scans,
        "episode": n_scans / (t_reset + t_sense),
        "sense": n_scans / t_sense,
        "reset_ms": 1e3 * t_reset / n_episodes,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--episodes", type=int, default=100)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="scenario override")
    args = ap.parse_args()
    overrides = {k: yaml.safe_load(v) for k, v in (item.split("=", 1) for item in args.set)}
    head = f"{'scenario':20s} {'targets':>7s} {'pairs':>5s} {'scans/s (episode)':>24s} {'scans/s (sense)':>24s}"
    print(head + f" {'reset ms/episode':>17s}")
    for name in scenarios.names():
        runs = [measure(name, args.episodes, overrides) for _ in range(args.repeats)]

        def fmt(key: str, runs: list[dict[str, float]] = runs) -> str:
            v = [r[key] for r in runs]
            return f"{statistics.median(v):.0f} [{min(v):.0f}-{max(v):.0f}]"

        r = runs[0]
        reset = statistics.median(x["reset_ms"] for x in runs)
        print(f"{name:20s} {r['targets']:7d} {r['pairs']:5d} {fmt('episode'):>24s} {fmt('sense'):>24s} {reset:17.2f}")


if __name__ == "__main__":
    main()
