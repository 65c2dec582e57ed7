r"""Monte Carlo campaign: one environment x schemes x N seeded runs, paired by common random numbers.

The library behind ``uwb-env-evaluate`` (``uwb_env.agents.cli``; ``scripts/evaluate.py`` runs the same):

    uwb-env-evaluate --preset seed003 --runs 100 --out results/seed003
    uwb-env-evaluate --env uwb_env/UrbanWaveform-v3 --schemes myopic round-robin random fixed-0 --baseline myopic

A **scheme** is ``SCHEDULER[@TRACKER]``: the scheduler is one of ``uwb_env.agents.scheduler_names()`` (``myopic``,
``round-robin``, ``random``, ``fixed-K``, ``lookahead-D``), the tracker ``scenario`` (default: the scenario's
``tracker.kind``), ``open-loop`` (seed 003's baseline, one NCV UKF: ``uwb_env.config.open_loop_tracker``),
``open-loop-one-rx`` (the same on one receiver, below), either with ``:SIGMA`` (the NCV's white-acceleration std in
m/s^2; default that of the VS-IMM's NCV model, 0.5: the ablation's "VS-IMM removed"), or a tracker kind of
``uwb_env.tracking.registry``: ``imm-lmipda`` (seed 003's VS-IMM / LMIPDA), ``phd`` (seed 000's particle PHD),
``pf`` (seed 002's particle filter).

``open-loop-one-rx`` is seed 003's baseline as section V words it, "an open-loop system which does not support any
diversity modes": no waveform diversity (the scheduler: round-robin), no motion-model diversity (one NCV UKF) and
no spatial diversity (the abstract's mode 1, "coordinated multistatic radars"): the first transmitter-receiver pair
alone (``pairs = [[0, 0]]``, :data:`ONE_RECEIVER`). One receiver's range and range-rate cannot place a target, so that
receiver also measures the azimuth with its array (``sensing.measure_doa``), as in the ablation's one-receiver row.
Every scheme plays the same seeds ``seed0 .. seed0 + N - 1``; ``env.reset(seed)`` draws truth, clutter and noise
from named streams and the truth never depends on actions, so differences between schemes are paired.

Output folder:

    campaign.json               the campaign's definition; a resumed campaign must match it (runs may grow)
    runs/<scheme>/seed-<s>.csv  the per-scan record of one run, written atomically when it finishes
    .lock                       held while a campaign runs on the folder: a second one is refused (names the pid)
    runs/**/*.damaged           a run file found damaged on resume, moved aside (the run is played again)
    runs.csv                    per-run metrics (below), every scheme and seed
    summary.md                  per scheme mean [95 % t-interval]; paired differences against the baseline
    confirmed_tracks.png, position_rmse.png, model_probabilities.png   seed 003 Figs. 4-6, one curve per scheme

Runs whose file exists and is complete (:func:`read_record`) are not recomputed: an interrupted campaign resumes
where it stopped, and gives the same summary as an uninterrupted one (tested, after Ctrl-C, after SIGKILL and after
a damaged run file). Every file is written atomically under a unique temporary name
(:mod:`uwb_env.agents.storage`).

Interrupts: Ctrl-C (or SIGTERM to the command) terminates the workers at once, cancels the queued runs and writes
the summary of the seeds every scheme finished (``uwb_env.agents.summary.evaluate``). Workers die with the main
process however it dies: on Linux through ``prctl(PR_SET_PDEATHSIG, SIGKILL)`` set in the pool's initializer
(:func:`worker_init`), elsewhere through a thread polling the parent's pid. Only one campaign runs on a folder at
a time (an exclusive ``flock`` on ``<out>/.lock``).

Per-run metrics: ``rmse_m`` position RMSE of the confirmed tracks assigned to alive targets within the env's cover
gate (5 m), pooled over the run; ``ospa_m`` mean OSPA (cut-off 10 m, order 2); ``confirmed`` confirmed tracks per
scan; ``true_confirmed`` of them assigned to a target; ``false`` confirmed tracks per scan not assigned;
``trace_m2`` mean over scans with a confirmed track of the mean position-covariance trace (the reward's term; a
confirmed false track coasting through a shadow, where Pd ~ 0 and only the survival probability lowers its
existence, grows its covariance to hundreds of m^2 and dominates it in a few runs); ``target_trace_m2`` the same
over the confirmed tracks assigned to targets only; ``target_cost_m2`` mean over scans with an alive target of the
per-target cost: the covered targets' track traces and, for each missed target, the env's ``missed_target_penalty_m2``
(the reward's own price of a miss), divided by the alive targets. ``target_trace_m2`` is conditional on holding a
track, so a scheme that drops the hard targets lowers it; ``target_cost_m2`` charges the drop;
``energy_j`` transmitted energy of the run; ``return`` the sum of rewards.
"""

