"""Seed 002's navigation study: NEO curves of the particle filter on indoor-monostatic (Figs. 2-4), beside the seed's.

Experiments (seed 002 section V; every curve pools the errors of ``--walks`` random 20 m walks at 1 m/s, the walk of
seed s being the truth stream's draw for episode seed s, the same walk in every curve):

- ``npulse``: Npulse = 32 / 128 / 512 (the scenario's waveforms), T_int = 4 ns, T = 0.2 s, SKDU; LOS and OLOS;
- ``tint``: T_int = 2 / 4 / 6 ns, Npulse = 128, T = 0.2 s, SKDU; LOS and OLOS;
- ``mobility``: SKDU against SDL at T = 0.5 / 0.2 / 0.1 s, T_int = 4 ns, Npulse = 128, OLOS.

LOS is the seed's "same environment area and nodes deployment ... in the absence of walls": the walls made
transparent to the radio (0 dB, no excess delay), so the person walks the same rooms and doors (the walk is drawn
with the floor plan: without walls it would leave the building) and every radar sees it. OLOS is the scenario as
registered (concrete walls with doors). Every radar transmits the waveform and
listens each scan (the seed schedules nothing). The navigation error e = |p_hat - p| is taken at every scan from
the first at which the filter holds an estimate; a scan without an estimate after that counts as an outage at every
threshold (it is reported). The episode has round(20 m / (1 m/s) / T) scans.

Run: python scripts/seed002_neo.py [--fidelity parametric|signal] [--walks 5] [--out results/seed002-neo]
Writes neo.csv (the curves), summary.md (the 80 % points beside the seed's) and neo_npulse.png, neo_tint.png,
neo_mobility.png.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from uwb_env import scenarios
from uwb_env.config import MaterialConfig, ScenarioConfig
from uwb_env.metrics import error_at_outage, navigation_error_outage
from uwb_env.sensing.records import ScanPlan
from uwb_env.sim import Simulator

THRESHOLDS = np.linspace(0.0, 6.0, 121)
AIR = MaterialConfig("air", loss_db=0.0, excess_delay_s=0.0)
"""LOS: the walls' material made transparent to the radio."""
OUTAGE_M = 1e6
"""The error recorded for a scan without an estimate (after the first): an outage at every threshold."""

SEED = {  # seed 002's 80 % points [m] (section V-A, V-B)
    ("npulse", "los"): {"32": 0.8, "128": 1.0, "512": 1.2},
    ("npulse", "olos"): {"32": 2.0, "128": 2.3, "512": 2.3},
    ("tint", "los"): {"2": 0.6, "4": 0.9, "6": 1.5},
    ("tint", "olos"): {"2": 2.3, "4": 2.5, "6": 2.9},
    ("mobility", "olos"): {"skdu T=0.5": 2.7, "sdl T=0.5": 5.0, "skdu T=0.2": 2.7, "sdl T=0.2": 2.7},
}


@dataclasses.dataclass(frozen=True)
class Case:
    """One NEO curve: experiment, condition, label, and how to build it."""

    experiment: str
    condition: str
    label: str
    n_pulses: int = 128
    integration_time_s: float = 4e-9
    scan_period_s: float = 0.2
    mobility: str = "skdu"


def cases() -> list[Case]:
    """Every curve of Figs. 2-4 (module docstring)."""
    out = []
    for cond in ("los", "olos"):
        out += [Case("npulse", cond, str(n), n_pulses=n) for n in (32, 128, 512)]
        out += [Case("tint", cond, str(t), integration_time_s=t * 1e-9) for t in (2, 4, 6)]
    out += [
        Case("mobility", "olos", f"{m} T={t}", scan_period_s=t, mobility=m)
        for t in (0.5, 0.2, 0.1)
        for m in ("skdu", "sdl")
    ]
    return out


def scenario(case: Case, fidelity: str, likelihood: str | None = None) -> tuple[ScenarioConfig, int]:
    """The case's scenario and the index of its waveform (``likelihood``: the PF's perception model, None: default)."""
    base = scenarios.get("indoor-monostatic")
    waveforms = tuple(
        dataclasses.replace(
            w,
            energy_detector=dataclasses.replace(w.energy_detector, integration_time_s=case.integration_time_s),
        )
        for w in base.waveforms
    )
    index = [w.n_pulses for w in waveforms].index(case.n_pulses)
    walls = base.walls
    pf = dataclasses.replace(base.tracker.pf, mobility=case.mobility)
    if likelihood is not None:
        pf = dataclasses.replace(pf, likelihood=likelihood)
    tracker = dataclasses.replace(base.tracker, kind="pf", pf=pf)
    cfg = dataclasses.replace(
        base,
        waveforms=waveforms,
        walls=base.walls if case.condition == "olos" else tuple(dataclasses.replace(w, material=AIR) for w in walls),
        tracker=tracker,
        n_scans=round(20.0 / case.scan_period_s),
        sensing=dataclasses.replace(base.sensing, scan_period_s=case.scan_period_s, fidelity=fidelity),
    )
    return cfg, index


