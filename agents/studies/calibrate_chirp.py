"""Calibrate the parametric chirp model on the chirp signal path (urban-intersection): writes report.md and figures.

Sections (each compares the signal path, ``ChirpSignalSensor``, with the parametric model, ``ParametricSensor``, of
the same scenario; the signal path is the reference):

A. beams: the fitted SNR of a strong echo over its direction of arrival vs the parametric SNR (the DFT beam gain);
B. Pd over SNR per waveform: controlled Swerling I echoes at random geometry (pair, direction in the field of view,
   range, range-rate away from the blind speeds), detected when a merged detection lies on the echo's path (within
   one resolution cell, ``delay_doppler.truth_origin``); the parametric Pd is its formula at the same mean SNR with
   the notch gain: the single-cell Swerling I test at 0 dB (the model without the detector's window), and the
   windowed model 1 - (1 - Pd_echo) (1 - Pfa)^n (``SensingConfig.noise_window_cells``, ``sensing.pd``) with the
   scenario's configured and the refitted detector gain (``SensingConfig.detection_gain_db``); binomial standard
   errors per point;
C. false peaks per pair and scan in clutter-only scans, by truth origin (noise, static clutter), against the
   parametric clutter's expected false alarms; the per-cell Pfa and the clutter density that would make them agree;
   the noise peaks per image cell and unit Pfa at the scenario's Pfa, which sets ``noise_window_cells`` (B);
D. multipath ghosts in whole episodes (round-robin, both receivers): rate per covered target, pair and scan and
   their offsets from the target; the parametric path's ghost detections under the scenario's configured ghost
   settings (``SensingConfig.ghost_rate``, offsets) on the same truths and plans, and the ghost_rate that matches;
E. range / range-rate spread of strong Swerling 0 echoes against the pulse-train CRLB (``ChirpWaveform.covariance``)
   and the reported R against the spread;
F. the clutter notch: Pd of echoes at the vehicles' positions with folded Doppler near zero (blind speeds), and the
   ``residue_fraction`` / ``doppler_spread_hz`` that make the parametric Pd match (maximum likelihood on a grid).

Run: python scripts/calibrate_chirp.py [--out results/calibration-urban] [--scale 1.0] [--seed 0] [--scenario NAME]
(``--scale`` multiplies every Monte Carlo count; ``--pd-scans`` sets section B's scans per point, 2000 by default, so
that its binomial standard error stays at or below 0.011; 1.0 takes ~10-15 minutes on one core.)
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from uwb_env import scenarios
from uwb_env.channel.doppler_notch import doppler_notch_gain, train_doppler_spread_hz
from uwb_env.config import ScenarioConfig
from uwb_env.rng import RngStreams
from uwb_env.scene.truth import sample_truth
from uwb_env.sensing import ScanPlan
from uwb_env.sensing.parametric import ParametricSensor
from uwb_env.sensing.pd import detection_probability, windowed_detection_probability
from uwb_env.sensing.signal.chirp_sensor import ChirpEpisode, ChirpSignalSensor

SCENARIO = "urban-intersection"


@dataclass
class Bench:
    """One scenario's signal sensor, its parametric model and a signal episode (background, thresholds)."""

    cfg: ScenarioConfig
    signal: ChirpSignalSensor
    param: ParametricSensor
    episode: ChirpEpisode


def bench(seed: int, **overrides: object) -> Bench:
    """Build the signal sensor (and its parametric model) of the scenario with ``overrides`` and one episode."""
    cfg = scenarios.get(SCENARIO, **{"sensing.fidelity": "signal", **overrides})
    sensor = ChirpSignalSensor(cfg)
    rngs = RngStreams.from_seed(seed)
    truth = sample_truth(cfg, rngs.truth, sensor.layout)
    return Bench(cfg, sensor, sensor.model, sensor.new_episode(truth, rngs))


def random_geometry(b: Bench, rng: np.random.Generator, n: int, w: int, blind: bool = False) -> dict:
    """``n`` random echoes: pair, direction in the field of view, bistatic range in the gate, range-rate.

    ``blind``: folded Doppler within +-8 Hz of zero (the notch); else at least 0.2 / T1 away from it.
    """
    s = b.signal
    q = rng.integers(0, s.pairs.shape[0], n)
    bore = np.array([s.elements[i][2] for i in q])
    fov = np.array([s.elements[i][3] for i in q])
    doa = bore + rng.uniform(-1.0, 1.0, n) * fov
    lo = s.gate[0][q] + 20.0
    length = rng.uniform(lo, s.gate[1] - 20.0)
    pri = s.library[w].config.pri_s
    lam = s.library[w].wavelength_m
    if blind:
        f = rng.uniform(-8.0, 8.0, n)
    else:
        f = rng.choice([-1.0, 1.0], n) * rng.uniform(0.2, 0.5, n) / pri
    nu = f + rng.integers(-2, 3, n) / pri
    return {"pair": q, "doa": doa, "length": length, "rdot": -lam * nu, "f": f}


def notch(b: Bench, w: int, q: np.ndarray, length: np.ndarray, rdot: np.ndarray, eta: float, spread: float):
    """Parametric SCNR / SNR at (pair, range, range-rate) with residue fraction ``eta`` and clutter spread [Hz].

    Includes the train's range-migration loss for detection (``ParametricSensor.detection_migration_gain``): the
    signal path's echoes walk.
    """
    p = b.param
    t, r = p.pairs[q, 0], p.pairs[q, 1]
    cnr = p.clutter_to_noise(w, t, r, length)
    wf = p.library[w]
    sigma = train_doppler_spread_hz(wf.config.n_pulses, wf.config.pri_s, spread)
    gain = doppler_notch_gain(cnr, rdot, wf.wavelength_m, wf.config.pri_s, sigma, eta)
    return gain * p.detection_migration_gain(w, rdot)


def _pair_index(p: ParametricSensor, tx: int, rx: int) -> int:
    return int(np.flatnonzero((p.pairs[:, 0] == tx) & (p.pairs[:, 1] == rx))[0])


def pd_model(b: Bench, snr: np.ndarray, gain_db: float, window: bool = True) -> np.ndarray:
    """The parametric Pd (Swerling I) at mean SNR ``snr`` x the detector gain, with the noise window when ``window``."""
    pfa = b.cfg.sensing.false_alarm_probability
    pd = detection_probability(np.asarray(snr) * 10.0 ** (gain_db / 10.0), pfa, 1)
    return windowed_detection_probability(pd, pfa, b.cfg.sensing.noise_window_cells) if window else pd


def detected(trace) -> bool:
    """The controlled echo (target 0) lies under a merged detection."""
    return bool((trace.detections.origin == 0).any())


