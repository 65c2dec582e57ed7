"""Particle PHD tracker throughput on indoor-rsn (one person, 1 Tx + 6 Rx), one process, beside the IMM tracker.

Run: python benchmarks/phd_throughput.py [--episodes N] [--particles P]

Detections are generated first (parametric sensing, every receiver listening with the seed's Ns = 20480 waveform):
per-pair bistatic ranges. Then each tracker's ``step`` is timed alone on the same detections, its sensor-model Pd
included (the parametric radar equation, the simulator's ``rx = -1`` rule for the PHD's fused positions):

- ``PhdTracker`` (``uwb_env.tracking.phd``, ``PhdConfig.particles_per_target`` particles per target): the network
  chain that fuses the ranges into positions (``localization.locate``, reported separately), the SMC-PHD
  prediction / update / birth / resampling, EM peak extraction, association and the track state machine;
- ``Tracker`` (VS-IMM / LMIPDA, the scenario's tracker configuration) on the per-pair ranges.

The first episode of each tracker warms its compiled kernels and is not timed. Prints scans/s, ms/scan, the mean
particle count and the PHD's position error against the truth (nearest confirmed track) as a sanity figure.
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

from uwb_env import scenarios
from uwb_env.config import PhdConfig
from uwb_env.localization import network
from uwb_env.rng import RngStreams
from uwb_env.scene import sample_truth
from uwb_env.sensing import ParametricSensor, ScanPlan
from uwb_env.sim import at_least
from uwb_env.tracking import Tracker
from uwb_env.tracking.phd import PhdTracker


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--episodes", type=int, default=10)
    ap.add_argument("--particles", type=int, default=PhdConfig().particles_per_target)
    args = ap.parse_args()
    cfg = scenarios.get("indoor-rsn")
    sensor = ParametricSensor(cfg)
    lay, tc = sensor.layout, cfg.tracker
    plan = ScanPlan.all_listening(0, sensor.n_tx, sensor.n_rx)
    dt = cfg.sensing.scan_period_s
    episodes, truths, tracker_rngs = [], [], []
    for seed in range(args.episodes + 1):  # +1: the warm-up episode
        rngs = RngStreams.from_seed(seed)
        truth = sample_truth(cfg, rngs.truth, lay)
        ep = sensor.new_episode(truth, rngs)
        episodes.append([sensor.sense(ep, k, plan, k * dt) for k in range(1, cfg.n_scans + 1)])
        truths.append(truth)
        tracker_rngs.append(rngs.tracker)

    def pair_pd(tx: int, rx: int, pos: np.ndarray) -> np.ndarray:
        if rx >= 0:
            pd = sensor.detection_probability_at(tx, rx, pos, 0, tc.assumed_rcs_m2, tc.assumed_swerling)
        else:  # the network's fused position: at least nu receivers detect (uwb_env.sim)
            per_pair = np.array(
                [
                    sensor.detection_probability_at(t, r, pos, 0, tc.assumed_rcs_m2, tc.assumed_swerling)
                    for t, r in sensor.pairs.tolist()
                ]
            )
            pd = at_least(per_pair, cfg.sensing.signal.nu)
        return np.minimum(pd, tc.max_detection_probability)

    phd_cfg = dataclasses.replace(tc, kind="phd", phd=dataclasses.replace(tc.phd, particles_per_target=args.particles))
    locate_time = [0.0]
    original_locate = network.locate

    def timed_locate(*a, **kw):  # type: ignore[no-untyped-def]
        t0 = time.perf_counter()
        out = original_locate(*a, **kw)
        locate_time[0] += time.perf_counter() - t0
        return out

    import uwb_env.tracking.phd as phd_module

    phd_module.locate = timed_locate  # type: ignore[assignment]
    phd = PhdTracker.from_layout(phd_cfg, lay, pair_pd)
    imm = Tracker(tc, lay.tx_pos, lay.rx_pos, lay.area, pair_pd)
    results = {}
    for name, trk in (("phd", phd), ("imm", imm)):
        total, n_scans, particles, errors = 0.0, 0, [], []
        locate_time[0] = 0.0
        for e, scans in enumerate(episodes):
            if name == "phd":
                trk.reset(tracker_rngs[e])
            else:
                trk.reset()
            if e == 1:  # the warm-up episode is over
                total, n_scans, particles, errors = 0.0, 0, [], []
                locate_time[0] = 0.0
            for k, dets in enumerate(scans, start=1):
                t0 = time.perf_counter()
                t = trk.step(dets, k * dt, k)
                total += time.perf_counter() - t0
                n_scans += 1
                if name == "phd":
                    particles.append(trk.particles.shape[0])
                if t.confirmed.any():
                    x, _ = t.combined()
                    d = np.linalg.norm(x[t.confirmed][:, [0, 2]] - truths[e].states[k][0, [0, 2]], axis=-1)
                    errors.append(d.min())
        results[name] = (total, n_scans, locate_time[0], particles, errors)
    for name, (total, n, loc, particles, errors) in results.items():
        line = f"{name}: {n / total:8.1f} scans/s  {1e3 * total / n:6.3f} ms/scan"
        if name == "phd":
            line += (
                f"  (network chain {1e3 * loc / n:.3f} ms/scan; {args.particles} particles per target,"
                f" mean {np.mean(particles):.0f} particles)"
            )
        line += f"  median error to the nearest confirmed track {np.median(errors):.3f} m over {len(errors)} scans"
        print(line)
    ratio = results["phd"][0] / results["imm"][0]
    print(f"phd / imm per-scan time: {ratio:.2f}  ({args.episodes} episodes of 61 scans)")


if __name__ == "__main__":
    main()
