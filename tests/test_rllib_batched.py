"""``uwb-env-train --engine rllib --vectorize batched`` (issue 19, part 3): RLlib's runners step the batched vector env.

:class:`MaskedUWBVectorEnv` gives env by env what :class:`MaskedUWBEnv` gives (observations with their masks,
rewards, terminations, truncations, NEXT_STEP autoreset), and PPO trains an iteration on it through RLlib's
``gym_env_vectorize_mode="vector_entry_point"`` (tiny runs, as ``tests/test_rllib.py``).
"""

from __future__ import annotations

import copy
import csv

import numpy as np
import pytest
import yaml

pytest.importorskip("ray.rllib")


from test_rllib import MASKED_ID, MASKED_KWARGS, TINY  # the RLlib tests' tiny run and masked env

import uwb_env  # noqa: F401
from uwb_env.agents.rl import rllib_engine
from uwb_env.agents.rl.rllib_engine import (
    MaskedUWBEnv,
    MaskedUWBVectorEnv,
    RLlibTrainConfig,
    build_config,
    masked_uwb_env,
    resolve_rllib,
    rllib_checkpoints,
    sampled_steps,
    train_rllib,
)


def test_the_masked_vector_env_equals_the_masked_env_env_by_env():
    config = {"env_id": MASKED_ID, "env_kwargs": MASKED_KWARGS}
    vec = masked_uwb_env({**config, "num_envs": 2})
    singles = [masked_uwb_env(config) for _ in range(2)]
    assert isinstance(vec, MaskedUWBVectorEnv) and all(isinstance(e, MaskedUWBEnv) for e in singles)
    assert vec.single_observation_space == singles[0].observation_space
    assert vec.single_action_space == singles[0].action_space and vec.metadata["autoreset_mode"].value == "NextStep"
    obs, _ = vec.reset(seed=4)
    ref = [e.reset(seed=4 + i)[0] for i, e in enumerate(singles)]
    assert obs["action_mask"].dtype == np.float32 and obs["action_mask"].shape == (2, vec.single_action_space.n)
    assert not obs["action_mask"].all()  # rx1 out of service: some plans invalid
    rng = np.random.default_rng(1)
    done = np.zeros(2, bool)
    ends = 0
    for t in range(64):  # the indoor episodes are 61 scans: one ends, the next starts (NEXT_STEP)
        for i in range(2):
            np.testing.assert_array_equal(obs["action_mask"][i], ref[i]["action_mask"], err_msg=f"t={t}")
            np.testing.assert_array_equal(obs["observations"][i], ref[i]["observations"], err_msg=f"t={t}")
        actions = np.array([rng.choice(np.flatnonzero(m)) for m in obs["action_mask"]], np.int64)
        obs, rewards, term, trunc, _ = vec.step(actions)
        for i, env in enumerate(singles):
            if done[i]:
                ref[i], _ = env.reset()
                assert rewards[i] == 0 and not term[i] and not trunc[i]
            else:
                ref[i], r, te, tr, _ = env.step(int(actions[i]))
                assert (rewards[i], term[i], trunc[i]) == (r, te, tr), t
        done = term | trunc
        ends += int(done.sum())
    assert ends == 2
    vec.close()


def test_bad_vectorize_is_named(tmp_path):
    with pytest.raises(ValueError, match=r"^vectorize='subproc' \(--vectorize\): with engine='rllib' must be one of"):
        RLlibTrainConfig(env_id=MASKED_ID, algo="ppo", timesteps=8, out=tmp_path / "r", vectorize="subproc")
    cfg = RLlibTrainConfig(env_id=MASKED_ID, algo="ppo", timesteps=8, out=tmp_path / "r", vectorize="batched",
                           env_kwargs={"tracker": "pf"})  # fmt: skip
    with pytest.raises(ValueError, match=r"--vectorize batched .*tracker='pf'"):
        train_rllib(cfg, progress=False)  # refused before Ray starts or anything is written
    assert not (tmp_path / "r").exists()


@pytest.fixture(scope="module")
def batched_run(tmp_path_factory, local_ray):
    """One PPO iteration of ``train_rllib`` on 1 runner x 2 batched envs, with what its runner held and the
    iteration's result (read by a spy on ``sampled_steps``, which the training loop calls with each result).

    Shared by the two tests below: each built and trained its own algorithm before (~6 s a build on two busy cores,
    the first test's by ``build_config(...).build_algo()``, the call ``train_rllib`` makes).
    """
    cfg = RLlibTrainConfig(env_id=MASKED_ID, algo="ppo", timesteps=128, out=tmp_path_factory.mktemp("batched") / "run",
                           seed=3, env_kwargs=MASKED_KWARGS, overrides=TINY, env_runners=1, envs_per_runner=2,
                           checkpoint_every=1, vectorize="batched")  # fmt: skip
    seen = []

    def spy(algo, result=None):
        if result is not None:
            kinds = algo.env_runner_group.foreach_env_runner(
                lambda r: (type(r.env.unwrapped).__name__, r.num_envs), local_env_runner=False
            )
            seen.append((kinds, result))
        return sampled_steps(algo, result)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(rllib_engine, "sampled_steps", spy)
        algo = train_rllib(copy.copy(cfg), progress=False)
    return cfg, algo, seen


def test_the_runners_step_the_batched_vector_env(batched_run):
    cfg, _, seen = batched_run
    config = build_config(cfg, resolve_rllib(cfg))
    assert config.gym_env_vectorize_mode == "vector_entry_point"
    [(kinds, result)] = seen  # one iteration
    assert kinds == [("MaskedUWBVectorEnv", 2)]
    runners = result["env_runners"]
    assert runners["num_env_steps_sampled_lifetime"] >= 128
    assert np.isfinite(result["learners"]["default_policy"]["total_loss"])


def test_ppo_trains_an_iteration_with_vectorize_batched(batched_run):
    cfg, algo, _ = batched_run
    cfg, out = copy.copy(cfg), cfg.out
    assert algo.iteration == 1 and [i for i, _ in rllib_checkpoints(out)] == [1]
    run = yaml.safe_load((out / "run.yaml").read_text())
    assert run["vectorize"] == "batched" and run["envs_per_runner"] == 2
    with (out / "progress.csv").open() as f:
        assert [r["timesteps"] for r in csv.DictReader(f)] == ["128"]
    cfg.timesteps, cfg.vectorize = 256, "sync"  # the same episodes either way: may change on resume
    algo = train_rllib(cfg, resume=True, progress=False)
    assert algo.iteration == 2
    assert yaml.safe_load((out / "run.yaml").read_text())["vectorize"] == "sync"
