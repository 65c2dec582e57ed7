"""Schedulers: ``reset(seed)`` then ``act(obs, env) -> action`` every scan.

RoundRobin, Fixed and Random are seed 003's open-loop baselines; Myopic is its closed-loop scheduler, the argmin of
the environment's one-step lookahead costs (seed 003 eq. 7). Ties go to the lowest action index.
"""

from __future__ import annotations

from typing import Any, Protocol

import gymnasium as gym
import numpy as np


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
        costs = np.asarray(env.unwrapped.lookahead_costs(), dtype=float)
        costs = np.where(env.unwrapped.action_masks(), costs, np.inf)
        return int(np.argmin(costs))
