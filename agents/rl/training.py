r"""Training RL schedulers with stable-baselines3 / sb3-contrib on the registered environments (issue 6).

The pieces an RL-Zoo user expects, kept small:

* :data:`ALGORITHMS`: ``ppo``, ``a2c``, ``dqn`` (stable-baselines3) and ``maskable-ppo`` (sb3-contrib; it reads the
  env's ``action_masks()``);
* :func:`load_preset`: versioned YAML hyper-parameters per env id (``agents/rl/presets/<Id>.yaml``), one block per
  algorithm and a ``common`` block (vector envs, normalisation, evaluation and checkpoint intervals);
* :func:`make_vec_env`: ``n_envs`` seeded copies (``DummyVecEnv`` or ``SubprocVecEnv``, each wrapped in
  ``Monitor``; or, ``vec_env: batched`` / ``--vectorize batched``, the batched vector env under
  :class:`~.batched_vec_env.BatchedVecEnv` in ``VecMonitor``) with ``VecNormalize`` when the preset asks for it;
* :class:`SchedulerEvalCallback`: every ``eval_freq`` steps the policy plays fixed evaluation seeds (never used for
  training) next to the myopic and round-robin schedulers, and the mean return and mean covariance trace of each are
  logged (``eval.csv``);
* :func:`train`: builds or resumes (``resume=True``: the latest checkpoint with its step counter, normaliser and
  replay buffer) and learns, writing checkpoints every ``checkpoint_freq`` steps, the final model and normaliser;
* :func:`train_seeds`: one such run per training seed into ``<out>/seed-<s>/`` (``uwb-env-train --seeds N``),
  skipping finished seeds, then ``<out>/learning_curves.png`` (IQM across seeds, ``uwb_env.agents.multiseed``).

Run directory layout: ``model.zip``, ``vecnormalize.pkl``, ``checkpoints/rl_model_<steps>_steps.zip`` (+
``rl_model_vecnormalize_<steps>_steps.pkl``, ``rl_model_replay_buffer_<steps>_steps.pkl``), ``progress.csv``,
``eval.csv``, ``run.yaml`` (the resolved configuration).
"""

from __future__ import annotations

import csv
import importlib.util
import inspect
import io
import json
import math
import os
import pickle
import re
import sys
import zipfile
from dataclasses import dataclass, field, replace
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
from stable_baselines3.common.logger import CSVOutputFormat, KVWriter, Logger, make_output_format
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecEnv, VecMonitor, VecNormalize
from tqdm.auto import tqdm

import uwb_env  # noqa: F401  (registers the env ids)
from uwb_env.agents.multiseed import is_multi_seed, plot_learning_curves, seed_folder
from uwb_env.agents.rl.imitation import DEMO_SEED0, demonstrate, warm_start
from uwb_env.agents.schedulers import check_scheduler_name, make_scheduler
from uwb_env.agents.storage import FolderLock, atomic_write, atomic_write_text, move_aside, read_error
from uwb_env.envs import ENV_IDS

ALGORITHMS: dict[str, type[BaseAlgorithm]] = {"ppo": PPO, "a2c": A2C, "dqn": DQN, "maskable-ppo": MaskablePPO}
ACTOR_CRITIC = ("ppo", "a2c", "maskable-ppo")  # the algorithms a behaviour-cloning warm start can fit (bc_steps)
EVAL_SEED0 = 1_000_000  # evaluation seeds start here; training seeds are seed .. seed + n_envs - 1 (and resets)
_CHECKPOINT = re.compile(r"rl_model_(\d+)_steps\.zip$")
VEC_ENVS = ("dummy", "subproc", "batched")  # --vectorize / the preset's common.vec_env


