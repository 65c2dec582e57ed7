"""Layering and RNG discipline (STYLE.md B1, B4): enforced, not just written down."""

from __future__ import annotations

import doctest
import pathlib
import re
import subprocess
import sys

import uwb_env.units

ROOT = pathlib.Path(__file__).resolve().parents[1]


def test_core_packages_import_neither_gymnasium_nor_torch():
    """Only ``uwb_env/envs`` (and the package's registration hook) may import gymnasium; nothing imports torch."""
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
