"""Sensing: truth + scan plan -> per-pair detections, behind one seam (``sensing.protocol``: ``make_sensor``).

Importing this package registers every sensor: the parametric one and the signal-level ones (``sensing.signal``).
"""

from uwb_env.sensing import signal
from uwb_env.sensing.parametric import EpisodeGeometry, EpisodeSensing, ParametricSensor, azimuth_variance
from uwb_env.sensing.pd import (
    detection_probability,
    pd_swerling0,
    pd_swerling1,
    pd_swerling3,
    threshold_from_pfa,
)
from uwb_env.sensing.protocol import Sensor, make_sensor, register_sensor, registered_sensors
from uwb_env.sensing.records import Detections, ScanPlan

__all__ = [
    "Detections",
    "EpisodeGeometry",
    "EpisodeSensing",
    "ParametricSensor",
    "ScanPlan",
    "Sensor",
    "azimuth_variance",
    "detection_probability",
    "make_sensor",
    "pd_swerling0",
    "pd_swerling1",
    "pd_swerling3",
    "register_sensor",
    "registered_sensors",
    "signal",
    "threshold_from_pfa",
]
