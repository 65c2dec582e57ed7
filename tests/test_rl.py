"""RL schedulers (issue 6): every algorithm on every env, save/load, resume, a trained agent in a campaign."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
import yaml

from uwb_env.agents.rl import (
    ALGORITHMS,
    PolicyScheduler,
    TrainConfig,
    latest_checkpoint,
    load_preset,
    load_scheduler,
    train,
)
from uwb_env.envs import ENV_IDS as REGISTERED

ENV_IDS = ["uwb_env/UrbanWaveform-v3", "uwb_env/IndoorSensorSubset-v1", "uwb_env/IndoorJoint-v1"]
SMALL = {  # a few hundred steps: small rollouts, one evaluation episode, no learning delay
    "n_envs": 2,
    "eval_freq": 10**9,
    "eval_episodes": 1,
    "checkpoint_freq": 128,
}
PER_ALGO = {
    "ppo": {"n_steps": 64, "batch_size": 64, "n_epochs": 2},
    "maskable-ppo": {"n_steps": 64, "batch_size": 64, "n_epochs": 2},
    "a2c": {"n_steps": 8},
    "dqn": {"learning_starts": 64, "buffer_size": 10_000, "batch_size": 32, "target_update_interval": 64},
}


def _cfg(tmp_path, env_id, algo, steps, **extra):
    return TrainConfig(env_id, algo, steps, tmp_path / "run", seed=3, overrides={**SMALL, **PER_ALGO[algo], **extra})


@pytest.mark.parametrize("env_id", sorted(REGISTERED))
@pytest.mark.parametrize("algo", sorted(ALGORITHMS))
def test_each_algorithm_trains_a_few_hundred_steps_on_each_env(tmp_path, env_id, algo):
    model = train(_cfg(tmp_path, env_id, algo, 256), progress=False)
    out = tmp_path / "run"
    assert model.num_timesteps == 256  # 128 rollouts of 2 envs (every rollout size divides 256)
    assert latest_checkpoint(out)[1] == 256
    run = yaml.safe_load((out / "run.yaml").read_text())
    assert run["preset_version"] == 1 and run["algo"] == algo and run["hyper"]["learning_rate"] > 0
    # the normaliser saw every observation: 2 initial resets + 256 steps (+ the auto-resets' first observations)
    agent = load_scheduler(out)
    assert agent.normalizer.obs_rms.count >= 256
    e = gym.make(env_id)
    obs, _ = e.reset(seed=5)
    for _ in range(20):
        a = agent.act(obs, e)
        assert 0 <= a < e.action_space.n
        if algo == "maskable-ppo":
            assert e.unwrapped.action_masks()[a]
        obs, *_ = e.step(a)


def test_saved_and_loaded_policies_act_identically(tmp_path):
    model = train(_cfg(tmp_path, ENV_IDS[0], "ppo", 128), progress=False)
    loaded = load_scheduler(tmp_path / "run")
    live = PolicyScheduler(model, loaded.normalizer)
    env = gym.make(ENV_IDS[0])
    obs, _ = env.reset(seed=11)
    for _ in range(30):
        a, b = live.act(obs, env), loaded.act(obs, env)
        assert a == b
        obs, *_ = env.step(a)


def test_resume_continues_the_step_counter_normaliser_and_replay_buffer(tmp_path):
    """Stop a DQN run at 256 steps (as if interrupted), resume to 512: one uninterrupted history."""
    cfg = _cfg(tmp_path, ENV_IDS[1], "dqn", 256)
    first = train(cfg, progress=False)
    assert first.replay_buffer.size() == 128  # 256 transitions over 2 envs
    ckpt = tmp_path / "run" / "checkpoints" / "rl_model_256_steps.zip"
    assert ckpt.is_file()
    with pytest.raises(ValueError, match="differs from the run's"):
        train(TrainConfig(cfg.env_id, "dqn", 512, cfg.out, seed=4, overrides=cfg.overrides), resume=True)
    cfg.timesteps = 512
    second = train(cfg, resume=True, progress=False)
    assert second.num_timesteps == 512
    # restored: the checkpoint's buffer + 128 more per env. SB3's CheckpointCallback runs before the step's transition
    # is stored, so the checkpoint holds 127 of the first 128 per env; a fresh buffer would hold 128
    assert second.replay_buffer.size() == 127 + 128
    count = load_scheduler(tmp_path / "run").normalizer.obs_rms.count
    assert count >= 512  # the normaliser's statistics continued too (a fresh one would have counted ~256)


def test_presets_are_versioned_and_unknown_names_raise():
    p = load_preset("uwb_env/UrbanWaveform-v3", "maskable-ppo")
    assert p["version"] == 1 and p["common"]["n_envs"] >= 1 and p["algo"]["policy"] == "MlpPolicy"
    with pytest.raises(ValueError, match="algo='sac'"):
        load_preset("uwb_env/UrbanWaveform-v3", "sac")
    with pytest.raises(ValueError, match="no preset"):
        load_preset("uwb_env/Nope-v0", "ppo")


def test_a_trained_agent_plays_in_a_paired_campaign(tmp_path):
    from uwb_env.agents.campaign import Campaign, run_one

    train(_cfg(tmp_path, ENV_IDS[0], "maskable-ppo", 128), progress=False)
    scheme = f"rl:{tmp_path / 'run'}"
    camp = Campaign(env=ENV_IDS[0], schemes=("myopic", scheme), baseline="myopic", runs=2, seed0=0, overrides={})
    path = run_one(camp, scheme, 0, tmp_path / "rec.csv")
    rec = np.loadtxt(path, delimiter=",", skiprows=1)
    assert rec.shape[0] == 140  # every scan of the episode
    names = path.read_text().splitlines()[0].split(",")
    actions = rec[:, names.index("action")]
    assert set(np.unique(actions)) <= set(range(6))  # the urban library: 6 chirps


def test_a_parallel_campaign_with_a_trained_agent_finishes_and_matches_a_serial_one(tmp_path):
    """Workers with torch must not be forked from a parent that used it (they hang): a fork server is used."""
    from uwb_env.agents.campaign import Campaign, load_runs, run_campaign

    train(_cfg(tmp_path, ENV_IDS[1], "ppo", 128), progress=False)
    scheme = f"rl:{tmp_path / 'run'}"
    camp = Campaign(env=ENV_IDS[1], schemes=("round-robin", scheme), baseline="round-robin", runs=2)
    run_campaign(camp, tmp_path / "par", workers=2, progress=False)
    run_campaign(camp, tmp_path / "ser", workers=1, progress=False)
    par, ser = load_runs(camp, tmp_path / "par"), load_runs(camp, tmp_path / "ser")
    for s in camp.schemes:
        for a, b in zip(par[s], ser[s], strict=True):
            np.testing.assert_array_equal(a["action"], b["action"])
            # same actions; rewards to the last bits (a fresh process may sum in another order: measured 1e-11)
            np.testing.assert_allclose(a["reward"], b["reward"], rtol=1e-9)


@pytest.mark.parametrize("env_id", sorted(REGISTERED))
def test_default_observation_is_normalised_on_the_scenarios_typical_range(env_id):
    """Two myopic episodes: every feature stays O(1) (measured max |x| <= 4.4) and no feature's scale is orders of
    magnitude beyond the others' (99th percentile of |x| per varying feature within 100x of their median)."""
    from uwb_env.agents import make_scheduler

    env = gym.make(env_id, include_lookahead=True)
    agent = make_scheduler("myopic")
    obs = []
    for seed in range(2):
        o, _ = env.reset(seed=seed)
        agent.reset(seed)
        done = False
        while not done:
            o, _, terminated, truncated, _ = env.step(agent.act(o, env))
            done = terminated or truncated
            obs.append(o)
    x = np.abs(np.array(obs))
    assert np.isfinite(x).all() and x.max() <= 10.0
    scale = np.quantile(x, 0.99, axis=0)
    varying = scale[np.array(obs).std(axis=0) > 0]
    assert varying.max() <= 100.0 * np.median(varying)


def test_the_command_line_names_every_algorithm_without_importing_torch():
    from uwb_env.agents.cli import ALGORITHM_NAMES

    assert ALGORITHM_NAMES == tuple(sorted(ALGORITHMS))


@pytest.mark.parametrize("kind", ["phd", "pf"])
def test_ppo_trains_and_plays_on_each_particle_tracker(tmp_path, kind):
    """An RL scheduler on the particle trackers (env_kwargs tracker=KIND): the observation carries their one model."""
    cfg = TrainConfig("uwb_env/IndoorSensorSubset-v1", "ppo", 128, tmp_path / "run", seed=3,
                      env_kwargs={"tracker": kind}, overrides={**SMALL, **PER_ALGO["ppo"]})  # fmt: skip
    model = train(cfg, progress=False)
    assert model.num_timesteps == 128
    agent = load_scheduler(tmp_path / "run")
    e = gym.make("uwb_env/IndoorSensorSubset-v1", tracker=kind)
    assert e.unwrapped.sim.tracker.kind == kind
    obs, _ = e.reset(seed=5)
    for _ in range(10):
        obs, reward, *_ = e.step(agent.act(obs, e))
        assert np.isfinite(reward)