def make_batched(env_id: str, n_envs: int, env_kwargs: dict[str, Any]) -> VecEnv:
    """The batched vector env as SB3's ``VecEnv``; ``ValueError`` naming ``--vectorize batched`` when unsupported."""
    from uwb_env.agents.rl.batched_vec_env import make_batched_vec_env

    if gym.spec(env_id).vector_entry_point is None:
        raise ValueError(
            f"--vectorize batched on {env_id}: it has no batched vector env (a scene-family id: every episode a "
            "different scene); use --vectorize dummy or subproc"
        )
    try:
        return make_batched_vec_env(env_id, n_envs, env_kwargs)
    except ValueError as e:
        raise ValueError(f"--vectorize batched with --env-kwarg {env_kwargs} on {env_id}: {e}") from e


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
    """``n_envs`` copies of ``env_id`` (seeds ``seed + i``), in ``Monitor``, optionally under ``VecNormalize``.

    ``vec_env``: ``dummy`` / ``subproc`` (SB3's, each env in ``Monitor``) or ``batched`` (one batched
    ``UWBVectorEnv`` under :class:`~.batched_vec_env.BatchedVecEnv` in ``VecMonitor``: the same episodes env by env,
    parametric fidelity and ``imm-lmipda`` tracker only, ``ValueError`` naming ``--vectorize batched`` otherwise).
    """
    kwargs = dict(env_kwargs or {})

    def factory(i: int):
        def make() -> gym.Env:
            env = Monitor(gym.make(env_id, **kwargs))
            env.reset(seed=seed + i)
            return env

        return make

    if vec_env not in VEC_ENVS:
        raise ValueError(f"vec_env={vec_env!r}: must be one of {sorted(VEC_ENVS)}")
    if vec_env == "batched":
        venv: VecEnv = VecMonitor(make_batched(env_id, n_envs, kwargs))
    else:
        fns = [factory(i) for i in range(n_envs)]
        venv = SubprocVecEnv(fns, start_method="fork") if vec_env == "subproc" else DummyVecEnv(fns)
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


EVAL_COLUMNS = ["timesteps", "return", "trace_m2", "myopic_return", "myopic_trace_m2", "round_robin_return",
                "round_robin_trace_m2"]  # fmt: skip
"""The columns of ``eval.csv`` (both engines)."""


class EvalTable:
    """The policy on fixed evaluation seeds next to the myopic and round-robin schedulers: rows of ``eval.csv``.

    The baselines are played once, on first use; both engines (SB3 here, RLlib in ``rllib_engine``) append to it.
    """

    def __init__(self, env_id: str, env_kwargs: dict, n_episodes: int, path: Path) -> None:
        self.env = gym.make(env_id, **env_kwargs).unwrapped
        self.seeds = list(range(EVAL_SEED0, EVAL_SEED0 + n_episodes))
        self.path = path
        self.baselines: dict[str, EvalResult] = {}

    def prepare(self) -> None:
        """Play the baselines on the evaluation seeds (once)."""
        for name in ("myopic", "round-robin"):
            if name not in self.baselines:
                sched = make_scheduler(name)
                sched.reset(0)
                self.baselines[name] = evaluate_policy_on_seeds(sched.act, self.env, self.seeds)

    def evaluate(self, act, timesteps: int) -> EvalResult:
        """Play ``act(obs, env)`` on the evaluation seeds and append a row (``timesteps``) to ``eval.csv``."""
        self.prepare()
        res = evaluate_policy_on_seeds(act, self.env, self.seeds)
        new = not self.path.exists()
        with self.path.open("a", newline="") as f:
            w = csv.writer(f)
            if new:
                w.writerow(EVAL_COLUMNS)
            m, rr = self.baselines["myopic"], self.baselines["round-robin"]
            w.writerow([timesteps, res.mean_return, res.mean_trace, m.mean_return, m.mean_trace, rr.mean_return,
                        rr.mean_trace])  # fmt: skip
        return res


class SchedulerEvalCallback(BaseCallback):
    """Evaluate the policy every ``eval_freq`` steps on fixed seeds next to myopic and round-robin (``EvalTable``)."""

    def __init__(self, env_id: str, env_kwargs: dict, n_episodes: int, eval_freq: int, path: Path) -> None:
        super().__init__()
        self.table = EvalTable(env_id, env_kwargs, n_episodes, path)
        self.eval_freq = eval_freq
        self._last = 0

    def _on_training_start(self) -> None:
        self.table.prepare()
        self._last = self.num_timesteps

    def _on_step(self) -> bool:
        if self.num_timesteps - self._last >= self.eval_freq:
            self._last = self.num_timesteps
            self.evaluate()
        return True

    def evaluate(self) -> EvalResult:
        """Evaluate now and append a row to the CSV."""
        agent = PolicyScheduler(self.model, self.training_env if isinstance(self.training_env, VecNormalize) else None)
        res = self.table.evaluate(agent.act, self.num_timesteps)
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


