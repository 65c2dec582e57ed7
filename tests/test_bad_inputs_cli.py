"""Bad input to the command lines and damaged files (issue 16): every case refused with an error that names the
field or file, the value and what is allowed; none silently accepted; nothing written by a refused campaign.

Before: ``--seed0 -5`` failed only after ``campaign.json`` was written, a typo in ``--set`` wrote it first (so the
corrected re-run was refused), ``--timesteps -5`` exited 0 with an untrained model, ``--hyper tensorboard_log=...``
was ignored, ``--env-kwarg a=1 --env-kwarg b=2`` kept only ``b``, and damaged ``campaign.json``, ``run.yaml`` or
``vecnormalize.pkl`` gave errors that named no file.
"""

from __future__ import annotations

import importlib.util
import json
import pathlib
import pickle
import re

import pytest

from uwb_env.agents.campaign import Campaign, check_workers
from uwb_env.agents.cli import evaluate_main, parse_overrides, train_main

U = "uwb_env/UrbanWaveform-v3"

# (argv, substrings the error must contain: the field, the value, what is allowed)
EVALUATE = {
    "runs 1": (["--runs", "1"], ["--runs", "1 must be >= 2"]),
    "runs 0": (["--runs", "0"], ["--runs", "0 must be >= 2"]),
    "runs negative": (["--runs", "-3"], ["--runs", "-3 must be >= 2"]),
    "runs not a number": (["--runs", "abc"], ["--runs", "'abc' is not an integer (must be >= 2)"]),
    "runs a float": (["--runs", "2.5"], ["--runs", "'2.5' is not an integer"]),
    "runs missing value": (["--runs"], ["--runs", "expected one argument"]),
    "seed0 negative": (["--seed0", "-5"], ["--seed0", "-5 must be >= 0"]),
    "seed0 not a number": (["--seed0", "x"], ["--seed0", "'x' is not an integer (must be >= 0)"]),
    "workers 0": (["--workers", "0"], ["--workers", "0 must be >= 1"]),
    "workers negative": (["--workers", "-1"], ["--workers", "-1 must be >= 1"]),
    "workers not a number": (["--workers", "two"], ["--workers", "'two' is not an integer (must be >= 1)"]),
    "unknown env": (["--env", "nope"], ["--env", "invalid choice: 'nope'", U]),
    "unknown preset": (["--preset", "nope"], ["--preset", "invalid choice: 'nope'", "seed003"]),
    "unknown scheduler": (["--schemes", "greedy"], ["scheme 'greedy'", "scheduler='greedy'", "must be one of"]),
    "unknown tracker": (["--schemes", "myopic@nn"], ["scheme 'myopic@nn'", "tracker 'nn'", "open-loop"]),
    "scheme twice": (["--schemes", "myopic", "myopic"], ["schemes=['myopic', 'myopic']", "listed twice"]),
    "fixed action out of range": (["--schemes", "fixed-99", "myopic"], ["scheme 'fixed-99'", "99", "0..5"]),
    "lookahead depth 0": (["--schemes", "lookahead-0"], ["scheme 'lookahead-0'", "depth=0", "must be >= 1"]),
    "rl run missing": (["--schemes", "rl:/nonexistent", "myopic"], ["rl:/nonexistent", "not a trained run"]),
    "baseline not a scheme": (["--schemes", "myopic", "--baseline", "random"], ["baseline='random'", "['myopic']"]),
    "set without =": (["--set", "n_scans"], ["--set 'n_scans'", "must be KEY=VALUE"]),
    "set without key": (["--set", "=5"], ["--set '=5'", "must be KEY=VALUE"]),
    "set unknown field": (["--set", "nosuch.field=1"], ["unknown field 'nosuch'", "allowed:", "n_scans"]),
    "set n_scans negative": (["--set", "n_scans=-4"], ["n_scans = -4", "must be an integer >= 1"]),
    "set n_scans 0": (["--set", "n_scans=0"], ["n_scans = 0", "must be an integer >= 1"]),
    "set n_scans text": (["--set", "n_scans=abc"], ["n_scans = 'abc'", "must be an integer >= 1"]),
    "set clutter negative": (["--set", "sensing.clutter.density_per_m2=-1"], ["density_per_m2 = -1.0", "[0.0, 1.0]"]),
    "set no waveforms": (["--set", "waveforms=[]"], ["waveforms = ()", "non-empty"]),
    "set key twice": (["--set", "n_scans=5", "n_scans=6"], ["--set 'n_scans=6'", "'n_scans' is given twice"]),
    "set key twice, repeated flag": (["--set", "n_scans=5", "--set", "n_scans=6"], ["'n_scans' is given twice"]),
    "set value not YAML": (["--set", "x=[1,"], ["--set 'x=[1,'", "'[1,' is not valid YAML"]),
    "env-kwarg without =": (["--env-kwarg", "nokey"], ["--env-kwarg 'nokey'", "must be KEY=VALUE"]),
    "env-kwarg bool as text": (
        ["--env-kwarg", "include_lookahead=maybe"],
        ["include_lookahead='maybe'", "True or False"],
    ),
    "env-kwarg n_slots 0": (["--env-kwarg", "n_slots=0"], ["n_slots=0", "[1, 1024]"]),
    "env-kwarg n_slots float": (["--env-kwarg", "n_slots=8.5"], ["n_slots=8.5", "[1, 1024]"]),
    "env-kwarg observation": (["--env-kwarg", "observation=xyz"], ["observation='xyz'", "('box', 'dict')"]),
    "env-kwarg action_kind": (["--env-kwarg", "action_kind=foo"], ["action_kind='foo'", "'waveform'"]),
    "env-kwarg fidelity": (["--env-kwarg", "fidelity=exact"], ["fidelity='exact'", "'parametric', 'signal'"]),
    "env-kwarg cover gate": (["--env-kwarg", "cover_gate_m=-1"], ["cover_gate_m=-1", "> 0.0"]),
    "env-kwarg scenario": (["--env-kwarg", "scenario=nope"], ["scenario 'nope'", "urban-intersection"]),
    "env-kwarg unknown": (["--env-kwarg", "nosuch=1"], ["unknown field 'nosuch'", "allowed:"]),
    "env-kwarg key twice": (["--env-kwarg", "n_slots=4", "--env-kwarg", "n_slots=5"], ["'n_slots' is given twice"]),
}


