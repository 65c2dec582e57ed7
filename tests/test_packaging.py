"""The built wheel (issue 16 item 6): ``agents/`` installed as ``uwb_env.agents``, no ``scripts`` or ``agents``
top-level package, console entry points on installed modules, and a user's own ``agents/`` folder does not shadow
the library."""

from __future__ import annotations

import importlib.util
import pathlib
import shutil
import subprocess
import sys
import zipfile

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> pathlib.Path:
    if importlib.util.find_spec("setuptools") is None or importlib.util.find_spec("pip") is None:
        pytest.skip("building a wheel needs pip and setuptools")
    out = tmp_path_factory.mktemp("wheel")
    src = out / "src"  # a copy of the sources: the in-tree build's build/ and egg-info stay out of the repository
    skip = shutil.ignore_patterns("__pycache__", "*.pyc", "*.nbi", "*.nbc")
    for name in ("uwb_env", "agents"):
        shutil.copytree(ROOT / name, src / name, ignore=skip)
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        if (ROOT / name).exists():
            shutil.copy(ROOT / name, src / name)
    cmd = [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w", str(out), str(src)]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=out)
    if done.returncode != 0:
        pytest.skip(f"pip wheel failed here (offline build?): {done.stderr[-500:]}")
    (path,) = out.glob("uwb_env-*.whl")
    return path


def test_the_wheel_holds_uwb_env_agents_and_no_scripts_or_agents_package(wheel):
    names = zipfile.ZipFile(wheel).namelist()
    tops = {n.split("/")[0] for n in names if not n.split("/")[0].endswith(".dist-info")}
    assert tops == {"uwb_env"}
    for module in ("agents/__init__.py", "agents/campaign.py", "agents/cli.py", "agents/summary.py",
                   "agents/storage.py", "agents/rl/training.py", "agents/studies/calibrate_chirp.py",
                   "agents/rl/presets/UrbanWaveform-v3.yaml"):  # fmt: skip
        assert f"uwb_env/{module}" in names
    entry = next(n for n in names if n.endswith("entry_points.txt"))
    text = zipfile.ZipFile(wheel).read(entry).decode()
    assert "uwb-env-evaluate = uwb_env.agents.cli:evaluate_main" in text
    assert "uwb-env-train = uwb_env.agents.cli:train_main" in text


def test_a_users_own_agents_folder_does_not_shadow_the_installed_library(wheel, tmp_path):
    site = tmp_path / "site"
    zipfile.ZipFile(wheel).extractall(site)
    user = tmp_path / "project"
    (user / "agents").mkdir(parents=True)
    (user / "agents" / "__init__.py").write_text("MINE = True\n")
    code = (
        "import agents, uwb_env.agents, uwb_env.agents.campaign; "
        "assert agents.MINE; assert uwb_env.agents.__file__.startswith(sys.argv[1]), uwb_env.agents.__file__; "
        "from uwb_env.agents import make_scheduler; make_scheduler('myopic'); print('ok')"
    )
    done = subprocess.run([sys.executable, "-c", f"import sys; {code}", str(site)], cwd=user, capture_output=True,
                          text=True, timeout=120, env={"PYTHONPATH": str(site), "PATH": ""})  # fmt: skip
    assert done.stdout.strip() == "ok", done.stderr