from __future__ import annotations

import ctypes
import dataclasses
import json
import math
import multiprocessing
import os
import pathlib
import re
import signal
import sys
import threading
import time
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import IO, Any

import numpy as np
from tqdm import tqdm

from uwb_env import scenarios
from uwb_env.agents.schedulers import check_scheduler_name, make_scheduler
from uwb_env.agents.storage import (
    FolderLock,
    atomic_write,
    atomic_write_text,
    move_aside,
    read_error,
    remove_stale_temporaries,
)
from uwb_env.config import TRACKER_KINDS, apply_overrides, open_loop_tracker
from uwb_env.envs import ENV_IDS, UWBSchedulingEnv
from uwb_env.envs.family import SceneFamilyEnv
from uwb_env.scenarios.families import get_family

TRACKERS = ("scenario", "open-loop", "open-loop-one-rx", *TRACKER_KINDS)
ONE_RECEIVER = {"pairs": [[0, 0]], "sensing.measure_doa": True}
"""The scenario overrides of ``open-loop-one-rx``: no spatial diversity (module docstring)."""
METRICS = {
    "rmse_m": "position RMSE [m]",
    "ospa_m": "OSPA [m]",
    "confirmed": "confirmed tracks / scan",
    "true_confirmed": "true confirmed tracks / scan",
    "false": "false tracks / scan",
    "trace_m2": "mean covariance trace [m^2]",
    "target_trace_m2": "covariance trace on targets [m^2]",
    "target_cost_m2": "trace on targets, missed at the penalty [m^2]",
    "energy_j": "energy / run [J]",
    "return": "return",
}
RECORD = ("scan", "alive", "confirmed", "true_confirmed", "false", "missed", "missed_penalty", "sq_error_sum", "ospa_m",
          "trace_m2", "target_trace_m2", "energy_j", "reward", "action")  # fmt: skip


# ------------------------------------------------------------------------------------------------- definition
@dataclasses.dataclass(frozen=True)
class Campaign:
    """What a campaign runs (``campaign.json``)."""

    env: str
    schemes: tuple[str, ...]
    baseline: str
    runs: int
    seed0: int = 0
    overrides: dict[str, Any] = dataclasses.field(default_factory=dict)
    env_kwargs: dict[str, Any] = dataclasses.field(default_factory=dict)  # e.g. include_lookahead for an RL agent
    title: str = ""
    reference: dict[str, str] = dataclasses.field(default_factory=dict)

    def __post_init__(self) -> None:
        check_types(self)
        if self.env not in ENV_IDS:
            raise ValueError(f"env={self.env!r}: must be one of {sorted(ENV_IDS)}")
        if self.runs < 2:
            raise ValueError(f"runs={self.runs}: must be >= 2 (a confidence interval needs two runs)")
        if self.seed0 < 0:
            raise ValueError(f"seed0={self.seed0}: must be >= 0 (episode seeds are non-negative integers)")
        if not self.schemes:
            raise ValueError("schemes=[]: give at least one scheme")
        if len(set(self.schemes)) != len(self.schemes):
            raise ValueError(f"schemes={list(self.schemes)}: a scheme is listed twice")
        for s in self.schemes:
            parse_scheme(s)
        if self.baseline not in self.schemes:
            raise ValueError(f"baseline={self.baseline!r}: must be one of the schemes {list(self.schemes)}")
        bad = set(self.reference) - set(METRICS)
        if bad:
            raise ValueError(f"reference metrics {sorted(bad)}: must be among {list(METRICS)}")

    def seeds(self) -> range:
        """The common random numbers: the same episode seeds for every scheme."""
        return range(self.seed0, self.seed0 + self.runs)

    def definition(self) -> dict[str, Any]:
        """Everything that fixes a run's result (``runs`` may grow on resume)."""
        out = {"env": self.env, "schemes": list(self.schemes), "seed0": self.seed0, "overrides": self.overrides}
        if self.env_kwargs:  # only when set, so campaigns written before the field existed still resume
            out["env_kwargs"] = self.env_kwargs
        return out


