"""Seed 002's particle filter on indoor-monostatic: per-scan time beside the IMM tracker, and the seed's NEO figures.

Run: python benchmarks/pf_throughput.py [--episodes N] [--particles N] [--neo]

Throughput: detections are generated first (parametric sensing, every radar on the 128-pulse waveform, all
listening); then ``step`` of each tracker is timed alone on the same detections: the PF (``TrackerConfig.kind =
"pf"``, its default ``PfConfig``) with the sensor model's Pd evaluated at every particle (that call is timed with it
and its share printed), the PF with a constant Pd, and the VS-IMM / LMIPDA tracker of the scenario with the same
sensor-model Pd.

``--neo``: the 80 % point of the navigation error outage (seed 002 Figs. 2-4: the error below which 80 % of the
scans fall, ``uwb_env.metrics.error_at_outage``) over ``--episodes`` random walks, beside the seed's figures: LOS
(the same floor with walls transparent to the radio) and OLOS, N_pulse 32 / 128 / 512, T_int 2 / 4 / 6 ns (T = 0.2 s,
SKDU), and SKDU against SDL at T = 0.1 / 0.2 / 0.5 s (OLOS). Each row with the default likelihood (each detection's
three-region sigma(SNR)) and with the seed's own perception model (fixed sigma_p = 0.8 m).
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

from uwb_env import scenarios
from uwb_env.config import MaterialConfig, PfConfig, ScenarioConfig
from uwb_env.metrics import error_at_outage
from uwb_env.rng import RngStreams
from uwb_env.scene import sample_truth
from uwb_env.sensing.protocol import make_sensor
from uwb_env.sensing.records import ScanPlan
from uwb_env.tracking.registry import make_tracker


def line_of_sight(cfg: ScenarioConfig) -> ScenarioConfig:
    """The same floor and walks, walls transparent to the radio (seed 002's LOS comparison)."""
    air = MaterialConfig("air", loss_db=0.0, excess_delay_s=0.0)
    return dataclasses.replace(cfg, walls=tuple(dataclasses.replace(w, material=air) for w in cfg.walls))


def with_integration_time(cfg: ScenarioConfig, t_int_s: float) -> ScenarioConfig:
    """Every waveform's energy detector with integration time ``t_int_s``."""
    waveforms = tuple(
        dataclasses.replace(w, energy_detector=dataclasses.replace(w.energy_detector, integration_time_s=t_int_s))
        for w in cfg.waveforms
    )
    return dataclasses.replace(cfg, waveforms=waveforms)


def with_period(cfg: ScenarioConfig, period_s: float) -> ScenarioConfig:
    """Scan period ``period_s``, as many scans as the 20 m walk at 1 m/s lasts."""
    return dataclasses.replace(
        cfg,
        sensing=dataclasses.replace(cfg.sensing, scan_period_s=period_s),
        n_scans=round(20.0 / period_s),
    )


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


SEED_FIGS = {
    ("los", "npulse"): {32: 0.8, 128: 1.0, 512: 1.2},
    ("olos", "npulse"): {32: 2.0, 128: 2.3, 512: 2.3},
    ("los", "tint"): {2: 0.6, 4: 0.9, 6: 1.5},
    ("olos", "tint"): {2: 2.3, 4: 2.5, 6: 2.9},
}


def neo(args: argparse.Namespace) -> None:
    base = scenarios.get("indoor-monostatic")
    likelihoods = (
        ("snr", PfConfig(n_particles=args.particles)),
        ("seed", PfConfig(n_particles=args.particles, likelihood="seed")),
    )
    print(
        f"80 % point of the NEO [m], {args.episodes} walks each; "
        "seed 002's figure | ours (snr likelihood, seed's sigma_p)"
    )
    waveform_of = {128: 0, 32: 1, 512: 2}
    for env in ("los", "olos"):
        cfg0 = line_of_sight(base) if env == "los" else base
        for npulse in (32, 128, 512):
            sensor, eps = episodes(cfg0, args.episodes, waveform_of[npulse])
            ours = []
            for _, pf in likelihoods:
                tc = dataclasses.replace(base.tracker, kind="pf", pf=pf)
                ours.append(error_at_outage(run(cfg0, tc, sensor, eps, waveform_of[npulse], confirmed=False)[0]))
            print(
                f"  Fig. 2 {env:4s} N_pulse {npulse:3d}: {SEED_FIGS[(env, 'npulse')][npulse]:.1f} | "
                f"{ours[0]:.2f}, {ours[1]:.2f}"
            )
        for tint in (2, 4, 6):
            cfg = with_integration_time(cfg0, tint * 1e-9)
            sensor, eps = episodes(cfg, args.episodes)
            ours = []
            for _, pf in likelihoods:
                tc = dataclasses.replace(base.tracker, kind="pf", pf=pf)
                ours.append(error_at_outage(run(cfg, tc, sensor, eps, confirmed=False)[0]))
            print(
                f"  Fig. 3 {env:4s} T_int {tint} ns:     {SEED_FIGS[(env, 'tint')][tint]:.1f} | "
                f"{ours[0]:.2f}, {ours[1]:.2f}"
            )
    seed_fig4 = {
        (0.5, "skdu"): "< 2.7",
        (0.5, "sdl"): "~ 5",
        (0.2, "skdu"): "~ 2.7",
        (0.2, "sdl"): "~ 2.7",
        (0.1, "skdu"): "> SDL",
        (0.1, "sdl"): "best",
    }
    for period in (0.5, 0.2, 0.1):
        cfg = with_period(base, period)
        sensor, eps = episodes(cfg, args.episodes)
        for model in ("skdu", "sdl"):
            ours = []
            for _, pf in likelihoods:
                tc = dataclasses.replace(base.tracker, kind="pf", pf=dataclasses.replace(pf, mobility=model))
                ours.append(error_at_outage(run(cfg, tc, sensor, eps, confirmed=False)[0]))
            print(
                f"  Fig. 4 olos T {period} s {model:4s}:   {seed_fig4[(period, model)]:5s} | "
                f"{ours[0]:.2f}, {ours[1]:.2f}"
            )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--episodes", type=int, default=5)
    ap.add_argument("--particles", type=int, default=PfConfig().n_particles)
    ap.add_argument("--neo", action="store_true", help="the seed's Figs. 2-4 80 %% points instead of the timing")
    args = ap.parse_args()
    neo(args) if args.neo else throughput(args)


if __name__ == "__main__":
    main()