# ---------------------------------------------------------------------------------------------------- sections
def section_beams(b: Bench, rng: np.random.Generator, n: int) -> dict:
    """A: fitted SNR / commanded SNR of 25 dB Swerling 0 echoes over the direction of arrival (both pairs)."""
    s = b.signal
    snr = 10.0**2.5
    rows = []
    for i in range(n):  # scans: calibration, not a hot path
        g = random_geometry(b, rng, 1, 0)
        q = int(g["pair"][0])
        tr = s.controlled_scan(b.episode, 0, q, g["length"], g["rdot"], g["doa"], [snr], rng=rng)
        hit = tr.detections.origin == 0
        off = float(np.angle(np.exp(1j * (g["doa"][0] - s.elements[q][2]))))
        if hit.any():
            rows.append((off, float(tr.detections.snr[hit].max()) / snr))
        del i
    a = np.array(rows)
    edges = np.radians(np.arange(-50, 51, 10))
    cells = []
    for lo, hi in itertools.pairwise(edges):  # angle bins: a handful
        sel = (a[:, 0] >= lo) & (a[:, 0] < hi)
        cells.append((math.degrees(lo), math.degrees(hi), int(sel.sum()), float(np.median(a[sel, 1]))))
    return {"bins": cells, "median_ratio": float(np.median(a[:, 1])), "n": len(rows)}


def section_pd(b: Bench, rng: np.random.Generator, n: int, snr_db: np.ndarray) -> dict:
    """B: Pd over mean SNR per waveform, signal vs parametric (Swerling I, away from the blind speeds)."""
    s, pfa = b.signal, b.cfg.sensing.false_alarm_probability
    out = {}
    for w in range(len(s.library)):  # the library: 6-8 waveforms
        sig, par, eff = [], [], []
        for x in snr_db:  # SNR grid: a dozen points
            g = random_geometry(b, rng, n, w)
            fade = rng.standard_exponential(n)
            mean = 10.0 ** (x / 10.0)
            hits = 0
            for i in range(n):  # scans: calibration
                q = int(g["pair"][i])
                tr = s.controlled_scan(
                    b.episode, w, q, g["length"][i : i + 1], g["rdot"][i : i + 1], g["doa"][i : i + 1],
                    [mean * fade[i]], rng=rng,
                )  # fmt: skip
                hits += detected(tr)
            gain = notch(b, w, g["pair"], g["length"], g["rdot"], *_notch_constants(b.cfg))
            par.append(float(np.mean(pd_model(b, mean * gain, 0.0, window=False))))
            eff.append(mean * gain)
            sig.append(hits / n)
        out[s.library[w].name] = {"snr_db": snr_db.tolist(), "signal": sig, "parametric": par, "n": n, "_eff": eff}
    # the detector gain (SensingConfig.detection_gain_db) that fits every waveform's curve with the noise window
    # (least squares, each point weighted by its binomial variance at the model)
    grid = np.arange(-1.0, 2.01, 0.05)
    sse = []
    for x in grid:  # gain grid
        total = 0.0
        for r in out.values():  # waveforms
            for a, e in zip(r["signal"], r["_eff"], strict=True):
                m = float(np.mean(pd_model(b, e, x)))
                total += (a - m) ** 2 / max(m * (1.0 - m), 1e-3)
        sse.append(total)
    best = float(grid[int(np.argmin(sse))])
    configured = b.cfg.sensing.detection_gain_db
    for r in out.values():  # waveforms
        eff = r.pop("_eff")
        r["parametric_configured"] = [float(np.mean(pd_model(b, e, configured))) for e in eff]
        r["parametric_fitted"] = [float(np.mean(pd_model(b, e, best))) for e in eff]
        r["se"] = [math.sqrt(max(a * (1.0 - a), 1e-12) / n) for a in r["signal"]]
    return {
        "curves": out,
        "detection_gain_db": best,
        "configured_gain_db": configured,
        "pfa": pfa,
        "noise_window_cells": b.cfg.sensing.noise_window_cells,
    }


def _notch_constants(cfg: ScenarioConfig) -> tuple[float, float]:
    cl = cfg.sensing.clutter
    return cl.residue_fraction, cl.doppler_spread_hz


def section_false_peaks(seed: int, rng: np.random.Generator, n: int, pfas: tuple[float, ...]) -> dict:
    """C: false peaks per pair and scan (clutter-only scans) by truth origin, per Pfa; parametric expectation.

    ``pfas`` gets the scenario's own Pfa added; ``scenario_index`` is its place in ``pfa``.
    """
    cfg = scenarios.get(SCENARIO)
    scenario_pfa = cfg.sensing.false_alarm_probability
    pfas = tuple(sorted({*pfas, scenario_pfa}))
    out = {"pfa": [], "noise": [], "static": [], "total": [], "cells": None}
    out["scenario_pfa"] = scenario_pfa
    out["scenario_index"] = pfas.index(scenario_pfa)
    out["density_per_m2"] = cfg.sensing.clutter.density_per_m2
    param_expected = None
    for pfa in pfas:  # a few per-cell Pfa values
        b = bench(seed, **{"sensing.false_alarm_probability": pfa})
        s = b.signal
        per = {"noise": 0, "static": 0, "other": 0}
        scans = 0
        by_w = {}
        for w in range(len(s.library)):  # the library
            n0, t0 = per["noise"], per["noise"] + per["static"] + per["other"]
            for q in range(s.pairs.shape[0]):  # formed pairs
                for _ in range(n):  # scans: calibration
                    tr = s.controlled_scan(b.episode, w, q, [], [], [], [], rng=rng)
                    o = tr.detections.origin
                    per["noise"] += int((o == -3).sum())
                    per["static"] += int((o == -1).sum())
                    per["other"] += int((o >= 0).sum() + (o == -2).sum())
                    scans += 1
            k = s.pairs.shape[0] * n
            cells_w = float(s.searched_cells[w].mean() * s.n_beams)
            by_w[s.library[w].name] = {
                "noise": (per["noise"] - n0) / k,
                "total": (per["noise"] + per["static"] + per["other"] - t0) / k,
                "cells": cells_w,
                "peak_cap": int(s.max_peaks[w]),
                "noise_per_cell_pfa": (per["noise"] - n0) / k / (pfa * cells_w),
                "parametric": float(b.param.expected_clutter[b.param.pair_mask].mean() * b.param.false_alarm_scale[w]),
            }
        if pfa == scenario_pfa:
            out["per_waveform"] = by_w
        out["pfa"].append(pfa)
        out["noise"].append(per["noise"] / scans)
        out["static"].append(per["static"] / scans)
        out["total"].append((per["noise"] + per["static"] + per["other"]) / scans)
        cells = s.searched_cells.mean() * s.n_beams
        out["cells"] = float(cells)
        if param_expected is None:  # every waveform's own density (ClutterConfig.reference_bandwidth_hz), averaged
            param_expected = float(np.mean([r["parametric"] for r in by_w.values()]))
    out["parametric_expected"] = param_expected
    out["peaks_per_cell_pfa"] = [t / (p * out["cells"]) for t, p in zip(out["total"], out["pfa"], strict=True)]
    # the noise peaks per image cell and unit Pfa at the scenario's Pfa: rho of the noise window (B)
    i0 = out["scenario_index"]
    out["noise_per_cell_pfa"] = out["noise"][i0] / (scenario_pfa * out["cells"])
    beams = cfg.receivers[0].array.n_elements
    out["noise_window_cells"] = scenarios.urban_intersection.noise_window_cells(
        cfg.sensing.signal.chirp, beams, out["noise_per_cell_pfa"]
    )
    out["configured_noise_window_cells"] = cfg.sensing.noise_window_cells
    lp, lt = np.log(out["pfa"]), np.log(out["total"])
    target = math.log(param_expected)
    if np.all(np.diff(lt) > 0) and lt[0] <= target <= lt[-1]:  # between two grid Pfa: interpolate, log-log
        match = float(np.exp(np.interp(target, lt, lp)))
        out["match_method"] = "log-log interpolation between the neighbouring Pfa values of the table"
    else:  # outside the grid (or not monotone): a straight line through all of them, log-log
        slope, icept = np.polyfit(lp, lt, 1)
        match = float(np.exp((target - icept) / slope))
        out["match_method"] = "log-log straight-line fit over the Pfa values of the table"
    out["pfa_matching_parametric"] = match
    # check: the signal path at that Pfa against the parametric expectation at that Pfa (unchanged: a density)
    b = bench(seed, **{"sensing.false_alarm_probability": match})
    s = b.signal
    total, scans = 0, 0
    for w in range(len(s.library)):  # the library
        for q in range(s.pairs.shape[0]):  # formed pairs
            for _ in range(n):  # scans: calibration
                total += len(s.controlled_scan(b.episode, w, q, [], [], [], [], rng=rng).detections)
                scans += 1
    out["total_at_match"] = total / scans
    return out


