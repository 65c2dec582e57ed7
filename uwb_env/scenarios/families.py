r"""Scene families: seeded variants of a registered scenario, with train / held-out splits (issue 20, item 3).

A policy trained on one scene can key on its coordinates and on the handedness of its turn (the urban policy fell to
round-robin level on the mirror image of ``urban-intersection``). A family draws variants of a registered scenario
along three axes, so training can randomise the scene and evaluation can hold variants out:

* **orientation**, the 8 elements of the dihedral group D4 acting on the whole scene about a centre c: the element
  ``g = 4 m + k`` (m in {0, 1}, k in 0..3) maps a point p to c + R^k S^m (p - c), S = diag(-1, 1) the mirror about
  the vertical line through c (applied first), R = [[0, -1], [1, 0]] a quarter turn counter-clockwise. Quarter turns
  keep every :class:`~uwb_env.config.Box` axis-aligned. Names (``ORIENTATIONS``): ``identity``, ``rot90``,
  ``rot180``, ``rot270``, then the four reflections r^k s about the lines through c at 90 + 45 k deg:
  ``mirror-vertical``, ``mirror-antidiagonal``, ``mirror-horizontal``, ``mirror-diagonal``.
* **path** through the intersection: the seed's left turn and a right turn and a straight crossing built in its style
  (``seed003_right_path``, ``seed003_straight_path``);
* **births and count**: 1 .. ``max_targets`` vehicles on the path, vehicle i born at ``i * birth_spacing_s`` plus a
  uniform whole number of scans in ``[0, birth_jitter_scans]`` (the seed: two vehicles, 0 s and 10 s).

What moves (:func:`transform`): the world and surveillance boxes, the transmitter and receiver positions, the arrays'
boresights (angle a -> 90 k + (180 - a if mirrored else a), wrapped to [-180, 180)), walls, line scatterers, clutter
points, the targets' start positions, start velocities (M v) and the turn rates' signs (times det M = -1 under a
mirror), start regions of room walks. Under a mirror the tracker's coordinated-turn models swap roles: each model of
kind ``ct`` is paired with the model of the same noise and opposite turn rate (``ct_left`` <-> ``ct_right``), and the
default model set, the VS-IMM windows' sets and the transition matrix are permuted accordingly, T'[pi(i), pi(j)] =
T[i, j] (a ct model without a partner raises). Nothing else in a scenario has a position or a direction.

Physics is the same: every distance between nodes, walls, clutter points and targets is preserved by an orthogonal M,
so bistatic ranges, range-rates (u . v with u and v both mapped by M), path losses, wall crossings, coverage and
field-of-view tests are identical (tests/unit/test_families.py: 1e-9 relative, 1e-13 seen). The uniform linear array
needs one more condition under a mirror: its element order has a handedness (element l at l d along the array axis,
``uwb_env.sensing.beams``) that a mirror reverses, so the mirrored array sees the mirrored target, at off-boresight
angle -psi, through beams at -u_m. The config has no element-order field to reverse; the beam gain max_m g_m(psi)
is unchanged iff the beam set {u_m} is symmetric about 0, which holds for ``boresight``, ``steered`` and the DFT beams
of an odd number of elements (0, +-41.8 deg for the seed's L = 3, d = lambda / 2). A mirror of a scenario whose
arrays' beams are not symmetric (``dft`` with even L) raises rather than silently changing the physics. The
azimuth CRLB depends on cos(psi) only. Random trajectories (``motion_model``, ``room_walk``) transform in distribution
only: their draws are made in the global frame (isotropic noise), so the same seed gives another realisation.

Same seed, same episode? The measurement noise and RCS draws are per link, so they carry over; two things are drawn in
the global frame and so carry over in distribution only: the false alarms (uniform over the surveillance box and
around the clutter points, in x then y), and the UKF's sigma points, taken from a Cholesky factor of the covariance,
which is equivariant under the axis sign flips (``identity``, ``rot180``, ``mirror-vertical``, ``mirror-horizontal``)
but not under the four elements that swap x and y. Measured on the right-turn path, clutter-free, seed 3, a fixed
action cycle: with the EKF (``tracker.filter = "ekf"``) all eight orientations give the same 140 rewards to 5e-12
relative; with the UKF the sign-flip elements agree to 3e-10 m^2 per scan and the axis-swapping ones differ from scan
29 on, the first confirmed track's (up to 105 m^2 in one scan's reward).

The centre: :func:`mirror` and :func:`rotate` default to the surveillance area's centre; the urban families use the
intersection's centre (``INTERSECTION_CENTRE``), so every variant's streets cross at the same point and the
variants overlap on the map (the physics does not depend on the choice).

Splits: a family's cells are (orientation, path) pairs; ``heldout`` lists the cells training never draws, ``train``
is the rest, ``all`` every cell; counts and births are drawn the same way in every split. The urban families hold
out 7 of the 24 cells so that the issue's held-out check has each kind of unseen variant
(``URBAN_HELDOUT``):

* *rotated*: every path in ``rot90`` (vehicles enter from the south);
* *mirrored*: every path in ``mirror-vertical``; its left-turn path is the issue's mirror image of the seed (the
  vehicles turn right in a mirrored city), on which ``rl:runs/urban-mppo-p1`` fell to round-robin level;
* *the other turn*: the seed's own orientation with the right turn.

Each kind is also a split of its own (``heldout_kinds``: ``heldout-rotated``, ``heldout-mirrored``,
``heldout-turn``), so an evaluation can report the three separately.

``SceneFamily.draw(seed, split)`` is deterministic: one ``numpy.random.Generator`` seeded by ``seed`` draws the cell
(uniform over the split's cells), the count (uniform in 1 .. ``max_targets``) and the births, in that order.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from uwb_env import scenarios
from uwb_env.config import (
    Box,
    LineScattererConfig,
    MotionModelTrajectoryConfig,
    MotionSegmentConfig,
    ReceiverConfig,
    RoomWalkTrajectoryConfig,
    ScenarioConfig,
    SegmentedTrajectoryConfig,
    TargetConfig,
    TrackerConfig,
    TransmitterConfig,
    UniformLinearArrayConfig,
    Vec2,
    WallConfig,
)
from uwb_env.constants import SPEED_OF_LIGHT_MPS
from uwb_env.scenarios.urban_intersection import END, START, TURN_RATE, seed003_path, seed003_speed_profile
from uwb_env.scene.geometry import point_segment_distance, segments_cross
from uwb_env.scene.trajectories import segmented_states
from uwb_env.sensing.beams import beam_sines
from uwb_env.typing import FloatArray

ORIENTATIONS: tuple[str, ...] = (
    "identity",
    "rot90",
    "rot180",
    "rot270",
    "mirror-vertical",
    "mirror-antidiagonal",
    "mirror-horizontal",
    "mirror-diagonal",
)
"""The D4 elements by index g = 4 m + k: k quarter turns counter-clockwise after m mirrors about the vertical line."""

SPLITS: tuple[str, ...] = ("train", "heldout", "all")

_QUARTER = np.array([[0, -1], [1, 0]], dtype=np.int64)
_MIRROR = np.array([[-1, 0], [0, 1]], dtype=np.int64)


# ---------------------------------------------------------------------------------------------------- the group
def orientation_matrix(orientation: int) -> np.ndarray:
    """``(2, 2)`` integer matrix M = R^k S^m of D4 element ``orientation`` = 4 m + k (module docstring)."""
    _check_orientation(orientation)
    m, k = divmod(int(orientation), 4)
    return np.linalg.matrix_power(_QUARTER, k) @ np.linalg.matrix_power(_MIRROR, m)


def compose(first: int, then: int) -> int:
    """The D4 index of applying ``first`` and then ``then`` (M_then M_first)."""
    product = orientation_matrix(then) @ orientation_matrix(first)
    for g in range(8):
        if np.array_equal(orientation_matrix(g), product):
            return g
    raise AssertionError("D4 is closed")  # pragma: no cover


def _check_orientation(orientation: object) -> None:
    if not isinstance(orientation, (int, np.integer)) or isinstance(orientation, bool) or not 0 <= orientation < 8:
        raise ValueError(f"orientation={orientation!r}: must be an integer in [0, 7] (one of {ORIENTATIONS})")


class _Map:
    """The affine map p -> c + M (p - c) with M in D4 (exact: M's entries are 0 and +-1)."""

    def __init__(self, orientation: int, centre: Vec2) -> None:
        self.orientation = int(orientation)
        self.m, self.k = divmod(self.orientation, 4)
        self.M = orientation_matrix(orientation)
        self.det = -1 if self.m else 1
        self.cx, self.cy = float(centre[0]), float(centre[1])

    def vector(self, v: Vec2) -> Vec2:
        (a, b), (c, d) = self.M.tolist()
        return (float(a * v[0] + b * v[1]), float(c * v[0] + d * v[1]))

    def point(self, p: Vec2) -> Vec2:
        dx, dy = self.vector((p[0] - self.cx, p[1] - self.cy))
        return (self.cx + dx, self.cy + dy)

    def angle_deg(self, a: float) -> float:
        """Direction a [deg] counter-clockwise from +x, mapped by M and wrapped to [-180, 180)."""
        out = 90.0 * self.k + ((180.0 - a) if self.m else a)
        return (out + 180.0) % 360.0 - 180.0

    def box(self, box: Box) -> Box:
        xs, ys = zip(self.point((box.x_min_m, box.y_min_m)), self.point((box.x_max_m, box.y_max_m)), strict=True)
        return Box(min(xs), max(xs), min(ys), max(ys))


# ------------------------------------------------------------------------------------------------ the transforms
def transform(cfg: ScenarioConfig, orientation: int, centre: Vec2 | None = None) -> ScenarioConfig:
    """``cfg`` moved by D4 element ``orientation`` about ``centre`` (default: the surveillance area's centre).

    Every coordinate and direction moves (module docstring); the result is validated as any ``ScenarioConfig``.
    Raises ``ValueError`` for a mirror of a scenario whose array beams are not symmetric about boresight or whose
    tracker has a coordinated-turn model without a mirror partner.
    """
    _check_orientation(orientation)
    if centre is None:
        a = cfg.surveillance_area
        centre = ((a.x_min_m + a.x_max_m) / 2.0, (a.y_min_m + a.y_max_m) / 2.0)
    if int(orientation) == 0:
        return cfg
    f = _Map(int(orientation), centre)
    if f.det < 0:
        _check_mirror_symmetric_beams(cfg, ORIENTATIONS[int(orientation)])
    return dataclasses.replace(
        cfg,
        world=f.box(cfg.world),
        surveillance_area=f.box(cfg.surveillance_area),
        transmitters=tuple(_transmitter(t, f) for t in cfg.transmitters),
        receivers=tuple(_receiver(r, f) for r in cfg.receivers),
        targets=tuple(dataclasses.replace(t, trajectory=_trajectory(t.trajectory, f)) for t in cfg.targets),
        walls=tuple(WallConfig(f.point(w.start_m), f.point(w.end_m), w.material) for w in cfg.walls),
        line_scatterers=tuple(
            LineScattererConfig(f.point(s.start_m), f.point(s.end_m), s.reflectivity) for s in cfg.line_scatterers
        ),
        clutter_points_m=tuple(f.point(p) for p in cfg.clutter_points_m),
        tracker=_mirror_tracker(cfg.tracker) if f.det < 0 else cfg.tracker,
    )


def mirror(cfg: ScenarioConfig, axis: str = "vertical", centre: Vec2 | None = None) -> ScenarioConfig:
    """``cfg`` mirrored about the vertical (x -> 2 cx - x) or horizontal (y -> 2 cy - y) line through ``centre``."""
    if axis not in ("vertical", "horizontal"):
        raise ValueError(f"axis={axis!r}: must be 'vertical' or 'horizontal'")
    return transform(cfg, ORIENTATIONS.index(f"mirror-{axis}"), centre)


def rotate(cfg: ScenarioConfig, quarter_turns: int, centre: Vec2 | None = None) -> ScenarioConfig:
    """``cfg`` rotated by ``quarter_turns`` x 90 deg counter-clockwise about ``centre`` (any integer; mod 4)."""
    if not isinstance(quarter_turns, (int, np.integer)) or isinstance(quarter_turns, bool):
        raise ValueError(f"quarter_turns={quarter_turns!r}: must be an integer (multiples of 90 deg)")
    return transform(cfg, int(quarter_turns) % 4, centre)


def _transmitter(t: TransmitterConfig, f: _Map) -> TransmitterConfig:
    return dataclasses.replace(t, position_m=f.point(t.position_m))


def _receiver(r: ReceiverConfig, f: _Map) -> ReceiverConfig:
    array = r.array
    if array is not None:
        array = dataclasses.replace(array, boresight_deg=f.angle_deg(array.boresight_deg))
    return dataclasses.replace(r, position_m=f.point(r.position_m), array=array)


def _trajectory(traj: object, f: _Map) -> object:
    if isinstance(traj, SegmentedTrajectoryConfig):
        segments = tuple(
            dataclasses.replace(s, turn_rate_rps=s.turn_rate_rps * f.det) if s.kind == "ct" else s
            for s in traj.segments
        )
        return SegmentedTrajectoryConfig(f.point(traj.start_position_m), f.vector(traj.start_velocity_mps), segments)
    if isinstance(traj, MotionModelTrajectoryConfig):
        return dataclasses.replace(
            traj,
            start_position_m=f.point(traj.start_position_m),
            start_velocity_mps=f.vector(traj.start_velocity_mps),
            turn_rate_rps=traj.turn_rate_rps * f.det,
        )
    if isinstance(traj, RoomWalkTrajectoryConfig):
        return dataclasses.replace(traj, start_region=f.box(traj.start_region))
    raise TypeError(f"trajectory {type(traj).__name__}: no transform defined")


def _check_mirror_symmetric_beams(cfg: ScenarioConfig, name: str) -> None:
    """Raise unless every array's beam set {u_m} is symmetric about boresight at every carrier (module docstring)."""
    carriers = {getattr(w, "carrier_hz", None) or w.center_freq_hz for w in cfg.waveforms}
    for r in cfg.receivers:
        array: UniformLinearArrayConfig | None = r.array
        if array is None:
            continue
        for carrier in sorted(carriers):
            u = beam_sines(cfg.sensing.array_beams, array.n_elements, array.spacing_m, SPEED_OF_LIGHT_MPS / carrier)
            if u is not None and not np.allclose(np.sort(u), np.sort(-u), rtol=0.0, atol=1e-12):
                raise ValueError(
                    f"transform {name!r} of {cfg.name!r}: receiver {r.name!r}'s {cfg.sensing.array_beams!r} beams at "
                    f"u = {np.round(u, 4).tolist()} are not symmetric about boresight, so its mirror image would see "
                    f"the mirrored scene through other beams (the config has no element-order field to reverse); "
                    f"allowed: array_beams 'boresight' or 'steered', or an odd n_elements"
                )


def _mirror_tracker(tracker: TrackerConfig) -> TrackerConfig:
    """The tracker of the mirrored scene: coordinated-turn models swap roles with their opposite-rate partners."""
    models = tracker.models
    names = [m.name for m in models]
    partner = []
    for m in models:
        if m.kind != "ct":
            partner.append(names.index(m.name))
            continue
        match = [
            j
            for j, o in enumerate(models)
            if o.kind == "ct"
            and o.turn_rate_rps == -m.turn_rate_rps
            and o.accel_noise_std_mps2 == m.accel_noise_std_mps2
        ]
        if not match:
            raise ValueError(
                f"tracker.models: {m.name!r} (ct, turn_rate_rps={m.turn_rate_rps}) has no mirror partner; a mirrored "
                f"scene needs a ct model with turn_rate_rps={-m.turn_rate_rps} and the same accel_noise_std_mps2"
            )
        partner.append(match[0])
    swap = {names[i]: names[p] for i, p in enumerate(partner)}
    r = len(models)
    transition = [[0.0] * r for _ in range(r)]
    for i in range(r):
        for j in range(r):
            transition[partner[i]][partner[j]] = tracker.transition[i][j]
    return dataclasses.replace(
        tracker,
        transition=tuple(tuple(row) for row in transition),
        default_models=tuple(swap[n] for n in tracker.default_models),
        model_set_windows=tuple(
            dataclasses.replace(w, models=tuple(swap[n] for n in w.models)) for w in tracker.model_set_windows
        ),
    )


# ------------------------------------------------------------------------------------------------ seed-003 paths
RIGHT_TURN_FIRST_LEG_S = 3.5
"""The right turn's first leg [s]: 1.5 s shorter than the left turn's, so it starts 15 m earlier (x = 2022.5) and
ends heading south at x = 2054.3, the southbound lane 15 m west of the seed's northbound one (x = 2069.3), 9 m from the
west sidewalk (x = 2045) and 14 m from the south-west block's corner (2040, 1478)."""
STRAIGHT_END_X = 2195.0
"""The straight path ends 5 m inside the surveillance area's east edge (x = 2200), where the vehicle leaves it."""


def seed003_right_path(first_leg_s: float = RIGHT_TURN_FIRST_LEG_S) -> SegmentedTrajectoryConfig:
    """Seed 003's path with a right turn: the same speeds, deceleration and turn rate, clockwise.

    East at 10 m/s from (1950, 1500), decelerate 1 m/s^2 for 5 s, turn right at pi/20 rad/s for 10 s (radius
    5 / (pi / 20) = 31.8 m, lateral acceleration 0.79 m/s^2), accelerate 1 m/s^2 for 5 s, then south at 10 m/s until
    y = 1500 - (1667.8 - 1500) = 1332.2, the left turn's end mirrored about the vehicle's lane.
    """
    speed_after_turn = 10.0 - 5.0
    radius = speed_after_turn / TURN_RATE
    y_after_accel = START[1] - radius - (speed_after_turn * 5.0 + 0.5 * 1.0 * 5.0**2)
    end_y = START[1] - (END[1] - START[1])
    turn = MotionSegmentConfig("ct", 10.0, turn_rate_rps=-TURN_RATE)
    return seed003_speed_profile(first_leg_s, turn, (y_after_accel - end_y) / 10.0)


def seed003_straight_path(end_x: float = STRAIGHT_END_X) -> SegmentedTrajectoryConfig:
    """Seed 003's path straight across: the same speed profile, with the turn's 10 s at 5 m/s held straight.

    East at 10 m/s from (1950, 1500) for 5 s, decelerate 1 m/s^2 for 5 s, cross the intersection at 5 m/s for 10 s,
    accelerate 1 m/s^2 for 5 s (x = 2125), then 10 m/s until ``end_x``: the three paths differ only in heading.
    """
    x_after_accel = START[0] + 50.0 + 37.5 + 50.0 + 37.5
    return seed003_speed_profile(5.0, MotionSegmentConfig("cv", 10.0), (end_x - x_after_accel) / 10.0)


# ------------------------------------------------------------------------------------------------------- families
@dataclass(frozen=True, slots=True)
class SceneVariant:
    """One drawn variant: D4 ``orientation`` index, ``path`` index into the family's paths, the births [s]."""

    orientation: int
    path: int
    birth_times_s: tuple[float, ...]

    @property
    def n_targets(self) -> int:
        """Number of vehicles."""
        return len(self.birth_times_s)

    @property
    def cell(self) -> tuple[int, int]:
        """The (orientation, path) cell that the splits partition."""
        return (self.orientation, self.path)


@dataclass(frozen=True, slots=True)
class SceneFamily:
    """Seeded variants of registered scenario ``scenario`` (module docstring).

    Attributes:
        name: the family's name; scenario: the registered base scenario; centre_m: the D4 centre [m];
        paths: ``((name, path), ...)`` the paths through the scene, in the base frame;
        heldout: the (orientation, path index) cells training never draws;
        heldout_kinds: ``((kind, cells), ...)`` named subsets of ``heldout``, each also a split ``heldout-<kind>``;
        max_targets: vehicles per variant at most (at least 1); birth_spacing_s: the births' spacing [s];
        birth_jitter_scans: each birth is delayed by a uniform whole number of scans in [0, this];
        target_template: index of the base target whose RCS model every vehicle takes;
        clearance_m: the least distance from a path to an opaque wall (``check_paths``).
    """

    name: str
    scenario: str
    centre_m: Vec2
    paths: tuple[tuple[str, SegmentedTrajectoryConfig], ...]
    heldout: tuple[tuple[int, int], ...]
    heldout_kinds: tuple[tuple[str, tuple[tuple[int, int], ...]], ...] = ()
    max_targets: int = 3
    birth_spacing_s: float = 10.0
    birth_jitter_scans: int = 8
    target_template: int = 0
    clearance_m: float = 5.0

    def __post_init__(self) -> None:
        base = scenarios.get(self.scenario)
        if not self.paths or len({n for n, _ in self.paths}) != len(self.paths):
            raise ValueError(f"SceneFamily.paths = {[n for n, _ in self.paths]}: must be non-empty, uniquely named")
        cells = {(g, p) for g in range(8) for p in range(len(self.paths))}
        bad = [c for c in self.heldout if c not in cells]
        if bad or len(set(self.heldout)) != len(self.heldout) or len(self.heldout) >= len(cells):
            raise ValueError(
                f"SceneFamily.heldout = {self.heldout}: must be distinct (orientation in 0..7, path in "
                f"0..{len(self.paths) - 1}) cells, leaving at least one to train on"
            )
        for kind, subset in self.heldout_kinds:
            if not isinstance(kind, str) or not kind or not set(subset) <= set(self.heldout) or not subset:
                raise ValueError(
                    f"SceneFamily.heldout_kinds: {kind!r} = {subset}: must be a named, non-empty subset of heldout"
                )
        if not isinstance(self.max_targets, int) or self.max_targets < 1:
            raise ValueError(f"SceneFamily.max_targets = {self.max_targets!r}: must be an integer >= 1")
        if not isinstance(self.birth_jitter_scans, int) or self.birth_jitter_scans < 0:
            raise ValueError(f"SceneFamily.birth_jitter_scans = {self.birth_jitter_scans!r}: must be an integer >= 0")
        last = (self.max_targets - 1) * self.birth_spacing_s + self.birth_jitter_scans * base.sensing.scan_period_s
        if not self.birth_spacing_s >= 0 or last >= base.duration_s:
            raise ValueError(
                f"SceneFamily.birth_spacing_s = {self.birth_spacing_s}: the last birth ({last} s) must come before "
                f"the episode's end ({base.duration_s} s)"
            )
        if not 0 <= self.target_template < len(base.targets):
            raise ValueError(f"SceneFamily.target_template = {self.target_template}: no such target in {self.scenario}")

    # -------------------------------------------------------------------------------------------------- splits
    @property
    def splits(self) -> tuple[str, ...]:
        """``train``, ``heldout``, ``all`` and one ``heldout-<kind>`` per named held-out kind."""
        return SPLITS + tuple(f"heldout-{kind}" for kind, _ in self.heldout_kinds)

    def cells(self, split: str = "all") -> tuple[tuple[int, int], ...]:
        """The (orientation, path) cells of ``split`` (one of :attr:`splits`), sorted."""
        if split not in self.splits:
            raise ValueError(f"split={split!r}: must be one of {self.splits}")
        every = [(g, p) for g in range(8) for p in range(len(self.paths))]
        held = set(self.heldout)
        if split == "all":
            return tuple(every)
        if split.startswith("heldout-"):
            held = set(dict(self.heldout_kinds)[split.removeprefix("heldout-")])
            return tuple(c for c in every if c in held)
        return tuple(c for c in every if (c in held) == (split == "heldout"))

    def split_of(self, variant: SceneVariant) -> str:
        """``heldout`` or ``train``: the split whose cells hold ``variant``."""
        return "heldout" if variant.cell in set(self.heldout) else "train"

    # --------------------------------------------------------------------------------------------------- draws
    def draw(
        self, seed: int | np.random.SeedSequence | np.random.Generator, split: str = "all"
    ) -> tuple[SceneVariant, ScenarioConfig]:
        """A variant of ``split`` and its scenario, from a generator seeded by ``seed`` (module docstring)."""
        rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        cells = self.cells(split)
        orientation, path = cells[int(rng.integers(len(cells)))]
        n = int(rng.integers(1, self.max_targets + 1))
        delays = rng.integers(0, self.birth_jitter_scans + 1, size=n)
        dt = _base(self.scenario).sensing.scan_period_s
        births = tuple(float(i * self.birth_spacing_s + d * dt) for i, d in enumerate(delays.tolist()))
        variant = SceneVariant(int(orientation), int(path), births)
        return variant, self.build(variant)

    def build(self, variant: SceneVariant) -> ScenarioConfig:
        """The scenario of ``variant``: the base scene, its vehicles on the variant's path, moved by its orientation."""
        return _build(self, variant)

    def check_paths(self, cfg: ScenarioConfig) -> float:
        """The least clearance [m] of ``cfg``'s segmented paths to opaque walls; raises where a path leaves the streets.

        Sampled every scan period over each path's whole life: every position inside the surveillance area, at
        least ``clearance_m`` from every opaque wall, no step crossing one, and the start outside every building.
        """
        return check_paths(cfg, self.clearance_m)


def _base(name: str) -> ScenarioConfig:
    return _base_cached(name)


@lru_cache(maxsize=16)
def _base_cached(name: str) -> ScenarioConfig:
    return scenarios.get(name)


@lru_cache(maxsize=256)
def _build(family: SceneFamily, variant: SceneVariant) -> ScenarioConfig:
    if not 0 <= variant.path < len(family.paths) or not 1 <= variant.n_targets <= family.max_targets:
        raise ValueError(f"variant {variant}: path must be in [0, {len(family.paths) - 1}] and 1..{family.max_targets} "
                         f"birth times")  # fmt: skip
    _check_orientation(variant.orientation)
    base = _base(family.scenario)
    template = base.targets[family.target_template]
    path_name, path = family.paths[variant.path]
    targets = tuple(
        TargetConfig(f"vehicle-{i + 1}", path, birth, template.rcs_mean_m2, template.swerling)
        for i, birth in enumerate(variant.birth_times_s)
    )
    orientation = ORIENTATIONS[variant.orientation]
    cfg = dataclasses.replace(
        base,
        name=f"{base.name}/{orientation}/{path_name}/{variant.n_targets}",
        description=f"{base.description} Family {family.name!r}: {orientation}, {path_name} path, "
        f"{variant.n_targets} vehicle(s) born at {list(variant.birth_times_s)} s.",
        targets=targets,
    )
    return transform(cfg, variant.orientation, family.centre_m)


def check_paths(cfg: ScenarioConfig, clearance_m: float = 5.0) -> float:
    """The least clearance [m] of ``cfg``'s segmented target paths to its opaque walls (``SceneFamily.check_paths``).

    Raises ``ValueError`` naming the target and the time where a sampled position leaves the surveillance area, comes
    closer than ``clearance_m`` to an opaque wall, a step crosses one, or the start lies inside a building (ray
    parity against the opaque faces).
    """
    opaque = [w for w in cfg.walls if math.isinf(w.material.loss_db)]
    a = np.array([w.start_m for w in opaque], dtype=float).reshape(-1, 2)
    b = np.array([w.end_m for w in opaque], dtype=float).reshape(-1, 2)
    area = cfg.surveillance_area
    least = math.inf
    for target in cfg.targets:
        traj = target.trajectory
        if not isinstance(traj, SegmentedTrajectoryConfig):
            continue
        local = np.append(np.arange(0.0, traj.duration_s, cfg.sensing.scan_period_s), traj.duration_s)
        states, valid = segmented_states(traj, local)
        pos: FloatArray = states[valid][:, [0, 2]]
        inside = (
            (pos[:, 0] >= area.x_min_m) & (pos[:, 0] <= area.x_max_m)
            & (pos[:, 1] >= area.y_min_m) & (pos[:, 1] <= area.y_max_m)
        )  # fmt: skip
        if not inside.all():
            i = int(np.flatnonzero(~inside)[0])
            raise ValueError(f"{cfg.name}: target {target.name!r} at {pos[i].round(2).tolist()} leaves the "
                             f"surveillance area {area}")  # fmt: skip
        if not len(opaque):
            continue
        dist = point_segment_distance(pos, a, b).min(axis=1)
        if dist.min() < clearance_m:
            i = int(np.argmin(dist))
            raise ValueError(f"{cfg.name}: target {target.name!r} at {pos[i].round(2).tolist()} is {dist[i]:.2f} m "
                             f"from a building, closer than clearance_m = {clearance_m}")  # fmt: skip
        if segments_cross(pos[:-1], pos[1:], a, b).any():
            raise ValueError(f"{cfg.name}: target {target.name!r}'s path crosses a building wall")
        far = pos[:1] + np.array([[1e5, 1e5 * 0.013671875]])  # a ray through no corner
        if int(segments_cross(pos[:1], far, a, b).sum()) % 2:
            raise ValueError(f"{cfg.name}: target {target.name!r} starts inside a building at {pos[0].tolist()}")
        least = min(least, float(dist.min()))
    return least


# ------------------------------------------------------------------------------------------------------ registry
INTERSECTION_CENTRE: Vec2 = (2067.5, 1512.0)
"""Where seed 003's streets cross: the east-west street's median (the vegetation at y = 1512) and the middle of the
north-south street between its west kerb (x = 2030 north, 2040 south: 2035) and its east kerb (x = 2100)."""

URBAN_PATHS = (("left", seed003_path()), ("straight", seed003_straight_path()), ("right", seed003_right_path()))
URBAN_HELDOUT_KINDS: tuple[tuple[str, tuple[tuple[int, int], ...]], ...] = (
    ("rotated", ((1, 0), (1, 1), (1, 2))),  # rot90, every path
    ("mirrored", ((4, 0), (4, 1), (4, 2))),  # mirror-vertical, every path (its left turn: the mirror image)
    ("turn", ((0, 2),)),  # the other turn: the seed's orientation, turning right
)
URBAN_HELDOUT: tuple[tuple[int, int], ...] = tuple(c for _, cells in URBAN_HELDOUT_KINDS for c in cells)

_FAMILIES: dict[str, Callable[[], SceneFamily]] = {}


def register_family(name: str) -> Callable[[Callable[[], SceneFamily]], Callable[[], SceneFamily]]:
    """Decorator registering a family factory under ``name`` (duplicates raise ``KeyError``)."""

    def deco(factory: Callable[[], SceneFamily]) -> Callable[[], SceneFamily]:
        if name in _FAMILIES:
            raise KeyError(f"family {name!r} already registered")
        _FAMILIES[name] = factory
        return factory

    return deco


def family_names() -> tuple[str, ...]:
    """Registered family names, sorted."""
    return tuple(sorted(_FAMILIES))


@lru_cache(maxsize=16)
def get_family(name: str) -> SceneFamily:
    """The registered family ``name`` (``KeyError`` naming the known ones)."""
    if name not in _FAMILIES:
        raise KeyError(f"unknown scene family {name!r} (known: {', '.join(family_names())})")
    return _FAMILIES[name]()


@register_family("urban-intersection")
def urban_intersection_family() -> SceneFamily:
    """Seed 003's intersection: D4 x {left, straight, right} x 1-3 vehicles 10 s apart (+0..2 s); 7 cells held out."""
    return SceneFamily(
        "urban-intersection", "urban-intersection", INTERSECTION_CENTRE, URBAN_PATHS, URBAN_HELDOUT, URBAN_HELDOUT_KINDS
    )


@register_family("urban-intersection-wideband")
def urban_intersection_wideband_family() -> SceneFamily:
    """The same family on the wideband library (``urban-intersection-wideband``)."""
    return SceneFamily(
        "urban-intersection-wideband",
        "urban-intersection-wideband",
        INTERSECTION_CENTRE,
        URBAN_PATHS,
        URBAN_HELDOUT,
        URBAN_HELDOUT_KINDS,
    )


__all__ = [
    "INTERSECTION_CENTRE",
    "ORIENTATIONS",
    "SPLITS",
    "SceneFamily",
    "SceneVariant",
    "check_paths",
    "compose",
    "family_names",
    "get_family",
    "mirror",
    "orientation_matrix",
    "register_family",
    "rotate",
    "seed003_right_path",
    "seed003_straight_path",
    "transform",
]
