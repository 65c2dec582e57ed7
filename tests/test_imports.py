"""Import layering seen from a fresh interpreter: the low modules import no gymnasium (nor torch, stable-baselines3,
ray), and the env ids still reach ``gymnasium.make`` the documented ways, in either import order."""

from __future__ import annotations

import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
HEAVY = ("gymnasium", "torch", "stable_baselines3", "sb3_contrib", "ray")
ABOVE_THE_CORE = {"envs", "agents"}  # the gymnasium-aware package and the schedulers / campaigns


def _python(code: str) -> str:
    """Run ``code`` in a fresh interpreter from the repository root; its stdout (stderr shown on failure)."""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert out.returncode == 0, out.stderr
    return out.stdout.strip()


def _core_modules() -> list[str]:
    """Every module and package directly under ``uwb_env/`` except the env and the agents."""
    names = []
    for p in sorted((ROOT / "uwb_env").iterdir()):
        if p.name.startswith(("_", ".")) or p.name in ABOVE_THE_CORE:
            continue
        if p.suffix == ".py" or (p.is_dir() and (p / "__init__.py").exists()):
            names.append(f"uwb_env.{p.stem}")
    return names


def test_importing_uwb_env_units_imports_no_gymnasium():
    assert _python("import sys, uwb_env.units; print('gymnasium' in sys.modules)") == "False"


def test_importing_the_top_package_imports_no_gymnasium():
    assert _python("import sys, uwb_env; print('gymnasium' in sys.modules)") == "False"


def test_no_core_module_imports_gymnasium_torch_stable_baselines3_or_ray():
    """Imported one after the other in one interpreter; the first module that pulls a heavy package is named."""
    modules = _core_modules()
    assert {"uwb_env.units", "uwb_env.config", "uwb_env.scene", "uwb_env.tracking", "uwb_env.sim"} <= set(modules)
    code = (
        "import importlib, sys\n"
        f"for name in {modules!r}:\n"
        "    importlib.import_module(name)\n"
        f"    heavy = [m for m in {HEAVY!r} if m in sys.modules]\n"
        "    if heavy:\n"
        "        print(name, 'imports', *heavy)\n"
        "        break\n"
        "else:\n"
        "    print('clean')\n"
    )
    assert _python(code) == "clean"


ORDERS = {
    "import uwb_env, then gymnasium": "import uwb_env\nimport gymnasium as gym\n",
    "import gymnasium, then uwb_env": "import gymnasium as gym\nimport uwb_env\n",
    "import uwb_env.envs, then gymnasium": "from uwb_env.envs import ENV_IDS\nimport gymnasium as gym\n",
    "a low module only, then gymnasium": "import uwb_env.units\nimport gymnasium as gym\n",
    "gymnasium only, module:id": "import gymnasium as gym\n",
}


@pytest.mark.parametrize("order", ORDERS)
def test_gymnasium_make_finds_every_registered_id(order):
    prefix = "uwb_env:" if order.endswith("module:id") else ""
    code = ORDERS[order] + (
        "import sys\n"
        "from uwb_env.envs import ENV_IDS\n"
        f"envs = [gym.make({prefix!r} + env_id) for env_id in ENV_IDS]\n"
        "print(sorted(env.spec.id for env in envs))\n"
        "print(type(sys.modules['gymnasium'].__spec__.loader).__name__, type(gym.__loader__).__name__)\n"
        "print(any(type(f).__name__ == '_RegisterOnImport' for f in sys.meta_path))\n"
    )
    ids, loaders, hook_left = _python(code).splitlines()
    from uwb_env.envs import ENV_IDS

    assert ids == str(sorted(ENV_IDS))
    assert "_RunAfterExec" not in loaders  # gymnasium keeps its own loader
    assert hook_left == "False"  # the import hook removed itself once it had registered


def test_a_failing_env_import_is_reported_by_the_import_that_triggers_registration():
    """If ``uwb_env.envs`` cannot be imported, importing gymnasium afterwards says why, naming uwb_env.envs."""
    code = "import sys, uwb_env\nsys.modules['uwb_env.envs'] = None  # cannot be imported\nimport gymnasium\n"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert out.returncode != 0
    assert "once both are imported, and importing uwb_env.envs failed" in out.stderr
