"""Sensing: truth + scan plan -> per-pair detections (parametric fidelity; the signal fidelity comes later)."""

from uwb_env.sensing.parametric import EpisodeGeometry, EpisodeSensing, ParametricSensor, azimuth_variance
from uwb_env.sensing.pd import (
    detection_probability,
    pd_swerling0,
    pd_swerling1,
    pd_swerling3,
    threshold_from_pfa,
)
from uwb_env.sensing.records import Detections, ScanPlan

__all__ = [
    "Detections",
    "EpisodeGeometry",
    "EpisodeSensing",
    "ParametricSensor",
    "ScanPlan",
    "azimuth_variance",
    "detection_probability",
    "pd_swerling0",
    "pd_swerling1",
    "pd_swerling3",
    "threshold_from_pfa",
]