def section_ghosts(seed: int, n_episodes: int) -> dict:
    """D: multipath ghosts of whole round-robin episodes (signal), their offsets; the parametric model fitted."""
    b = bench(seed)
    s = b.signal
    plans = [ScanPlan.all_listening(w, s.n_tx, s.n_rx) for w in range(len(s.library))]
    ghosts, covered, pair_scans, target_dets = [], 0, 0, 0
    for e in range(n_episodes):  # episodes: calibration
        rngs = RngStreams.from_seed(seed + 1000 + e)
        truth = sample_truth(b.cfg, rngs.truth, s.layout)
        ep = s.new_episode(truth, rngs)
        geom = s.model.episode_geometry(truth)
        for k in range(1, b.cfg.n_scans + 1):  # scans
            s.sense(ep, k, plans[k % len(plans)])
            for tr in ep.last_trace:  # active pairs: 2
                t, r = s.pairs[tr.pair]
                pair_scans += 1
                covered += int(geom.covered[k, t, r].sum())
                d = tr.detections
                target_dets += int((d.origin >= 0).sum())
                period = s.model.range_rate_period[tr.waveform]
                for i in np.flatnonzero((d.origin == -2) & (tr.source >= 0)):  # ghosts: a few per episode
                    j = tr.source[i]
                    dv = d.range_rate_mps[i] - geom.range_rate[k, t, r, j]
                    dv = (dv + period / 2) % period - period / 2
                    ghosts.append((d.range_m[i] - geom.bistatic_range[k, t, r, j], dv, d.snr[i]))
    g = np.array(ghosts).reshape(-1, 3)
    rate = len(g) / max(covered, 1)
    positive = g[:, 0] > 0
    offset = float(g[positive, 0].mean()) if positive.any() else 20.0
    std = float(np.sqrt(np.mean(g[:, 1] ** 2))) if len(g) else 2.5
    par = parametric_ghosts(seed, n_episodes, plans)
    return {
        "episodes": n_episodes,
        "pair_scans": pair_scans,
        "covered_target_pair_scans": covered,
        "target_detections": target_dets,
        "ghosts": len(g),
        "rate_per_pair_scan": len(g) / max(pair_scans, 1),
        "rate_per_covered_target": rate,
        "range_offset_mean_m": offset,
        "range_offset_quantiles_m": np.quantile(g[:, 0], [0.1, 0.5, 0.9]).tolist() if len(g) else [],
        "negative_offsets": int((~positive).sum()),
        "range_rate_offset_mean_mps": float(g[:, 1].mean()) if len(g) else 0.0,
        "range_rate_offset_rms_mps": std,
        "snr_median": float(np.median(g[:, 2])) if len(g) else 0.0,
        "rate_per_target_detection": len(g) / max(target_dets, 1),
        **par,
    }


def parametric_ghosts(seed: int, n_episodes: int, plans: list[ScanPlan]) -> dict:
    """D: ghost detections of the parametric path under the scenario's configured ghost settings.

    ``ParametricSensor._draw_ghosts`` gives a ghost origin -1, like a false alarm, and draws it from the clutter
    stream after every other draw of the episode, so a copy of the scenario with ``ghost_rate`` 0 on the same seeds
    makes the same false alarms: a scan's ghost detections are the origin -1 detections that the copy lacks (checked
    row by row). Same truths, scans and round-robin plans as the signal path; per covered target, pair and scan.
    """
    cfg = scenarios.get(SCENARIO)
    sens = cfg.sensing
    with_ghosts = ParametricSensor(cfg)
    without = ParametricSensor(scenarios.get(SCENARIO, **{"sensing.ghost_rate": 0.0}))
    n_ghosts, covered, pair_scans, drawn = 0, 0, 0, 0
    for e in range(n_episodes):  # episodes: calibration
        eps = []
        for param in (with_ghosts, without):
            rngs = RngStreams.from_seed(seed + 1000 + e)
            eps.append(param.new_episode(sample_truth(cfg, rngs.truth, param.layout), rngs))
        geom = eps[0].geometry
        drawn += int(eps[0].clutter_start[-1] - eps[0].clutter_start[1]) - int(
            eps[1].clutter_start[-1] - eps[1].clutter_start[1]
        )
        for k in range(1, cfg.n_scans + 1):  # scans
            plan = plans[k % len(plans)]
            for dg, d0 in zip(with_ghosts.sense(eps[0], k, plan), without.sense(eps[1], k, plan), strict=True):
                z_g, z_0 = dg.z[dg.origin == -1], d0.z[d0.origin == -1]
                kept = (z_g[:, None, :] == z_0[None, :, :]).all(axis=2).any(axis=0)
                if not kept.all():
                    raise RuntimeError("ghost_rate 0 copy does not reproduce the false alarms: cannot count ghosts")
                n_ghosts += len(z_g) - len(z_0)
                pair_scans += 1
                covered += int(geom.covered[k, dg.tx, dg.rx].sum())
    return {
        "parametric_ghost_rate": sens.ghost_rate,
        "parametric_ghost_range_offset_m": sens.ghost_range_offset_m,
        "parametric_ghost_range_rate_std_mps": sens.ghost_range_rate_std_mps,
        "parametric_ghosts": n_ghosts,
        "parametric_ghosts_drawn": drawn,
        "parametric_covered_target_pair_scans": covered,
        "parametric_pair_scans": pair_scans,
        "parametric_rate_per_covered_target": n_ghosts / max(covered, 1),
        "parametric_rate_per_pair_scan": n_ghosts / max(pair_scans, 1),
    }


