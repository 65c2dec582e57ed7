"""Seed 001's replica: two persons tracked through a brick wall by a 1 Tx + 2 Rx radar, with / without ToA association.

The scenario is ``through-wall`` (``uwb_env.scenarios.through_wall``: the seed's antennas, wall, M-sequence radar
and chain; our walks, powers and wall loss). Each seeded run plays the scenario's signal path (``fidelity="signal"``)
six times on identical scans (the draws never depend on the association): with the seed's ToA association
(``sensing.signal.toa_association = True``: couples of steps 4-7), with it but without step 6's completion from the
previous scan (``association_completion = False``, an ablation), without it (every Rx1 x Rx2 ToA combination
intersected), and with the association and a spatial clutter map feeding each position's clutter intensity
(``sensing.signal.clutter_map``, :mod:`uwb_env.detection.clutter_map`: every couple counted, only the couples
that have not moved since the previous scan, or -- Musicki's refinement -- each couple weighted by its a-posteriori
clutter probability from the tracker's association of the scan; the still couples' map is the scenario's default,
the seed's chains run with the map off), each into the scenario's tracker (imm-lmipda with one nearly-constant-velocity
model of a walking person's acceleration, ``through_wall.PERSON_ACCEL_STD_MPS2``: a linear Kalman filter per track
with LMIPDA association and existence-based track management, our stand-in for the seed's MTT). Every chain
compensates the wall (its 0.8 ns excess delay per crossing removed before the intersection).

Per run and chain:

- the localized couples by kind (``couple_kinds``): a person's (both ranges near that person's), a cross ghost
  (Rx1's range near one person's, Rx2's near the other's: the seed's ghost, "approximately eight ghost targets could
  be generated due to the incorrect TOA association") or a false-alarm couple (the seed: "considerably" more than
  the ghosts, "confirmed during association phase"); the cross ghosts the walks make with exact ranges
  (``cross_geometric``); positions off the persons: localized couples farther than ``GHOST_M`` from both;
- hit rate: scans in which a person has a localized couple within ``GHOST_M``;
- tracks: a ghost track is a confirmed track whose median distance to the nearer person over its confirmed scans
  exceeds ``GATE_M`` (a track of no one: the seed's ghost trajectories); a false track (``uwb_env.metrics.
  TrackAccounting``, gate ``GATE_M``) is one matched one-to-one to a person in fewer than half of its confirmed
  scans (ghosts, and also a second track on a person or a track held more than ``GATE_M`` off); a person is tracked
  when a confirmed track holds it in at least ``TRACKED_FRACTION`` of the scans; RMSE over the held scans (to the
  body centre; the seed's ToA is the body's leading edge, so part of it is that bias);
- a ghost track's origin: the kind of most of the localized couples within ``GATE_M`` of the track over its life
  (tentative scans included): persons' couples (a person's second track, or one left lagging behind the person) or
  false-alarm couples (e.g. the background subtraction's static residue on the array's axis, which step 6 without
  its stillness rule completed into ghost tracks: ``toa_association.associate_toas``).

The check (issue 18): with association, 0 ghost tracks in at least 90 % of the runs and both persons tracked (in at
least 90 % of the runs), read on the seed's chain, the scenario's default (``DEFAULT_CHAIN``), and with the still
couples' clutter map (``STILL_MAP_CHAIN``, ThroughWall-v3's default).

Run: python scripts/seed001_through_wall.py [--runs 20] [--seed0 0] [--workers 1] [--set key=value ...]
[--out results/seed001]
(``--calibrate RUNS``: only the range-error model's measurement, ``calibrate``; ``--rooms N [--room0 R]``: only the
check in the rooms R..R+N-1, ``rooms_check``, rooms.md; with ``--alphas A ...`` the check per exponential-averaging
factor, ``alpha_sweep``, alphas.md)
Writes summary.md (ours beside the seed's), summary.csv (its numbers per chain), runs.csv (one row per run and chain),
radargrams.png (Figs. 5e-f / 6a-d-like: background-subtracted, normalized scans and CFAR outputs), toa_association.png
(Fig. 6e-f-like: the potential simple targets and the associated couples) and positions_tracks.png (Fig. 7-like:
positions without and with association, tracks vs truth) of the first run.
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import os
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from uwb_env import scenarios
from uwb_env.config import ScenarioConfig
from uwb_env.constants import SPEED_OF_LIGHT_MPS
from uwb_env.localization.couples import array_frame, couple_positions
from uwb_env.metrics import TrackAccounting
from uwb_env.scenarios import through_wall
from uwb_env.sensing.records import ScanPlan
from uwb_env.sim import Simulator

GHOST_M = 0.75
"""A localized couple farther than this from both persons is a ghost position [m]."""
ATTRIBUTION_M = 0.4
"""A couple's range within this of a person's bistatic range is that person's (3 sigma of the ToA error) [m]."""
CALIBRATION_GATE_M = 0.5
"""``calibrate``: a ToA within this of a person's bistatic range is that person's [m]."""
GATE_M = 1.0
"""Track-to-person assignment gate [m] (``TrackAccounting``)."""
TRACKED_FRACTION = 0.5
"""A person is tracked when a confirmed track holds it in at least this fraction of its scans."""
SEED = {"ghosts": 8, "scan_s": 0.074, "processing_s": 0.012}
"""Seed 001's numbers: ~8 ghost targets without the association (section 4), one impulse response every 0.074 s,
0.012 s to process one in MATLAB (section 3.3)."""
_NO_MAP = {"sensing.signal.clutter_map": False}
CHAINS = {
    "association": {"sensing.signal.toa_association": True, **_NO_MAP},
    "association without step 6": {
        "sensing.signal.toa_association": True,
        "sensing.signal.association_completion": False,
        **_NO_MAP,
    },
    "no association": {"sensing.signal.toa_association": False, **_NO_MAP},
    "association + clutter map": {
        "sensing.signal.toa_association": True,
        "sensing.signal.clutter_map": True,
        "sensing.signal.clutter_map_count": "all",
    },
    "association + clutter map of still couples": {
        "sensing.signal.toa_association": True,
        "sensing.signal.clutter_map": True,
        "sensing.signal.clutter_map_count": "still",
    },
    "association + clutter map of unassociated detections": {
        "sensing.signal.toa_association": True,
        "sensing.signal.clutter_map": True,
        "sensing.signal.clutter_map_count": "unassociated",
    },
}
"""The chains compared: name -> overrides of the scenario's signal path."""
DEFAULT_CHAIN = "association"
"""The scenario's own signal path (``through_wall.THROUGH_WALL_SIGNAL``): the seed's chain (ThroughWall-v4; v3 added
the still couples' clutter map, ``STILL_MAP_CHAIN``)."""
STILL_MAP_CHAIN = "association + clutter map of still couples"
"""The seed's chain and a clutter map of the couples that have not moved (the scenario's default in ThroughWall-v3)."""
ROOM_CHAINS = (DEFAULT_CHAIN, STILL_MAP_CHAIN)
"""``--rooms``: the scenario's (the seed's) chain and with the still couples' map."""
CHECK_FRACTION = 0.9
"""Issue 18's check: no ghost track in, and both persons tracked in, at least this fraction of the runs."""
TITLES = {
    "association": "association (seed 001, steps 1-7: the scenario's default)",
    "association without step 6": "association without step 6",
    "no association": "no association (every Rx1 x Rx2 couple)",
    "association + clutter map": "association + clutter map (every couple counted)",
    "association + clutter map of still couples": "association + clutter map (still couples counted)",
    "association + clutter map of unassociated detections": "association + clutter map (each couple x its clutter "
    "probability, Musicki)",
}
"""The chains' column titles in summary.md."""