@pytest.mark.parametrize("case", sorted(EVALUATE))
def test_a_bad_campaign_argument_is_refused_naming_it_and_writes_nothing(tmp_path, capsys, case):
    argv, expected = EVALUATE[case]
    out = tmp_path / "c"
    args = ["--out", str(out), "--no-progress", "--workers", "1"]
    if "--runs" not in argv:
        args += ["--runs", "2"]
    with pytest.raises(SystemExit) as e:
        evaluate_main([*args, *argv])
    assert e.value.code == 2
    err = capsys.readouterr().err
    for s in expected:
        assert s in err, (s, err)
    assert not (out / "campaign.json").exists()


def test_out_that_is_a_file_is_refused(tmp_path, capsys):
    f = tmp_path / "f"
    f.write_text("x")
    with pytest.raises(SystemExit):
        evaluate_main(["--out", str(f), "--runs", "2"])
    assert f"argument --out: '{f}' is a file (must be a folder" in capsys.readouterr().err


def _campaign_folder(tmp_path: pathlib.Path, content: bytes) -> pathlib.Path:
    out = tmp_path / "c"
    out.mkdir()
    (out / "campaign.json").write_bytes(content)
    return out


DAMAGED_DEFINITIONS = {
    "not JSON": (b"{not json", "cannot be read as a campaign definition"),
    "empty": (b"", "cannot be read as a campaign definition"),
    "NUL bytes": (b"\0" * 64, "cannot be read as a campaign definition"),
    "a list": (b"[1, 2]", "a JSON list, not an object"),
    "another campaign": (
        json.dumps({"env": U, "schemes": ["myopic", "round-robin"], "seed0": 0, "overrides": {"n_scans": 7}}).encode(),
        "field 'overrides' is {'n_scans': 7}",
    ),
}


