"""Schedulers: a small protocol and the open-loop and lookahead agents (SPEC.md agents/)."""

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