WALK_SETS = {
    "scenario": through_wall.WALKS,
    "mirrored": tuple(((-s[0], s[1]), (-e[0], e[1])) for s, e in through_wall.WALKS),
    "tangential": (((-1.8, 2.4), (1.2, 2.6)), ((1.8, 4.6), (-1.2, 4.4))),
}
"""The persons' walks, (start, far end) each (``--set walks=NAME``, the study's key): the scenario's (radial: towards
and away from the array), mirrored left-right (the turns too; the room's paths are not mirrored), or across the array's
view (3 m walks at 2.5 m and 4.5 m, bistatic range-rates within +-0.6 m/s); ``random-N``: ``random_walks(N)``."""


def random_walks(n: int) -> tuple[tuple[tuple[float, float], tuple[float, float]], ...]:
    """Walk set ``random-N``: two persons' (start, far end), drawn from seed N.

    Each point uniform over x in [-1.8, 1.8] m, y in [1.6, 5.5] m (the room behind the wall, clear of the blind zone),
    the far end redrawn until the walk is at least 2 m long.
    """
    rng = np.random.default_rng(n)
    walks = []
    for _ in range(2):  # persons
        start = (float(rng.uniform(-1.8, 1.8)), float(rng.uniform(1.6, 5.5)))
        end = start
        while np.hypot(end[0] - start[0], end[1] - start[1]) < 2.0:  # a few draws
            end = (float(rng.uniform(-1.8, 1.8)), float(rng.uniform(1.6, 5.5)))
        walks.append((start, end))
    return tuple(walks)


def with_walks(cfg: ScenarioConfig, walks: str) -> ScenarioConfig:
    """``cfg`` with the persons on ``WALK_SETS[walks]``, or on ``random_walks(N)`` for ``random-N``.

    Each person walks there and back at ``through_wall.SPEED_MPS`` (``through_wall.there_and_back``).
    """
    name, _, n = walks.partition("-")
    if walks not in WALK_SETS and not (name == "random" and n.isdigit()):
        raise ValueError(f"walks = {walks!r}: must be one of {sorted(WALK_SETS)} or random-N (N >= 0)")
    if walks == "scenario":
        return cfg
    chosen = random_walks(int(n)) if name == "random" else WALK_SETS[walks]
    sign = -1.0 if walks == "mirrored" else 1.0
    targets = tuple(
        dataclasses.replace(target, trajectory=through_wall.there_and_back(start, end, sign))
        for target, (start, end) in zip(cfg.targets, chosen, strict=True)  # persons: two
    )
    return dataclasses.replace(cfg, targets=targets, n_scans=through_wall.walk_scans(chosen))


def scenario(chain: str, overrides: dict[str, Any]) -> ScenarioConfig:
    """The through-wall scenario on its signal path with ``chain``'s association (``CHAINS``) and ``overrides``.

    ``overrides["walks"]`` (the study's key, not the scenario's): the persons' walks, ``WALK_SETS``.
    """
    rest = {k: v for k, v in overrides.items() if k != "walks"}
    cfg = scenarios.get("through-wall", **{"sensing.fidelity": "signal", **CHAINS[chain], **rest})
    return with_walks(cfg, str(overrides.get("walks", "scenario")))


def _array(cfg: ScenarioConfig) -> tuple[np.ndarray, np.ndarray]:
    """``(tx (2,), rx (2, 2))`` of the through-wall radar."""
    return np.asarray(cfg.transmitters[0].position_m, dtype=float), np.array([r.position_m for r in cfg.receivers])