def _read_yaml(path: Path, what: str) -> dict[str, Any]:
    """A YAML mapping, or ``ValueError`` naming the file when it is damaged."""
    with read_error(path, what):
        data = yaml.safe_load(path.read_text())
        if not isinstance(data, dict):
            raise TypeError(f"a YAML {type(data).__name__}, not a mapping")
    return data


def _load_normalizer(path: Path) -> VecNormalize:
    """A saved ``VecNormalize`` (its statistics only, no env behind it), or ``ValueError`` naming the file."""
    with read_error(path, "a VecNormalize pickle (the observation normaliser)"), path.open("rb") as f:
        normalizer = pickle.load(f)  # our own run's file
        if not isinstance(normalizer, VecNormalize):
            raise TypeError(f"a pickled {type(normalizer).__name__}, not a VecNormalize")
    return normalizer


def load_scheduler(run: str | Path) -> PolicyScheduler:
    """A trained run (its directory, or a model zip with ``vecnormalize.pkl`` beside it) as a scheduler.

    A damaged ``run.yaml``, model zip or ``vecnormalize.pkl`` raises ``ValueError`` naming the file.
    """
    path = Path(run)
    zip_path = path / "model.zip" if path.is_dir() else path
    if not zip_path.is_file():
        raise FileNotFoundError(f"rl model {str(zip_path)!r} not found (a run directory or a model .zip)")
    run_yaml = zip_path.parent / "run.yaml"
    if not run_yaml.is_file():
        raise FileNotFoundError(f"{str(run_yaml)!r} not found: a trained run keeps its env id and algorithm there")
    cfg = _read_yaml(run_yaml, "a training run's configuration (YAML mapping with env_id and algo)")
    if cfg.get("algo") not in ALGORITHMS:
        raise ValueError(f"{run_yaml}: algo={cfg.get('algo')!r} must be one of {sorted(ALGORITHMS)}")
    th.set_num_threads(1)  # a small MLP: one thread is fastest, and campaign workers must not oversubscribe
    with read_error(zip_path, f"a saved {cfg['algo']} model (zip)"):
        model = ALGORITHMS[cfg["algo"]].load(zip_path, device="cpu")
    norm = zip_path.parent / "vecnormalize.pkl"
    normalizer = None
    if norm.is_file():
        normalizer = _load_normalizer(norm)
        normalizer.training = False
    return PolicyScheduler(model, normalizer)


# ------------------------------------------------------------------------------------------ configuration checks
COMMON_KEYS = ("n_envs", "vec_env", "normalize", "eval_freq", "eval_episodes", "checkpoint_freq", "bc_steps",
               "bc_scheduler", "bc_epochs")  # fmt: skip
"""The preset's ``common`` keys. ``bc_steps`` > 0: a behaviour-cloning warm start from ``bc_scheduler`` (default
``myopic``) on that many demonstration steps, ``bc_epochs`` (default 20) passes (``agents/rl/imitation.py``)."""
RESERVED = {  # constructor arguments the command sets itself
    "env": "the env is --env with --env-kwarg",
    "seed": "use --seed",
    "tensorboard_log": "use --tensorboard (logs to <out>/tensorboard)",
    "device": "training runs on the CPU",
    "verbose": "progress goes to progress.csv",
    "_init_setup_model": "internal to stable-baselines3",
}
POSITIVE_INTS = {"n_envs", "eval_freq", "eval_episodes", "checkpoint_freq", "n_steps", "batch_size", "n_epochs",
                 "buffer_size", "train_freq", "target_update_interval", "gradient_steps", "bc_epochs"}  # fmt: skip
UNIT_INTERVAL = {"gamma", "gae_lambda", "exploration_fraction", "exploration_initial_eps", "exploration_final_eps"}


def allowed_keys(algo: str) -> set[str]:
    """The ``--hyper`` keys for ``algo``: the preset's common keys and the algorithm's constructor arguments."""
    params = inspect.signature(ALGORITHMS[algo].__init__).parameters
    return (set(params) - {"self", "args", "kwargs"} - set(RESERVED)) | set(COMMON_KEYS)


