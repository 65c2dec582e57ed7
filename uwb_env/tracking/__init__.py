"""Tracking: the tracker seam (protocol, registry by ``TrackerConfig.kind``) and seed 003's VS-IMM / LMIPDA ``Tracker``.

Seed 000's particle PHD (``phd``) and seed 002's particle filter (``pf``) load through the registry.
"""

from uwb_env.scene.motion_models import ct_transition, nca_transition, ncv_transition, process_noise
from uwb_env.tracking import compiled
from uwb_env.tracking.imm import (
    SEED003_MODELS,
    SEED003_TRANSITION,
    imm_combine,
    imm_mix,
    restrict_transition,
    switch_model_sets,
)
from uwb_env.tracking.kernels import (
    UnscentedWeights,
    ekf_moments,
    gaussian_log_likelihood,
    joseph_update,
    kf_predict,
    mixture_reduce,
    sigma_points,
    ukf_moments,
)
from uwb_env.tracking.lmipda import lmipda, predict_existence
from uwb_env.tracking.measurement import measure
from uwb_env.tracking.protocol import MultiTargetTracker, Prediction
from uwb_env.tracking.registry import make_tracker
from uwb_env.tracking.tracker import Tracker, TrackSet

__all__ = [
    "SEED003_MODELS",
    "SEED003_TRANSITION",
    "MultiTargetTracker",
    "Prediction",
    "TrackSet",
    "Tracker",
    "UnscentedWeights",
    "compiled",
    "ct_transition",
    "ekf_moments",
    "gaussian_log_likelihood",
    "imm_combine",
    "imm_mix",
    "joseph_update",
    "kf_predict",
    "lmipda",
    "make_tracker",
    "measure",
    "mixture_reduce",
    "nca_transition",
    "ncv_transition",
    "predict_existence",
    "process_noise",
    "restrict_transition",
    "sigma_points",
    "switch_model_sets",
    "ukf_moments",
]