def section_spread(b: Bench, rng: np.random.Generator, n: int, snr_db: tuple[float, ...]) -> dict:
    """E: spread of range and range-rate of strong Swerling 0 echoes vs the CRLB; reported R vs the spread."""
    s = b.signal
    out = {}
    for w in range(len(s.library)):  # the library
        wf = s.library[w]
        rows = []
        for x in snr_db:  # a few SNRs
            snr = 10.0 ** (x / 10.0)
            g = random_geometry(b, rng, n, w)
            err, rep, model = [], [], []
            for i in range(n):  # scans: calibration
                q = int(g["pair"][i])
                tr = s.controlled_scan(
                    b.episode, w, q, g["length"][i : i + 1], g["rdot"][i : i + 1], g["doa"][i : i + 1], [snr],
                    rng=rng,
                )  # fmt: skip
                hit = np.flatnonzero(tr.detections.origin == 0)
                if hit.size:  # the echo's own peak: the strongest matched one (a noise peak in the window is not it)
                    d = tr.detections
                    j = hit[np.argmax(d.snr[hit])]
                    period = wf.range_rate_ambiguity_mps
                    dv = (d.range_rate_mps[j] - g["rdot"][i] + period / 2) % period - period / 2
                    err.append((d.range_m[j] - g["length"][i], dv))
                    rep.append(s.covariance(d.R[j : j + 1], w)[0])
                    model.append(g["rdot"][i])
            e = np.array(err)
            crlb = wf.covariance(np.array([snr]))[0]
            Rm = np.mean(rep, axis=0)
            # the parametric model's variances of these echoes: the bound at the walked SNR times the walk's factors
            rdot = np.asarray(model)
            gain = b.param.migration_gain(np.full(rdot.size, w), rdot)
            var0 = np.stack([crlb[0, 0] / gain, crlb[1, 1] / gain], axis=-1)
            par = var0 * b.param.walk_factors(np.full(rdot.size, w), rdot, var0)
            rows.append(
                {
                    "snr_db": x,
                    "n": len(e),
                    "range_std_over_bound": float(e[:, 0].std() / math.sqrt(crlb[0, 0])),
                    "rate_std_over_bound": float(e[:, 1].std() / math.sqrt(crlb[1, 1])),
                    "range_std_over_parametric": float(e[:, 0].std() / math.sqrt(par[:, 0].mean())),
                    "rate_std_over_parametric": float(e[:, 1].std() / math.sqrt(par[:, 1].mean())),
                    "range_bias_m": float(e[:, 0].mean()),
                    "reported_range_std_over_spread": float(math.sqrt(Rm[0, 0]) / e[:, 0].std()),
                    "reported_rate_std_over_spread": float(math.sqrt(Rm[1, 1]) / e[:, 1].std()),
                }
            )
        out[wf.name] = rows
    return out


def section_notch(
    b: Bench, rng: np.random.Generator, n: int, snr_db: float, waveforms: tuple[int, ...], gain_db: float
) -> dict:
    """F: Pd at the vehicles' positions with folded Doppler near zero; fit eta and the Doppler spread.

    The parametric Pd includes the detector gain ``gain_db`` fitted in section B and the noise window.
    """
    s, p = b.signal, b.param
    geom = p.episode_geometry(b.episode.truth)
    k_i, t_i, r_i, j_i = np.nonzero(geom.covered)
    samples = {}
    for w in waveforms:  # two PRIs
        pick = rng.integers(0, k_i.size, n)
        k, t, r, j = k_i[pick], t_i[pick], r_i[pick], j_i[pick]
        q = np.array([_pair_index(p, a, c) for a, c in zip(t.tolist(), r.tolist(), strict=True)])
        length = geom.bistatic_range[k, t, r, j]
        doa = geom.azimuth[k, r, j]
        wf = s.library[w]
        f = rng.uniform(-8.0, 8.0, n)
        rdot = -wf.wavelength_m * (f + np.rint(-geom.range_rate[k, t, r, j] / wf.wavelength_m * wf.config.pri_s)
                                   / wf.config.pri_s)  # fmt: skip
        mean = 10.0 ** (snr_db / 10.0)
        fade = rng.standard_exponential(n)
        hit = np.zeros(n, bool)
        for i in range(n):  # scans: calibration
            tr = s.controlled_scan(
                b.episode, w, int(q[i]), length[i : i + 1], rdot[i : i + 1], doa[i : i + 1], [mean * fade[i]],
                rng=rng,
            )  # fmt: skip
            hit[i] = detected(tr)
        samples[w] = (q, length, rdot, f, hit)
    etas = np.geomspace(0.005, 1.0, 31)
    spreads = np.arange(0.0, 12.01, 0.5)
    ll = np.zeros((etas.size, spreads.size))
    mean = 10.0 ** (snr_db / 10.0)
    for a, eta in enumerate(etas):  # grid: 25 x 25
        for c, spread in enumerate(spreads):
            for w, (q, length, rdot, _, hit) in samples.items():  # two PRIs
                pd = np.clip(pd_model(b, mean * notch(b, w, q, length, rdot, eta, spread), gain_db), 1e-6, 1 - 1e-6)
                ll[a, c] += float(np.sum(np.where(hit, np.log(pd), np.log1p(-pd))))
    a, c = np.unravel_index(np.argmax(ll), ll.shape)
    eta_fit, spread_fit = float(etas[a]), float(spreads[c])
    inside = ll >= ll[a, c] - 1.92  # profile-likelihood 95 % region (chi-square, 1 dof per parameter)
    eta_ci = (float(etas[inside.any(axis=1)].min()), float(etas[inside.any(axis=1)].max()))
    spread_ci = (float(spreads[inside.any(axis=0)].min()), float(spreads[inside.any(axis=0)].max()))
    eta0, spread0 = _notch_constants(b.cfg)
    table = {}
    edges = np.array([0.0, 1.0, 2.0, 3.0, 4.0, 6.0, 8.0])
    for w, (q, length, rdot, f, hit) in samples.items():  # two PRIs
        rows = []
        pd_fit = pd_model(b, mean * notch(b, w, q, length, rdot, eta_fit, spread_fit), gain_db)
        pd_now = pd_model(b, mean * notch(b, w, q, length, rdot, eta0, spread0), gain_db)
        cnr = p.clutter_to_noise(w, p.pairs[q, 0], p.pairs[q, 1], length)
        for lo, hi in itertools.pairwise(edges):  # Doppler bins
            sel = (np.abs(f) >= lo) & (np.abs(f) < hi)
            rows.append(
                (lo, hi, int(sel.sum()), float(hit[sel].mean()), float(pd_now[sel].mean()), float(pd_fit[sel].mean()))
            )
        table[s.library[w].name] = {
            "bins": rows,
            "cnr_db_quantiles": (10 * np.log10(np.quantile(cnr, [0.1, 0.5, 0.9]) + 1e-12)).tolist(),
            "f": f.tolist(),
            "hit": hit.astype(int).tolist(),
            "pd_fit": pd_fit.tolist(),
            "pd_now": pd_now.tolist(),
        }
    return {
        "snr_db": snr_db,
        "n_per_waveform": n,
        "residue_fraction": eta_fit,
        "doppler_spread_hz": spread_fit,
        "scenario_residue_fraction": eta0,
        "scenario_doppler_spread_hz": spread0,
        "log_likelihood_fit": float(ll[a, c]),
        "residue_fraction_95": eta_ci,
        "doppler_spread_hz_95": spread_ci,
        "detection_gain_db": gain_db,
        "table": table,
    }


