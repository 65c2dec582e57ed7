"""Campaigns under faults (issue 16 item 2): a second campaign on one folder, Ctrl-C, SIGKILL, damaged run files.

Each test reproduces a defect first seen by hand: two campaigns sharing a temporary file name (run CSVs starting
with NUL bytes), a run CSV cut at a line boundary read as complete, Ctrl-C letting the campaign run on with no
summary, workers outliving a killed parent. The campaigns run as a user runs them (``python -m
uwb_env.agents.cli`` in its own session, so that its whole process group can be signalled and inspected).
"""

from __future__ import annotations

import os
import pathlib
import signal
import subprocess
import sys
import time

import pytest

from uwb_env.agents.campaign import Campaign, DamagedRun, preflight, read_record, run_campaign, run_path
from uwb_env.agents.storage import FolderLock, FolderLocked, atomic_write_text
from uwb_env.agents.summary import relative, summarise

ROOT = pathlib.Path(__file__).resolve().parents[1]
SHORT = ["n_scans=20", "targets.1.birth_time_s=1"]  # a few seconds for a whole campaign
LONG = ["n_scans=140", "targets.1.birth_time_s=1"]  # long episodes ...
# ... and enough of them to interrupt mid-way: at ~2,000 myopic steps/s a 140-scan episode takes ~0.1 s, and 8 paired
# runs (16 episodes on 2 workers) could finish between seeing the 4th run file and the signal arriving.
LONG_RUNS = 24


def _args(out: pathlib.Path, runs: int, overrides: list[str], workers: int = 2) -> list[str]:
    return ["--schemes", "myopic", "round-robin", "--runs", str(runs), "--set", *overrides,
            "--out", str(out), "--workers", str(workers), "--no-progress"]  # fmt: skip


def _foreground_signals() -> None:
    """In the child before exec: SIGINT and SIGTERM at their defaults, as in a campaign started at a terminal.

    A disposition set to ignore is inherited across exec, and Python then installs no KeyboardInterrupt handler; the
    test process's own may have been changed by what ran before it in the session (seen in a fresh clone's full
    suite: the Ctrl-C'd campaign ran to the end with returncode 0).
    """
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def _start(args: list[str]) -> subprocess.Popen:
    """The campaign command in its own session (its pid is its process group), signals as at a terminal."""
    return subprocess.Popen(
        [sys.executable, "-m", "uwb_env.agents.cli", *args],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=_foreground_signals,
    )


def _run(args: list[str]) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "uwb_env.agents.cli", *args], cwd=ROOT, capture_output=True,
                          text=True, timeout=300)  # fmt: skip


def _group(pgid: int) -> list[int]:
    """Live (not zombie) processes of process group ``pgid``, read from /proc."""
    pids = []
    for stat in pathlib.Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[2]) == pgid and fields[0] != "Z":
            pids.append(int(stat.parent.name))
    return pids


def _wait_empty(pgid: int, timeout: float = 10.0) -> list[int]:
    end = time.monotonic() + timeout
    while (left := _group(pgid)) and time.monotonic() < end:
        time.sleep(0.1)
    return left


def _wait_runs(out: pathlib.Path, n: int, proc: subprocess.Popen, timeout: float = 120.0) -> None:
    end = time.monotonic() + timeout
    while len(list((out / "runs").rglob("seed-*.csv"))) < n:
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < end, "the campaign did not get going"
        time.sleep(0.05)


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> pathlib.Path:
    """An uninterrupted campaign of LONG_RUNS paired runs (the long episodes the interrupt tests cut)."""
    out = tmp_path_factory.mktemp("reference")
    done = _run(_args(out, LONG_RUNS, LONG, workers=2))
    assert done.returncode == 0, done.stderr
    return out


pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")


def test_a_second_campaign_on_the_same_folder_is_refused_and_the_first_finishes_intact(tmp_path, reference):
    out = tmp_path / "c"
    first = _start(_args(out, LONG_RUNS, LONG))
    _wait_runs(out, 1, first)
    os.killpg(first.pid, signal.SIGSTOP)  # paused while holding the lock: the second surely meets a running first
    try:
        second = _run(_args(out, LONG_RUNS, LONG))
    finally:
        os.killpg(first.pid, signal.SIGCONT)
    assert second.returncode == 2
    assert f"{out}: another campaign (pid {first.pid}) is running on this folder" in second.stderr
    _, stderr = first.communicate(timeout=300)
    assert first.returncode == 0, stderr
    assert (out / "summary.md").read_bytes() == (reference / "summary.md").read_bytes()
    assert (out / "runs.csv").read_bytes() == (reference / "runs.csv").read_bytes()
    for p in (out / "runs").rglob("*"):
        assert p.is_dir() or (p.suffix == ".csv" and not p.name.startswith(".")), p


