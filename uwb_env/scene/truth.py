"""Episode truth: all target states on the scan grid, drawn once per episode from the truth stream.

The truth is sampled whole at ``reset`` (each scan's truth step then only advances an index), so it can never depend on
the actions taken: two schedulers run on the same seed face the same targets (common random numbers).
Scan ``k`` (k = 0 .. n_scans) is at time ``t_k = k * scan_period_s``; k = 0 is the reset instant.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from uwb_env.config import (
    MotionModelTrajectoryConfig,
    RoomWalkTrajectoryConfig,
    ScenarioConfig,
    SegmentedTrajectoryConfig,
    TargetConfig,
)
from uwb_env.scene.layout import SceneLayout
from uwb_env.scene.trajectories import (
    motion_model_states,
    polyline_states,
    room_walk_polyline,
    segmented_states,
)
from uwb_env.typing import BoolArray, FloatArray


@dataclass(frozen=True, slots=True)
class Truth:
    """Target truth over one episode.

    Attributes:
        times_s: ``(S,)`` scan times [s], S = n_scans + 1.
        states: ``(S, K, 6)`` ``[x, vx, y, vy, ax, ay]`` per scan and target (undefined where not alive).
        alive: ``(S, K)`` whether each target exists at each scan.
    """

    times_s: FloatArray
    states: FloatArray
    alive: BoolArray

    @property
    def n_targets(self) -> int:
        """Number of targets K."""
        return int(self.states.shape[1])


@lru_cache(maxsize=64)
def _segmented_cached(
    traj: SegmentedTrajectoryConfig, birth_s: float, n: int, dt: float
) -> tuple[FloatArray, BoolArray]:
    """Deterministic paths do not change between episodes: evaluate once per (path, birth, grid)."""
    states, valid = segmented_states(traj, np.arange(n) * dt - birth_s)
    states.flags.writeable = False
    valid.flags.writeable = False
    return states, valid


def _target_states(
    target: TargetConfig, local_t: FloatArray, dt: float, layout: SceneLayout, rng: np.random.Generator
) -> tuple[FloatArray, BoolArray]:
    traj = target.trajectory
    if isinstance(traj, SegmentedTrajectoryConfig):
        return _segmented_cached(traj, target.birth_time_s, local_t.size, dt)
    if isinstance(traj, MotionModelTrajectoryConfig):
        return motion_model_states(traj, local_t, dt, rng)
    if isinstance(traj, RoomWalkTrajectoryConfig):
        vertices = room_walk_polyline(traj, layout.wall_start, layout.wall_end, rng)
        return polyline_states(vertices, traj.speed_mps, local_t)
    raise TypeError(f"unknown trajectory config {type(traj).__name__}")


def sample_truth(cfg: ScenarioConfig, rng: np.random.Generator, layout: SceneLayout | None = None) -> Truth:
    """Draw the whole episode's truth from the truth stream ``rng`` (targets in config order)."""
    layout = layout or SceneLayout.from_config(cfg)
    dt = cfg.sensing.scan_period_s
    times = np.arange(cfg.n_scans + 1) * dt
    states = np.zeros((times.size, len(cfg.targets), 6))
    alive = np.zeros((times.size, len(cfg.targets)), dtype=bool)
    for j, target in enumerate(cfg.targets):  # a few targets per scenario; each path is vectorised over time
        local = times - target.birth_time_s
        states[:, j], valid = _target_states(target, local, dt, layout, rng)
        alive[:, j] = valid & (local >= -1e-9)
    return Truth(times_s=times, states=states, alive=alive)
