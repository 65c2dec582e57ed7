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

import yaml
from signal_throughput import run  # the same timing loop as indoor-rsn's (benchmarks/ is the script's path)

from uwb_env import scenarios
from uwb_env.sensing.signal import SignalSensor

FLOOR_SCANS_PER_S = 200.0


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