# ---------------------------------------------------------------------------------------------------- report
def scenario_settings(b: Bench) -> dict:
    """The scenario's configured values the report compares with (read from its config, never typed in)."""
    sens, cl = b.cfg.sensing, b.cfg.sensing.clutter
    trains = sorted({(wf.config.n_pulses, wf.config.pri_s) for wf in b.signal.library})
    return {
        "false_alarm_probability": sens.false_alarm_probability,
        "density_per_m2": cl.density_per_m2,
        "detection_gain_db": sens.detection_gain_db,
        "ghost_rate": sens.ghost_rate,
        "ghost_range_offset_m": sens.ghost_range_offset_m,
        "ghost_range_rate_std_mps": sens.ghost_range_rate_std_mps,
        "residue_fraction": cl.residue_fraction,
        "doppler_spread_hz": cl.doppler_spread_hz,
        "reference_bandwidth_hz": cl.reference_bandwidth_hz,
        "scatterer_rcs_m2": cl.scatterer_rcs_m2,
        "array_beams": sens.array_beams,
        "n_elements": "/".join(sorted({str(r.array.n_elements) for r in b.cfg.receivers if r.array is not None})),
        "band_energy": float(b.signal.grids[0].band_energy),
        "train_doppler_std_hz": [(pri, float(train_doppler_spread_hz(n, pri, 0.0))) for n, pri in trains],
    }


