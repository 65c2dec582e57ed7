"""The static scene as arrays: node positions, walls, scatterers, areas (built once from a ScenarioConfig)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from uwb_env.config import ScenarioConfig
from uwb_env.typing import BoolArray, FloatArray


@dataclass(frozen=True, slots=True)
class SceneLayout:
    """Array view of the static scene.

    Attributes:
        tx_pos: ``(T, 2)`` transmitter positions [m]; rx_pos: ``(R, 2)`` receiver positions [m].
        wall_start, wall_end: ``(W, 2)`` wall segments [m]; wall_loss_db: ``(W,)`` one-way loss per crossing
            (inf = opaque); wall_delay_s: ``(W,)`` excess delay per crossing [s].
        clutter_points: ``(C, 2)`` discrete clutter scatterers [m].
        area: ``(4,)`` surveillance area ``[x_min, x_max, y_min, y_max]`` [m].
        rx_has_array: ``(R,)``; rx_n_elements: ``(R,)`` (1 without array); rx_boresight_rad, rx_fov_rad,
            rx_spacing_m: ``(R,)`` array geometry (nan without array).
    """

    tx_pos: FloatArray
    rx_pos: FloatArray
    wall_start: FloatArray
    wall_end: FloatArray
    wall_loss_db: FloatArray
    wall_delay_s: FloatArray
    clutter_points: FloatArray
    area: FloatArray
    rx_has_array: BoolArray
    rx_n_elements: FloatArray
    rx_boresight_rad: FloatArray
    rx_fov_rad: FloatArray
    rx_spacing_m: FloatArray

    @classmethod
    def from_config(cls, cfg: ScenarioConfig) -> SceneLayout:
        """Build the arrays from a validated scenario."""
        walls = cfg.walls
        arrays = [r.array for r in cfg.receivers]
        a = cfg.surveillance_area
        return cls(
            tx_pos=np.array([t.position_m for t in cfg.transmitters], dtype=float).reshape(-1, 2),
            rx_pos=np.array([r.position_m for r in cfg.receivers], dtype=float).reshape(-1, 2),
            wall_start=np.array([w.start_m for w in walls], dtype=float).reshape(-1, 2),
            wall_end=np.array([w.end_m for w in walls], dtype=float).reshape(-1, 2),
            wall_loss_db=np.array([w.material.loss_db for w in walls], dtype=float),
            wall_delay_s=np.array([w.material.excess_delay_s for w in walls], dtype=float),
            clutter_points=np.array(cfg.clutter_points_m, dtype=float).reshape(-1, 2),
            area=np.array([a.x_min_m, a.x_max_m, a.y_min_m, a.y_max_m]),
            rx_has_array=np.array([ar is not None for ar in arrays]),
            rx_n_elements=np.array([ar.n_elements if ar else 1 for ar in arrays], dtype=float),
            rx_boresight_rad=np.array([math.radians(ar.boresight_deg) if ar else np.nan for ar in arrays]),
            rx_fov_rad=np.array([math.radians(ar.field_of_view_deg) if ar else np.nan for ar in arrays]),
            rx_spacing_m=np.array([ar.spacing_m if ar else np.nan for ar in arrays]),
        )

    @property
    def n_tx(self) -> int:
        """Number of transmitters T."""
        return int(self.tx_pos.shape[0])

    @property
    def n_rx(self) -> int:
        """Number of receivers R."""
        return int(self.rx_pos.shape[0])

    @property
    def baselines(self) -> FloatArray:
        """``(T, R)`` transmitter-receiver distances [m]."""
        return np.linalg.norm(self.tx_pos[:, None] - self.rx_pos[None], axis=-1)
