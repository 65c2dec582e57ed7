"""Signal-level sensing throughput on indoor-rsn: full scans (6 pairs x 1920 samples, synthesis + in-sensor chain +
network chain) per second in one process, and the memory over 10^4 scans.

Run: python benchmarks/signal_throughput.py [--scans 10000] [--repeats 3] [--set KEY=VALUE ...]

Episodes of 61 scans are played back to back (truth, empty-room references and episode draws included in the time);
"scans/s (sense)" times the per-scan ``SignalSensor.sense`` alone. The resident set size is read from /proc before
and after, after a warm-up episode (numba compilation, FFT plans), to show that memory stays flat.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import yaml

from uwb_env import scenarios
from uwb_env.rng import RngStreams
from uwb_env.scene import sample_truth
from uwb_env.sensing import ScanPlan
from uwb_env.sensing.signal import SignalSensor


def rss_mib() -> float:
    """Resident set size of this process [MiB] (Linux /proc)."""
    pages = int(Path("/proc/self/statm").read_text().split()[1])
    return pages * 4096 / 2**20


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
        for k in range(1, cfg.n_scans + 1):
            sensor.sense(episode, k, plan)
        t2 = time.perf_counter()
        t_total += t2 - t0
        t_sense += t2 - t1
        done += cfg.n_scans
        ep += 1
    return t_total, t_sense, done


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scans", type=int, default=10_000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE")
    args = ap.parse_args()
    overrides = {k: yaml.safe_load(v) for k, v in (s.split("=", 1) for s in args.set)}
    cfg = scenarios.get("indoor-rsn", **{"sensing.fidelity": "signal", **overrides})
    sensor = SignalSensor(cfg)
    run(sensor, cfg.n_scans, 10_000)  # warm-up: compilation, caches
    rss0 = rss_mib()
    per_episode, per_sense = [], []
    for r in range(args.repeats):
        total, sense, n = run(sensor, args.scans if r == 0 else max(args.scans // 10, cfg.n_scans), 100 * r)
        per_episode.append(n / total)
        per_sense.append(n / sense)
        if r == 0:
            rss1 = rss_mib()
            print(f"memory: {rss0:.1f} MiB before, {rss1:.1f} MiB after {n} scans ({rss1 - rss0:+.1f} MiB)")
    pairs = sensor.pairs.shape[0]
    print(f"indoor-rsn, signal fidelity, {pairs} pairs x {cfg.sensing.signal.n_samples} samples, whole chain:")
    print(
        f"  scans/s (episode): {statistics.median(per_episode):.0f} "
        f"[{min(per_episode):.0f}-{max(per_episode):.0f}]; scans/s (sense): {statistics.median(per_sense):.0f} "
        f"[{min(per_sense):.0f}-{max(per_sense):.0f}] over {args.repeats} repeats"
    )


if __name__ == "__main__":
    main()
