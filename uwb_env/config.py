"""Typed, validated configuration for every knob of a scenario (the design's config stage).

Conventions:
    * Frozen ``slots`` dataclasses; tuples, never lists, so configs are hashable and immutable.
    * SI units, named in the field (``_m``, ``_s``, ``_hz``, ``_mps``); decibels only in ``_db`` / ``_dbm`` fields.
    * Validation in ``__post_init__``: a bad value raises ``ValueError`` naming the field, the value and what is
      allowed, at construction -- never mid-episode.
    * Coordinates are 2-D ``(x, y)`` in metres in one global Cartesian frame; angles in degrees at this boundary
      (``_deg``), radians inside the kernels.
    * Fields whose type is a union of configs (trajectories, waveforms) are tagged with ``kind`` in YAML.

``to_dict`` / ``from_dict`` / ``save_yaml`` / ``load_yaml`` round-trip any config exactly, and
``apply_overrides(cfg, {"sensing.false_alarm_probability": 1e-4, "receivers.0.noise_figure_db": 7.0})`` replaces
fields by dotted path (integers index tuples), re-validates, and raises ``KeyError`` on an unknown key with a
"did you mean" hint.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import numbers
import types
import typing
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar, Literal, Union, get_args, get_origin

import yaml

Vec2 = tuple[float, float]


# ----------------------------------------------------------------------------------------------- validation helpers
def _fail(owner: str, name: str, value: object, allowed: str) -> typing.NoReturn:
    raise ValueError(f"{owner}.{name} = {value!r}: must be {allowed}")


def _finite(owner: str, name: str, value: float) -> None:
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
        _fail(owner, name, value, "a finite number")


def _positive(owner: str, name: str, value: float) -> None:
    _finite(owner, name, value)
    if value <= 0:
        _fail(owner, name, value, "> 0")


def _non_negative(owner: str, name: str, value: float) -> None:
    _finite(owner, name, value)
    if value < 0:
        _fail(owner, name, value, ">= 0")


def _in_range(owner: str, name: str, value: float, lo: float, hi: float, *, closed: str = "[]") -> None:
    _finite(owner, name, value)
    ok_lo = value >= lo if closed[0] == "[" else value > lo
    ok_hi = value <= hi if closed[1] == "]" else value < hi
    if not (ok_lo and ok_hi):
        _fail(owner, name, value, f"in {closed[0]}{lo}, {hi}{closed[1]}")


def _vec2(owner: str, name: str, value: object) -> None:
    if (
        not isinstance(value, tuple)
        or len(value) != 2
        or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value)
    ):
        _fail(owner, name, value, "a tuple (x, y) of two finite numbers in metres")


def _choice(owner: str, name: str, value: object, allowed: tuple[object, ...]) -> None:
    # equal *and* of the same type: True is not 1, 1.0 is not 1, so a bool or a float never passes for an int
    if not any(type(value) is type(a) and value == a for a in allowed):
        hint = ""
        if isinstance(value, str):
            close = difflib.get_close_matches(value, [str(a) for a in allowed], n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
        _fail(owner, name, value, f"one of {allowed}{hint}")


def _int_at_least(owner: str, name: str, value: object, lo: int) -> None:
    if not isinstance(value, int) or isinstance(value, bool) or value < lo:
        _fail(owner, name, value, f"an integer >= {lo}")


def _name(owner: str, value: object) -> None:
    if not isinstance(value, str) or not value.strip():
        _fail(owner, "name", value, "a non-empty string")


def _bool(owner: str, name: str, value: object) -> None:
    if not isinstance(value, bool):
        _fail(owner, name, value, "True or False (a bool)")


def _str(owner: str, name: str, value: object) -> None:
    if not isinstance(value, str):
        _fail(owner, name, value, "a string")


def _instance(owner: str, name: str, value: object, cls: type | tuple[type, ...], allowed: str) -> None:
    if not isinstance(value, cls):
        _fail(owner, name, value, allowed)


def _tuple_of(owner: str, name: str, value: object, cls: type | tuple[type, ...], allowed: str) -> None:
    if not isinstance(value, tuple) or not all(isinstance(v, cls) for v in value):
        _fail(owner, name, value, f"a tuple of {allowed}")


# --------------------------------------------------------------------------------------------------------- geometry
@dataclass(frozen=True, slots=True)
class Box:
    """Axis-aligned rectangle [m]: the world, the surveillance area, a start region."""

    x_min_m: float
    x_max_m: float
    y_min_m: float
    y_max_m: float

    def __post_init__(self) -> None:
        for f in ("x_min_m", "x_max_m", "y_min_m", "y_max_m"):
            _finite("Box", f, getattr(self, f))
        if self.x_max_m <= self.x_min_m:
            _fail("Box", "x_max_m", self.x_max_m, f"> x_min_m = {self.x_min_m}")
        if self.y_max_m <= self.y_min_m:
            _fail("Box", "y_max_m", self.y_max_m, f"> y_min_m = {self.y_min_m}")

    @property
    def area_m2(self) -> float:
        """Area [m^2]."""
        return (self.x_max_m - self.x_min_m) * (self.y_max_m - self.y_min_m)

    def contains(self, point: Vec2) -> bool:
        """Whether a point lies inside or on the boundary."""
        return self.x_min_m <= point[0] <= self.x_max_m and self.y_min_m <= point[1] <= self.y_max_m

    def contains_box(self, other: Box) -> bool:
        """Whether ``other`` lies entirely inside this box."""
        return self.contains((other.x_min_m, other.y_min_m)) and self.contains((other.x_max_m, other.y_max_m))


# ------------------------------------------------------------------------------------------------------------ nodes
@dataclass(frozen=True, slots=True)
class UniformLinearArrayConfig:
    """A receiver's uniform linear array (seed 003 section 3.2: L_m elements spaced d_m).

    ``boresight_deg`` is the direction the broadside of the array faces, counter-clockwise from +x. Targets
    outside ``+-field_of_view_deg`` of boresight are not seen by the array receiver.
    """

    n_elements: int = 3
    spacing_m: float = 0.0375
    boresight_deg: float = 90.0
    field_of_view_deg: float = 60.0

    def __post_init__(self) -> None:
        _int_at_least("UniformLinearArrayConfig", "n_elements", self.n_elements, 2)
        _positive("UniformLinearArrayConfig", "spacing_m", self.spacing_m)
        _in_range("UniformLinearArrayConfig", "boresight_deg", self.boresight_deg, -360.0, 360.0)
        _in_range("UniformLinearArrayConfig", "field_of_view_deg", self.field_of_view_deg, 0.0, 89.0, closed="(]")


@dataclass(frozen=True, slots=True)
class TransmitterConfig:
    """A transmitter node.

    ``power_dbm`` is the average transmitted power for impulse waveforms (energy per pulse = P / PRF, seed 000
    section VI) and the peak envelope power for Gaussian chirps (energy per pulse = P kappa sqrt(pi), seed 003 eq. 1).
    """

    name: str
    position_m: Vec2
    power_dbm: float
    antenna_gain_db: float = 0.0

    def __post_init__(self) -> None:
        _name("TransmitterConfig", self.name)
        _vec2("TransmitterConfig", "position_m", self.position_m)
        _in_range("TransmitterConfig", "power_dbm", self.power_dbm, -100.0, 100.0)
        _in_range("TransmitterConfig", "antenna_gain_db", self.antenna_gain_db, -30.0, 60.0)


@dataclass(frozen=True, slots=True)
class ReceiverConfig:
    """A receiver node, optionally a uniform linear array (its coherent gain multiplies the SNR by L)."""

    name: str
    position_m: Vec2
    noise_figure_db: float = 4.8
    antenna_gain_db: float = 0.0
    array: UniformLinearArrayConfig | None = None

    def __post_init__(self) -> None:
        _name("ReceiverConfig", self.name)
        _vec2("ReceiverConfig", "position_m", self.position_m)
        _in_range("ReceiverConfig", "noise_figure_db", self.noise_figure_db, 0.0, 40.0)
        _in_range("ReceiverConfig", "antenna_gain_db", self.antenna_gain_db, -30.0, 60.0)
        if self.array is not None:
            _instance(
                "ReceiverConfig", "array", self.array, UniformLinearArrayConfig, "None or a UniformLinearArrayConfig"
            )


# ------------------------------------------------------------------------------------------------- walls, clutter
@dataclass(frozen=True, slots=True)
class MaterialConfig:
    """Wall material: one-way loss per crossing and the excess delay it adds (seed 002 section II-D).

    ``loss_db = inf`` is an opaque obstacle (a building): nothing is seen through it.
    """

    name: str
    loss_db: float
    excess_delay_s: float = 0.0

    def __post_init__(self) -> None:
        _name("MaterialConfig", self.name)
        if (
            not isinstance(self.loss_db, (int, float))
            or isinstance(self.loss_db, bool)
            or math.isnan(self.loss_db)
            or self.loss_db < 0
        ):
            _fail("MaterialConfig", "loss_db", self.loss_db, ">= 0 (inf for an opaque obstacle)")
        _in_range("MaterialConfig", "excess_delay_s", self.excess_delay_s, 0.0, 1e-6)


@dataclass(frozen=True, slots=True)
class WallConfig:
    """A wall or obstacle face: the segment from ``start_m`` to ``end_m``."""

    start_m: Vec2
    end_m: Vec2
    material: MaterialConfig

    def __post_init__(self) -> None:
        _vec2("WallConfig", "start_m", self.start_m)
        _vec2("WallConfig", "end_m", self.end_m)
        _instance("WallConfig", "material", self.material, MaterialConfig, "a MaterialConfig")
        if math.dist(self.start_m, self.end_m) <= 0:
            _fail("WallConfig", "end_m", self.end_m, "different from start_m (a wall has non-zero length)")


@dataclass(frozen=True, slots=True)
class LineScattererConfig:
    """A smooth reflecting line (seed 003 section 3.1: y = m x + c, restricted to a segment)."""

    start_m: Vec2
    end_m: Vec2
    reflectivity: float = 0.5

    def __post_init__(self) -> None:
        _vec2("LineScattererConfig", "start_m", self.start_m)
        _vec2("LineScattererConfig", "end_m", self.end_m)
        if math.dist(self.start_m, self.end_m) <= 0:
            _fail("LineScattererConfig", "end_m", self.end_m, "different from start_m")
        _in_range("LineScattererConfig", "reflectivity", self.reflectivity, 0.0, 1.0)


@dataclass(frozen=True, slots=True)
class ClutterConfig:
    """False-alarm (clutter) model of the parametric path.

    False detections are a spatial Poisson process of ``density_per_m2`` over the surveillance area; a fraction
    ``discrete_fraction`` of them is concentrated around the scene's clutter points (vegetation, seed 003 Fig. 3)
    with Gaussian spread ``discrete_spread_m``, the rest is uniform. Each pair sees an independent realisation,
    thinned to its coverage gate. Range-rates of false detections are uniform in +-``range_rate_max_mps``.

    Per waveform (``reference_bandwidth_hz``): a detector at a fixed per-cell Pfa makes false detections in
    proportion to its resolution cells, i.e. to the bandwidth (c / B per range cell; the trains' Doppler cells per
    period are their pulse count, the same for every train of the scenarios). ``density_per_m2`` is then the density
    of a waveform of bandwidth ``reference_bandwidth_hz`` (seed 003's 2.5e-4 per m^2: its 40 MHz chirps), and a
    waveform of bandwidth B_w has ``density_per_m2`` x B_w / ``reference_bandwidth_hz``, in its draws and in the
    clutter map (the detections' ``clutter_intensity`` and ``expected_false_alarms``,
    ``ParametricSensor.clutter_intensity_at``). The draws keep common random numbers across plans: false alarms are
    drawn at the library's largest rate and each waveform keeps one with probability rate_w / rate_max (one spare
    uniform per false alarm), so a narrower waveform's false alarms are a subset of a wider one's. 0 (default): the
    same density for every waveform and no thinning (the draws as before the field existed).

    Chirp trains only: the clutter points also echo as static scatterers of RCS ``scatterer_rcs_m2`` (0: none), whose
    background-subtraction residue (``residue_fraction`` of their power, Doppler spread ``doppler_spread_hz``)
    masks targets at blind speeds (``uwb_env.channel.doppler_notch``).
    """

    density_per_m2: float = 0.0
    discrete_fraction: float = 0.0
    discrete_spread_m: float = 3.0
    range_rate_max_mps: float = 30.0
    scatterer_rcs_m2: float = 0.0
    residue_fraction: float = 1.0
    doppler_spread_hz: float = 0.0
    reference_bandwidth_hz: float = 0.0

    def __post_init__(self) -> None:
        _in_range("ClutterConfig", "density_per_m2", self.density_per_m2, 0.0, 1.0)
        _non_negative("ClutterConfig", "reference_bandwidth_hz", self.reference_bandwidth_hz)
        _in_range("ClutterConfig", "discrete_fraction", self.discrete_fraction, 0.0, 1.0)
        _positive("ClutterConfig", "discrete_spread_m", self.discrete_spread_m)
        _positive("ClutterConfig", "range_rate_max_mps", self.range_rate_max_mps)
        _in_range("ClutterConfig", "scatterer_rcs_m2", self.scatterer_rcs_m2, 0.0, 1e6)
        _in_range("ClutterConfig", "residue_fraction", self.residue_fraction, 0.0, 1.0)
        _in_range("ClutterConfig", "doppler_spread_hz", self.doppler_spread_hz, 0.0, 1e6)


@dataclass(frozen=True, slots=True)
class ChannelConfig:
    """Propagation: IEEE 802.15.4a path-loss form PL(f, d) = PL0 (f/fc)^(2(kappa+1)) (d/d0)^rho per leg.

    Seed 000 eq. 9 / seed 002 eq. 4. PL0 is free-space at d0 plus ``excess_loss_db``; rho = 2, kappa = 0 and no
    excess is free space, where the SNR reduces to seed 000 eqs. 1-3.
    """

    path_loss_exponent: float = 2.0
    frequency_exponent: float = 0.0
    reference_distance_m: float = 1.0
    excess_loss_db: float = 0.0

    def __post_init__(self) -> None:
        _in_range("ChannelConfig", "path_loss_exponent", self.path_loss_exponent, 1.0, 6.0)
        _in_range("ChannelConfig", "frequency_exponent", self.frequency_exponent, -3.0, 3.0)
        _positive("ChannelConfig", "reference_distance_m", self.reference_distance_m)
        _in_range("ChannelConfig", "excess_loss_db", self.excess_loss_db, 0.0, 200.0)


# ------------------------------------------------------------------------------------------------- targets, motion
@dataclass(frozen=True, slots=True)
class MotionSegmentConfig:
    """One piece of a deterministic trajectory.

    ``cv``: constant velocity. ``ca``: constant tangential acceleration ``acceleration_mps2`` along the heading
    (negative decelerates; the speed must stay positive). ``ct``: coordinated turn at ``turn_rate_rps`` (positive
    = left / counter-clockwise) at constant speed.
    """

    kind: Literal["cv", "ca", "ct"]
    duration_s: float
    acceleration_mps2: float = 0.0
    turn_rate_rps: float = 0.0

    def __post_init__(self) -> None:
        _choice("MotionSegmentConfig", "kind", self.kind, ("cv", "ca", "ct"))
        _positive("MotionSegmentConfig", "duration_s", self.duration_s)
        _finite("MotionSegmentConfig", "acceleration_mps2", self.acceleration_mps2)
        _finite("MotionSegmentConfig", "turn_rate_rps", self.turn_rate_rps)
        if self.kind != "ca" and self.acceleration_mps2 != 0:
            _fail("MotionSegmentConfig", "acceleration_mps2", self.acceleration_mps2, f"0 for kind {self.kind!r}")
        if self.kind != "ct" and self.turn_rate_rps != 0:
            _fail("MotionSegmentConfig", "turn_rate_rps", self.turn_rate_rps, f"0 for kind {self.kind!r}")
        if self.kind == "ct" and self.turn_rate_rps == 0:
            _fail("MotionSegmentConfig", "turn_rate_rps", self.turn_rate_rps, "non-zero for a coordinated turn")


@dataclass(frozen=True, slots=True)
class SegmentedTrajectoryConfig:
    """A deterministic trajectory: start state then segments in order (seed 003 section V)."""

    kind: ClassVar[str] = "segments"
    start_position_m: Vec2
    start_velocity_mps: Vec2
    segments: tuple[MotionSegmentConfig, ...]

    def __post_init__(self) -> None:
        _vec2("SegmentedTrajectoryConfig", "start_position_m", self.start_position_m)
        _vec2("SegmentedTrajectoryConfig", "start_velocity_mps", self.start_velocity_mps)
        if math.hypot(*self.start_velocity_mps) <= 0:
            _fail("SegmentedTrajectoryConfig", "start_velocity_mps", self.start_velocity_mps, "non-zero")
        if (
            not isinstance(self.segments, tuple)
            or not self.segments
            or not all(isinstance(g, MotionSegmentConfig) for g in self.segments)
        ):
            _fail("SegmentedTrajectoryConfig", "segments", self.segments, "a non-empty tuple of MotionSegmentConfig")

    @property
    def duration_s(self) -> float:
        """Total duration [s]."""
        return float(sum(s.duration_s for s in self.segments))


@dataclass(frozen=True, slots=True)
class MotionModelTrajectoryConfig:
    """A random trajectory driven by a motion model (seed 003 section 3.3) on the truth stream.

    ``model``: ``ncv`` (white-noise acceleration), ``ct`` (coordinated turn at ``turn_rate_rps`` with the same
    noise), ``nca`` (Wiener-sequence acceleration). ``accel_noise_std_mps2`` is sigma_w of seed 003's Q = sigma_w^2 G
    G^T (for ``nca`` it drives the acceleration increments, in m/s^2 per step).
    """

    kind: ClassVar[str] = "motion_model"
    start_position_m: Vec2
    start_velocity_mps: Vec2
    model: Literal["ncv", "ct", "nca"]
    duration_s: float
    accel_noise_std_mps2: float = 0.1
    turn_rate_rps: float = 0.0

    def __post_init__(self) -> None:
        _vec2("MotionModelTrajectoryConfig", "start_position_m", self.start_position_m)
        _vec2("MotionModelTrajectoryConfig", "start_velocity_mps", self.start_velocity_mps)
        _choice("MotionModelTrajectoryConfig", "model", self.model, ("ncv", "ct", "nca"))
        _positive("MotionModelTrajectoryConfig", "duration_s", self.duration_s)
        _non_negative("MotionModelTrajectoryConfig", "accel_noise_std_mps2", self.accel_noise_std_mps2)
        _finite("MotionModelTrajectoryConfig", "turn_rate_rps", self.turn_rate_rps)
        if self.model == "ct" and self.turn_rate_rps == 0:
            _fail("MotionModelTrajectoryConfig", "turn_rate_rps", self.turn_rate_rps, "non-zero for model 'ct'")


@dataclass(frozen=True, slots=True)
class RoomWalkTrajectoryConfig:
    """A random indoor walk (seed 002 section V): ``length_m`` at ``speed_mps`` that never crosses a wall.

    The start is uniform in ``start_region`` (at least ``wall_clearance_m`` from any wall). Each step of
    ``step_m`` turns the heading by N(0, ``heading_change_std_rad``^2); a step that would cross a wall or come
    closer than the clearance is redrawn, so the walk stays inside rooms and moves between rooms only through
    door gaps.
    """

    kind: ClassVar[str] = "room_walk"
    start_region: Box
    length_m: float = 20.0
    speed_mps: float = 1.0
    heading_change_std_rad: float = 0.35
    step_m: float = 0.25
    wall_clearance_m: float = 0.3

    def __post_init__(self) -> None:
        _instance("RoomWalkTrajectoryConfig", "start_region", self.start_region, Box, "a Box")
        _positive("RoomWalkTrajectoryConfig", "length_m", self.length_m)
        _positive("RoomWalkTrajectoryConfig", "speed_mps", self.speed_mps)
        _non_negative("RoomWalkTrajectoryConfig", "heading_change_std_rad", self.heading_change_std_rad)
        _positive("RoomWalkTrajectoryConfig", "step_m", self.step_m)
        _non_negative("RoomWalkTrajectoryConfig", "wall_clearance_m", self.wall_clearance_m)
        if self.step_m > self.length_m:
            _fail("RoomWalkTrajectoryConfig", "step_m", self.step_m, f"<= length_m = {self.length_m}")

    @property
    def duration_s(self) -> float:
        """Walk duration [s]."""
        return self.length_m / self.speed_mps


TrajectoryConfig = Union[SegmentedTrajectoryConfig, MotionModelTrajectoryConfig, RoomWalkTrajectoryConfig]


@dataclass(frozen=True, slots=True)
class TargetConfig:
    """A target: its trajectory, birth time and radar cross-section model.

    ``swerling``: 0 (non-fluctuating), 1 (exponential RCS, scan-to-scan) or 3 (chi-square with 4 degrees of
    freedom, scan-to-scan; seed 002's model of a person).
    """

    name: str
    trajectory: TrajectoryConfig
    birth_time_s: float = 0.0
    rcs_mean_m2: float = 1.0
    swerling: int = 1

    def __post_init__(self) -> None:
        _name("TargetConfig", self.name)
        if not isinstance(self.trajectory, _TRAJECTORY_TYPES):
            _fail("TargetConfig", "trajectory", self.trajectory, f"one of {[t.__name__ for t in _TRAJECTORY_TYPES]}")
        _non_negative("TargetConfig", "birth_time_s", self.birth_time_s)
        _positive("TargetConfig", "rcs_mean_m2", self.rcs_mean_m2)
        _choice("TargetConfig", "swerling", self.swerling, (0, 1, 3))


_TRAJECTORY_TYPES = (SegmentedTrajectoryConfig, MotionModelTrajectoryConfig, RoomWalkTrajectoryConfig)


# ------------------------------------------------------------------------------------------------------- waveforms
@dataclass(frozen=True, slots=True)
class ChirpWaveformConfig:
    """Gaussian-windowed linear chirp, seed 003 eq. 1.

    s(t) = (pi kappa^2)^(-1/4) exp((+-j gamma - 1/(2 kappa^2)) t^2), repeated ``n_pulses`` times every ``pri_s``.
    ``bandwidth_hz`` is the frequency swept over t in [-kappa, kappa], so gamma = pi B / (2 kappa) [rad/s^2]
    (our reading of the seed's "40 MHz of bandwidth"). ``sweep`` "up" is +gamma, "down" is -gamma.
    """

    kind: ClassVar[str] = "chirp"
    name: str
    pulse_duration_s: float
    bandwidth_hz: float
    carrier_hz: float
    sweep: Literal["up", "down"] = "up"
    n_pulses: int = 25
    pri_s: float = 0.01

    def __post_init__(self) -> None:
        _name("ChirpWaveformConfig", self.name)
        _in_range("ChirpWaveformConfig", "pulse_duration_s", self.pulse_duration_s, 1e-10, 1e-2, closed="[]")
        _positive("ChirpWaveformConfig", "carrier_hz", self.carrier_hz)
        _positive("ChirpWaveformConfig", "bandwidth_hz", self.bandwidth_hz)
        if self.bandwidth_hz >= self.carrier_hz:
            _fail("ChirpWaveformConfig", "bandwidth_hz", self.bandwidth_hz, f"< carrier_hz = {self.carrier_hz}")
        tb = self.bandwidth_hz * self.pulse_duration_s
        if tb > 1e5:
            _fail(
                "ChirpWaveformConfig",
                "bandwidth_hz",
                self.bandwidth_hz,
                f"such that bandwidth x pulse_duration <= 1e5 (got {tb:.3g})",
            )
        _choice("ChirpWaveformConfig", "sweep", self.sweep, ("up", "down"))
        _int_at_least("ChirpWaveformConfig", "n_pulses", self.n_pulses, 1)
        _positive("ChirpWaveformConfig", "pri_s", self.pri_s)
        if self.pri_s <= 4 * self.pulse_duration_s:
            _fail("ChirpWaveformConfig", "pri_s", self.pri_s, f"> 4 x pulse_duration_s = {4 * self.pulse_duration_s}")


@dataclass(frozen=True, slots=True)
class EnergyDetectorToaConfig:
    """Seed 002 section III: energy-detector threshold ToA estimator (integration time, observation window)."""

    integration_time_s: float = 4e-9
    observation_window_s: float = 100e-9

    def __post_init__(self) -> None:
        _in_range("EnergyDetectorToaConfig", "integration_time_s", self.integration_time_s, 1e-11, 1e-6)
        if not self.observation_window_s > self.integration_time_s:
            _fail(
                "EnergyDetectorToaConfig",
                "observation_window_s",
                self.observation_window_s,
                f"> integration_time_s = {self.integration_time_s}",
            )
        _in_range("EnergyDetectorToaConfig", "observation_window_s", self.observation_window_s, 1e-10, 1e-4)


@dataclass(frozen=True, slots=True)
class ImpulseWaveformConfig:
    """UWB impulse-radio waveform (seeds 000, 002): a Gaussian-shaped band-pass pulse train.

    The pulse spectrum is Gaussian around ``center_freq_hz`` with -10 dB width ``bandwidth_hz`` (the
    high-order limit of a Gaussian-derivative pulse); ``n_pulses`` (Ns) pulses at ``prf_hz`` are integrated per
    scan. ``toa_error_model``: ``crlb`` (ToA variance 1 / (8 pi^2 beta^2 SNR)) or ``energy_detector`` (seed 002's
    three-region sigma(SNR), eq. 9 and its Table). ``detection_gain_db``: this waveform's part of the parametric
    detector's SNR gain (Pd only), added to ``SensingConfig.detection_gain_db``: an energy detector accumulates its
    ``n_pulses`` pulses non-coherently, a loss against the coherent square-law test that depends on the pulses
    (calibrated by ``scripts/calibrate_parametric.py --gain-per-waveform``); in [-30, 10] dB, 0 by default.
    ``false_alarm_factor``: this waveform's parametric false-alarm density over ``ClutterConfig.density_per_m2``
    (times the bandwidth rule's, ``uwb_env.sensing.parametric.false_alarm_scale``): where a chain's false detections
    are the static background's residues, whose power is the waveform's energy, they grow with the pulses integrated
    (through-wall: fitted on seed 001's chain by ``scripts/calibrate_through_wall.py``); in (0, 100], 1 by default.
    """

    kind: ClassVar[str] = "impulse"
    name: str
    center_freq_hz: float
    bandwidth_hz: float
    n_pulses: int = 128
    prf_hz: float = 5e6
    toa_error_model: Literal["crlb", "energy_detector"] = "crlb"
    energy_detector: EnergyDetectorToaConfig = field(default_factory=EnergyDetectorToaConfig)
    detection_gain_db: float = 0.0
    false_alarm_factor: float = 1.0

    def __post_init__(self) -> None:
        _name("ImpulseWaveformConfig", self.name)
        _in_range("ImpulseWaveformConfig", "detection_gain_db", self.detection_gain_db, -30.0, 10.0)
        _in_range("ImpulseWaveformConfig", "false_alarm_factor", self.false_alarm_factor, 0.0, 100.0, closed="(]")
        _positive("ImpulseWaveformConfig", "center_freq_hz", self.center_freq_hz)
        _positive("ImpulseWaveformConfig", "bandwidth_hz", self.bandwidth_hz)
        if self.bandwidth_hz >= 2 * self.center_freq_hz:
            _fail(
                "ImpulseWaveformConfig",
                "bandwidth_hz",
                self.bandwidth_hz,
                f"< 2 x center_freq_hz = {2 * self.center_freq_hz}",
            )
        _int_at_least("ImpulseWaveformConfig", "n_pulses", self.n_pulses, 1)
        _in_range("ImpulseWaveformConfig", "prf_hz", self.prf_hz, 1.0, 1e9, closed="[]")
        _choice("ImpulseWaveformConfig", "toa_error_model", self.toa_error_model, ("crlb", "energy_detector"))
        _instance(
            "ImpulseWaveformConfig",
            "energy_detector",
            self.energy_detector,
            EnergyDetectorToaConfig,
            "an EnergyDetectorToaConfig",
        )


WaveformConfig = Union[ChirpWaveformConfig, ImpulseWaveformConfig]
_WAVEFORM_TYPES = (ChirpWaveformConfig, ImpulseWaveformConfig)


# ---------------------------------------------------------------------------------------------- sensing, tracker
@dataclass(frozen=True, slots=True)
class ChirpSignalConfig:
    """Signal-level fidelity of chirp pulse trains (seed 003 sections 3.2, 4.1; ``sensing.signal.chirp_sensor``).

    Images: the receiver samples at ``sample_rate_factor`` x B_w, interpolates the delay axis ``delay_oversample``
    and the Doppler axis ``doppler_oversample`` times (``sensing.signal.chirp_chain``), over bistatic ranges from the
    baseline to 2 ``SensingConfig.max_range_m``. Paths: static (target-free) paths whose integrated SNR at one
    element of the weakest waveform is below ``static_snr_floor`` are dropped, target paths below
    ``target_snr_floor``; at most ``max_bounces`` reflections (seed 003: 3). Background: the mean magnitude of
    ``background_scans`` (J) clutter-only images per pair, beam and waveform, taken at the start of the episode.
    Clutter motion: every static scatterer path has a random phase per scan (seed 003 eq. 2) and a diffuse part of
    ``clutter_diffuse_fraction`` of its power (wind in the foliage) with a Gaussian Doppler spectrum of standard
    deviation ``clutter_doppler_spread_hz`` within the dwell. Detection: per-cell threshold for
    ``SensingConfig.false_alarm_probability``, at most ``max_peaks`` peaks per beam image of the library's narrowest
    bandwidth; ``threshold`` ``rice`` models every cell as a static return plus noise, ``clutter_map`` also adapts to
    the fluctuation measured over the J background images (``sensing.signal.chirp_sensor.clutter_map_threshold``).

    The peak cap per image cell (``scale_max_peaks``, default True): at a fixed per-cell Pfa a beam image holds noise
    peaks in proportion to its cells, and a waveform of k times the bandwidth has k times the delay rows (the same
    Doppler columns for the same pulse count). With one cap for every image, a 160 MHz image (~28 noise peaks above
    the threshold at Pfa 7e-4) would keep only its ``max_peaks`` strongest ones and drop a weak echo ranked below
    them: the cap, not the threshold, would decide detection. So ``max_peaks`` is the cap of the smallest image of
    the library's narrowest bandwidth (the reference) and every other waveform's image gets
    max(``max_peaks``, round(``max_peaks`` x its cells / the reference's cells)) (``chirp_sensor.peak_caps``; 38 for
    the 160 MHz chirps of urban-intersection-wideband next to 10 for its 40 MHz ones): the same cap per image cell,
    so the noise peaks per cell and unit Pfa (the noise window of the parametric Pd) and the false peaks per cell
    are the same for every bandwidth, and a library of one bandwidth keeps ``max_peaks`` everywhere. False: one cap
    ``max_peaks`` for every image (the chain before this choice).
    """

    background_scans: int = 10
    sample_rate_factor: float = 2.0
    delay_oversample: int = 2
    doppler_oversample: int = 4
    static_snr_floor: float = 1e-3
    target_snr_floor: float = 0.1
    max_bounces: int = 3
    clutter_diffuse_fraction: float = 0.12
    clutter_doppler_spread_hz: float = 4.0
    max_peaks: int = 10
    scale_max_peaks: bool = True
    threshold: Literal["clutter_map", "rice"] = "clutter_map"

    def __post_init__(self) -> None:
        _int_at_least("ChirpSignalConfig", "background_scans", self.background_scans, 2)
        _choice("ChirpSignalConfig", "threshold", self.threshold, ("clutter_map", "rice"))
        _in_range("ChirpSignalConfig", "sample_rate_factor", self.sample_rate_factor, 1.0, 8.0)
        _int_at_least("ChirpSignalConfig", "delay_oversample", self.delay_oversample, 1)
        _int_at_least("ChirpSignalConfig", "doppler_oversample", self.doppler_oversample, 1)
        _non_negative("ChirpSignalConfig", "static_snr_floor", self.static_snr_floor)
        _non_negative("ChirpSignalConfig", "target_snr_floor", self.target_snr_floor)
        if (
            not isinstance(self.max_bounces, int)
            or isinstance(self.max_bounces, bool)
            or not 0 <= self.max_bounces <= 3
        ):
            _fail("ChirpSignalConfig", "max_bounces", self.max_bounces, "an integer in [0, 3]")
        _in_range("ChirpSignalConfig", "clutter_diffuse_fraction", self.clutter_diffuse_fraction, 0.0, 1.0)
        _non_negative("ChirpSignalConfig", "clutter_doppler_spread_hz", self.clutter_doppler_spread_hz)
        _int_at_least("ChirpSignalConfig", "max_peaks", self.max_peaks, 1)
        if not isinstance(self.scale_max_peaks, bool):
            _fail("ChirpSignalConfig", "scale_max_peaks", self.scale_max_peaks, "a bool")


@dataclass(frozen=True, slots=True)
class BodyModelConfig:
    """The extended person of the impulse signal path (``SignalConfig.target_model = "extended"``; ``scene.extended``).

    A walking person as six scattering centres seen from above (the simulation is 2-D): torso, head, two arms, two
    legs, each a vertical body segment whose horizontal cross-section is an ellipse; a centre's echo comes from the
    point of that ellipse whose normal bisects the directions to the pair's transmitter and receiver (geometric
    optics), at its own bistatic delay, with its own path loss, carrier phase and per-scan Swerling factor.

    Geometry (body frame: x along the heading = the velocity's direction, y to the left): the torso an ellipse
    ``torso_depth_m`` x ``torso_width_m`` (0.25 m x 0.40 m, an adult's chest), the head a circle of
    ``head_radius_m`` above its centre; the arms circles of ``arm_radius_m`` beside the torso (y = +-(width / 2 +
    radius)), the legs circles of ``leg_radius_m`` at the hip joints (y = +-``hip_half_width_m``). Gait (Boulic,
    Magnenat-Thalmann & Thalmann 1990, as used by V. C. Chen, *The Micro-Doppler Effect in Radar*, 2011, ch. 5): the
    relative velocity RV = v / H_t (H_t = ``hip_height_m``, the thigh height; RV clipped to Boulic's 0-2.3), a cycle
    (two steps) of D_c = 1.346 / sqrt(RV) s and stride v D_c = 1.346 sqrt(v H_t); the legs swing through the angle
    theta with sin theta = stride / (4 H_t) (feet a step, half a stride, apart at double support), each leg's
    scattering centre (its centroid, half-way down) moving +-(H_t / 2) sin theta along the heading; the arms swing
    through the same angle about the shoulder, their centroids +-(``arm_length_m`` / 2) sin theta, each arm in
    anti-phase with its leg. A standing person (RV = 0) does not swing.

    RCS shares (relative, normalised to sum 1 over the six centres; times the target's mean RCS): ``torso_share``,
    ``head_share``, and per limb ``arm_share``, ``leg_share``. Their defaults are the high-frequency RCS of Chen's
    ellipsoid body segments (sigma = pi a^2 b^2 c^2 / (a^2 cos^2 phi + b^2 sin^2 phi)^2 at horizontal incidence;
    segment lengths of a 1.8 m adult): torso seen from the front 0.55 m^2, a leg (thigh and shank) 0.30 m^2, an arm
    (upper arm and forearm) 0.14 m^2, the head 0.03 m^2 -> 0.38 / 0.20 / 0.10 / 0.02. An arm whose line of sight to
    the transmitter or the receiver crosses the torso is attenuated by ``occlusion_loss_db`` per blocked leg (legs and
    head, below and above the torso, are never hidden by it).

    ``range_std_m``: the spread of a detection's bistatic range about the body centre's (its centres' extent, the
    front surface's bias included: an RMS) that the trackers' measurement model adds in quadrature to
    ``SignalConfig.range_std_floor_m``; it depends on the signal chain, so each scenario sets the value measured on
    its own (``scripts/body_spread.py``); 0 by default.
    """

    torso_depth_m: float = 0.25
    torso_width_m: float = 0.40
    head_radius_m: float = 0.09
    arm_radius_m: float = 0.045
    leg_radius_m: float = 0.06
    hip_half_width_m: float = 0.10
    hip_height_m: float = 0.95
    arm_length_m: float = 0.60
    torso_share: float = 0.38
    head_share: float = 0.02
    arm_share: float = 0.10
    leg_share: float = 0.20
    occlusion_loss_db: float = 20.0
    range_std_m: float = 0.0

    def __post_init__(self) -> None:
        for name in ("torso_depth_m", "torso_width_m", "hip_height_m"):
            _positive("BodyModelConfig", name, getattr(self, name))
        for name in (
            "head_radius_m",
            "arm_radius_m",
            "leg_radius_m",
            "hip_half_width_m",
            "arm_length_m",
            "torso_share",
            "head_share",
            "arm_share",
            "leg_share",
            "occlusion_loss_db",
            "range_std_m",
        ):
            _non_negative("BodyModelConfig", name, getattr(self, name))
        total = self.torso_share + self.head_share + 2.0 * (self.arm_share + self.leg_share)
        if not total > 0.0:
            _fail("BodyModelConfig", "torso_share", self.torso_share, "shares with a positive sum")


@dataclass(frozen=True, slots=True)
class SignalConfig:
    """Signal-level fidelity (seed 000 sections IV-V; ``uwb_env.sensing.signal``, ``detection``, ``localization``).

    Synthesis: scans of ``n_samples`` at ``sample_rate_hz`` (seed 000: 16.4 GHz, 1920 samples) with the direct path
    ``direct_path_offset_s`` into the window plus a per-scan timing jitter of std ``scan_jitter_s``; a static
    background of ``n_multipath`` paths ``multipath_spacing_s`` apart with an exponential power-delay profile of
    constant ``multipath_decay_s`` and total power ``multipath_power_ratio_db`` relative to the direct path (seed 002),
    drawn once from ``background_seed`` (the room); background amplitudes fluctuate by an AR(1) process of relative std
    ``clutter_fluctuation`` and scan-to-scan correlation ``clutter_correlation`` (slowly moving clutter); a target
    within ``shadow_radius_m`` of a path's legs attenuates that path by ``shadow_loss_db`` (the source of ghosts). The
    empty-room reference averages ``empty_room_scans`` noisy scans.

    In-sensor chain: square-law envelope with a Gaussian low-pass of std ``envelope_lpf_s``; direct-path ToA by jump
    back ``dp_jump_back_s`` from the strongest sample and search forward for ``dp_threshold_ratio`` of it;
    ``background`` ``empty_room`` (seed 000 eq. 13, on envelopes), ``exponential`` (seed 001, factor
    ``background_alpha``) or ``coherent`` (the empty-room raw scan subtracted before the envelope: seed 002's static
    clutter removal, for radars whose transmitter and receiver share a clock); ``align_scans``: re-time each scan
    onto the reference by its direct path (seed 000; off for a common clock, where a timing estimate would only add
    error to a coherent subtraction);
    CFAR ``cfar`` in {dtb, ca, g, os}: DTB with ``dtb_alpha_local``, ``dtb_alpha_global``, ``dtb_buffer``,
    ``dtb_qmax`` and increment ``dtb_delta`` (in units of the global power), CA/G/OS designed for ``cfar_pfa`` with
    ``cfar_reference`` / ``cfar_guard`` samples and OS rank ``os_rank``; 1-D clustering with distance
    ``cluster_distance_s`` and weight threshold ``cluster_min_weight`` (seed 000: 65 Ts, 4); ``toa_estimator``
    ``median`` (seed 000) or ``peak`` (quadratic fit on the cluster's peak, seed 003's peak refinement), or
    ``energy-detector``: seed 002's energy-detector ToA in place of CFAR and clustering (``uwb_env.detection.
    energy_detector``; ``background = "coherent"`` only): the raw difference through a band-pass zonal filter over
    the pulse's -10 dB band, squared and integrated in bins of the waveform's ``energy_detector.integration_time_s``
    over its ``observation_window_s`` from the end of the blind zone; the ToA is the centre of the first bin above
    xi = max(z_min + ``ed_threshold_ratio`` (z_max - z_min), xi_0), xi_0 the noise bin energy that noise alone
    exceeds somewhere in the window with probability ``ed_false_alarm_probability`` (1: never a missed window);
    at most one ToA per pair and scan, its range variance seed 002's three-region sigma(SNR) at the SNR estimated
    from the largest bin, plus ``range_std_floor_m``^2. The default ratio 0.95 is what seed 002's a-posteriori
    search (``energy_detector.search_threshold_ratio``: least ToA RMSE over alpha in 0.2-0.99 on synthetic scans of
    one pulse, 0-40 dB, 128 pulses) picks at every SNR (0.8-0.99, the RMSE flat within sampling error over
    0.9-0.99); lower ratios pull low-SNR ToAs to the window's first bins. ``ed_pulse_integration``:
    ``noncoherent`` (seed 002 eq. 1: the energies of the N_pulse pulses are summed, so the noise energy has N_pulse
    times the degrees of freedom of the coherently integrated scan) or ``coherent`` (the ED on the synthesised
    scan, the pulses averaged first).

    Network chain: ``nu``-tuples of receivers, measurement weight threshold ``min_tuple_weight`` and residual
    threshold ``max_residual_m`` (the LS residual of seed 000 eq. 25, normalised to metres: see
    ``uwb_env.localization.ellipse``), 2-D clustering with ``linkage`` and ``cluster_2d_distance_m``; the position
    covariance is the geometry's (J^T J)^-1 sigma_r^2 with sigma_r = ``range_std_floor_m``; the tracker's clutter
    density of fused positions is ``false_position_density_per_m2``. ``output = "ranges"`` skips the network chain
    and hands the tracker each pair's bistatic ranges (variance sigma_r^2, ``false_ranges_per_scan`` false ones per
    scan and pair, spread over the range window): for sparse networks where few receivers see a target at once. The
    defaults are measured on indoor-rsn (``scripts/calibrate_parametric.py``). ``chirp`` holds the knobs of the
    chirp pulse-train signal path (:class:`ChirpSignalConfig`). ``target_model``: ``point`` synthesises each target as
    one echo at its bistatic delay (the default), ``extended`` as the scattering centres of a walking person
    (:class:`BodyModelConfig` ``body``; impulse signal path only).

    Seed 001's chain (through-wall, one transmitter between two receivers on a line; ``uwb_env.detection.
    toa_association``, ``uwb_env.localization.couples``): ``background = "exponential-coherent"`` is the seed's
    exponential averaging on the raw scans (b <- alpha b + (1 - alpha) x, the envelope of x - b detected; a common
    clock: no alignment); ``normalization = "advance"`` the advance normalization before the CFAR (``"none"``:
    none); ``toa_estimator = "interval"`` the seed's ToA of distributed targets (steps 1-3: a window of
    ``toa_interval_samples`` W_p, at least ``toa_interval_threshold`` T_LIM detections in it, ToA = interval start -
    T_LIM, plus ``toa_interval_offset_s``: 0 is the seed's eq. 3); ``network = "couples"`` localizes ToA couples
    of the transmitter's two receivers by ellipse intersection
    (instead of seed 000's ``nu``-tuples): with ``toa_association`` the couples of the seed's ToA association (steps
    4-7, widening 2 d / c + ``association_correction_s``; ``association_completion``: step 6, isolated ToAs completed
    from the previous scan's couples), without it every Rx1 x Rx2 combination (the ghosts' source);
    ``wall_compensation`` removes the known walls' excess delay from the couple's ranges before the
    intersection; a couple's position covariance takes the two ranges' errors as independent of std
    ``range_std_floor_m`` plus a common part of std ``couple_common_std_m`` (both receivers see the same body).
    ``coherent_echoes`` (``background = "exponential-coherent"`` only): each echo (target, or body centre) keeps its
    carrier phase from scan to scan, so its phase follows its delay as a real scatterer's does (off: a new uniform
    phase every scan, which no background can cancel); the exponential average is then a moving-target indicator
    that cancels a still target, and the parametric model of the same scenario takes the MTI's loss on the echo's
    SNR at the target's bistatic range-rate (``uwb_env.channel.background_mti``).
    ``clutter_map`` (``output = "positions"``): each position detection's clutter intensity is a spatial clutter
    map's density at its position (Musicki & Evans 2004, :mod:`uwb_env.detection.clutter_map`): per cell of
    ``clutter_map_cell_m`` over the surveillance area, the position detections per scan exponentially averaged with
    a memory of ``clutter_map_memory_scans`` scans, over the cell's area, floored at
    ``false_position_density_per_m2``; read before the scan's own detections update it, empty at every episode
    (off: the constant ``false_position_density_per_m2``). ``clutter_map_count``: what a detection adds to its cell,
    1 (``"all"``), 1 for a couple that has not moved (``"still"``, network ``"couples"``), or its a-posteriori clutter
    probability from the tracker's association of the scan (``"unassociated"``: Musicki's refinement, the map updated
    after the tracker's step, ``Simulator.step``; the tracker must offer ``clutter_probabilities``).

    Seed 004's ToA (``toa_estimator = "hmm"``, :mod:`uwb_env.detection.hmm`): the scan's and the raw empty room's
    energies in bins of ``hmm_bin_s`` from the blind zone's end, the single-capture change statistic O_k per bin
    (chi^2_1 in an unchanged bin: the noise and the background paths' fluctuation ``clutter_fluctuation`` being
    known), a two-state HMM along delay (``hmm_p01`` the per-bin change probability, ``hmm_p10`` the seed's small
    return probability epsilon; state 0's O exactly chi^2_1, state 1's log O ~ N(``hmm_change_log_mean``,
    ``hmm_change_log_var``)), ``hmm_iterations`` Baum-Welch iterations over the scan's pairs from that lambda; the ToA
    is the centre of the first bin whose posterior P(X_k = 1 | O) exceeds 1/2 (eq. 12), at most one per pair.
    """

    sample_rate_hz: float = 16.4e9
    n_samples: int = 1920
    direct_path_offset_s: float = 20e-9
    scan_jitter_s: float = 0.5e-9
    n_multipath: int = 20
    multipath_spacing_s: float = 4e-9
    multipath_decay_s: float = 20e-9
    multipath_power_ratio_db: float = -3.0
    background_seed: int = 0
    clutter_fluctuation: float = 0.005
    clutter_correlation: float = 0.9
    shadow_radius_m: float = 0.25
    shadow_loss_db: float = 20.0
    empty_room_scans: int = 16
    envelope_lpf_s: float = 0.2e-9
    dp_threshold_ratio: float = 0.3
    dp_jump_back_s: float = 3e-9
    background: Literal["empty_room", "exponential", "coherent", "exponential-coherent"] = "empty_room"
    background_alpha: float = 0.9
    align_scans: bool = True
    cfar: Literal["dtb", "ca", "g", "os"] = "dtb"
    dtb_alpha_local: float = 5.0
    dtb_alpha_global: float = 8.0
    dtb_buffer: int = 25
    dtb_qmax: int = 4
    dtb_delta: float = 0.5
    cfar_pfa: float = 1e-4
    cfar_reference: int = 32
    cfar_guard: int = 16
    os_rank: int = 48
    cluster_distance_s: float = 65 / 16.4e9
    cluster_min_weight: int = 4
    toa_estimator: Literal["median", "peak", "energy-detector", "interval", "hmm"] = "peak"
    ed_threshold_ratio: float = 0.95
    ed_false_alarm_probability: float = 0.01
    ed_pulse_integration: Literal["noncoherent", "coherent"] = "noncoherent"
    hmm_bin_s: float = 1e-9
    hmm_p01: float = 0.02
    hmm_p10: float = 0.01
    hmm_change_log_mean: float = 3.0
    hmm_change_log_var: float = 4.0
    hmm_iterations: int = 0
    nu: int = 3
    min_tuple_weight: float = 30.0
    max_residual_m: float = 0.15
    linkage: Literal["centroid", "single", "complete"] = "centroid"
    cluster_2d_distance_m: float = 0.5
    range_std_floor_m: float = 0.05
    output: Literal["positions", "ranges"] = "positions"
    false_ranges_per_scan: float = 3.0
    false_position_density_per_m2: float = 0.004
    chirp: ChirpSignalConfig = field(default_factory=ChirpSignalConfig)
    target_model: Literal["point", "extended"] = "point"
    body: BodyModelConfig = field(default_factory=BodyModelConfig)
    normalization: Literal["none", "advance"] = "none"
    toa_interval_samples: int = 15
    toa_interval_threshold: int = 4
    toa_association: bool = False
    association_correction_s: float = 0.5e-9
    association_completion: bool = True
    toa_interval_offset_s: float = 0.0
    couple_common_std_m: float = 0.0
    network: Literal["nu-tuples", "couples"] = "nu-tuples"
    wall_compensation: bool = False
    coherent_echoes: bool = False
    clutter_map: bool = False
    clutter_map_cell_m: float = 0.25
    clutter_map_memory_scans: float = 50.0
    clutter_map_count: Literal["all", "still", "unassociated"] = "all"

    def __post_init__(self) -> None:
        for name in (
            "sample_rate_hz",
            "direct_path_offset_s",
            "multipath_spacing_s",
            "multipath_decay_s",
            "envelope_lpf_s",
            "dp_jump_back_s",
            "dtb_alpha_local",
            "dtb_alpha_global",
            "cluster_distance_s",
            "max_residual_m",
            "cluster_2d_distance_m",
        ):
            _positive("SignalConfig", name, getattr(self, name))
        for name in ("scan_jitter_s", "clutter_fluctuation", "shadow_radius_m", "shadow_loss_db", "dtb_delta"):
            _non_negative("SignalConfig", name, getattr(self, name))
        _non_negative("SignalConfig", "min_tuple_weight", self.min_tuple_weight)
        _non_negative("SignalConfig", "range_std_floor_m", self.range_std_floor_m)
        _non_negative("SignalConfig", "false_position_density_per_m2", self.false_position_density_per_m2)
        _finite("SignalConfig", "multipath_power_ratio_db", self.multipath_power_ratio_db)
        _int_at_least("SignalConfig", "n_samples", self.n_samples, 64)
        _int_at_least("SignalConfig", "n_multipath", self.n_multipath, 0)
        _int_at_least("SignalConfig", "background_seed", self.background_seed, 0)
        _int_at_least("SignalConfig", "empty_room_scans", self.empty_room_scans, 1)
        _int_at_least("SignalConfig", "dtb_buffer", self.dtb_buffer, 1)
        _int_at_least("SignalConfig", "dtb_qmax", self.dtb_qmax, 1)
        _int_at_least("SignalConfig", "cfar_reference", self.cfar_reference, 1)
        _int_at_least("SignalConfig", "cfar_guard", self.cfar_guard, 0)
        _int_at_least("SignalConfig", "cluster_min_weight", self.cluster_min_weight, 1)
        _int_at_least("SignalConfig", "nu", self.nu, 3)
        if not 1 <= self.os_rank <= 2 * self.cfar_reference:
            _fail("SignalConfig", "os_rank", self.os_rank, f"in [1, 2 x cfar_reference = {2 * self.cfar_reference}]")
        _in_range("SignalConfig", "clutter_correlation", self.clutter_correlation, 0.0, 1.0, closed="[)")
        _in_range("SignalConfig", "background_alpha", self.background_alpha, 0.0, 1.0, closed="()")
        _in_range("SignalConfig", "dp_threshold_ratio", self.dp_threshold_ratio, 0.0, 1.0, closed="()")
        _in_range("SignalConfig", "cfar_pfa", self.cfar_pfa, 0.0, 0.5, closed="()")
        _choice(
            "SignalConfig",
            "background",
            self.background,
            ("empty_room", "exponential", "coherent", "exponential-coherent"),
        )
        _choice("SignalConfig", "align_scans", self.align_scans, (True, False))
        _choice("SignalConfig", "cfar", self.cfar, ("dtb", "ca", "g", "os"))
        _choice(
            "SignalConfig",
            "toa_estimator",
            self.toa_estimator,
            ("median", "peak", "energy-detector", "interval", "hmm"),
        )
        _positive("SignalConfig", "hmm_bin_s", self.hmm_bin_s)
        _in_range("SignalConfig", "hmm_p01", self.hmm_p01, 0.0, 1.0, closed="()")
        _in_range("SignalConfig", "hmm_p10", self.hmm_p10, 0.0, 1.0, closed="[)")
        _positive("SignalConfig", "hmm_change_log_var", self.hmm_change_log_var)
        _int_at_least("SignalConfig", "hmm_iterations", self.hmm_iterations, 0)
        _in_range("SignalConfig", "ed_threshold_ratio", self.ed_threshold_ratio, 0.0, 1.0, closed="()")
        _in_range("SignalConfig", "ed_false_alarm_probability", self.ed_false_alarm_probability, 0.0, 1.0, closed="(]")
        _choice("SignalConfig", "ed_pulse_integration", self.ed_pulse_integration, ("noncoherent", "coherent"))
        if self.toa_estimator == "energy-detector" and self.background != "coherent":
            _fail("SignalConfig", "toa_estimator", self.toa_estimator, "'energy-detector' with background = 'coherent'")
        _choice("SignalConfig", "linkage", self.linkage, ("centroid", "single", "complete"))
        _choice("SignalConfig", "output", self.output, ("positions", "ranges"))
        _non_negative("SignalConfig", "false_ranges_per_scan", self.false_ranges_per_scan)
        if self.direct_path_offset_s * self.sample_rate_hz >= self.n_samples:
            _fail("SignalConfig", "direct_path_offset_s", self.direct_path_offset_s, "inside the scan window")
        _instance("SignalConfig", "chirp", self.chirp, ChirpSignalConfig, "a ChirpSignalConfig")
        _choice("SignalConfig", "target_model", self.target_model, ("point", "extended"))
        _instance("SignalConfig", "body", self.body, BodyModelConfig, "a BodyModelConfig")
        _choice("SignalConfig", "normalization", self.normalization, ("none", "advance"))
        _int_at_least("SignalConfig", "toa_interval_samples", self.toa_interval_samples, 1)
        if not isinstance(self.toa_interval_threshold, int) or not (
            1 <= self.toa_interval_threshold <= self.toa_interval_samples
        ):
            _fail(
                "SignalConfig",
                "toa_interval_threshold",
                self.toa_interval_threshold,
                f"an integer in [1, toa_interval_samples = {self.toa_interval_samples}]",
            )
        _choice("SignalConfig", "toa_association", self.toa_association, (True, False))
        _choice("SignalConfig", "association_completion", self.association_completion, (True, False))
        _finite("SignalConfig", "toa_interval_offset_s", self.toa_interval_offset_s)
        _non_negative("SignalConfig", "couple_common_std_m", self.couple_common_std_m)
        _non_negative("SignalConfig", "association_correction_s", self.association_correction_s)
        _choice("SignalConfig", "network", self.network, ("nu-tuples", "couples"))
        _choice("SignalConfig", "wall_compensation", self.wall_compensation, (True, False))
        if self.toa_association and self.network != "couples":
            _fail("SignalConfig", "toa_association", self.toa_association, "False unless network = 'couples'")
        if self.network == "couples" and self.output != "positions":
            _fail("SignalConfig", "network", self.network, "'nu-tuples' unless output = 'positions'")
        if self.normalization != "none" and self.background == "coherent":
            _fail("SignalConfig", "normalization", self.normalization, "'none' with background = 'coherent'")
        if self.background == "exponential-coherent" and self.align_scans:
            _fail("SignalConfig", "align_scans", self.align_scans, "False with background = 'exponential-coherent'")
        _choice("SignalConfig", "coherent_echoes", self.coherent_echoes, (True, False))
        if self.coherent_echoes and self.background != "exponential-coherent":
            _fail(
                "SignalConfig",
                "coherent_echoes",
                self.coherent_echoes,
                "False unless background = 'exponential-coherent'",
            )
        _choice("SignalConfig", "clutter_map", self.clutter_map, (True, False))
        _positive("SignalConfig", "clutter_map_cell_m", self.clutter_map_cell_m)
        _finite("SignalConfig", "clutter_map_memory_scans", self.clutter_map_memory_scans)
        if self.clutter_map_memory_scans < 1.0:
            _fail("SignalConfig", "clutter_map_memory_scans", self.clutter_map_memory_scans, ">= 1 (scans)")
        _choice("SignalConfig", "clutter_map_count", self.clutter_map_count, ("all", "still", "unassociated"))
        if self.clutter_map_count == "still" and self.network != "couples":
            _fail("SignalConfig", "clutter_map_count", self.clutter_map_count, "'all' unless network = 'couples'")
        if self.clutter_map and self.output != "positions":
            _fail("SignalConfig", "clutter_map", self.clutter_map, "False unless output = 'positions'")


@dataclass(frozen=True, slots=True)
class SensingConfig:
    """How a scan is sensed.

    ``max_range_m``: a target is covered by a pair only if both legs are shorter. ``blind_zone_excess_m``:
    detections whose bistatic range exceeds the baseline by less than this are discarded (seed 000 section IV-G;
    for a monostatic radar this is twice seed 002's blind range d*). ``measure_doa`` adds the azimuth measured by
    array receivers. ``clutter_residue_ratio`` (kappa) is the power of the residue that clutter removal leaves, per
    unit of the pair's direct-path SNR: the parametric detector sees SCNR = SNR / (1 + kappa SNR_dp) (clutter-limited
    detection; the measurement covariance keeps the thermal SNR because the residue lies at other delays); with
    ``clutter_residue_looks`` m > 0 the residue power fluctuates from scan to scan as kappa SNR_dp X, X ~ Gamma(m,
    1/m), and Pd is averaged over X (m = 0: a constant residue; m <= 100); kappa = 0 is a
    noise-limited detector, impulse-radio scenarios use the value calibrated on the signal path
    (``scripts/calibrate_parametric.py``). ``signal`` holds the knobs of the signal-level fidelity
    (:class:`SignalConfig`).

    ``array_beams``: how an array receiver combines its L elements (``uwb_env.sensing.beams``; both fidelities
    use it): ``dft`` forms L orthogonal beams by an element-space DFT and detects on each (a target at direction
    theta gets the gain max_m |AF_m(theta)|^2 / L of one element: L at a beam's centre, 0.44 L midway between two
    beams of a 3-element half-wavelength array); ``boresight`` is seed 003 eq. 6's plain element sum (one beam at
    boresight, nulls at +-41.8 deg for L = 3, d = lambda / 2); ``steered`` assumes a beam steered at every target
    (gain L everywhere: the parametric idealisation; no signal path).

    ``detection_gain_db``: the parametric detection test sees the SNR times this gain (Pd only, not R): the signal
    path's detector searches the neighbouring cells and beams for the peak, which a single-cell square-law test
    does not (calibrated on the chirp signal path by ``scripts/calibrate_chirp.py``; 0 by default).

    ``noise_window_cells`` (n): a peak detector counts a target as detected when any peak lies within its
    truth-matching window, so a noise peak there counts too; the parametric Pd is then
    1 - (1 - Pd_echo) (1 - Pfa)^n (``uwb_env.sensing.pd.windowed_detection_probability``), n the window's cells
    times the beams times the detector's noise peaks per cell and per unit Pfa (derived for the chirp chain in
    ``uwb_env.scenarios.urban_intersection``); 0 (the default) is the single-cell test.

    Multipath ghosts (parametric path; measured on the chirp signal path by ``scripts/calibrate_chirp.py``): every
    covered target yields, per pair and scan, a Poisson number of mean ``ghost_rate`` of detections on its paths
    through a scatterer, an exponential excess of mean ``ghost_range_offset_m`` beyond its bistatic range, its
    range-rate offset by N(0, ``ghost_range_rate_std_mps``^2); 0 (the default) draws none.

    ``min_range_std_m``: the floor of every measurement's range std (the receiver's timing jitter times c): the
    CRLB measurement models stop improving at the SNR where the range std reaches it, which floors range-rate and
    azimuth variances at the same SNR (``uwb_env.sensing.parametric.accuracy_snr_caps``). Without it a valid strong
    transmitter gives variances the tracker's covariance update cannot hold positive definite. In [1e-5, 1] m: below
    10 um the update of a track at the deletion limit (P ~ (50 m)^2) meets float64 rounding.

    ``compensate_walls`` (parametric path): the radar knows the walls (positions and excess delays) and removes
    their delay from every target detection's bistatic range, the delay of the walls crossed by the straight legs to
    the detection's own uncompensated position estimate (``ParametricSensor._wall_compensation``): the parametric
    counterpart of the signal path's ``SignalConfig.wall_compensation`` (seed 001's wall-effect compensation).
    Off (the default), a detection keeps the walls' excess delay as a positive range bias.

    ``detection_swerling`` (parametric path): the Swerling case of every target's RCS draws in the parametric
    detection test (``ParametricSensor.new_episode``), in place of each ``TargetConfig.swerling``, which the signal
    path's echoes (and the background MTI's retained fraction) keep reading: a detection statistic fitted on a signal
    chain whose decision is not a single-cell test of the target's own fluctuation (``through-wall``: seed 001's
    interval ToA over an extended body). None (the default): each target's own case.
    """

    fidelity: Literal["parametric", "signal"] = "parametric"
    scan_period_s: float = 0.25
    false_alarm_probability: float = 1e-4
    max_range_m: float = 300.0
    blind_zone_excess_m: float = 0.0
    measure_doa: bool = False
    clutter_residue_ratio: float = 0.0
    clutter_residue_looks: float = 0.0
    array_beams: Literal["dft", "boresight", "steered"] = "dft"
    detection_gain_db: float = 0.0
    noise_window_cells: float = 0.0
    ghost_rate: float = 0.0
    ghost_range_offset_m: float = 20.0
    ghost_range_rate_std_mps: float = 2.5
    min_range_std_m: float = 5e-5
    compensate_walls: bool = False
    detection_swerling: int | None = None
    clutter: ClutterConfig = field(default_factory=ClutterConfig)
    signal: SignalConfig = field(default_factory=SignalConfig)

    def __post_init__(self) -> None:
        _choice("SensingConfig", "fidelity", self.fidelity, ("parametric", "signal"))
        _choice("SensingConfig", "array_beams", self.array_beams, ("dft", "boresight", "steered"))
        _in_range("SensingConfig", "detection_gain_db", self.detection_gain_db, -10.0, 10.0)
        _in_range("SensingConfig", "noise_window_cells", self.noise_window_cells, 0.0, 1e4)
        _in_range("SensingConfig", "ghost_rate", self.ghost_rate, 0.0, 100.0)
        _positive("SensingConfig", "ghost_range_offset_m", self.ghost_range_offset_m)
        _non_negative("SensingConfig", "ghost_range_rate_std_mps", self.ghost_range_rate_std_mps)
        _in_range("SensingConfig", "min_range_std_m", self.min_range_std_m, 1e-5, 1.0)
        _positive("SensingConfig", "scan_period_s", self.scan_period_s)
        _in_range("SensingConfig", "false_alarm_probability", self.false_alarm_probability, 0.0, 0.1, closed="(]")
        _positive("SensingConfig", "max_range_m", self.max_range_m)
        _non_negative("SensingConfig", "blind_zone_excess_m", self.blind_zone_excess_m)
        _non_negative("SensingConfig", "clutter_residue_ratio", self.clutter_residue_ratio)
        # the Gauss-Laguerre weights of Gamma(m, 1/m) overflow above m = 171; beyond 100 looks the residue varies by
        # under 10 %: use 0 (a constant residue)
        _in_range("SensingConfig", "clutter_residue_looks", self.clutter_residue_looks, 0.0, 100.0)
        _bool("SensingConfig", "measure_doa", self.measure_doa)
        _bool("SensingConfig", "compensate_walls", self.compensate_walls)
        if self.detection_swerling is not None:
            _choice("SensingConfig", "detection_swerling", self.detection_swerling, (0, 1, 3))
        _instance("SensingConfig", "clutter", self.clutter, ClutterConfig, "a ClutterConfig")
        _instance("SensingConfig", "signal", self.signal, SignalConfig, "a SignalConfig")


@dataclass(frozen=True, slots=True)
class MotionModelConfig:
    """One model of the tracker's (VS-)IMM: ``ncv``, ``nca`` or ``ct`` (seed 003 section 3.3).

    ``accel_noise_std_mps2`` is sigma_w of Q = sigma_w^2 G G^T (for ``nca``, the std of the acceleration
    increment per scan); ``turn_rate_rps`` is the known rate of a ``ct`` model (positive = left).
    """

    name: str
    kind: Literal["ncv", "nca", "ct"]
    accel_noise_std_mps2: float = 0.5
    turn_rate_rps: float = 0.0

    def __post_init__(self) -> None:
        _name("MotionModelConfig", self.name)
        _choice("MotionModelConfig", "kind", self.kind, ("ncv", "nca", "ct"))
        # (0, 100 g]: at 1e6 m/s^2 the predicted covariance (~1e12 m^2/s^4 per scan) meets float64 rounding
        _in_range("MotionModelConfig", "accel_noise_std_mps2", self.accel_noise_std_mps2, 0.0, 1000.0, closed="(]")
        _finite("MotionModelConfig", "turn_rate_rps", self.turn_rate_rps)
        if self.kind == "ct" and self.turn_rate_rps == 0:
            _fail("MotionModelConfig", "turn_rate_rps", self.turn_rate_rps, "non-zero for a coordinated turn")


@dataclass(frozen=True, slots=True)
class ModelSetWindowConfig:
    """VS-IMM: the active model set during scans ``first_scan .. last_scan`` (inclusive), seed 003 section V."""

    first_scan: int
    last_scan: int
    models: tuple[str, ...]

    def __post_init__(self) -> None:
        _int_at_least("ModelSetWindowConfig", "first_scan", self.first_scan, 0)
        _int_at_least("ModelSetWindowConfig", "last_scan", self.last_scan, self.first_scan)
        if not isinstance(self.models, tuple) or not self.models or not all(isinstance(m, str) for m in self.models):
            _fail("ModelSetWindowConfig", "models", self.models, "a non-empty tuple of model names")


_SEED003_TRACKER_MODELS = (
    MotionModelConfig("ncv", "ncv", 0.5),
    MotionModelConfig("nca", "nca", 0.3),
    MotionModelConfig("ct_left", "ct", 0.5, math.pi / 20.0),
    MotionModelConfig("ct_right", "ct", 0.5, -math.pi / 20.0),
)
# Seed 003's transition matrix over (NCV, NCA, CT-left, CT-right), rows "from"; its printed rows 3-4 sum to 1.09
# and are read with 0.01 for 0.1 (see uwb_env.tracking.imm).
SEED003_TRANSITION_ROWS = (
    (0.99, 0.01, 0.0, 0.0),
    (0.10, 0.70, 0.10, 0.10),
    (0.0, 0.01, 0.99, 0.0),
    (0.0, 0.01, 0.0, 0.99),
)


@dataclass(frozen=True, slots=True)
class PhdConfig:
    """Seed 000's particle PHD tracker (``TrackerConfig.kind = "phd"``, ``uwb_env.tracking.phd``).

    Seed 000 (section V-D) fixes the structure (SMC-PHD with births around each measurement, a constant particle count
    per expected target by resampling, EM peak extraction, association to labelled tracks with an
    unconfirmed / confirmed / silent / dead state machine) but prints none of its numbers except nu = 3; the values
    below are ours, for indoor-rsn's walking person at 10 scans/s (``uwb_env.tracking.phd`` explains each).

    Particles: ``particles_per_target`` per unit of PHD mass after resampling (at least ``min_particles``, at most
    ``max_particles``), ``particles_per_birth`` new particles around each measurement. Birth: measurement-driven
    (Ristic, Clark, Vo, Vo 2012) with intensity ``birth_intensity_per_m2`` in the measurement space (same units as the
    clutter intensity: an isolated measurement is a new target with probability nu_b / (kappa + nu_b)), position from
    the measurement's covariance, velocity N(0, ``birth_velocity_std_mps``^2 I). Prediction: survival
    ``survival_probability`` per scan (0 beyond ``area_margin_m`` outside the surveillance area), NCV with white
    acceleration of std ``accel_noise_std_mps2``. Detection probability from the sensor model evaluated on a grid of
    ``pd_grid_m`` cells (0: at every particle). Ranges in, positions formed with the network chain
    (``uwb_env.localization.locate``): ``nu``-tuples, residual at most ``max_residual_m``, 2-D clustering
    ``linkage`` / ``cluster_distance_m``, covariance with range std ``range_std_m``, clutter intensity of the
    formed positions ``false_position_density_per_m2`` (measured on indoor-rsn at parametric fidelity: 1.35 false
    positions per scan over 69 m^2). EM: at most ``em_iterations`` iterations, stop below ``em_tolerance`` relative
    change of the log-likelihood, up to ``em_extra_components`` components beyond round(mass) seeded at measurements
    holding at least ``em_min_seed_mass`` (they absorb clutter mass; the round(mass) heaviest are the peaks).
    Association: minimum-cost hypothesis (sum of position distances) valid as a whole when its cost is at most
    ``max_hypothesis_cost_m``, else pair by pair in the chi-square gate of ``TrackerConfig.gate_probability``.
    State machine: confirmed after ``confirm_updates`` consecutive updated scans (birth included), a silent track dies
    after ``silent_max_scans`` scans without an update.

    Birth and confirmation were chosen on indoor-rsn's signal path (20 runs, then checked on 40 other seeds):
    nu_b = 0.001 / m^2 is 0.07 expected new targets per scan over the 69 m^2 room (a prior on people entering, not a
    match for the clutter), so an isolated false position is a new target with probability 0.2 (kappa = 0.004 / m^2
    there); five consecutive updates (0.5 s) outlast the multipath ghosts of the person that the network chain forms
    for two to four scans. With nu_b = 0.01 and three updates a false track was confirmed in 25 % of runs.
    """

    particles_per_target: int = 1000
    particles_per_birth: int = 100
    min_particles: int = 100
    max_particles: int = 50000
    birth_intensity_per_m2: float = 0.001
    birth_velocity_std_mps: float = 1.5
    survival_probability: float = 0.99
    accel_noise_std_mps2: float = 0.5
    area_margin_m: float = 1.0
    pd_grid_m: float = 0.25
    em_iterations: int = 20
    em_tolerance: float = 1e-6
    em_extra_components: int = 10
    em_min_seed_mass: float = 0.05
    max_hypothesis_cost_m: float = 1.0
    confirm_updates: int = 5
    silent_max_scans: int = 10
    nu: int = 3
    max_residual_m: float = 0.15
    cluster_distance_m: float = 0.5
    linkage: Literal["centroid", "single", "complete"] = "centroid"
    range_std_m: float = 0.05
    false_position_density_per_m2: float = 0.02

    def __post_init__(self) -> None:
        for name, lo in (
            ("particles_per_target", 1),
            ("particles_per_birth", 1),
            ("min_particles", 1),
            ("em_iterations", 1),
            ("em_extra_components", 0),
            ("confirm_updates", 1),
            ("silent_max_scans", 0),
            ("nu", 3),
        ):
            _int_at_least("PhdConfig", name, getattr(self, name), lo)
        _int_at_least("PhdConfig", "max_particles", self.max_particles, self.min_particles)
        for name in (
            "birth_intensity_per_m2",
            "birth_velocity_std_mps",
            "accel_noise_std_mps2",
            "em_tolerance",
            "max_hypothesis_cost_m",
            "max_residual_m",
            "cluster_distance_m",
            "range_std_m",
            "false_position_density_per_m2",
        ):
            _positive("PhdConfig", name, getattr(self, name))
        _in_range("PhdConfig", "survival_probability", self.survival_probability, 0.0, 1.0, closed="(]")
        _non_negative("PhdConfig", "area_margin_m", self.area_margin_m)
        _non_negative("PhdConfig", "pd_grid_m", self.pd_grid_m)
        _in_range("PhdConfig", "em_min_seed_mass", self.em_min_seed_mass, 0.0, 1.0)
        _choice("PhdConfig", "linkage", self.linkage, ("centroid", "single", "complete"))


@dataclass(frozen=True, slots=True)
class PfConfig:
    """Seed 002's particle filter (``TrackerConfig.kind = "pf"``, ``uwb_env.tracking.pf``).

    Owned by the particle filter's module; every field is validated here like the rest of the configuration.
    Defaults are the seed's (section V) where it gives one:

    - ``n_particles`` N_p (the seed does not print it; 1000 is ours);
    - ``mobility``: ``skdu`` (speed known, direction unknown, eq. 16) or ``sdl`` (speed and direction learnt from
      past estimates, eqs. 17-18);
    - SDL's learnt velocity v_el (the seed leaves these open; ``uwb_env.tracking.pf`` measures each choice):
      ``sdl_window_s`` = 1 s, the window in time, N_v = round(``sdl_window_s`` / T) steps (the seed's N_v = 5 at
      its T = 0.2 s; 0: the fixed ``sdl_window`` = N_v = 5 steps at any T); ``sdl_estimator``: ``lsq`` (default,
      the least-squares slope of the window's estimates against time) or ``difference`` (eq. 17 read literally,
      (p^_{k-1} - p^_{k-1-N_v}) / (N_v T)); ``sdl_velocity_spread``: each particle draws its velocity from
      N(v_el, C_v), C_v = Cov(v_el) from the estimates' covariances + (``sdl_accel_std_mps2`` tau)^2 I, the
      manoeuvre (1 m/s^2: a 1 m/s walker turning at ~1 rad/s) over the lag tau from the window's mean time to the
      move (False: every particle moves by v_el, the seed's). ``difference``, 0 and False: the seed as printed;
    - ``speed_mps``: the known speed v of SKDU (the seed's person walks at 1 m/s);
    - ``mobility_std_m``: sigma_m of the Gaussian mobility model (eq. 15); 0 (default) applies the seed's rule
      "with probability ``mobility_containment`` = 0.9 the new position is within a circle of radius v T":
      sigma_m = v T / sqrt(-2 ln(1 - 0.9)) = 0.093 m at T = 0.2 s (the seed's printed "1m" is read as this rule);
    - ``likelihood``: the perception model's range std: ``snr`` (default: each detection's own R, the
      three-region sigma(SNR) of the energy detector, seed 002 eq. 9), ``seed`` (the fixed sigma_p =
      ``perception_std_m`` = 0.8 m on the one-way distance, eq. 20) or ``both`` (their variances added). The
      seed's fixed sigma_p reproduces its LOS Fig. 2 but loses the person behind walls, where most detections
      have the several-metre spread of the low-SNR region (``uwb_env.tracking.pf``);
    - ``wall_bias``: the predicted range of a particle includes the walls' excess delay on its radar legs
      (section II-D, mu_i(p)); ``respect_walls``: a move that would cross a wall segment is redrawn up to
      ``wall_redraws`` times, then the particle stays where it was (our choice: the seed's person does not walk
      through walls, the seed says nothing on how its PF enforces it);
    - ``resample_threshold``: systematic resampling when the effective sample size falls below this fraction of
      N_p; ``confirm_ess_fraction``: the track is reported confirmed while the ESS after the update is at least
      this fraction of N_p;
    - ``init_std_m``: the range spread of the particles drawn on the iso-range rings of the first scan with
      detections (0: uniform over the surveillance area, weighted by the first scan's likelihood);
    - ``detection_probability_floor``: the smallest Pd the likelihood uses where the sensor model says 0 (a
      detection far from the model's coverage must not annihilate every particle).
    """

    n_particles: int = 1000
    mobility: Literal["skdu", "sdl"] = "skdu"
    speed_mps: float = 1.0
    mobility_std_m: float = 0.0
    mobility_containment: float = 0.9
    sdl_window: int = 5
    sdl_window_s: float = 1.0
    sdl_estimator: Literal["difference", "lsq"] = "lsq"
    sdl_velocity_spread: bool = True
    sdl_accel_std_mps2: float = 1.0
    likelihood: Literal["snr", "seed", "both"] = "snr"
    perception_std_m: float = 0.8
    wall_bias: bool = True
    respect_walls: bool = True
    wall_redraws: int = 3
    resample_threshold: float = 0.5
    confirm_ess_fraction: float = 0.05
    init_std_m: float = 0.0
    detection_probability_floor: float = 0.05

    def __post_init__(self) -> None:
        _int_at_least("PfConfig", "n_particles", self.n_particles, 1)
        _choice("PfConfig", "mobility", self.mobility, ("skdu", "sdl"))
        _in_range("PfConfig", "speed_mps", self.speed_mps, 0.0, 1e3)
        _in_range("PfConfig", "mobility_std_m", self.mobility_std_m, 0.0, 1e3)
        _in_range("PfConfig", "mobility_containment", self.mobility_containment, 0.0, 1.0, closed="()")
        _int_at_least("PfConfig", "sdl_window", self.sdl_window, 1)
        _in_range("PfConfig", "sdl_window_s", self.sdl_window_s, 0.0, 1e3)
        _choice("PfConfig", "sdl_estimator", self.sdl_estimator, ("difference", "lsq"))
        _bool("PfConfig", "sdl_velocity_spread", self.sdl_velocity_spread)
        _in_range("PfConfig", "sdl_accel_std_mps2", self.sdl_accel_std_mps2, 0.0, 1e3)
        _choice("PfConfig", "likelihood", self.likelihood, ("snr", "seed", "both"))
        _positive("PfConfig", "perception_std_m", self.perception_std_m)
        _bool("PfConfig", "wall_bias", self.wall_bias)
        _bool("PfConfig", "respect_walls", self.respect_walls)
        _int_at_least("PfConfig", "wall_redraws", self.wall_redraws, 0)
        _in_range("PfConfig", "resample_threshold", self.resample_threshold, 0.0, 1.0)
        _in_range("PfConfig", "confirm_ess_fraction", self.confirm_ess_fraction, 0.0, 1.0)
        _in_range("PfConfig", "init_std_m", self.init_std_m, 0.0, 1e3)
        _in_range("PfConfig", "detection_probability_floor", self.detection_probability_floor, 0.0, 1.0)
        if self.mobility_std_m == 0.0 and self.speed_mps == 0.0:
            _fail("PfConfig", "mobility_std_m", self.mobility_std_m, "> 0 when speed_mps = 0 (the seed's rule gives 0)")


TRACKER_KINDS = ("imm-lmipda", "phd", "pf")
"""The trackers of ``uwb_env.tracking.registry``: seed 003's VS-IMM / LMIPDA (the default), seed 000's particle PHD,
seed 002's particle filter."""


@dataclass(frozen=True, slots=True)
class TrackerConfig:
    """The VS-IMM / LMIPDA tracker (seed 003 section 4.2).

    ``models`` with the row-stochastic ``transition`` (rows "from"); the active set is ``default_models`` except
    in ``model_set_windows``. ``filter``: ``ukf`` (Julier-Uhlmann, alpha = 1, beta = 2, kappa = 0) or ``ekf``.
    ``detection_probability`` is used when the tracker is given no sensor model. Existence: Markov survival
    ``survival_probability`` per scan; new tracks start at ``initial_existence`` (the prior that a two-point
    candidate is a target: low, since clutter forms several candidate pairs per scan), are confirmed at
    ``confirm_existence`` and deleted below ``terminate_existence``, when their position std exceeds
    ``max_position_std_m``, or when still tentative after ``tentative_max_age`` scans (confirmation time-out).
    Initiation: two-point differencing with the velocity gate of seed 003 section 4.2.1 (``max_speed_mps``) from
    candidates whose position std is below ``init_max_position_std_m``; new tracks get
    acceleration std ``initial_accel_std_mps2``; at most ``init_max_candidates`` candidates per scan (the most
    precise; range-only tuples use at most that many highest-SNR detections per receiver) bound the work in
    very dense clutter. ``min_clutter_intensity`` floors rho_i (a clutter-free scene is a
    vanishing clutter intensity). ``fixed_existence`` turns LMIPDA into PDA association (every track
    claims measurements as if it existed; existence is still updated for track management). With a sensor model the
    detection probability of a track is the radar equation's at its predicted position for a target of
    ``assumed_rcs_m2`` and ``assumed_swerling``, capped at ``max_detection_probability`` (one missed detection
    must not end a track). ``range_rate_noise_floor_mps`` is added in quadrature to every range-rate
    measurement's std in the filter (and the lookahead): the manoeuvre a scan's motion models do not follow
    (a deceleration's onset, a turn's entry), which a pulse train's 0.03 m/s range-rate would otherwise turn into
    a collapse of the IMM onto the wrong model and gated-out detections (0: the sensor's R as it is).
    """

    models: tuple[MotionModelConfig, ...] = _SEED003_TRACKER_MODELS
    transition: tuple[tuple[float, ...], ...] = SEED003_TRANSITION_ROWS
    default_models: tuple[str, ...] = ("ncv", "nca")
    model_set_windows: tuple[ModelSetWindowConfig, ...] = ()
    filter: Literal["ukf", "ekf"] = "ukf"
    gate_probability: float = 0.99
    detection_probability: float = 0.9
    survival_probability: float = 0.98
    initial_existence: float = 0.005
    confirm_existence: float = 0.99
    terminate_existence: float = 0.001
    max_speed_mps: float = 20.0
    initial_accel_std_mps2: float = 1.0
    init_max_position_std_m: float = 10.0
    init_max_candidates: int = 200
    max_position_std_m: float = 50.0
    tentative_max_age: int = 5
    min_clutter_intensity: float = 1e-15
    fixed_existence: bool = False
    assumed_rcs_m2: float = 1.0
    assumed_swerling: int = 1
    max_detection_probability: float = 0.99
    range_rate_noise_floor_mps: float = 0.0
    kind: Literal["imm-lmipda", "phd", "pf"] = "imm-lmipda"
    phd: PhdConfig = PhdConfig()
    pf: PfConfig = PfConfig()

    def __post_init__(self) -> None:
        _choice("TrackerConfig", "kind", self.kind, TRACKER_KINDS)
        _instance("TrackerConfig", "phd", self.phd, PhdConfig, "a PhdConfig")
        _instance("TrackerConfig", "pf", self.pf, PfConfig, "a PfConfig")
        _in_range("TrackerConfig", "range_rate_noise_floor_mps", self.range_rate_noise_floor_mps, 0.0, 1e3)
        if (
            not isinstance(self.models, tuple)
            or not self.models
            or not all(isinstance(m, MotionModelConfig) for m in self.models)
        ):
            _fail("TrackerConfig", "models", self.models, "a non-empty tuple of MotionModelConfig")
        _tuple_of("TrackerConfig", "default_models", self.default_models, str, "model names")
        _tuple_of(
            "TrackerConfig", "model_set_windows", self.model_set_windows, ModelSetWindowConfig, "ModelSetWindowConfig"
        )
        names = [m.name for m in self.models]
        if len(set(names)) != len(names):
            _fail("TrackerConfig", "models", names, "uniquely named")
        r = len(self.models)
        rows = self.transition
        if (
            not isinstance(rows, tuple)
            or len(rows) != r
            or any(not isinstance(row, tuple) or len(row) != r for row in rows)
        ):
            _fail("TrackerConfig", "transition", rows, f"a {r} x {r} tuple of tuples (one row per model)")
        for i, row in enumerate(rows):
            numbers = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in row)
            if not numbers or any((not math.isfinite(v)) or v < 0 for v in row) or abs(sum(row) - 1.0) > 1e-9:
                _fail("TrackerConfig", f"transition[{i}]", row, "non-negative entries summing to 1 (rows = from)")
        for group, sets in (
            ("default_models", (self.default_models,)),
            ("model_set_windows", tuple(w.models for w in self.model_set_windows)),
        ):
            for models in sets:
                unknown = [m for m in models if m not in names]
                if unknown or not models:
                    _fail("TrackerConfig", group, models, f"a non-empty subset of the model names {names}")
        _choice("TrackerConfig", "filter", self.filter, ("ukf", "ekf"))
        _in_range("TrackerConfig", "gate_probability", self.gate_probability, 0.0, 1.0, closed="(]")
        _in_range("TrackerConfig", "detection_probability", self.detection_probability, 0.0, 1.0, closed="(]")
        _in_range("TrackerConfig", "survival_probability", self.survival_probability, 0.0, 1.0, closed="(]")
        for f in ("initial_existence", "confirm_existence", "terminate_existence"):
            _in_range("TrackerConfig", f, getattr(self, f), 0.0, 1.0, closed="()")
        if not self.terminate_existence < self.initial_existence < self.confirm_existence:
            _fail(
                "TrackerConfig",
                "initial_existence",
                self.initial_existence,
                "strictly between terminate_existence and confirm_existence",
            )
        _positive("TrackerConfig", "max_speed_mps", self.max_speed_mps)
        _in_range("TrackerConfig", "initial_accel_std_mps2", self.initial_accel_std_mps2, 0.0, 1000.0, closed="(]")
        _positive("TrackerConfig", "init_max_position_std_m", self.init_max_position_std_m)
        _int_at_least("TrackerConfig", "init_max_candidates", self.init_max_candidates, 1)
        _positive("TrackerConfig", "max_position_std_m", self.max_position_std_m)
        _int_at_least("TrackerConfig", "tentative_max_age", self.tentative_max_age, 1)
        _in_range("TrackerConfig", "min_clutter_intensity", self.min_clutter_intensity, 1e-300, 1.0, closed="(]")
        _positive("TrackerConfig", "assumed_rcs_m2", self.assumed_rcs_m2)
        _choice("TrackerConfig", "assumed_swerling", self.assumed_swerling, (0, 1, 3))
        _in_range("TrackerConfig", "max_detection_probability", self.max_detection_probability, 0.0, 1.0, closed="(]")
        _bool("TrackerConfig", "fixed_existence", self.fixed_existence)

    def active_models(self, scan_index: int) -> tuple[str, ...]:
        """The model set in force at a scan (the first matching window, else the default set)."""
        for w in self.model_set_windows:
            if w.first_scan <= scan_index <= w.last_scan:
                return w.models
        return self.default_models


def open_loop_tracker(tracker: TrackerConfig, accel_noise_std_mps2: float = 0.5) -> TrackerConfig:
    """Seed 003's open-loop baseline tracker: one NCV UKF -- the same machinery with a single model."""
    return dataclasses.replace(
        tracker,
        models=(MotionModelConfig("ncv", "ncv", accel_noise_std_mps2),),
        transition=((1.0,),),
        default_models=("ncv",),
        model_set_windows=(),
    )


# ------------------------------------------------------------------------------------------------------- scenario
@dataclass(frozen=True, slots=True)
class ScenarioConfig:
    """A whole scenario: scene, targets, waveform library, channel, sensing and tracker settings.

    ``surveillance_area`` is where targets are tracked and clutter falls; ``world`` bounds everything (nodes,
    walls, trajectories). ``n_scans`` scans of ``sensing.scan_period_s`` make an episode. ``pairs`` lists the
    (transmitter, receiver) index pairs that form radars; empty means every combination (a multistatic network);
    a network of monostatic radars lists ``((0, 0), (1, 1), ...)``.
    """

    name: str
    world: Box
    surveillance_area: Box
    transmitters: tuple[TransmitterConfig, ...]
    receivers: tuple[ReceiverConfig, ...]
    waveforms: tuple[WaveformConfig, ...]
    targets: tuple[TargetConfig, ...]
    n_scans: int
    walls: tuple[WallConfig, ...] = ()
    line_scatterers: tuple[LineScattererConfig, ...] = ()
    clutter_points_m: tuple[Vec2, ...] = ()
    pairs: tuple[tuple[int, int], ...] = ()
    channel: ChannelConfig = field(default_factory=ChannelConfig)
    sensing: SensingConfig = field(default_factory=SensingConfig)
    tracker: TrackerConfig = field(default_factory=TrackerConfig)
    description: str = ""
    seed_reference: str = ""

    def __post_init__(self) -> None:
        _name("ScenarioConfig", self.name)
        _instance("ScenarioConfig", "world", self.world, Box, "a Box")
        _instance("ScenarioConfig", "surveillance_area", self.surveillance_area, Box, "a Box")
        for group, cls in (
            ("transmitters", TransmitterConfig),
            ("receivers", ReceiverConfig),
            ("targets", TargetConfig),
            ("walls", WallConfig),
            ("line_scatterers", LineScattererConfig),
        ):
            _tuple_of("ScenarioConfig", group, getattr(self, group), cls, cls.__name__)
        _instance("ScenarioConfig", "clutter_points_m", self.clutter_points_m, tuple, "a tuple of (x, y) points")
        _instance("ScenarioConfig", "pairs", self.pairs, tuple, "a tuple of (tx, rx) index pairs")
        _instance("ScenarioConfig", "channel", self.channel, ChannelConfig, "a ChannelConfig")
        _instance("ScenarioConfig", "sensing", self.sensing, SensingConfig, "a SensingConfig")
        _instance("ScenarioConfig", "tracker", self.tracker, TrackerConfig, "a TrackerConfig")
        _str("ScenarioConfig", "description", self.description)
        _str("ScenarioConfig", "seed_reference", self.seed_reference)
        if not self.world.contains_box(self.surveillance_area):
            _fail("ScenarioConfig", "surveillance_area", self.surveillance_area, f"inside world {self.world}")
        for group in ("transmitters", "receivers", "waveforms", "targets"):
            items = getattr(self, group)
            if not isinstance(items, tuple) or not items:
                _fail("ScenarioConfig", group, items, "a non-empty tuple")
            names = [it.name for it in items]
            dup = sorted({n for n in names if names.count(n) > 1})
            if dup:
                _fail("ScenarioConfig", group, names, f"uniquely named (duplicates: {dup})")
        for group in ("transmitters", "receivers"):
            for i, node in enumerate(getattr(self, group)):
                if not self.world.contains(node.position_m):
                    _fail(
                        "ScenarioConfig",
                        f"{group}[{i}] ({node.name!r}).position_m",
                        node.position_m,
                        f"inside the world {self.world}",
                    )
        for i, w in enumerate(self.waveforms):
            if not isinstance(w, _WAVEFORM_TYPES):
                _fail("ScenarioConfig", f"waveforms[{i}]", w, "a ChirpWaveformConfig or ImpulseWaveformConfig")
        kinds = {type(w) for w in self.waveforms}
        if len(kinds) > 1:
            _fail(
                "ScenarioConfig",
                "waveforms",
                [w.name for w in self.waveforms],
                "all of one kind (chirp or impulse): the measurement space must not change with the action",
            )
        _int_at_least("ScenarioConfig", "n_scans", self.n_scans, 1)
        duration = self.n_scans * self.sensing.scan_period_s
        for i, t in enumerate(self.targets):
            if t.birth_time_s >= duration:
                _fail(
                    "ScenarioConfig",
                    f"targets[{i}] ({t.name!r}).birth_time_s",
                    t.birth_time_s,
                    f"< episode duration n_scans x scan_period_s = {duration}",
                )
            start = getattr(t.trajectory, "start_position_m", None)
            if start is not None and not self.world.contains(start):
                _fail(
                    "ScenarioConfig",
                    f"targets[{i}] ({t.name!r}).trajectory.start_position_m",
                    start,
                    f"inside the world {self.world}",
                )
            region = getattr(t.trajectory, "start_region", None)
            if region is not None and not self.world.contains_box(region):
                _fail(
                    "ScenarioConfig",
                    f"targets[{i}] ({t.name!r}).trajectory.start_region",
                    region,
                    f"inside the world {self.world}",
                )
        for i, p in enumerate(self.clutter_points_m):
            _vec2("ScenarioConfig", f"clutter_points_m[{i}]", p)
        seen = set()
        for i, pair in enumerate(self.pairs):
            if (
                not isinstance(pair, tuple)
                or len(pair) != 2
                or not all(isinstance(i, int) and not isinstance(i, bool) for i in pair)
                or not 0 <= pair[0] < len(self.transmitters)
                or not 0 <= pair[1] < len(self.receivers)
            ):
                _fail(
                    "ScenarioConfig",
                    f"pairs[{i}]",
                    pair,
                    f"(tx, rx) with 0 <= tx < {len(self.transmitters)} and 0 <= rx < {len(self.receivers)}",
                )
            if pair in seen:
                _fail("ScenarioConfig", f"pairs[{i}]", pair, "listed once")
            seen.add(pair)
        if self.sensing.clutter.discrete_fraction > 0 and not self.clutter_points_m:
            _fail(
                "ScenarioConfig",
                "sensing.clutter.discrete_fraction",
                self.sensing.clutter.discrete_fraction,
                "0 when the scenario has no clutter_points_m",
            )

    @property
    def duration_s(self) -> float:
        """Episode duration [s]."""
        return self.n_scans * self.sensing.scan_period_s

    @property
    def radar_pairs(self) -> tuple[tuple[int, int], ...]:
        """The formed (tx, rx) pairs in (tx, rx) order: ``pairs`` or every combination."""
        if self.pairs:
            return tuple(sorted(self.pairs))
        return tuple((t, r) for t in range(len(self.transmitters)) for r in range(len(self.receivers)))


# ------------------------------------------------------------------------------------------ dict / YAML round trip
def to_dict(obj: Any) -> Any:
    """Convert a config (or any nested value) to plain Python types; union-typed configs carry ``kind``."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        out: dict[str, Any] = {}
        kind = getattr(type(obj), "kind", None)
        if isinstance(kind, str):
            out["kind"] = kind
        for f in dataclasses.fields(obj):
            out[f.name] = to_dict(getattr(obj, f.name))
        return out
    if isinstance(obj, tuple):
        return [to_dict(v) for v in obj]
    return obj


def _kinds(args: tuple[Any, ...]) -> dict[str, type]:
    return {a.kind: a for a in args if isinstance(getattr(a, "kind", None), str)}


def _convert(tp: Any, value: Any, path: str) -> Any:
    """Coerce plain data ``value`` into type ``tp`` (dataclass, union, tuple, scalar)."""
    origin = get_origin(tp)
    if tp is Any:
        return value
    if origin in (Union, types.UnionType):
        args = get_args(tp)
        if value is None and type(None) in args:
            return None
        if dataclasses.is_dataclass(value) and isinstance(value, tuple(a for a in args if isinstance(a, type))):
            return value
        kinds = _kinds(args)
        if kinds:
            if not isinstance(value, Mapping) or "kind" not in value:
                raise ValueError(f"{path}: expected a mapping with 'kind' in {sorted(kinds)}, got {value!r}")
            kind = value["kind"]
            if kind not in kinds:
                close = difflib.get_close_matches(str(kind), list(kinds), n=1)
                hint = f" (did you mean {close[0]!r}?)" if close else ""
                raise ValueError(f"{path}.kind = {kind!r}: must be one of {sorted(kinds)}{hint}")
            return from_dict(kinds[kind], {k: v for k, v in value.items() if k != "kind"}, path)
        non_none = [a for a in args if a is not type(None)]
        return _convert(non_none[0], value, path)
    if origin is Literal:
        return value
    if origin is tuple:
        args = get_args(tp)
        if isinstance(value, (str, bytes)) or not hasattr(value, "__iter__"):
            raise ValueError(f"{path} = {value!r}: expected a sequence")
        seq = list(value)
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_convert(args[0], v, f"{path}[{i}]") for i, v in enumerate(seq))
        if len(seq) != len(args):
            raise ValueError(f"{path} = {value!r}: expected {len(args)} items")
        return tuple(_convert(a, v, f"{path}[{i}]") for i, (a, v) in enumerate(zip(args, seq, strict=True)))
    if isinstance(tp, type) and dataclasses.is_dataclass(tp):
        if isinstance(value, tp):
            return value
        if not isinstance(value, Mapping):
            raise ValueError(f"{path} = {value!r}: expected a mapping for {tp.__name__}")
        return from_dict(tp, value, path)
    # numbers keep their kind: an int (or numpy integer) is a valid float and becomes one; a float never becomes an
    # int (8.0 for an integer field is refused by the field's check), a bool or a string never becomes a number
    if tp is float and isinstance(value, numbers.Real) and not isinstance(value, bool):
        return float(value)
    if tp is int and isinstance(value, numbers.Integral) and not isinstance(value, bool):
        return int(value)
    if tp is bool and type(value).__name__ == "bool_":  # numpy's bool
        return bool(value)
    return value


def from_dict(cls: type, data: Mapping[str, Any], path: str = "") -> Any:
    """Build config ``cls`` from plain data (the inverse of :func:`to_dict`); unknown keys raise ``KeyError``."""
    hints = typing.get_type_hints(cls)
    names = [f.name for f in dataclasses.fields(cls)]
    where = path or cls.__name__
    if not isinstance(data, Mapping):
        raise ValueError(f"{where} = {data!r}: must be a mapping of {cls.__name__} fields {names}")
    tag = "kind" if "kind" not in names else None  # the union tag, unless ``kind`` is a real field
    unknown = [k for k in data if k not in names and k != tag]
    if unknown:
        close = difflib.get_close_matches(unknown[0], names, n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise KeyError(f"{where}: unknown field {unknown[0]!r}{hint}; allowed: {names}")
    required = [
        f.name
        for f in dataclasses.fields(cls)
        if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
    ]
    missing = [k for k in required if k not in data]
    if missing:
        raise KeyError(f"{where}: missing field {missing[0]!r}; {cls.__name__} requires {required}")
    kwargs = {k: _convert(hints[k], v, f"{where}.{k}") for k, v in data.items() if k != tag}
    return cls(**kwargs)


def save_yaml(cfg: ScenarioConfig, path: str | Path) -> None:
    """Write a scenario to YAML."""
    Path(path).write_text(yaml.safe_dump(to_dict(cfg), sort_keys=False))


def load_yaml(path: str | Path) -> ScenarioConfig:
    """Read a scenario from YAML (validated on construction); every error names the file.

    Raises ``ValueError`` for a file that is empty, not YAML or not a mapping, ``KeyError`` / ``ValueError`` (as
    :func:`from_dict`) for unknown or missing fields and bad values, each message prefixed with the file's path.
    """
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise ValueError(f"{path}: not valid YAML ({exc})") from exc
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: not a text file ({exc})") from exc
    if data is None:
        raise ValueError(f"{path}: the file is empty; it must hold a mapping of ScenarioConfig fields")
    if not isinstance(data, Mapping):
        raise ValueError(f"{path}: holds a {type(data).__name__}; it must hold a mapping of ScenarioConfig fields")
    try:
        return from_dict(ScenarioConfig, data)
    except KeyError as exc:
        raise KeyError(f"{path}: {exc.args[0]}") from exc
    except (ValueError, TypeError) as exc:
        raise type(exc)(f"{path}: {exc}") from exc


# ------------------------------------------------------------------------------------------------------ overrides
def _apply_tree(obj: Any, tree: Mapping[str, Any], where: str) -> Any:
    """Apply a nested mapping of changes to a config (or tuple of configs), one ``replace`` per node."""
    if isinstance(obj, tuple):
        items = list(obj)
        for key, value in tree.items():
            here = f"{where}.{key}" if where else key
            if not key.lstrip("-").isdigit() or not -len(obj) <= int(key) < len(obj):
                raise KeyError(f"{here}: index {key!r} out of range for a tuple of {len(obj)} items")
            i = int(key) % len(obj)
            if isinstance(value, Mapping) and dataclasses.is_dataclass(items[i]):
                items[i] = _apply_tree(items[i], value, here)
            else:
                items[i] = _convert(type(items[i]), value, here) if dataclasses.is_dataclass(items[i]) else value
        return tuple(items)
    if not dataclasses.is_dataclass(obj):
        raise KeyError(f"{where}: {where or 'config'} is not a config and has no fields {sorted(tree)}")
    names = [f.name for f in dataclasses.fields(obj)]
    hints = typing.get_type_hints(type(obj))
    changes = {}
    for key, value in tree.items():
        here = f"{where}.{key}" if where else key
        if key not in names:
            close = difflib.get_close_matches(key, names, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise KeyError(f"{here}: unknown field {key!r} of {type(obj).__name__}{hint}; allowed: {names}")
        current = getattr(obj, key)
        nested = dataclasses.is_dataclass(current) or isinstance(current, tuple)
        if isinstance(value, Mapping) and nested and not isinstance(current, type):
            changes[key] = _apply_tree(current, value, here)
        else:
            changes[key] = _convert(hints[key], value, here)
    try:
        return dataclasses.replace(obj, **changes)
    except ValueError as exc:  # the config's check names its own field; add where it sits in the override
        raise ValueError(f"{where}: {exc}" if where else str(exc)) from exc


def _as_tree(overrides: Mapping[str, Any]) -> dict[str, Any]:
    """Dotted keys (and nested mappings) -> one nested mapping."""
    tree: dict[str, Any] = {}
    for dotted, value in overrides.items():
        if not isinstance(dotted, str) or not dotted:
            raise KeyError(f"override key {dotted!r}: must be a dotted field path such as 'sensing.scan_period_s'")
        keys = dotted.split(".")
        node = tree
        for k in keys[:-1]:
            child = node.get(k)
            if not isinstance(child, dict):
                child = node[k] = {}
            node = child
        leaf = keys[-1]
        if isinstance(value, Mapping) and isinstance(node.get(leaf), dict):
            node[leaf].update(_as_tree(value))
        else:
            node[leaf] = _as_tree(value) if isinstance(value, Mapping) else value
    return tree


def apply_overrides(cfg: Any, overrides: Mapping[str, Any]) -> Any:
    """Return ``cfg`` with dotted-path overrides applied and re-validated.

    Example: ``apply_overrides(cfg, {"sensing.clutter.density_per_m2": 0.0, "receivers.1.noise_figure_db": 6})``.
    A value that is a mapping updates a nested config field by field. All changes to one config are applied
    together, so overrides that are only valid jointly (e.g. two existence thresholds) work.
    """
    return _apply_tree(cfg, _as_tree(overrides), "") if overrides else cfg
