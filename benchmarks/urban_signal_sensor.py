"""Signal-level urban scan throughput: ``ChirpSignalSensor.sense`` on urban-intersection, 2 pairs, to detections.

One process, round-robin waveforms over the 6-waveform library, every receiver listening: per scan the draws of
both pairs (RCS, clutter phases and diffuse parts, thermal noise), the target paths (<= 3 bounces through the
vegetation), the matched-filtered spectra of the 3 DFT beams of each receiver, the delay-Doppler images, the
section-4.1 detection on every beam, the merge over the beams, the gate, the truth origin and the records. Episode
set-up (per-scan seeds, the fixed static spectrum, J = 10 clutter-only scans per waveform, thresholds) is timed
apart.

Run: python benchmarks/urban_signal_sensor.py [--episodes 3] [--profile]

Measured on the 2-core development machine (load ~0.4): 296-302 scans/s (3.3 ms a scan, 2 pairs, 3 beams each),
episode set-up ~0.2 s; 6.2 detections per pair-scan (0.91 on a vehicle, 4.6 noise, 0.7 static clutter, 0.01 ghosts).
Where a scan's time goes (pyinstrument): images (two FFTs per beam) 31 %, section-4.1 detection on the 6 beam images
26 %, the plan-independent draws (thermal noise of both pairs) 19 %, static clutter + noise spectra (compiled) 14 %,
merge over the beams 7 %, target paths 3 %. The hot path calls no multi-threaded BLAS (a loaded machine made
OpenBLAS's threads spin: 20 scans/s).
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from uwb_env import scenarios
from uwb_env.rng import RngStreams
from uwb_env.scene.truth import sample_truth
from uwb_env.sensing import ScanPlan
from uwb_env.sensing.signal import ChirpSignalSensor


def run(sensor: ChirpSignalSensor, seed: int) -> tuple[float, float, dict]:
    """One episode: set-up time [s], scans time [s], detection counts by truth origin."""
    cfg = sensor.cfg
    plans = [ScanPlan.all_listening(w, sensor.n_tx, sensor.n_rx) for w in range(len(sensor.library))]
    rngs = RngStreams.from_seed(seed)
    truth = sample_truth(cfg, rngs.truth, sensor.layout)
    t0 = time.perf_counter()
    ep = sensor.new_episode(truth, rngs)
    t1 = time.perf_counter()
    counts = {"detections": 0, "target": 0, "ghost": 0, "static": 0, "noise": 0}
    for k in range(1, cfg.n_scans + 1):
        dets = sensor.sense(ep, k, plans[k % len(plans)], k * cfg.sensing.scan_period_s)
        for d, tr in zip(dets, ep.last_trace, strict=True):
            o = tr.detections.origin
            counts["detections"] += len(d)
            counts["target"] += int((o >= 0).sum())
            counts["static"] += int((o == -1).sum())
            counts["ghost"] += int((o == -2).sum())
            counts["noise"] += int((o == -3).sum())
    return t1 - t0, time.perf_counter() - t1, counts


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--episodes", type=int, default=3)
    ap.add_argument("--profile", action="store_true", help="profile one episode with pyinstrument")
    args = ap.parse_args()
    cfg = scenarios.get("urban-intersection", **{"sensing.fidelity": "signal"})
    sensor = ChirpSignalSensor(cfg)
    run(sensor, 0)  # warm-up: numba (cached on disk), FFT plans
    if args.profile:
        from pyinstrument import Profiler  # optional: pip install pyinstrument

        prof = Profiler(interval=0.0002)
        prof.start()
        run(sensor, 1)
        prof.stop()
        print(prof.output_text(unicode=False, color=False, show_all=False))
        return
    rates, setups, total = [], [], {}
    for e in range(args.episodes):
        t_setup, t_scans, counts = run(sensor, 1 + e)
        rates.append(cfg.n_scans / t_scans)
        setups.append(t_setup)
        total = {k: total.get(k, 0) + v for k, v in counts.items()}
    pair_scans = 2 * cfg.n_scans * args.episodes
    print(f"scans/s (2 pairs, to detections): median {statistics.median(rates):.0f}  runs {[round(r) for r in rates]}")
    print(f"episode set-up: median {statistics.median(setups) * 1e3:.0f} ms")
    per = {k: round(v / pair_scans, 3) for k, v in total.items()}
    print(f"per pair-scan: {per}")
    print(f"mean ms per scan {1e3 / np.median(rates):.2f}")


if __name__ == "__main__":
    main()
