"""Calibration report: the parametric sensor model against the signal path (issue 5, item 5).

Usage:
    python scripts/calibrate_parametric.py --out results/calibration [--scenario indoor-rsn] [--scans 600]

For every waveform of the scenario and an SNR grid, ``--scans`` scans (spread over every pair) carry one echo of
known integrated SNR at ``--excess`` m beyond the baseline over the room's background: a non-fluctuating point, or
with ``signal.target_model = "extended"`` (``--target-model``, by default the scenario's) a walking person's six
scattering centres at ``--speed`` (``SignalSensor.controlled_scans``: random heading and gait phase, each centre with
the target's Swerling factor). The scenario's in-sensor chain runs on them (CFAR and clustering, or seed 002's
energy detector with the waveform's bins and accumulated pulses) and we measure

* the detection probability: a ToA within the gate of the echo's bistatic range (0.3 m for a point, 0.45 m for a
  person, at least the energy detector's bin), less the gate's hits on echo-free scans (false detections, which
  the parametric model counts as clutter): Pd = (h - f0) / (1 - f0),
* the false detections per scan and pair (every other ToA),
* the spread (std) of the range error against c sqrt(CRLB) of the waveform at that SNR, and for a person the
  median, MAD std and RMS of its ToAs about its centre (the body's spread; ``scripts/body_spread.py`` measures the
  value the trackers use on the scenario's walks).

The parametric detector with the clutter residue of ``SensingConfig.clutter_residue_ratio`` (kappa) and
``clutter_residue_looks`` (m) and the detector gain g (``detection_gain_db``, ``--gain-db``; 0 dB unless given; one
per waveform with ``--gain-per-waveform``, ``ImpulseWaveformConfig.detection_gain_db``),
Pd = E_X[Pd_SW(g SNR / (1 + kappa SNR_dp X), Pfa)], X ~ Gamma(m, 1/m), SW the echo's Swerling case (0 for the point,
the target's for the person), is fitted to these points: kappa, m, g and the detector's effective Pfa minimise the
largest Pd difference over every waveform and SNR (pairs pooled, the model averaged over them; grid search, the
objective being a maximum). The report gives them, the largest |Pd difference| with the binomial std of the
measured points, and the ToA spread. The scenarios' constants (``sensing.clutter_residue_ratio``,
``clutter_residue_looks``, ``detection_gain_db`` and ``false_alarm_probability``) are the values this script fits,
with the commands in their module docstrings (``uwb_env/scenarios/indoor_rsn.py``, ``indoor_monostatic.py``).
Writes calibration.md, pd.png and toa_spread.png.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from uwb_env import scenarios
from uwb_env.constants import SPEED_OF_LIGHT_MPS
from uwb_env.rng import RngStreams
from uwb_env.scene import sample_truth
from uwb_env.sensing.parametric import residue_quadrature
from uwb_env.sensing.pd import detection_probability
from uwb_env.sensing.signal import SignalSensor
from uwb_env.waveforms.impulse import toa_crlb_variance

HIT_M = 0.3
# a person's detections lie -0.5 to +0.3 m about its centre's range; the room's multipath residue 1.2 m apart, at
# +-0.6 m about the echo (--excess 3 m): a 0.45 m gate keeps the one and not the other
BODY_HIT_M = 0.45


def hit_gate_m(sensor: SignalSensor) -> float:
    """The largest range error [m] of a detection counted as the echo's.

    0.3 m for a point, 0.45 m for an extended person; the energy detector's ToA is a bin centre, so at least its bin
    (``origin_tolerance_m``).
    """
    gate = BODY_HIT_M if sensor.sig.target_model == "extended" else HIT_M
    if sensor.sig.toa_estimator == "energy-detector":
        gate = max(gate, sensor.origin_tolerance_m)
    return gate


def measure(
    sensor: SignalSensor, waveform: int, snr_db: float, n_scans: int, excess_m: float, seed: int, speed_mps: float = 1.5
) -> dict:
    """Signal-path statistics of one (waveform, SNR) cell, the scans spread evenly over the pairs.

    The chain is the scenario's (``in_sensor``: CFAR and clustering, or the energy detector with the waveform's
    bins and, with ``ed_pulse_integration = "noncoherent"``, its pulses' accumulated noise); an extended person
    (``signal.target_model``) walks at ``speed_mps``.
    """
    rngs = RngStreams.from_seed(seed)
    ep = sensor.new_episode(sample_truth(sensor.cfg, rngs.truth, sensor.layout), rngs)
    rng = np.random.default_rng(seed)
    P = sensor.pairs.shape[0]
    per = max(1, n_scans // P)
    gate = hit_gate_m(sensor)
    ed_noise = sensor.sig.toa_estimator == "energy-detector" and sensor.sig.ed_pulse_integration == "noncoherent"
    hits, falses, errors, all_errors, scans, dp = [], [], [], [], 0, []
    for p in range(P):  # pairs: a handful; each a batch of scans
        snr = np.full(per, 10.0 ** (snr_db / 10.0))
        x = sensor.controlled_scans(rng, p, waveform, excess_m, snr, speed_mps)
        ref = np.broadcast_to(ep.reference[waveform, p], x.shape)
        *_, (row, _, _, _), ranges = sensor.in_sensor(
            x,
            ref,
            np.full(per, ep.reference_toa[waveform, p]),
            np.full(per, ep.reference_peak[waveform, p]),
            np.full(per, p),
            np.broadcast_to(ep.reference_scan[waveform, p], x.shape),
            waveform=np.full(per, waveform),
            ed_uniform=rng.uniform(0.0, 1.0, (per, sensor.ed_n_bins)) if ed_noise else None,
        )
        err = ranges - (sensor.baseline[p] + excess_m)
        hit = np.abs(err) < gate
        all_errors.append(err[hit])
        detected = np.zeros(per, bool)
        detected[row[hit]] = True
        hits.append(detected.sum())
        falses.append((~hit).sum())
        best = {}
        for r, e in zip(row[hit].tolist(), err[hit].tolist(), strict=True):  # detections: one per scan mostly
            if r not in best or abs(e) < abs(best[r]):
                best[r] = e
        errors.extend(best.values())
        scans += per
        dp.append(sensor.dp_snr[waveform, p])
    return {
        "pd": sum(hits) / scans,
        "n": scans,
        "false_per_scan": sum(falses) / scans,
        "toa_std_m": float(np.std(errors)) if len(errors) > 2 else math.nan,
        "errors_m": np.concatenate(all_errors),
        "dp_snr": float(np.exp(np.mean(np.log(dp)))),
        "per_pair_hits": hits,
        "per": per,
    }


CONSTANT_RESIDUE = (np.ones(1), np.ones(1))  # quadrature of looks = 0: X = 1


def parametric_pd(snr, dp_snr: np.ndarray, kappa: float, pfa: float, quadrature=CONSTANT_RESIDUE, swerling: int = 0):
    """Parametric Pd ``(..., P)`` of an echo of Swerling case ``swerling`` for each pair's direct-path SNR.

    ``snr`` (...,), ``dp_snr`` (..., P): E_X[Pd_SW(SNR / (1 + kappa SNR_dp X))] (``ParametricSensor``).
    """
    x, w = quadrature
    scnr = np.asarray(snr, dtype=float)[..., None, None] / (1.0 + kappa * dp_snr[..., None] * x)
    return detection_probability(scnr.reshape(-1), pfa, swerling).reshape(scnr.shape) @ w


def body_range_spread(errors_m: np.ndarray) -> tuple[float, float, float]:
    """Range error of an extended person's detections about its centre: (median bias, MAD std, their RMS) [m].

    Robust statistics: the body's spread, not the rare false detections inside the hit gate.
    """
    bias = float(np.median(errors_m))
    std = float(1.4826 * np.median(np.abs(errors_m - bias)))
    return bias, std, math.hypot(bias, std)


def main() -> None:
    """The command line (the module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=Path("results/calibration"))
    ap.add_argument("--scenario", default="indoor-rsn")
    ap.add_argument("--scans", type=int, default=600, help="scans per (waveform, SNR) cell")
    ap.add_argument("--excess", type=float, default=3.0, help="echo's bistatic range beyond the baseline [m]")
    ap.add_argument(
        "--target-model",
        choices=("point", "extended"),
        default=None,
        help="the echo: one point, or a walking person's scattering centres (default: the scenario's)",
    )
    ap.add_argument(
        "--gain-db",
        nargs="+",
        type=float,
        default=[0.0],
        help="detection gains tried (sensing.detection_gain_db: the chain's SNR gain or loss over the square-law test)",
    )
    ap.add_argument(
        "--gain-per-waveform",
        action="store_true",
        help="fit one gain of --gain-db per waveform (ImpulseWaveformConfig.detection_gain_db: an energy detector's "
        "non-coherent accumulation loss depends on the pulses)",
    )
    ap.add_argument("--speed", type=float, default=1.5, help="an extended person's walking speed [m/s]")
    ap.add_argument(
        "--looks",
        nargs="+",
        type=float,
        default=[0.0, 1.0, 2.0, 4.0, 6.0, 8.0, 12.0, 16.0, 32.0],
        help="residue looks m tried (0: constant residue)",
    )
    ap.add_argument("--snr-db", nargs=3, type=float, default=(20.0, 56.0, 2.0), metavar=("FROM", "TO", "STEP"))
    ap.add_argument(
        "--log-pfa", nargs=2, type=float, default=(-8.0, -2.0), metavar=("FROM", "TO"), help="log10 Pfa grid"
    )
    ap.add_argument("--log-pfa-step", type=float, default=0.5, help="step of the log10 Pfa grid")
    ap.add_argument(
        "--log-kappa", nargs=2, type=float, default=(-6.0, -2.5), metavar=("FROM", "TO"), help="kappa grid, 0.05 steps"
    )
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    base = scenarios.get(args.scenario)
    overrides = {"sensing.fidelity": "signal", "sensing.clutter_residue_ratio": 0.0}
    if args.target_model is not None:
        overrides["sensing.signal.target_model"] = args.target_model
    cfg = scenarios.get(args.scenario, **overrides)
    body = cfg.sensing.signal.target_model == "extended"
    # a point echo is non-fluctuating (Swerling 0); a person's centres fluctuate with the target's Swerling case, and
    # the parametric model of the person is that case's Pd
    swerling = cfg.targets[0].swerling if body else 0
    sensor = SignalSensor(cfg)
    grid = np.arange(args.snr_db[0], args.snr_db[1] + 1e-9, args.snr_db[2])
    W = len(sensor.library)
    cells = {
        (w, s): measure(sensor, w, s, args.scans, args.excess, 1000 * w + int(s), args.speed)
        for w in range(W)
        for s in grid
    }
    # false detections inside the gate: the hit rate of echo-free scans f0, removed from every cell's hit rate h as
    # from independent events (h = 1 - (1 - Pd)(1 - f0)); the parametric model counts them as clutter, not as Pd
    empty = {
        w: measure(sensor, w, -math.inf, args.scans, args.excess, 1000 * w + 999, args.speed)["pd"] for w in range(W)
    }
    for (w, _), c in cells.items():
        c["hit_rate"] = c["pd"]
        c["pd"] = max(0.0, (c["pd"] - empty[w]) / (1.0 - empty[w]))
    P = sensor.pairs.shape[0]

    w_idx = np.array([w for w, _ in cells])
    snr_all = np.array([10.0 ** (s / 10.0) for _, s in cells])
    measured = np.array([c["pd"] for c in cells.values()])
    dp_all = sensor.dp_snr[w_idx]  # (C, P)

    gain_grid = np.asarray(args.gain_db, dtype=float)
    on_w = np.arange(W)[:, None] == w_idx[None]  # (W, C)

    def worst(log_kappa: float, pfa_fit: float, quad) -> tuple[float, np.ndarray]:
        """Largest |Pd difference| over the cells (pairs pooled, the model averaged over them) and the gains [dB].

        The gains (W,): the best one of ``--gain-db``, or each waveform's best with ``--gain-per-waveform`` (a gain
        acts on its own waveform's cells, so the largest difference is the largest of the waveforms' own).
        """
        g = 10.0 ** (gain_grid / 10.0)
        model = parametric_pd(g[:, None] * snr_all[None], dp_all[None], 10.0**log_kappa, pfa_fit, quad, swerling).mean(
            axis=-1
        )  # (G, C)
        err = np.max(np.where(on_w[None], np.abs(model - measured)[:, None], 0.0), axis=-1)  # (G, W)
        if args.gain_per_waveform:
            best = np.argmin(err, axis=0)
            return float(err[best, np.arange(W)].max()), gain_grid[best]
        best = int(np.argmin(err.max(axis=1)))
        return float(err[best].max()), np.full(W, gain_grid[best])

    # grid search (the objective is a max, not smooth): kappa, residue looks, the detector's effective Pfa and gain
    quads = {m: residue_quadrature(m) for m in args.looks}
    candidates = [
        (*worst(lk, 10.0**lp, quads[m]), lk, 10.0**lp, m)
        for m in args.looks
        for lp in np.arange(args.log_pfa[0], args.log_pfa[1] + 0.01, args.log_pfa_step)
        for lk in np.arange(args.log_kappa[0], args.log_kappa[1], 0.05)
    ]
    _, _, lk0, pfa, looks = min(candidates, key=lambda c: (c[0], c[2], c[3], c[4]))
    fine = [(*worst(lk, pfa, quads[looks]), lk) for lk in np.arange(lk0 - 0.05, lk0 + 0.05, 0.002)]
    max_pooled, gain_db_w, log_kappa = min(fine, key=lambda c: (c[0], c[2]))
    kappa = 10.0**log_kappa
    gain_w = 10.0 ** (gain_db_w / 10.0)
    quad = quads[looks]
    rows = []
    for w in range(W):
        beta = sensor.library.waveforms[w].rms_bandwidth_hz
        for s in grid:
            c = cells[(w, s)]
            model = float(
                np.mean(parametric_pd(gain_w[w] * 10.0 ** (s / 10.0), sensor.dp_snr[w], kappa, pfa, quad, swerling))
            )
            crlb = SPEED_OF_LIGHT_MPS * math.sqrt(toa_crlb_variance(beta, 10.0 ** (s / 10.0)))
            ratio = c["toa_std_m"] / crlb if c["pd"] > 0.5 else math.nan
            rows.append(
                (sensor.library.waveforms[w].name, s, c["pd"], model, c["false_per_scan"], c["toa_std_m"], crlb, ratio)
            )
    ratios = np.array([r[7] for r in rows if np.isfinite(r[7])])
    false_low = np.mean([c["false_per_scan"] for (_, s), c in cells.items() if s <= grid[0] + 6.0])
    model_false = float(np.mean(sensor.model._clutter_mean[sensor.pairs[:, 0], sensor.pairs[:, 1]]))
    high = np.array([r[7] for r in rows if np.isfinite(r[7]) and r[1] >= grid[-1] - 10.0])
    lines = [
        f"# Calibration of the parametric sensor model on the signal path ({args.scenario})",
        "",
        f"{args.scans} scans per cell over {P} pairs, echo {args.excess} m beyond the baseline: "
        + (
            f"an extended person (signal.target_model = 'extended') walking at {args.speed:g} m/s, random heading and "
            f"gait phase, its centres Swerling {swerling} against the parametric Swerling {swerling} Pd; a detection "
            f"within {hit_gate_m(sensor):g} m of the body centre's bistatic range is the echo's."
            if body
            else f"a non-fluctuating point (Swerling 0); a detection within {hit_gate_m(sensor):g} m is the echo's."
        ),
        f"Command: `python scripts/calibrate_parametric.py {' '.join(sys.argv[1:])}`",
        "",
        f"* fitted: clutter residue ratio kappa = {kappa:.4g} (log10 {log_kappa:.3f}), residue looks {looks:g}, "
        f"detector Pfa {pfa:.3g}, detection gain "
        + (
            ", ".join(f"{sensor.library.waveforms[w].name} {g:g} dB" for w, g in enumerate(gain_db_w))
            if args.gain_per_waveform
            else f"{gain_db_w[0]:g} dB"
        )
        + " (the scenario's: kappa "
        f"{base.sensing.clutter_residue_ratio:g}, looks {base.sensing.clutter_residue_looks:g}, Pfa "
        f"{base.sensing.false_alarm_probability:g}, gain {base.sensing.detection_gain_db:g} dB, waveforms' gains "
        + ", ".join(f"{w.name} {getattr(w, 'detection_gain_db', 0.0):g} dB" for w in base.waveforms)
        + ")",
        f"* largest |Pd difference| over the grid (pairs pooled): {max_pooled:.4f} (binomial std of a point at "
        f"Pd 0.5: {0.5 / math.sqrt(args.scans):.3f})",
        "* hits within the gate on echo-free scans (false detections there), removed from the Pd as independent "
        "events: " + ", ".join(f"{sensor.library.waveforms[w].name} {f:.3f}" for w, f in empty.items()),
        f"* false detections per scan and pair (echo undetected, lowest 6 dB of the grid): signal {false_low:.2f}, "
        f"parametric {model_false:.2f} (sensing.clutter.density_per_m2 = {cfg.sensing.clutter.density_per_m2:g} over "
        "the pair's gate); the network chain's weight / residual filter and 2-D clustering leave "
        f"sensing.signal.false_position_density_per_m2 = {cfg.sensing.signal.false_position_density_per_m2:g} per m^2",
        f"* ToA spread / CRLB where Pd > 0.5: median {np.median(ratios):.2f}, range [{ratios.min():.2f}, "
        f"{ratios.max():.2f}]; top 10 dB of the grid: median {np.median(high):.2f}",
    ]
    if body:
        strong = [c["errors_m"] for c in cells.values() if c["pd"] > 0.5]
        bias, spread, rms = body_range_spread(np.concatenate(strong)) if strong else (math.nan,) * 3
        lines.append(
            f"* the person's range error about its centre where Pd > 0.5 (every detection within the gate): median "
            f"{bias:.3f} m, MAD std {spread:.3f} m, RMS {rms:.3f} m (the scenario's signal.body.range_std_m: "
            f"{base.sensing.signal.body.range_std_m:g} m)"
        )
    lines += [
        "",
        "| waveform | SNR [dB] | Pd signal | Pd parametric | false / scan / pair | range std [m] | c sqrt(CRLB) [m] "
        "| ratio |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    lines += [
        f"| {n} | {s:.0f} | {a:.3f} | {b:.3f} | {f:.2f} | {e:.2e} | {c:.2e} | {r:.2f} |"
        for n, s, a, b, f, e, c, r in rows
    ]
    (args.out / "calibration.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines[:10]))

    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    fine = np.linspace(grid[0], grid[-1], 200)
    for w in range(W):
        name = sensor.library.waveforms[w].name
        meas = [cells[(w, s)]["pd"] for s in grid]
        (line,) = ax.plot(grid, meas, "o", ms=4, label=f"{name} signal")
        model = parametric_pd(
            gain_w[w] * 10.0 ** (fine / 10.0),
            np.broadcast_to(sensor.dp_snr[w], (fine.size, P)),
            kappa,
            pfa,
            quad,
            swerling,
        )
        model = model.mean(axis=-1)
        ax.plot(fine, model, "-", color=line.get_color(), lw=1, label=f"{name} parametric")
    ax.set_xlabel("integrated SNR of the echo [dB]")
    ax.set_ylabel("detection probability")
    ax.set_title(f"{args.scenario}: kappa = {kappa:.3g}")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(args.out / "pd.png", dpi=120)
    plt.close(fig)
    fig, ax = plt.subplots(figsize=(6, 4))
    for w in range(W):
        sel = [r for r in rows if r[0] == sensor.library.waveforms[w].name and np.isfinite(r[7])]
        ax.semilogy([r[1] for r in sel], [r[5] for r in sel], "o", ms=4, label=f"{sel[0][0] if sel else w} signal")
    ax.semilogy(
        grid,
        [
            SPEED_OF_LIGHT_MPS
            * math.sqrt(toa_crlb_variance(sensor.library.waveforms[0].rms_bandwidth_hz, 10.0 ** (s / 10.0)))
            for s in grid
        ],
        "k-",
        lw=1,
        label="c sqrt(CRLB)",
    )
    ax.set_xlabel("integrated SNR of the echo [dB]")
    ax.set_ylabel("range error std [m]")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(args.out / "toa_spread.png", dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    main()
