"""Shared fixtures: a tiny scenario builder and a seeded test rng."""

from __future__ import annotations

import numpy as np
import pytest

from uwb_env.config import (
    Box,
    ChirpWaveformConfig,
    ClutterConfig,
    ImpulseWaveformConfig,
    MotionSegmentConfig,
    ReceiverConfig,
    ScenarioConfig,
    SegmentedTrajectoryConfig,
    SensingConfig,
    TargetConfig,
    TransmitterConfig,
)


def tiny_config(
    *,
    n_scans: int = 50,
    swerling: int = 1,
    waveform: str = "chirp",
    power_dbm: float = 30.0,
    clutter_density: float = 0.0,
    target_xy: tuple[float, float] = (60.0, 40.0),
    speed: float = 1e-4,
    max_range_m: float = 500.0,
    blind_zone_excess_m: float = 0.0,
    pfa: float = 1e-3,
    walls: tuple = (),
    arrays: tuple = (None, None),
    measure_doa: bool = False,
) -> ScenarioConfig:
    """1 transmitter, 2 receivers, 1 (nearly static) target, 2 waveforms: the `tiny` scenario of STYLE.md B10."""
    if waveform == "chirp":
        waveforms = (
            ChirpWaveformConfig("short-up", 0.5e-6, 40e6, 4e9, "up", n_pulses=25, pri_s=0.01),
            ChirpWaveformConfig("long-down", 1.375e-6, 40e6, 4e9, "down", n_pulses=25, pri_s=0.01),
        )
    else:
        waveforms = (
            ImpulseWaveformConfig("ns1024", 4.3e9, 2.2e9, n_pulses=1024, prf_hz=10e6),
            ImpulseWaveformConfig("ns4096", 4.3e9, 2.2e9, n_pulses=4096, prf_hz=10e6),
        )
    traj = SegmentedTrajectoryConfig(target_xy, (speed, 0.0), (MotionSegmentConfig("cv", 1e6),))
    return ScenarioConfig(
        name="tiny",
        world=Box(-100.0, 200.0, -100.0, 200.0),
        surveillance_area=Box(0.0, 100.0, 0.0, 100.0),
        transmitters=(TransmitterConfig("tx", (0.0, 0.0), power_dbm=power_dbm),),
        receivers=(
            ReceiverConfig("rx1", (20.0, 0.0), array=arrays[0]),
            ReceiverConfig("rx2", (0.0, 20.0), array=arrays[1]),
        ),
        waveforms=waveforms,
        targets=(TargetConfig("t", traj, rcs_mean_m2=1.0, swerling=swerling),),
        n_scans=n_scans,
        walls=walls,
        sensing=SensingConfig(
            scan_period_s=0.1,
            false_alarm_probability=pfa,
            max_range_m=max_range_m,
            blind_zone_excess_m=blind_zone_excess_m,
            measure_doa=measure_doa,
            clutter=ClutterConfig(density_per_m2=clutter_density),
        ),
    )


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


@pytest.fixture(scope="module")
def local_ray(request):
    """One local 2-CPU Ray for a module's runs (the RLlib engine joins a Ray it finds and leaves it running).

    Kept running for the next module when a later test of the session uses it too (test_rllib.py, then
    test_rllib_batched.py: one start of ~4.5 s and one shutdown of ~1.5 s fewer), shut down after the last one.
    """
    import ray  # the optional extra: only the modules that use the fixture need it

    if not ray.is_initialized():
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, ignore_reinit_error=True)
    yield
    items = request.session.items
    mine = [i for i, item in enumerate(items) if getattr(item, "module", None) is request.module]
    last = max(mine, default=len(items))
    if not any("local_ray" in getattr(item, "fixturenames", ()) for item in items[last + 1 :]):
        ray.shutdown()