def bistatic(p: np.ndarray, array: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """``(L, 2)`` bistatic ranges (no walls) of positions ``p`` ``(L, 2)`` to Rx1 and Rx2 [m]."""
    tx, rx = array
    return np.linalg.norm(p - tx, axis=-1)[:, None] + np.linalg.norm(p[:, None] - rx[None], axis=-1)


def couple_kinds(z: np.ndarray, truth: np.ndarray, array: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """``(L,)`` kind of each localized couple at ``z`` ``(L, 2)``: 0 a person's, 1 a cross ghost, 2 a false alarm's.

    The couple's ranges are those of its position (the intersection is exact; walls already removed), compared with
    the persons' ``truth`` ``(K, 2)``: both within ``ATTRIBUTION_M`` of one person: that person's couple; Rx1's of
    one person and Rx2's of another: a cross ghost (seed 001's ghost: "the incorrect TOA association" of two
    persons' ToAs); otherwise a couple with at least one false alarm.
    """
    if z.shape[0] == 0:
        return np.zeros(0, np.int64)
    near = np.abs(bistatic(z, array)[:, None, :] - bistatic(truth, array)[None]) < ATTRIBUTION_M  # (L, K, 2)
    person = (near[..., 0] & near[..., 1]).any(axis=1)
    cross = near[..., 0].any(axis=1) & near[..., 1].any(axis=1) & ~person  # two different persons
    return np.where(person, 0, np.where(cross, 1, 2))


def cross_geometric(truth: np.ndarray, array: tuple[np.ndarray, np.ndarray], cfg: ScenarioConfig) -> int:
    """The cross ghosts the two walks themselves create, ``truth`` ``(S, K, 2)`` the persons' positions.

    Per scan, the persons' exact ranges crossed (Rx1's of one, Rx2's of the other), intersected, inside the
    surveillance area and farther than ``GHOST_M`` from both persons: the count a chain that detected every ToA
    exactly would show without association.
    """
    tx, rx = array
    e, n, beta = array_frame(tx, rx[0], rx[1], np.array([0.0, 1.0]))
    area = cfg.surveillance_area
    count = 0
    for pos in truth:  # scans
        r = bistatic(pos, array)  # (K, 2)
        K = r.shape[0]
        i, j = (a.ravel() for a in np.meshgrid(np.arange(K), np.arange(K), indexing="ij"))
        sel = i != j
        p, ok = couple_positions(r[i[sel], 0], r[j[sel], 1], tx, e, n, beta)
        inside = (p[:, 0] >= area.x_min_m) & (p[:, 0] <= area.x_max_m) & (p[:, 1] >= area.y_min_m)
        inside &= p[:, 1] <= area.y_max_m
        far = np.linalg.norm(p[:, None] - pos[None], axis=-1).min(axis=1) > GHOST_M
        count += int(np.sum(ok & inside & far))
    return count


def run(
    seed: int, overrides: dict[str, Any], keep: bool = False, chains: tuple[str, ...] = tuple(CHAINS)
) -> dict[str, Any]:
    """The ``chains`` (default: all of ``CHAINS``) on run ``seed``; ``keep``: also the per-scan positions and tracks."""
    out: dict[str, Any] = {"seed": seed}
    for name in chains:  # the chains: six
        cfg = scenario(name, overrides)
        sim = Simulator(cfg)
        plan = ScanPlan.all_listening(0, sim.sensor.n_tx, sim.sensor.n_rx)
        sim.reset(seed)
        acc = TrackAccounting(sim.truth.n_targets, GATE_M)
        array = _array(cfg)
        if "cross_geometric" not in out:  # the walks' own cross couples: the same in every chain
            out["cross_geometric"] = cross_geometric(sim.truth.states[1:][..., [0, 2]], array, cfg)
        ghosts, hits, positions, tracks = [], [], [], []
        kinds = np.zeros(3, np.int64)  # person couples, cross ghosts, false-alarm couples
        track_dist: dict[int, list[float]] = {}
        feeds: dict[int, np.ndarray] = {}  # per track: the kinds of the couples within GATE_M of it, all its scans
        while not sim.done:
            res = sim.step(plan)
            k = res.scan_index
            truth = sim.truth.states[k][:, [0, 2]]
            z = np.concatenate([d.z for d in res.detections]) if res.detections else np.zeros((0, 2))
            dist = np.linalg.norm(z[:, None] - truth[None], axis=-1)  # (L, K)
            ghosts.append(int(np.sum(dist.min(axis=1, initial=np.inf) > GHOST_M)))
            kind = couple_kinds(z, truth, array)
            kinds += np.bincount(kind, minlength=3)
            hits.append((dist < GHOST_M).any(axis=0))
            x, _ = res.tracks.combined()
            fed = np.linalg.norm(x[:, None, [0, 2]] - z[None], axis=-1) < GATE_M  # (N, L)
            for tid, row in zip(res.tracks.ids.tolist(), fed, strict=True):  # tracks: a few
                feeds[tid] = feeds.get(tid, np.zeros(3, np.int64)) + np.bincount(kind[row], minlength=3)
            acc.add(res.tracks.ids, res.tracks.confirmed, x[:, [0, 2]], truth, sim.truth.alive[k])
            c = np.flatnonzero(res.tracks.confirmed)
            live = truth[sim.truth.alive[k]]
            near = np.linalg.norm(x[c][:, None, [0, 2]] - live[None], axis=-1).min(axis=1, initial=np.inf)
            for tid, dist_m in zip(res.tracks.ids[c].tolist(), near.tolist(), strict=True):  # confirmed: a few
                track_dist.setdefault(tid, []).append(dist_m)
            if keep:
                positions.append(z)
                c = res.tracks.confirmed
                tracks.append((res.tracks.ids[c], x[c][:, [0, 2]]))
        err = np.array(acc.errors)
        coverage = acc.coverage()
        ghost_ids = [tid for tid, v in track_dist.items() if float(np.median(v)) > GATE_M]
        # a ghost track's origin: the kind of most of the couples near it (persons': a person's second or lagging
        # track; false alarms': e.g. a static residue of the background subtraction)
        origin = np.bincount([int(np.argmax(feeds[tid])) for tid in ghost_ids], minlength=3)
        out[name] = {
            "ghost_positions": int(np.sum(ghosts)),
            "person_couples": int(kinds[0]),
            "cross_ghosts": int(kinds[1]),
            "false_couples": int(kinds[2]),
            "ghosts_per_scan": float(np.mean(ghosts)),
            "hit_rate": np.mean(hits, axis=0),
            "ghost_tracks": len(ghost_ids),
            "ghost_tracks_person": int(origin[0]),
            "ghost_tracks_cross": int(origin[1]),
            "ghost_tracks_false": int(origin[2]),
            "false_tracks": acc.false_tracks(),
            "coverage": coverage,
            "both_tracked": bool(np.all(coverage >= TRACKED_FRACTION)),
            "rmse_m": float(np.sqrt(np.nanmean(err**2))) if np.isfinite(err).any() else float("nan"),
            "positions": positions,
            "tracks": tracks,
        }
    return out


def traces(seed: int, overrides: dict[str, Any]) -> dict[str, Any]:
    """Run ``seed``'s in-sensor traces, scanned as the simulator scans them.

    Per scan: normalized differences, decisions, ToAs and the associated couples; the truth's bistatic ranges (walls'
    delay included).
    """
    cfg = scenario("association", overrides)
    sim = Simulator(cfg)
    sim.reset(seed)
    s, ep = sim.sensor, sim.episode
    plan = ScanPlan.all_listening(0, s.n_tx, s.n_rx)
    d, dec, toas, couples = [], [], [], []
    for k in range(1, cfg.n_scans + 1):  # scans
        scans, active = s.synthesise(ep, k, plan)
        tr = s.detect(ep, k, plan, scans, active)
        d.append(tr.difference)
        dec.append(tr.decisions)
        toas.append([tr.ranges[tr.toa_row == i] for i in range(2)])
        _, r, _, _ = s.couples(ep, k, tr, associate=True)
        couples.append(r)
    fs = cfg.sensing.signal.sample_rate_hz
    axis = s.baseline[0] + SPEED_OF_LIGHT_MPS * (np.arange(cfg.sensing.signal.n_samples) - ep.reference_peak[0, 0]) / fs
    wall = 2.0 * SPEED_OF_LIGHT_MPS * cfg.walls[0].material.excess_delay_s
    return {
        "d": np.array(d),
        "decisions": np.array(dec),
        "toas": toas,
        "couples": couples,
        "range_axis": axis,
        "truth_range": ep.geom.bistatic_range[1:, 0],
        "truth_pos": sim.truth.states[1:][..., [0, 2]],
        "wall_m": wall,
        "cfg": cfg,
    }


def calibrate(seeds: list[int], overrides: dict[str, Any]) -> dict[str, float]:
    """The couples' range-error model measured on runs ``seeds``.

    The scenario's ``toa_interval_offset_s``, ``range_std_floor_m`` and ``couple_common_std_m``. Per scan and
    person whose bistatic range both receivers have a ToA within ``CALIBRATION_GATE_M`` of, the errors
    e_k = ToA range - the body centre's range (walls included). e_k = c + i_k with c common to both receivers (the
    same body surface) and i_k independent: E[(e_1 - e_2)^2] / 2 = sigma_i^2 (a residual bias between the receivers
    included), var((e_1 + e_2) / 2) = sigma_c^2 + sigma_i^2 / 2. Returns the mean error (the interval ToA's bias
    towards the body front), the offset that removes it, sigma_i, sigma_c, the samples and the persons' ToA rate.
    """
    e, n_slots = [], 0
    for seed in seeds:  # runs: a few
        tr = traces(seed, overrides)
        for k, toas in enumerate(tr["toas"]):  # scans
            truth = tr["truth_range"][k]  # (2, K)
            for j in range(truth.shape[1]):  # persons: two
                n_slots += 1
                pair = []
                for i in range(2):  # receivers
                    d = toas[i] - truth[i, j]
                    if d.size and np.abs(d).min() < CALIBRATION_GATE_M:
                        pair.append(float(d[np.argmin(np.abs(d))]))
                if len(pair) == 2:
                    e.append(pair)
    err = np.array(e)
    mean = float(err.mean())
    ind2 = float(np.mean((err[:, 0] - err[:, 1]) ** 2) / 2.0)
    com2 = float(np.var(err.mean(axis=1)) - ind2 / 2.0)
    sig = scenario("association", overrides).sensing.signal
    return {
        "mean_error_m": mean,
        "toa_interval_offset_s": sig.toa_interval_offset_s - mean / SPEED_OF_LIGHT_MPS,
        "range_std_floor_m": float(np.sqrt(ind2)),
        "couple_common_std_m": float(np.sqrt(max(com2, 0.0))),
        "samples": float(err.shape[0]),
        "both_receivers_rate": err.shape[0] / max(n_slots, 1),
    }


def _figures(out: Path, tr: dict[str, Any], rec: dict[str, Any]) -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    S = tr["d"].shape[0]
    scans = np.arange(1, S + 1)
    ax_r = tr["range_axis"]
    names = []
    fig, axes = plt.subplots(2, 2, figsize=(11, 7), sharex=True, sharey=True)
    for i in range(2):  # receivers
        for row, (img, title) in enumerate(((tr["d"][:, i], "normalized difference"), (tr["decisions"][:, i], "CFAR"))):
            a = axes[row, i]
            a.imshow(img.T, aspect="auto", origin="lower", extent=(0.5, S + 0.5, ax_r[0], ax_r[-1]), cmap="viridis")
            a.plot(scans, tr["truth_range"][:, i], "r--", lw=0.6)
            a.set_ylim(0.0, 14.0)
            a.set_title(f"Rx{i + 1}: {title}", fontsize=9)
        axes[1, i].set_xlabel("scan")
    for a in axes[:, 0]:
        a.set_ylabel("bistatic range [m]")
    fig.suptitle("Radargrams after background subtraction and advance normalization; CFAR outputs (truth dashed)")
    fig.tight_layout()
    fig.savefig(out / "radargrams.png", dpi=60)
    plt.close(fig)
    names.append("radargrams.png")

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5), sharey=True)
    for i in range(2):  # receivers
        xs = np.concatenate([np.full(t[i].size, k + 1) for k, t in enumerate(tr["toas"])])
        ys = np.concatenate([t[i] for t in tr["toas"]])
        axes[0].plot(xs + (0.2 * i), ys, ".", ms=2, label=f"Rx{i + 1}")
        xc = np.concatenate([np.full(c.shape[0], k + 1) for k, c in enumerate(tr["couples"])])
        yc = np.concatenate([c[:, i] for c in tr["couples"]]) + tr["wall_m"]
        axes[1].plot(xc + (0.2 * i), yc, ".", ms=3, label=f"Rx{i + 1}")
    titles = ("potential simple targets (steps 1-3)", "associated ToA couples (steps 4-7)")
    for a, title in zip(axes, titles, strict=True):
        for i in range(2):
            a.plot(scans, tr["truth_range"][:, i], "k-", lw=0.4)
        a.set_title(title, fontsize=9)
        a.set_xlabel("scan")
        a.set_ylim(0.0, 14.0)
        a.legend(fontsize=8)
    axes[0].set_ylabel("bistatic range [m] (walls' delay included)")
    fig.tight_layout()
    fig.savefig(out / "toa_association.png", dpi=80)
    plt.close(fig)
    names.append("toa_association.png")

    fig, axes = plt.subplots(1, 3, figsize=(14, 5), sharex=True, sharey=True)
    truth = tr["truth_pos"]
    area = tr["cfg"].surveillance_area
    for a, name in zip(axes[:2], ("no association", "association"), strict=True):
        z = np.concatenate(rec[name]["positions"])
        a.plot(z[:, 0], z[:, 1], ".", ms=2, color="tab:blue")
        c = rec[name]
        a.set_title(f"positions, {name} ({c['cross_ghosts']} cross ghosts, {c['ghost_positions']} off)", fontsize=9)
    a = axes[2]
    ids = np.concatenate([t[0] for t in rec["association"]["tracks"]])
    xy = np.concatenate([t[1] for t in rec["association"]["tracks"]])
    for tid in np.unique(ids):  # confirmed tracks of one run: a few
        sel = ids == tid
        a.plot(xy[sel, 0], xy[sel, 1], "-", lw=1.2)
    a.set_title(f"confirmed tracks, association ({rec['association']['ghost_tracks']} ghost tracks)", fontsize=9)
    for a in axes:
        for j in range(truth.shape[1]):
            a.plot(truth[:, j, 0], truth[:, j, 1], "k--", lw=0.8)
        a.plot([-0.4, 0.0, 0.4], [0.0, 0.0, 0.0], "k^")
        a.axhline(tr["cfg"].walls[0].start_m[1], color="brown", lw=3)
        a.set_xlim(area.x_min_m, area.x_max_m)
        a.set_ylim(-0.2, area.y_max_m)
        a.set_aspect("equal")
        a.set_xlabel("x [m]")
    axes[0].set_ylabel("y [m]")
    fig.tight_layout()
    fig.savefig(out / "positions_tracks.png", dpi=80)
    plt.close(fig)
    names.append("positions_tracks.png")
    return names


