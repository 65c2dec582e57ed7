"""Tracker throughput on urban-intersection (2 targets, VS-IMM of 4 UKF models, 2 receivers, clutter), one process.

Run: python benchmarks/tracker_throughput.py [--episodes N] [--backend compiled|numpy]

Detections are generated first (parametric sensing, round-robin waveforms, the tracker's sensor-model Pd
precomputed per scan); then ``Tracker.step`` is timed alone: prediction (VS-IMM switch, mixing, Kalman
prediction), the receiver-by-receiver LMIPDA updates, initiation and track management. Prints scans/s and the
per-stage share, and the mean number of live tracks (tentative included).
"""

from __future__ import annotations

import argparse
import time
from collections import defaultdict

import numpy as np

from uwb_env import scenarios
from uwb_env.rng import RngStreams
from uwb_env.scene import sample_truth
from uwb_env.sensing import ParametricSensor, ScanPlan
from uwb_env.tracking import Tracker
from uwb_env.tracking.reference import ReferenceTracker


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--episodes", type=int, default=10)
    ap.add_argument("--scenario", default="urban-intersection")
    ap.add_argument("--backend", default="compiled", choices=("compiled", "numpy"))
    args = ap.parse_args()
    cfg = scenarios.get(args.scenario)
    sensor = ParametricSensor(cfg)
    lay = sensor.layout
    plans = [ScanPlan.all_listening(w, sensor.n_tx, sensor.n_rx) for w in range(len(sensor.library))]
    episodes = []
    for seed in range(args.episodes):
        rngs = RngStreams.from_seed(seed)
        ep = sensor.new_episode(sample_truth(cfg, rngs.truth, lay), rngs)
        episodes.append(
            [
                sensor.sense(ep, k, plans[k % len(plans)], k * cfg.sensing.scan_period_s)
                for k in range(1, cfg.n_scans + 1)
            ]
        )

    # the sensor-model Pd, looked up from a table filled outside the timed loop
    state: dict[str, object] = {}
    pd_table: dict[tuple[int, int, int, int], np.ndarray] = {}

    def pd_model(tx: int, rx: int, pos: np.ndarray) -> np.ndarray:
        key = (state["episode"], state["k"], tx, rx)
        if key not in pd_table:
            w = int(plans[state["k"] % len(plans)].waveform[tx])
            pd_table[key] = np.minimum(
                sensor.detection_probability_at(
                    tx, rx, pos, w, cfg.tracker.assumed_rcs_m2, cfg.tracker.assumed_swerling
                ),
                cfg.tracker.max_detection_probability,
            )
        p = pd_table[key]
        return p if p.shape[0] == pos.shape[0] else np.full(pos.shape[0], float(p.mean()) if p.size else 0.9)

    stage = defaultdict(float)

    def timed(name, fn):
        def wrapper(*a, **kw):
            t0 = time.perf_counter()
            out = fn(*a, **kw)
            stage[name] += time.perf_counter() - t0
            return out

        return wrapper

    total, n_scans, n_tracks = 0.0, 0, []
    for rep in range(2):  # first pass fills the Pd table (not timed), second is measured
        stage.clear()
        total, n_scans, n_tracks = 0.0, 0, []
        for e, scans in enumerate(episodes):
            kind = ReferenceTracker if args.backend == "numpy" else Tracker
            tr = kind(cfg.tracker, lay.tx_pos, lay.rx_pos, lay.area, pd_model)
            if rep == 1:
                tr._predict = timed("predict (VS-IMM switch, mixing, Kalman)", tr._predict)
                tr._update = timed("update (gating, LMIPDA, PDA, per receiver)", tr._update)
                tr._initiate = timed("initiation (candidates, two-point)", tr._initiate)
            for k, dets in enumerate(scans, 1):
                state["episode"], state["k"] = e, k
                t0 = time.perf_counter()
                t = tr.step(dets, k * cfg.sensing.scan_period_s, k)
                total += time.perf_counter() - t0
                n_scans += 1
                n_tracks.append(len(t))
    print(
        f"{args.scenario}: {n_scans} tracker scans, {n_scans / total:.0f} scans/s "
        f"({1e3 * total / n_scans:.2f} ms/scan), live tracks {np.mean(n_tracks):.1f} mean, {np.max(n_tracks)} max"
    )
    other = total - sum(stage.values())
    for name, t in [*sorted(stage.items(), key=lambda kv: -kv[1]), ("confirmation / deletion / other", other)]:
        print(f"  {name:45s} {1e3 * t / n_scans:7.3f} ms/scan  {100 * t / total:5.1f} %")


if __name__ == "__main__":
    main()
