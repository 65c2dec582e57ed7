"""Schedulers: ``reset(seed)`` then ``act(obs, env) -> action`` every scan.

RoundRobin, Fixed and Random are seed 003's open-loop baselines; Myopic is its closed-loop scheduler, the argmin of
the environment's one-step lookahead costs (seed 003 eq. 7); MultiStepLookahead searches sequences of d plans on
the expected covariance recursion (the env's ``sequence_costs``). Ties (no track yet: every cost is 0) go
to the plan that transmits the most energy -- the best detection for search -- then to the lowest action index.
``make_scheduler("fixed-2")`` builds one from its name (the campaign's schemes).

Every scheduler chooses a plan (an index into the env's ``plans``, over which ``lookahead_costs()`` and the masks
are given) and returns the env's action for it (``UWBSchedulingEnv.action_of_plan``): the index itself for a
``Discrete`` space, the per-transmitter waveforms ``(T,)`` for the ``MultiDiscrete`` space of per-tx plans
(``UrbanDistributed-v0``). ``fixed-K`` plays plan K (for per-tx, K = w_1 W + w_2 ...: first transmitter slowest).
"""

from __future__ import annotations

import pathlib
import re
from typing import Any, Protocol

import gymnasium as gym
import numpy as np

from uwb_env.ceiling import Ceiling
from uwb_env.lookahead import check_search


class Scheduler(Protocol):
    """What an agent is: ``reset(seed)`` at every episode, ``act(obs, env)`` every scan."""

    name: str

    def reset(self, seed: int | None = None) -> None: ...  # noqa: D102

    def act(self, obs: Any, env: gym.Env) -> Any: ...  # noqa: D102


def _n_actions(env: gym.Env) -> int:
    """The number of plans a scheduler chooses from: ``Discrete(n)``'s n, or the env's plans (``MultiDiscrete``)."""
    space = env.action_space
    if isinstance(space, gym.spaces.Discrete):
        return int(space.n)
    plans = getattr(env.unwrapped, "plans", None)
    if isinstance(space, gym.spaces.MultiDiscrete) and plans is not None and hasattr(env.unwrapped, "action_of_plan"):
        return len(plans)
    raise TypeError(
        f"action_space {space}: these schedulers need a Discrete action space or a MultiDiscrete one whose env "
        "enumerates its plans (UWBSchedulingEnv with action_kind='per-tx')"
    )


def plan_masks(env: gym.Env) -> np.ndarray:
    """``(n_plans,)`` the valid plans: ``plan_masks()`` where the env has it, else its (Discrete) ``action_masks()``."""
    e = env.unwrapped
    return e.plan_masks() if hasattr(e, "plan_masks") else e.action_masks()


def to_action(plan: int, env: gym.Env) -> Any:
    """The env's action for plan index ``plan`` (``action_of_plan``: the index, or per-transmitter waveforms)."""
    e = env.unwrapped
    return e.action_of_plan(int(plan)) if hasattr(e, "action_of_plan") else int(plan)


def best_plan(costs: np.ndarray, env: gym.Env) -> int:
    """The valid plan of least cost; ties to the most transmitted energy, then the lowest index."""
    e = env.unwrapped
    costs = np.asarray(costs, dtype=float)
    mask = plan_masks(env)
    if not mask.all():
        costs = np.where(mask, costs, np.inf)
    tied = np.flatnonzero(costs == costs.min())
    return int(tied[0]) if tied.size == 1 else int(tied[np.argmax(e.plan_energy_j[tied])])


def best_action(costs: np.ndarray, env: gym.Env) -> Any:
    """The env's action for :func:`best_plan` (an int for ``Discrete``, ``(T,)`` waveforms for ``MultiDiscrete``)."""
    return to_action(best_plan(costs, env), env)


class RoundRobin:
    """Cycles through the valid actions in order, 0, 1, ..., n - 1, 0, ... when all are (seed 003's open loop).

    The valid actions are those of ``action_masks()``: a plan that needs a receiver out of service or an unavailable
    waveform is skipped (the env refuses it).
    """

    name = "round-robin"

    def reset(self, seed: int | None = None) -> None:
        """Start again at the first valid action."""
        self._k = 0

    def act(self, obs: Any, env: gym.Env) -> Any:
        """The next valid plan of the cycle, as the env's action."""
        _n_actions(env)  # a Discrete space or enumerated plans, checked
        valid = np.flatnonzero(plan_masks(env))
        self._k += 1
        return to_action(int(valid[(self._k - 1) % valid.size]), env)