_TYPES = {"env": str, "schemes": tuple, "baseline": str, "runs": int, "seed0": int, "overrides": dict,
          "env_kwargs": dict, "title": str, "reference": dict}  # fmt: skip


def check_types(campaign: Campaign) -> None:
    """Raise ``ValueError`` naming the field whose value has the wrong type (a bool is not an int)."""
    for name, kind in _TYPES.items():
        value = getattr(campaign, name)
        if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
            raise ValueError(f"{name}={value!r}: must be of type {kind.__name__}")
    for s in campaign.schemes:
        if not isinstance(s, str):
            raise ValueError(f"schemes: {s!r} must be a string SCHEDULER[@TRACKER]")


def parse_scheme(scheme: str) -> tuple[str, str]:
    """``"SCHEDULER[@TRACKER]"`` -> (scheduler, tracker), both checked (``TRACKER`` may be ``open-loop:SIGMA``)."""
    scheduler, _, spec = scheme.partition("@")
    spec = spec or "scenario"
    name, colon, sigma = spec.partition(":")
    if colon:
        if not name.startswith("open-loop"):
            raise ValueError(f"scheme {scheme!r}: only an open-loop tracker takes ':SIGMA' (got {name!r})")
        open_loop_sigma(scheme, sigma)
    if name not in TRACKERS:
        raise ValueError(f"scheme {scheme!r}: tracker {spec!r} must be one of {TRACKERS}")
    try:
        check_scheduler_name(scheduler)  # raises with the allowed names
    except ValueError as e:
        raise ValueError(f"scheme {scheme!r}: {e}") from None
    return scheduler, spec


def open_loop_sigma(scheme: str, text: str) -> float:
    """The NCV UKF's white-acceleration std [m/s^2] of ``open-loop:SIGMA``, checked: a number in (0, 1000]."""
    try:
        sigma = float(text)
    except ValueError:
        sigma = math.nan
    if not 0.0 < sigma <= 1000.0:
        raise ValueError(f"scheme {scheme!r}: open-loop SIGMA {text!r} must be a number in (0, 1000] m/s^2")
    return sigma


