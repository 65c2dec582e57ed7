"""Calibration of the through-wall parametric model on its signal path (seed 001's chain), end to end on the walks.

Usage:
    python scripts/calibrate_through_wall.py --out results/calibration-through-wall [--runs 2] [--power-db 0 -10 -20]

``scripts/calibrate_parametric.py`` does not fit this chain: its controlled scans are single scans over the empty
room's reference, while seed 001's chain subtracts an exponentially averaged background (alpha 0.9) and normalizes
by the advance maxima, so a lone scan over a static reference is mostly false alarms (echo-free gates hit in 28-30 %
of the scans, 2-4 false ToAs per scan). Here both fidelities play the scenario's own walks (two persons behind the
brick wall), one waveform per episode, the transmitter's power shifted by ``--power-db`` to sweep the SNR, ``--runs``
seeds each. Per scan, receiver and person (the parametric pair's bistatic range, walls' delay included):

* signal path: the chain's per-receiver interval ToAs (``SignalSensor.detect``, before the ToA association); a
  person is detected when a ToA lies within ``GATE_M`` of its bistatic range, less the chance hits of the false
  ToAs (their density per metre of range times the gate's 2 ``GATE_M``: Pd = (h - f0) / (1 - f0)); every ToA
  farther than ``GATE_M`` from both persons and inside the parametric false alarms' range span (``span_m``: the
  surveillance area's) is a false detection; the range errors of the nearest ToAs split, as
  ``seed001_through_wall.calibrate``, into the part independent per receiver (E[(e_1 - e_2)^2] / 2) and the part
  common to both (var of the mean less half the independent), about their mean (the interval ToA's offset).
* parametric path: its detections of the same scans (``ParametricSensor.sense``): a person detected in a pair when a
  detection of that origin is there; false detections the origin -1 rows; the range error of the person detections
  against the free-space bistatic range (the radar compensates the wall, ``sensing.compensate_walls``).

The cells are binned by the person's mean integrated SNR (the parametric radar constant times the geometry's unit SNR,
walls' loss included) times what seed 001's exponential background leaves of the echo at the person's bistatic
range-rate history (``ParametricSensor.mti_history``, ``uwb_env.channel.background_mti``: 0.12 for a Swerling III person
standing still, ~1.06 while walking), per waveform. The parametric Pd is the Swerling case ``--swerling`` (the
scenario's ``sensing.detection_swerling``: I) at the Pfa of the chain's decision, the interval test's binomial tail
P(Bin(W_p, cfar_pfa) >= T_LIM) (``through_wall.interval_test_pfa``, 1.25e-5; ``--log-pfa`` searches a grid instead),
with the gain ``detection_gain_db`` (and each waveform's own) and the clutter residue (ratio, looks) fitted by grid
search (``--criterion``: the binomial likelihood of the signal's hits among the forms whose largest |Pd difference|
holds within ``--max-dpd``, the default, or the largest |Pd difference|) over the bins holding at least ``MIN_CELLS``
cells: one Pfa and residue for all, one gain per waveform. ``--compare`` fits a second form (by default the previous
one, Swerling III at the CFAR's Pfa 1e-2) on the same cells and reports both forms' likelihoods. ``--cells`` keeps the
signal path's cells in a file (they do not depend on the parametric constants) for the next run. The false rate per scan
and pair gives ``clutter.density_per_m2`` from the first waveform's and each waveform's ``false_alarm_factor`` over it
(the parametric false count is density x factor x the pair's gate area, linear in both).

The check: parametric and signal Pd within 0.05 (every populated bin), false rates within 20 %, range spread within
30 % (the parametric independent std against the chain's per-receiver total, hypot(independent, common): the
parametric model draws every pair's range independently, ``ParametricSensor._measure``). Then the tracker on the
scenario's parametric path (``tracker_check``). Writes calibration.md and pd.png.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import math
import operator
import pickle
import sys
from pathlib import Path

import numpy as np

from uwb_env import scenarios
from uwb_env.rng import RngStreams
from uwb_env.scenarios.through_wall import interval_test_pfa
from uwb_env.scene import sample_truth
from uwb_env.sensing import ParametricSensor, ScanPlan
from uwb_env.sensing.parametric import residue_quadrature
from uwb_env.sensing.pd import detection_probability
from uwb_env.sensing.signal import SignalSensor

GATE_M = 0.5
"""A ToA within this of a person's bistatic range is that person's [m] (``seed001_through_wall.CALIBRATION_GATE_M``)."""
MIN_CELLS = 60
"""A SNR bin enters the Pd check with at least this many (scan, receiver, person) cells (binomial std <= 0.065)."""
SNR_STEP_DB = 3.0
MIN_SEPARATION_M = 1.5
"""The Pd fit's cells: persons this far apart in bistatic range [m]. Nearer (0.5-1.5 m), the two persons' echoes
fall in one interval of the ToA estimator (W_p = 15 samples: 1.0 m of bistatic range, the bodies' extent on top):
one interval ToA, the nearer person's, and the farther person missed -- a resolution loss the parametric model (one
detection test per target) does not have; the report gives its Pd apart."""


def _overrides(fidelity: str, power_db: float, extra: dict) -> dict:
    base = scenarios.get("through-wall")
    tx = tuple(dataclasses.replace(t, power_dbm=t.power_dbm + power_db) for t in base.transmitters)
    return {"sensing.fidelity": fidelity, "transmitters": tx, **extra}


def span_m(cfg, baseline: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(R,)`` each receiver's bistatic range span of the parametric false alarms [m].

    From the blind zone's edge (baseline + ``blind_zone_excess_m``) to the farthest corner of the surveillance area
    (the bistatic range is convex: its maximum over the box is at a corner). The chain's ToAs beyond it (the room's
    reverberation, 13-25 m of bistatic range: most of its false ToAs) are outside the room, where the parametric
    model draws none; the tracker's area holds no person there.
    """
    a = cfg.surveillance_area
    corners = np.array([(x, y) for x in (a.x_min_m, a.x_max_m) for y in (a.y_min_m, a.y_max_m)])
    tx = np.array(cfg.transmitters[0].position_m)
    rx = np.array([r.position_m for r in cfg.receivers])
    far = np.linalg.norm(corners - tx, axis=1)[None] + np.linalg.norm(corners[None] - rx[:, None], axis=-1)
    return np.asarray(baseline, dtype=float) + cfg.sensing.blind_zone_excess_m, far.max(axis=1)