@pytest.mark.parametrize("case", sorted(DAMAGED_DEFINITIONS))
def test_a_damaged_or_foreign_campaign_json_is_named_and_kept(tmp_path, capsys, case):
    content, expected = DAMAGED_DEFINITIONS[case]
    out = _campaign_folder(tmp_path, content)
    with pytest.raises(SystemExit) as e:
        evaluate_main(["--out", str(out), "--runs", "2", "--workers", "1", "--no-progress"])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert f"{out / 'campaign.json'}" in err and expected in err, err
    assert (out / "campaign.json").read_bytes() == content  # not overwritten


CAMPAIGN_FIELDS = {
    "runs a bool": ({"runs": True}, "runs=True: must be of type int"),
    "seed0 a float": ({"seed0": 1.5}, "seed0=1.5: must be of type int"),
    "seed0 negative": ({"seed0": -1}, "seed0=-1: must be >= 0"),
    "schemes a list": ({"schemes": ["myopic"]}, "schemes=['myopic']: must be of type tuple"),
    "schemes empty": ({"schemes": ()}, "schemes=[]: give at least one scheme"),
    "scheme not a string": ({"schemes": (3,)}, "schemes: 3 must be a string"),
    "overrides not a mapping": ({"overrides": [1]}, "overrides=[1]: must be of type dict"),
    "reference metric unknown": ({"reference": {"speed": "+1 %"}}, "reference metrics ['speed']: must be among"),
}


@pytest.mark.parametrize("case", sorted(CAMPAIGN_FIELDS))
def test_a_bad_campaign_field_is_refused_naming_it(case):
    change, expected = CAMPAIGN_FIELDS[case]
    fields = {"env": U, "schemes": ("myopic",), "baseline": "myopic", "runs": 3, **change}
    with pytest.raises(ValueError, match=re.escape(expected)):
        Campaign(**fields)


@pytest.mark.parametrize("workers", [0, -2, True, 1.5, "2"])
def test_bad_worker_counts_are_refused(workers):
    with pytest.raises(ValueError, match=rf"workers={workers!r}: must be an integer >= 1"):
        check_workers(workers)


def test_pairs_accumulate_the_same_way_in_both_commands():
    """``--env-kwarg a=1 --env-kwarg b=2`` and ``--env-kwarg a=1 b=2`` give both keys, in both parsers."""
    from uwb_env.agents.cli import evaluate_parser, train_parser

    for parser, flag, dest in ((evaluate_parser(), "--env-kwarg", "env_kwargs"), (train_parser(), "--env-kwarg",
                               "env_kwargs"), (evaluate_parser(), "--set", "overrides"), (train_parser(), "--hyper",
                               "hyper")):  # fmt: skip
        base = ["--out", "x"]
        a = vars(parser.parse_args([*base, flag, "a=1", flag, "b=2"]))[dest]
        b = vars(parser.parse_args([*base, flag, "a=1", "b=2"]))[dest]
        assert parse_overrides(a) == parse_overrides(b) == {"a": 1, "b": 2}


