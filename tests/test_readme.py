"""The README as a user of a fresh clone meets it: its examples run, it cites only files the repository has, its
commands write to folders that are not committed, and the repository carries no outputs beyond the references."""

from __future__ import annotations

import pathlib
import re
import shutil
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def _git(*args: str) -> list[str]:
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    out = subprocess.run(["git", *args], capture_output=True, text=True, cwd=ROOT, check=True)
    return out.stdout.splitlines()


def _python_blocks() -> list[str]:
    return re.findall(r"^```python\n(.*?)^```", README, flags=re.M | re.S)


def _shell_commands() -> list[str]:
    """Every command line of the README's bash blocks, continuation lines joined."""
    blocks = re.findall(r"^```bash\n(.*?)^```", README, flags=re.M | re.S)
    lines = "\n".join(blocks).replace("\\\n", " ").splitlines()
    return [line.split(" #")[0].strip() for line in lines if line.strip() and not line.lstrip().startswith("#")]


def test_the_readme_has_its_three_python_examples():
    blocks = _python_blocks()
    assert len(blocks) == 3
    assert any("gym.make(" in b for b in blocks)


@pytest.mark.parametrize("index", range(3))
def test_every_python_example_of_the_readme_runs_as_written(index):
    """Each example verbatim in a fresh interpreter (the env example plays a whole episode with myopic)."""
    code = _python_blocks()[index] + "\nprint('ran')\n"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().endswith("ran")


def test_the_readme_cites_no_file_outside_the_repository():
    assert re.search(r"SPEC\.md|STYLE\.md|shared folder|\.\./|(?<![\w-])seeds/", README) is None


def test_every_repository_path_the_readme_names_is_committed():
    """Committed, not merely on this disk: a local output (say ``results/seed003/runs.csv``) is not in a clone."""
    path = r"(?<![\w/.-])((?:uwb_env|agents|scripts|benchmarks|tests|results|\.ci)/[\w./-]*[\w/])"
    names = set(re.findall(path, README))
    names = {n for n in names if not n.endswith("-run") and "-run/" not in n and re.search(r"-v\d+$", n) is None}
    assert len(names) > 20
    tracked = _git("ls-files")
    missing = sorted(n for n in names if not any(f == n or f.startswith(n.rstrip("/") + "/") for f in tracked))
    assert missing == []


def test_every_command_that_writes_outputs_names_its_folder():
    writers = re.compile(r"^(uwb-env-evaluate|uwb-env-train|python scripts/(calibrate_\w+|signal_figures)\.py)\b")
    commands = [c for c in _shell_commands() if writers.match(c.split("&& ")[-1])]
    assert len(commands) >= 10
    assert [c for c in commands if "--out " not in c] == []


def test_the_readme_commands_write_to_folders_that_are_not_committed():
    """A fresh clone recomputes: no ``--out`` of the README is a folder with committed files, and git ignores it."""
    outs = sorted(set(re.findall(r"--out\s+([\w./-]+[\w/])", README)))
    assert "results/seed003-run" in outs and len(outs) >= 15
    assert [o for o in outs if _git("ls-files", "--", o)] == []
    ignored = _git("check-ignore", "--no-index", *[f"{o}/summary.md" for o in outs])
    assert sorted(p.removesuffix("/summary.md") for p in ignored) == outs


def test_the_repository_carries_no_outputs_beyond_the_references():
    """Neither training runs nor per-run records are committed; the tracked references are what .gitignore keeps."""
    assert _git("ls-files", "--", "runs") == []
    results = _git("ls-files", "--", "results")
    assert 0 < len(results) < 150
    assert [f for f in results if "/runs/" in f or f.endswith(("runs.csv", ".zip", ".pkl"))] == []
    assert _git("ls-files", "--cached", "--ignored", "--exclude-standard") == []  # index and .gitignore agree
    assert {f"results/{d}/summary.md" for d in ("seed003", "schedulers", "warmup-rl")} <= set(results)
