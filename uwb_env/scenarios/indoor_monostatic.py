"""``indoor-monostatic``: seed 002 (network of 10 monostatic UWB sensor radars indoors, with walls), section V.

From the seed: 10 monostatic radars; random trajectories of 20 m at 1 m/s; PRF 5 MHz; transmitted PSD -42 dBm/MHz
over [3.1, 4.8] GHz (so Pt = -9.7 dBm, fc = 3.95 GHz, B = 1.7 GHz); N0 = -200 dBW/Hz (a 3.98 dB noise figure at 290 K);
path-loss exponent 2, kappa = 0, d0 = 1 m; Swerling III RCS of mean 1 m^2; energy-detector ToA with T_int = 4 ns,
T_a = 100 ns and N_pulse = 128 (32 and 512 compared); scan period 0.2 s; walls with obstruction loss and the
excess-delay bias of section II-D.

Our choices (the seed's Fig. 1 floor plan has no coordinates): a 20 m x 12 m floor with five rooms joined by 1 m
doors, concrete walls of 10 dB one-way loss and 1 ns excess delay (0.2 m at relative permittivity ~6), the ten
radar positions, a blind range d* = 0.5 m (blind zone excess 1 m), Pfa 1e-3, 0.01 false detections per m^2.
A new random walk is drawn from the truth stream every episode (the seed's five trajectories are five seeds).
"""

from __future__ import annotations

from uwb_env.config import (
    Box,
    ChannelConfig,
    ClutterConfig,
    EnergyDetectorToaConfig,
    ImpulseWaveformConfig,
    MaterialConfig,
    ReceiverConfig,
    RoomWalkTrajectoryConfig,
    ScenarioConfig,
    SensingConfig,
    TargetConfig,
    TransmitterConfig,
    WallConfig,
)
from uwb_env.scenarios import register
from uwb_env.scenarios.indoor_rsn import PERSON_TRACKER

CONCRETE = MaterialConfig("concrete", loss_db=10.0, excess_delay_s=1e-9)


def _wall_with_doors(
    a: tuple[float, float], b: tuple[float, float], doors: tuple[tuple[float, float], ...]
) -> tuple[WallConfig, ...]:
    """Split a horizontal or vertical wall a->b into segments, leaving gaps at the door intervals."""
    horizontal = a[1] == b[1]
    lo, hi = (a[0], b[0]) if horizontal else (a[1], b[1])
    cuts = [lo]
    for d0, d1 in sorted(doors):
        cuts += [d0, d1]
    cuts.append(hi)
    out = []
    for s, e in zip(cuts[::2], cuts[1::2], strict=True):
        if e > s:
            p, q = ((s, a[1]), (e, a[1])) if horizontal else ((a[0], s), (a[0], e))
            out.append(WallConfig(p, q, CONCRETE))
    return tuple(out)


def floor_plan() -> tuple[WallConfig, ...]:
    """Outer walls and interior walls with door gaps: rooms (0-7, 7-13, 13-20) x (0-6) and (0-10, 10-20) x (6-12)."""
    outer = (
        _wall_with_doors((0.0, 0.0), (20.0, 0.0), ())
        + _wall_with_doors((0.0, 12.0), (20.0, 12.0), ())
        + _wall_with_doors((0.0, 0.0), (0.0, 12.0), ())
        + _wall_with_doors((20.0, 0.0), (20.0, 12.0), ())
    )
    inner = (
        _wall_with_doors((0.0, 6.0), (20.0, 6.0), ((3.0, 4.0), (9.5, 10.5), (16.0, 17.0)))
        + _wall_with_doors((7.0, 0.0), (7.0, 6.0), ((2.5, 3.5),))
        + _wall_with_doors((13.0, 0.0), (13.0, 6.0), ((2.5, 3.5),))
        + _wall_with_doors((10.0, 6.0), (10.0, 12.0), ((8.5, 9.5),))
    )
    return outer + inner


RADARS = (
    (0.5, 0.5),
    (6.5, 5.5),
    (7.5, 0.5),
    (12.5, 5.5),
    (13.5, 0.5),
    (19.5, 5.5),
    (0.5, 11.5),
    (9.5, 6.5),
    (10.5, 11.5),
    (19.5, 6.5),
)


@register("indoor-monostatic")
def indoor_monostatic() -> ScenarioConfig:
    """Seed 002's ten monostatic radars on a walled floor, one person on a random 20 m walk."""
    ed = EnergyDetectorToaConfig(integration_time_s=4e-9, observation_window_s=100e-9)
    waveforms = tuple(
        ImpulseWaveformConfig(
            f"npulse{n}",
            center_freq_hz=3.95e9,
            bandwidth_hz=1.7e9,
            n_pulses=n,
            prf_hz=5e6,
            toa_error_model="energy_detector",
            energy_detector=ed,
        )
        for n in (128, 32, 512)
    )
    walk = RoomWalkTrajectoryConfig(start_region=Box(1.0, 19.0, 1.0, 11.0), length_m=20.0, speed_mps=1.0)
    return ScenarioConfig(
        name="indoor-monostatic",
        description="Seed 002: ten monostatic UWB radars on a walled floor, a person on a random 20 m walk.",
        seed_reference="002 (UWB monostatic sensor radar networks, passive navigation), section V",
        world=Box(-0.5, 20.5, -0.5, 12.5),
        surveillance_area=Box(0.0, 20.0, 0.0, 12.0),
        transmitters=tuple(TransmitterConfig(f"radar{i}", p, power_dbm=-9.7) for i, p in enumerate(RADARS)),
        receivers=tuple(ReceiverConfig(f"radar{i}", p, noise_figure_db=3.98) for i, p in enumerate(RADARS)),
        pairs=tuple((i, i) for i in range(len(RADARS))),
        waveforms=waveforms,
        targets=(TargetConfig("person", walk, rcs_mean_m2=1.0, swerling=3),),
        n_scans=100,
        walls=floor_plan(),
        channel=ChannelConfig(path_loss_exponent=2.0, frequency_exponent=0.0, reference_distance_m=1.0),
        tracker=PERSON_TRACKER,
        sensing=SensingConfig(
            scan_period_s=0.2,
            false_alarm_probability=1e-3,
            max_range_m=15.0,
            blind_zone_excess_m=1.0,
            clutter=ClutterConfig(density_per_m2=0.01, range_rate_max_mps=2.0),
        ),
    )