def figures(out: Path, pd: dict, notch_res: dict) -> list[str]:
    """Pd over SNR (both paths) per waveform; Pd over folded Doppler near the blind speeds."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = []
    fig, axes = plt.subplots(2, 3, figsize=(12, 7), sharex=True, sharey=True)
    for ax, (name, r) in zip(axes.ravel(), pd.items(), strict=False):
        x = np.array(r["snr_db"])
        sig = np.array(r["signal"])
        err = np.sqrt(sig * (1 - sig) / r["n"])
        ax.errorbar(x, sig, yerr=2 * err, fmt="o", ms=3, label="signal path (2 sigma)")
        ax.plot(x, r["parametric"], "-", label="parametric (single cell, 0 dB)")
        ax.plot(x, r["parametric_configured"], ":", label="parametric (noise window, configured gain)")
        ax.plot(x, r["parametric_fitted"], "--", label="parametric (noise window, fitted gain)")
        ax.set_title(name)
        ax.grid(alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel("mean SNR [dB] (beam gain included)")
    for ax in axes[:, 0]:
        ax.set_ylabel("Pd")
    axes[0, 0].legend(loc="lower right", fontsize=8)
    fig.suptitle("urban-intersection: Pd over SNR, Swerling I, away from the blind speeds")
    fig.tight_layout()
    fig.savefig(out / "pd_vs_snr.png", dpi=110)
    plt.close(fig)
    names.append("pd_vs_snr.png")
    fig, axes = plt.subplots(1, len(notch_res["table"]), figsize=(11, 4), sharey=True)
    for ax, (name, r) in zip(np.atleast_1d(axes), notch_res["table"].items(), strict=True):
        b = np.array(r["bins"])
        mid = 0.5 * (b[:, 0] + b[:, 1])
        ax.plot(mid, b[:, 3], "o-", label="signal path")
        ax.plot(mid, b[:, 4], "s--", label="parametric, scenario constants")
        ax.plot(mid, b[:, 5], "^-", label="parametric, fitted")
        ax.set_xlabel("|folded Doppler| [Hz]")
        ax.set_title(name)
        ax.grid(alpha=0.3)
    np.atleast_1d(axes)[0].set_ylabel("Pd")
    np.atleast_1d(axes)[0].legend(fontsize=8)
    fig.suptitle(f"clutter notch at the vehicles' positions, mean SNR {notch_res['snr_db']:.0f} dB")
    fig.tight_layout()
    fig.savefig(out / "notch.png", dpi=110)
    plt.close(fig)
    names.append("notch.png")
    return names


def inside(value: float, bounds: tuple[float, float] | list[float]) -> str:
    """'inside' or 'outside' of a closed range (report text)."""
    return "inside" if bounds[0] <= value <= bounds[1] else "outside"


def report(out: Path, res: dict, command: str, elapsed: float) -> None:
    """report.md: every number of the sections, with the command that reproduces it."""
    L = [f"# Chirp calibration: parametric path vs signal path ({SCENARIO})", ""]
    L += [f"Reproduce: `{command}` ({elapsed / 60:.1f} min on this machine).", ""]
    L += ["Signal path: `uwb_env.sensing.signal.chirp_sensor.ChirpSignalSensor`; parametric: `ParametricSensor` of "
          "the same scenario. Numbers are Monte Carlo estimates; binomial standard errors are given where they "
          "matter.", ""]  # fmt: skip
    fp, g, nt, pdr, sc = res["false_peaks"], res["ghosts"], res["notch"], res["pd"], res["scenario"]
    pfa_now = sc["false_alarm_probability"]
    i_now = fp["scenario_index"]
    tot = fp["total"][i_now]
    density_match = sc["density_per_m2"] * tot / fp["parametric_expected"]
    lobes = ", ".join(f"{sig:.1f} Hz std at {pri * 1e3:g} ms" for pri, sig in sc["train_doppler_std_hz"])
    L += ["## Summary: values for the scenario (`uwb_env/scenarios/urban_intersection.py`)", ""]
    L += [f"Every fit below is made at the scenario's configured per-cell Pfa, {pfa_now:g} (sections A, B, D, E and "
          f"F run the scenario as configured; section C scans a few Pfa values, the scenario's among them). \"now\" "
          "is the scenario's configured value.", ""]  # fmt: skip
    L += ["| setting | now | calibrated | from |", "|---|---|---|---|"]
    L += [f"| `sensing.clutter.residue_fraction` | {sc['residue_fraction']:g} | {nt['residue_fraction']:.3g} "
          f"(95 %: {nt['residue_fraction_95'][0]:.3g}-{nt['residue_fraction_95'][1]:.3g}) | F |",
          f"| `sensing.clutter.doppler_spread_hz` | {sc['doppler_spread_hz']:g} | {nt['doppler_spread_hz']:.3g} "
          f"(95 %: {nt['doppler_spread_hz_95'][0]:.3g}-{nt['doppler_spread_hz_95'][1]:.3g}) | F |",
          f"| `sensing.detection_gain_db` | {sc['detection_gain_db']:+.2f} | {pdr['detection_gain_db']:+.2f} | B |",
          f"| `sensing.noise_window_cells` (n) | {fp['configured_noise_window_cells']:.1f} | "
          f"{fp['noise_window_cells']:.1f} | C |",
          f"| `sensing.ghost_rate` | {sc['ghost_rate']:g} | {g['rate_per_covered_target']:.4f} | D |",
          f"| `sensing.ghost_range_offset_m` | {sc['ghost_range_offset_m']:g} | {g['range_offset_mean_m']:.1f} | D |",
          f"| `sensing.ghost_range_rate_std_mps` | {sc['ghost_range_rate_std_mps']:g} | "
          f"{g['range_rate_offset_rms_mps']:.2f} | D |",
          f"| false alarms: `sensing.false_alarm_probability` (keeps the density "
          f"{sc['density_per_m2']:g} / m^2) | {pfa_now:g} | {fp['pfa_matching_parametric']:.1e} | C |",
          f"| or `sensing.clutter.density_per_m2` (keeps Pfa {pfa_now:g}) | {sc['density_per_m2']:g} | "
          f"{density_match:.1e} | C |",
          "", f"After a change of Pfa, run the script again (the detector gain and the false peaks per cell depend "
          f"weakly on it). A doppler_spread_hz of 0 means the notch is as wide as the train's own Doppler main lobe "
          f"({lobes}).", ""]  # fmt: skip
    b = res["beams"]
    L += [f"## A. Receive beams ({sc['array_beams'].upper()}, {sc['n_elements']} elements)", ""]
    L += [f"Fitted SNR / parametric SNR of 25 dB Swerling 0 echoes: median {b['median_ratio']:.3f} over {b['n']} "
          "echoes (1 = the parametric beam gain max_m |AF_m|^2 / L^2 is what the beams deliver; the band-limited "
          f"pulse keeps eta = {sc['band_energy']:.3f} of its energy).", ""]  # fmt: skip
    L += ["| off boresight [deg] | echoes | median fitted / parametric SNR |", "|---|---|---|"]
    L += [f"| {lo:.0f} .. {hi:.0f} | {n} | {r:.3f} |" for lo, hi, n, r in b["bins"]]
    gdb, gcf = pdr["detection_gain_db"], pdr["configured_gain_db"]
    L += ["", "## B. Pd over SNR (Swerling I, away from blind speeds)", ""]
    nw = pdr["noise_window_cells"]
    pn = 1.0 - (1.0 - pdr["pfa"]) ** nw
    L += [f"At the scenario's Pfa {pdr['pfa']:g}. The signal detector counts the echo as detected when a merged peak "
          "lies within one resolution cell of it (delay and Doppler) in any of its beams, so a noise peak there "
          "counts too. The parametric model: P = 1 - (1 - Pd_echo(G SNR)) (1 - Pfa)^n, Pd_echo the Swerling I test, "
          f"n = `sensing.noise_window_cells` = {nw:.1f} (derived in `urban_intersection.noise_window_cells`: "
          "the window's 2 x 2 resolution cells x 4 x 4 image cells x the beams x the chain's noise peaks per cell "
          f"and unit Pfa of section C), so P -> 1 - (1 - Pfa)^n = {pn:.4f} as SNR -> 0, and one detector gain G "
          f"(`sensing.detection_gain_db`: the strongest of the neighbouring cells and of two straddling beams) "
          f"as configured ({gcf:+.2f} dB) and refitted here, **{gdb:+.2f} dB** (weighted least squares over every "
          "waveform and SNR). For reference, the single-cell Swerling I test at 0 dB (no window, no gain). "
          "SE: the largest binomial standard error of the signal Pd over the SNR points.", ""]  # fmt: skip
    L += ["| waveform | max abs(dPd), single cell 0 dB | at SNR [dB] | "
          f"max abs(dPd), as configured ({gcf:+.2f} dB) | at SNR [dB] | mean dPd, as configured | "
          f"max abs(dPd), refitted ({gdb:+.2f} dB) | mean dPd, refitted | largest SE | "
          "max abs(dPd) / SE (refitted) | scans per point |",
          "|---|---|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for name, r in pdr["curves"].items():
        d = np.array(r["signal"]) - np.array(r["parametric"])
        c = np.array(r["signal"]) - np.array(r["parametric_configured"])
        f = np.array(r["signal"]) - np.array(r["parametric_fitted"])
        se = np.array(r["se"])
        i, j = int(np.argmax(np.abs(d))), int(np.argmax(np.abs(c)))
        L.append(f"| {name} | {abs(d[i]):.3f} | {r['snr_db'][i]:.0f} | {abs(c[j]):.3f} | {r['snr_db'][j]:.0f} | "
                 f"{c.mean():+.3f} | {np.abs(f).max():.3f} | {f.mean():+.3f} | {se.max():.3f} | "
                 f"{np.max(np.abs(f) / se):.1f} | {r['n']} |")  # fmt: skip
    L += [
        "",
        f"Per SNR (signal / single cell 0 dB / windowed as configured {gcf:+.2f} dB / windowed refitted "
        f"{gdb:+.2f} dB):",
        "",
    ]
    first = next(iter(pdr["curves"].values()))
    L += ["| waveform | " + " | ".join(f"{x:.0f} dB" for x in first["snr_db"]) + " |",
          "|---|" + "---|" * len(first["snr_db"])]  # fmt: skip
    for name, r in pdr["curves"].items():
        L.append(f"| {name} | " + " | ".join(f"{a:.2f}/{p:.2f}/{c:.2f}/{q:.2f}" for a, p, c, q in zip(
            r["signal"], r["parametric"], r["parametric_configured"], r["parametric_fitted"], strict=True))
            + " |")  # fmt: skip
    L += ["", "## C. False peaks per pair and scan (clutter-only scans)", ""]
    L += [
        "| per-cell Pfa | noise peaks | static-clutter peaks | total | peaks / (Pfa x cells) |",
        "|---|---|---|---|---|",
    ]
    for i, pfa in enumerate(fp["pfa"]):
        L.append(f"| {pfa:g} | {fp['noise'][i]:.2f} | {fp['static'][i]:.2f} | {fp['total'][i]:.2f} | "
                 f"{fp['peaks_per_cell_pfa'][i]:.3f} |")  # fmt: skip
    L += ["", f"Searched cells per pair (gate x Doppler x beams), mean over the library: {fp['cells']:.0f}. Parametric "
          f"expected false alarms per pair and scan (density {fp['density_per_m2']:g} / m^2 over the gate, x each "
          f"waveform's B_w / `clutter.reference_bandwidth_hz` = {sc['reference_bandwidth_hz']:g} Hz where set), mean "
          f"over the library: {fp['parametric_expected']:.2f}. The table pools every waveform of the library.",
          ""]  # fmt: skip
    pw = fp.get("per_waveform", {})
    if pw:
        L += [f"Per waveform at the scenario's Pfa {fp['scenario_pfa']:g} (the chain's peak cap per beam image, "
              "`ChirpSignalConfig.scale_max_peaks`):", "",
              "| waveform | peak cap | searched cells (x beams) | noise peaks | total | noise peaks / (Pfa x cells) | "
              "parametric expected | signal / parametric |", "|---|---|---|---|---|---|---|---|"]  # fmt: skip
        for name, r in pw.items():
            ratio = r["total"] / r["parametric"]
            L.append(f"| {name} | {r['peak_cap']} | {r['cells']:.0f} | {r['noise']:.2f} | {r['total']:.2f} | "
                     f"{r['noise_per_cell_pfa']:.4f} | {r['parametric']:.2f} | {ratio:.2f} |")  # fmt: skip
        L.append("")
    L += [
        f"Noise peaks per image cell and unit Pfa at the scenario's Pfa: **{fp['noise_per_cell_pfa']:.4f}** "
        f"(rho of the noise window, section B): n = 3 beams x 8 x 8 image cells x rho = "
        f"{fp['noise_window_cells']:.1f} (configured {fp['configured_noise_window_cells']:.1f}).",
        "",
    ]
    L += [f"At the scenario's Pfa {fp['scenario_pfa']:g} the signal path makes {tot:.2f} false peaks per pair and "
          f"scan, {tot / fp['parametric_expected']:.2f} x the parametric expectation. They agree (a) at a per-cell "
          f"Pfa of {fp['pfa_matching_parametric']:.2e} ({fp['match_method']}) or (b) with "
          f"`clutter.density_per_m2` = {density_match:.2e} at Pfa {fp['scenario_pfa']:g}. Check of (a): at Pfa "
          f"{fp['pfa_matching_parametric']:.2e} the signal path makes {fp['total_at_match']:.2f} false peaks per pair "
          f"and scan ({fp['total_at_match'] / fp['parametric_expected']:.2f} x the parametric "
          f"{fp['parametric_expected']:.2f}).", ""]  # fmt: skip
    L += ["## D. Multipath ghosts (round-robin episodes, both receivers)", ""]
    L += [f"{g['episodes']} episodes, {g['pair_scans']} pair-scans, {g['covered_target_pair_scans']} covered "
          f"target-pair-scans, {g['target_detections']} target detections, {g['ghosts']} ghost detections: "
          f"{g['rate_per_pair_scan']:.4f} per pair-scan, {g['rate_per_covered_target']:.4f} per covered target, pair "
          "and scan.", ""]  # fmt: skip
    L += [f"Offsets from the ghost's target: range {np.round(g['range_offset_quantiles_m'], 1).tolist()} m "
          "(10/50/90 %), mean of the "
          f"positive ones {g['range_offset_mean_m']:.1f} m ({g['negative_offsets']} negative: ghosts on a path "
          f"within one cell of a shorter one); range-rate mean {g['range_rate_offset_mean_mps']:+.2f} m/s, rms "
          f"{g['range_rate_offset_rms_mps']:.2f} m/s (folded); median SNR {g['snr_median']:.1f}.", ""]  # fmt: skip
    pr, sr = g["parametric_rate_per_covered_target"], g["rate_per_covered_target"]
    ratio = pr / max(sr, 1e-12)
    # Poisson standard errors of both counts, propagated to the ratio
    ratio_se = ratio * math.sqrt(1.0 / max(g["parametric_ghosts"], 1) + 1.0 / max(g["ghosts"], 1))
    within = abs(ratio - 1.0) <= 0.2
    L += [f"Signal-path ghosts per detected target (pair and scan): {g['rate_per_target_detection']:.4f}.", ""]
    L += [f"Parametric ghosts as configured (`sensing.ghost_rate` = {g['parametric_ghost_rate']:g}, "
          f"`ghost_range_offset_m` = {g['parametric_ghost_range_offset_m']:g}, `ghost_range_rate_std_mps` = "
          f"{g['parametric_ghost_range_rate_std_mps']:g}; Pfa {sc['false_alarm_probability']:g}), on the same truths, "
          f"scans and round-robin plans: {g['parametric_ghosts']} ghost detections over "
          f"{g['parametric_covered_target_pair_scans']} covered target-pair-scans and {g['parametric_pair_scans']} "
          f"pair-scans. A parametric ghost has origin -1 like a false alarm and is drawn from the clutter stream after "
          "every other draw, so it is counted as an origin -1 detection that a copy of the scenario with ghost_rate 0 "
          "on the same seeds does not make (the copy's false alarms checked row by row).", ""]  # fmt: skip
    L += ["| ghosts per | signal path | parametric (configured) | parametric / signal |", "|---|---|---|---|",
          f"| covered target, pair and scan | {sr:.4f} | {pr:.4f} | {ratio:.2f} +- {ratio_se:.2f} |",
          f"| pair-scan | {g['rate_per_pair_scan']:.4f} | {g['parametric_rate_per_pair_scan']:.4f} | "
          f"{g['parametric_rate_per_pair_scan'] / max(g['rate_per_pair_scan'], 1e-12):.2f} |", ""]  # fmt: skip
    L += [f"Goal (parametric within 20 % of the signal path): **{'met' if within else 'not met'}** "
          f"({(ratio - 1.0) * 100:+.0f} %, +- {ratio_se * 100:.0f} % one standard error).", ""]  # fmt: skip
    per_rate = pr / max(g["parametric_ghost_rate"], 1e-12)
    per_rate_se = per_rate / math.sqrt(max(g["parametric_ghosts"], 1))
    L += [f"Why the parametric rate per covered target is {per_rate:.2f} x ghost_rate (+- {per_rate_se:.2f}): "
          "`ParametricSensor._draw_ghosts` draws a Poisson(ghost_rate) number of ghosts for every covered (scan, "
          "formed pair, target) -- the covered cells counted here -- and `sense` passes all of them to every "
          "listening receiver, so no covered target is left without its draw and the expected parametric rate per "
          "covered target, pair and scan is ghost_rate itself.", ""]  # fmt: skip
    L += [f"The ghost_rate that makes the two equal: **{sr:.4f}**, the signal path's rate per covered target (the "
          f"parametric expectation is ghost_rate); scaling the configured {g['parametric_ghost_rate']:g} by the "
          f"measured 1 / ratio gives {g['parametric_ghost_rate'] / max(ratio, 1e-12):.4f}"
          + (", the same within two standard errors of the Monte Carlo." if abs(per_rate - 1.0) <= 2.0 * per_rate_se
             else ", further from it than two standard errors of the Monte Carlo allow."),
          ""]  # fmt: skip
    L += ["## E. Spread at high SNR vs the pulse-train CRLB (Swerling 0)", ""]
    L += [
        "Echoes at random range-rates (up to 2.5 range-rate periods), each measured by its strongest matched peak "
        "(a noise peak within the matching window is not the echo's estimate). \"bound\": the train's CRLB at the "
        'commanded SNR, which ignores the range walk; "parametric": the parametric model\'s variance of the same '
        "echoes (the bound at the walked SNR times `ParametricSensor.walk_factors`), RMS over the echoes.",
        "",
    ]
    L += [
        "| waveform | SNR [dB] | detections | range std / bound | range-rate std / bound | range std / parametric | "
        "range-rate std / parametric | range bias [m] | reported sqrt(R_rr) / range std | "
        "reported sqrt(R_dd) / range-rate std |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, rows in res["spread"].items():
        for r in rows:
            L.append(f"| {name} | {r['snr_db']:.0f} | {r['n']} | {r['range_std_over_bound']:.2f} | "
                     f"{r['rate_std_over_bound']:.2f} | {r['range_std_over_parametric']:.2f} | "
                     f"{r['rate_std_over_parametric']:.2f} | {r['range_bias_m']:+.3f} | "
                     f"{r['reported_range_std_over_spread']:.2f} | "
                     f"{r['reported_rate_std_over_spread']:.2f} |")  # fmt: skip
    L += ["", "## F. Clutter notch at the blind speeds", ""]
    L += [f"Echoes at the vehicles' positions on the path (covered scans of one episode, both receivers), folded "
          f"Doppler uniform in +-8 Hz, mean SNR {nt['snr_db']:.0f} dB Swerling I, {nt['n_per_waveform']} per waveform. "
          f"Maximum-likelihood fit of the parametric notch on a grid: **residue_fraction = "
          f"{nt['residue_fraction']:.3g}, doppler_spread_hz = {nt['doppler_spread_hz']:.3g}** (profile-likelihood "
          f"95 % ranges {nt['residue_fraction_95'][0]:.3g}-{nt['residue_fraction_95'][1]:.3g} and "
          f"{nt['doppler_spread_hz_95'][0]:.3g}-{nt['doppler_spread_hz_95'][1]:.3g} Hz; scenario now: "
          f"{nt['scenario_residue_fraction']:g}, {nt['scenario_doppler_spread_hz']:g}; scatterer_rcs_m2 stays "
          f"{sc['scatterer_rcs_m2']:g}; Pfa {sc['false_alarm_probability']:g}). The "
          f"parametric Pd here includes the detector gain refitted in section B ({nt['detection_gain_db']:+.2f} dB). "
          f"The scenario's residue_fraction lies {inside(nt['scenario_residue_fraction'], nt['residue_fraction_95'])} "
          f"the 95 % range, its doppler_spread_hz "
          f"{inside(nt['scenario_doppler_spread_hz'], nt['doppler_spread_hz_95'])} it.", ""]  # fmt: skip
    L += ["| waveform | abs(folded Doppler) [Hz] | echoes | Pd signal | Pd parametric (scenario notch) | "
          "Pd parametric (fitted) |", "|---|---|---|---|---|---|"]  # fmt: skip
    for name, r in nt["table"].items():
        for lo, hi, n, s_, p0, p1 in r["bins"]:
            L.append(f"| {name} | {lo:.0f} .. {hi:.0f} | {n} | {s_:.2f} | {p0:.2f} | {p1:.2f} |")
        L.append(f"| {name} | CNR at the echoes (10/50/90 %) [dB] | {np.round(r['cnr_db_quantiles'], 1).tolist()} | "
                 "| | |")  # fmt: skip
    L += ["", "Figures: `pd_vs_snr.png`, `notch.png`.", ""]
    (out / "report.md").write_text("\n".join(L))


def main() -> None:
    """The command line (the module docstring)."""
    global SCENARIO  # the sections read the calibrated scenario from here
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="results/calibration-urban")
    ap.add_argument("--scale", type=float, default=1.0, help="multiplies every Monte Carlo count")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--pd-scans", type=int, default=2000, help="section B's scans per waveform and SNR (x --scale)")
    ap.add_argument("--scenario", default=SCENARIO, choices=("urban-intersection", "urban-intersection-wideband"))
    args = ap.parse_args()
    SCENARIO = args.scenario
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    n = lambda x: max(2, round(x * args.scale))  # noqa: E731
    rng = np.random.default_rng(args.seed)
    t0 = time.perf_counter()
    b = bench(args.seed)
    res = {"scenario": scenario_settings(b)}
    res["beams"] = section_beams(b, rng, n(400))
    print(f"A beams done {time.perf_counter() - t0:.0f} s", flush=True)
    res["pd"] = section_pd(b, rng, n(args.pd_scans), np.arange(-3.0, 25.0, 3.0))
    print(f"B Pd done {time.perf_counter() - t0:.0f} s", flush=True)
    res["false_peaks"] = section_false_peaks(args.seed, rng, n(60), (1e-4, 3e-4, 1e-3))
    print(f"C false peaks done {time.perf_counter() - t0:.0f} s", flush=True)
    res["ghosts"] = section_ghosts(args.seed, n(12))
    print(f"D ghosts done {time.perf_counter() - t0:.0f} s", flush=True)
    res["spread"] = section_spread(b, rng, n(200), (20.0, 25.0, 30.0))
    print(f"E spread done {time.perf_counter() - t0:.0f} s", flush=True)
    res["notch"] = section_notch(b, rng, n(2500), 15.0, (0, 4), res["pd"]["detection_gain_db"])
    print(f"F notch done {time.perf_counter() - t0:.0f} s", flush=True)
    elapsed = time.perf_counter() - t0
    figures(out, res["pd"]["curves"], res["notch"])
    cmd = "python scripts/calibrate_chirp.py" + ("" if args.scale == 1.0 else f" --scale {args.scale}")
    cmd += "" if args.pd_scans == 2000 else f" --pd-scans {args.pd_scans}"
    cmd += "" if args.seed == 0 else f" --seed {args.seed}"
    cmd += "" if args.scenario == "urban-intersection" else f" --scenario {args.scenario} --out {args.out}"
    report(out, res, cmd, elapsed)
    slim = {k: v for k, v in res.items() if k != "notch"}
    slim["notch"] = {k: v for k, v in res["notch"].items() if k != "table"}
    slim["notch"]["bins"] = {name: r["bins"] for name, r in res["notch"]["table"].items()}
    (out / "results.json").write_text(json.dumps(slim, indent=1))
    print((out / "report.md").read_text())


if __name__ == "__main__":
    main()
