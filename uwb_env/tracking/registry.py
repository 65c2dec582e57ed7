"""The trackers by ``TrackerConfig.kind``: one factory per kind, imported when first built.

Every factory takes ``(cfg, layout, pd_model)``: the ``TrackerConfig``, the scene's ``SceneLayout`` (node positions,
walls, surveillance area) and an optional sensor model ``pd_model(tx, rx, positions (N, 2)) -> Pd (N,)`` (``rx = -1``:
the network's fused position measurement), and returns a ``MultiTargetTracker`` (``uwb_env.tracking.protocol``).
A new tracker is a new module and one line here.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable

from uwb_env.config import TRACKER_KINDS, TrackerConfig
from uwb_env.scene.layout import SceneLayout
from uwb_env.tracking.protocol import MultiTargetTracker
from uwb_env.typing import FloatArray

PdModel = Callable[[int, int, FloatArray], FloatArray]

FACTORIES: dict[str, str] = {
    "imm-lmipda": "uwb_env.tracking.tracker:Tracker.from_layout",
    "phd": "uwb_env.tracking.phd:PhdTracker.from_layout",
    "pf": "uwb_env.tracking.pf:ParticleFilterTracker.from_layout",
}
"""``kind -> "module:attribute"`` of its factory (imported lazily: the particle trackers compile numba kernels)."""
assert tuple(FACTORIES) == TRACKER_KINDS


def make_tracker(cfg: TrackerConfig, layout: SceneLayout, pd_model: PdModel | None = None) -> MultiTargetTracker:
    """Build the tracker of ``cfg.kind`` for the scene ``layout``."""
    if cfg.kind not in FACTORIES:
        raise ValueError(f"TrackerConfig.kind = {cfg.kind!r}: must be one of {tuple(FACTORIES)}")
    module, _, attribute = FACTORIES[cfg.kind].partition(":")
    factory: object = importlib.import_module(module)
    for part in attribute.split("."):
        factory = getattr(factory, part)
    return factory(cfg, layout, pd_model)  # type: ignore[operator]