def run_case(case: Case, fidelity: str, walks: int, likelihood: str | None = None) -> tuple[np.ndarray, int]:
    """The navigation errors [m] of every walk (outages as ``OUTAGE_M``) and the number of scans without estimate."""
    cfg, w = scenario(case, fidelity, likelihood)
    sim = Simulator(cfg)
    plan = ScanPlan.all_listening(w, sim.sensor.n_tx, sim.sensor.n_rx)
    errors, missing = [], 0
    for seed in range(walks):
        sim.reset(seed)
        started = False
        while not sim.done:
            res = sim.step(plan)
            truth = sim.truth.states[res.scan_index][0, [0, 2]]
            if len(res.tracks):
                x, _ = res.tracks.combined()
                errors.append(float(np.hypot(*(x[0, [0, 2]] - truth))))
                started = True
            elif started:
                errors.append(OUTAGE_M)
                missing += 1
    return np.array(errors), missing


def main() -> None:
    """Run every case, write neo.csv, summary.md and the figures."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fidelity", choices=("parametric", "signal"), default="parametric")
    ap.add_argument("--walks", type=int, default=5)
    ap.add_argument(
        "--likelihood",
        choices=("snr", "seed", "both"),
        help="the PF's perception model: each detection's sigma(SNR) (snr, the default), the seed's fixed sigma_p "
        "(seed), or both",
    )
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--out", default="results/seed002-neo")
    args = ap.parse_args()
    if args.walks < 1:
        raise SystemExit(f"--walks={args.walks}: must be >= 1")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    all_cases = cases()
    with ProcessPoolExecutor(args.workers) as pool:
        n = len(all_cases)
        results = list(pool.map(run_case, all_cases, [args.fidelity] * n, [args.walks] * n, [args.likelihood] * n))
    rows = ["experiment,condition,label," + ",".join(f"{t:.2f}" for t in THRESHOLDS)]
    table = [
        f"# Seed 002: NEO of the particle filter on indoor-monostatic ({args.fidelity} fidelity, {args.walks} walks)",
        "",
        "Command: `python scripts/seed002_neo.py --fidelity "
        + f"{args.fidelity} --walks {args.walks}"
        + (f" --likelihood {args.likelihood}" if args.likelihood else "")
        + f" --out {out}`",
        "",
        "| experiment | condition | case | 80 % point [m] | seed [m] | scans | scans without estimate |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    curves = {}
    for case, (errors, missing) in zip(all_cases, results, strict=True):
        neo = navigation_error_outage(np.where(errors >= OUTAGE_M, np.inf, errors), THRESHOLDS)
        # outages (no estimate) exceed every threshold: fold them back in after the finite errors' curve
        n, n_out = errors.size, int((errors >= OUTAGE_M).sum())
        neo = (neo * (n - n_out) + n_out) / max(n, 1)
        curves[case] = neo
        at80 = error_at_outage(errors) if n else float("nan")
        seed = SEED.get((case.experiment, case.condition), {}).get(case.label)
        rows.append(f"{case.experiment},{case.condition},{case.label}," + ",".join(f"{v:.5f}" for v in neo))
        table.append(
            f"| {case.experiment} | {case.condition} | {case.label} | {at80:.2f} | "
            f"{'' if seed is None else f'{seed:.1f}'} | {n} | {missing} |"
        )
    (out / "neo.csv").write_text("\n".join(rows) + "\n")
    (out / "summary.md").write_text("\n".join(table) + "\n")
    _plot(curves, out)
    print("\n".join(table))


def _plot(curves: dict[Case, np.ndarray], out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    for experiment in ("npulse", "tint", "mobility"):
        fig, ax = plt.subplots(figsize=(6, 4))
        for case, neo in curves.items():
            if case.experiment != experiment:
                continue
            style = "-" if case.condition == "los" else "--"
            ax.semilogy(THRESHOLDS, np.maximum(neo, 1e-3), style, label=f"{case.condition} {case.label}")
        ax.axhline(0.2, color="grey", lw=0.8)
        ax.set(xlabel="e_th [m]", ylabel="NEO = P(e > e_th)", ylim=(1e-3, 1.1), title=f"seed 002: {experiment}")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(out / f"neo_{experiment}.png", dpi=120)
        plt.close(fig)


if __name__ == "__main__":
    main()
