"""Training under faults (issue 16 item 3): a killed run resumed, a damaged newest checkpoint, missing extras.

Before: ``--resume`` overwrote ``progress.csv`` (the history before the interruption was lost) and failed instead of
falling back when the newest checkpoint was damaged; without torch, training died with a bare
``ModuleNotFoundError``.
"""

from __future__ import annotations

import csv
import pathlib
import subprocess
import sys
import time

import pytest

from uwb_env.agents.rl import TrainConfig, load_scheduler, train

ROOT = pathlib.Path(__file__).resolve().parents[1]
ENV = "uwb_env/IndoorSensorSubset-v1"
HYPER = {"n_envs": 2, "eval_freq": 10**9, "eval_episodes": 1, "checkpoint_freq": 128, "n_steps": 64,
         "batch_size": 64, "n_epochs": 2}  # fmt: skip


def _cfg(out: pathlib.Path, steps: int) -> TrainConfig:
    return TrainConfig(ENV, "ppo", steps, out, seed=3, overrides=dict(HYPER))


def _steps(out: pathlib.Path) -> list[int]:
    with (out / "progress.csv").open() as f:
        return [int(float(r["time/total_timesteps"])) for r in csv.DictReader(f)]


def test_a_killed_training_resumes_with_continuous_logs_counters_and_normaliser(tmp_path, capsys):
    out = tmp_path / "run"
    hyper = [f"{k}={v}" for k, v in HYPER.items()]
    cmd = [sys.executable, "scripts/train.py", "--env", ENV, "--algo", "ppo", "--timesteps", "100000", "--seed", "3",
           "--out", str(out), "--no-progress", "--hyper", *hyper]  # fmt: skip
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        end = time.monotonic() + 240
        while not (out / "checkpoints" / "rl_model_vecnormalize_384_steps.pkl").exists():
            assert proc.poll() is None, proc.communicate()[1]
            assert time.monotonic() < end
            time.sleep(0.05)
    finally:
        proc.kill()  # mid-training, possibly mid-checkpoint
        proc.communicate()
    before = _steps(out)
    assert before[:2] == [128, 256]  # the history before the kill (the 384 row may not be logged yet)
    model = train(_cfg(out, 1024), resume=True, progress=False)
    err = capsys.readouterr().err
    assert "resuming from" in err and "rl_model_" in err
    assert model.num_timesteps == 1024
    after = _steps(out)
    # one row per PPO iteration, the history before the kill kept, nothing repeated. The row of the checkpoint's own
    # step (384) is there only if the killed run logged it: SB3 checkpoints before that iteration's update and log
    assert after[:2] == [128, 256] and after == sorted(set(after)) and after[-1] == 1024
    assert set(range(512, 1025, 128)) <= set(after) <= set(range(128, 1025, 128))
    assert load_scheduler(out).normalizer.obs_rms.count >= 1024  # the normaliser's statistics continued


def test_a_damaged_newest_checkpoint_falls_back_to_the_previous_one_and_says_so(tmp_path, capsys):
    out = tmp_path / "run"
    train(_cfg(out, 256), progress=False)
    newest = out / "checkpoints" / "rl_model_256_steps.zip"
    newest.write_bytes(newest.read_bytes()[:1000])  # cut, as by a kill while saving
    model = train(_cfg(out, 384), resume=True, progress=False)
    err = capsys.readouterr().err
    assert f"damaged file {newest}" in err and "trying the previous one" in err
    assert f"resuming from {out / 'checkpoints' / 'rl_model_128_steps.zip'} at 128 steps" in err
    assert model.num_timesteps == 384
    assert _steps(out) == [128, 256, 384]
    assert (out / "checkpoints" / "rl_model_256_steps.zip.damaged").exists()


def test_a_second_run_into_a_trained_folder_is_refused_without_resume(tmp_path):
    out = tmp_path / "run"
    train(_cfg(out, 128), progress=False)
    with pytest.raises(ValueError, match=r"already holds a training run .*use --resume or another --out"):
        train(_cfg(out, 256), progress=False)


# Makes ``import torch`` fail as if it were not installed (``sys.modules['torch'] = None`` is not the same: scipy
# reads ``sys.modules['torch'].Tensor`` when the key is present).
NO_TORCH = """
import importlib.abc, importlib.machinery, sys
class _Missing(importlib.abc.Loader):
    def create_module(self, spec):
        raise ModuleNotFoundError(f"No module named {spec.name!r}", name=spec.name)
    def exec_module(self, module):
        pass
class _NoTorch(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] == "torch":
            return importlib.machinery.ModuleSpec(name, _Missing())
        return None
sys.meta_path.insert(0, _NoTorch())
"""


def test_the_no_torch_shim_hides_torch():
    code = NO_TORCH + "import torch\n"
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert "ModuleNotFoundError: No module named 'torch'" in done.stderr


def test_training_without_torch_names_the_extra_to_install(tmp_path):
    code = NO_TORCH + (
        "from uwb_env.agents.cli import train_main\n"
        f"train_main(['--out', {str(tmp_path / 'run')!r}, '--timesteps', '10'])\n"
    )
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode != 0
    assert "training needs the rl extra (torch is missing)" in done.stderr
    assert 'pip install -e ".[rl]"' in done.stderr and "torch==2.13.0" in done.stderr
    assert "Traceback" not in done.stderr
    assert not (tmp_path / "run").exists()


def test_evaluate_works_without_torch(tmp_path):
    """The campaign command needs no rl extra: it imports torch only for rl: schemes."""
    code = NO_TORCH + (
        "from uwb_env.agents.cli import evaluate_main\n"
        "evaluate_main(['--schemes', 'fixed-0', 'fixed-1', '--runs', '2', '--set', 'n_scans=5',"
        " 'targets.1.birth_time_s=0.5', '--workers', '1', '--no-progress',"
        f" '--out', {str(tmp_path / 'c')!r}])\n"
    )
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "c" / "summary.md").exists()
