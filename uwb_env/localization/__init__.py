"""Network processing (seed 000 section V): ellipse intersection over nu-tuples, filtering, 2-D clustering."""

from uwb_env.localization.clustering import LINKAGES, cluster_positions
from uwb_env.localization.ellipse import ellipse_intersection, ls_ellipse_intersection
from uwb_env.localization.network import TupleMeasurements, geometry_covariance, locate, tuple_measurements

__all__ = [
    "LINKAGES",
    "TupleMeasurements",
    "cluster_positions",
    "ellipse_intersection",
    "geometry_covariance",
    "locate",
    "ls_ellipse_intersection",
    "tuple_measurements",
]
