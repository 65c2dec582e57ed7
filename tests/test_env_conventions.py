"""Gymnasium conventions of ``UWBSchedulingEnv`` (issue 16 item 5).

Before: episodes at the scenario's horizon returned ``terminated=True`` with no time in the observation,
``render()`` in ``human`` mode returned an array, the render title read "action 19", ``action_masks()`` was all-true
on every id, the flattened ``Dict`` observation's order differed from the ``Box``'s, and ``reset()``'s info held
only ``scan_index``.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces

import uwb_env
from uwb_env.agents import Myopic, Random
from uwb_env.envs import ENV_IDS, UWBSchedulingEnv

gym.register_envs(uwb_env)

IDS = sorted(ENV_IDS)


@pytest.mark.parametrize("env_id", IDS)
def test_the_horizon_truncates_and_nothing_terminates(env_id):
    env = gym.make(env_id)
    env.reset(seed=1)
    n = env.unwrapped.cfg.n_scans
    flags = [env.step(0)[2:4] for _ in range(n)]
    assert [t for t, _ in flags] == [False] * n
    assert [t for _, t in flags] == [False] * (n - 1) + [True]


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("lookahead", [False, True])
def test_flattened_dict_observation_equals_the_box_observation(env_id, lookahead):
    box = gym.make(env_id, include_lookahead=lookahead)
    dct = gym.make(env_id, include_lookahead=lookahead, observation="dict")
    assert spaces.flatdim(dct.observation_space) == box.observation_space.shape[0]
    ob, od = box.reset(seed=4)[0], dct.reset(seed=4)[0]
    for k in range(12):
        np.testing.assert_array_equal(spaces.flatten(dct.observation_space, od), ob)
        assert dct.observation_space.contains(od)
        a = k % box.action_space.n
        ob, od = box.step(a)[0], dct.step(a)[0]
    assert list(dct.observation_space.spaces)[:2] == ["tracks", "previous_action"]  # the Box's order, not sorted


def test_warmup_dict_keeps_the_box_order_of_all_five_parts():
    env = gym.make("uwb_env/IndoorSubsetWarmup-v1", include_lookahead=True, observation="dict")
    assert list(env.observation_space.spaces) == [
        "tracks",
        "previous_action",
        "lookahead",
        "lookahead_all_ready",
        "ready_receivers",
    ]


@pytest.mark.parametrize("env_id", IDS)
def test_masks_match_the_action_space_and_are_all_valid_by_default(env_id):
    env = gym.make(env_id)
    env.reset(seed=0)
    mask = env.unwrapped.action_masks()
    assert mask.dtype == bool and mask.shape == (env.action_space.n,) and mask.all()


def test_a_receiver_out_of_service_masks_every_subset_that_needs_it():
    env = gym.make("uwb_env/IndoorSensorSubset-v1", out_of_service_rx=("rx2",))
    e = env.unwrapped
    mask = e.action_masks()
    needs_rx2 = np.array([p.active_rx[1] for p in e.plans])
    np.testing.assert_array_equal(mask, ~needs_rx2)
    assert mask.sum() == 10  # C(5, 3) of the C(6, 3) = 20 subsets avoid rx2
    env.reset(seed=0)
    for scheduler in (Random(), Myopic()):  # both pick only valid actions, so stepping never raises
        scheduler.reset(0)
        obs = env.reset(seed=0)[0]
        for _ in range(15):
            a = scheduler.act(obs, env)
            assert mask[a]
            obs, *_ = env.step(a)
    masked_copy = e.action_masks()
    masked_copy[:] = True  # a copy: the env's mask cannot be changed from outside
    np.testing.assert_array_equal(e.action_masks(), ~needs_rx2)


def test_an_unavailable_waveform_masks_its_actions_and_an_idle_receiver_delivers_nothing():
    env = gym.make("uwb_env/UrbanWaveform-v3", unavailable_waveforms=(0, 3), out_of_service_rx=("rx2",))
    e = env.unwrapped
    np.testing.assert_array_equal(e.action_masks(), [False, True, True, False, True, True])
    assert all(not p.active_rx[1] and p.active_rx[0] for p in e.plans)  # every plan listens with rx1 only
    env.reset(seed=0)
    for _ in range(30):
        env.step(1)
        assert all(d.rx == 0 for d in e._last.detections)
    joint = gym.make("uwb_env/IndoorJoint-v1", unavailable_waveforms=("ns5120",)).unwrapped
    np.testing.assert_array_equal(joint.action_masks(), [p.waveform[0] != 1 for p in joint.plans])
    assert joint.action_masks().sum() == 40


def test_a_maskable_policy_sees_the_mask():
    sb3_contrib = pytest.importorskip("sb3_contrib")
    from sb3_contrib.common.maskable.utils import get_action_masks
    from stable_baselines3.common.vec_env import DummyVecEnv

    venv = DummyVecEnv([lambda: gym.make("uwb_env/IndoorSensorSubset-v1", out_of_service_rx=(0,))])
    venv.reset()
    masks = get_action_masks(venv)
    assert masks.shape == (1, 20) and masks.sum() == 10
    model = sb3_contrib.MaskablePPO("MlpPolicy", venv, n_steps=32, batch_size=32, seed=0)
    action, _ = model.predict(venv.reset(), action_masks=masks)
    assert masks[0, int(action[0])]


def test_describe_action_names_the_waveform_and_the_receivers():
    e = gym.make("uwb_env/IndoorJoint-v1").unwrapped
    assert e.describe_action(0) == "action 0: waveform ns20480; receivers rx1, rx2, rx3"
    assert e.describe_action(59) == "action 59: waveform ns81920; receivers rx4, rx5, rx6"
    u = gym.make("uwb_env/UrbanWaveform-v3").unwrapped
    assert u.describe_action(1).startswith(f"action 1: waveform {u.cfg.waveforms[1].name}; receivers rx1, rx2")


def test_render_rgb_array_returns_a_frame_titled_with_the_plan(monkeypatch):
    pytest.importorskip("matplotlib")
    import matplotlib.axes

    titles = []
    original = matplotlib.axes.Axes.set_title
    monkeypatch.setattr(matplotlib.axes.Axes, "set_title", lambda ax, t, **kw: titles.append(t) or original(ax, t))
    env = gym.make("uwb_env/IndoorSensorSubset-v1", render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    env.step(19)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    assert titles[0] == "scan 0: no scan yet"
    assert titles[-1] == "scan 1: action 19: waveform ns20480; receivers rx4, rx5, rx6"


def test_render_human_shows_the_frame_and_returns_none(monkeypatch):
    pytest.importorskip("matplotlib")
    import matplotlib.pyplot as plt

    shown = []
    monkeypatch.setattr(plt, "show", lambda *a, **k: shown.append("show"))
    monkeypatch.setattr(plt, "pause", lambda *a, **k: None)
    env = UWBSchedulingEnv("indoor-rsn", action_kind="subset", render_mode="human")
    env.reset(seed=0)  # human mode draws after reset and every step (Gymnasium's convention)
    env.step(0)
    assert env.render() is None
    assert len(shown) == 3


@pytest.mark.parametrize("env_id", IDS)
def test_info_has_fixed_keys_and_shapes_with_padded_errors(env_id):
    """Before: ``position_errors_m`` had one entry per covered target (0, 1 or 2 from scan to scan) and ``reset``'s
    info only ``scan_index``; vector envs could not stack them."""
    env = gym.make(env_id)
    k = len(env.unwrapped.cfg.targets)
    _, info0 = env.reset(seed=3)
    assert info0["scan_index"] == 0 and info0["position_errors_count"] == 0
    np.testing.assert_array_equal(info0["position_errors_m"], np.zeros(k))
    keys, counts = set(info0), []
    for step in range(60):
        _, _, _, _, info = env.step(step % env.action_space.n)
        assert set(info) == keys
        e, n = info["position_errors_m"], info["position_errors_count"]
        assert e.shape == (k,) and isinstance(n, int) and 0 <= n <= k
        assert n == info["confirmed_tracks"] - info["false_tracks"]  # one error per confirmed track on a target
        assert (e[n:] == 0.0).all() and (e[:n] > 0.0).all()  # padding is 0; errors within the cover gate
        assert (e[:n] <= env.unwrapped.cover_gate_m).all()
        counts.append(n)
    assert max(counts) >= 1  # some scans cover a target
