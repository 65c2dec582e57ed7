r"""Training RL schedulers with stable-baselines3 / sb3-contrib on the registered environments (issue 6).

The pieces an RL-Zoo user expects, kept small:

* :data:`ALGORITHMS`: ``ppo``, ``a2c``, ``dqn`` (stable-baselines3) and ``maskable-ppo`` (sb3-contrib; it reads the
  env's ``action_masks()``);
* :func:`load_preset`: versioned YAML hyper-parameters per env id (``agents/rl/presets/<Id>.yaml``), one block per
  algorithm and a ``common`` block (vector envs, normalisation, evaluation and checkpoint intervals);
* :func:`make_vec_env`: ``n_envs`` seeded copies (``DummyVecEnv`` or ``SubprocVecEnv``, each wrapped in
  ``Monitor``) with ``VecNormalize`` when the preset asks for it;
* :class:`SchedulerEvalCallback`: every ``eval_freq`` steps the policy plays fixed evaluation seeds (never used for
  training) next to the myopic and round-robin schedulers, and the mean return and mean covariance trace of each are
  logged (``eval.csv``);
* :func:`train`: builds or resumes (``resume=True``: the latest checkpoint with its step counter, normaliser and
  replay buffer) and learns, writing checkpoints every ``checkpoint_freq`` steps, the final model and normaliser.

Run directory layout: ``model.zip``, ``vecnormalize.pkl``, ``checkpoints/rl_model_<steps>_steps.zip`` (+
``rl_model_vecnormalize_<steps>_steps.pkl``, ``rl_model_replay_buffer_<steps>_steps.pkl``), ``progress.csv``,
``eval.csv``, ``run.yaml`` (the resolved configuration).
"""

from __future__ import annotations

import csv
import math
import pickle
import re
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch as th
import yaml
from sb3_contrib import MaskablePPO
from stable_baselines3 import A2C, DQN, PPO
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.callbacks import BaseCallback, CallbackList, CheckpointCallback
from stable_baselines3.common.logger import configure
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecEnv, VecNormalize
from tqdm.auto import tqdm

import uwb_env  # noqa: F401  (registers the env ids)
from uwb_env.agents.schedulers import make_scheduler

ALGORITHMS: dict[str, type[BaseAlgorithm]] = {"ppo": PPO, "a2c": A2C, "dqn": DQN, "maskable-ppo": MaskablePPO}
EVAL_SEED0 = 1_000_000  # evaluation seeds start here; training seeds are seed .. seed + n_envs - 1 (and resets)
_CHECKPOINT = re.compile(r"rl_model_(\d+)_steps\.zip$")


def load_preset(env_id: str, algo: str) -> dict[str, Any]:
    """The preset of ``env_id`` for ``algo``: ``{"version", "common": {...}, "algo": {...}}``."""
    if algo not in ALGORITHMS:
        raise ValueError(f"algo={algo!r}: must be one of {sorted(ALGORITHMS)}")
    name = env_id.split("/")[-1] + ".yaml"
    path = resources.files("uwb_env.agents.rl") / "presets" / name
    if not path.is_file():
        raise ValueError(f"env_id={env_id!r}: no preset agents/rl/presets/{name}")
    data = yaml.safe_load(path.read_text())
    if algo not in data:
        raise ValueError(
            f"preset {name} has no block for algo={algo!r} (has {sorted(set(data) - {'version', 'common'})})"
        )
    return {"version": data["version"], "common": dict(data.get("common", {})), "algo": dict(data[algo])}


def make_vec_env(
    env_id: str,
    n_envs: int,
    seed: int,
    env_kwargs: dict[str, Any] | None = None,
    vec_env: str = "dummy",
    normalize: dict[str, Any] | None = None,
) -> VecEnv:
    """``n_envs`` copies of ``env_id`` (seeds ``seed + i``), in ``Monitor``, optionally under ``VecNormalize``."""
    kwargs = dict(env_kwargs or {})

    def factory(i: int):
        def make() -> gym.Env:
            env = Monitor(gym.make(env_id, **kwargs))
            env.reset(seed=seed + i)
            return env

        return make

    if vec_env not in ("dummy", "subproc"):
        raise ValueError(f"vec_env={vec_env!r}: must be 'dummy' or 'subproc'")
    fns = [factory(i) for i in range(n_envs)]
    venv: VecEnv = SubprocVecEnv(fns, start_method="fork") if vec_env == "subproc" else DummyVecEnv(fns)
    venv.seed(seed)
    if normalize:
        venv = VecNormalize(venv, **normalize)
    return venv


@dataclass
class EvalResult:
    """Mean return and mean covariance trace over the evaluation seeds."""

    mean_return: float
    mean_trace: float


