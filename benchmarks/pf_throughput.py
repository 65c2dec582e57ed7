"""Seed 002's particle filter on indoor-monostatic: per-scan time beside the IMM tracker.

Run: python benchmarks/pf_throughput.py [--episodes N] [--particles N]

Throughput: detections are generated first (parametric sensing, every radar on the 128-pulse waveform, all
listening); then ``step`` of each tracker is timed alone on the same detections: the PF (``TrackerConfig.kind =
"pf"``, its default ``PfConfig``) with the sensor model's Pd evaluated at every particle (that call is timed with it
and its share printed), the PF with a constant Pd, and the VS-IMM / LMIPDA tracker of the scenario with the same
sensor-model Pd.

The seed's NEO figures (Figs. 2-4) are ``scripts/seed002_neo.py`` (``uwb_env.agents.studies.seed002_neo``).
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

from uwb_env import scenarios
from uwb_env.config import PfConfig, ScenarioConfig
from uwb_env.metrics import error_at_outage
from uwb_env.rng import RngStreams
from uwb_env.scene import sample_truth
from uwb_env.sensing.protocol import make_sensor
from uwb_env.sensing.records import ScanPlan
from uwb_env.tracking.registry import make_tracker


def episodes(cfg: ScenarioConfig, n: int, waveform: int = 0):
    """Sensor, per-episode (truth, detections per scan) for seeds 0..n-1."""
    sensor = make_sensor(cfg)
    plan = ScanPlan.all_listening(waveform, sensor.n_tx, sensor.n_rx)
    out = []
    for seed in range(n):
        rngs = RngStreams.from_seed(seed)
        truth = sample_truth(cfg, rngs.truth, sensor.layout)
        ep = sensor.new_episode(truth, rngs)
        dets = [sensor.sense(ep, k, plan, k * cfg.sensing.scan_period_s) for k in range(1, cfg.n_scans + 1)]
        out.append((truth, dets, seed))
    return sensor, out


def run(cfg: ScenarioConfig, tracker_cfg, sensor, eps, waveform: int = 0, sensor_pd: bool = True, confirmed=True):
    """Per-scan errors, step time [s] and Pd-model time [s] of the tracker over the episodes.

    The error of a scan: the nearest confirmed track's (``confirmed``) or the nearest track's; nan without one.
    """
    pd_time = [0.0]

    def pd(tx: int, rx: int, pos: np.ndarray) -> np.ndarray:
        t0 = time.perf_counter()
        p = sensor.detection_probability_at(
            tx, rx, pos, waveform, tracker_cfg.assumed_rcs_m2, tracker_cfg.assumed_swerling
        )
        pd_time[0] += time.perf_counter() - t0
        return np.minimum(p, tracker_cfg.max_detection_probability)

    trk = make_tracker(tracker_cfg, sensor.layout, pd if sensor_pd else None)
    errors, total = [], 0.0
    for truth, dets, seed in eps:
        trk.reset(RngStreams.from_seed(seed).tracker)
        for k, d in enumerate(dets, 1):
            t0 = time.perf_counter()
            tracks = trk.step(d, k * cfg.sensing.scan_period_s, k)
            total += time.perf_counter() - t0
            x, _ = tracks.combined()
            c = np.flatnonzero(tracks.confirmed if confirmed else np.ones(len(tracks), bool))
            if c.size:
                e = np.linalg.norm(x[c][:, [0, 2]] - truth.states[k, 0, [0, 2]], axis=1).min()
            else:
                e = np.nan
            errors.append(e)
    return np.array(errors), total, pd_time[0]


def throughput(args: argparse.Namespace) -> None:
    cfg = scenarios.get("indoor-monostatic")
    sensor, eps = episodes(cfg, args.episodes)
    n = sum(len(d) for _, d, _ in eps)
    pf = dataclasses.replace(cfg.tracker, kind="pf", pf=PfConfig(n_particles=args.particles))
    rows = [
        ("PF (sensor-model Pd per particle)", pf, True),
        ("PF (constant Pd)", pf, False),
        ("IMM-LMIPDA (sensor-model Pd)", cfg.tracker, True),
    ]
    print(f"indoor-monostatic: {args.episodes} episodes x {cfg.n_scans} scans, {args.particles} particles")
    for name, tc, use_pd in rows:
        run(cfg, tc, sensor, eps[:1], sensor_pd=use_pd)  # warm-up (numba compilation, caches)
        errors, total, pd_t = run(cfg, tc, sensor, eps, sensor_pd=use_pd)
        ok = errors[np.isfinite(errors)]
        share = f", Pd model {1e3 * pd_t / n:.2f} ms" if use_pd else ""
        print(
            f"  {name:36s} {1e3 * total / n:6.2f} ms/scan{share}; confirmed-track error: "
            f"80 % point {error_at_outage(ok):.2f} m, {ok.size / n:.0%} of scans held"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--episodes", type=int, default=5)
    ap.add_argument("--particles", type=int, default=PfConfig().n_particles)
    throughput(ap.parse_args())


if __name__ == "__main__":
    main()
