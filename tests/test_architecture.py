"""Layering and RNG discipline (STYLE.md B1, B4): enforced, not just written down."""

from __future__ import annotations

import ast
import doctest
import pathlib
import re
import subprocess
import sys

import tomllib

import uwb_env.units

ROOT = pathlib.Path(__file__).resolve().parents[1]


def test_core_packages_import_neither_gymnasium_nor_torch():
    """Only ``uwb_env/envs`` (and the package's registration hook) may import gymnasium; only ``agents/`` (installed
    as ``uwb_env.agents``) and ``scripts/`` may import torch or stable-baselines3."""
    root = pathlib.Path(__file__).resolve().parents[1] / "uwb_env"
    pattern = re.compile(r"^\s*(import|from)\s+(gymnasium|torch|stable_baselines3)\b", re.M)
    bad = [
        str(f.relative_to(root))
        for f in root.rglob("*.py")
        if f.parent.name != "envs" and f != root / "__init__.py" and pattern.search(f.read_text())
    ]
    assert bad == []
    code = "import sys, uwb_env; print(','.join(m for m in ('torch', 'stable_baselines3') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


def test_no_legacy_or_unseeded_randomness_in_the_package():
    pattern = re.compile(
        r"np\.random\.(seed|rand|randn|randint|normal|uniform|random|choice|RandomState)\b|"
        r"^\s*import random\b|default_rng\(\s*\)"
    )
    offenders = [
        f"{p.relative_to(ROOT)}:{i}"
        for p in (ROOT / "uwb_env").rglob("*.py")
        for i, line in enumerate(p.read_text().splitlines(), 1)
        if pattern.search(line)
    ]
    assert offenders == []


def test_units_doctests():
    result = doctest.testmod(uwb_env.units)
    assert result.attempted >= 4 and result.failed == 0


def _imports(path: pathlib.Path) -> list[str]:
    """Every module name a file imports (absolute imports; ``from x import y`` gives ``x``)."""
    names = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            names.append(node.module or "")
    return names


def test_only_agents_and_scripts_import_torch_and_stable_baselines3():
    heavy = re.compile(r"^(torch|stable_baselines3|sb3_contrib|ray)(\.|$)")
    allowed = (ROOT / "agents", ROOT / "scripts")
    offenders = [
        str(f.relative_to(ROOT))
        for top in ("uwb_env", "agents", "scripts", "benchmarks")
        for f in (ROOT / top).rglob("*.py")
        if not f.is_relative_to(allowed[0])
        and not f.is_relative_to(allowed[1])
        and any(heavy.match(n) for n in _imports(f))
    ]
    assert offenders == []


def test_nothing_imports_the_uninstalled_top_level_names():
    """``agents/`` is installed as ``uwb_env.agents`` and ``scripts/`` not at all: imports use the installed name."""
    offenders = [
        f"{f.relative_to(ROOT)}: {n}"
        for top in ("uwb_env", "agents", "scripts", "benchmarks", "tests")
        for f in (ROOT / top).rglob("*.py")
        for n in _imports(f)
        if re.match(r"^(agents|scripts)(\.|$)", n)
    ]
    assert offenders == []


def test_the_distribution_lists_every_package_folder_and_no_scripts_package():
    """``pyproject.toml`` lists its packages (``find`` cannot map ``agents/`` to ``uwb_env.agents``): every folder
    with an ``__init__.py`` under ``uwb_env/`` and ``agents/`` is listed, and ``scripts`` is not a package."""
    setup = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert setup["package-dir"] == {"uwb_env.agents": "agents"}
    found = {".".join(p.parent.relative_to(ROOT).parts) for p in (ROOT / "uwb_env").rglob("__init__.py")}
    found |= {".".join(("uwb_env", *p.parent.relative_to(ROOT).parts)) for p in (ROOT / "agents").rglob("__init__.py")}
    assert set(setup["packages"]) == found
    assert not (ROOT / "scripts" / "__init__.py").exists()
    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    assert all(target.startswith("uwb_env.") for target in scripts.values())


def test_scripts_are_thin_entry_points():
    """No function or class is defined in ``scripts/``: the logic lives in the packages, where tests reach it."""
    for f in (ROOT / "scripts").glob("*.py"):
        defs = [n.name for n in ast.parse(f.read_text()).body if isinstance(n, ast.FunctionDef | ast.ClassDef)]
        assert defs == [], f"{f.name} defines {defs}"


def test_importing_the_agents_does_not_import_torch():
    code = (
        "import sys, uwb_env.agents, uwb_env.agents.campaign, uwb_env.agents.summary, uwb_env.agents.cli; "
        "print(','.join(m for m in ('torch', 'stable_baselines3', 'ray') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert out.stdout.strip() == ""
