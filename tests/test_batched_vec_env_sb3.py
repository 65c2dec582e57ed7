"""SB3's ``VecEnv`` over the batched vector env (``agents/rl/batched_vec_env.py``, issue 19 part 3).

The adapter must give exactly what SB3's ``DummyVecEnv`` of N single envs gives with the same seeds and actions:
observations, rewards (float32), dones, infos (``terminal_observation``, ``TimeLimit.truncated``) and reset infos,
across episode ends (UrbanWaveform's episodes are 140 scans, the indoor ids' 61); sb3-contrib's MaskablePPO trains
on it; and ``--vectorize batched`` trains through ``uwb-env-train``.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("sb3_contrib")

from sb3_contrib import MaskablePPO
from sb3_contrib.common.maskable.utils import get_action_masks
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor, VecNormalize

import uwb_env  # noqa: F401
from uwb_env.agents.cli import train_main
from uwb_env.agents.rl.batched_vec_env import BatchedVecEnv, make_batched_vec_env, make_batched_vector_env
from uwb_env.agents.rl.training import TrainConfig, make_vec_env

URBAN = "uwb_env/UrbanWaveform-v3"
MASKED_ID, MASKED_KWARGS = "uwb_env/IndoorSubsetWarmup-v1", {"out_of_service_rx": ["rx1"]}


def _equal(a, b, where: str = "") -> None:
    """Recursive equality of observations / infos, types included (ndarray vs ndarray, int vs int, ...)."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and sorted(a) == sorted(b), (where, sorted(a), sorted(b))
        for k in a:
            _equal(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, list | tuple):
        assert type(a) is type(b) and len(a) == len(b), where
        for j, (x, y) in enumerate(zip(a, b, strict=True)):
            _equal(x, y, f"{where}[{j}]")
    elif isinstance(a, np.ndarray):
        assert isinstance(b, np.ndarray) and a.dtype == b.dtype and a.shape == b.shape, where
        np.testing.assert_array_equal(a, b, err_msg=where)
    else:
        assert type(a) is type(b), (where, type(a), type(b))
        assert a == b or (a != a and b != b), (where, a, b)  # NaN == NaN here


def _dummy(env_id: str, n: int, kwargs: dict) -> DummyVecEnv:
    return DummyVecEnv([lambda: gym.make(env_id, **kwargs) for _ in range(n)])


@pytest.mark.parametrize(("env_id", "kwargs", "n", "steps"), [(URBAN, {}, 2, 290), (MASKED_ID, MASKED_KWARGS, 3, 130)])
def test_equal_to_dummy_vec_env_across_episodes(env_id, kwargs, n, steps):
    ref, ours = _dummy(env_id, n, kwargs), make_batched_vec_env(env_id, n, kwargs)
    assert ours.num_envs == n and ours.observation_space == ref.observation_space
    assert ours.action_space == ref.action_space
    ref.seed(11)
    ours.seed(11)
    _equal(ref.reset(), ours.reset(), "reset obs")
    _equal(ref.reset_infos, ours.reset_infos, "reset infos")
    masks = np.stack(ref.env_method("action_masks"))
    assert masks.dtype == bool and masks.shape == (n, ours.action_space.n)
    np.testing.assert_array_equal(get_action_masks(ours), masks)
    assert (not masks.all()) == (env_id == MASKED_ID)
    rng = np.random.default_rng(5)
    ends = 0
    for t in range(steps):
        actions = np.array([rng.choice(np.flatnonzero(m)) for m in masks], np.int64)
        ref.step_async(actions)
        ours.step_async(actions)
        (o1, r1, d1, i1), (o2, r2, d2, i2) = ref.step_wait(), ours.step_wait()
        assert o2.dtype == np.float32 and o2.shape == (n, *ours.observation_space.shape)
        assert r2.dtype == np.float32 and r2.shape == (n,) and d2.dtype == bool and d2.shape == (n,)
        assert isinstance(i2, list) and len(i2) == n
        _equal(o1, o2, f"obs t={t}")
        np.testing.assert_array_equal(r1, r2)
        np.testing.assert_array_equal(d1, d2)
        _equal(i1, i2, f"infos t={t}")
        if d1.any():
            ends += int(d1.sum())
            _equal(ref.reset_infos, ours.reset_infos, f"reset infos t={t}")
            assert all(i2[e]["TimeLimit.truncated"] for e in np.flatnonzero(d2))
    assert ends == 2 * n  # every env ended two episodes (and restarted) on the way
    # the seeds were used once: a second reset continues each env's RNG, as DummyVecEnv's
    _equal(ref.reset(), ours.reset(), "second reset")
    ref.close()
    ours.close()