class Fixed:
    """Always plan ``action`` (the env's action for it: ``to_action``)."""

    def __init__(self, action: int) -> None:
        if action < 0:
            raise ValueError(f"action={action}: must be >= 0")
        self.action = action
        self.name = f"fixed-{action}"

    def reset(self, seed: int | None = None) -> None:
        """Nothing to reset."""

    def act(self, obs: Any, env: gym.Env) -> Any:
        """The fixed plan's action (checked against the env)."""
        n = _n_actions(env)
        if self.action >= n:
            raise ValueError(f"Fixed action={self.action}: the env has {n} actions")
        return to_action(self.action, env)


class Random:
    """Uniform over the valid actions (``action_masks()``), from its own seeded generator."""

    name = "random"

    def __init__(self) -> None:
        self._rng = np.random.default_rng()

    def reset(self, seed: int | None = None) -> None:
        """Reseed the generator."""
        self._rng = np.random.default_rng(seed)

    def act(self, obs: Any, env: gym.Env) -> Any:
        """A uniform draw over the valid plans (for per-tx: independent uniform waveforms over each one's valid)."""
        mask = plan_masks(env)
        return to_action(int(self._rng.choice(np.flatnonzero(mask))), env)


class Myopic:
    """Seed 003 eq. 7: the action with the smallest expected covariance trace after the next scan."""

    name = "myopic"

    def reset(self, seed: int | None = None) -> None:
        """Nothing to reset."""

    def act(self, obs: Any, env: gym.Env) -> Any:
        """Argmin over the valid actions of ``env.unwrapped.lookahead_costs()``."""
        return best_action(env.unwrapped.lookahead_costs(), env)


class CommonWaveformMyopic:
    """Seed 003 eq. 7 over the plans whose transmitters all send one waveform (the seed's single-waveform network).

    The baseline of distributed transmitters (``action_kind="per-tx"``): the myopic scheduler when the network must
    send a common waveform, so the value of choosing per transmitter is the gap to ``Myopic`` over every joint plan.
    On the other action kinds every plan sends one waveform and it is ``Myopic``.
    """

    name = "myopic-common"

    def reset(self, seed: int | None = None) -> None:
        """Nothing to reset."""

    def act(self, obs: Any, env: gym.Env) -> Any:
        """Argmin of ``lookahead_costs()`` over the valid plans with one waveform for every transmitter."""
        e = env.unwrapped
        common = np.array([bool((p.waveform == p.waveform[0]).all()) for p in e.plans])
        if not (common & plan_masks(env)).any():
            raise ValueError("myopic-common: no valid plan sends one waveform from every transmitter (action_masks())")
        return best_action(np.where(common, e.lookahead_costs(), np.inf), env)


class DetectionConstrainedMyopic:
    """Seed 003's eq. 7 under a detection constraint, and the finest-ranging plan for search.

    With confirmed tracks: the plan of least expected trace (``Myopic``) among those whose expected Pd, averaged over
    the plan's pairs, is at least ``min_pd`` for every confirmed track (``env.detection_probabilities()``); when
    none is, the plan whose weakest track's Pd is highest. Without a confirmed track (search and confirmation): the
    plan whose detections bring the most range information (``env.search_information()``), which sets the
    two-ellipse initiation's accuracy.

    Why: the expected trace of one scan weighs a missed detection as one scan of prediction, but a track that keeps
    missing is deleted and its target lost (the reward's missed-target penalty) -- a loss one scan cannot see. With
    waveforms that trade detection for accuracy (``urban-intersection-wideband``: range migration of a 160 MHz chirp
    on fast vehicles) the plain myopic scheduler takes the accurate waveform until it loses the track, and over
    tentative tracks (mostly clutter) it takes the most detectable one, initiating tracks from coarse ranges.

    Args: min_pd in [0, 1].
    """

    def __init__(self, min_pd: float = 0.5) -> None:
        if not 0.0 <= min_pd <= 1.0:
            raise ValueError(f"min_pd={min_pd}: must be in [0, 1]")
        self.min_pd = min_pd
        self.name = "myopic-pd" if min_pd == 0.5 else f"myopic-pd{min_pd:g}"

    def reset(self, seed: int | None = None) -> None:
        """Nothing to reset."""

    def act(self, obs: Any, env: gym.Env) -> Any:
        """The constrained argmin (class docstring) over the valid actions."""
        e = env.unwrapped
        pd = e.detection_probabilities()
        if pd is None:
            return best_action(-e.search_information(), env)
        used = pd > 0.0
        weakest = (pd.sum(axis=2) / np.maximum(used.sum(axis=2), 1)).min(axis=1)  # (A,) mean over the plan's pairs
        ok = weakest >= self.min_pd
        if not (ok & plan_masks(env)).any():
            return best_action(-weakest, env)
        return best_action(np.where(ok, e.lookahead_costs(), np.inf), env)


