r"""Spatial clutter map of position detections (Musicki & Evans, IEEE TAES 40(2), 2004).

"Clutter map information for data association and track initialization": the clutter measurement density is
estimated per cell of the surveillance area from the detections of past scans with exponential forgetting, and each
detection's likelihood ratio against the target's uses the map's density at its position. Here the map holds, per
cell, the exponentially averaged count of position detections per scan,

    m_k = (1 - a) m_{k-1} + a n_k,    a = 1 / N,

``n_k`` the scan's detections in the cell and N the map's memory in scans (time constant); the density of a cell is
``m / cell_area``, floored at the prior density (the map never says there is less clutter than the prior: a cell
the map has seen nothing in keeps the configured ``false_position_density_per_m2``). A detection reads the map
before the map is updated with its own scan, so a detection never raises its own clutter density.

Known answers: from m_0 = 0, one detection per scan in one cell gives m_k = a sum_{j<k} (1 - a)^j = 1 - (1 - a)^k
(the geometric sum), density (1 - (1 - a)^k) / A, A the cell's area; it tends to 1 / A. After the detections stop,
m decays by (1 - a) per scan (halves in N ln 2 scans).

The constants (``SignalConfig.clutter_map_cell_m`` = 0.25 m, ``clutter_map_memory_scans`` = 50), chosen for seed
001's through-wall scenario from its physics before any run (scans of T = 0.074 s, persons walking at v = 0.8 m/s,
a person's couple in q ~ 0.77 of the scans, ``results/seed001``):

* a static residue of the background subtraction (a room path the persons perturb: both receivers' ToA at 2.57 m,
  localized on the array's axis at about (0, 1.25) m) sits on the chain's sample grid and flickers by one sample
  (6.7 cm of bistatic range at 4.5 GHz), so its positions fall in one or two cells of s = 0.25 m (about two range
  stds of 0.13 m); its steady density is p / s^2 = 16 p per m^2 (p the fraction of scans it lands in the cell),
  320 p times the prior 0.05 per m^2. Smaller cells would split it, larger ones would raise a passing person's
  share (which falls as 1 / s while the residue's falls as 1 / s^2);
* a walking person crosses a cell in s / (v T) = 4.2 scans and leaves n = q s / (v T) ~ 3.3 detections in it (at
  most ``passing_density_bound``: 7 scans on the diagonal, 2.24 per m^2 at N = 50); at its own next detection half
  of them are behind it, so the map reads ~n / (2 N s^2) = 26 / N per m^2 there, decaying afterwards. A longer
  memory lowers that as 1 / N; while the map is young (k << N scans) the residue's cell holds k p / (N s^2), so the
  ratio of the two, 2 k p / n, does not depend on N. N = 50 scans (3.7 s) is the upper end of what a 117-scan
  episode can fill.

What it does on seed 001 (``scripts/seed001_through_wall.py``, its clutter-map chains): the map suppresses the
residue's ghost tracks but costs the persons their tracks, because the map cannot estimate a density as low as the
prior's: one detection in a cell reads 1 / (N s^2) = 0.32 per m^2, 6.4 times the prior, and the persons' tracks
live on the prior (couples localize to ~0.05 m in range but ~0.85 m across, so a person track's Pd g at its
detections is ~0.6 per m^2 at the median, ~0.09 at the lower quartile; against 0.05 per m^2 of clutter their
likelihood ratio is ~12, against one earlier detection's 0.32 it is ~2, and below one for a quarter of them).
Estimating a density of lambda per m^2 to within a factor of two needs N lambda s^2 >~ 1 expected false detections
per cell over the map's memory: N ~ 320 scans at s = 0.25 m, three episodes. The residue itself comes in bursts of
4-6 scans, two or three per episode, and its ghost is confirmed within one burst (the first in 2 of the 5 runs with
such a ghost among seeds 40-79), while a person turning at the end of its walk (a half circle of 0.25 m radius in
1 s) is as still for as long.

Musicki's refinement counts only the detections no track uses. Three counts (``SignalConfig.clutter_map_count``):
every position detection (``"all"``); the sensor's own stand-in, only the couples that have not moved since the
previous scan (``"still"``: both ranges within step 6's stillness bound of a previous couple,
``SignalSensor._still_couples``), which spares walking persons but not a person at its turn; and the refinement
itself (``"unassociated"``), each detection counted with its a-posteriori clutter probability from the tracker's
association of the scan. The weighting: the map estimates E[n_k], the expected clutter detections per scan in the
cell, and n_k = sum_i 1{detection i is clutter} is not observed; its conditional mean given the scan's data is
sum_i P(i is clutter | Z), and since a detection has one origin the events "track t exists and made i" exclude each
other, so

    w_i = P(i is clutter | Z) = 1 - sum_t psi_t+ sum_r mu_r^t+ beta_i^{t,r},

psi_t+ the track's posterior existence, mu_r^t+ its posterior model probabilities, beta_i^{t,r} the LMIPDA association
probability conditioned on existence and model (``uwb_env.tracking.lmipda``; ``Tracker.association_probabilities``,
the tracks as they stand before that pair's update, every track, tentative or confirmed), and the update is
m_k = (1 - a) m_{k-1} + a sum_{i in cell} w_i (``map_update`` with ``weights``): Musicki & Evans' map updated with the
measurements weighted by their clutter probability (the same weighting as Park, Chong, Kim et al., "Adaptive
estimation of spatial clutter measurement density using clutter measurement probability", Sensors 20(1) 114, 2019).
LMIPDA computes each track's claims with the other tracks as modulated clutter, so the sum over tracks may exceed 1
where tracks overlap (1.05 in a test): w is clipped to [0, 1] (``Tracker.clutter_probabilities``). A detection with
beta 0.7 adds 0.3 / N to its cell; one a track fully uses adds nothing. The tracker's association needs the map
update after the tracker's step: the sensor reads the map in ``sense`` (before its scan updates it, as in the other
counts), leaves the scan's positions in ``SignalEpisode.map_pending``, and ``Simulator.step`` hands it the tracker's
``clutter_probabilities`` through ``SignalSensor.after_tracking`` (the one way back from tracker to sensor; positions
the tracker did not get count 1).

What it does on seed 001 (``scripts/seed001_through_wall.py``, the chain "association + clutter map of unassociated
detections"; runs without a ghost track / both persons tracked / scans a person is held): runs 40-79 88 % / 50 % /
60.6 %, runs 0-19 95 % / 45 % / 57.7 %, against 82 % / 95 % / 81.8 % and 95 % / 95 % / 81.8 % without the map. The
residue's ghost tracks are gone (fed by false-alarm couples: 0.00 per run, 0.12 without the map on runs 40-79), but
the weights are the tracker's belief, and where the tracker has not found a person, or has lost it, its detections
count like clutter: a tentative track starts at existence ``initial_existence`` = 0.005, so a person's first
detections count ~1, raise the map on its path (one detection reads 1 / (N s^2) = 0.32 per m^2, 6.4 x the prior) and
slow its confirmation further. On runs 40-79 the persons' couples no confirmed track held carry weight 0.69 on
average (2745 couples), those held 0.15 (4393; off-gate ones count), the residue's 0.98 (270) and the other false
alarms' 0.93 (577): 76 % of what the map counts is the persons' own (seed 47: without the map the persons are first
held at scans 14 and 42, with it at 42 and 107, one person's couples reading up to 0.77 per m^2 in between). Letting
tentative tracks claim as if they existed (psi -> 1, not the posterior; a diagnostic, not an option here) gives 88 %
/ 85 % on runs 40-79. A longer memory lowers what one detection reads (N = 200: 0.08 per m^2) but learns the residue
more slowly: runs 0-19 / 40-79 / 80-119 give 95 / 90 %, 95 / 95 %, 88 / 92 % at N = 200 and 100 / 95 %, 85 / 92 %,
82 / 95 % at N = 320 (``--set sensing.signal.clutter_map_memory_scans=...``; 320 is the estimate above, 200 was
tried after seeing runs 40-79, so runs 80-119 are the held-out test, and there neither holds the check; without the
map 80 / 95 %). What the map cannot remove is a person's second or lagging track (fed by the persons' couples: 0.10
per run at N = 200 on runs 80-119), which is not clutter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from uwb_env.typing import FloatArray, IntArray


@dataclass(frozen=True, slots=True)
class ClutterMapGrid:
    """A regular grid of square cells of side ``cell_m`` over ``[x_min, x_max] x [y_min, y_max]``."""

    x_min: float
    y_min: float
    cell_m: float
    nx: int
    ny: int

    @classmethod
    def over(cls, area: tuple[float, float, float, float] | FloatArray, cell_m: float) -> ClutterMapGrid:
        """The grid over ``area`` = (x_min, x_max, y_min, y_max), cells of ``cell_m`` (the last may stick out)."""
        if not (cell_m > 0.0 and math.isfinite(cell_m)):
            raise ValueError(f"clutter map: cell_m = {cell_m!r} must be a positive finite size [m]")
        x0, x1, y0, y1 = (float(v) for v in area)
        if not (x1 > x0 and y1 > y0):
            raise ValueError(f"clutter map: area {tuple(area)} must have x_max > x_min and y_max > y_min")
        nx = max(1, math.ceil((x1 - x0) / cell_m - 1e-9))
        ny = max(1, math.ceil((y1 - y0) / cell_m - 1e-9))
        return cls(x0, y0, float(cell_m), nx, ny)

    @property
    def n_cells(self) -> int:
        """Number of cells."""
        return self.nx * self.ny

    @property
    def cell_area_m2(self) -> float:
        """A cell's area [m^2]."""
        return self.cell_m * self.cell_m


