"""The behaviour-cloning warm start (agents/rl/imitation.py): returns, normaliser statistics, the fit, the wiring."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
import yaml
from sb3_contrib import MaskablePPO
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

from uwb_env.agents.rl import TrainConfig, train
from uwb_env.agents.rl.imitation import Demonstrations, episode_returns, running_returns, warm_start


def test_episode_returns_are_the_discounted_sums_to_each_episode_end():
    r = np.array([1.0, 1.0, 1.0, 2.0, 4.0])
    ep = np.array([0, 0, 0, 1, 1])
    # by hand, gamma 0.5: episode 0: 1 + .5 + .25, 1 + .5, 1; episode 1: 2 + .5 * 4, 4
    np.testing.assert_allclose(episode_returns(r, ep, 0.5), [1.75, 1.5, 1.0, 4.0, 4.0])
    np.testing.assert_allclose(running_returns(r, ep, 0.5), [1.0, 1.5, 1.75, 2.0, 5.0])


def test_running_returns_are_what_vecnormalize_keeps_while_stepping():
    """VecNormalize's R_t = gamma R_{t-1} + r_t, reset after each episode: the same numbers, one env."""
    rng = np.random.default_rng(3)
    r = rng.normal(size=40)
    ep = np.repeat([0, 1, 2], [10, 17, 13])
    want, R = [], 0.0
    for t in range(r.size):
        R = 0.9 * R + r[t]
        want.append(R)
        if t + 1 < r.size and ep[t + 1] != ep[t]:
            R = 0.0
    np.testing.assert_allclose(running_returns(r, ep, 0.9), want, rtol=1e-12)


class ArgminEnv(gym.Env):
    """Observation: 6 costs; the expert picks the cheapest valid action; action 5 is always masked."""

    observation_space = gym.spaces.Box(-5.0, 5.0, (6,), np.float32)
    action_space = gym.spaces.Discrete(6)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        return self.observation_space.sample(), {}

    def step(self, action):
        return self.observation_space.sample(), 0.0, False, True, {}

    def action_masks(self):
        return np.array([True] * 5 + [False])


def argmin_demos(n: int, seed: int) -> Demonstrations:
    rng = np.random.default_rng(seed)
    obs = rng.normal(size=(n, 6)).astype(np.float32)
    masks = np.tile(ArgminEnv().action_masks(), (n, 1))
    actions = np.argmin(np.where(masks, obs, np.inf), axis=1)
    episode = np.arange(n) // 20  # episodes of 20 steps, reward 1 each step
    return Demonstrations(obs, actions.astype(np.int64), masks, np.ones(n), episode)


@pytest.mark.parametrize("cls", [MaskablePPO, PPO])
def test_warm_start_clones_an_argmin_expert_and_fits_its_value(cls):
    venv = VecNormalize(DummyVecEnv([ArgminEnv]), gamma=0.5)
    model = cls("MlpPolicy", venv, seed=0, device="cpu", policy_kwargs={"net_arch": [64, 64]})
    demos = argmin_demos(6000, 1)
    stats = warm_start(model, venv, demos, epochs=30, seed=0)
    # a 6-way argmin of Gaussian costs: the network learns it to > 90 % on episodes it did not see
    assert stats["agreement_heldout"] > 0.9, stats
    # the normaliser saw the demonstrations: its observation mean is their mean to sampling error (6000 samples)
    np.testing.assert_allclose(venv.obs_rms.mean, demos.obs.mean(axis=0), atol=1e-6)
    assert abs(venv.obs_rms.mean).max() < 4 / np.sqrt(6000)
    # the critic: the normalised return to the episode's end, here a known function of the step in the episode
    obs = venv.normalize_obs(demos.obs[:200])
    import torch as th

    with th.no_grad():
        v = model.policy.predict_values(th.as_tensor(obs)).numpy().ravel()
    g = episode_returns(venv.normalize_reward(demos.rewards[:200]).astype(float), demos.episode[:200], model.gamma)
    # the observation says nothing of the step, so the best fit is the mean return over the episode's steps
    np.testing.assert_allclose(v.mean(), g.mean(), rtol=0.1)
    if cls is MaskablePPO:  # the masked action is never chosen
        with th.no_grad():
            dist = model.policy.get_distribution(th.as_tensor(obs), action_masks=demos.masks[:200])
        assert (dist.mode().numpy() != 5).all()


def test_training_with_a_warm_start_writes_its_agreement_and_starts_at_the_demonstrator(tmp_path):
    """Seed 003's urban env with the lookahead costs observed: the clone plays myopic's action on >= 90 % of scans."""
    cfg = TrainConfig("uwb_env/UrbanWaveform-v3", "maskable-ppo", 64, tmp_path / "run",
                      env_kwargs={"include_lookahead": True},
                      overrides={"bc_steps": 1500, "n_envs": 1, "n_steps": 64, "batch_size": 64, "eval_freq": 10**6,
                                 "checkpoint_freq": 10**6})  # fmt: skip
    train(cfg, progress=False)
    stats = yaml.safe_load((tmp_path / "run" / "bc.yaml").read_text())
    assert stats["scheduler"] == "myopic" and stats["steps"] >= 1500
    assert stats["agreement_train"] >= 0.9 and stats["agreement_heldout"] >= 0.9, stats
    assert yaml.safe_load((tmp_path / "run" / "run.yaml").read_text())["common"]["bc_steps"] == 1500


@pytest.mark.parametrize(
    ("algo", "key", "value", "match"),
    [
        ("maskable-ppo", "bc_steps", -1, "bc_steps=-1: must be an integer >= 0"),
        ("maskable-ppo", "bc_epochs", 0, "bc_epochs=0: must be an integer >= 1"),
        ("maskable-ppo", "bc_scheduler", "rl:runs/x", "bc_scheduler='rl:runs/x': must name a scheduler"),
        ("maskable-ppo", "bc_scheduler", "greedy", "greedy"),
        ("dqn", "bc_steps", 100, "needs an actor-critic algorithm"),
    ],
)
def test_bad_warm_start_settings_are_refused_naming_the_key(tmp_path, algo, key, value, match):
    cfg = TrainConfig("uwb_env/UrbanWaveform-v3", algo, 64, tmp_path / "run", overrides={key: value})
    with pytest.raises(ValueError, match=match):
        train(cfg, progress=False)
    assert not (tmp_path / "run" / "run.yaml").exists()  # refused before a run is recorded
