r"""``SceneFamilyEnv``: every episode a variant of a scene family (``uwb_env.scenarios.families``), drawn by seed.

``reset(seed=s)`` draws the variant of ``split`` (``train``, ``heldout`` or ``all``) from the episode's variant stream
and plays it with an inner :class:`~uwb_env.envs.scheduling.UWBSchedulingEnv` reset with the same seed ``s``. The
variant stream is child ``len(STREAM_NAMES)`` of ``numpy.random.SeedSequence(s)``, spawned after the episode's named
streams (``uwb_env.rng``), so it never changes them: the inner episode is exactly the one a plain
``UWBSchedulingEnv(scenario=<variant>)`` plays with seed ``s`` (tests/test_family_env.py). Every other keyword
(``action_kind``, ``include_lookahead``, ``fidelity``, ``tracker``, dotted config overrides, ...) goes to the inner env;
overrides apply to each drawn variant, in its own (moved) frame.

Spaces: the variants of a family differ in geometry, paths and target counts, none of which enters the observation
or action space (track slots, plans, models); the family's spaces are those of its first training variant, and
every inner env is checked against them when it is built (``ValueError`` naming the variant otherwise).

Cost of a reset: the sensor (its clutter statistics and link tables, ~60 ms on urban-intersection) depends on the
geometry and on the targets' RCS models, not on their paths or births, so one sensor per (orientation, target count)
is built and shared by the inner envs of that geometry (as the batched vector env shares one); inner envs are kept
per variant in an LRU cache of ``cache_size``. A new variant of a known geometry costs ~1 ms.

Info: the inner env's keys, with ``position_errors_m`` padded with 0 to the family's ``max_targets`` (so vector envs
can stack it whatever the count), plus the variant as numbers: ``variant_orientation`` (D4 index,
``families.ORIENTATIONS``), ``variant_path`` (index into the family's paths), ``variant_targets`` (vehicles),
``variant_heldout`` (1 if the cell is held out, else 0) and ``variant_birth_times_s`` ``(max_targets,)`` [s]
(-1 past the count).

``action_masks()``, ``lookahead_costs()``, ``detection_probabilities()``, ``search_information()``,
``sequence_costs()``, ``describe_action()``, ``plans``, ``plan_energy_j``, ``sim`` and ``cfg`` are the current inner
env's (the schedulers of ``uwb_env.agents.schedulers`` and the campaigns read them through ``env.unwrapped``), and so is
any other public attribute (``cover_gate_m``, ``n_slots``, ...).
"""

from __future__ import annotations

import dataclasses
from collections import OrderedDict
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np

from uwb_env.config import ScenarioConfig
from uwb_env.envs.scheduling import UWBSchedulingEnv, check_choice, check_int, episode_seed
from uwb_env.rng import STREAM_NAMES
from uwb_env.scenarios.families import SceneFamily, SceneVariant, family_names, get_family
from uwb_env.sim import Simulator
from uwb_env.typing import BoolArray, FloatArray

VARIANT_STREAM_INDEX = len(STREAM_NAMES)
"""The variant stream: child ``len(STREAM_NAMES)`` of the episode's ``SeedSequence``, after the named streams."""


def variant_generator(seed: int) -> np.random.Generator:
    """The generator that draws episode ``seed``'s variant (module docstring)."""
    return np.random.default_rng(np.random.SeedSequence(seed).spawn(VARIANT_STREAM_INDEX + 1)[-1])


def _scene(cfg: ScenarioConfig, like: ScenarioConfig) -> ScenarioConfig:
    """``cfg`` with the targets, name and description of ``like``: equals ``like`` iff the scenes differ only there."""
    return dataclasses.replace(cfg, targets=like.targets, name=like.name, description=like.description)


