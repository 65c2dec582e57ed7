"""Every registered id under Gymnasium's and SB3's vector envs, and RLlib with two envs per runner (issue 16).

The info dict has a fixed key set and fixed shapes at every step and at reset (``UWBSchedulingEnv`` docstring),
so a vector env can stack it: before, ``position_errors_m`` changed length from step to step and
``gymnasium.make_vec(id, num_envs=4)`` failed after 4-13 steps in ``_add_info``
("could not broadcast input array from shape (0,) into shape (1,)"), and the async env then hung in ``close()``.

Each case plays ``TOTAL_STEPS`` env steps per id, split across ``NUM_ENVS`` envs (several autoresets: the episodes are
61 to 140 scans), and checks finite observations inside the space, finite rewards and the info's shapes. The
async cases stop earlier (``test_gymnasium_vector_envs_run_2000_steps``); the SB3 subprocess case runs by default on
two ids (``SUBPROC_BY_DEFAULT``), on the others it is ``slow``.
"""

from __future__ import annotations

import contextlib
import signal

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import uwb_env
from uwb_env.envs import ENV_IDS

gym.register_envs(uwb_env)

TOTAL_STEPS = 2000
NUM_ENVS = 4
IDS = sorted(ENV_IDS)
# SB3's SubprocVecEnv by default on a plain id (the largest info, Discrete(64) with masks) and a scene-family id (its
# own entry point); ~9 s a case, ~6 s of it the two workers' fresh interpreters importing the package, SB3 and torch.
SUBPROC_BY_DEFAULT = ("uwb_env/UrbanDistributed-v0", "uwb_env/UrbanWidebandFamily-v0")
# Steps an async case plays after every env has ended an episode: the autoreset (SAME_STEP: final_obs / final_info),
# the reset step (NEXT_STEP) and a step of the next episode.
ASYNC_STEPS_AFTER_THE_EPISODE_ENDS = 2


@contextlib.contextmanager
def time_limit(seconds: int):
    """Fail (rather than hang) when the block runs longer than ``seconds`` (SIGALRM: main thread, POSIX)."""

    def _raise(signum, frame):
        raise TimeoutError(f"vector env did not finish within {seconds} s")

    old = signal.signal(signal.SIGALRM, _raise)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def _reference_info(env_id: str) -> dict:
    """One env's info after a step: the key set and shapes every step (and reset) must have."""
    env = gym.make(env_id)
    _, reset_info = env.reset(seed=0)
    _, _, _, _, info = env.step(0)
    assert set(reset_info) == set(info), "reset() and step() infos must have the same keys"
    for k, v in info.items():
        assert np.shape(reset_info[k]) == np.shape(v), k
    env.close()
    return info


def _check_vector_info(info: dict, ref: dict, n: int) -> None:
    if "final_info" in info:  # SAME_STEP: the ended episodes' last infos, stacked the same way
        assert info["_final_info"].any() and np.isfinite(info["final_obs"][info["_final_obs"]].tolist()).all()
        ended = info["final_info"]
        assert {k for k in ended if not k.startswith("_")} == set(ref)
        for k, v in ref.items():
            assert (ended[f"_{k}"] == info["_final_info"]).all(), k
            assert np.shape(ended[k]) == (n, *np.shape(v)), k
        info = {k: v for k, v in info.items() if k not in ("final_info", "_final_info", "final_obs", "_final_obs")}
    assert {k for k in info if not k.startswith("_")} == set(ref)
    for k, v in ref.items():
        assert info[f"_{k}"].all(), f"info[{k!r}] missing in some env"  # every env reported every key
        assert np.shape(info[k]) == (n, *np.shape(v)), k
        assert np.isfinite(np.asarray(info[k], dtype=float)).all(), k
    count = info["position_errors_count"]
    width = np.shape(ref["position_errors_m"])[0]
    assert ((count >= 0) & (count <= width)).all()
    pad = np.arange(width)[None, :] >= count[:, None]
    assert (info["position_errors_m"][pad] == 0.0).all()  # documented pad value
    assert (info["position_errors_m"] >= 0.0).all()