def evaluate_policy_on_seeds(act, env: gym.Env, seeds: list[int]) -> EvalResult:
    """Play ``act(obs, env) -> action`` on ``env`` for each seed; the mean return and mean target-trace [m^2]."""
    returns, traces = [], []
    for s in seeds:
        obs, _ = env.reset(seed=s)
        done, total = False, 0.0
        while not done:
            obs, r, term, trunc, info = env.step(act(obs, env))
            total += r
            if math.isfinite(info["target_covariance_trace"]) and info["target_covariance_trace"] > 0:
                traces.append(info["target_covariance_trace"])
            done = term or trunc
        returns.append(total)
    return EvalResult(float(np.mean(returns)), float(np.mean(traces)) if traces else math.nan)


class SchedulerEvalCallback(BaseCallback):
    """Evaluate the policy on fixed seeds next to the myopic and round-robin schedulers (``eval.csv``)."""

    def __init__(self, env_id: str, env_kwargs: dict, n_episodes: int, eval_freq: int, path: Path) -> None:
        super().__init__()
        self.env = gym.make(env_id, **env_kwargs).unwrapped
        self.seeds = list(range(EVAL_SEED0, EVAL_SEED0 + n_episodes))
        self.eval_freq, self.path = eval_freq, path
        self.baselines: dict[str, EvalResult] = {}
        self._last = 0

    def _on_training_start(self) -> None:
        for name in ("myopic", "round-robin"):
            sched = make_scheduler(name)
            sched.reset(0)
            self.baselines[name] = evaluate_policy_on_seeds(sched.act, self.env, self.seeds)
        self._last = self.num_timesteps

    def _on_step(self) -> bool:
        if self.num_timesteps - self._last >= self.eval_freq:
            self._last = self.num_timesteps
            self.evaluate()
        return True

    def evaluate(self) -> EvalResult:
        """Evaluate now and append a row to the CSV."""
        agent = PolicyScheduler(self.model, self.training_env if isinstance(self.training_env, VecNormalize) else None)
        res = evaluate_policy_on_seeds(agent.act, self.env, self.seeds)
        new = not self.path.exists()
        with self.path.open("a", newline="") as f:
            w = csv.writer(f)
            if new:
                w.writerow(
                    [
                        "timesteps",
                        "return",
                        "trace_m2",
                        "myopic_return",
                        "myopic_trace_m2",
                        "round_robin_return",
                        "round_robin_trace_m2",
                    ]
                )
            m, rr = self.baselines["myopic"], self.baselines["round-robin"]
            w.writerow(
                [
                    self.num_timesteps,
                    res.mean_return,
                    res.mean_trace,
                    m.mean_return,
                    m.mean_trace,
                    rr.mean_return,
                    rr.mean_trace,
                ]
            )
        self.logger.record("eval/return", res.mean_return)
        self.logger.record("eval/trace_m2", res.mean_trace)
        return res


class _ProgressBar(BaseCallback):
    """A tqdm bar over the timesteps still to learn."""

    def __init__(self, total: int) -> None:
        super().__init__()
        self.total = total

    def _on_training_start(self) -> None:
        self.bar = tqdm(total=self.total, unit="step", dynamic_ncols=True)

    def _on_step(self) -> bool:
        self.bar.update(self.training_env.num_envs)
        return True

    def _on_training_end(self) -> None:
        self.bar.close()


class PolicyScheduler:
    """A trained model as a :class:`agents.Scheduler`.

    Deterministic actions, the training normaliser's statistics, and the env's action masks for maskable policies.
    """

    def __init__(self, model: BaseAlgorithm, normalizer: VecNormalize | None = None) -> None:
        self.model = model
        self.normalizer = normalizer
        self.maskable = isinstance(model, MaskablePPO)

    def reset(self, seed: int | None = None) -> None:  # noqa: D102 - the protocol
        pass

    def act(self, obs: Any, env: gym.Env) -> int:  # noqa: D102 - the protocol
        x = np.asarray(obs, dtype=np.float32)[None]
        want = self.model.observation_space.shape
        if x.shape[1:] != want:
            raise ValueError(
                f"observation shape {x.shape[1:]} != {want}, the trained policy's: build the env with the training "
                "run's env_kwargs (run.yaml; e.g. include_lookahead=true, --env-kwarg in uwb-env-evaluate)"
            )
        if self.normalizer is not None:
            x = self.normalizer.normalize_obs(x)
        if self.maskable:
            action, _ = self.model.predict(x, deterministic=True, action_masks=env.unwrapped.action_masks()[None])
        else:
            action, _ = self.model.predict(x, deterministic=True)
        return int(np.asarray(action).reshape(-1)[0])