def _window_note(cfg: ScenarioConfig) -> str:
    """Why steps 4-5 add nothing to an exact two-ellipse intersection when W_p exceeds the widening m."""
    sig = cfg.sensing.signal
    wp_m = sig.toa_interval_samples / sig.sample_rate_hz * SPEED_OF_LIGHT_MPS
    rx = np.array([r.position_m for r in cfg.receivers])
    aperture = float(np.linalg.norm(rx[0] - rx[1]))
    m_m = aperture + SPEED_OF_LIGHT_MPS * sig.association_correction_s
    relation = "wider than" if wp_m > m_m else "not wider than"
    return (
        f"Steps 1-3's window W_p = {sig.toa_interval_samples} samples spans {wp_m:.2f} m of bistatic range, "
        f"{relation} the widening m c = {aperture:.2f} m + c t_corr = {m_m:.2f} m: one receiver's ToAs lie at least "
        "W_p apart, their widened intervals never merge, and steps 4-5 keep exactly the Rx1 x Rx2 couples whose "
        f"ranges differ by at most m c -- those whose ellipses can meet at all (|r1 - r2| <= |Rx1 Rx2| = "
        f"{aperture:.2f} m) up to t_corr. Our exact two-ellipse intersection rejects the others by itself, so "
        "without step 6 the association and no association give the same positions: the association removes no "
        "cross ghost that intersects (the seed's deghosting needs a localization that turns the other couples "
        "into positions too; its 'ghost positions would form two additional continuous trajectories'). Cross "
        "ghosts need the two persons' ranges within m of each other across the receivers; there the interval ToA "
        "of each receiver often merges the two traces into one (the seed's 'losses TOA in the case of the target "
        "trace crossing'), so the chain's couples hold fewer cross ghosts than the walks' exact ranges make. Step "
        "6 repeats a previous scan's couple for an isolated ToA near it: more persons' and more false couples. It "
        "completes a moving target's trace only: an isolated ToA within one sample of its receiver's ToA in the "
        "previous couple (toa_association.STILL_S) has not moved and is not completed -- the background "
        "subtraction's residue of a static path (on the array's axis, both receivers' ToAs at 2.57 m), which the "
        "literal step 6 completed into ghost tracks."
    )


