"""Seed 004's HMM detector throughput: scans per second in one process.

Run: python benchmarks/hmm_throughput.py [--scans 2000] [--repeats 5]

Three timings, medians over ``--repeats`` (after a warm-up: numba compilation):

* "signal sensor, HMM chain": ``SignalSensor.in_sensor`` with ``toa_estimator = "hmm"`` on indoor-rsn scans (6 pairs
  x 1920 samples): alignment, bin energies, the single-capture statistic, forward-backward over ~95 bins, eq. 12,
  ranges. The scans are synthesised beforehand (``controlled_scans``, one 30 dB echo per pair), so the time is the
  detector's alone. The target: >= 200 scans/s on the 2-core development machine.
* "signal sensor, sense()": the whole per-scan ``sense`` (synthesis + HMM chain + detections) on an episode.
* "seed 004 link": the replica's per-link detector on simulated cluttered CIRs (section 2): O of eq. 5 from 10
  calibration and 10 test captures' bin energies (40 bins), forward-backward with a fixed lambda, eq. 12; one
  "scan" = the six links of a room's radio pairs at one person position.
"""

from __future__ import annotations

import argparse

import numpy as np
from timing import call_rate

from uwb_env import scenarios
from uwb_env.detection import hmm
from uwb_env.rng import RngStreams
from uwb_env.scene import sample_truth
from uwb_env.sensing import ScanPlan
from uwb_env.sensing.signal import SignalSensor
from uwb_env.sensing.signal.cir import CirConfig, RoomConfig, bin_energy, point_grid, simulate_room


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scans", type=int, default=2000)
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    over = {"sensing.fidelity": "signal", "sensing.signal.target_model": "point", "sensing.signal.toa_estimator": "hmm"}
    cfg = scenarios.get("indoor-rsn", **over)
    s = SignalSensor(cfg)
    rngs = RngStreams.from_seed(1)
    ep = s.new_episode(sample_truth(cfg, rngs.truth, s.layout), rngs)
    rng = np.random.default_rng(2)
    P = s.pairs.shape[0]
    pairs = np.arange(P)
    scans = np.concatenate([s.controlled_scans(rng, p, 0, 3.0, np.full(1, 1e3)) for p in pairs])  # (P, N)
    args_in = (
        scans,
        ep.reference[0, pairs],
        ep.reference_toa[0, pairs],
        ep.reference_peak[0, pairs],
        pairs,
        ep.reference_scan[0, pairs],
    )
    med, lo, hi = call_rate(lambda: s.in_sensor(*args_in), args.scans, args.repeats)
    print(f"signal sensor, HMM chain (indoor-rsn, {P} pairs x {scans.shape[1]} samples, {s.hmm_n_bins} bins):")
    print(f"  {med:.0f} scans/s [{lo:.0f}-{hi:.0f}]")
    plan = ScanPlan.all_listening(0, s.n_tx, s.n_rx)
    k = iter(range(10**9))
    med, lo, hi = call_rate(lambda: s.sense(ep, 1 + next(k) % cfg.n_scans, plan), args.scans // 4, args.repeats)
    print(f"signal sensor, sense() with the HMM (synthesis included): {med:.0f} scans/s [{lo:.0f}-{hi:.0f}]")

    cir_cfg = CirConfig()
    radios = np.array([[-2.8, -2.3], [2.8, -2.3], [2.8, 2.3], [-2.8, 2.3]])
    room = RoomConfig("bench", (6.0, 5.0), radios, point_grid(2, 1))
    ld = simulate_room(np.random.default_rng(3), room, cir_cfg)
    cal = bin_energy(ld.cal, cir_cfg)  # (6, 10, 40)
    test = bin_energy(ld.test[:, 0], cir_cfg)  # (6, 10, 40): the six links at one position
    lam = hmm.HmmParams([0.8, 0.2], [[0.85, 0.15], [0.01, 0.99]], [-0.5, 2.5], [3.0, 3.5])

    def link_scan() -> np.ndarray:
        obs = hmm.kl_observations(cal, test)[:, 1:]
        return hmm.hmm_delay(hmm.changed_posterior(obs, lam))

    med, lo, hi = call_rate(link_scan, args.scans, args.repeats)
    print(f"seed 004 link detector (6 links x 10 + 10 captures x 40 bins): {med:.0f} scans/s [{lo:.0f}-{hi:.0f}]")


if __name__ == "__main__":
    main()
