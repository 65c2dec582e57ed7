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


# ---------------------------------------------------------------------------- several training seeds (issue 20)
def test_seeds_train_each_seed_as_a_single_run_skip_finished_and_resume_interrupted(tmp_path, capsys):
    """``--seeds 2`` = two single runs (seed-1's model equals ``--seed 1`` alone); a stopped job continues."""
    import pathlib

    from uwb_env.agents.cli import train_main
    from uwb_env.agents.rl import train_seeds
    from uwb_env.agents.rl.training import trained_steps

    env_id, out = ENV_IDS[1], tmp_path / "multi"
    hyper = {**SMALL, **PER_ALGO["ppo"], "eval_freq": 64}
    flags = [f"{k}={v}" for k, v in hyper.items()]
    common = ["--env", env_id, "--algo", "ppo", "--timesteps", "128", "--no-progress", "--hyper", *flags]
    train_main([*common, "--seed", "0", "--seeds", "2", "--out", str(out)])
    assert "seeds 0 (trained), 1 (trained)" in capsys.readouterr().out
    assert [trained_steps(out / f"seed-{s}") for s in (0, 1)] == [128, 128]
    assert (out / "learning_curves.png").is_file()
    rows = (out / "seed-1" / "eval.csv").read_text().splitlines()
    assert rows[0].startswith("timesteps,return,trace_m2") and [r.split(",")[0] for r in rows[1:]] == ["64", "128"]
    # seed 1 of the multi-seed run is exactly the single run of seed 1
    train_main([*common, "--seed", "1", "--out", str(tmp_path / "single")])
    a, b = load_scheduler(out / "seed-1").model.policy, load_scheduler(tmp_path / "single").model.policy
    for (name, p), (_, q) in zip(a.state_dict().items(), b.state_dict().items(), strict=True):
        np.testing.assert_array_equal(p.numpy(), q.numpy(), err_msg=name)
    # seed 0 interrupted (its final model gone, checkpoints kept): refused without --resume, before training seed 2
    (out / "seed-0" / "model.zip").unlink()
    cfg = TrainConfig(env_id, "ppo", 128, out, overrides=hyper)
    with pytest.raises(ValueError, match=r"unfinished run of seed 0 \(no final model.zip, --timesteps 128\)"):
        train_seeds(cfg, [0, 1, 2], progress=False)
    assert not (out / "seed-2").exists()
    assert train_seeds(cfg, [0, 1, 2], resume=True, progress=False) == {0: "resume", 1: "finished", 2: "train"}
    assert [trained_steps(out / f"seed-{s}") for s in (0, 1, 2)] == [128, 128, 128]
    # a single run into a multi-seed folder, or a multi-seed run into a single run's folder, is refused
    with pytest.raises(ValueError, match="holds a multi-seed run"):
        train(TrainConfig(env_id, "ppo", 128, out, overrides=hyper), progress=False)
    with pytest.raises(ValueError, match="holds a single training run"):
        train_seeds(TrainConfig(env_id, "ppo", 128, pathlib.Path(tmp_path / "single"), overrides=hyper), [0])
    with pytest.raises(ValueError, match="differs from the run's"):  # the seeds' run.yaml must match
        train_seeds(TrainConfig(env_id, "ppo", 128, out, overrides={**hyper, "n_epochs": 3}), [0], resume=True)
    # the campaign: rl:OUT plays every seed and the summary reports them across seeds
    from uwb_env.agents.cli import evaluate_main
    from uwb_env.agents.summary import read_runs_csv

    camp = tmp_path / "campaign"
    evaluate_main(["--env", env_id, "--schemes", "myopic", f"rl:{out}", "--baseline", "myopic", "--runs", "2",
                   "--workers", "1", "--no-progress", "--out", str(camp)])  # fmt: skip
    text = (camp / "summary.md").read_text()
    assert f"## Across training seeds: `rl:{out}` (seeds 0..2)" in text
    schemes, metrics = read_runs_csv(camp / "runs.csv")
    assert schemes == ["myopic", *(f"rl:{out}/seed-{s}" for s in range(3))]
    per_seed = " | ".join(f"{metrics[f'rl:{out}/seed-{s}']['return'].mean():.4g}" for s in range(3))
    assert f"| return | higher | {per_seed} |" in text


def test_learning_curves_read_the_columns_training_writes():
    from uwb_env.agents.multiseed import CURVE_METRICS, REFERENCES
    from uwb_env.agents.rl.training import EVAL_COLUMNS

    need = ["timesteps", *CURVE_METRICS, *(f"{r}_{m}" for r in REFERENCES for m in CURVE_METRICS)]
    assert sorted(need) == sorted(EVAL_COLUMNS)
