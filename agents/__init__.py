"""Schedulers and the campaign library that plays them, installed as ``uwb_env.agents`` (from the top-level agents/).

Installed under ``uwb_env`` (``package-dir`` in pyproject.toml) so that a user's own ``agents`` package cannot shadow
it. Modules:

* :mod:`~uwb_env.agents.schedulers`: the scheduler protocol; round-robin, fixed, random, myopic, multi-step lookahead;
* :mod:`~uwb_env.agents.campaign`: paired Monte Carlo runs on a process pool, run records, resume;
* :mod:`~uwb_env.agents.summary`: per-run metrics, paired statistics, ``summary.md``, plots;
* :mod:`~uwb_env.agents.storage`: atomic writes, the folder lock, damaged files moved aside;
* :mod:`~uwb_env.agents.presets`: named campaigns; :mod:`~uwb_env.agents.cli`: ``uwb-env-evaluate`` and
  ``uwb-env-train``;
* :mod:`~uwb_env.agents.rl`: stable-baselines3 training and trained-policy schedulers (imports torch; only on use);
* :mod:`~uwb_env.agents.studies`: calibration reports and figures that ``scripts/`` runs.

Only the schedulers are imported here; the rest (and torch) load when used.
"""

from uwb_env.agents.schedulers import (
    DetectionConstrainedMyopic,
    Fixed,
    MultiStepLookahead,
    Myopic,
    Random,
    RoundRobin,
    Scheduler,
    check_scheduler_name,
    make_scheduler,
    scheduler_names,
)

__all__ = [
    "DetectionConstrainedMyopic",
    "Fixed",
    "MultiStepLookahead",
    "Myopic",
    "Random",
    "RoundRobin",
    "Scheduler",
    "check_scheduler_name",
    "make_scheduler",
    "scheduler_names",
]
