"""Static scene geometry and target truth motion."""

from uwb_env.scene.geometry import point_segment_distance, segments_cross
from uwb_env.scene.layout import SceneLayout
from uwb_env.scene.motion_models import (
    STATE_DIM,
    ct_transition,
    model_transition,
    nca_transition,
    ncv_transition,
    process_noise,
)
from uwb_env.scene.truth import Truth, sample_truth

__all__ = [
    "STATE_DIM",
    "SceneLayout",
    "Truth",
    "ct_transition",
    "model_transition",
    "nca_transition",
    "ncv_transition",
    "point_segment_distance",
    "process_noise",
    "sample_truth",
    "segments_cross",
]