def _clutter_map_note(cfg: ScenarioConfig, aggs: dict[str, dict[str, float]]) -> str:
    """summary.md's paragraph on the clutter-map chains (``CHAINS``): what the map does, which is the default."""
    sig = cfg.sensing.signal
    one = 1.0 / (sig.clutter_map_memory_scans * sig.clutter_map_cell_m**2)
    a, m, st, un = (
        aggs["association"],
        aggs["association + clutter map"],
        aggs[STILL_MAP_CHAIN],
        aggs["association + clutter map of unassociated detections"],
    )
    cells = [f"{x['zero_ghost_tracks']:.0%} / {x['both']:.0%} / {x['coverage']:.1%}" for x in (a, m, st, un)]
    return (
        "Clutter map (Musicki & Evans 2004, `uwb_env.detection.clutter_map`: cells of "
        f"{sig.clutter_map_cell_m} m, the position detections per scan averaged over a memory of "
        f"{sig.clutter_map_memory_scans:.0f} scans, floored at the prior {sig.false_position_density_per_m2} per m^2, "
        "read before each scan updates it, empty every episode): runs without a ghost track / both persons tracked / "
        f"scans a person is held {cells[0]} without the map (the seed's chain, the scenario's default), {cells[2]} "
        f"counting the couples that have not moved (ThroughWall-v3's default), {cells[1]} counting every couple, "
        f"{cells[3]} with Musicki's "
        "a-posteriori weights. The exponential background passes the fluctuation of the room's static paths, whose "
        "couples come back at one spot in bursts of a few scans, enough to confirm a ghost track; a walking person "
        "moves about one range sample a scan and does not feed the still couples' map. Counting every couple "
        f"costs the persons their tracks: one detection in a cell reads {one:.2f} per m^2, "
        f"{one / sig.false_position_density_per_m2:.1f} times the prior on which the persons' tracks live. Musicki's "
        "refinement (each couple adds 1 - sum over tracks of P(the track exists and made it), from the tracker's "
        "LMIPDA association, the map updated after the tracker's step) counts a person the tracker has not yet "
        "confirmed as clutter."
    )


