r"""stable-baselines3 ``VecEnv`` over the batched vector env (issue 19, part 3): ``--vectorize batched``.

:class:`BatchedVecEnv` drives one ``uwb_env.envs.vector.UWBVectorEnv`` (N scenarios stepped in lockstep, each
stage batched over them) in Gymnasium's ``SAME_STEP`` autoreset mode and speaks SB3's ``VecEnv`` protocol, so that
PPO, A2C, DQN and sb3-contrib's MaskablePPO train on it as on a ``DummyVecEnv`` of N single envs, with the same
results env by env (``tests/test_batched_vec_env_sb3.py``):

* ``reset()``: the seeds of ``seed(s)`` (env i: ``s + i``) are used at the next reset only, as SB3's convention;
  the per-env reset infos are in ``reset_infos``. The env takes no reset options (``set_options`` with a non-empty
  mapping raises at ``reset``, as the single env would);
* ``step_async`` / ``step_wait``: rewards ``float32``, ``dones = terminated | truncated``; an episode's end
  returns the next episode's first observation, ``infos[i]["terminal_observation"]`` holds the final one and
  ``infos[i]["TimeLimit.truncated"] = truncated and not terminated``; ``infos`` is a list of per-env dicts (the
  vector env's ``_key``-masked arrays split back per env, scalars as Python numbers);
* ``env_method("action_masks")`` (sb3-contrib's ``get_action_masks``) and ``env_method("lookahead_costs")`` use the
  vector env's batched ``(N, A)`` methods; any other method, ``get_attr`` and ``set_attr`` act on the underlying
  ``UWBSchedulingEnv`` objects (``UWBVectorEnv.envs``);
* no rendering (the vector env renders nothing): ``render()`` warns and returns None as SB3 does for
  ``render_mode=None``; ``get_images()`` gives None per env.

Scope: the vector env's (parametric fidelity, ``imm-lmipda`` tracker); other env arguments raise ``ValueError``
from :func:`make_batched_vec_env` naming the argument. Episode statistics (``info["episode"]``) come from SB3's
``VecMonitor`` around it (``agents.rl.training.make_vec_env``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env.base_vec_env import VecEnv, VecEnvIndices, VecEnvObs, VecEnvStepReturn

import uwb_env  # noqa: F401  (registers the env ids)
from uwb_env.envs.vector import UWBVectorEnv

BATCHED_METHODS = ("action_masks", "lookahead_costs")  # env_method names answered by one batched call


def make_batched_vector_env(env_id: str, num_envs: int, env_kwargs: dict[str, Any] | None = None) -> UWBVectorEnv:
    """``gymnasium.make_vec(env_id, num_envs, vectorization_mode="vector_entry_point")`` in ``SAME_STEP`` mode."""
    kwargs = dict(env_kwargs or {})
    if "autoreset_mode" in kwargs:
        raise ValueError(f"env_kwargs autoreset_mode={kwargs['autoreset_mode']!r}: set by the SB3 adapter (SAME_STEP)")
    venv = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="vector_entry_point",
                        autoreset_mode=AutoresetMode.SAME_STEP, **kwargs)  # fmt: skip
    return venv  # type: ignore[return-value]


def make_batched_vec_env(env_id: str, num_envs: int, env_kwargs: dict[str, Any] | None = None) -> BatchedVecEnv:
    """A :class:`BatchedVecEnv` of ``num_envs`` copies of ``env_id`` with ``env_kwargs`` (seed it with ``seed``)."""
    return BatchedVecEnv(make_batched_vector_env(env_id, num_envs, env_kwargs))


def unbatch_infos(infos: dict[str, Any], num_envs: int) -> list[dict[str, Any]]:
    """A vector env's infos (arrays with ``_key`` masks, nested for dict values) as ``num_envs`` per-env dicts.

    ``final_obs`` / ``final_info`` (``SAME_STEP`` autoreset) are left out: :class:`BatchedVecEnv` reads them itself.
    Numeric scalars come back as Python numbers (as the single env gives them), arrays as copies.
    """
    out: list[dict[str, Any]] = [{} for _ in range(num_envs)]
    for key, value in infos.items():
        mask = infos.get(f"_{key}")
        if mask is None or key in ("final_obs", "final_info"):
            continue  # a mask itself, or the autoreset's entries
        per = unbatch_infos(value, num_envs) if isinstance(value, dict) else None
        for i in np.flatnonzero(mask).tolist():
            out[i][key] = per[i] if per is not None else _item(value, i)
    return out


def _item(array: Any, i: int) -> Any:
    """Entry ``i`` of an info array: Python scalars for numeric 1-d arrays, copies of sub-arrays, objects as is."""
    if not isinstance(array, np.ndarray) or array.dtype == object:
        return array[i]
    if array.ndim == 1:
        return array[i].item()
    return array[i].copy()


class BatchedVecEnv(VecEnv):
    """SB3's ``VecEnv`` protocol over a ``UWBVectorEnv`` in ``SAME_STEP`` autoreset mode (module docstring)."""

    def __init__(self, venv: UWBVectorEnv) -> None:
        if not isinstance(getattr(venv, "unwrapped", None), UWBVectorEnv):
            raise ValueError(f"venv={venv!r}: must be a uwb_env.envs.vector.UWBVectorEnv")
        if venv.autoreset_mode != AutoresetMode.SAME_STEP:
            raise ValueError(
                f"venv.autoreset_mode={venv.autoreset_mode!r}: must be AutoresetMode.SAME_STEP "
                "(use make_batched_vec_env, or gymnasium.make_vec(..., autoreset_mode='SameStep'))"
            )
        self.venv = venv
        self.envs = venv.unwrapped.envs
        super().__init__(venv.num_envs, venv.single_observation_space, venv.single_action_space)
        self._actions: np.ndarray | None = None

    # ------------------------------------------------------------------------------------------------ protocol
    def reset(self) -> VecEnvObs:
        """Reset every env with the seeds of ``seed()`` (then forgotten); reset infos in ``reset_infos``."""
        options = [o for o in self._options if o]
        if options:
            raise ValueError(f"options={options[0]!r}: the env takes no reset options (set_options with None or {{}})")
        obs, infos = self.venv.reset(seed=list(self._seeds))
        self.reset_infos = unbatch_infos(infos, self.num_envs)
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:  # noqa: D102 - SB3's protocol
        self._actions = np.asarray(actions).reshape(self.num_envs)

    def step_wait(self) -> VecEnvStepReturn:
        """One scan of every env; an ended episode's env starts its next one (SB3's autoreset convention)."""
        if self._actions is None:
            raise RuntimeError("step_wait() without step_async(actions)")
        actions, self._actions = self._actions, None
        obs, rewards, terminated, truncated, vinfos = self.venv.step(actions)
        dones = terminated | truncated
        infos = unbatch_infos(vinfos, self.num_envs)
        if dones.any():
            finals = unbatch_infos(vinfos["final_info"], self.num_envs)
            for i in np.flatnonzero(dones).tolist():
                self.reset_infos[i] = infos[i]
                infos[i] = finals[i]
                infos[i]["terminal_observation"] = vinfos["final_obs"][i]
        for i in range(self.num_envs):
            infos[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
        return obs, rewards.astype(np.float32), dones, infos

    def close(self) -> None:  # noqa: D102 - SB3's protocol
        self.venv.close()

    def get_images(self) -> Sequence[np.ndarray | None]:
        """None per env: the batched vector env does not render."""
        return [None] * self.num_envs

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """An attribute of each underlying ``UWBSchedulingEnv``."""
        return [getattr(self.envs[i], attr_name) for i in self._indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """Set an attribute of each underlying ``UWBSchedulingEnv`` (the batched stages read some of them once)."""
        for i in self._indices(indices):
            setattr(self.envs[i], attr_name, value)

    def env_method(self, method_name: str, *method_args: Any, indices: VecEnvIndices = None, **method_kwargs: Any):
        """Call a method of each env: ``action_masks`` / ``lookahead_costs`` batched, others env by env."""
        idx = self._indices(indices)
        if method_name in BATCHED_METHODS and not method_args and not method_kwargs:
            rows = getattr(self.venv.unwrapped, method_name)()
            return [rows[i] for i in idx]
        return [getattr(self.envs[i], method_name)(*method_args, **method_kwargs) for i in idx]

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: VecEnvIndices = None) -> list[bool]:
        """False for each env: the underlying envs are never wrapped (``VecMonitor`` wraps the whole)."""
        return [False for _ in self._indices(indices)]

    def _indices(self, indices: VecEnvIndices) -> list[int]:
        if indices is None:
            return list(range(self.num_envs))
        if isinstance(indices, (int, np.integer)):
            return [int(indices)]
        return [int(i) for i in indices]
