"""In-sensor processing (seed 000 section IV): envelope, direct path, clutter removal, CFAR, 1-D clustering."""

from uwb_env.detection.cfar import (
    ca_cfar,
    ca_threshold_factor,
    dtb_cfar,
    g_cfar,
    os_cfar,
    os_false_alarm,
    os_threshold_factor,
)
from uwb_env.detection.clustering import cluster_detections
from uwb_env.detection.envelope import (
    align_to_reference,
    direct_path_toa,
    exponential_background,
    fine_alignment,
    fractional_shift,
    parabolic_peak,
    rectified_difference,
    square_law_envelope,
)

__all__ = [
    "align_to_reference",
    "ca_cfar",
    "ca_threshold_factor",
    "cluster_detections",
    "direct_path_toa",
    "dtb_cfar",
    "exponential_background",
    "fine_alignment",
    "fractional_shift",
    "g_cfar",
    "os_cfar",
    "os_false_alarm",
    "os_threshold_factor",
    "parabolic_peak",
    "rectified_difference",
    "square_law_envelope",
]
