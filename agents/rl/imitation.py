r"""Behaviour-cloning warm start: an actor-critic policy starts from a scheduler's decisions, then PPO fine-tunes it.

Why (issue 20): on seed 003's intersection the myopic scheduler is already within 0.0 % of the exhaustive 4-scan
optimum on the expected covariance recursion (``scripts/ceiling_gap.py``), and PPO from a random policy spends its
whole budget rediscovering it -- five seeds x 150k steps ended 5-14 % below myopic on the return. The env puts the
lookahead costs in the observation (``include_lookahead=True``), so myopic is a simple function of what the policy
sees (the argmin of eight or 64 numbers) and a network learns it in a few thousand gradient steps; the RL budget then
goes to what the one-step lookahead does not see (track loss, false tracks, the horizon). This is the warm start of
AlphaStar and of DQfD-style pre-training; the RL Zoo's users know it from ``imitation``'s BC, which we do not add as a
dependency: it is forty lines on the policy's own ``evaluate_actions``.

Two stages, both on the policy's own networks:

1. :func:`demonstrate`: the scheduler plays whole episodes on seeds of its own (``DEMO_SEED0`` + 10,000 x the
   training seed + k, never a training or evaluation seed), recording the raw observations, its actions, the action
   masks and the rewards;
2. :func:`warm_start`: the normaliser's statistics are updated with the demonstrations exactly as ``VecNormalize``
   would have while stepping them (observations; the running discounted return for the reward scale), then minibatch
   Adam on

       L = - mean log pi(a_demo | o)  +  vf_coef * mean (V(o) - G)^2,      G_t = sum_k gamma^k r~_{t+k}

   (r~ the normalised reward, G the Monte Carlo return to the episode's end: the critic starts near the
   demonstrator's value, so PPO's first advantages are not noise that would undo the cloned policy). A tenth of the
   episodes is held out; the agreement of the cloned policy's deterministic action with the demonstrator's on them
   is reported (``bc.yaml`` in the run folder).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
import torch as th
from sb3_contrib.common.maskable.policies import MaskableActorCriticPolicy
from scipy.signal import lfilter
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.vec_env import VecEnv, VecNormalize

from uwb_env.agents.schedulers import make_scheduler

DEMO_SEED0 = 2_000_000  # demonstration episodes: DEMO_SEED0 + 10_000 * training seed + k


@dataclass(frozen=True)
class Demonstrations:
    """A scheduler's episodes, step by step: raw observations, its actions, the masks and the rewards.

    ``obs`` (N, D) float32; ``actions`` (N,) int64 (``Discrete``) or (N, T) (``MultiDiscrete``); ``masks`` (N, M)
    bool, the env's ``action_masks()``; ``rewards`` (N,) float64 (the env's, not normalised); ``episode`` (N,) int64,
    the episode index of each step (episodes are whole and contiguous).
    """

    obs: np.ndarray
    actions: np.ndarray
    masks: np.ndarray
    rewards: np.ndarray
    episode: np.ndarray

    @property
    def n_episodes(self) -> int:
        """The number of episodes."""
        return int(self.episode[-1]) + 1 if self.episode.size else 0


def demonstrate(env_id: str, env_kwargs: dict[str, Any], scheduler: str, n_steps: int, seed0: int) -> Demonstrations:
    """Whole episodes of ``scheduler`` on ``env_id`` (seeds ``seed0``, ``seed0 + 1``, ...), >= ``n_steps`` steps."""
    if isinstance(n_steps, bool) or not isinstance(n_steps, int) or n_steps < 1:
        raise ValueError(f"bc_steps={n_steps!r}: must be an integer >= 1")
    env = gym.make(env_id, **env_kwargs)
    sched = make_scheduler(scheduler)
    obs_l, act_l, mask_l, rew_l, ep_l = [], [], [], [], []
    k = 0
    while len(rew_l) < n_steps:
        sched.reset(seed0 + k)
        obs, _ = env.reset(seed=seed0 + k)
        done = False
        while not done:
            action = sched.act(obs, env)
            obs_l.append(np.asarray(obs, dtype=np.float32))
            act_l.append(np.asarray(action, dtype=np.int64))
            mask_l.append(np.asarray(env.unwrapped.action_masks(), dtype=bool))
            obs, reward, term, trunc, _ = env.step(action)
            rew_l.append(float(reward))
            ep_l.append(k)
            done = term or trunc
        k += 1
    env.close()
    return Demonstrations(np.stack(obs_l), np.stack(act_l), np.stack(mask_l), np.asarray(rew_l), np.asarray(ep_l))


def running_returns(rewards: np.ndarray, episode: np.ndarray, gamma: float) -> np.ndarray:
    """``(N,)`` the running discounted return VecNormalize keeps for its reward scale, R_t = gamma R_{t-1} + r_t."""
    out = np.empty_like(rewards, dtype=float)
    bounds = np.flatnonzero(np.diff(episode)) + 1
    for s in np.split(np.arange(rewards.size), bounds):  # a loop over episodes (tens), each one filter call
        out[s] = lfilter([1.0], [1.0, -gamma], rewards[s])
    return out


def episode_returns(rewards: np.ndarray, episode: np.ndarray, gamma: float) -> np.ndarray:
    """``(N,)`` the discounted return to each episode's end, G_t = r_t + gamma G_{t+1}: the running return backwards."""
    return running_returns(rewards[::-1], episode[::-1], gamma)[::-1].copy()  # contiguous (torch takes it)