def cell_index(grid: ClutterMapGrid, z: FloatArray) -> IntArray:
    """Flat cell index ``(n,)`` of positions ``z`` ``(n, 2)``; -1 outside the grid (or not finite)."""
    z = np.asarray(z, dtype=float).reshape(-1, 2)
    with np.errstate(invalid="ignore"):
        ix = np.floor((z[:, 0] - grid.x_min) / grid.cell_m)
        iy = np.floor((z[:, 1] - grid.y_min) / grid.cell_m)
    ok = np.isfinite(ix) & np.isfinite(iy) & (ix >= 0) & (ix < grid.nx) & (iy >= 0) & (iy < grid.ny)
    return np.where(ok, np.where(ok, iy, 0).astype(np.int64) * grid.nx + np.where(ok, ix, 0).astype(np.int64), -1)


def map_update(
    counts: FloatArray, cells: IntArray, memory_scans: float, weights: FloatArray | None = None
) -> FloatArray:
    """One scan of the map: ``(1 - a) counts + a n``, returned (``counts`` is not modified).

    ``a = 1 / memory_scans``, ``n`` the scan's detections per cell (``cells``: their flat indices; -1 ignored), each
    counted with its ``weights`` (default 1; Musicki's refinement: 1 - the probability that a target made it).
    """
    a = 1.0 / memory_scans
    cells = np.asarray(cells, dtype=np.int64)
    ok = cells >= 0
    w = None if weights is None else np.asarray(weights, dtype=float)[ok]
    n = np.bincount(cells[ok], weights=w, minlength=counts.size).astype(float)
    return (1.0 - a) * counts + a * n


