"""Seed 003's regime on urban-intersection: the SNR along the path per waveform, and what it means for detection.

    python scripts/seed003_regime.py [--seed 0]

Prints, for every waveform, the E/N0 of one compressed pulse at one array element (the seed's "SNR experienced is
0.2", see ``uwb_env.scenarios.urban_intersection``), the integrated scan SNR and the Swerling-I Pd at the scenario's
Pfa, over the covered (target, receiver, scan) links of one episode: median and the 10 / 90 % points.
"""

from __future__ import annotations

import argparse

import numpy as np

from uwb_env import scenarios
from uwb_env.rng import RngStreams
from uwb_env.scene import sample_truth
from uwb_env.sensing import ParametricSensor
from uwb_env.sensing.pd import detection_probability


def main() -> None:
    """The command line (the module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--scenario", default="urban-intersection")
    args = ap.parse_args()
    cfg = scenarios.get(args.scenario)
    sensor = ParametricSensor(cfg)
    truth = sample_truth(cfg, RngStreams.from_seed(args.seed).truth, sensor.layout)
    geom = sensor.episode_geometry(truth)  # scan SNR with the receive beams' gain g(psi) <= L
    # one element's SNR: the array's full coherent gain L ("steered") divided out
    element = ParametricSensor(scenarios.get(args.scenario, **{"sensing.array_beams": "steered"}))
    geom_el = element.episode_geometry(truth)
    pfa = cfg.sensing.false_alarm_probability
    power = cfg.transmitters[0].power_dbm
    print(f"{args.scenario}: Tx power {power} dBm, Pfa {pfa:g}, covered links {geom.covered.sum()}")
    print("waveform | one pulse, one element E/N0 [dB] p10 / median / p90 | scan SNR [dB] median | Pd p10/median/p90")
    for w, wf in enumerate(sensor.library.waveforms):
        n_el = np.array([r.array.n_elements if r.array else 1 for r in cfg.receivers])
        snr = sensor.radar_constant[w][:, :, None][None] * geom.unit_snr  # (S, T, R, K) scan SNR at mean RCS
        scan = snr[geom.covered]
        snr_el = element.radar_constant[w][:, :, None][None] * geom_el.unit_snr
        per_pulse = (snr_el / (wf.config.n_pulses * n_el[None, None, :, None]))[geom.covered]
        pd = detection_probability(scan, pfa, 1)
        p = np.percentile(10 * np.log10(per_pulse), [10, 50, 90])
        q = np.percentile(pd, [10, 50, 90])
        print(
            f"{wf.name:>14} | {p[0]:6.1f} / {p[1]:6.1f} / {p[2]:6.1f} | {10 * np.log10(np.median(scan)):6.1f} | "
            f"{q[0]:.2f} / {q[1]:.2f} / {q[2]:.2f}"
        )


if __name__ == "__main__":
    main()
