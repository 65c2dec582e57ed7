"""``uwb-env-train --engine rllib`` (issue 19, part 2): RLlib's new API stack trains, checkpoints, resumes, evaluates
and plays as a campaign scheduler (``rllib:RUN_DIR``); bad arguments name their field.

Every run here is tiny (2 env runners x 1 env, 128 steps an iteration, one epoch); most of a test's time is Ray
starting the runners' processes (~15 s per build on two busy cores). One id with invalid actions (a receiver out of
service: the masked PPO never steps one, or the env would raise) runs by default; every registered id is ``slow``.
"""

from __future__ import annotations

import csv
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("ray.rllib")


import uwb_env  # noqa: F401
from uwb_env.agents.cli import train_main
from uwb_env.agents.rl.rllib_engine import (
    RLlibTrainConfig,
    rllib_checkpoints,
    train_rllib,
)
from uwb_env.agents.rl.training import EVAL_COLUMNS
from uwb_env.agents.schedulers import check_scheduler_name, make_scheduler
from uwb_env.envs import ENV_IDS

TINY = {"train_batch_size_per_learner": 128, "minibatch_size": 64, "num_epochs": 1, "fcnet_hiddens": [32, 32],
        "eval_episodes": 1}  # fmt: skip
MASKED_ID, MASKED_KWARGS = "uwb_env/IndoorSubsetWarmup-v1", {"out_of_service_rx": ["rx1"]}


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open() as f:
        return list(csv.DictReader(f))


def _train_resume_play(env_id: str, out: Path, env_kwargs: dict | None = None) -> None:
    kwargs = dict(env_kwargs or {})
    cfg = RLlibTrainConfig(env_id=env_id, algo="ppo", timesteps=128, out=out, seed=3, env_kwargs=kwargs,
                           overrides=TINY, env_runners=2, checkpoint_every=1)  # fmt: skip
    algo = train_rllib(cfg, progress=False)
    assert algo.iteration == 1
    assert [i for i, _ in rllib_checkpoints(out)] == [1]
    cfg.timesteps = 256
    algo = train_rllib(cfg, resume=True, progress=False)
    assert algo.iteration == 2  # the counters continue from the checkpoint
    assert [i for i, _ in rllib_checkpoints(out)] == [2, 1]
    progress = _rows(out / "progress.csv")
    assert [(r["training_iteration"], r["timesteps"]) for r in progress] == [("1", "128"), ("2", "256")]
    evals = _rows(out / "eval.csv")
    assert list(evals[0]) == EVAL_COLUMNS and [r["timesteps"] for r in evals] == ["128", "256"]
    assert all(np.isfinite(float(r["myopic_return"])) for r in evals)
    assert (out / "policy").is_dir()

    name = f"rllib:{out}"
    check_scheduler_name(name)
    agent = make_scheduler(name)
    env = gym.make(env_id, **kwargs)
    mask = env.unwrapped.action_masks()
    obs, _ = env.reset(seed=7)
    agent.reset(7)
    for _ in range(5):
        action = agent.act(obs, env)
        assert mask[action]
        obs, *_ = env.step(action)
    env.close()


def test_ppo_trains_resumes_and_plays_masked_on_an_env_with_invalid_actions(tmp_path, local_ray):
    assert not gym.make(MASKED_ID, **MASKED_KWARGS).unwrapped.action_masks().all()
    _train_resume_play(MASKED_ID, tmp_path / "run", MASKED_KWARGS)


@pytest.mark.slow
@pytest.mark.parametrize("env_id", sorted(ENV_IDS))
def test_ppo_on_every_registered_id(env_id, tmp_path, local_ray):
    _train_resume_play(env_id, tmp_path / "run")


@pytest.mark.slow
def test_dqn_trains_resumes_and_plays_masked_on_an_env_with_invalid_actions(tmp_path, local_ray):
    """Off-policy, masked: an epsilon-greedy step on a masked action would raise in the env."""
    out = tmp_path / "run"
    hyper = {"train_batch_size_per_learner": 32, "num_steps_sampled_before_learning_starts": 32, "fcnet_hiddens": [16],
             "eval_episodes": 1, "training_intensity": 0.25}  # fmt: skip
    cfg = RLlibTrainConfig(env_id=MASKED_ID, algo="dqn", timesteps=100, out=out, env_kwargs=MASKED_KWARGS,
                           overrides=hyper, checkpoint_every=1)  # fmt: skip
    algo = train_rllib(cfg, progress=False)
    assert algo.iteration == 1 and [i for i, _ in rllib_checkpoints(out)] == [1]
    first = int(_rows(out / "progress.csv")[-1]["timesteps"])
    cfg.timesteps = first + 1
    algo = train_rllib(cfg, resume=True, progress=False)
    assert algo.iteration == 2 and int(_rows(out / "progress.csv")[-1]["timesteps"]) > first
    assert np.isfinite(float(_rows(out / "progress.csv")[-1]["loss"]))  # -inf Q-values never reach the loss
    agent = make_scheduler(f"rllib:{out}")
    env = gym.make(MASKED_ID, **MASKED_KWARGS)
    mask = env.unwrapped.action_masks()
    obs, _ = env.reset(seed=0)
    for _ in range(5):
        action = agent.act(obs, env)
        assert mask[action]
        obs, *_ = env.step(action)