def signal_cells(seed: int, w: int, power_db: float, extra: dict) -> dict:
    """Signal path, waveform ``w``, one run: per (scan, rx, person) SNR [linear], hit, nearest error; false ToAs."""
    cfg = scenarios.get("through-wall", **_overrides("signal", power_db, extra))
    s = SignalSensor(cfg)
    rngs = RngStreams.from_seed(seed)
    truth = sample_truth(cfg, rngs.truth, s.layout)
    ep = s.new_episode(truth, rngs)
    plan = ScanPlan.all_listening(w, s.n_tx, s.n_rx)
    snr = s.model.radar_constant[w, 0][None, :, None] * ep.geom.unit_snr[:, 0]  # (S + 1, R, K)
    snr = snr * s.model.mti_history(ep.geom)[w, :, 0]  # what the exponential background leaves (MTI)
    out = {"snr": [], "sep": [], "dp": [], "hit": [], "false": 0, "false_span_m": 0.0, "slots": 0}
    lo, hi = span_m(cfg, s.baseline)
    out["err"] = np.full((cfg.n_scans, s.n_rx, truth.states.shape[1]), math.nan)
    for k in range(1, cfg.n_scans + 1):  # scans
        scans, active = s.synthesise(ep, k, plan)
        tr = s.detect(ep, k, plan, scans, active)
        truth_r = ep.geom.bistatic_range[k, 0]  # (R, K), the walls' delay included
        covered = ep.geom.covered[k, 0]
        for i in range(s.n_rx):  # receivers: two
            toas = tr.ranges[tr.toa_row == i]
            near = np.abs(toas[:, None] - truth_r[i][None]) < GATE_M  # (D, K)
            inside = (toas >= lo[i]) & (toas <= hi[i])  # where the parametric false alarms lie
            out["false"] += int(np.sum(~near.any(axis=1) & inside))
            out["slots"] += 1
            for j in range(truth_r.shape[1]):  # persons: two
                if not covered[i, j]:
                    continue
                d = toas - truth_r[i, j]
                hit = bool(d.size) and float(np.abs(d).min()) < GATE_M
                out["snr"].append(float(snr[k, i, j]))
                out["sep"].append(float(np.min(np.abs(np.delete(truth_r[i], j) - truth_r[i, j]), initial=np.inf)))
                out["dp"].append(float(s.dp_snr[w, i]))
                out["hit"].append(hit)
                if hit:
                    out["err"][k - 1, i, j] = float(d[np.argmin(np.abs(d))])
    span = float(np.mean(hi - lo))
    out["false_span_m"] = span
    # the chance that a false ToA of this run falls in a person's gate (their density per metre of range)
    out["f0"] = np.full(len(out["snr"]), 1.0 - math.exp(-out["false"] / out["slots"] / span * 2.0 * GATE_M))
    return out


