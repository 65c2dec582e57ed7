r"""Training RL schedulers on RLlib's new API stack (issue 19, part 2): ``uwb-env-train --engine rllib``.

The same run folder and the same evaluation as the stable-baselines3 engine (:mod:`.training`), on Ray's
scale-out: ``--env-runners N`` Ray actors sample ``--envs-per-runner M`` envs each (on this machine, or spread
over a cluster started with ``ray start --head`` and joined with ``--address``), one learner updates the policy.

* :data:`RLLIB_ALGORITHMS`: ``ppo`` and ``dqn`` (off-policy), both masked: the invalid actions of the env's
  ``action_masks()`` are never sampled, explored or chosen;
* :class:`MaskedUWBEnv`: the env as RLlib sees it, ``Dict(action_mask, observations)``; the class travels to the
  runners by reference, so each runner imports uwb_env itself;
* :class:`MaskedUWBVectorEnv` (``--vectorize batched``): its vector counterpart over the batched
  ``uwb_env.envs.vector.UWBVectorEnv`` (the runner's envs stepped together, each stage batched), built by
  :func:`masked_uwb_env` when RLlib's runner asks for ``num_envs`` (``gym_env_vectorize_mode="vector_entry_point"``);
* :class:`MaskedPPOTorchRLModule` (PPO's default module, logits of invalid actions -inf: RLlib's action-masking
  example) and :class:`MaskedDQNTorchRLModule` (DQN's, Q-values of invalid actions -inf);
* :func:`train_rllib`: builds (or resumes from the newest readable checkpoint: module, optimiser, iteration and
  step counters) and trains up to ``timesteps`` sampled steps, checkpointing every ``checkpoint_every``
  iterations and at the end, evaluating the policy at each checkpoint against myopic and round-robin on the fixed
  evaluation seeds of the SB3 engine (``eval.csv``, same columns);
* :class:`RLlibPolicyScheduler` / :func:`load_rllib_scheduler`: the trained module as a campaign scheduler
  (``rllib:RUN_DIR``): the greedy action (PPO's logits, DQN's Q-values), invalid actions masked.

Hyper-parameters: the SB3 preset of the env (``agents/rl/presets/<Id>.yaml``) translated to RLlib's names
(:func:`rllib_hyper`), then ``--hyper KEY=VALUE`` with RLlib's names (``lr``, ``gamma``, ``lambda_``,
``entropy_coeff``, ``train_batch_size_per_learner``, ``minibatch_size``, ``num_epochs``, ``fcnet_hiddens``, ...
any argument of the algorithm config's ``training()``) and ``eval_episodes``.

Run folder: ``run.yaml`` (``engine: rllib``), ``checkpoints/iter_<iteration>/`` (``Algorithm.save_to_path``),
``policy/`` (the final RLModule, ``RLModule.from_checkpoint``), ``progress.csv``, ``eval.csv``.
"""

from __future__ import annotations

import csv
import inspect
import math
import os
import re
import shutil
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
import yaml

import uwb_env  # noqa: F401  (registers the env ids)
from uwb_env.agents.rl.training import (
    EvalTable,
    _read_yaml,
    check_env,
    check_run_folder,
    keep_rows_up_to,
    load_preset,
    make_batched,
)
from uwb_env.agents.storage import FolderLock, atomic_write_text, move_aside
from uwb_env.envs import ENV_IDS

RLLIB_ALGORITHMS = ("dqn", "ppo")
_CHECKPOINT = re.compile(r"^iter_(\d+)$")
LEARNER_MODULE = Path("learner_group", "learner", "rl_module", "default_policy")  # inside a checkpoint
PROGRESS_COLUMNS = ["training_iteration", "timesteps", "episode_return_mean", "episode_len_mean", "loss", "time_s"]
MODEL_KEYS = ("fcnet_hiddens", "fcnet_activation")  # --hyper keys that go to the module's model_config
COMMON_KEYS = ("eval_episodes",)
VECTORIZE = {"sync": "sync", "batched": "vector_entry_point"}  # --vectorize -> gym_env_vectorize_mode
MASKED_ENV_NAME = "uwb_env-masked"  # masked_uwb_env in RLlib's env registry (it takes classes or registered names)