def map_density(counts: FloatArray, cells: IntArray, cell_area_m2: float, floor_per_m2: float) -> FloatArray:
    """Clutter density [1/m^2] at detections in ``cells``: the cell's averaged count / its area, at least the floor.

    A detection outside the grid (cell -1) gets ``floor_per_m2``.
    """
    cells = np.asarray(cells, dtype=np.int64)
    own = np.where(cells >= 0, counts[np.maximum(cells, 0)] / cell_area_m2, 0.0)
    return np.maximum(own, floor_per_m2)


def steady_density(k: int, memory_scans: float, cell_area_m2: float) -> float:
    """The known answer: the density after ``k`` scans of one detection per scan in one cell, from an empty map.

    ``(1 - (1 - 1/N)^k) / A``: the geometric sum a sum_{j<k} (1 - a)^j over the cell's area.
    """
    return (1.0 - (1.0 - 1.0 / memory_scans) ** k) / cell_area_m2


def passing_density_bound(
    detections_per_scan: float, speed_mps: float, scan_s: float, cell_m: float, memory_scans: float
) -> float:
    """Upper bound [1/m^2] on what a target crossing a cell in a straight line adds to the cell's density.

    At most ``ceil(s sqrt(2) / (v T)) + 1`` scans in the cell (the diagonal at speed v, any entry point), at most
    ``min(1, q)`` detections per scan there, each of weight 1 / N, over the cell's area (forgetting ignored).
    """
    scans_in_cell = math.ceil(cell_m * math.sqrt(2.0) / (speed_mps * scan_s)) + 1
    return min(1.0, detections_per_scan) * scans_in_cell / memory_scans / (cell_m * cell_m)


@dataclass(slots=True)
class ClutterMap:
    """The map's state for one episode: ``density`` reads it at detections, ``update`` adds a scan, ``reset``."""

    grid: ClutterMapGrid
    memory_scans: float
    floor_per_m2: float
    counts: FloatArray = field(init=False)
    scans: int = field(init=False, default=0)

    def __post_init__(self) -> None:
        if not (self.memory_scans >= 1.0 and math.isfinite(self.memory_scans)):
            raise ValueError(f"clutter map: memory_scans = {self.memory_scans!r} must be a finite number >= 1")
        if not (self.floor_per_m2 >= 0.0 and math.isfinite(self.floor_per_m2)):
            raise ValueError(f"clutter map: floor_per_m2 = {self.floor_per_m2!r} must be finite and >= 0")
        self.reset()

    @classmethod
    def over(
        cls,
        area: tuple[float, float, float, float] | FloatArray,
        cell_m: float,
        memory_scans: float,
        floor_per_m2: float,
    ) -> ClutterMap:
        """An empty map over ``area`` = (x_min, x_max, y_min, y_max)."""
        return cls(ClutterMapGrid.over(area, cell_m), float(memory_scans), float(floor_per_m2))

    def reset(self) -> None:
        """An empty map (every cell at the floor): a new episode."""
        self.counts = np.zeros(self.grid.n_cells)
        self.scans = 0

    def density(self, z: FloatArray) -> FloatArray:
        """Clutter density [1/m^2] at positions ``z`` ``(n, 2)`` from the scans so far (not this one)."""
        return map_density(self.counts, cell_index(self.grid, z), self.grid.cell_area_m2, self.floor_per_m2)

    def update(self, z: FloatArray, weights: FloatArray | None = None) -> None:
        """Add one scan's position detections ``z`` ``(n, 2)``, each counted with its ``weights`` (default 1).

        A scan without detections still forgets.
        """
        self.counts = map_update(self.counts, cell_index(self.grid, z), self.memory_scans, weights)
        self.scans += 1

    def density_map(self) -> FloatArray:
        """``(ny, nx)`` density of every cell [1/m^2] (floored), for pictures."""
        return np.maximum(self.counts / self.grid.cell_area_m2, self.floor_per_m2).reshape(self.grid.ny, self.grid.nx)
