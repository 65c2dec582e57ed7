"""SceneFamilyEnv (issue 20, item 3): seeded variants per reset, splits, the inner episode, spaces, ids, campaigns."""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np
import pytest

import uwb_env
from uwb_env.agents.campaign import Campaign, make_env, play
from uwb_env.agents.schedulers import Myopic
from uwb_env.envs import ENV_IDS, FAMILY_ENV_IDS, UWBSchedulingEnv
from uwb_env.envs.family import SceneFamilyEnv, variant_generator
from uwb_env.scenarios.families import SceneFamily, get_family

gym.register_envs(uwb_env)

FAMILY = get_family("urban-intersection")
ID = "uwb_env/UrbanFamily-v0"


def _rollout(env, seed, actions):
    obs, info = env.reset(seed=seed)
    out, rewards = [obs], []
    for a in actions:
        obs, r, _, _, info = env.step(a)
        out.append(obs)
        rewards.append(r)
    return np.array(out), np.array(rewards), info


def test_reset_seed_is_reproducible_and_seeds_vary_the_variant():
    a, b = SceneFamilyEnv(), SceneFamilyEnv()
    actions = [k % 6 for k in range(60)]
    oa, ra, ia = _rollout(a, 12, actions)
    ob, rb, ib = _rollout(b, 12, actions)
    np.testing.assert_array_equal(oa, ob)
    np.testing.assert_array_equal(ra, rb)
    assert a.variant == b.variant and ia["variant_orientation"] == ib["variant_orientation"]
    _, rc, _ = _rollout(a, 13, actions)
    assert not np.array_equal(ra, rc)
    variants = []
    for seed in range(40):
        a.reset(seed=seed)
        variants.append(a.variant)
    assert len(set(variants)) >= 35 and len({v.cell for v in variants}) >= 12  # 17 training cells
    # the variant is the family's draw from the seed's variant stream, independent of the episode's named streams
    assert variants[7] == FAMILY.draw(variant_generator(7), "train")[0]


def test_splits_are_respected_and_a_heldout_variant_is_never_trained_on():
    held, train = set(FAMILY.cells("heldout")), set(FAMILY.cells("train"))
    for seed in range(3000):  # the draws the env makes, without building the envs
        assert FAMILY.draw(variant_generator(seed), "train")[0].cell in train
    env = SceneFamilyEnv(split="heldout")
    drawn = set()
    for seed in range(60):
        _, info = env.reset(seed=seed)
        assert (info["variant_orientation"], info["variant_path"]) in held and info["variant_heldout"] == 1
        drawn.add(env.variant.cell)
    assert drawn == held  # all 7 held-out cells in 60 draws (P(one missed) < 7 (6/7)^60 = 7e-4)
    _, info = SceneFamilyEnv(split="train").reset(seed=0)
    assert info["variant_heldout"] == 0
    mirrored = gym.make(ID, split="heldout-mirrored")
    for seed in range(5):
        _, info = mirrored.reset(seed=seed)
        assert info["variant_orientation"] == 4 and info["variant_heldout"] == 1


@pytest.mark.parametrize("seed", [4, 21])
def test_the_family_episode_is_the_inner_env_episode_under_the_myopic_scheduler(seed):
    """Reward, observation and info equal (bitwise) those of a plain UWBSchedulingEnv on the drawn variant."""
    fam_env = SceneFamilyEnv(split="all")
    obs, info = fam_env.reset(seed=seed)
    plain = UWBSchedulingEnv(FAMILY.build(fam_env.variant))
    obs_p, _ = plain.reset(seed=seed)
    np.testing.assert_array_equal(obs, obs_p)
    scheduler, total, n = Myopic(), 0.0, fam_env.variant.n_targets
    done = False
    while not done:
        a = scheduler.act(obs, fam_env)
        assert a == scheduler.act(obs_p, plain)
        obs, r, _, done, info = fam_env.step(a)
        obs_p, r_p, _, _, info_p = plain.step(a)
        np.testing.assert_array_equal(obs, obs_p)
        assert r == r_p
        total += r
        np.testing.assert_array_equal(info["position_errors_m"][:n], info_p["position_errors_m"])
        assert (info["position_errors_m"][n:] == 0.0).all() and info["position_errors_m"].shape == (3,)
    assert info["scan_index"] == 140 and total < 0.0
    np.testing.assert_array_equal(fam_env.lookahead_costs(), plain.lookahead_costs())


def test_info_has_fixed_keys_and_shapes_for_every_variant():
    env = SceneFamilyEnv(split="all")
    ref = None
    for seed in range(6):
        _, reset_info = env.reset(seed=seed)
        _, _, _, _, info = env.step(0)
        for d in (reset_info, info):
            shapes = {k: np.shape(v) for k, v in d.items()}
            ref = ref or shapes
            assert shapes == ref
        births = info["variant_birth_times_s"]
        n = info["variant_targets"]
        assert births.shape == (3,) and (births[n:] == -1.0).all()
        np.testing.assert_array_equal(births[:n], env.variant.birth_times_s)
    assert ref["position_errors_m"] == (3,) and ref["variant_birth_times_s"] == (3,)