def _import_rllib():
    """RLlib's pieces, or ``ImportError`` naming the extra."""
    try:
        import ray  # noqa: F401
        from ray.rllib.algorithms.dqn import DQNConfig
        from ray.rllib.algorithms.ppo import PPOConfig
    except ImportError as e:
        raise ImportError(f"--engine rllib needs the ray extra ({e}): pip install -e '.[ray]'", name="ray") from e
    return {"ppo": PPOConfig, "dqn": DQNConfig}


# ------------------------------------------------------------------------------------------------ the env
class MaskedUWBEnv(gym.Env):
    """A registered env as RLlib's runners build it: ``MaskedUWBEnv({"env_id": ..., "env_kwargs": {...}})``.

    The observation is ``Dict(action_mask=Box(0, 1, (n,)), observations=<the env's Box>)``, the mask being the env's
    ``action_masks()`` (1.0: valid; all ones on the registered ids' defaults).
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": []}

    def __init__(self, config: dict[str, Any] | None = None) -> None:
        config = dict(config or {})
        self.env = gym.make(config["env_id"], **dict(config.get("env_kwargs") or {}))
        self.action_space = self.env.action_space
        n = int(self.action_space.n)
        self.observation_space = gym.spaces.Dict(
            {"action_mask": gym.spaces.Box(0.0, 1.0, (n,), np.float32), "observations": self.env.observation_space}
        )

    def _obs(self, obs: Any) -> dict[str, Any]:
        return {"action_mask": self.env.unwrapped.action_masks().astype(np.float32), "observations": obs}

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):  # noqa: D102 - gym API
        obs, info = self.env.reset(seed=seed, options=options)
        return self._obs(obs), info

    def step(self, action: Any):  # noqa: D102 - gym API
        obs, reward, terminated, truncated, info = self.env.step(action)
        return self._obs(obs), reward, terminated, truncated, info

    def close(self) -> None:  # noqa: D102 - gym API
        self.env.close()


class MaskedUWBVectorEnv(gym.vector.VectorEnv):
    """:class:`MaskedUWBEnv`'s vector counterpart: ``MaskedUWBVectorEnv({"env_id", "env_kwargs", "num_envs"})``.

    The batched ``UWBVectorEnv`` (``gymnasium.make_vec(..., vectorization_mode="vector_entry_point")``, its default
    ``NEXT_STEP`` autoreset, which RLlib's runner expects) with observations ``Dict(action_mask, observations)``
    stacked over the envs, the masks its ``action_masks()`` as float32. Env e gives what ``MaskedUWBEnv`` does with
    the same seed and actions. Parametric fidelity and ``imm-lmipda`` tracker only (``ValueError`` otherwise).
    """

    def __init__(self, config: dict[str, Any]) -> None:
        config = dict(config)
        kwargs = dict(config.get("env_kwargs") or {})
        self.env = gym.make_vec(config["env_id"], int(config["num_envs"]), "vector_entry_point", **kwargs)
        self.num_envs = self.env.num_envs
        self.metadata = {"autoreset_mode": self.env.metadata["autoreset_mode"], "render_modes": []}
        self.render_mode = None
        self.single_action_space = self.env.single_action_space
        self.action_space = self.env.action_space
        n = int(self.single_action_space.n)
        mask = gym.spaces.Box(0.0, 1.0, (n,), np.float32)
        self.single_observation_space = gym.spaces.Dict(
            {"action_mask": mask, "observations": self.env.single_observation_space}
        )
        self.observation_space = gym.vector.utils.batch_space(self.single_observation_space, self.num_envs)

    def _obs(self, obs: Any) -> dict[str, Any]:
        return {"action_mask": self.env.unwrapped.action_masks().astype(np.float32), "observations": obs}

    def reset(self, *, seed: Any = None, options: dict[str, Any] | None = None):  # noqa: D102 - gym API
        obs, info = self.env.reset(seed=seed, options=options)
        return self._obs(obs), info

    def step(self, actions: Any):  # noqa: D102 - gym API
        obs, rewards, terminated, truncated, info = self.env.step(np.asarray(actions))
        return self._obs(obs), rewards, terminated, truncated, info

    def close_extras(self, **kwargs: Any) -> None:  # noqa: D102 - gym API
        self.env.close()


def masked_uwb_env(config: dict[str, Any]) -> gym.Env | gym.vector.VectorEnv:
    """RLlib's env creator (``--vectorize batched``): the vector env when the config has ``num_envs``.

    RLlib's runner calls it with ``num_envs`` for its ``vector_entry_point`` (:class:`MaskedUWBVectorEnv`), without
    for one env (:class:`MaskedUWBEnv`).
    """
    if "num_envs" in config:
        return MaskedUWBVectorEnv(config)
    return MaskedUWBEnv(config)


try:  # the module classes need RLlib; without it the engine refuses to run (``_import_rllib``)
    import torch
    from ray.rllib.algorithms.dqn.torch.default_dqn_torch_rl_module import DefaultDQNTorchRLModule
    from ray.rllib.algorithms.ppo.torch.default_ppo_torch_rl_module import DefaultPPOTorchRLModule
    from ray.rllib.core.columns import Columns
    from ray.rllib.utils.torch_utils import FLOAT_MIN

    class _OnMaskedObservations:
        """A module built on the ``observations`` part of ``Dict(action_mask, observations)``.

        ``observation_space`` stays the ``Dict`` once built (so that a checkpoint rebuilds the module with it).
        """

        def __init__(self, *, observation_space: gym.Space | None = None, **kwargs: Any) -> None:
            if not isinstance(observation_space, gym.spaces.Dict) or set(observation_space.spaces) != {
                "action_mask",
                "observations",
            }:
                raise ValueError(f"observation_space={observation_space}: must be Dict(action_mask, observations)")
            self.observation_space_with_mask = observation_space
            super().__init__(observation_space=observation_space["observations"], **kwargs)

        def setup(self) -> None:
            """Build on the ``observations`` part, then keep the ``Dict`` as the module's space."""
            super().setup()
            self.observation_space = self.observation_space_with_mask

    class MaskedPPOTorchRLModule(_OnMaskedObservations, DefaultPPOTorchRLModule):
        """PPO's default torch module on ``Dict(action_mask, observations)``: logits of invalid actions -> -inf.

        RLlib's ``ActionMaskingTorchRLModule`` example, on ``DefaultPPOTorchRLModule``.
        """

        @staticmethod
        def _split(batch: dict) -> tuple[Any, dict]:
            obs = batch[Columns.OBS]
            batch[Columns.OBS] = obs["observations"]
            return obs["action_mask"], batch

        @staticmethod
        def _masked(outs: dict, mask: Any) -> dict:
            outs[Columns.ACTION_DIST_INPUTS] = outs[Columns.ACTION_DIST_INPUTS] + torch.clamp(
                torch.log(mask), min=FLOAT_MIN
            )
            return outs

        def _forward_inference(self, batch: dict, **kwargs: Any) -> dict:
            mask, batch = self._split(batch)
            return self._masked(super()._forward_inference(batch, **kwargs), mask)

        def _forward_exploration(self, batch: dict, **kwargs: Any) -> dict:
            mask, batch = self._split(batch)
            return self._masked(super()._forward_exploration(batch, **kwargs), mask)

        def _forward_train(self, batch: dict, **kwargs: Any) -> dict:
            if isinstance(batch[Columns.OBS], dict):
                mask, batch = self._split(batch)
                batch["action_mask"] = mask
            return self._masked(super()._forward_train(batch, **kwargs), batch["action_mask"])

        def compute_values(self, batch: dict, embeddings: Any = None) -> Any:  # noqa: D102 - ValueFunctionAPI
            if isinstance(batch[Columns.OBS], dict):
                mask, batch = self._split(batch)
                batch["action_mask"] = mask  # _forward_train reads it after the values (GAE)
            return super().compute_values(batch, embeddings)

    class MaskedDQNTorchRLModule(_OnMaskedObservations, DefaultDQNTorchRLModule):
        """DQN's default torch module on ``Dict(action_mask, observations)``: Q-values of invalid actions -> -inf.

        Every Q-value of the module (online, target, current and next observations) goes through
        ``_qf_forward_helper``, so the greedy action, the double-Q argmax and the target's max range over the valid
        actions; RLlib's epsilon-greedy draws its random actions among the finite Q-values, and its loss reads -inf
        as 0 (``nan_to_num``). Expected Q-values only (``num_atoms`` 1, the default).
        """

        def _qf_forward_helper(self, batch: dict, encoder: Any, head: Any) -> dict:
            obs = batch[Columns.OBS]
            if not isinstance(obs, dict):
                return super()._qf_forward_helper(batch, encoder, head)
            out = super()._qf_forward_helper({**batch, Columns.OBS: obs["observations"]}, encoder, head)
            q = out["qf_preds"]
            out["qf_preds"] = torch.where(obs["action_mask"] > 0, q, torch.full_like(q, -torch.inf))
            return out

    MODULES = {"ppo": MaskedPPOTorchRLModule, "dqn": MaskedDQNTorchRLModule}

except ImportError:  # pragma: no cover - without the ray extra
    MODULES = {}


# ------------------------------------------------------------------------------------------ configuration
@dataclass
class RLlibTrainConfig:
    """One RLlib training run (written to ``run.yaml``); checked when built, each error naming its field."""

    env_id: str
    algo: str
    timesteps: int
    out: Path
    seed: int = 0
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    overrides: dict[str, Any] = field(default_factory=dict)  # RLlib names, model keys, eval_episodes
    env_runners: int = 2
    envs_per_runner: int = 1
    checkpoint_every: int = 5  # training iterations
    address: str | None = None  # a Ray cluster to join ("auto", "ray://host:10001"); None: a local Ray
    vectorize: str = "sync"  # a runner's envs: "sync" (gymnasium's SyncVectorEnv) or "batched" (MaskedUWBVectorEnv)

    def __post_init__(self) -> None:
        self.out = Path(self.out)
        if self.env_id not in ENV_IDS:
            raise ValueError(f"env_id={self.env_id!r}: must be one of {sorted(ENV_IDS)}")
        if self.algo not in RLLIB_ALGORITHMS:
            raise ValueError(f"algo={self.algo!r}: with engine='rllib' must be one of {list(RLLIB_ALGORITHMS)}")
        for name, low in (("timesteps", 1), ("seed", 0), ("env_runners", 1), ("envs_per_runner", 1),
                          ("checkpoint_every", 1)):  # fmt: skip
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < low:
                raise ValueError(f"{name}={value!r}: must be an integer >= {low}")
        for name in ("env_kwargs", "overrides"):
            if not isinstance(getattr(self, name), dict):
                raise ValueError(f"{name}={getattr(self, name)!r}: must be a mapping")
        if self.vectorize not in VECTORIZE:
            raise ValueError(f"vectorize={self.vectorize!r} (--vectorize): with engine='rllib' must be one of "
                             f"{sorted(VECTORIZE)}")  # fmt: skip
        if self.address is not None and (not isinstance(self.address, str) or not self.address.strip()):
            raise ValueError(f"address={self.address!r}: must be a Ray address (auto, ray://host:10001) or None")
        if self.out.exists() and not self.out.is_dir():
            raise ValueError(f"out={str(self.out)!r}: is a file (must be a folder, existing or new)")


def rllib_hyper(env_id: str, algo: str) -> dict[str, Any]:
    """The env's SB3 preset for ``algo`` under RLlib's names (plus ``eval_episodes`` from its common block)."""
    preset = load_preset(env_id, algo)
    common, p = preset["common"], preset["algo"]
    net = list((p.get("policy_kwargs") or {}).get("net_arch", [64, 64]))
    hyper: dict[str, Any] = {"lr": float(p.get("learning_rate", 3e-4)), "gamma": float(p.get("gamma", 0.99)),
                             "fcnet_hiddens": net, "eval_episodes": int(common.get("eval_episodes", 5))}  # fmt: skip
    if algo == "ppo":
        hyper.update(
            lambda_=float(p.get("gae_lambda", 0.95)),
            entropy_coeff=float(p.get("ent_coef", 0.0)),
            num_epochs=int(p.get("n_epochs", 10)),
            minibatch_size=int(p.get("batch_size", 64)),
            train_batch_size_per_learner=int(p.get("n_steps", 256)) * int(common.get("n_envs", 1)),
        )
    else:
        hyper.update(
            train_batch_size_per_learner=int(p.get("batch_size", 64)),
            num_steps_sampled_before_learning_starts=int(p.get("learning_starts", 1000)),
            target_network_update_freq=int(p.get("target_update_interval", 1000)),
            replay_buffer_config={
                "type": "PrioritizedEpisodeReplayBuffer",
                "capacity": int(p.get("buffer_size", 50_000)),
            },
            epsilon=[[0, 1.0], [20_000, float(p.get("exploration_final_eps", 0.05))]],
        )
    return hyper


def _training_keys(algo: str) -> set[str]:
    """The arguments of the algorithm config's ``training()`` (its own and its bases')."""
    keys: set[str] = set()
    for cls in type(_import_rllib()[algo]()).__mro__:
        if "training" in vars(cls):
            keys |= set(inspect.signature(vars(cls)["training"]).parameters)
    return keys - {"self", "kwargs"}


def resolve_rllib(cfg: RLlibTrainConfig) -> dict[str, Any]:
    """:func:`rllib_hyper` with ``cfg.overrides`` applied, each key checked (``ValueError`` naming ``--hyper KEY``)."""
    hyper = rllib_hyper(cfg.env_id, cfg.algo)
    allowed = _training_keys(cfg.algo) | set(MODEL_KEYS) | set(COMMON_KEYS)
    for key, value in cfg.overrides.items():
        if key not in allowed:
            raise ValueError(f"--hyper {key}={value!r}: unknown for rllib {cfg.algo}; must be one of {sorted(allowed)}")
        if key == "eval_episodes" and (isinstance(value, bool) or not isinstance(value, int) or value < 1):
            raise ValueError(f"--hyper eval_episodes={value!r}: must be an integer >= 1")
        hyper[key] = value
    if hyper.get("num_atoms", 1) != 1:
        raise ValueError(f"--hyper num_atoms={hyper['num_atoms']!r}: the masked DQN module takes expected Q-values (1)")
    return hyper


def build_config(cfg: RLlibTrainConfig, hyper: dict[str, Any]):
    """The ``AlgorithmConfig`` of a run (env, runners, hyper-parameters, module, seed)."""
    from ray.rllib.core.rl_module.rl_module import RLModuleSpec
    from ray.tune.registry import register_env

    configs = _import_rllib()
    if cfg.vectorize == "batched":  # RLlib gives a registered creator's runners vector_entry_point=creator(num_envs)
        register_env(MASKED_ENV_NAME, masked_uwb_env)
    training = {k: v for k, v in hyper.items() if k not in MODEL_KEYS and k not in COMMON_KEYS}
    model = {k: hyper[k] for k in MODEL_KEYS if k in hyper}
    config = (
        configs[cfg.algo]()
        .environment(
            MaskedUWBEnv if cfg.vectorize == "sync" else MASKED_ENV_NAME,
            env_config={"env_id": cfg.env_id, "env_kwargs": cfg.env_kwargs},
        )
        .env_runners(
            num_env_runners=cfg.env_runners,
            num_envs_per_env_runner=cfg.envs_per_runner,
            rollout_fragment_length="auto",
            gym_env_vectorize_mode=VECTORIZE[cfg.vectorize],
        )
        .training(**training)
        .debugging(seed=cfg.seed)
        .reporting(metrics_num_episodes_for_smoothing=20)
    )
    return config.rl_module(rl_module_spec=RLModuleSpec(module_class=MODULES[cfg.algo], model_config=model))


# -------------------------------------------------------------------------------------------- checkpoints
def rllib_checkpoints(out: Path) -> list[tuple[int, Path]]:
    """Every ``checkpoints/iter_<iteration>/`` of a run, newest first."""
    folder = out / "checkpoints"
    if not folder.is_dir():
        return []
    found = [(int(m.group(1)), p) for p in folder.iterdir() if p.is_dir() and (m := _CHECKPOINT.match(p.name))]
    return sorted(found, reverse=True)


def save_checkpoint(algo: Any, out: Path) -> Path:
    """``algo.save_to_path`` into ``checkpoints/iter_<iteration>`` (written aside, then renamed: never half-there)."""
    folder = out / "checkpoints"
    folder.mkdir(parents=True, exist_ok=True)
    final = folder / f"iter_{algo.iteration:06d}"
    tmp = folder / f".tmp-{final.name}-{os.getpid()}"
    shutil.rmtree(tmp, ignore_errors=True)
    algo.save_to_path(str(tmp))
    if final.exists():
        shutil.rmtree(final)
    os.replace(tmp, final)
    return final


def sampled_steps(algo: Any, result: dict | None = None) -> int:
    """The env steps sampled over the run's life (from an iteration's ``result``, or the algorithm's metrics)."""
    from ray.rllib.utils.metrics import ENV_RUNNER_RESULTS, NUM_ENV_STEPS_SAMPLED_LIFETIME

    if result is not None:
        return int(result.get(ENV_RUNNER_RESULTS, {}).get(NUM_ENV_STEPS_SAMPLED_LIFETIME, 0) or 0)
    try:
        return int(algo.metrics.peek((ENV_RUNNER_RESULTS, NUM_ENV_STEPS_SAMPLED_LIFETIME), default=0) or 0)
    except Exception:  # an older MetricsLogger: no lifetime count before the first iteration
        return 0


def resume_rllib(algo: Any, out: Path) -> int | None:
    """Restore the newest checkpoint that loads (older ones after a damaged one, moved aside); its step count."""
    for iteration, path in rllib_checkpoints(out):
        try:
            algo.restore_from_path(str(path))
        except Exception as e:  # a damaged or partial checkpoint
            move_aside(path, f"checkpoint at iteration {iteration} does not load ({type(e).__name__}: {e})",
                       "trying the previous one")  # fmt: skip
            continue
        steps = sampled_steps(algo)
        print(f"resuming from {path} at iteration {algo.iteration}, {steps} steps", file=sys.stderr)
        return steps
    return None


# ------------------------------------------------------------------------------------------ the scheduler
class RLlibPolicyScheduler:
    """A trained RLModule as a :class:`agents.Scheduler`: its greedy action, invalid actions masked.

    ``ppo``: the argmax of ``forward_inference``'s logits; ``dqn``: of the module's Q-values. The env's
    ``action_masks()`` goes into the observation as in training, and the argmax is over the valid actions.
    """

    name = "rllib"

    def __init__(self, module: Any, algo: str) -> None:
        if algo not in RLLIB_ALGORITHMS:
            raise ValueError(f"algo={algo!r}: must be one of {list(RLLIB_ALGORITHMS)}")
        self.module, self.algo = module, algo
        self.obs_shape = tuple(module.observation_space["observations"].shape)

    def reset(self, seed: int | None = None) -> None:  # noqa: D102 - the protocol
        pass

    def scores(self, obs: Any, env: gym.Env) -> np.ndarray:
        """``(n,)`` the module's action scores (logits, or Q-values for DQN); invalid actions -inf."""
        x = np.asarray(obs, dtype=np.float32)
        if x.shape != self.obs_shape:
            raise ValueError(
                f"observation shape {x.shape} != {self.obs_shape}, the trained policy's: build the env with the "
                "training run's env_kwargs (run.yaml; --env-kwarg in uwb-env-evaluate)"
            )
        mask = torch.from_numpy(env.unwrapped.action_masks().astype(np.float32))[None]
        batch = {Columns.OBS: {"action_mask": mask, "observations": torch.from_numpy(x)[None]}}
        with torch.no_grad():
            if self.algo == "dqn":
                out = self.module.compute_q_values(batch)["qf_preds"]
            else:
                out = self.module.forward_inference(batch)[Columns.ACTION_DIST_INPUTS]
        return out[0].numpy().astype(float)

    def act(self, obs: Any, env: gym.Env) -> int:  # noqa: D102 - the protocol
        mask = env.unwrapped.action_masks()
        return int(np.argmax(np.where(mask, self.scores(obs, env), -np.inf)))


def load_rllib_scheduler(run: str | Path) -> RLlibPolicyScheduler:
    """A trained RLlib run (its directory with ``run.yaml`` and ``policy/``) as a scheduler.

    ``policy/`` is the final module; a run stopped before its end falls back to its newest checkpoint's module.
    """
    from ray.rllib.core.rl_module.rl_module import RLModule

    path = Path(run)
    run_yaml = path / "run.yaml"
    if not run_yaml.is_file():
        raise FileNotFoundError(f"{str(run_yaml)!r} not found: {str(path)!r} is not an RLlib training run")
    cfg = _read_yaml(run_yaml, "a training run's configuration (YAML mapping with env_id and algo)")
    if cfg.get("engine") != "rllib" or cfg.get("algo") not in RLLIB_ALGORITHMS:
        raise ValueError(f"{run_yaml}: not an RLlib run (engine={cfg.get('engine')!r}, algo={cfg.get('algo')!r})")
    module_dir = path / "policy"
    if not module_dir.is_dir():
        found = rllib_checkpoints(path)
        if not found:
            raise FileNotFoundError(f"{str(module_dir)!r} not found and no checkpoint in {path / 'checkpoints'}")
        module_dir = found[0][1] / LEARNER_MODULE
    torch.set_num_threads(1)  # a small MLP; campaign workers must not oversubscribe
    try:
        module = RLModule.from_checkpoint(str(module_dir))
    except Exception as e:
        raise ValueError(f"{module_dir}: cannot be read as a saved RLModule ({type(e).__name__}: {e})") from e
    module.eval()
    return RLlibPolicyScheduler(module, cfg["algo"])


# --------------------------------------------------------------------------------------------- evaluation
def _progress_row(path: Path, row: list[Any]) -> None:
    new = not path.exists()
    with path.open("a", newline="") as f:
        w = csv.writer(f)
        if new:
            w.writerow(PROGRESS_COLUMNS)
        w.writerow(row)


def _init_ray(cfg: RLlibTrainConfig) -> bool:
    """Start (or join) Ray unless this process already has it; whether we started it."""
    import ray

    if ray.is_initialized():
        return False
    if cfg.address:
        ray.init(address=cfg.address, log_to_driver=False)
    else:  # one CPU per runner is RLlib's default request: never fewer CPUs than runners, or they would wait forever
        ray.init(num_cpus=max(os.cpu_count() or 1, cfg.env_runners), include_dashboard=False, log_to_driver=False)
    return True


# ----------------------------------------------------------------------------------------------- training
def train_rllib(cfg: RLlibTrainConfig, resume: bool = False, progress: bool = True) -> Any:
    """Build (or resume) and train on RLlib; returns the stopped ``Algorithm`` (``iteration``, ``metrics``).

    Everything is checked before anything is written, as with the SB3 engine: the hyper-parameters, the env
    arguments, the run folder (locked while training; a folder holding a run is refused unless ``resume``; a
    resumed run must match its ``run.yaml``, ``timesteps``, ``env_runners``, ``envs_per_runner``, ``vectorize``
    (the same episodes either way) and ``checkpoint_every`` may change). ``progress``: one line per iteration on
    stderr.
    """
    _import_rllib()
    hyper = resolve_rllib(cfg)
    check_env(cfg)  # type: ignore[arg-type]  (reads env_id and env_kwargs)
    if cfg.vectorize == "batched":
        make_batched(cfg.env_id, 1, cfg.env_kwargs).close()  # ValueError naming --vectorize batched
    run_yaml = {"engine": "rllib", "env_id": cfg.env_id, "algo": cfg.algo, "seed": cfg.seed,
                "timesteps": cfg.timesteps, "env_kwargs": cfg.env_kwargs, "hyper": hyper,
                "env_runners": cfg.env_runners, "envs_per_runner": cfg.envs_per_runner,
                "vectorize": cfg.vectorize, "checkpoint_every": cfg.checkpoint_every}  # fmt: skip
    out = cfg.out
    with FolderLock(out, "training"):
        check_run_folder(out, run_yaml, resume, ("engine", "env_id", "algo", "seed", "env_kwargs", "hyper"))
        started = _init_ray(cfg)
        try:
            return _train(cfg, hyper, resume, progress, yaml.safe_dump(run_yaml, sort_keys=True))
        finally:
            if started:
                import ray

                ray.shutdown()


def _train(cfg: RLlibTrainConfig, hyper: dict, resume: bool, progress: bool, meta: str) -> Any:
    out = cfg.out
    try:
        algo = build_config(cfg, hyper).build_algo()
    except (TypeError, ValueError, KeyError, AssertionError) as e:
        raise ValueError(f"rllib {cfg.algo} with hyper-parameters {hyper}: {type(e).__name__}: {e}") from e
    try:
        steps = resume_rllib(algo, out) if resume else None
        if resume and steps is None:
            print(f"no readable checkpoint in {out / 'checkpoints'}: training from scratch", file=sys.stderr)
        steps = steps or 0
        out.mkdir(parents=True, exist_ok=True)
        atomic_write_text(out / "run.yaml", meta)
        keep_rows_up_to(out / "progress.csv", "timesteps", steps)
        keep_rows_up_to(out / "eval.csv", "timesteps", steps)
        evaluator = EvalTable(cfg.env_id, cfg.env_kwargs, int(hyper["eval_episodes"]), out / "eval.csv")
        t0 = time.monotonic()
        saved_at = algo.iteration if steps else -1
        while steps < cfg.timesteps:
            result = algo.train()
            steps = sampled_steps(algo, result)
            runners = result.get("env_runners", {})
            ret, length = runners.get("episode_return_mean", math.nan), runners.get("episode_len_mean", math.nan)
            learner = result.get("learners", {}).get("default_policy", {})
            loss = next((learner[k] for k in ("total_loss", "qf_loss", "policy_loss") if k in learner), math.nan)
            row = [algo.iteration, steps, ret, length, float(loss), round(time.monotonic() - t0, 3)]
            _progress_row(out / "progress.csv", row)
            if progress:
                print(f"iteration {algo.iteration}: {steps}/{cfg.timesteps} steps, return {ret:.4g}", file=sys.stderr)
            if algo.iteration % cfg.checkpoint_every == 0:
                evaluator.evaluate(_scheduler_of(save_checkpoint(algo, out), cfg.algo).act, steps)
                saved_at = algo.iteration
        if saved_at != algo.iteration:
            evaluator.evaluate(_scheduler_of(save_checkpoint(algo, out), cfg.algo).act, steps)
        _save_policy(rllib_checkpoints(out)[0][1], out)
    finally:
        algo.stop()
    return algo


def _scheduler_of(checkpoint: Path, algo: str) -> RLlibPolicyScheduler:
    """The learner's module of a checkpoint as a scheduler (what the checkpoint holds, nothing newer)."""
    from ray.rllib.core.rl_module.rl_module import RLModule

    module = RLModule.from_checkpoint(str(checkpoint / LEARNER_MODULE))
    module.eval()
    return RLlibPolicyScheduler(module, algo)


def _save_policy(checkpoint: Path, out: Path) -> None:
    """The learner's module of the final checkpoint in ``policy/`` (copied aside, then renamed)."""
    tmp = out / f".tmp-policy-{os.getpid()}"
    shutil.rmtree(tmp, ignore_errors=True)
    shutil.copytree(checkpoint / LEARNER_MODULE, tmp)
    old = out / "policy"
    if old.exists():
        shutil.rmtree(old)
    os.replace(tmp, old)