# ------------------------------------------------------------------------------------------------ training
TRAIN = {
    "timesteps negative": (["--timesteps", "-5"], ["--timesteps", "-5 must be >= 1"]),
    "timesteps 0": (["--timesteps", "0"], ["--timesteps", "0 must be >= 1"]),
    "timesteps text": (["--timesteps", "many"], ["--timesteps", "'many' is not an integer (must be >= 1)"]),
    "seed negative": (["--seed", "-1"], ["--seed", "-1 must be >= 0"]),
    "unknown algo": (["--algo", "sac"], ["--algo", "invalid choice: 'sac'", "maskable-ppo"]),
    "unknown env": (["--env", "nope"], ["--env", "invalid choice: 'nope'", U]),
    "hyper tensorboard_log": (["--hyper", "tensorboard_log=/tmp/tb"], ["tensorboard_log='/tmp/tb'", "--tensorboard"]),
    "hyper seed": (["--hyper", "seed=3"], ["--hyper seed=3", "use --seed"]),
    "hyper device": (["--hyper", "device=cuda"], ["--hyper device='cuda'", "CPU"]),
    "hyper unknown": (["--hyper", "nosuch=1"], ["--hyper nosuch=1", "unknown for ppo", "learning_rate"]),
    "hyper dqn-only for ppo": (["--hyper", "buffer_size=10"], ["--hyper buffer_size=10", "unknown for ppo"]),
    "hyper n_envs 0": (["--hyper", "n_envs=0"], ["--hyper n_envs=0", "integer >= 1"]),
    "hyper n_envs float": (["--hyper", "n_envs=1.5"], ["--hyper n_envs=1.5", "integer >= 1"]),
    "hyper n_steps text": (["--hyper", "n_steps=abc"], ["--hyper n_steps='abc'", "integer >= 1"]),
    "hyper checkpoint_freq 0": (["--hyper", "checkpoint_freq=0"], ["--hyper checkpoint_freq=0", "integer >= 1"]),
    "hyper eval_episodes negative": (["--hyper", "eval_episodes=-2"], ["eval_episodes=-2", "integer >= 1"]),
    "hyper learning_rate negative": (["--hyper", "learning_rate=-1"], ["learning_rate=-1", "number >= 0"]),
    "hyper gamma above 1": (["--hyper", "gamma=2"], ["--hyper gamma=2", "[0, 1]"]),
    "hyper vec_env": (["--hyper", "vec_env=threads"], ["vec_env='threads'", "'dummy' or 'subproc'"]),
    "hyper normalize": (["--hyper", "normalize=sometimes"], ["normalize='sometimes'", "false or a mapping"]),
    "hyper policy": (["--hyper", "policy=TransformerPolicy"], ["policy='TransformerPolicy'", "'MlpPolicy'"]),
    "hyper policy_kwargs": (["--hyper", "policy_kwargs=5"], ["--hyper policy_kwargs=5", "must be a mapping"]),
    "hyper rejected by SB3": (["--hyper", "batch_size=1"], ["ppo with hyper-parameters", "batch_size"]),
    "hyper without =": (["--hyper", "badpair"], ["--hyper 'badpair'", "must be KEY=VALUE"]),
    "hyper key twice": (["--hyper", "n_envs=1", "--hyper", "n_envs=2"], ["'n_envs' is given twice"]),
    "env-kwarg unknown": (["--env-kwarg", "nosuch=1"], ["--env-kwarg {'nosuch': 1}", "unknown field 'nosuch'"]),
    "env-kwarg n_slots": (["--env-kwarg", "n_slots=-1"], ["n_slots=-1", "[1, 1024]"]),
    "env-kwarg bool as text": (["--env-kwarg", "include_lookahead=maybe"], ["include_lookahead='maybe'", "True or"]),
}
if importlib.util.find_spec("tensorboard") is None:
    TRAIN["tensorboard missing"] = (["--tensorboard"], ["tensorboard=True", "pip install tensorboard"])


@pytest.mark.parametrize("case", sorted(TRAIN))
def test_a_bad_training_argument_is_refused_naming_it_and_writes_nothing(tmp_path, capsys, case):
    pytest.importorskip("stable_baselines3")
    argv, expected = TRAIN[case]
    out = tmp_path / "run"
    with pytest.raises(SystemExit) as e:
        train_main(["--out", str(out), "--no-progress", "--env", U, "--algo", "ppo", *argv])
    assert e.value.code == 2
    err = capsys.readouterr().err
    for s in expected:
        assert s in err, (s, err)
    assert not (out / "run.yaml").exists() and not (out / "model.zip").exists()