def test_spaces_are_the_inner_envs_and_a_family_that_would_change_them_is_refused():
    env = SceneFamilyEnv(include_lookahead=True)
    plain = UWBSchedulingEnv("urban-intersection", include_lookahead=True)
    assert env.observation_space == plain.observation_space and env.action_space == plain.action_space
    assert env.cover_gate_m == 5.0 and env.n_slots == 8 and env.include_lookahead  # the inner env's attributes
    with pytest.raises(AttributeError, match="_nothing"):
        env._nothing  # noqa: B018

    @dataclasses.dataclass(frozen=True)
    class FewerWaveforms(SceneFamily):
        def build(self, variant):
            cfg = SceneFamily.build(self, variant)
            return dataclasses.replace(cfg, waveforms=cfg.waveforms[:4]) if variant.orientation == 2 else cfg

    odd = FewerWaveforms(**{f.name: getattr(FAMILY, f.name) for f in dataclasses.fields(SceneFamily)})
    env = SceneFamilyEnv(odd, split="all")
    seed = next(s for s in range(200) if odd.draw(variant_generator(s), "all")[0].orientation == 2)
    with pytest.raises(ValueError, match=r"changes the spaces: observation .* action Discrete\(4\)"):
        env.reset(seed=seed)


def test_bad_arguments_name_themselves():
    with pytest.raises(ValueError, match="split='test'"):
        SceneFamilyEnv(split="test")
    with pytest.raises(ValueError, match="family='nowhere'"):
        SceneFamilyEnv("nowhere")
    with pytest.raises(TypeError, match="scenario='urban-intersection': a SceneFamilyEnv draws"):
        SceneFamilyEnv(scenario="urban-intersection")
    with pytest.raises(ValueError, match="cache_size=0"):
        SceneFamilyEnv(cache_size=0)
    with pytest.raises(RuntimeError, match="before reset"):
        SceneFamilyEnv().step(0)


def test_registered_ids_make_and_vectorise():
    assert set(FAMILY_ENV_IDS) <= set(ENV_IDS)
    env = gym.make(ID, split="heldout")
    assert isinstance(env.unwrapped, SceneFamilyEnv) and env.unwrapped.split == "heldout"
    assert gym.make(ID).unwrapped.split == "train"
    wide = gym.make("uwb_env/UrbanWidebandFamily-v0")
    assert wide.action_space.n == 8
    envs = gym.make_vec(ID, num_envs=2, vectorization_mode="sync")
    _, info = envs.reset(seed=[0, 1])
    for _ in range(3):
        _, reward, _, _, info = envs.step(np.array([0, 1]))
    assert info["position_errors_m"].shape == (2, 3) and info["variant_orientation"].shape == (2,)
    assert np.isfinite(reward).all()
    envs.close()


def test_the_cache_keeps_resets_cheap_and_bounded():
    env = SceneFamilyEnv(split="all", cache_size=4)
    for seed in range(30):
        env.reset(seed=seed)
    assert len(env._envs) == 4
    assert len(env._sensors) <= 24  # one sensor per (orientation, target count)
    keys = {(v.orientation, v.n_targets) for v in (FAMILY.draw(variant_generator(s), "all")[0] for s in range(30))}
    assert set(env._sensors) == keys | {(0, 3)}  # and the reference variant's


def test_a_campaign_plays_a_family_env_with_its_tracker():
    camp = Campaign(env=ID, schemes=("myopic", "myopic@open-loop"), baseline="myopic", runs=2,
                    env_kwargs={"split": "heldout"})  # fmt: skip
    env = make_env(camp, "open-loop")
    assert isinstance(env, SceneFamilyEnv) and env.split == "heldout"
    rows, names = play(env, Myopic(), 3)
    assert rows.shape == (140, len(names)) and names[-1] == "mu:ncv"
    assert make_env(camp, "scenario").sim.tracker.model_names == ("ncv", "nca", "ct_left", "ct_right")


def test_training_takes_the_family_id_and_its_split(tmp_path):
    pytest.importorskip("stable_baselines3")
    from uwb_env.agents.rl import TrainConfig, train

    cfg = TrainConfig(ID, "ppo", 64, tmp_path / "run", seed=1, env_kwargs={"split": "heldout"},
                      overrides={"n_envs": 1, "n_steps": 32, "batch_size": 32, "n_epochs": 1, "eval_freq": 10**9,
                                 "eval_episodes": 1, "checkpoint_freq": 64})  # fmt: skip
    model = train(cfg, progress=False)
    assert model.num_timesteps >= 64
    venv_env = model.get_env().envs[0].unwrapped
    assert isinstance(venv_env, SceneFamilyEnv) and venv_env.split == "heldout"
