"""Seed 001's signal path throughput on through-wall: scans per second of synthesis + the whole chain.

One scan: two pairs x 511 samples synthesised (room background, the two persons' scattering centres behind the wall,
noise), then the in-sensor chain (exponential-averaging background subtraction on the raw scans, envelope, advance
normalization, CA-CFAR, interval ToAs), the ToA association with step 6, wall compensation and the two-ellipse
intersection (``SignalSensor.sense``). Episodes of the scenario's 117 scans are played back to back in one process;
"scans/s (sense)" times ``sense`` alone, "scans/s (total)" includes each episode's truth and empty-room references.
The floor (issue 18): 200 scans/s on a 2-core machine.

Run: python benchmarks/through_wall_throughput.py [--scans 5000] [--repeats 3] [--set KEY=VALUE ...]
"""

from __future__ import annotations

import argparse
import statistics
import time

import yaml

from uwb_env import scenarios
from uwb_env.rng import RngStreams
from uwb_env.scene import sample_truth
from uwb_env.sensing import ScanPlan
from uwb_env.sensing.signal import SignalSensor

FLOOR_SCANS_PER_S = 200.0


def run(sensor: SignalSensor, n_scans: int, seed0: int) -> tuple[float, float, int]:
    """Play episodes until ``n_scans`` scans; returns (total time, sense time, scans)."""
    cfg = sensor.cfg
    plan = ScanPlan.all_listening(0, sensor.n_tx, sensor.n_rx)
    t_total = t_sense = 0.0
    done, ep = 0, seed0
    while done < n_scans:
        t0 = time.perf_counter()
        rngs = RngStreams.from_seed(ep)
        episode = sensor.new_episode(sample_truth(cfg, rngs.truth, sensor.layout), rngs)
        t1 = time.perf_counter()
        for k in range(1, cfg.n_scans + 1):  # scans of the episode
            sensor.sense(episode, k, plan)
        t2 = time.perf_counter()
        t_total += t2 - t0
        t_sense += t2 - t1
        done += cfg.n_scans
        ep += 1
    return t_total, t_sense, done


def main() -> None:
    """Time the chain and print scans/s against the floor."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scans", type=int, default=5000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE")
    args = ap.parse_args()
    overrides = {k: yaml.safe_load(v) for k, v in (s.split("=", 1) for s in args.set)}
    cfg = scenarios.get("through-wall", **{"sensing.fidelity": "signal", **overrides})
    sensor = SignalSensor(cfg)
    run(sensor, cfg.n_scans, 10_000)  # warm-up: numba compilation, FFT plans
    totals, senses = [], []
    for r in range(args.repeats):  # repeats: a few
        t_total, t_sense, n = run(sensor, args.scans, 100 * r)
        totals.append(n / t_total)
        senses.append(n / t_sense)
    best = max(senses)
    print(f"through-wall signal path, {cfg.sensing.signal.n_samples} samples x {len(sensor.pairs)} pairs per scan")
    print(f"scans/s (sense): median {statistics.median(senses):.0f}, best {best:.0f}")
    print(f"scans/s (total): median {statistics.median(totals):.0f}, best {max(totals):.0f}")
    met = statistics.median(senses) >= FLOOR_SCANS_PER_S
    print(f"floor {FLOOR_SCANS_PER_S:.0f} scans/s: {'met' if met else 'NOT met'}")


if __name__ == "__main__":
    main()