def check_hyper(key: str, value: Any, preset_value: Any, algo: str) -> None:
    """Raise ``ValueError`` naming ``--hyper KEY``, the value and what is allowed."""
    if key in RESERVED:
        raise ValueError(f"--hyper {key}={value!r}: not a hyper-parameter ({RESERVED[key]})")
    if key not in allowed_keys(algo):
        raise ValueError(f"--hyper {key}={value!r}: unknown for {algo}; must be one of {sorted(allowed_keys(algo))}")
    is_int = isinstance(value, int) and not isinstance(value, bool)
    if key in POSITIVE_INTS and (not is_int or value < 1):
        raise ValueError(f"--hyper {key}={value!r}: must be an integer >= 1")
    if key in ("learning_starts", "bc_steps") and (not is_int or value < 0):
        raise ValueError(f"--hyper {key}={value!r}: must be an integer >= 0")
    if key == "bc_steps" and value > 0 and algo not in ACTOR_CRITIC:
        raise ValueError(f"--hyper bc_steps={value}: the warm start needs an actor-critic algorithm "
                         f"({', '.join(ACTOR_CRITIC)}), not {algo}")  # fmt: skip
    number = isinstance(value, int | float) and not isinstance(value, bool)
    if key in UNIT_INTERVAL and (not number or not 0.0 <= value <= 1.0):
        raise ValueError(f"--hyper {key}={value!r}: must be a number in [0, 1]")
    if key in ("learning_rate", "ent_coef", "vf_coef", "max_grad_norm", "tau") and (not number or value < 0):
        raise ValueError(f"--hyper {key}={value!r}: must be a number >= 0")
    if key == "vec_env" and value not in VEC_ENVS:
        raise ValueError(f"--hyper vec_env={value!r}: must be 'dummy' or 'subproc' (SB3's) or 'batched' (the batched "
                         "vector env, as --vectorize batched)")  # fmt: skip
    if key == "bc_scheduler":
        if not isinstance(value, str) or value.startswith(("rl:", "rllib:")):
            raise ValueError(f"--hyper bc_scheduler={value!r}: must name a scheduler of this package (myopic, "
                             "lookahead-2, ...), not a trained run")  # fmt: skip
        check_scheduler_name(value)
    if key == "normalize" and not (value is False or value is None or isinstance(value, dict)):
        raise ValueError(f"--hyper normalize={value!r}: must be false or a mapping of VecNormalize arguments")
    if preset_value is not None and type(preset_value) is bool and type(value) is not bool:
        raise ValueError(f"--hyper {key}={value!r}: must be true or false")
    if isinstance(preset_value, dict) and not isinstance(value, dict):
        raise ValueError(f"--hyper {key}={value!r}: must be a mapping, e.g. {key}={json.dumps(preset_value)}")
    if key == "policy" and value not in ALGORITHMS[algo].policy_aliases:
        raise ValueError(f"--hyper policy={value!r}: must be one of {sorted(ALGORITHMS[algo].policy_aliases)}")