@pytest.mark.slow
def test_the_cli_trains_with_the_rllib_engine(tmp_path, local_ray, capsys):
    out = tmp_path / "cli"
    hyper = [f"{k}={v}" for k, v in TINY.items()]
    hyper[-2] = "fcnet_hiddens=[16]"
    train_main(["--engine", "rllib", "--env", "uwb_env/IndoorJoint-v1", "--timesteps", "100", "--env-runners", "2",
                "--out", str(out), "--no-progress", "--hyper", *hyper])  # fmt: skip
    assert "trained rllib ppo on uwb_env/IndoorJoint-v1: 1 iterations, 128 steps" in capsys.readouterr().out
    assert [i for i, _ in rllib_checkpoints(out)] == [1] and (out / "eval.csv").is_file()


# ------------------------------------------------------------------------------------------ bad arguments
@pytest.mark.parametrize(
    ("field", "value"),
    [("env_runners", 0), ("envs_per_runner", 0), ("checkpoint_every", 0), ("algo", "a2c"), ("env_id", "nope"),
     ("timesteps", 0), ("address", "")],
)  # fmt: skip
def test_bad_config_fields_are_named(field, value, tmp_path):
    args = {"env_id": "uwb_env/IndoorJoint-v1", "algo": "ppo", "timesteps": 10, "out": tmp_path / "r"}
    with pytest.raises(ValueError, match=rf"^{field}="):
        RLlibTrainConfig(**{**args, field: value})


@pytest.mark.parametrize(
    ("argv", "named"),
    [
        (["--engine", "tf"], "--engine"),
        (["--engine", "rllib", "--env-runners", "0"], "--env-runners"),
        (["--engine", "rllib", "--envs-per-runner", "-1"], "--envs-per-runner"),
        (["--env-runners", "2"], "--env-runners: only with --engine rllib"),
        (["--engine", "rllib", "--algo", "maskable-ppo"], "algo='maskable-ppo'"),
        (["--engine", "rllib", "--hyper", "bogus=1"], "--hyper bogus=1"),
        (["--engine", "rllib", "--tensorboard"], "--tensorboard"),
        (["--engine", "rllib", "--algo", "dqn", "--hyper", "num_atoms=51"], "--hyper num_atoms=51"),
    ],
)
def test_bad_cli_arguments_exit_2_naming_the_field(argv, named, tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        train_main([*argv, "--env", "uwb_env/IndoorJoint-v1", "--out", str(tmp_path / "r"), "--no-progress"])
    assert e.value.code == 2
    assert named in capsys.readouterr().err
    assert not (tmp_path / "r").exists()  # nothing written


def test_a_folder_that_is_not_an_rllib_run_is_not_a_scheduler(tmp_path):
    with pytest.raises(ValueError, match="not a trained RLlib run"):
        check_scheduler_name(f"rllib:{tmp_path}")


def test_a_run_folder_is_refused_without_resume_and_a_resume_must_match(tmp_path):
    """Checked before Ray starts: nothing trains, nothing is written."""
    out = tmp_path / "r"
    cfg = RLlibTrainConfig(env_id="uwb_env/IndoorJoint-v1", algo="ppo", timesteps=10, out=out, seed=1)
    out.mkdir()
    (out / "run.yaml").write_text("engine: rllib\nenv_id: uwb_env/IndoorJoint-v1\nalgo: ppo\nseed: 0\n")
    with pytest.raises(ValueError, match="already holds a training run"):
        train_rllib(cfg)
    with pytest.raises(ValueError, match=r"--resume: seed = 1 differs from the run's 0"):
        train_rllib(cfg, resume=True)
    assert sorted(p.name for p in out.iterdir()) == [".lock", "run.yaml"]  # the folder lock's file, released


@pytest.mark.slow
def test_resume_falls_back_to_the_previous_checkpoint_when_the_newest_is_damaged(tmp_path, local_ray, capsys):
    out = tmp_path / "run"
    cfg = RLlibTrainConfig(env_id="uwb_env/IndoorJoint-v1", algo="ppo", timesteps=256, out=out, overrides=TINY,
                           checkpoint_every=1)  # fmt: skip
    train_rllib(cfg, progress=False)
    (out / "checkpoints" / "iter_000002" / "algorithm_state.pkl").write_bytes(b"cut")
    algo = train_rllib(cfg, resume=True, progress=False)
    err = capsys.readouterr().err
    assert "iter_000002.damaged" in err and "resuming from" in err and "iteration 1, 128 steps" in err
    assert algo.iteration == 2
    assert [i for i, _ in rllib_checkpoints(out)] == [2, 1]
    assert [r["timesteps"] for r in _rows(out / "progress.csv")] == ["128", "256"]  # the lost iteration replayed