def make_env(campaign: Campaign, spec: str) -> UWBSchedulingEnv:
    """The campaign's environment (the registered id's arguments, the overrides, the scheme's tracker).

    A scene-family id (``uwb_env.envs.FAMILY_ENV_IDS``) gives a ``SceneFamilyEnv``: the overrides and the scheme's
    tracker apply to every variant it draws (the open-loop tracker as overrides of the tracker's model fields).
    ``open-loop-one-rx`` adds :data:`ONE_RECEIVER` to the overrides (refused if they set those keys themselves);
    ``open-loop:SIGMA`` (either open loop) sets the NCV UKF's white-acceleration std to SIGMA m/s^2.
    """
    kwargs = {**ENV_IDS[campaign.env], **campaign.env_kwargs}
    overrides = dict(campaign.overrides)
    tracker, colon, sigma_text = spec.partition(":")
    ncv = {"accel_noise_std_mps2": open_loop_sigma(spec, sigma_text)} if colon else {}
    if tracker == "open-loop-one-rx":
        clash = sorted(set(overrides) & set(ONE_RECEIVER))
        if clash:
            raise ValueError(
                f"scheme tracker 'open-loop-one-rx' sets {clash} itself ({ONE_RECEIVER}): drop them from the overrides"
            )
        overrides.update(ONE_RECEIVER)
        tracker = "open-loop"
    if "family" in kwargs:
        if tracker == "open-loop":
            single = open_loop_tracker(scenarios.get(get_family(kwargs["family"]).scenario).tracker, **ncv)
            fields = ("models", "transition", "default_models", "model_set_windows")
            overrides.update({f"tracker.{f}": getattr(single, f) for f in fields})
        elif tracker in TRACKER_KINDS:
            kwargs["tracker"] = tracker
        return SceneFamilyEnv(**kwargs, **overrides)  # type: ignore[return-value]
    cfg = apply_overrides(scenarios.get(kwargs.pop("scenario")), overrides)
    if tracker == "open-loop":
        cfg = dataclasses.replace(cfg, tracker=open_loop_tracker(cfg.tracker, **ncv))
    elif tracker in TRACKER_KINDS:
        cfg = dataclasses.replace(cfg, tracker=dataclasses.replace(cfg.tracker, kind=tracker))
    return UWBSchedulingEnv(cfg, **kwargs)


# ------------------------------------------------------------------------------------------------------ runs
def play(env: UWBSchedulingEnv, scheduler: Any, seed: int) -> tuple[np.ndarray, tuple[str, ...]]:
    """One episode: the per-scan record ``(n_scans, len(RECORD) + r)`` and its column names."""
    obs, _ = env.reset(seed=seed)
    scheduler.reset(seed)
    rows, done = [], False
    while not done:
        action = scheduler.act(obs, env)
        obs, reward, terminated, truncated, info = env.step(action)
        done = terminated or truncated
        e = info["position_errors_m"]
        conf = info["confirmed_tracks"]
        rows.append(
            [
                info["scan_index"],
                conf - info["false_tracks"] + info["missed_targets"],
                conf,
                conf - info["false_tracks"],
                info["false_tracks"],
                info["missed_targets"],
                info["missed_penalty"],
                float(e @ e),
                info["ospa_m"],
                info["covariance_trace"] if conf else math.nan,
                info["target_covariance_trace"] if conf > info["false_tracks"] else math.nan,
                info["energy_j"],
                reward,
                action,
                *info["model_probabilities"],
            ]
        )
    names = RECORD + tuple(f"mu:{m}" for m in env.sim.tracker.model_names)
    return np.array(rows, dtype=float), names


_ENVS: dict[str, UWBSchedulingEnv] = {}


def campaign_env(campaign: Campaign, tracker: str) -> UWBSchedulingEnv:
    """The campaign's env for ``tracker``, built once per process (building it compiles nothing twice)."""
    key = json.dumps([campaign.env, campaign.overrides, campaign.env_kwargs, tracker], sort_keys=True)
    if key not in _ENVS:
        _ENVS[key] = make_env(campaign, tracker)
    return _ENVS[key]


@dataclasses.dataclass(frozen=True)
class Layout:
    """What a complete run file of a scheme holds: ``n_scans`` rows under the header ``names``."""

    n_scans: int
    names: tuple[str, ...]


def preflight(campaign: Campaign) -> dict[str, Layout]:
    """Build every env the campaign plays and check every scheme against it, before anything is written.

    Raises ``ValueError`` naming the field (a bad ``--set`` override or ``--env-kwarg``, a ``fixed-K`` outside the
    action space); returns each scheme's run-file :class:`Layout`.
    """
    layouts = {}
    for scheme in campaign.schemes:
        scheduler, tracker = parse_scheme(scheme)
        try:
            env = campaign_env(campaign, tracker)
        except (TypeError, ValueError, KeyError) as e:
            why = e.args[0] if isinstance(e, KeyError) and e.args else e  # a KeyError's str() adds quotes
            raise ValueError(
                f"env {campaign.env} with overrides {campaign.overrides} and env_kwargs {campaign.env_kwargs}: {why}"
            ) from e
        n = getattr(env.action_space, "n", None)  # Discrete spaces; fixed-K is an action index
        if (m := re.fullmatch(r"fixed-(\d+)", scheduler)) and n is not None:
            if int(m.group(1)) >= n:
                raise ValueError(f"scheme {scheme!r}: action {m.group(1)} must be in 0..{n - 1} on {campaign.env}")
        layouts[scheme] = Layout(int(env.cfg.n_scans), RECORD + tuple(f"mu:{m}" for m in env.sim.tracker.model_names))
    return layouts