@dataclass
class TrainConfig:
    """Everything one training run needs (written to ``run.yaml``); checked when built."""

    env_id: str
    algo: str
    timesteps: int
    out: Path
    seed: int = 0
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    overrides: dict[str, Any] = field(default_factory=dict)  # replace preset entries ("n_envs", "learning_rate", ...)
    tensorboard: bool = False  # also log to <out>/tensorboard (needs the tensorboard package)
    vectorize: str | None = None  # replaces the preset's common.vec_env: dummy, subproc or batched (--vectorize)

    def __post_init__(self) -> None:
        self.out = Path(self.out)
        if self.env_id not in ENV_IDS:
            raise ValueError(f"env_id={self.env_id!r}: must be one of {sorted(ENV_IDS)}")
        if self.algo not in ALGORITHMS:
            raise ValueError(f"algo={self.algo!r}: must be one of {sorted(ALGORITHMS)}")
        for name, low in (("timesteps", 1), ("seed", 0)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise ValueError(f"{name}={value!r}: must be an integer >= {low}")
        for name in ("env_kwargs", "overrides"):
            if not isinstance(getattr(self, name), dict):
                raise ValueError(f"{name}={getattr(self, name)!r}: must be a mapping")
        if self.vectorize is not None and self.vectorize not in VEC_ENVS:
            raise ValueError(f"vectorize={self.vectorize!r} (--vectorize): must be one of {sorted(VEC_ENVS)}")
        if not isinstance(self.tensorboard, bool):
            raise ValueError(f"tensorboard={self.tensorboard!r}: must be true or false")
        if self.tensorboard and importlib.util.find_spec("tensorboard") is None:
            raise ValueError("tensorboard=True: the tensorboard package is not installed (pip install tensorboard)")
        if self.out.exists() and not self.out.is_dir():
            raise ValueError(f"out={str(self.out)!r}: is a file (must be a folder, existing or new)")


def resolve(cfg: TrainConfig) -> tuple[dict[str, Any], dict[str, Any], int]:
    """The preset's ``common`` and algorithm blocks with ``cfg.overrides`` applied (each checked), and its version."""
    preset = load_preset(cfg.env_id, cfg.algo)
    common, hyper = preset["common"], preset["algo"]
    for key, value in cfg.overrides.items():
        target = common if key in COMMON_KEYS else hyper
        check_hyper(key, value, target.get(key), cfg.algo)
        target[key] = value
    if cfg.vectorize is not None:
        common["vec_env"] = cfg.vectorize
    return common, hyper, preset["version"]


def check_env(cfg: TrainConfig) -> None:
    """Build the env once with ``cfg.env_kwargs`` (``ValueError`` naming them when the env refuses them)."""
    try:
        gym.make(cfg.env_id, **cfg.env_kwargs).close()
    except (TypeError, ValueError, KeyError) as e:
        why = e.args[0] if isinstance(e, KeyError) and e.args else e  # a KeyError's str() adds quotes
        raise ValueError(f"--env-kwarg {cfg.env_kwargs} on {cfg.env_id}: {why}") from e


# ------------------------------------------------------------------------------------------------ checkpoints
def checkpoints(out: Path) -> list[tuple[int, Path]]:
    """Every ``checkpoints/rl_model_<steps>_steps.zip`` of a run, newest first."""
    found = [(int(m.group(1)), p) for p in (out / "checkpoints").glob("rl_model_*_steps.zip")
             if (m := _CHECKPOINT.search(p.name))]  # fmt: skip
    return sorted(found, reverse=True)


def latest_checkpoint(out: Path) -> tuple[Path, int] | None:
    """The newest ``checkpoints/rl_model_<steps>_steps.zip`` of a run and its step count."""
    found = checkpoints(out)
    return (found[0][1], found[0][0]) if found else None


def load_checkpoint(cls: type[BaseAlgorithm], path: Path, steps: int, venv: VecEnv, normalize: bool):
    """A checkpoint's model (on ``venv``, under its saved normaliser when ``normalize``) and replay buffer."""
    folder = path.parent
    if normalize:
        norm = folder / f"rl_model_vecnormalize_{steps}_steps.pkl"
        if not norm.is_file():
            raise FileNotFoundError(f"{norm.name} is missing")
        saved = _load_normalizer(norm)
        saved.set_venv(venv)
        venv = saved
    model = cls.load(path, env=venv, device="cpu")
    buf = folder / f"rl_model_replay_buffer_{steps}_steps.pkl"
    if hasattr(model, "replay_buffer") and buf.is_file():
        model.load_replay_buffer(buf)
    return model, venv


def resume_from(cls: type[BaseAlgorithm], out: Path, venv: VecEnv, normalize: bool):
    """The newest checkpoint that loads, falling back to older ones; says which it used and which were damaged.

    A damaged checkpoint (its zip, normaliser or replay buffer does not load) is moved aside (``*.damaged``) so
    that the run's checkpoints stay readable. Returns ``(model, venv, steps)``, or ``None`` without checkpoints.
    """
    for steps, path in checkpoints(out):
        try:
            model, wrapped = load_checkpoint(cls, path, steps, venv, normalize)
        except Exception as e:  # any failure to read it: a damaged or partial checkpoint
            reason = f"checkpoint at {steps} steps does not load ({type(e).__name__}: {e})"
            move_aside(path, reason, "trying the previous one")
            continue
        print(f"resuming from {path} at {steps} steps", file=sys.stderr)
        return model, wrapped, steps
    return None


# ------------------------------------------------------------------------------------------------- the logs
class AppendingCSV(CSVOutputFormat):
    """SB3's CSV log, continuing an existing file (its header's keys kept) instead of overwriting it."""

    def __init__(self, filename: str) -> None:
        path = Path(filename)
        self.file = path.open("r+" if path.is_file() else "w+")
        header = self.file.readline().strip()
        self.keys = header.split(",") if header else []
        self.separator, self.quotechar = ",", '"'
        self.file.seek(0, os.SEEK_END)


def keep_rows_up_to(path: Path, column: str, steps: int) -> None:
    """Drop the rows of a CSV log beyond ``steps`` (they are played again from the checkpoint), atomically.

    A resumed run's logs then continue the history without a gap or a repeat. A cut last line is dropped too.
    """
    if not path.is_file():
        return
    with read_error(path, f"a CSV log with a {column!r} column"):
        rows = list(csv.reader(path.read_text().splitlines()))
        if not rows:
            return
        j = rows[0].index(column)
    kept = [rows[0]] + [row for row in rows[1:] if len(row) == len(rows[0]) and _at_most(row[j], steps)]
    buffer = io.StringIO()
    csv.writer(buffer, lineterminator="\n").writerows(kept)
    atomic_write_text(path, buffer.getvalue())


def _at_most(value: str, steps: int) -> bool:
    try:
        return float(value) <= steps
    except ValueError:
        return False


def make_logger(out: Path, tensorboard: bool) -> Logger:
    """``progress.csv`` (continued when it exists) and, when asked, TensorBoard under ``<out>/tensorboard``."""
    formats: list[KVWriter] = [AppendingCSV(str(out / "progress.csv"))]
    if tensorboard:
        formats.append(make_output_format("tensorboard", str(out / "tensorboard")))
    return Logger(str(out), formats)


# --------------------------------------------------------------------------------------------------- training
def train(cfg: TrainConfig, resume: bool = False, progress: bool = True) -> BaseAlgorithm:
    """Build (or resume) and train; returns the model. See the module docstring for the files written.

    Every argument is checked (the preset overrides, the env arguments) before anything is written. The run's
    folder is locked while training (:class:`~uwb_env.agents.storage.FolderLock`). A folder that already holds a
    run is refused unless ``resume``; a resumed run must match its ``run.yaml`` (``timesteps`` may grow), continues
    its logs from the checkpoint it resumes (rows beyond it dropped) and falls back to an older checkpoint when the
    newest is damaged.
    """
    common, hyper, version = resolve(cfg)
    check_env(cfg)
    if common.get("vec_env") == "batched":
        make_batched(cfg.env_id, 1, cfg.env_kwargs).close()  # refused before anything is written
    out = cfg.out
    if is_multi_seed(out):
        raise ValueError(f"{out}: holds a multi-seed run (seed-<s>/ folders); add --seeds N, or use another --out")
    meta = run_record(cfg, common, hyper, version)
    with FolderLock(out, "training"):
        check_run_folder(out, meta, resume, RESUME_FIXED)
        return _train(cfg, common, hyper, resume, progress, yaml.safe_dump(meta, sort_keys=True))


RESUME_FIXED = ("env_id", "algo", "seed", "env_kwargs", "common", "hyper")  # a resumed run's run.yaml must match


def run_record(cfg: TrainConfig, common: dict, hyper: dict, version: int) -> dict[str, Any]:
    """The run's ``run.yaml``: the configuration resolved from the preset and the overrides."""
    return {
        "env_id": cfg.env_id,
        "algo": cfg.algo,
        "seed": cfg.seed,
        "timesteps": cfg.timesteps,
        "env_kwargs": cfg.env_kwargs,
        "preset_version": version,
        "common": common,
        "hyper": hyper,
    }


def check_run_folder(out: Path, run_yaml: dict, resume: bool, fixed: tuple[str, ...]) -> None:
    """Refuse a folder that holds a run unless ``resume``; a resumed run must match its ``run.yaml`` on ``fixed``."""
    meta = out / "run.yaml"
    if meta.is_file() and not resume:
        raise ValueError(f"{out}: already holds a training run ({meta}); use --resume or another --out")
    if resume and meta.is_file():
        old = _read_yaml(meta, "a training run's configuration (YAML mapping)")
        for key in fixed:
            if old.get(key) != run_yaml[key]:
                raise ValueError(f"--resume: {key} = {run_yaml[key]!r} differs from the run's {old.get(key)!r}")


def _train(cfg: TrainConfig, common: dict, hyper: dict, resume: bool, progress: bool, meta: str) -> BaseAlgorithm:
    """Build or restore the model, then write ``run.yaml`` (so a model the arguments cannot build leaves no run).

    Torch runs on one thread: the policies are small MLPs, for which one thread is fastest, and torch's default (one
    per core, spinning while they wait) made several training processes on one machine crawl: four on these 2-core
    machines trained at ~30-60 steps/s each, and at ~370-920 with one thread each.
    """
    th.set_num_threads(1)
    out = cfg.out
    normalize = common.get("normalize")
    venv = make_vec_env(cfg.env_id, int(common.get("n_envs", 1)), cfg.seed, cfg.env_kwargs,
                        common.get("vec_env", "dummy"))  # fmt: skip
    cls = ALGORITHMS[cfg.algo]
    restored = resume_from(cls, out, venv, bool(normalize)) if resume else None
    if restored is not None:
        model, venv, steps = restored
    else:
        if resume:
            print(f"no readable checkpoint in {out / 'checkpoints'}: training from scratch", file=sys.stderr)
        steps = 0
        if normalize:
            venv = VecNormalize(venv, **normalize)
        kwargs = {k: v for k, v in hyper.items() if k != "policy"}
        try:
            model = cls(hyper.get("policy", "MlpPolicy"), venv, seed=cfg.seed, device="cpu", verbose=0, **kwargs)
        except (TypeError, ValueError, AssertionError) as e:  # SB3 asserts some of its arguments
            venv.close()
            raise ValueError(f"{cfg.algo} with hyper-parameters {hyper}: {type(e).__name__}: {e}") from e
    if restored is None and int(common.get("bc_steps", 0)) > 0:
        behaviour_clone(model, venv, cfg, common)
    atomic_write_text(out / "run.yaml", meta)
    keep_rows_up_to(out / "progress.csv", "time/total_timesteps", steps)
    keep_rows_up_to(out / "eval.csv", "timesteps", steps)
    model.set_logger(make_logger(out, cfg.tensorboard))
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
        model.learn(remaining, callback=CallbackList(callbacks), reset_num_timesteps=restored is None,
                    progress_bar=False)  # fmt: skip
    finally:
        model.logger.close()  # the CSV writer's file
    atomic_write(out / "model.zip", model.save)
    if isinstance(venv, VecNormalize):
        atomic_write(out / "vecnormalize.pkl", lambda f: pickle.dump(venv, f))
    venv.close()
    return model


def behaviour_clone(model: BaseAlgorithm, venv: VecEnv, cfg: TrainConfig, common: dict) -> dict[str, float]:
    """The warm start of ``agents/rl/imitation.py`` before PPO; writes its statistics to ``<out>/bc.yaml``."""
    scheduler = str(common.get("bc_scheduler", "myopic"))
    demos = demonstrate(cfg.env_id, cfg.env_kwargs, scheduler, int(common["bc_steps"]), DEMO_SEED0 + 10_000 * cfg.seed)
    stats = warm_start(model, venv, demos, int(common.get("bc_epochs", 20)), seed=cfg.seed)
    stats = {"scheduler": scheduler, **stats}
    atomic_write_text(cfg.out / "bc.yaml", yaml.safe_dump(stats, sort_keys=False))
    print(f"behaviour cloning from {scheduler}: {stats['steps']} steps, agreement {stats['agreement_train']:.3f} "
          f"(train) {stats['agreement_heldout']:.3f} (held-out episodes)", file=sys.stderr)  # fmt: skip
    return stats


# ----------------------------------------------------------------------------------------- several training seeds
def trained_steps(out: Path) -> int | None:
    """The step counter saved in a run's final ``model.zip`` (SB3 keeps it in the zip's ``data`` JSON).

    ``None`` when there is no final model yet, or it cannot be read (the run is then not finished: ``--resume``
    continues it from its checkpoints and writes a new one).
    """
    path = out / "model.zip"
    try:
        with zipfile.ZipFile(path) as z:
            return int(json.loads(z.read("data"))["num_timesteps"])
    except (OSError, KeyError, ValueError, TypeError, zipfile.BadZipFile):
        return None


SEED_PLANS = ("train", "resume", "finished")


def plan_seeds(cfg: TrainConfig, seeds: list[int], resume: bool) -> dict[int, str]:
    """What :func:`train_seeds` does with each seed's folder: ``train`` (new), ``resume`` or ``finished`` (skipped).

    A finished run is one whose ``model.zip`` holds at least ``cfg.timesteps`` steps; its ``run.yaml`` must match
    the configuration (else ``ValueError`` naming the key). An unfinished run is resumed with ``resume``, refused
    without it (``ValueError`` naming the folder), before any seed is trained.
    """
    common, hyper, version = resolve(cfg)
    plan = {}
    for seed in seeds:
        one = replace(cfg, seed=seed, out=seed_folder(cfg.out, seed))
        if not (one.out / "run.yaml").is_file():
            plan[seed] = "train"
            continue
        check_run_folder(one.out, run_record(one, common, hyper, version), True, RESUME_FIXED)
        steps = trained_steps(one.out)
        if steps is not None and steps >= cfg.timesteps:
            plan[seed] = "finished"
        elif resume:
            plan[seed] = "resume"
        else:
            done = f"its model.zip holds {steps} steps" if steps is not None else "no final model.zip"
            raise ValueError(
                f"{one.out}: an unfinished run of seed {seed} ({done}, --timesteps {cfg.timesteps}): "
                "use --resume to continue it, or another --out"
            )
    return plan


def train_seeds(cfg: TrainConfig, seeds: list[int], resume: bool = False, progress: bool = True) -> dict[int, str]:
    """Train one run per training seed into ``cfg.out/seed-<s>/`` (``uwb-env-train --seeds N``); the plan per seed.

    Each seed's run is exactly :func:`train` with ``seed=s, out=cfg.out/seed-<s>``. Seeds whose run finished are
    skipped, so a stopped multi-seed job run again continues where it stopped; with ``resume`` an interrupted run
    continues from its checkpoints (:func:`plan_seeds`). Everything is checked before anything is trained; the
    folder is locked throughout. At the end, ``cfg.out/learning_curves.png``
    (``uwb_env.agents.multiseed.plot_learning_curves``) when the seeds have evaluation logs.
    """
    if not seeds or len(set(seeds)) != len(seeds) or any(isinstance(s, bool) or s < 0 for s in seeds):
        raise ValueError(f"seeds={seeds!r}: must be distinct integers >= 0, at least one")
    common, _, _ = resolve(cfg)
    check_env(cfg)
    if common.get("vec_env") == "batched":
        make_batched(cfg.env_id, 1, cfg.env_kwargs).close()
    if (cfg.out / "run.yaml").is_file():
        raise ValueError(f"{cfg.out}: holds a single training run (run.yaml); a multi-seed run needs its own --out")
    with FolderLock(cfg.out, "multi-seed training"):
        plan = plan_seeds(cfg, seeds, resume)
        for seed in seeds:
            if plan[seed] == "finished":
                print(f"seed {seed}: finished in {seed_folder(cfg.out, seed)}, skipped", file=sys.stderr)
                continue
            print(f"seed {seed}: {'resuming' if plan[seed] == 'resume' else 'training'}", file=sys.stderr)
            one = replace(cfg, seed=seed, out=seed_folder(cfg.out, seed))
            train(one, resume=plan[seed] == "resume", progress=progress)
        try:
            plot_learning_curves(cfg.out)
        except ValueError as e:  # no evaluation yet (eval_freq beyond the budget)
            print(f"no learning curves: {e}", file=sys.stderr)
    return plan
