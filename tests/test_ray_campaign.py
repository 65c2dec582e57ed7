"""Campaigns on Ray (uwb_env.agents.ray_backend): the process pool's run files, resumable after the driver dies."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from uwb_env.agents.campaign import Campaign, run_campaign

ray = pytest.importorskip("ray")

CAMPAIGN = Campaign("uwb_env/IndoorSensorSubset-v1", ("myopic", "random"), "random", runs=3)


def _files(folder):
    return {p.relative_to(folder): p.read_bytes() for p in sorted((folder / "runs").rglob("*.csv"))}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("local")
    run_campaign(CAMPAIGN, out, workers=2, progress=False)
    return _files(out)


def test_ray_tasks_write_the_process_pools_files(tmp_path, reference):
    """A local Ray cluster of 2 CPUs (started by the test) plays every run; the files are byte-identical."""
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, configure_logging=False)
    try:
        run_campaign(CAMPAIGN, tmp_path, workers=2, progress=False, backend="ray")
        assert ray.is_initialized()  # a cluster the caller started is left running
    finally:
        ray.shutdown()
    assert _files(tmp_path) == reference


def test_a_killed_ray_driver_resumes_to_the_same_files(tmp_path, reference):
    """SIGKILL the command while its Ray tasks run; the finished files stay, a re-run completes the rest."""
    cmd = [sys.executable, "-m", "uwb_env.agents.cli", "--env", CAMPAIGN.env, "--schemes", *CAMPAIGN.schemes,
           "--baseline", CAMPAIGN.baseline, "--runs", "3", "--workers", "2", "--backend", "ray", "--out", str(tmp_path),
           "--no-progress"]  # fmt: skip
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and len(list((tmp_path / "runs").rglob("*.csv"))) < 2:
            time.sleep(0.2)
        assert (tmp_path / "runs").exists(), "the campaign wrote nothing in 120 s"
        os.killpg(proc.pid, signal.SIGKILL)  # the driver and the local Ray it started
    finally:
        proc.wait(timeout=30)
    written = _files(tmp_path)
    assert written and len(written) <= len(reference)
    assert all(reference[k] == v for k, v in written.items())  # whatever finished is complete and right
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert _files(tmp_path) == reference


def test_bad_backend_arguments_are_named():
    with pytest.raises(ValueError, match=r"backend='dask': must be one of \('local', 'ray'\)"):
        run_campaign(CAMPAIGN, "unused", backend="dask")
    with pytest.raises(ValueError, match=r"address='auto': .*with backend 'ray' only"):
        run_campaign(CAMPAIGN, "unused", address="auto")