def play_scheme(campaign: Campaign, scheme: str, seed: int) -> tuple[np.ndarray, tuple[str, ...]]:
    """Play one (scheme, seed) of the campaign: its per-scan record and column names (:func:`play`)."""
    scheduler, tracker = parse_scheme(scheme)
    return play(campaign_env(campaign, tracker), make_scheduler(scheduler), seed)


def write_record(path: pathlib.Path, record: np.ndarray, names: Sequence[str]) -> pathlib.Path:
    """Write one run's record atomically to ``path`` (see :mod:`uwb_env.agents.storage`); every backend's format."""

    def write(f: IO[bytes]) -> None:
        f.write((",".join(names) + "\n").encode())
        np.savetxt(f, record, delimiter=",", fmt="%.17g")

    atomic_write(path, write)
    return path


def run_one(campaign: Campaign, scheme: str, seed: int, path: pathlib.Path) -> pathlib.Path:
    """Play one (scheme, seed) and write its record atomically to ``path``."""
    return write_record(path, *play_scheme(campaign, scheme, seed))


def run_path(out: pathlib.Path, scheme: str, seed: int) -> pathlib.Path:
    """Where a run's record lives."""
    return out / "runs" / re.sub(r"[^A-Za-z0-9._-]", "_", scheme.replace("@", "__")) / f"seed-{seed}.csv"


# ------------------------------------------------------------------------------------------- run files on disk
NAN_ALLOWED = ("trace_m2", "target_trace_m2")  # nan on scans without a confirmed track (on a target)


class DamagedRun(ValueError):
    """A run file that is not a complete record of one run (the message names the file and what is wrong)."""


def read_record(path: pathlib.Path, layout: Layout) -> dict[str, np.ndarray]:
    """A run file as column name -> ``(n_scans,)``, checked: header, row count, every row complete, finite values.

    The header is the layout's (:data:`RECORD` and one ``mu:<model>`` column per tracker model); every value is
    finite except those of :data:`NAN_ALLOWED`; ``scan`` counts 1..n_scans. Raises :class:`DamagedRun` saying
    what is wrong.
    """
    n_scans = layout.n_scans
    try:
        raw = path.read_bytes()
        text = raw.decode("ascii")
    except (OSError, UnicodeDecodeError) as e:
        raise DamagedRun(f"{path}: unreadable ({e})") from None
    lines = text.split("\n")
    names = lines[0].split(",")
    if tuple(names) != layout.names:
        raise DamagedRun(f"{path}: header {lines[0][:60]!r}... must be {','.join(layout.names)}")
    if not text.endswith("\n"):
        raise DamagedRun(f"{path}: the last line is cut (no end of line)")
    rows = lines[1:-1]
    if len(rows) != n_scans:
        raise DamagedRun(f"{path}: {len(rows)} scans, a complete run has {n_scans}")
    try:
        data = np.array([[float(v) for v in row.split(",")] for row in rows if row.count(",") == len(names) - 1])
    except ValueError as e:
        raise DamagedRun(f"{path}: a value is not a number ({e})") from None
    if data.shape != (n_scans, len(names)):
        raise DamagedRun(f"{path}: a row does not have the header's {len(names)} columns")
    finite = np.isfinite(data)
    for j, n in enumerate(names):
        if n not in NAN_ALLOWED and not finite[:, j].all():
            raise DamagedRun(f"{path}: column {n!r} has a non-finite value at scan {int(np.argmin(finite[:, j])) + 1}")
    if not np.array_equal(data[:, 0], np.arange(1, n_scans + 1)):
        raise DamagedRun(f"{path}: column 'scan' must count 1..{n_scans}")
    return {n: data[:, j] for j, n in enumerate(names)}