class SceneFamilyEnv(gym.Env):
    """A scheduling env whose scene is a family's variant, drawn at every ``reset`` (module docstring).

    Args:
        family: a registered family name (``uwb_env.scenarios.families.family_names()``) or a ``SceneFamily``.
        split: ``"train"`` (default), ``"heldout"``, ``"all"`` or ``"heldout-<kind>"`` (``family.splits``; the urban
            families: ``heldout-rotated``, ``heldout-mirrored``, ``heldout-turn``): the cells the variants are drawn
            from.
        cache_size: inner envs kept (LRU), >= 1.
        **env_kwargs: every ``UWBSchedulingEnv`` keyword but ``scenario``, and dotted config overrides.
    """

    metadata: ClassVar[dict[str, Any]] = UWBSchedulingEnv.metadata

    def __init__(
        self,
        family: str | SceneFamily = "urban-intersection",
        split: str = "train",
        cache_size: int = 64,
        **env_kwargs: Any,
    ) -> None:
        if isinstance(family, str):
            if family not in family_names():
                raise ValueError(f"family={family!r}: must be one of {family_names()} or a SceneFamily")
            family = get_family(family)
        elif not isinstance(family, SceneFamily):
            raise TypeError(f"family={family!r}: must be a family name (one of {family_names()}) or a SceneFamily")
        check_choice("split", split, family.splits)
        check_int("cache_size", cache_size, 1, None)
        if "scenario" in env_kwargs:
            raise TypeError(
                f"scenario={env_kwargs['scenario']!r}: a SceneFamilyEnv draws its scenario from family "
                f"{family.name!r}; pass family= and split= instead"
            )
        self.family, self.split, self.cache_size = family, split, int(cache_size)
        self._kwargs = dict(env_kwargs)
        self.render_mode = env_kwargs.get("render_mode")
        self._sensors: dict[tuple[int, int], tuple[Any, ScenarioConfig]] = {}
        self._envs: OrderedDict[SceneVariant, UWBSchedulingEnv] = OrderedDict()
        g, p = family.cells(split)[0]
        first = SceneVariant(g, p, tuple(i * family.birth_spacing_s for i in range(family.max_targets)))
        self._reference: UWBSchedulingEnv | None = None
        self._env = self._inner(first, family.build(first))
        self._reference = self._env
        self.observation_space = self._env.observation_space
        self.action_space = self._env.action_space
        self.variant = first
        self._started = False

    # ------------------------------------------------------------------------------------------------- inner envs
    def _inner(self, variant: SceneVariant, cfg: ScenarioConfig) -> UWBSchedulingEnv:
        """The inner env of ``variant`` (LRU), its sensor shared per (orientation, target count)."""
        env = self._envs.get(variant)
        if env is not None:
            self._envs.move_to_end(variant)
            return env
        key = (variant.orientation, variant.n_targets)
        shared = self._sensors.get(key)
        try:
            env = UWBSchedulingEnv(cfg, _sensor=None if shared is None else shared[0], **self._kwargs)
        except TypeError as e:
            raise TypeError(f"SceneFamilyEnv({self.family.name!r}): {e}") from e
        if shared is None:
            self._sensors[key] = (env.sim.sensor, env.cfg)
        elif _scene(env.cfg, shared[1]) != shared[1] or [(t.rcs_mean_m2, t.swerling) for t in env.cfg.targets] != [
            (t.rcs_mean_m2, t.swerling) for t in shared[1].targets
        ]:
            raise ValueError(
                f"variant {variant} of family {self.family.name!r}: its scene differs from its geometry's shared "
                f"sensor's beyond the targets' paths and births; the family cannot share sensors"
            )
        ref = self._reference
        if ref is not None and (env.observation_space != ref.observation_space or env.action_space != ref.action_space):
            raise ValueError(
                f"variant {variant} of family {self.family.name!r} changes the spaces: observation "
                f"{env.observation_space} / action {env.action_space}, the family's are {ref.observation_space} / "
                f"{ref.action_space}; a family's variants must keep the nodes, waveforms and tracker models"
            )
        self._envs[variant] = env
        while len(self._envs) > self.cache_size:
            _, old = self._envs.popitem(last=False)
            if old is not self._reference:
                old.close()
        return env

    # --------------------------------------------------------------------------------------------------- gym API
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        """Draw the variant of ``split`` from the variant stream of ``seed`` and reset its inner env with ``seed``."""
        seed = episode_seed(self, seed, options)
        variant, cfg = self.family.draw(variant_generator(seed), self.split)
        self._env = self._inner(variant, cfg)
        self.variant = variant
        self._started = True
        obs, info = self._env.reset(seed=seed)
        return obs, self._info(info)

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """One scan of the current variant (``UWBSchedulingEnv.step``)."""
        if not self._started:
            raise RuntimeError("step() before reset(): call reset() to start an episode")
        obs, reward, terminated, truncated, info = self._env.step(action)
        return obs, reward, terminated, truncated, self._info(info)

    def _info(self, info: dict[str, Any]) -> dict[str, Any]:
        """The inner info with the errors padded to ``max_targets`` and the variant's numbers (module docstring)."""
        n = self.family.max_targets
        errors = np.zeros(n)
        inner = np.asarray(info["position_errors_m"], dtype=float)
        errors[: inner.size] = inner
        births = np.full(n, -1.0)
        births[: self.variant.n_targets] = self.variant.birth_times_s
        return {
            **info,
            "position_errors_m": errors,
            "variant_orientation": self.variant.orientation,
            "variant_path": self.variant.path,
            "variant_targets": self.variant.n_targets,
            "variant_heldout": int(self.family.split_of(self.variant) == "heldout"),
            "variant_birth_times_s": births,
        }

    def render(self) -> np.ndarray | None:
        """The current variant's frame (``UWBSchedulingEnv.render``)."""
        return self._env.render()

    def close(self) -> None:
        """Close every cached inner env."""
        for env in self._envs.values():
            env.close()
        self._envs.clear()
        super().close()

    # ------------------------------------------------------------------------------------- the inner env's API
    def action_masks(self) -> BoolArray:
        """``(n_actions,)`` the valid actions (``UWBSchedulingEnv.action_masks``)."""
        return self._env.action_masks()

    def lookahead_costs(self) -> FloatArray:
        """Expected mean position-covariance trace [m^2] after the next scan per action (pure)."""
        return self._env.lookahead_costs()

    def detection_probabilities(self) -> FloatArray | None:
        """``(A, N, Q)`` expected Pd of the confirmed tracks per action and pair (pure); None without a track."""
        return self._env.detection_probabilities()

    def search_information(self) -> FloatArray:
        """``(A,)`` range information a new target's detections would bring per action (pure)."""
        return self._env.search_information()

    def sequence_costs(self, depth: int, beam: int | None = None, discount: float = 1.0) -> FloatArray:
        """``(A,)`` the cheapest expected d-scan cost of the sequences starting with each action (pure)."""
        return self._env.sequence_costs(depth, beam, discount)

    def describe_action(self, action: int) -> str:
        """The plan of ``action`` in words."""
        return self._env.describe_action(action)

    @property
    def plans(self) -> list[Any]:
        """The plans the actions index (the same in every variant)."""
        return self._env.plans

    @property
    def plan_energy_j(self) -> FloatArray:
        """``(A,)`` each plan's transmitted energy per scan [J]."""
        return self._env.plan_energy_j

    @property
    def ready_rx(self) -> BoolArray | None:
        """The receivers able to deliver next scan under receiver warm-up (None without it)."""
        return self._env.ready_rx

    @property
    def sim(self) -> Simulator:
        """The current variant's simulator."""
        return self._env.sim

    @property
    def cfg(self) -> ScenarioConfig:
        """The current variant's scenario."""
        return self._env.cfg

    @property
    def inner(self) -> UWBSchedulingEnv:
        """The current variant's ``UWBSchedulingEnv``.

        Before the first ``reset``: the family's reference variant (its split's first cell, ``max_targets`` vehicles).
        """
        return self._env

    def __getattr__(self, name: str) -> Any:
        """Any other public attribute of the current inner env (``cover_gate_m``, ``n_slots``, ``action_kind``, ...).

        Only called when normal lookup fails; private and dunder names are not delegated.
        """
        if name.startswith("_") or "_env" not in self.__dict__:
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")
        return getattr(self.__dict__["_env"], name)


__all__ = ["VARIANT_STREAM_INDEX", "SceneFamilyEnv", "variant_generator"]