def parametric_cells(seed: int, w: int, power_db: float, extra: dict) -> dict:
    """Parametric path, the same walks and waveform: per (scan, pair, person) SNR, hit, error; false detections."""
    cfg = scenarios.get("through-wall", **_overrides("parametric", power_db, extra))
    s = ParametricSensor(cfg)
    rngs = RngStreams.from_seed(seed)
    truth = sample_truth(cfg, rngs.truth, s.layout)
    ep = s.new_episode(truth, rngs)
    plan = ScanPlan.all_listening(w, s.n_tx, s.n_rx)
    geom = ep.geometry
    snr = s.radar_constant[w, 0][None, :, None] * geom.unit_snr[:, 0]
    snr = snr * s.mti_history(geom)[w, :, 0]  # what the exponential background leaves (MTI)
    tx = s.layout.tx_pos[0]
    out = {"snr": [], "sep": [], "hit": [], "false": 0, "slots": 0}
    out["err"] = np.full((cfg.n_scans, s.n_rx, truth.states.shape[1]), math.nan)
    for k in range(1, cfg.n_scans + 1):  # scans
        pos = truth.states[k][:, [0, 2]]
        dets = {int(d.rx): d for d in s.sense(ep, k, plan, 0.0)}
        for i in range(s.n_rx):
            d = dets.get(i)
            out["slots"] += 1
            if d is not None:
                out["false"] += int(np.sum(d.origin < 0))
            for j in range(pos.shape[0]):
                if not geom.covered[k, 0, i, j]:
                    continue
                sel = np.flatnonzero(d.origin == j) if d is not None else np.zeros(0, np.int64)
                out["snr"].append(float(snr[k, i, j]))
                rk = geom.bistatic_range[k, 0, i]
                out["sep"].append(float(np.min(np.abs(np.delete(rk, j) - rk[j]), initial=np.inf)))
                out["hit"].append(sel.size > 0)
                r = np.linalg.norm(pos[j] - tx) + np.linalg.norm(pos[j] - s.layout.rx_pos[i])
                if sel.size:
                    out["err"][k - 1, i, j] = float(d.z[sel[0], 0] - r)
    return out


def tracker_check(runs: int, waveform: int, overrides: dict | None = None) -> dict:
    """The scenario's tracker on its parametric path, waveform fixed, runs ``0..runs-1``.

    Per run (``uwb_env.metrics.TrackAccounting``, gate 1 m): each person's coverage (the fraction of its scans a
    confirmed track holds it), the false tracks (matched to a person in fewer than half of their confirmed scans) and
    the RMSE of the held scans. Returns the mean coverage per person, the runs with both persons held in >= 50 % of
    the scans, the false tracks per run and the mean RMSE.
    """
    from uwb_env.metrics import TrackAccounting
    from uwb_env.sim import Simulator

    cfg = scenarios.get("through-wall", **{"sensing.fidelity": "parametric", **(overrides or {})})
    sim = Simulator(cfg)
    cov, false, rmse = [], [], []
    for seed in range(runs):  # runs: a dozen
        sim.reset(seed)
        acc = TrackAccounting(sim.truth.n_targets, 1.0)
        while not sim.done:
            res = sim.step(ScanPlan.all_listening(waveform, 1, 2))
            k = res.scan_index
            x, _ = res.tracks.combined()
            truth = sim.truth.states[k][:, [0, 2]]
            acc.add(res.tracks.ids, res.tracks.confirmed, x[:, [0, 2]], truth, sim.truth.alive[k])
        cov.append(acc.coverage())
        false.append(acc.false_tracks())
        rmse.append(float(np.sqrt(np.nanmean(np.array(acc.errors) ** 2))))
    cov = np.array(cov)
    return {
        "coverage": cov.mean(axis=0),
        "both": int(np.sum(np.all(cov >= 0.5, axis=1))),
        "false_per_run": float(np.mean(false)),
        "rmse_m": float(np.mean(rmse)),
    }


def split_errors(err: np.ndarray) -> tuple[float, float, float]:
    """(mean, independent std, common std) of ``(N, 2)`` range errors of one person in both receivers [m]."""
    ind2 = float(np.mean((err[:, 0] - err[:, 1]) ** 2) / 2.0)
    com2 = float(np.var(err.mean(axis=1)) - ind2 / 2.0)
    return float(err.mean()), math.sqrt(ind2), math.sqrt(max(com2, 0.0))


def paired(cells: list[dict]) -> np.ndarray:
    """``(N, 2)`` errors of (scan, person) slots detected by both receivers (the cells in scan, rx, person order)."""
    rows = []
    for c in cells:
        e = c["err"]  # (scan, rx, person)
        both = np.isfinite(e).all(axis=1)
        rows.append(np.stack([e[:, 0][both], e[:, 1][both]], axis=-1))
    return np.concatenate(rows) if rows else np.zeros((0, 2))


