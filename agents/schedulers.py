"""Schedulers: ``reset(seed)`` then ``act(obs, env) -> action`` every scan.

RoundRobin, Fixed and Random are seed 003's open-loop baselines; Myopic is its closed-loop scheduler, the argmin of
the environment's one-step lookahead costs (seed 003 eq. 7); MultiStepLookahead searches sequences of d plans on
the expected covariance recursion (the env's ``sequence_costs``). Ties (no track yet: every cost is 0) go
to the plan that transmits the most energy -- the best detection for search -- then to the lowest action index.
``make_scheduler("fixed-2")`` builds one from its name (the campaign's schemes).
"""

from __future__ import annotations

import pathlib
import re
from typing import Any, Protocol

import gymnasium as gym
import numpy as np

from uwb_env.lookahead import check_search


class Scheduler(Protocol):
    """What an agent is: ``reset(seed)`` at every episode, ``act(obs, env)`` every scan."""

    name: str

    def reset(self, seed: int | None = None) -> None: ...  # noqa: D102

    def act(self, obs: Any, env: gym.Env) -> int: ...  # noqa: D102


def _n_actions(env: gym.Env) -> int:
    space = env.action_space
    if not isinstance(space, gym.spaces.Discrete):
        raise TypeError(f"action_space {space}: these schedulers need a Discrete action space")
    return int(space.n)


def best_action(costs: np.ndarray, env: gym.Env) -> int:
    """The valid action of least cost; ties to the most transmitted energy, then the lowest index."""
    e = env.unwrapped
    costs = np.asarray(costs, dtype=float)
    mask = e.action_masks()
    if not mask.all():
        costs = np.where(mask, costs, np.inf)
    tied = np.flatnonzero(costs == costs.min())
    return int(tied[0]) if tied.size == 1 else int(tied[np.argmax(e.plan_energy_j[tied])])


class RoundRobin:
    """Cycles through the actions 0, 1, ..., n - 1, 0, ... (seed 003's open loop)."""

    name = "round-robin"

    def reset(self, seed: int | None = None) -> None:
        """Start again at action 0."""
        self._k = 0

    def act(self, obs: Any, env: gym.Env) -> int:
        """The next action of the cycle."""
        a = self._k % _n_actions(env)
        self._k += 1
        return a


class Fixed:
    """Always ``action``."""

    def __init__(self, action: int) -> None:
        if action < 0:
            raise ValueError(f"action={action}: must be >= 0")
        self.action = action
        self.name = f"fixed-{action}"

    def reset(self, seed: int | None = None) -> None:
        """Nothing to reset."""

    def act(self, obs: Any, env: gym.Env) -> int:
        """The fixed action (checked against the env)."""
        n = _n_actions(env)
        if self.action >= n:
            raise ValueError(f"Fixed action={self.action}: the env has {n} actions")
        return self.action


class Random:
    """Uniform over the valid actions (``action_masks()``), from its own seeded generator."""

    name = "random"

    def __init__(self) -> None:
        self._rng = np.random.default_rng()

    def reset(self, seed: int | None = None) -> None:
        """Reseed the generator."""
        self._rng = np.random.default_rng(seed)

    def act(self, obs: Any, env: gym.Env) -> int:
        """A uniform draw over the valid actions."""
        mask = env.unwrapped.action_masks()
        return int(self._rng.choice(np.flatnonzero(mask)))


class Myopic:
    """Seed 003 eq. 7: the action with the smallest expected covariance trace after the next scan."""

    name = "myopic"

    def reset(self, seed: int | None = None) -> None:
        """Nothing to reset."""

    def act(self, obs: Any, env: gym.Env) -> int:
        """Argmin over the valid actions of ``env.unwrapped.lookahead_costs()``."""
        return best_action(env.unwrapped.lookahead_costs(), env)


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

    def act(self, obs: Any, env: gym.Env) -> int:
        """Argmin over the valid actions of :meth:`costs`."""
        return best_action(self.costs(env), env)


_NAMED = {"myopic": Myopic, "round-robin": RoundRobin, "random": Random}


def scheduler_names() -> list[str]:
    """The names ``make_scheduler`` accepts."""
    return [*_NAMED, "fixed-K", "lookahead-D", "rl:PATH"]


def check_scheduler_name(name: str) -> None:
    """Raise ``ValueError`` unless ``make_scheduler(name)`` can build it (an ``rl:`` run is checked on disk only)."""
    if name.startswith("rl:"):
        path = pathlib.Path(name[3:])
        run = path if path.is_dir() else path.parent
        if not (run / "run.yaml").is_file() or not ((path / "model.zip") if path.is_dir() else path).is_file():
            raise ValueError(f"scheduler={name!r}: {str(path)!r} is not a trained run (run.yaml and model.zip)")
        return
    make_scheduler(name)


def make_scheduler(name: str) -> Scheduler:
    """A scheduler from its name.

    ``myopic``, ``round-robin``, ``random``, ``fixed-K`` (action K), ``lookahead-D``, ``rl:PATH`` (a run directory of
    ``scripts/train.py`` or its model zip; needs the ``rl`` extra).
    """
    if name.startswith("rl:"):
        from uwb_env.agents.rl.training import load_scheduler  # stable-baselines3 and torch only when asked for

        return load_scheduler(name[3:])
    if name in _NAMED:
        return _NAMED[name]()
    if m := re.fullmatch(r"fixed-(\d+)", name):
        return Fixed(int(m.group(1)))
    if m := re.fullmatch(r"lookahead-(\d+)", name):
        return MultiStepLookahead(int(m.group(1)))
    raise ValueError(f"scheduler={name!r}: must be one of {scheduler_names()}")
