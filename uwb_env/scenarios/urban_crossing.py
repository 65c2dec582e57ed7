"""``urban-crossing``: two vehicles whose paths cross at the same time, in seed 003's intersection.

Seed 003's scene, nodes, waveforms and clutter; our targets (the tracker issue asks for crossing targets): one
drives east along y = 1505 from x = 1960 at 10 m/s, the other north along x = 2060 from y = 1420 at 8.5 m/s; both
reach (2060, 1505) at t = 10 s and go on for 10 s. 80 scans of 0.25 s. The default model set {NCV, NCA} (no
turns) is active throughout.
"""

from __future__ import annotations

import dataclasses

from uwb_env.config import (
    MotionSegmentConfig,
    ScenarioConfig,
    SegmentedTrajectoryConfig,
    TargetConfig,
)
from uwb_env.scenarios import register
from uwb_env.scenarios.urban_intersection import urban_intersection

CROSSING_POINT = (2060.0, 1505.0)
CROSSING_TIME_S = 10.0


@register("urban-crossing")
def urban_crossing() -> ScenarioConfig:
    """Two vehicles crossing in seed 003's urban intersection."""
    base = urban_intersection()
    east = SegmentedTrajectoryConfig((1960.0, 1505.0), (10.0, 0.0), (MotionSegmentConfig("cv", 20.0),))
    north = SegmentedTrajectoryConfig((2060.0, 1420.0), (0.0, 8.5), (MotionSegmentConfig("cv", 20.0),))
    return dataclasses.replace(
        base,
        name="urban-crossing",
        description="Seed 003's intersection: two vehicles whose paths cross at the same instant.",
        seed_reference="003 (scene, nodes, waveforms, clutter); crossing targets are ours",
        targets=(
            TargetConfig("eastbound", east, rcs_mean_m2=10.0, swerling=1),
            TargetConfig("northbound", north, rcs_mean_m2=10.0, swerling=1),
        ),
        n_scans=80,
        tracker=dataclasses.replace(base.tracker, model_set_windows=()),
    )