def missing_runs(campaign: Campaign, out: pathlib.Path, layouts: dict[str, Layout]) -> list[tuple[str, int]]:
    """The (scheme, seed) pairs to play: no run file, or a damaged one (moved aside to ``*.damaged``, named)."""
    jobs = []
    for s in campaign.schemes:
        for seed in campaign.seeds():
            path = run_path(out, s, seed)
            if path.exists():
                try:
                    read_record(path, layouts[s])
                    continue
                except DamagedRun as e:
                    move_aside(path, str(e).removeprefix(f"{path}: "))
            jobs.append((s, seed))
    return jobs


def finished_seeds(campaign: Campaign, out: pathlib.Path, layouts: dict[str, Layout]) -> list[int]:
    """The seeds every scheme has a complete run of (the paired runs a summary can use)."""

    def ok(s: str, seed: int) -> bool:
        try:
            read_record(run_path(out, s, seed), layouts[s])
        except (DamagedRun, FileNotFoundError):
            return False
        return True

    return [seed for seed in campaign.seeds() if all(ok(s, seed) for s in campaign.schemes)]


def load_runs(
    campaign: Campaign, out: pathlib.Path, seeds: Sequence[int] | None = None
) -> dict[str, list[dict[str, np.ndarray]]]:
    """Every run's checked record (:func:`read_record`), per scheme in seed order."""
    layouts = preflight(campaign)
    seeds = campaign.seeds() if seeds is None else seeds
    return {s: [read_record(run_path(out, s, seed), layouts[s]) for seed in seeds] for s in campaign.schemes}


# ------------------------------------------------------------------------------------------------ the runner
def write_definition(campaign: Campaign, out: pathlib.Path) -> None:
    """Check ``campaign.json`` against this campaign (a resume must match it), then write it atomically."""
    meta = out / "campaign.json"
    if meta.exists():
        with read_error(meta, "a campaign definition (JSON object; delete it or use another --out)"):
            old = json.loads(meta.read_text())
            if not isinstance(old, dict):
                raise TypeError(f"a JSON {type(old).__name__}, not an object")
        for field, value in campaign.definition().items():
            if old.get(field) != value:
                raise ValueError(
                    f"{meta}: field {field!r} is {old.get(field)!r}, this campaign has {value!r}; "
                    "use another --out or the same definition to resume"
                )
    text = json.dumps({**dataclasses.asdict(campaign), "schemes": list(campaign.schemes)}, indent=2)
    atomic_write_text(meta, text)


def check_workers(workers: object) -> int:
    """``workers`` as a positive int, or ``ValueError`` naming it."""
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers={workers!r}: must be an integer >= 1")
    return workers


BACKENDS = ("local", "ray")
"""Where the runs play: ``local`` (a process pool on this machine, the default) or ``ray`` (one Ray task per run,
:mod:`uwb_env.agents.ray_backend`; needs ``pip install -e ".[ray]"``)."""