def main() -> None:
    """The command line (the module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=Path("results/calibration-through-wall"))
    ap.add_argument("--runs", type=int, default=2)
    ap.add_argument("--power-db", nargs="+", type=float, default=[0.0, -20.0, -30.0, -35.0, -40.0, -45.0, -50.0, -60.0])
    ap.add_argument(
        "--tracker-runs", type=int, default=12, help="runs of the tracker check (parametric path; 0: no check)"
    )
    ap.add_argument(
        "--log-pfa",
        nargs=3,
        type=float,
        default=None,
        metavar=("FROM", "TO", "STEP"),
        help="search the Pfa over this grid of log10 (default: the interval test's binomial tail, fixed)",
    )
    ap.add_argument("--swerling", type=int, choices=(0, 1, 3), default=None, help="the fitted form's Swerling case")
    ap.add_argument(
        "--criterion",
        choices=("loglik", "max"),
        default="loglik",
        help="loglik: the likeliest form whose |Pd difference| holds within --max-dpd; max: the smallest largest one",
    )
    ap.add_argument("--max-dpd", type=float, default=0.05, help="the check's largest |Pd difference| per bin")
    ap.add_argument(
        "--compare",
        nargs=2,
        type=float,
        default=(3.0, 1e-2),
        metavar=("SWERLING", "PFA"),
        help="a second form fitted on the same cells (default: the previous Swerling III at Pfa 1e-2)",
    )
    ap.add_argument("--model-cells", type=int, default=40, help="run 0's cells per bin the model's Pd averages over")
    ap.add_argument("--cells", type=Path, default=None, help="a file keeping the signal path's cells across runs")
    ap.add_argument(
        "--min-separation",
        type=float,
        default=MIN_SEPARATION_M,
        help="the Pd fit's cells: a person at least this far from the other's bistatic range [m]",
    )
    ap.add_argument(
        "--log-kappa",
        nargs="+",
        type=float,
        default=(-9.0, -5.0),
        metavar="FROM TO [STEP]",
        help="the residue ratio's grid of log10 (step 0.25 unless given; 0 is always tried)",
    )
    ap.add_argument("--looks", nargs="+", type=float, default=[1.0, 2.0, 4.0, 8.0])
    ap.add_argument("--gain-db", nargs=3, type=float, default=(-10.0, 10.0, 0.5), metavar=("FROM", "TO", "STEP"))
    args = ap.parse_args()
    if args.tracker_runs < 0:
        ap.error(f"--tracker-runs {args.tracker_runs}: must be >= 0")
    args.out.mkdir(parents=True, exist_ok=True)
    cfg = scenarios.get("through-wall")
    names = [wf.name for wf in cfg.waveforms]
    W = len(names)
    key = (args.runs, tuple(args.power_db))
    sig = None
    if args.cells is not None and args.cells.exists():
        stored = pickle.loads(args.cells.read_bytes())
        sig = stored["sig"] if stored.get("key") == key else None
    if sig is None:
        sig = {w: [signal_cells(r, w, p, {}) for p in args.power_db for r in range(args.runs)] for w in range(W)}
        if args.cells is not None:
            args.cells.write_bytes(pickle.dumps({"key": key, "sig": sig}))
    par = {w: [parametric_cells(r, w, p, {}) for p in args.power_db for r in range(args.runs)] for w in range(W)}

    # false detections per scan and receiver; their density per metre gives the gate's chance hits
    # at the scenario's power (0 dB): the signal's false ToAs grow with the power (the static paths' residue and the
    # persons' own trails scale with it), the parametric false alarms do not depend on it
    nominal = [c for i, p in enumerate(args.power_db) if p == 0.0 for c in range(i * args.runs, (i + 1) * args.runs)]
    if not nominal:
        raise SystemExit("--power-db must include 0 (the scenario's power)")
    s_false = {w: np.mean([sig[w][c]["false"] / sig[w][c]["slots"] for c in nominal]) for w in range(W)}
    p_false = {w: np.mean([par[w][c]["false"] / par[w][c]["slots"] for c in nominal]) for w in range(W)}

    def cat(cells: list[dict], key: str) -> np.ndarray:
        return np.concatenate([np.asarray(c[key], dtype=float) for c in cells])

    def binned(cells: list[dict], far: bool = True) -> dict:
        """SNR bins of the cells whose person is ``--min-separation`` or more from the other's bistatic range.

        Or, ``far`` False, nearer: keys, cells, hit rate and the cells' SNR, bin and run (0: the model's cells).
        """
        sep = cat(cells, "sep")
        sel = sep >= args.min_separation if far else sep < args.min_separation
        snr = cat(cells, "snr")[sel]
        hit = cat(cells, "hit")[sel]
        run = np.concatenate([np.full(len(c["snr"]), i % args.runs) for i, c in enumerate(cells)])[sel]
        b = np.floor(10.0 * np.log10(snr) / SNR_STEP_DB).astype(int)
        keys = np.unique(b)
        return {
            "keys": keys,
            "n": np.array([np.sum(b == q) for q in keys]),
            "rate": np.array([hit[b == q].mean() for q in keys]),
            "snr": snr,
            "b": b,
            "run": run,
            "sel": sel,
        }

    bins = {}
    f0 = {}
    for w in range(W):
        d = binned(sig[w])
        cf0 = cat(sig[w], "f0")[d["sel"]]
        f0[w] = np.array([cf0[d["b"] == q].mean() for q in d["keys"]])
        d["pd"] = np.clip((d["rate"] - f0[w]) / (1.0 - f0[w]), 0.0, 1.0)
        d["dp"] = cat(sig[w], "dp")[d["sel"]]
        # the model's cells: run 0's (every run has the same walks, so the same SNRs), at most --model-cells per bin
        keep = np.zeros(d["b"].size, bool)
        for q in d["keys"]:
            idx = np.flatnonzero((d["b"] == q) & (d["run"] == 0))
            keep[idx[np.linspace(0, idx.size - 1, min(idx.size, args.model_cells)).astype(int)]] = True
        d["m_snr"], d["m_dp"], d["m_b"] = d["snr"][keep], d["dp"][keep], d["b"][keep]
        bins[w] = d

    sig_cfg = cfg.sensing.signal
    chain_pfa = interval_test_pfa(sig_cfg.toa_interval_samples, sig_cfg.toa_interval_threshold, sig_cfg.cfar_pfa)
    if args.log_pfa is None:
        pfas = np.array([chain_pfa])
    else:
        pfas = 10.0 ** np.arange(args.log_pfa[0], args.log_pfa[1] + 1e-9, args.log_pfa[2])
    swerling = args.swerling
    if swerling is None:
        swerling = cfg.sensing.detection_swerling
        swerling = cfg.targets[0].swerling if swerling is None else swerling
    gains = np.arange(args.gain_db[0], args.gain_db[1] + 1e-9, args.gain_db[2])
    if len(args.log_kappa) not in (2, 3):
        raise SystemExit("--log-kappa takes FROM TO [STEP]")
    k_step = args.log_kappa[2] if len(args.log_kappa) == 3 else 0.25
    kappas = np.concatenate([[0.0], 10.0 ** np.arange(args.log_kappa[0], args.log_kappa[1] + 1e-9, k_step)])
    quads = {m: residue_quadrature(m) for m in args.looks}
    log_x = np.linspace(-4.0, 12.0, 3201)  # Pd tabulated over log10 SNR per (Pfa, case): interpolated in the search
    tables: dict[tuple[float, int], np.ndarray] = {}

    def model_bins(w: int, pfa: float, g_db, kappa: float, looks: float, case: int) -> np.ndarray:
        """``(G, bins)`` parametric Pd (Swerling ``case``) with the residue, averaged over each bin's cells."""
        if (pfa, case) not in tables:
            tables[pfa, case] = detection_probability(10.0**log_x, pfa, case)
        d = bins[w]
        x, wq = quads[looks] if kappa > 0.0 else (np.ones(1), np.ones(1))
        scnr = d["m_snr"][:, None] / (1.0 + kappa * d["m_dp"][:, None] * x[None])  # (C, Q)
        lg = np.log10(scnr)[None] + np.atleast_1d(g_db)[:, None, None] / 10.0
        pd = np.interp(lg, log_x, tables[pfa, case]) @ wq  # (G, C)
        return np.stack([pd[:, d["m_b"] == q].mean(axis=1) for q in d["keys"]], axis=1)

    def neg_loglik(w: int, q: np.ndarray) -> np.ndarray:
        """``(G,)`` -log likelihood of the signal's hits (Pd x cells per bin, bins of >= MIN_CELLS) under ``q``."""
        d = bins[w]
        ok = d["n"] >= MIN_CELLS
        n, h = d["n"][ok], d["pd"][ok] * d["n"][ok]
        q = np.clip(q[:, ok], 1e-12, 1.0 - 1e-12)
        return -np.sum(h * np.log(q) + (n - h) * np.log1p(-q), axis=1)

    def fit(case: int, pfa_grid: np.ndarray) -> tuple:
        """(criterion, Pfa, gains, max |dPd| per waveform, kappa, looks, -loglik per waveform) of the best form."""
        best = None
        for looks in args.looks:
            for kappa in kappas:
                if kappa == 0.0 and looks != args.looks[0]:
                    continue
                for pfa in pfa_grid:
                    errs, gsel, nll = [], [], []
                    for w in range(W):
                        ok = bins[w]["n"] >= MIN_CELLS
                        m = model_bins(w, pfa, gains, kappa, looks, case)
                        e = np.max(np.abs(m - bins[w]["pd"][None])[:, ok], axis=1)
                        ll = neg_loglik(w, m)
                        if args.criterion == "loglik" and np.any(e <= args.max_dpd):  # the likeliest that holds
                            g = int(np.argmin(np.where(e <= args.max_dpd, ll, np.inf)))
                        else:
                            g = int(np.argmin(ll if args.criterion == "loglik" else e))
                        gsel.append(float(gains[g]))
                        errs.append(float(e[g]))
                        nll.append(float(ll[g]))
                    # loglik: a form that holds every waveform within --max-dpd before one that does not
                    score = (max(errs) > args.max_dpd, sum(nll)) if args.criterion == "loglik" else (False, max(errs))
                    if best is None or score < best[0]:
                        best = (score, pfa, gsel, errs, kappa, looks, nll)
        return best

    _, pfa, gsel, errs, kappa, looks, nll = fit(swerling, pfas)
    worst = max(errs)
    c_case, c_pfa = int(args.compare[0]), float(args.compare[1])
    _, _, c_gsel, c_errs, c_kappa, c_looks, c_nll = fit(c_case, np.array([c_pfa]))

    def shadow(w: int, pd: np.ndarray) -> str:
        """The cells' mean Pd over the bins below 6 dB of SNR (``pd`` per bin), as text."""
        low = (bins[w]["keys"] + 1) * SNR_STEP_DB <= 6.0
        n = bins[w]["n"][low]
        return f"{float(np.sum(n * pd[low]) / max(n.sum(), 1)):.3f} ({int(n.sum())} cells)"

    # the scenario's own constants on the same cells (its gain, residue, Pfa and case)
    sc = cfg.sensing
    sc_case = sc.detection_swerling if sc.detection_swerling is not None else cfg.targets[0].swerling
    sc_nll = [
        float(
            neg_loglik(
                w,
                model_bins(
                    w,
                    sc.false_alarm_probability,
                    sc.detection_gain_db + cfg.waveforms[w].detection_gain_db,
                    sc.clutter_residue_ratio,
                    sc.clutter_residue_looks if sc.clutter_residue_ratio > 0.0 else args.looks[0],
                    sc_case,
                ),
            )[0]
        )
        for w in range(W)
    ]
    # the false rates at the scenario's power, linear in the density x each waveform's false_alarm_factor: the density
    # that gives the first waveform's (the reference) and each other waveform's factor over it
    # (ImpulseWaveformConfig.false_alarm_factor: the chain's false ToAs grow with the waveform's energy)
    ratio = {w: s_false[w] / p_false[w] for w in range(W)}
    density = cfg.sensing.clutter.density_per_m2 * ratio[0]
    current = [getattr(wf, "false_alarm_factor", 1.0) for wf in cfg.waveforms]  # the scenario's
    factors = [current[w] * ratio[w] / ratio[0] for w in range(W)]

    # parametric Pd as simulated (the scenario's constants), per bin of the same edges
    lines = [
        "# Calibration of the through-wall parametric model on its signal path",
        "",
        f"Command: `python scripts/calibrate_through_wall.py {' '.join(sys.argv[1:])}`",
        "",
        f"{args.runs} runs x {len(args.power_db)} transmitter powers ({', '.join(f'{p:+g}' for p in args.power_db)} "
        f"dB on the scenario's) x {cfg.n_scans} scans per waveform, both fidelities on the same walks; a person's "
        f"(scan, receiver) cell is detected with a ToA within {GATE_M} m of its bistatic range (signal: less the "
        "false ToAs' chance hits in the gate).",
        "",
        f"* the chain's decision, the interval ToA test (T_LIM = {sig_cfg.toa_interval_threshold} of W_p = "
        f"{sig_cfg.toa_interval_samples} samples above the CFAR's threshold of design Pfa {sig_cfg.cfar_pfa:g}): on "
        f"noise alone P(Bin({sig_cfg.toa_interval_samples}, {sig_cfg.cfar_pfa:g}) >= "
        f"{sig_cfg.toa_interval_threshold}) = {chain_pfa:.3g} per window",
        f"* fitted parametric detector (Swerling {'0' if swerling == 0 else 'I' if swerling == 1 else 'III'}, "
        f"criterion {args.criterion}): Pfa {pfa:.3g}, clutter residue ratio {kappa:.3g} of "
        f"{looks:g} looks, gains "
        + ", ".join(f"{names[w]} {gsel[w]:+g} dB" for w in range(W))
        + f"; largest |Pd difference| per waveform over bins of >= {MIN_CELLS} cells: "
        + ", ".join(f"{names[w]} {errs[w]:.3f}" for w in range(W))
        + "; -log likelihood of the signal's hits: "
        + ", ".join(f"{names[w]} {nll[w]:.0f}" for w in range(W))
        + f" (sum {sum(nll):.0f})"
        + f" (scenario's: Pfa {cfg.sensing.false_alarm_probability:.3g}, Swerling {sc_case}, residue "
        f"{cfg.sensing.clutter_residue_ratio:g} of {cfg.sensing.clutter_residue_looks:g} looks, gain "
        f"{cfg.sensing.detection_gain_db:g} dB, "
        + ", ".join(f"{wf.name} {wf.detection_gain_db:g} dB" for wf in cfg.waveforms)
        + "; -log likelihood "
        + ", ".join(f"{names[w]} {sc_nll[w]:.0f}" for w in range(W))
        + f", sum {sum(sc_nll):.0f})",
        f"* compared form (Swerling {c_case}, Pfa {c_pfa:.3g}, fitted the same way): residue {c_kappa:.3g} of "
        f"{c_looks:g} looks, gains "
        + ", ".join(f"{names[w]} {c_gsel[w]:+g} dB" for w in range(W))
        + "; largest |Pd difference| "
        + ", ".join(f"{names[w]} {c_errs[w]:.3f}" for w in range(W))
        + "; -log likelihood "
        + ", ".join(f"{names[w]} {c_nll[w]:.0f}" for w in range(W))
        + f" (sum {sum(c_nll):.0f}; the fitted form's less by {sum(c_nll) - sum(nll):.0f})",
        "* mean Pd of the cells below 6 dB (the shadow: signal / fitted / compared): "
        + ", ".join(
            f"{names[w]} {shadow(w, bins[w]['pd'])} / "
            f"{shadow(w, model_bins(w, pfa, gsel[w], kappa, looks, swerling)[0])}"
            f" / {shadow(w, model_bins(w, c_pfa, c_gsel[w], c_kappa, c_looks, c_case)[0])}"
            for w in range(W)
        ),
        "* false detections per scan and receiver at the scenario's power: "
        + ", ".join(f"{names[w]} signal {s_false[w]:.3f} / parametric {p_false[w]:.3f}" for w in range(W))
        + f" (the signal's chance hits in the {2 * GATE_M:g} m gate, removed from its Pd: up to "
        + ", ".join(f"{f0[w].max():.3f}" for w in range(W))
        + ")",
        f"* the false rates fitted per waveform: sensing.clutter.density_per_m2 = {density:.4g} ({names[0]}'s; "
        f"scenario's: {cfg.sensing.clutter.density_per_m2:g}), false_alarm_factor "
        + ", ".join(f"{names[w]} {factors[w]:.3g} (scenario's {current[w]:g})" for w in range(W)),
    ]
    pe = paired(functools.reduce(operator.iadd, (sig[w] for w in range(W)), []))
    qe = paired(functools.reduce(operator.iadd, (par[w] for w in range(W)), []))
    s_mean, s_ind, s_com = split_errors(pe)
    q_mean, q_ind, q_com = split_errors(qe)
    s_tot, q_tot = math.hypot(s_ind, s_com), math.hypot(q_ind, q_com)
    lines += [
        f"* range error (both receivers holding the person, {pe.shape[0]} signal / {qe.shape[0]} parametric slots): "
        f"signal mean {s_mean:+.3f} m, independent {s_ind:.3f} m, common {s_com:.3f} m, per receiver "
        f"{s_tot:.3f} m; parametric mean {q_mean:+.3f} m, independent {q_ind:.3f} m, common {q_com:.3f} m, per "
        f"receiver {q_tot:.3f} m",
    ]
    pd_ok = worst <= args.max_dpd
    near = []
    for w in range(W):  # the persons nearer than --min-separation in bistatic range, at the scenario's power
        sn = [sig[w][c] for c in nominal]
        pn = [par[w][c] for c in nominal]
        ms, mp = cat(sn, "sep") < args.min_separation, cat(pn, "sep") < args.min_separation
        near.append((names[w], int(ms.sum()), cat(sn, "hit")[ms].mean(), cat(pn, "hit")[mp].mean(),
                     cat(sn, "hit")[~ms].mean(), cat(pn, "hit")[~mp].mean()))  # fmt: skip
    lines.append(
        f"* persons nearer than {args.min_separation:g} m in bistatic range (left out of the fit: one interval ToA "
        "for both), hit rate at the scenario's power, signal / parametric: "
        + ", ".join(f"{n} {a:.2f} / {b:.2f} ({c} cells; apart: {d:.2f} / {e:.2f})" for n, c, a, b, d, e in near)
    )
    sim_pd = {}
    for w in range(W):
        d = binned(par[w])
        sim_pd[w] = dict(zip(d["keys"].tolist(), zip(d["n"].tolist(), d["rate"].tolist(), strict=True), strict=True))
    sim_worst = []
    for w in range(W):  # the scenario's parametric sensor as simulated, against the signal (bins of >= MIN_CELLS)
        d = bins[w]
        diffs = [abs(sim_pd[w][int(q)][1] - pd) for q, n, pd in zip(d["keys"], d["n"], d["pd"], strict=True)
                 if n >= MIN_CELLS and int(q) in sim_pd[w]]  # fmt: skip
        sim_worst.append(max(diffs))
    lines.append(
        "* the scenario's parametric sensor as simulated on the same scans against the signal, largest |Pd difference| "
        f"over bins of >= {MIN_CELLS} cells: " + ", ".join(f"{names[w]} {sim_worst[w]:.3f}" for w in range(W))
    )
    rel = [100.0 * (p_false[w] / s_false[w] - 1.0) for w in range(W)]  # parametric against signal [%]
    false_ok = all(abs(r) <= 20.0 for r in rel)
    spread_ok = abs(q_tot - s_tot) <= 0.3 * s_tot
    if args.tracker_runs > 0:  # 0: no tracker check (a refit's quick look)
        trk = tracker_check(args.tracker_runs, 0)
        lines.append(
            f"* the tracker on the scenario's parametric path ({names[0]}, runs 0-{args.tracker_runs - 1}): coverage "
            f"per person {', '.join(f'{c:.2f}' for c in trk['coverage'])}, both held in >= 50 % of the scans in "
            f"{trk['both']} / {args.tracker_runs} runs, {trk['false_per_run']:.2f} false tracks per run, RMSE "
            f"{trk['rmse_m']:.2f} m"
        )
    lines += [
        "",
        "Check (parametric and signal Pd within 0.05, false rates within 20 %, spread within 30 %): "
        f"Pd {'holds' if pd_ok else 'fails'} (fitted, largest {worst:.3f}); false rates with the scenario's density "
        f"{'hold' if false_ok else 'fail'} ("
        + ", ".join(f"{names[w]} {rel[w]:+.0f} %" for w in range(W))
        + f"); spread {'holds' if spread_ok else 'fails'} "
        f"({q_tot:.3f} vs {s_tot:.3f} m, {100 * (q_tot / s_tot - 1):+.0f} %).",
        "",
        "| waveform | SNR bin [dB] | cells | Pd signal | Pd parametric (fitted) | Pd parametric (simulated) |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for w in range(W):
        m = model_bins(w, pfa, gsel[w], kappa, looks, swerling)[0]
        for q, n, a, b in zip(bins[w]["keys"], bins[w]["n"], bins[w]["pd"], m, strict=True):
            sp = sim_pd[w].get(int(q))
            lines.append(
                f"| {names[w]} | {q * SNR_STEP_DB:.0f}-{(q + 1) * SNR_STEP_DB:.0f} | {n} | {a:.3f} | {b:.3f} | "
                + (f"{sp[1]:.3f} ({sp[0]})" if sp else "-")
                + " |"
            )
    (args.out / "calibration.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines[:14]))

    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for w in range(W):
        d = bins[w]
        ok = d["n"] >= MIN_CELLS
        x = (d["keys"] + 0.5) * SNR_STEP_DB
        (line,) = ax.plot(x[ok], d["pd"][ok], "o", ms=4, label=f"{names[w]} signal")
        ax.plot(
            x[ok],
            model_bins(w, pfa, gsel[w], kappa, looks, swerling)[0][ok],
            "-",
            color=line.get_color(),
            lw=1,
            label=f"{names[w]} fit",
        )
        sp = [(q, v) for q, v in sim_pd[w].items() if v[0] >= MIN_CELLS]
        ax.plot([(q + 0.5) * SNR_STEP_DB for q, _ in sp], [v[1] for _, v in sp], "x", color=line.get_color(), ms=5)
    ax.set_xlabel("person's mean integrated SNR [dB]")
    ax.set_ylabel("detection probability per receiver")
    ax.set_title(f"through-wall: Swerling {swerling}, Pfa {pfa:.2g}; x parametric as simulated")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(args.out / "pd.png", dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    main()