def _room_run(seed: int, overrides: dict[str, Any]) -> dict[str, tuple[int, bool, float]]:
    """(ghost tracks, both persons tracked, RMSE) of each of ``ROOM_CHAINS`` on run ``seed``."""
    rec = run(seed, overrides, chains=ROOM_CHAINS)
    return {c: (rec[c]["ghost_tracks"], rec[c]["both_tracked"], rec[c]["rmse_m"]) for c in ROOM_CHAINS}


def check_holds(zero_ghost_runs: float, both_runs: float) -> bool:
    """Issue 18's check from the fractions of runs without a ghost track and with both persons tracked."""
    return zero_ghost_runs >= CHECK_FRACTION and both_runs >= CHECK_FRACTION


def _rooms(
    pool: ProcessPoolExecutor, rooms: range, seeds: list[int], overrides: dict[str, Any]
) -> list[dict[str, tuple[float, float, float]]]:
    """Per room of ``rooms``: chain -> (runs without a ghost track, runs with both persons tracked, median RMSE)."""
    out = []
    for room in rooms:  # rooms: a few
        ov = {**overrides, "sensing.signal.background_seed": room}
        recs = list(pool.map(_room_run, seeds, [ov] * len(seeds)))
        out.append(
            {
                c: (
                    float(np.mean([r[c][0] == 0 for r in recs])),
                    float(np.mean([r[c][1] for r in recs])),
                    float(np.nanmedian([r[c][2] for r in recs])),
                )
                for c in ROOM_CHAINS
            }
        )
    return out


def _rooms_command(args: argparse.Namespace, out: Path, extra: str = "") -> str:
    sets = f" --set {' '.join(args.set)}" if args.set else ""
    first = f" --room0 {args.room0}" if args.room0 else ""
    return (
        f"`python scripts/seed001_through_wall.py --rooms {args.rooms}{first} --runs {args.runs} --seed0 {args.seed0}"
        f"{extra}{sets} --out {out}`"
    )


def rooms_check(args: argparse.Namespace, overrides: dict[str, Any]) -> None:
    """The check in rooms ``room0 .. room0 + rooms - 1``; writes rooms.md (``--alphas``: alphas.md instead).

    A room is the draw of its static paths from ``background_seed`` (the scenario's is 0); the walks and everything
    else are the scenario's.
    """
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    seeds = list(range(args.seed0, args.seed0 + args.runs))
    rooms = range(args.room0, args.room0 + args.rooms)
    if args.alphas:
        alpha_sweep(args, overrides, out, seeds, rooms)
        return
    lines = [
        f"# Seed 001's check in {args.rooms} rooms (runs {seeds[0]}-{seeds[-1]} in each)",
        "",
        f"Command: {_rooms_command(args, out)}",
        "",
        "A room is the draw of its static paths (`sensing.signal.background_seed`; the scenario's is 0). Cells: runs "
        "without a ghost track / runs with both persons tracked / median RMSE [m].",
        "",
        "| room | the seed's chain (association: the scenario's default) | + the still couples' clutter map | check "
        "holds (the scenario's chain) |",
        "| --- | --- | --- | --- |",
    ]
    with ProcessPoolExecutor(args.workers) as pool:
        for room, agg in zip(rooms, _rooms(pool, rooms, seeds, overrides), strict=True):  # rooms: a few
            cells = [f"{agg[c][0]:.0%} / {agg[c][1]:.0%} / {agg[c][2]:.3f}" for c in ROOM_CHAINS]
            holds = check_holds(*agg[DEFAULT_CHAIN][:2])
            lines.append(f"| {room} | {cells[0]} | {cells[1]} | {'yes' if holds else 'no'} |")
            print(lines[-1], flush=True)
    (out / "rooms.md").write_text("\n".join(lines) + "\n")


