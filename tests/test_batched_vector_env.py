"""The batched vector env (``uwb_env.envs.vector.UWBVectorEnv``) against N single envs (issue 19 part 3).

``gymnasium.make_vec(id, num_envs=N, vectorization_mode="vector_entry_point")`` must give, env by env, the
observations, rewards, terminations, truncations and infos of Gymnasium's ``SyncVectorEnv`` over N single envs
with the same seeds and actions (the same numbers to the bit: the batched kernels run the single env's compiled
kernels on the same rows), in both autoreset modes, with episodes that end at different steps (``reset_mask``
restarts a subset mid-episode), with the lookahead in the observation and with receiver warm-up.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import uwb_env
from uwb_env.envs import ENV_IDS
from uwb_env.envs.vector import UWBVectorEnv

gym.register_envs(uwb_env)

N = 3


def _batched_ids() -> list[str]:
    """The registered ids the batched env runs (parametric fidelity, imm-lmipda tracker)."""
    out = []
    for env_id in sorted(ENV_IDS):
        if gym.spec(env_id).vector_entry_point is None:  # scene families (SceneFamilyEnv): no batched env
            continue
        cfg = gym.make(env_id).unwrapped.cfg
        if cfg.sensing.fidelity == "parametric" and cfg.tracker.kind == "imm-lmipda":
            out.append(env_id)
    return out


def _assert_infos_equal(a: dict, b: dict) -> None:
    assert set(a) == set(b)
    for key in a:
        if key == "final_obs":
            for x, y in zip(a[key], b[key], strict=True):
                assert (x is None and y is None) or np.array_equal(x, y), key
        elif key == "final_info":
            _assert_infos_equal(a[key], b[key])
        else:
            assert np.asarray(a[key]).dtype == np.asarray(b[key]).dtype, key
            assert np.array_equal(a[key], b[key]), key


def _play(env_id: str, mode: AutoresetMode, extra: int, kwargs: dict, masked_resets: dict[int, list[int]]) -> None:
    """Play both vector envs side by side with random actions and compare everything at every step.

    ``n_scans + extra`` steps (every env must end an episode); ``masked_resets[t]``: the envs reset before step t.
    """
    batched = gym.make_vec(env_id, num_envs=N, vectorization_mode="vector_entry_point", autoreset_mode=mode, **kwargs)
    sync = gym.make_vec(env_id, num_envs=N, vectorization_mode="sync", vector_kwargs={"autoreset_mode": mode}, **kwargs)
    assert isinstance(batched, UWBVectorEnv)
    try:
        o1, i1 = batched.reset(seed=[11, 7, 3])
        o2, i2 = sync.reset(seed=[11, 7, 3])
        assert np.array_equal(o1, o2)
        _assert_infos_equal(i1, i2)
        rng = np.random.default_rng(0)
        n_actions = batched.single_action_space.n
        ended = np.zeros(N, int)
        for t in range(batched.envs[0].cfg.n_scans + extra):
            if t in masked_resets:  # restart some envs mid-episode: their episodes then end later
                mask = np.zeros(N, bool)
                mask[masked_resets[t]] = True
                seeds = [100 + t + e for e in range(N)]
                o1, i1 = batched.reset(seed=seeds, options={"reset_mask": mask})
                o2, i2 = sync.reset(seed=seeds, options={"reset_mask": mask.copy()})
                assert np.array_equal(o1, o2)
                _assert_infos_equal(i1, i2)
            actions = rng.integers(0, n_actions, N)
            r1 = batched.step(actions)
            r2 = sync.step(actions)
            for x, y in zip(r1[:4], r2[:4], strict=True):
                assert x.dtype == y.dtype and np.array_equal(x, y), t
            _assert_infos_equal(r1[4], r2[4])
            ended += r1[3]
            for e in range(N):  # the trackers' whole state, ids included (what campaigns score)
                mine, theirs = batched.envs[e].sim.tracker.tracks, sync.envs[e].unwrapped.sim.tracker.tracks
                for field in ("ids", "confirmed", "age", "born", "existence", "mu", "active", "x", "P"):
                    assert np.array_equal(getattr(mine, field), getattr(theirs, field)), (t, e, field)
        assert (ended > 0).all(), "every env must finish at least one episode"
    finally:
        batched.close()
        sync.close()


@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_equal_to_sync_vector_env_with_episodes_ending_at_different_steps(mode: AutoresetMode) -> None:
    """UrbanWaveform (140-scan episodes): env 1 restarted at step 20, env 2 at step 45, so the three end apart."""
    _play("uwb_env/UrbanWaveform-v3", mode, 50, {"include_lookahead": True}, {20: [1], 45: [2]})


@pytest.mark.parametrize("env_id", _batched_ids())
def test_every_batched_id_equal_to_sync(env_id: str) -> None:
    """Every id the batched env runs, with the lookahead observed (warm-up: both lookahead parts)."""
    _play(env_id, AutoresetMode.NEXT_STEP, 8, {"include_lookahead": True}, {5: [0]})


def test_equal_with_azimuth_measurements() -> None:
    """Receivers that measure azimuth: initiation takes the trackers' own path (``BatchedTracker._initiate``)."""
    _play("uwb_env/UrbanWaveform-v3", AutoresetMode.NEXT_STEP, 4, {"sensing.measure_doa": True}, {})


def test_lookahead_costs_and_masks_are_the_single_envs() -> None:
    """``lookahead_costs()`` ``(N, A)`` row e is env e's own ``lookahead_costs()``; ``action_masks()`` stacks."""
    kw = {"out_of_service_rx": (1,), "action_kind": "subset", "scenario": "indoor-rsn"}
    env_id = next(i for i in ENV_IDS if "IndoorSensorSubset" in i)
    batched = gym.make_vec(env_id, num_envs=N, vectorization_mode="vector_entry_point", **kw)
    batched.reset(seed=4)
    masks = batched.action_masks()
    single = batched.envs[0].action_masks()
    assert masks.shape == (N, single.size) and (masks == single).all() and not single.all()
    for _ in range(12):
        costs = batched.lookahead_costs()
        for e, env in enumerate(batched.envs):
            assert np.array_equal(costs[e], env.lookahead_costs())
        batched.step(np.where(masks, costs, np.inf).argmin(axis=1))
    assert (costs > 0).any()


def test_bad_inputs_raise_naming_the_field() -> None:
    env_id = "uwb_env/UrbanWaveform-v3"
    with pytest.raises(ValueError, match="num_envs=0"):
        UWBVectorEnv(0)
    with pytest.raises(ValueError, match="fidelity='signal'"):
        gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point", fidelity="signal")
    with pytest.raises(ValueError, match="tracker='phd'"):
        gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point", tracker="phd")
    with pytest.raises(ValueError, match="autoreset_mode='sometimes'"):
        gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point", autoreset_mode="sometimes")
    env = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point")
    with pytest.raises(RuntimeError, match="before reset"):
        env.step(np.zeros(2, np.int64))
    env.reset(seed=0)
    with pytest.raises(ValueError, match="actions="):
        env.step(np.zeros(3, np.int64))
    with pytest.raises(ValueError, match="action=9"):
        env.step(np.array([0, 9]))
    with pytest.raises(ValueError, match="reset_mask"):
        env.reset(options={"reset_mask": np.ones(3, bool)})
    with pytest.raises(ValueError, match="seed="):
        env.reset(seed=[1, 2, 3])