def warm_start(
    model: BaseAlgorithm,
    venv: VecEnv,
    demos: Demonstrations,
    epochs: int,
    seed: int,
    batch_size: int = 256,
    learning_rate: float = 1e-3,
    vf_coef: float = 0.5,
) -> dict[str, float]:
    """Clone ``demos`` into ``model``'s actor-critic policy (module docstring); returns the fit's statistics.

    ``venv``'s ``VecNormalize`` statistics (when it is one) are updated with the demonstrations first, so the policy
    is fitted on the observations and returns it will see. Returns ``agreement_train``, ``agreement_heldout`` (the
    fraction of steps whose deterministic action equals the demonstrator's), ``policy_loss``, ``value_loss`` (last
    epoch, per sample), ``steps``, ``episodes``.
    """
    if isinstance(epochs, bool) or not isinstance(epochs, int) or epochs < 1:
        raise ValueError(f"bc_epochs={epochs!r}: must be an integer >= 1")
    policy = model.policy
    if not hasattr(policy, "evaluate_actions"):
        raise ValueError(f"a behaviour-cloning warm start needs an actor-critic policy (ppo, a2c, maskable-ppo), "
                         f"not {type(model).__name__}")  # fmt: skip
    gamma = float(getattr(model, "gamma", 0.99))
    obs, rewards = demos.obs, demos.rewards
    if isinstance(venv, VecNormalize):
        if venv.norm_obs:
            venv.obs_rms.update(obs)
        if venv.norm_reward:
            venv.ret_rms.update(running_returns(rewards, demos.episode, venv.gamma))
        obs = venv.normalize_obs(obs)
        rewards = venv.normalize_reward(rewards).astype(float)
    returns = episode_returns(rewards, demos.episode, gamma)
    maskable = isinstance(policy, MaskableActorCriticPolicy)

    rng = np.random.default_rng(seed)
    held = rng.permutation(demos.n_episodes)[: max(1, demos.n_episodes // 10)] if demos.n_episodes > 1 else []
    is_held = np.isin(demos.episode, held)
    train_idx, held_idx = np.flatnonzero(~is_held), np.flatnonzero(is_held)
    o = th.as_tensor(obs, dtype=th.float32)
    a = th.as_tensor(demos.actions)
    g = th.as_tensor(returns, dtype=th.float32)
    optimizer = th.optim.Adam(policy.parameters(), lr=learning_rate)
    policy.set_training_mode(True)
    for _ in range(epochs):
        pl_sum = vl_sum = 0.0
        order = rng.permutation(train_idx)
        for start in range(0, order.size, batch_size):
            b = order[start : start + batch_size]
            kw = {"action_masks": demos.masks[b]} if maskable else {}
            values, log_prob, _ = policy.evaluate_actions(o[b], a[b], **kw)
            policy_loss = -log_prob.mean()
            value_loss = th.nn.functional.mse_loss(values.flatten(), g[b])
            loss = policy_loss + vf_coef * value_loss
            optimizer.zero_grad()
            loss.backward()
            th.nn.utils.clip_grad_norm_(policy.parameters(), 0.5)
            optimizer.step()
            pl_sum += policy_loss.item() * b.size
            vl_sum += value_loss.item() * b.size
    policy.set_training_mode(False)

    def agreement(idx: np.ndarray) -> float:
        if idx.size == 0:
            return float("nan")
        with th.no_grad():
            kw = {"action_masks": demos.masks[idx]} if maskable else {}
            dist = policy.get_distribution(o[idx], **kw)
            mode = dist.mode().numpy().reshape(idx.size, -1)
        return float(np.mean(np.all(mode == demos.actions[idx].reshape(idx.size, -1), axis=1)))

    return {
        "agreement_train": agreement(train_idx),
        "agreement_heldout": agreement(held_idx),
        "policy_loss": pl_sum / train_idx.size,
        "value_loss": vl_sum / train_idx.size,
        "steps": int(demos.rewards.size),
        "episodes": demos.n_episodes,
    }