def alpha_sweep(args: argparse.Namespace, overrides: dict[str, Any], out: Path, seeds: list[int], rooms: range) -> None:
    """The check in ``rooms`` for each exponential-averaging factor of ``args.alphas``; writes alphas.md.

    Per factor alpha (``sensing.signal.background_alpha``), on the scenario's chain: the rooms where the check holds,
    the runs without a ghost track and with both persons tracked over all rooms, the median of the rooms' median
    RMSE; beside them what alpha does to the signal (``uwb_env.channel.background_mti``): a static path's residue
    after a step (a person shadowing it) falls by 20 log10(1 / alpha) dB a scan, a walking person's echo (bistatic
    range-rate 1.6 m/s) keeps ``retained_fraction`` of its power and a steady echo at 0.1 m/s less.
    """
    from uwb_env.channel.background_mti import delay_step_s, envelope_std_s, retained_fraction
    from uwb_env.waveforms.library import WaveformLibrary

    cfg = scenario(DEFAULT_CHAIN, overrides)
    wf = WaveformLibrary(cfg.waveforms)[0]
    period, lpf = cfg.sensing.scan_period_s, cfg.sensing.signal.envelope_lpf_s
    s = envelope_std_s(wf.rms_bandwidth_hz)  # the MTI's inputs as the parametric model's table takes them
    lines = [
        f"# Seed 001's check against the exponential average's factor, rooms {rooms[0]}-{rooms[-1]} (runs "
        f"{seeds[0]}-{seeds[-1]} in each)",
        "",
        f"Command: {_rooms_command(args, out, ' --alphas ' + ' '.join(f'{a:g}' for a in args.alphas))}",
        "",
        "The scenario's chain (the seed's: association, no clutter map). Residue decay: what a static path's residue "
        "loses a scan after a person starts or stops shadowing it; retained: the background's loss on a steady echo "
        "(`background_mti.retained_fraction`) at a bistatic range-rate of 1.6 / 0.1 m/s.",
        "",
        "| alpha | rooms where the check holds (with the still couples' map) | runs without a ghost track | runs with "
        "both persons tracked | median RMSE [m] | residue decay [dB / scan] | retained at 1.6 / 0.1 m/s |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    with ProcessPoolExecutor(args.workers) as pool:
        for alpha in args.alphas:  # factors: a few
            per_room = _rooms(pool, rooms, seeds, {**overrides, "sensing.signal.background_alpha": alpha})
            zero, both, rmse = (np.array([a[DEFAULT_CHAIN][i] for a in per_room]) for i in range(3))
            holds = {c: sum(check_holds(*a[c][:2]) for a in per_room) for c in ROOM_CHAINS}
            kept = [
                float(np.squeeze(retained_fraction(delay_step_s(v, period), alpha, s, wf.center_freq_hz, lpf)))
                for v in (1.6, 0.1)
            ]
            lines.append(
                f"| {alpha:g} | {holds[DEFAULT_CHAIN]} ({holds[STILL_MAP_CHAIN]}) of {len(rooms)} | "
                f"{zero.mean():.1%} | {both.mean():.1%} | {np.median(rmse):.3f} | {20.0 * np.log10(1.0 / alpha):.1f} | "
                f"{kept[0]:.2f} / {kept[1]:.2f} |"
            )
            print(lines[-1], flush=True)
    (out / "alphas.md").write_text("\n".join(lines) + "\n")


def _row(label: str, cells: list[str], seed: str) -> str:
    return f"| {label} | " + " | ".join(cells) + f" | {seed} |"


def _parse_sets(items: list[str]) -> dict[str, Any]:
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep:
            raise SystemExit(f"--set {item!r}: must be key=value")
        try:
            out[key] = ast.literal_eval(value)
        except (ValueError, SyntaxError):
            out[key] = value
    return out


def main() -> None:
    """Run the seeded runs of both chains; write summary.md, runs.csv and the figures."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--seed0", type=int, default=0, help="the first run's seed (runs seed0 ... seed0 + runs - 1)")
    ap.add_argument("--workers", type=int, default=min(2, os.cpu_count() or 1))
    ap.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE", help="scenario overrides (dotted keys)")
    ap.add_argument("--out", default="results/seed001")
    ap.add_argument("--calibrate", type=int, default=0, metavar="RUNS", help="measure the range-error model only")
    ap.add_argument(
        "--rooms", type=int, default=0, metavar="N", help="only the check in rooms 0..N-1 (background_seed): rooms.md"
    )
    ap.add_argument("--room0", type=int, default=0, metavar="R", help="--rooms: the first room (default 0)")
    ap.add_argument(
        "--alphas",
        type=float,
        nargs="*",
        default=[],
        metavar="ALPHA",
        help="--rooms: the check for each exponential-averaging factor (sensing.signal.background_alpha): alphas.md",
    )
    args = ap.parse_args()
    if args.rooms < 0:
        raise SystemExit(f"--rooms={args.rooms}: must be >= 0")
    if args.room0 < 0:
        raise SystemExit(f"--room0={args.room0}: must be >= 0")
    if args.alphas and not args.rooms:
        raise SystemExit("--alphas: needs --rooms N")
    bad = [a for a in args.alphas if not 0.0 < a < 1.0]
    if bad:
        raise SystemExit(f"--alphas {bad[0]!r}: must be in (0, 1)")
    if args.runs < 1:
        raise SystemExit(f"--runs={args.runs}: must be >= 1")
    if args.seed0 < 0:
        raise SystemExit(f"--seed0={args.seed0}: must be >= 0")
    overrides = _parse_sets(args.set)
    if args.rooms:
        rooms_check(args, overrides)
        return
    if args.calibrate:
        cal = calibrate(list(range(args.calibrate)), overrides)
        print("\n".join(f"{k}: {v:.4g}" for k, v in cal.items()))
        return
    scenario("association", overrides)  # a bad override fails here, before the pool starts
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    seeds = list(range(args.seed0, args.seed0 + args.runs))
    with ProcessPoolExecutor(args.workers) as pool:
        futures = [pool.submit(run, s, overrides, s == seeds[0]) for s in seeds]
        runs = [f.result() for f in futures]
    rows = [
        "chain,seed,cross_ghosts,cross_geometric,false_couples,person_couples,ghost_positions,ghosts_per_scan,"
        "hit_rate_1,hit_rate_2,ghost_tracks,ghost_tracks_person,ghost_tracks_cross,ghost_tracks_false,false_tracks,"
        "coverage_1,coverage_2,rmse_m"
    ]
    for r in runs:
        for name in CHAINS:
            c = r[name]
            rows.append(
                f"{name},{r['seed']},{c['cross_ghosts']},{r['cross_geometric']},{c['false_couples']},"
                f"{c['person_couples']},{c['ghost_positions']},{c['ghosts_per_scan']:.4f},{c['hit_rate'][0]:.4f},"
                f"{c['hit_rate'][1]:.4f},{c['ghost_tracks']},{c['ghost_tracks_person']},{c['ghost_tracks_cross']},"
                f"{c['ghost_tracks_false']},{c['false_tracks']},{c['coverage'][0]:.4f},"
                f"{c['coverage'][1]:.4f},"
                f"{c['rmse_m']:.4f}"
            )
    (out / "runs.csv").write_text("\n".join(rows) + "\n")
    cfg = scenario("association", overrides)
    n = len(runs)

    def agg(name: str) -> dict[str, float]:
        c = [r[name] for r in runs]
        return {
            "cross_ghosts_per_run": float(np.mean([x["cross_ghosts"] for x in c])),
            "cross_geometric_per_run": float(np.mean([r["cross_geometric"] for r in runs])),
            "false_couples_per_scan": float(np.mean([x["false_couples"] for x in c])) / cfg.n_scans,
            "person_couples_per_scan": float(np.mean([x["person_couples"] for x in c])) / cfg.n_scans,
            "ghosts_per_scan": float(np.mean([x["ghosts_per_scan"] for x in c])),
            "ghosts_per_run": float(np.mean([x["ghost_positions"] for x in c])),
            "hit": float(np.mean([x["hit_rate"] for x in c])),
            "zero_ghost_tracks": float(np.mean([x["ghost_tracks"] == 0 for x in c])),
            "ghost_tracks": float(np.mean([x["ghost_tracks"] for x in c])),
            "ghost_tracks_person": float(np.mean([x["ghost_tracks_person"] for x in c])),
            "ghost_tracks_false": float(np.mean([x["ghost_tracks_false"] for x in c])),
            "false_tracks": float(np.mean([x["false_tracks"] for x in c])),
            "both": float(np.mean([x["both_tracked"] for x in c])),
            "coverage": float(np.mean([x["coverage"] for x in c])),
            "rmse": float(np.nanmedian([x["rmse_m"] for x in c])),
        }

    aggs = [agg(name) for name in CHAINS]
    a = aggs[0]
    keys = list(a)
    (out / "summary.csv").write_text(
        "\n".join(
            ["chain," + ",".join(keys)]
            + [f"{name}," + ",".join(f"{x[k]:.4f}" for k in keys) for name, x in zip(CHAINS, aggs, strict=True)]
        )
        + "\n"
    )
    d = aggs[list(CHAINS).index(STILL_MAP_CHAIN)]

    def verdict(x: dict[str, float]) -> str:
        holds = check_holds(x["zero_ghost_tracks"], x["both"])
        return (
            f"**{'holds' if holds else 'does not hold'}** ({x['zero_ghost_tracks']:.0%} of runs without a ghost "
            f"track, both persons tracked in {x['both']:.0%})"
        )

    cmd = (
        f"python scripts/seed001_through_wall.py --runs {args.runs}"
        + (f" --seed0 {args.seed0}" if args.seed0 else "")
        + (f" --set {' '.join(args.set)}" if args.set else "")
        + (f" --out {out}" if str(out) != "results/seed001" else "")
    )
    lines = [
        f"# Seed 001: through-wall tracking of two persons, ToA association ({n} seeded runs, seeds {seeds[0]}-"
        f"{seeds[-1]})",
        "",
        f"Command: `{cmd}`",
        "",
        f"Scenario `through-wall` on its signal path, {cfg.n_scans} scans of {cfg.sensing.scan_period_s} s; the "
        "chains on identical scans. A localized couple is a person's when both its ranges lie within "
        f"{ATTRIBUTION_M} m of that person's bistatic ranges, a cross ghost (the seed's ghost: the incorrect "
        "association of two persons' ToAs) when Rx1's lies near one person's and Rx2's near the other's, else a "
        "false-alarm couple; the walks' own cross ghosts: the persons' exact ranges crossed and intersected, "
        f"inside the room and farther than {GHOST_M} m from both (what a chain detecting every ToA exactly "
        f"would make without association). Position off the persons: a localized couple farther than {GHOST_M} m "
        "from both persons (any kind). Ghost track: a confirmed track whose median distance to the nearer person "
        f"exceeds {GATE_M} m; its origin: the kind of most of the localized couples within {GATE_M} m of it over "
        f"its life. False track: matched one-to-one (gate {GATE_M} m) to a person in fewer than half its "
        "confirmed scans (ghosts, duplicates, tracks held far off). Tracked: a confirmed track holds the person in >= "
        f"{TRACKED_FRACTION:.0%} of the scans. RMSE: median over runs of the held scans' track error to the body "
        "centre.",
        "",
        "| | " + " | ".join(TITLES[name] for name in CHAINS) + " | seed 001 |",
        "|" + " --- |" * (len(CHAINS) + 2),
        _row(
            "cross ghosts per run (seed's ghosts)",
            [f"{x['cross_ghosts_per_run']:.1f}" for x in aggs],
            f"~{SEED['ghosts']} ghost targets without association (two extra trajectories), none with it",
        ),
        _row(
            "the walks' own cross ghosts per run (exact ranges)",
            [f"{a['cross_geometric_per_run']:.1f}"] * len(aggs),
            "",
        ),
        _row(
            "false-alarm couples per scan",
            [f"{x['false_couples_per_scan']:.3f}" for x in aggs],
            "more than the ghosts, kept by the association",
        ),
        _row("persons' couples per scan", [f"{x['person_couples_per_scan']:.3f}" for x in aggs], ""),
        _row(
            f"positions off the persons (> {GHOST_M} m) per scan",
            [f"{x['ghosts_per_scan']:.3f}" for x in aggs],
            "",
        ),
        _row(f"person's position within {GHOST_M} m (scans)", [f"{x['hit']:.1%}" for x in aggs], ""),
        _row("runs with 0 ghost tracks", [f"{x['zero_ghost_tracks']:.0%}" for x in aggs], "(ghosts removed)"),
        _row("ghost tracks per run", [f"{x['ghost_tracks']:.2f}" for x in aggs], ""),
        _row(
            "ghost tracks per run fed by false-alarm couples / by persons' couples",
            [f"{x['ghost_tracks_false']:.2f} / {x['ghost_tracks_person']:.2f}" for x in aggs],
            "",
        ),
        _row("false tracks per run (one-to-one, gate)", [f"{x['false_tracks']:.2f}" for x in aggs], ""),
        _row(
            "runs with both persons tracked",
            [f"{x['both']:.0%}" for x in aggs],
            "both tracked, breaks where traces cross",
        ),
        _row("scans a person is held", [f"{x['coverage']:.1%}" for x in aggs], ""),
        _row("track RMSE [m] (median over runs)", [f"{x['rmse']:.3f}" for x in aggs], "(no number)"),
        "",
        "**Check** (with association: 0 ghost tracks in >= 90 % of runs and both persons tracked in >= 90 %): the "
        f"seed's chain, the scenario's default, {verdict(a)}; with the clutter map of still couples {verdict(d)}.",
        "",
        _clutter_map_note(cfg, dict(zip(CHAINS, aggs, strict=True))),
        "",
        f"Figures (run {seeds[0]}): radargrams.png, toa_association.png, positions_tracks.png. Per-chain numbers: "
        "summary.csv, per-run rows: runs.csv (neither committed).",
        "",
        _window_note(cfg),
    ]
    (out / "summary.md").write_text("\n".join(lines) + "\n")
    rec0 = next(r for r in runs if r["seed"] == seeds[0])
    _figures(out, traces(seeds[0], overrides), rec0)
    print("\n".join(lines))