def run_campaign(
    campaign: Campaign,
    out: pathlib.Path,
    workers: int = 1,
    progress: bool = True,
    backend: str = "local",
    address: str | None = None,
) -> None:
    """Play every (scheme, seed) whose record is missing or damaged, over ``workers`` processes (or on Ray).

    Order: every argument is checked and every env built (:func:`preflight`) before the folder is touched; then the
    folder is locked (:class:`~uwb_env.agents.storage.FolderLock`), ``campaign.json`` checked and written, the
    run files checked (:func:`missing_runs`), and the missing runs played. Each run's file is written atomically
    when it finishes. ``KeyboardInterrupt`` (Ctrl-C) terminates the workers at once and propagates; the finished
    runs stay on disk and a re-run resumes from them.
    """
    check_workers(workers)
    check_backend(backend, address)
    layouts = preflight(campaign)
    with FolderLock(out, "campaign"):
        remove_stale_temporaries([out, *(out / "runs").glob("*/")])  # the folders a campaign writes in
        write_definition(campaign, out)
        jobs = missing_runs(campaign, out, layouts)
        with tqdm(total=len(jobs), desc="runs", unit="run", disable=not progress) as bar:
            if backend == "ray":
                from uwb_env.agents.ray_backend import run_on_ray

                run_on_ray(campaign, out, jobs, bar, workers, address)
            elif workers == 1 or len(jobs) <= 1:
                for s, seed in jobs:
                    run_one(campaign, s, seed, run_path(out, s, seed))
                    bar.update()
            else:
                _run_parallel(campaign, out, jobs, workers, bar)


def check_backend(backend: object, address: object) -> None:
    """Validate ``backend`` (one of :data:`BACKENDS`) and ``address`` (a string, only with ``ray``)."""
    if backend not in BACKENDS:
        raise ValueError(f"backend={backend!r}: must be one of {BACKENDS}")
    if address is not None and (backend != "ray" or not isinstance(address, str) or not address):
        raise ValueError(
            f"address={address!r}: a Ray cluster address (e.g. 'ray://host:10001' or 'auto'), with backend 'ray' only"
        )


def _run_parallel(campaign: Campaign, out: pathlib.Path, jobs: list[tuple[str, int]], workers: int, bar) -> None:
    """The jobs over a process pool whose workers die with this process and stop at once on an interrupt.

    The first run plays here: it compiles (or loads) the numba kernels once, and the forked workers inherit them
    instead of compiling side by side on a fresh install. A run of a trained RL agent never plays here and, when
    there is one, workers start from a fork server: torch's thread pools do not survive a fork.
    """
    first = next((i for i, (s, _) in enumerate(jobs) if not s.startswith("rl:")), None)
    if first is not None:
        s, seed = jobs.pop(first)
        run_one(campaign, s, seed, run_path(out, s, seed))
        bar.update()
    rl = any(s.startswith("rl:") for s, _ in jobs)
    ctx = multiprocessing.get_context("forkserver" if rl else "fork")
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=worker_init)
    try:
        futures = [pool.submit(run_one, campaign, s, seed, run_path(out, s, seed)) for s, seed in jobs]
        for f in as_completed(futures):
            f.result()  # re-raise a worker's error here
            bar.update()
    except BaseException:
        stop_pool(pool)
        raise
    pool.shutdown()


def stop_pool(pool: ProcessPoolExecutor) -> None:
    """Cancel the queued runs and terminate the running ones now (their unfinished files never appear)."""
    procs = list((getattr(pool, "_processes", None) or {}).values())  # no public handle before Python 3.14
    pool.shutdown(wait=False, cancel_futures=True)
    for p in procs:
        p.terminate()
    for p in procs:
        p.join(timeout=5)
        if p.is_alive():
            p.kill()
            p.join()


PR_SET_PDEATHSIG = 1  # <linux/prctl.h>


def worker_init() -> None:
    """A campaign worker's set-up: die with the parent, leave Ctrl-C to the parent, drop the inherited lock.

    On Linux the kernel kills the worker when its parent dies (``prctl(PR_SET_PDEATHSIG, SIGKILL)`` through
    ctypes; checked right after, in case the parent died before the call). Elsewhere a daemon thread polls the
    parent's pid every second and exits the worker when it changes. SIGINT is ignored: the terminal sends Ctrl-C
    to the whole process group, and the parent stops the workers itself (:func:`stop_pool`).
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    FolderLock.close_inherited()
    parent = os.getppid()
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) == 0:
            if os.getppid() != parent:
                os._exit(1)
            return
    threading.Thread(target=_watch_parent, args=(parent,), daemon=True).start()


def _watch_parent(parent: int) -> None:
    while os.getppid() == parent:
        time.sleep(1.0)
    os._exit(1)
