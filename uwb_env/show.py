"""The main job for now: summarise a scenario and draw its scene and truth trajectories (a PNG).

Usage: ``uwb-env-scenario [--scenario NAME] [--seed N] [--out DIR]`` (also ``python -m uwb_env.show``).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from uwb_env import scenarios
from uwb_env.config import ChirpWaveformConfig, ScenarioConfig
from uwb_env.rng import RngStreams
from uwb_env.scene import SceneLayout, Truth, sample_truth
from uwb_env.sensing import ParametricSensor, ScanPlan
from uwb_env.sensing.records import Detections
from uwb_env.tracking.initiation import range_azimuth_candidates
from uwb_env.typing import FloatArray
from uwb_env.units import linear_to_db


def summary(cfg: ScenarioConfig, truth: Truth, sensor: ParametricSensor, seed: int) -> str:
    """A plain-text summary: nodes, waveforms with their CRLB at 20 dB, targets, clutter, one sensed scan."""
    lines = [
        f"scenario {cfg.name}: {cfg.description}",
        f"  seed paper: {cfg.seed_reference}",
        f"  {len(cfg.transmitters)} Tx, {len(cfg.receivers)} Rx, {sensor.pairs.shape[0]} radar pairs, "
        f"{len(cfg.walls)} walls, {len(cfg.clutter_points_m)} clutter points, "
        f"{cfg.n_scans} scans of {cfg.sensing.scan_period_s} s",
    ]
    lines.append("  waveforms (sigma at SNR = 20 dB; dwell; scan energy per watt):")
    for w in sensor.library.waveforms:
        R = w.covariance(np.array([100.0]))[0]
        sig = ", ".join(f"{n} {math.sqrt(R[i, i]):.3g}" for i, n in enumerate(w.measurement_names))
        extra = ""
        if isinstance(w.config, ChirpWaveformConfig):
            extra = f", rho {R[0, 1] / math.sqrt(R[0, 0] * R[1, 1]):+.4f}"
        lines.append(
            f"    {w.name:14s} {sig}{extra}; dwell {w.dwell_time_s * 1e3:.3g} ms; energy {w.scan_energy_j(1.0):.3g} J/W"
        )
    for j, t in enumerate(cfg.targets):
        alive = np.flatnonzero(truth.alive[:, j])
        a, b = truth.states[alive[0], j], truth.states[alive[-1], j]
        lines.append(
            f"  target {t.name}: born {t.birth_time_s} s, Swerling {t.swerling}, {t.rcs_mean_m2} m^2, "
            f"({a[0]:.1f}, {a[2]:.1f}) -> ({b[0]:.1f}, {b[2]:.1f}) m over scans {alive[0]}-{alive[-1]}"
        )
    per_pair = np.round(sensor.expected_clutter[sensor.pair_mask], 2)
    lines.append(f"  expected false detections per pair and scan: {per_pair}")
    rngs = RngStreams.from_seed(seed)
    episode = sensor.new_episode(sample_truth(cfg, rngs.truth, sensor.layout), rngs)
    k = int(np.argmax(truth.alive.sum(axis=1)))
    plan = ScanPlan.all_listening(0, sensor.n_tx, sensor.n_rx)
    snr = sensor.mean_snr(episode.geometry, k, plan)
    covered = snr[snr > 0]
    if covered.size:
        lines.append(
            f"  scan {k}, waveform {sensor.library[0].name}: mean target SNR "
            f"{linear_to_db(covered.min()):.1f} .. {linear_to_db(covered.max()):.1f} dB"
        )
    dets = sensor.sense(episode, k, plan)
    lines.append(
        f"  scan {k} detections per pair (targets + false): "
        f"{[(int((d.origin >= 0).sum()), int((d.origin < 0).sum())) for d in dets]}"
    )
    return "\n".join(lines)


def draw_scene(ax: Any, cfg: ScenarioConfig, lay: SceneLayout) -> None:
    """Static scene on a matplotlib axis: surveillance area, walls / buildings, clutter points, nodes."""
    import matplotlib.pyplot as plt

    a = cfg.surveillance_area
    ax.add_patch(
        plt.Rectangle(
            (a.x_min_m, a.y_min_m),
            a.x_max_m - a.x_min_m,
            a.y_max_m - a.y_min_m,
            fill=False,
            ls=":",
            color="0.5",
            label="surveillance area",
        )
    )
    for i in range(lay.wall_start.shape[0]):
        opaque = np.isinf(lay.wall_loss_db[i])
        ax.plot(
            *np.c_[lay.wall_start[i], lay.wall_end[i]],
            color="0.2" if opaque else "tab:brown",
            lw=2.0 if opaque else 1.5,
        )
    if lay.clutter_points.size:
        ax.plot(*lay.clutter_points.T, "+", color="tab:green", ms=6, label="clutter (vegetation)")
    ax.plot(*lay.tx_pos.T, "v", color="tab:red", ms=10, label="transmitter")
    ax.plot(*lay.rx_pos.T, "o", mfc="none", mec="tab:blue", ms=10, mew=2, label="receiver")
    ax.set_xlim(lay.area[0] - 0.05 * (lay.area[1] - lay.area[0]), lay.area[1] + 0.05 * (lay.area[1] - lay.area[0]))
    ax.set_ylim(lay.area[2] - 0.05 * (lay.area[3] - lay.area[2]), lay.area[3] + 0.05 * (lay.area[3] - lay.area[2]))
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")


def draw_detections(ax: Any, detections: Sequence[Detections], tx_pos: FloatArray, rx_pos: FloatArray) -> None:
    """One scan's detections: fused positions as points, range + azimuth as located points, else iso-range ellipses.

    The bistatic ellipse |p - tx| + |p - rx| = r has foci tx, rx, semi-axes r / 2 and sqrt(r^2 - d^2) / 2 (d the
    baseline); a point uses the azimuth line through rx (``range_azimuth_candidates``, range-rate ignored).
    """
    t = np.linspace(0.0, 2.0 * np.pi, 90)
    for det in detections:  # pairs: a small set; every detection of a pair in one array call
        if not len(det):
            continue
        if det.measurement_names == ("x", "y"):  # fused positions (signal path)
            ax.plot(det.z[:, 0], det.z[:, 1], "x", color="tab:orange", ms=4, label="detections")
            continue
        tx, rx = tx_pos[det.tx], rx_pos[det.rx]
        r = det.z[:, 0]
        if "azimuth" in det.measurement_names:
            theta = det.z[:, det.measurement_names.index("azimuth")]
            p, _, ok = range_azimuth_candidates(r, np.ones_like(r), theta, np.ones_like(r), tx, rx)
            ax.plot(p[ok, 0], p[ok, 1], "x", color="tab:orange", ms=4, label="detections")
            continue
        base = np.linalg.norm(rx - tx)
        a, b = r / 2.0, np.sqrt(np.maximum(r**2 - base**2, 0.0)) / 2.0
        phi = math.atan2(*(rx - tx)[::-1])
        ex, ey = a[:, None] * np.cos(t), b[:, None] * np.sin(t)  # (n, 90)
        cx, cy = (tx + rx) / 2.0
        xs = cx + ex * math.cos(phi) - ey * math.sin(phi)
        ys = cy + ex * math.sin(phi) + ey * math.cos(phi)
        ax.plot(xs.T, ys.T, "-", color="tab:orange", lw=0.5, alpha=0.6)


def draw(cfg: ScenarioConfig, truth: Truth, sensor: ParametricSensor, path: Path) -> None:
    """Scene picture: walls / buildings, clutter points, nodes, truth trajectories with start and end marks."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    lay = sensor.layout
    fig, ax = plt.subplots(figsize=(7, 7 * (lay.area[3] - lay.area[2]) / (lay.area[1] - lay.area[0]) + 0.5))
    draw_scene(ax, cfg, lay)
    for j, t in enumerate(cfg.targets):
        alive = truth.alive[:, j]
        xy = truth.states[alive, j][:, [0, 2]]
        style = ("-", "--", ":", "-.")[j % 4]
        ax.plot(*xy.T, style, lw=2.5 - 0.5 * (j % 3), label=f"{t.name} (from {t.birth_time_s:g} s)")
        ax.plot(*xy[0], "s", color="k", ms=6, mfc="none")
        ax.plot(*xy[-1], "s", color="k", ms=6)
    ax.set_title(f"{cfg.name} (seed {cfg.seed_reference.split()[0]}); squares: start (open), end (filled)")
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> None:
    """Print the scenario summary and write ``<out>/<scenario>.png``."""
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--scenario", default="urban-intersection", choices=scenarios.names())
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("results"))
    args = ap.parse_args(argv)
    cfg = scenarios.get(args.scenario)
    sensor = ParametricSensor(cfg)
    truth = sample_truth(cfg, RngStreams.from_seed(args.seed).truth, sensor.layout)
    print(summary(cfg, truth, sensor, args.seed))
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / f"{cfg.name}.png"
    draw(cfg, truth, sensor, path)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