@pytest.fixture(scope="module")
def trained(tmp_path_factory) -> pathlib.Path:
    """A tiny trained run (128 steps) to damage."""
    pytest.importorskip("stable_baselines3")
    from uwb_env.agents.rl import TrainConfig, train

    out = tmp_path_factory.mktemp("trained") / "run"
    over = {"n_envs": 2, "eval_freq": 10**9, "eval_episodes": 1, "checkpoint_freq": 64, "n_steps": 64,
            "batch_size": 64, "n_epochs": 1}  # fmt: skip
    train(TrainConfig("uwb_env/IndoorSensorSubset-v1", "ppo", 128, out, overrides=over), progress=False)
    return out


DAMAGED_RUN_FILES = {
    "run.yaml not YAML": ("run.yaml", b"algo: [ppo", "run.yaml: cannot be read as a training run's configuration"),
    "run.yaml a list": ("run.yaml", b"- ppo\n", "a YAML list, not a mapping"),
    "run.yaml empty": ("run.yaml", b"", "a YAML NoneType, not a mapping"),
    "run.yaml unknown algo": ("run.yaml", b"algo: sac\nenv_id: x\n", "run.yaml: algo='sac' must be one of"),
    "model.zip not a zip": ("model.zip", b"garbage", "model.zip: cannot be read as a saved ppo model (zip)"),
    "model.zip cut": ("model.zip", None, "model.zip: cannot be read as a saved ppo model (zip)"),
    "vecnormalize.pkl garbage": ("vecnormalize.pkl", b"\x80\x04garbage", "vecnormalize.pkl: cannot be read as a"),
    "vecnormalize.pkl empty": ("vecnormalize.pkl", b"", "vecnormalize.pkl: cannot be read as a VecNormalize"),
    "vecnormalize.pkl another object": ("vecnormalize.pkl", pickle.dumps({"a": 1}), "a pickled dict, not a"),
}


@pytest.mark.parametrize("case", sorted(DAMAGED_RUN_FILES))
def test_a_damaged_trained_run_file_is_named(tmp_path, trained, case):
    from uwb_env.agents.rl import load_scheduler

    name, content, expected = DAMAGED_RUN_FILES[case]
    run = tmp_path / "run"
    run.mkdir()
    for f in ("run.yaml", "model.zip", "vecnormalize.pkl"):
        (run / f).write_bytes((trained / f).read_bytes())
    original = (run / name).read_bytes()
    (run / name).write_bytes(original[: len(original) // 2] if content is None else content)
    with pytest.raises(ValueError, match=re.escape(str(run / name))) as e:
        load_scheduler(run)
    assert expected in str(e.value), str(e.value)


def test_a_damaged_run_yaml_on_resume_is_named(tmp_path, trained, capsys):
    run = tmp_path / "run"
    run.mkdir()
    (run / "run.yaml").write_text("env_id: [")
    with pytest.raises(SystemExit):
        train_main(["--out", str(run), "--env", "uwb_env/IndoorSensorSubset-v1", "--algo", "ppo", "--resume",
                    "--timesteps", "256", "--no-progress"])  # fmt: skip
    assert f"{run / 'run.yaml'}: cannot be read as a training run's configuration" in capsys.readouterr().err


def test_a_resume_with_another_seed_is_refused(trained, capsys):
    with pytest.raises(SystemExit):
        train_main(["--out", str(trained), "--env", "uwb_env/IndoorSensorSubset-v1", "--algo", "ppo", "--resume",
                    "--seed", "9", "--timesteps", "256", "--no-progress"])  # fmt: skip
    assert "--resume: seed = 9 differs from the run's 0" in capsys.readouterr().err