@pytest.mark.parametrize("autoreset_mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
@pytest.mark.parametrize("mode", ["sync", "async"])
@pytest.mark.parametrize("env_id", IDS)
def test_gymnasium_vector_envs_run_2000_steps(env_id, mode, autoreset_mode):
    """sync: TOTAL_STEPS steps. async: the same episodes (the same reset seeds and sampled actions, measured equal
    step by step), so its per-step checks would repeat the sync case's on the same data; what it adds is the worker
    processes, the shared-memory observations and the pickled infos of a step, a reset and an autoreset, so it stops
    ASYNC_STEPS_AFTER_THE_EPISODE_ENDS steps after every env has ended an episode (one 61-140-scan episode each: was
    TOTAL_STEPS too, 2-5.5 s a case, now 0.7-2 s)."""
    ref = _reference_info(env_id)
    with time_limit(240):
        envs = gym.make_vec(
            env_id, num_envs=NUM_ENVS, vectorization_mode=mode, vector_kwargs={"autoreset_mode": autoreset_mode}
        )
        try:
            obs, info = envs.reset(seed=list(range(NUM_ENVS)))
            _check_vector_info(info, ref, NUM_ENVS)
            envs.action_space.seed(0)
            n_done, ended, after = 0, np.zeros(NUM_ENVS, bool), 0
            for _ in range(TOTAL_STEPS // NUM_ENVS):
                obs, reward, terminated, truncated, info = envs.step(envs.action_space.sample())
                assert envs.observation_space.contains(obs)
                assert np.isfinite(obs).all()
                assert np.isfinite(reward).all() and (reward <= 0).all()
                _check_vector_info(info, ref, NUM_ENVS)
                assert not terminated.any()  # the scenario's horizon truncates (Gymnasium convention)
                n_done += int(truncated.sum())
                if mode == "async" and ended.all():
                    after += 1
                    if after == ASYNC_STEPS_AFTER_THE_EPISODE_ENDS:
                        break
                ended |= truncated
            assert n_done >= NUM_ENVS  # every env ran past at least one episode end
        finally:
            envs.close()


def _sb3_cases():
    """Every id with DummyVecEnv; with SubprocVecEnv on SUBPROC_BY_DEFAULT's ids, ``slow`` on the others. A slow case
    is covered by the default run's ``[<its id>-dummy]`` (the id's envs, steps and infos), the ``-subproc`` cases of
    SUBPROC_BY_DEFAULT (the worker processes and pipes) and
    test_imports.py::test_gymnasium_make_finds_every_registered_id (every id made by ``"uwb_env:<id>"`` in a fresh
    interpreter)."""
    for env_id in IDS:
        yield pytest.param(env_id, "dummy", id=f"{env_id}-dummy")
        slow = () if env_id in SUBPROC_BY_DEFAULT else (pytest.mark.slow,)
        yield pytest.param(env_id, "subproc", marks=slow, id=f"{env_id}-subproc")


@pytest.mark.parametrize(("env_id", "vec_kind"), list(_sb3_cases()))
def test_sb3_vector_envs_run_2000_steps(env_id, vec_kind):
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    ref = _reference_info(env_id)
    cls = DummyVecEnv if vec_kind == "dummy" else SubprocVecEnv
    n = NUM_ENVS if vec_kind == "dummy" else 2  # two worker processes: each one imports the package (~4 s)
    with time_limit(240):
        # SubprocVecEnv starts its workers by forkserver: a fresh interpreter, so the id names the module that
        # registers it ("module:id", Gymnasium's form) -- the same id works in the main process
        venv = make_vec_env(f"uwb_env:{env_id}", n_envs=n, seed=0, vec_env_cls=cls)
        try:
            obs = venv.reset()
            rng = np.random.default_rng(0)
            n_done = 0
            for _ in range(TOTAL_STEPS // n):
                actions = rng.integers(0, venv.action_space.n, n)
                obs, rewards, dones, infos = venv.step(actions)
                assert np.isfinite(obs).all() and np.isfinite(rewards).all()
                for info, done in zip(infos, dones, strict=True):
                    keys = set(info) - {"terminal_observation", "TimeLimit.truncated", "episode"}
                    assert keys == set(ref)
                    for k, v in ref.items():
                        assert np.shape(info[k]) == np.shape(v), k
                    if done:
                        assert info["TimeLimit.truncated"]  # SB3 bootstraps through the truncation
                        assert np.isfinite(info["terminal_observation"]).all()
                        n_done += 1
            assert n_done >= n
        finally:
            venv.close()


def test_rllib_ppo_with_two_envs_per_runner():
    """RLlib's new API stack vectorises with ``gym.make_vec``: one training iteration on two envs per runner."""
    ray = pytest.importorskip("ray")
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.utils.metrics import ENV_RUNNER_RESULTS, NUM_ENV_STEPS_SAMPLED_LIFETIME

    ray.init(num_cpus=2, include_dashboard=False, ignore_reinit_error=True, log_to_driver=False)
    try:
        config = (
            PPOConfig()
            .environment("uwb_env/IndoorSensorSubset-v1")
            .env_runners(num_env_runners=0, num_envs_per_env_runner=2, rollout_fragment_length=64)
            .training(train_batch_size_per_learner=128, minibatch_size=64, num_epochs=1)
            .debugging(seed=0)
        )
        algo = config.build_algo() if hasattr(config, "build_algo") else config.build()
        try:
            result = algo.train()
            assert result[ENV_RUNNER_RESULTS][NUM_ENV_STEPS_SAMPLED_LIFETIME] >= 128
        finally:
            algo.stop()
    finally:
        ray.shutdown()


@pytest.mark.slow
@pytest.mark.parametrize("env_id", IDS)
def test_async_vector_env_in_fresh_interpreters(env_id):
    """forkserver / spawn workers import nothing from the parent: the ``"module:id"`` form registers the ids there."""
    ref = _reference_info(env_id)
    with time_limit(300):
        envs = gym.make_vec(
            f"uwb_env:{env_id}", num_envs=2, vectorization_mode="async", vector_kwargs={"context": "forkserver"}
        )
        try:
            envs.reset(seed=[0, 1])
            envs.action_space.seed(0)
            for _ in range(TOTAL_STEPS // 2):
                obs, reward, _, _, info = envs.step(envs.action_space.sample())
                assert np.isfinite(obs).all() and np.isfinite(reward).all()
                _check_vector_info(info, ref, 2)
        finally:
            envs.close()