class MultiStepLookahead:
    """Depth-d lookahead: the first plan of the cheapest d-scan sequence (beam-pruned; depth 1 is Myopic).

    Args: depth d >= 1; beam: partial sequences kept after every scan (``None``: all); discount gamma in (0, 1].
    """

    def __init__(self, depth: int = 3, beam: int | None = 4, discount: float = 1.0) -> None:
        check_search(depth, beam, discount)
        self.depth, self.beam, self.discount = depth, beam, discount
        self.name = f"lookahead-{depth}"

    def reset(self, seed: int | None = None) -> None:
        """Nothing to reset."""

    def costs(self, env: gym.Env) -> np.ndarray:
        """``(A,)`` the cheapest d-scan cost of the sequences starting with each action (``inf``: pruned)."""
        return env.unwrapped.sequence_costs(self.depth, self.beam, self.discount)

    def act(self, obs: Any, env: gym.Env) -> Any:
        """Argmin over the valid actions of :meth:`costs`."""
        return best_action(self.costs(env), env)


_NAMED = {
    "myopic": Myopic,
    "myopic-pd": DetectionConstrainedMyopic,
    "myopic-common": CommonWaveformMyopic,
    "round-robin": RoundRobin,
    "random": Random,
}


def scheduler_names() -> list[str]:
    """The names ``make_scheduler`` accepts."""
    return [*_NAMED, "myopic-pdP", "fixed-K", "lookahead-D", "ceiling-H", "rl:PATH", "rllib:PATH"]


def check_scheduler_name(name: str) -> None:
    """Raise ``ValueError`` unless ``make_scheduler(name)`` can build it (``rl:`` / ``rllib:`` runs: on disk only)."""
    if name.startswith("rllib:"):
        run = pathlib.Path(name[6:])
        if not (run / "run.yaml").is_file() or not ((run / "policy").is_dir() or (run / "checkpoints").is_dir()):
            raise ValueError(f"scheduler={name!r}: {str(run)!r} is not a trained RLlib run (run.yaml and policy/)")
        return
    if name.startswith("rl:"):
        path = pathlib.Path(name[3:])
        run = path if path.is_dir() else path.parent
        if not (run / "run.yaml").is_file() or not ((path / "model.zip") if path.is_dir() else path).is_file():
            raise ValueError(f"scheduler={name!r}: {str(path)!r} is not a trained run (run.yaml and model.zip)")
        return
    make_scheduler(name)


def make_scheduler(name: str) -> Scheduler:
    """A scheduler from its name.

    ``myopic``, ``myopic-pd`` / ``myopic-pdP`` (minimum Pd P), ``myopic-common`` (one waveform for every
    transmitter), ``round-robin``, ``random``, ``fixed-K`` (action K),
    ``lookahead-D``, ``ceiling-H`` (clairvoyant: the optimal H-scan schedule on the truth's expected covariance
    recursion, receding horizon, ``uwb_env.ceiling.Ceiling``; a reference, not a causal scheduler),
    ``rl:PATH`` (a run directory of ``scripts/train.py`` or its model zip; needs the ``rl`` extra),
    ``rllib:PATH`` (a run directory of ``uwb-env-train --engine rllib``; needs the ``ray`` extra).
    """
    if name.startswith("rllib:"):
        from uwb_env.agents.rl.rllib_engine import load_rllib_scheduler  # ray and torch only when asked for

        return load_rllib_scheduler(name[6:])
    if name.startswith("rl:"):
        from uwb_env.agents.rl.training import load_scheduler  # stable-baselines3 and torch only when asked for

        return load_scheduler(name[3:])
    if name in _NAMED:
        return _NAMED[name]()
    if m := re.fullmatch(r"myopic-pd(0(?:\.\d+)?|1(?:\.0+)?)", name):
        return DetectionConstrainedMyopic(float(m.group(1)))
    if m := re.fullmatch(r"fixed-(\d+)", name):
        return Fixed(int(m.group(1)))
    if m := re.fullmatch(r"lookahead-(\d+)", name):
        return MultiStepLookahead(int(m.group(1)))
    if m := re.fullmatch(r"ceiling-(\d+)", name):
        return Ceiling(int(m.group(1)))
    raise ValueError(f"scheduler={name!r}: must be one of {scheduler_names()}")