@pytest.mark.parametrize("how", ["Ctrl-C to the group", "SIGTERM to the campaign"])
def test_ctrl_c_stops_the_workers_at_once_writes_the_summary_of_finished_runs_and_resumes(tmp_path, reference, how):
    out = tmp_path / "c"
    proc = _start(_args(out, LONG_RUNS, LONG))
    _wait_runs(out, 4, proc)
    if how == "Ctrl-C to the group":
        os.killpg(proc.pid, signal.SIGINT)  # what the terminal does on Ctrl-C: the whole foreground group
    else:
        proc.terminate()  # SIGTERM to the main process only (a scheduler's or a user's kill)
    t0 = time.monotonic()
    stdout, stderr = proc.communicate(timeout=60)
    assert time.monotonic() - t0 < 15  # workers terminated, queued runs cancelled (not every run played out)
    assert proc.returncode == 130, stderr
    assert "interrupted with" in stderr and "run again to resume" in stderr
    finished = len(list((out / "runs").rglob("seed-*.csv")))
    assert finished < 2 * LONG_RUNS
    if "Interrupted:" in stdout:  # at least one seed finished by both schemes: its summary is printed and written
        assert "Interrupted:" in (out / "summary.md").read_text()
    assert _wait_empty(proc.pid) == []
    again = _run(_args(out, LONG_RUNS, LONG))
    assert again.returncode == 0, again.stderr
    assert (out / "summary.md").read_bytes() == (reference / "summary.md").read_bytes()
    assert (out / "runs.csv").read_bytes() == (reference / "runs.csv").read_bytes()


def test_sigkill_of_the_campaign_leaves_no_worker_and_the_resume_matches(tmp_path, reference):
    out = tmp_path / "c"
    proc = _start(_args(out, LONG_RUNS, LONG))
    _wait_runs(out, 3, proc)
    assert len(_group(proc.pid)) >= 3  # the campaign and its two workers
    proc.kill()  # the main process only: its workers must follow it (PR_SET_PDEATHSIG)
    proc.communicate(timeout=30)
    assert _wait_empty(proc.pid) == []
    again = _run(_args(out, LONG_RUNS, LONG))
    assert again.returncode == 0, again.stderr
    assert (out / "summary.md").read_bytes() == (reference / "summary.md").read_bytes()
    assert not list(out.rglob(".*.tmp"))  # a killed writer's temporary file is removed on resume


def _small(runs: int = 3) -> Campaign:
    return Campaign(
        env="uwb_env/UrbanWaveform-v3",
        schemes=("myopic", "round-robin"),
        baseline="round-robin",
        runs=runs,
        overrides={"n_scans": 20, "targets.1.birth_time_s": 1},
    )


@pytest.fixture(scope="module")
def small(tmp_path_factory) -> tuple[pathlib.Path, str]:
    out = tmp_path_factory.mktemp("small")
    run_campaign(_small(), out, workers=1, progress=False)
    return out, summarise(_small(), out)