def test_dict_observations_and_env_methods():
    kwargs = {"observation": "dict", "include_lookahead": True}
    ref, ours = _dummy(URBAN, 2, kwargs), make_batched_vec_env(URBAN, 2, kwargs)
    ref.seed(0)
    ours.seed(0)
    _equal(dict(ref.reset()), ours.reset())
    for _ in range(3):
        ref.step_async(np.array([1, 4]))
        ours.step_async(np.array([1, 4]))
        (o1, r1, *_), (o2, r2, *_) = ref.step_wait(), ours.step_wait()
        _equal(dict(o1), o2)
        np.testing.assert_array_equal(r1, r2)
    np.testing.assert_array_equal(ref.env_method("lookahead_costs"), ours.env_method("lookahead_costs"))
    np.testing.assert_array_equal(ref.env_method("lookahead_costs", indices=[1]),
                                  ours.env_method("lookahead_costs", indices=1))  # fmt: skip
    assert ours.get_attr("include_lookahead") == [True, True] and ours.env_is_wrapped(Monitor) == [False, False]
    ours.set_attr("tag", 7, indices=[0])
    assert ours.get_attr("tag", indices=0) == [7]
    assert ours.get_images() == [None, None]
    with pytest.warns(UserWarning, match="render"):
        assert ours.render() is None
    ours.set_options({"x": 1})
    with pytest.raises(ValueError, match="no reset options"):
        ours.reset()


def test_refuses_what_it_does_not_support():
    with pytest.raises(ValueError, match="fidelity='signal'"):
        make_batched_vec_env(URBAN, 2, {"fidelity": "signal"})
    with pytest.raises(ValueError, match="autoreset_mode"):
        BatchedVecEnv(gym.make_vec(URBAN, num_envs=2, vectorization_mode="vector_entry_point"))
    with pytest.raises(ValueError, match="autoreset_mode"):
        make_batched_vector_env(URBAN, 2, {"autoreset_mode": "NextStep"})


def test_maskable_ppo_learns_on_it():
    venv = VecNormalize(VecMonitor(make_batched_vec_env(MASKED_ID, 2, MASKED_KWARGS)))
    venv.seed(0)
    model = MaskablePPO("MlpPolicy", venv, n_steps=64, batch_size=64, n_epochs=1, seed=0, device="cpu",
                        policy_kwargs={"net_arch": [16]})  # fmt: skip
    before = [p.detach().clone() for p in model.policy.parameters()]
    model.learn(256)
    assert model.num_timesteps == 256
    assert any(
        not np.array_equal(a.numpy(), b.detach().numpy())
        for a, b in zip(before, model.policy.parameters(), strict=True)
    )
    mask = get_action_masks(venv)
    assert mask.shape == (2, venv.action_space.n) and not mask.all()
    actions, _ = model.predict(venv.reset(), action_masks=mask)
    assert mask[np.arange(2), actions].all()  # never an invalid action
    venv.close()


def test_make_vec_env_batched_and_its_errors():
    venv = make_vec_env(URBAN, 2, 3, {}, "batched")
    assert isinstance(venv, VecMonitor) and isinstance(venv.venv, BatchedVecEnv)
    ref = make_vec_env(URBAN, 2, 3, {}, "dummy")
    _equal(ref.reset(), venv.reset())  # seeded as the Dummy path (env i: seed + i)
    with pytest.raises(ValueError, match=r"vec_env='nope': must be one of \['batched', 'dummy', 'subproc'\]"):
        make_vec_env(URBAN, 2, 3, {}, "nope")
    with pytest.raises(ValueError, match=r"--vectorize batched.*fidelity='signal'"):
        make_vec_env(URBAN, 2, 3, {"fidelity": "signal"}, "batched")
    with pytest.raises(ValueError, match=r"^--vectorize batched on uwb_env/UrbanFamily-v0: it has no batched vector"):
        make_vec_env("uwb_env/UrbanFamily-v0", 2, 3, {}, "batched")


@pytest.mark.parametrize(
    ("argv", "named"),
    [(["--vectorize", "threads"], "vectorize='threads' (--vectorize): must be one of ['batched', 'dummy', 'subproc']"),
     (["--vectorize", "dummy", "--engine", "rllib"], "vectorize='dummy' (--vectorize): with engine='rllib' must be"),
     (["--vectorize", "batched", "--env-kwarg", "fidelity=signal"], "--vectorize batched"),
     (["--vectorize", "batched", "--engine", "rllib", "--env-kwarg", "fidelity=signal"], "--vectorize batched")],
)  # fmt: skip
def test_bad_vectorize_arguments_exit_2_naming_the_flag(argv, named, tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        train_main([*argv, "--env", URBAN, "--out", str(tmp_path / "r"), "--no-progress", "--timesteps", "8"])
    assert e.value.code == 2
    assert named in capsys.readouterr().err
    assert not (tmp_path / "r").exists()


def test_bad_vectorize_config_is_named(tmp_path):
    allowed = r"\['batched', 'dummy', 'subproc'\]"
    with pytest.raises(ValueError, match=rf"^vectorize='x' \(--vectorize\): must be one of {allowed}"):
        TrainConfig(env_id=URBAN, algo="ppo", timesteps=8, out=tmp_path / "r", vectorize="x")


def test_uwb_env_train_vectorize_batched(tmp_path, capsys):
    out = tmp_path / "run"
    train_main(["--env", MASKED_ID, "--env-kwarg", "out_of_service_rx=[rx1]", "--vectorize", "batched",
                "--timesteps", "128", "--out", str(out), "--no-progress", "--hyper", "n_envs=2", "n_steps=64",
                "batch_size=64", "n_epochs=1", "eval_episodes=1", "eval_freq=100000"])  # fmt: skip
    assert "trained maskable-ppo" in capsys.readouterr().out and (out / "model.zip").is_file()
    import yaml

    assert yaml.safe_load((out / "run.yaml").read_text())["common"]["vec_env"] == "batched"