def load_scheduler(run: str | Path) -> PolicyScheduler:
    """A trained run (its directory, or a model zip with ``vecnormalize.pkl`` beside it) as a scheduler."""
    path = Path(run)
    zip_path = path / "model.zip" if path.is_dir() else path
    if not zip_path.is_file():
        raise FileNotFoundError(f"rl model {str(zip_path)!r} not found (a run directory or a model .zip)")
    run_yaml = zip_path.parent / "run.yaml"
    if not run_yaml.is_file():
        raise FileNotFoundError(f"{str(run_yaml)!r} not found: a trained run keeps its env id and algorithm there")
    cfg = yaml.safe_load(run_yaml.read_text())
    th.set_num_threads(1)  # a small MLP: one thread is fastest, and campaign workers must not oversubscribe
    model = ALGORITHMS[cfg["algo"]].load(zip_path, device="cpu")
    norm = zip_path.parent / "vecnormalize.pkl"
    normalizer = None
    if norm.is_file():  # only its statistics are needed: unpickled without an env behind it
        with norm.open("rb") as f:
            normalizer = pickle.load(f)  # our own run's file
        normalizer.training = False
    return PolicyScheduler(model, normalizer)


@dataclass
class TrainConfig:
    """Everything one training run needs (written to ``run.yaml``)."""

    env_id: str
    algo: str
    timesteps: int
    out: Path
    seed: int = 0
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    overrides: dict[str, Any] = field(default_factory=dict)  # replace preset entries ("n_envs", "learning_rate", ...)


def latest_checkpoint(out: Path) -> tuple[Path, int] | None:
    """The newest ``checkpoints/rl_model_<steps>_steps.zip`` of a run and its step count."""
    found = [
        (int(m.group(1)), p)
        for p in (out / "checkpoints").glob("rl_model_*_steps.zip")
        if (m := _CHECKPOINT.search(p.name))
    ]
    if not found:
        return None
    steps, path = max(found)
    return path, steps


def train(cfg: TrainConfig, resume: bool = False, progress: bool = True) -> BaseAlgorithm:
    """Build (or resume) and train; returns the model. See the module docstring for the files written."""
    preset = load_preset(cfg.env_id, cfg.algo)
    common, hyper = preset["common"], preset["algo"]
    for key, value in cfg.overrides.items():
        (common if key in common else hyper)[key] = value
    out = cfg.out
    out.mkdir(parents=True, exist_ok=True)
    run_yaml = {
        "env_id": cfg.env_id,
        "algo": cfg.algo,
        "seed": cfg.seed,
        "timesteps": cfg.timesteps,
        "env_kwargs": cfg.env_kwargs,
        "preset_version": preset["version"],
        "common": common,
        "hyper": hyper,
    }
    if resume and (out / "run.yaml").is_file():
        old = yaml.safe_load((out / "run.yaml").read_text())
        for key in ("env_id", "algo", "seed", "env_kwargs", "common", "hyper"):
            if old.get(key) != run_yaml[key]:
                raise ValueError(f"--resume: {key} = {run_yaml[key]!r} differs from the run's {old.get(key)!r}")
    (out / "run.yaml").write_text(yaml.safe_dump(run_yaml, sort_keys=True))
    ckpt = latest_checkpoint(out) if resume else None
    normalize = common.get("normalize")
    venv = make_vec_env(
        cfg.env_id,
        int(common.get("n_envs", 1)),
        cfg.seed,
        cfg.env_kwargs,
        common.get("vec_env", "dummy"),
        normalize if ckpt is None else None,  # a resumed run loads its normaliser from the checkpoint
    )
    cls = ALGORITHMS[cfg.algo]
    if ckpt is not None:
        path, steps = ckpt
        norm = out / "checkpoints" / f"rl_model_vecnormalize_{steps}_steps.pkl"
        if normalize:
            venv = VecNormalize.load(str(norm), venv)
        model = cls.load(path, env=venv, device="cpu")
        buf = out / "checkpoints" / f"rl_model_replay_buffer_{steps}_steps.pkl"
        if hasattr(model, "replay_buffer") and buf.is_file():
            model.load_replay_buffer(buf)
    else:
        kwargs = {k: v for k, v in hyper.items() if k != "policy"}
        model = cls(hyper.get("policy", "MlpPolicy"), venv, seed=cfg.seed, device="cpu", verbose=0, **kwargs)
    model.set_logger(configure(str(out), ["csv"]))
    n_envs = venv.num_envs
    callbacks: list[BaseCallback] = [
        CheckpointCallback(
            save_freq=max(1, int(common.get("checkpoint_freq", 10_000)) // n_envs),
            save_path=str(out / "checkpoints"),
            save_replay_buffer=True,
            save_vecnormalize=True,
        ),
        SchedulerEvalCallback(
            cfg.env_id,
            cfg.env_kwargs,
            int(common.get("eval_episodes", 5)),
            int(common.get("eval_freq", 10_000)),
            out / "eval.csv",
        ),
    ]
    remaining = max(0, cfg.timesteps - model.num_timesteps)
    if progress:
        callbacks.append(_ProgressBar(remaining))
    try:
        model.learn(remaining, callback=CallbackList(callbacks), reset_num_timesteps=ckpt is None, progress_bar=False)
    finally:
        model.logger.close()  # the CSV writer's file
    model.save(out / "model.zip")
    if isinstance(venv, VecNormalize):
        venv.save(str(out / "vecnormalize.pkl"))
    venv.close()
    return model