def _damage(path: pathlib.Path, how: str) -> None:
    text = path.read_text()
    lines = text.splitlines(keepends=True)
    damaged = {
        "cut at a line boundary": "".join(lines[:-5]),
        "cut mid-line": text[: len(text) // 2],
        "NUL bytes": "\0" * len(text),
        "empty": "",
        "header only": lines[0],
        "a column missing": "".join(",".join(x.split(",")[:-1]) + "\n" for x in lines),
        "a value not a number": lines[0] + lines[1].replace(",", ",x", 1) + "".join(lines[2:]),
        "an infinite value": lines[0] + ",".join(["1", "inf", *lines[1].split(",")[2:]]) + "".join(lines[2:]),
        "a wrong header": "a,b,c\n" + "".join(lines[1:]),
        "a row repeated": "".join([*lines, lines[-1]]),
    }[how]
    path.write_text(damaged)


DAMAGE = ["cut at a line boundary", "cut mid-line", "NUL bytes", "empty", "header only", "a column missing",
          "a value not a number", "an infinite value", "a wrong header", "a row repeated"]  # fmt: skip


@pytest.mark.parametrize("how", DAMAGE)
def test_a_damaged_run_file_is_named_moved_aside_and_recomputed(tmp_path, small, capsys, how):
    """Before: a run CSV cut at a line boundary was read as complete and the summary rewritten with wrong numbers."""
    src, expected = small
    out = tmp_path / "c"
    subprocess.run(["cp", "-r", str(src), str(out)], check=True)
    path = run_path(out, "myopic", 1)
    _damage(path, how)
    with pytest.raises(DamagedRun, match=str(path)):
        read_record(path, preflight(_small())["myopic"])
    run_campaign(_small(), out, workers=1, progress=False)
    err = capsys.readouterr().err
    assert f"damaged file {path}" in err and "moved to seed-1.csv.damaged" in err
    assert (path.parent / "seed-1.csv.damaged").exists()
    assert summarise(_small(), out) == expected


def test_two_writers_never_share_a_temporary_file(tmp_path):
    """Atomic writes use unique temporary names: interleaved writers leave one whole file, never a mix."""
    import threading

    target = tmp_path / "f.csv"
    texts = [f"{i}\n" * 20_000 for i in range(8)]
    threads = [threading.Thread(target=atomic_write_text, args=(target, t)) for t in texts]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert target.read_text() in texts
    assert [p.name for p in tmp_path.iterdir()] == ["f.csv"]


def test_a_stale_lock_of_a_dead_process_is_taken_over_and_said(tmp_path, capsys):
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    pid = int(dead.stdout)
    tmp_path.joinpath(".lock").write_text(f"{pid}\n")
    with FolderLock(tmp_path) as lock:
        assert lock.took_over == pid
        assert tmp_path.joinpath(".lock").read_text() == f"{os.getpid()}\n"
    assert f"taking over the lock of pid {pid}, which is no longer running" in capsys.readouterr().err


def test_the_lock_is_exclusive_across_processes_and_reentrant_within_one(tmp_path):
    code = (
        "import sys, time; from uwb_env.agents.storage import FolderLock\n"
        f"with FolderLock(__import__('pathlib').Path({str(tmp_path)!r})):\n"
        "    print('locked', flush=True); time.sleep(30)\n"
    )
    holder = subprocess.Popen([sys.executable, "-c", code], cwd=ROOT, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        with pytest.raises(FolderLocked, match=rf"another campaign \(pid {holder.pid}\)"):
            FolderLock(tmp_path).acquire()
    finally:
        holder.kill()
        holder.wait()
        holder.stdout.close()
    with FolderLock(tmp_path), FolderLock(tmp_path):  # re-entrant: a campaign that runs, then summarises
        pass
    with FolderLock(tmp_path):  # released after the dead holder and after the nested use
        pass


def test_relative_difference_keeps_the_sign_for_a_negative_baseline():
    """Before: a return of -50 against a baseline of -100 was printed -50 % (the scheme is better: +50 %)."""
    assert relative(50.0, -100.0) == "+50.0 %"
    assert relative(-0.1, 0.5) == "-20.0 %"
    assert relative(1.0, 0.0) == "-" and relative(1.0, float("nan")) == "-"


def test_an_interrupt_in_a_serial_campaign_summarises_the_finished_paired_runs(tmp_path, small, monkeypatch):
    """workers=1: Ctrl-C while the 5th run plays (seeds 0 and 1 finished by both schemes) -> their summary."""
    import uwb_env.agents.campaign as campaign_module
    from uwb_env.agents.summary import CampaignInterrupted, evaluate

    real, calls = campaign_module.play, []

    def play(*args):
        calls.append(1)
        if len(calls) == 5:
            raise KeyboardInterrupt
        return real(*args)

    monkeypatch.setattr(campaign_module, "play", play)
    with pytest.raises(CampaignInterrupted, match="interrupted with 1 of 3 paired runs finished") as e:
        evaluate(_small(), tmp_path, workers=1, progress=False)
    # runs play scheme by scheme: myopic 0, 1, 2, then round-robin 0 (the 5th call is round-robin 1)
    assert "**Interrupted: 1 of 3 paired runs finished" in e.value.summary
    assert (tmp_path / "summary.md").read_text() == e.value.summary
    monkeypatch.setattr(campaign_module, "play", real)
    assert evaluate(_small(), tmp_path, workers=1, progress=False) == small[1]
