"""Schedulers: a small protocol and the open-loop and lookahead agents (SPEC.md agents/)."""

from agents.schedulers import Fixed, Myopic, Random, RoundRobin, Scheduler

__all__ = ["Fixed", "Myopic", "Random", "RoundRobin", "Scheduler"]
