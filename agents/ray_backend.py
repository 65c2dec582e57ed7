"""Campaigns on Ray: each paired run a Ray task, its record streamed back and written here as it finishes.

``uwb-env-evaluate --backend ray [--address ADDR]`` (or ``run_campaign(..., backend="ray", address=...)``):

- without ``--address`` a local Ray is started for the campaign (``ray.init(num_cpus=workers)``) and shut down
  after it; with one (``auto``, ``ray://head:10001``, ``host:6379``) the campaign joins that cluster and uses every
  CPU it offers. Each node needs this package installed (``pip install -e ".[ray]"``), as for any Ray job;
- a task plays one (scheme, seed) exactly as a local worker does (:func:`~uwb_env.agents.campaign.play_scheme`:
  the env built once per worker process, the same seeded streams) and returns the record; the driver writes it with
  the local backend's writer (:func:`~uwb_env.agents.campaign.write_record`), so the run files are byte-identical to
  the process pool's and resume, common random numbers and the summaries are unchanged;
- the driver writes each file as its task finishes: a killed driver leaves the finished runs on disk and a re-run
  resumes from them (the campaign's tasks die with their driver: Ray cancels a dead driver's work);
- Ctrl-C cancels the queued and running tasks (``ray.cancel(force=True)``) and propagates.

``ray`` is an optional dependency: nothing in ``uwb_env`` imports it; this module does, when a campaign asks for it.
"""

from __future__ import annotations

import pathlib
from typing import Any

from uwb_env.agents.campaign import Campaign, play_scheme, run_path, write_record

RAY_EXTRA = 'pip install -e ".[ray]"'


def import_ray() -> Any:
    """The ``ray`` module, or a clear error naming the extra that installs it."""
    try:
        import ray
    except ImportError as e:
        raise ValueError(f"backend='ray' needs the ray package: {RAY_EXTRA} (after torch==2.13.0)") from e
    return ray


def run_on_ray(
    campaign: Campaign, out: pathlib.Path, jobs: list[tuple[str, int]], bar: Any, workers: int, address: str | None
) -> None:
    """Play ``jobs`` (scheme, seed) as Ray tasks, writing each record under ``out`` as it returns (module docstring)."""
    if not jobs:
        return
    ray = import_ray()
    started = not ray.is_initialized()
    if started:
        ray.init(
            address=address,
            num_cpus=None if address else workers,
            include_dashboard=False,
            log_to_driver=False,
            configure_logging=False,
        )
    task = ray.remote(num_cpus=1, max_retries=0)(play_scheme)  # one run: its record and column names
    campaign_ref = ray.put(campaign)
    which = {task.remote(campaign_ref, s, seed): (s, seed) for s, seed in jobs}
    pending = list(which)
    try:
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            for ref in done:
                scheme, seed = which[ref]
                record, names = ray.get(ref)
                write_record(run_path(out, scheme, seed), record, names)
                bar.update()
    except BaseException:
        for ref in pending:
            ray.cancel(ref, force=True)
        raise
    finally:
        if started:
            ray.shutdown()
