"""Simulator: one scan = plan -> truth -> sensing -> tracking (the one-step data flow); no gymnasium here.

``Simulator.reset(seed)`` draws the episode (named streams, truth first); ``Simulator.step(plan)`` senses the next
scan with the plan and updates the tracker, whose detection probabilities come from the sensor model at each
track's predicted position with the waveform the plan sends. A sensor whose ``needs_association`` is set (the signal
sensor's clutter map with ``clutter_map_count = "unassociated"``) gets the tracker's per-detection clutter
probabilities of the scan back after the tracker's step (``sensor.after_tracking``): the one way back, nothing else
flows from the tracker to the sensor. ``run_episode`` plays a plan policy through an
episode and returns the track accounting of ``uwb_env.metrics``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from uwb_env.config import ScenarioConfig, TrackerConfig
from uwb_env.metrics import TrackAccounting
from uwb_env.rng import RngStreams
from uwb_env.scene.truth import Truth, sample_truth
from uwb_env.sensing.protocol import Sensor, make_sensor
from uwb_env.sensing.records import Detections, ScanPlan
from uwb_env.tracking.protocol import MultiTargetTracker
from uwb_env.tracking.registry import make_tracker
from uwb_env.tracking.trackset import TrackSet
from uwb_env.typing import BoolArray, FloatArray


@dataclass(frozen=True, slots=True)
class ScanResult:
    """What one scan produced: its index and time, the detections per pair, the tracks after the update."""

    scan_index: int
    time_s: float
    detections: tuple[Detections, ...]
    tracks: TrackSet


class Simulator:
    """Owns the sensor, the tracker and the episode's streams (simulator tier)."""

    def __init__(
        self,
        cfg: ScenarioConfig,
        tracker: TrackerConfig | None = None,
        use_sensor_pd: bool = True,
        sensor: Sensor | None = None,
    ) -> None:
        """The simulator of scenario ``cfg``.

        ``sensor``: a sensor of ``cfg`` to share (it keeps no episode state: ``new_episode`` returns it), e.g.
        between the simulators of a batched vector env; None builds one.
        """
        self.cfg = cfg
        # the registry of (fidelity, waveform family) (sensing.protocol)
        self.sensor: Sensor = make_sensor(cfg) if sensor is None else sensor
        self.tracker_cfg = tracker or cfg.tracker
        # the tracker of TrackerConfig.kind (uwb_env.tracking.registry), read only through its seam
        self.tracker: MultiTargetTracker = make_tracker(
            self.tracker_cfg, self.sensor.layout, self._pd if use_sensor_pd else None
        )
        self._plan: ScanPlan | None = None
        self.k = 0
        # Musicki's clutter map: the tracker records its association for the sensor (after_tracking). Optional
        # capabilities of a sensor and a tracker, outside their protocols: looked up, not assumed.
        self._feedback = bool(getattr(self.sensor, "needs_association", False))
        self._clutter_probabilities: Callable[[], tuple[FloatArray, ...]] | None = None
        if self._feedback:
            record = getattr(self.tracker, "record_association", None)
            self._clutter_probabilities = getattr(self.tracker, "clutter_probabilities", None)
            if not callable(record) or not callable(self._clutter_probabilities):
                raise ValueError(
                    f"tracker.kind = {self.tracker_cfg.kind!r}: sensing.signal.clutter_map_count = 'unassociated' "
                    "needs a tracker with record_association / clutter_probabilities (allowed: 'imm-lmipda')"
                )
            record(True)

    def _pd(self, tx: int, rx: int, positions: FloatArray) -> FloatArray:
        """Pd of pair (tx, rx) at ``positions``; ``rx = -1`` is the network's fused position measurement."""
        tc = self.tracker_cfg
        plan = self._plan
        assert plan is not None  # set by step() before the tracker runs
        if rx >= 0:
            w = int(plan.waveform[tx])
            pd = self.sensor.detection_probability_at(tx, rx, positions, w, tc.assumed_rcs_m2, tc.assumed_swerling)
        else:
            per_pair = np.array(
                [
                    self.sensor.detection_probability_at(
                        t, r, positions, int(plan.waveform[t]), tc.assumed_rcs_m2, tc.assumed_swerling
                    )
                    for t, r in self.sensor.pairs.tolist()  # formed pairs: a handful
                    if plan.active_rx[r]
                ]
            )
            # a fused position needs that many receivers' ToAs: nu (seed 000's tuples) or 2 (seed 001's couples)
            pd = at_least(per_pair, getattr(self.sensor, "position_receivers", self.cfg.sensing.signal.nu))
        return np.minimum(pd, tc.max_detection_probability)

    def reset(self, seed: int | np.random.SeedSequence | None) -> None:
        """Start an episode: named streams, truth, the sensor's episode draws, an empty tracker on its stream."""
        self.rngs = RngStreams.from_seed(seed)
        self.truth: Truth = sample_truth(self.cfg, self.rngs.truth, self.sensor.layout)
        self.episode = self.sensor.new_episode(self.truth, self.rngs)
        self.tracker.reset(self.rngs.tracker)
        self.k = 0

    @property
    def done(self) -> bool:
        """Whether every scan of the episode has been played."""
        return self.k >= self.cfg.n_scans

    def step(self, plan: ScanPlan, ready_rx: BoolArray | None = None) -> ScanResult:
        """Sense the next scan with ``plan`` and update the tracker.

        ``ready_rx`` ``(R,)``: the receivers able to deliver detections (receiver warm-up,
        ``uwb_env.lookahead``); the plan's other listening receivers deliver nothing. None: every one.
        """
        if self.done:
            raise RuntimeError(f"episode over: all {self.cfg.n_scans} scans of {self.cfg.name!r} were played")
        self.k += 1
        t = self.k * self.cfg.sensing.scan_period_s
        delivering = plan.active_rx if ready_rx is None else plan.active_rx & ready_rx
        # Sense with the delivering receivers (the streams draw for every formed pair whatever the plan, so this
        # keeps common random numbers); with none, sense the listening plan and drop everything.
        sensed = ScanPlan(plan.waveform, delivering) if ready_rx is not None and delivering.any() else plan
        self._plan = sensed
        dets = self.sensor.sense(self.episode, self.k, sensed, t)
        if not delivering.any():  # every listening receiver is warming up: the tracker only predicts
            dets = ()
        tracks = self.tracker.step(dets, t, self.k)
        if self._clutter_probabilities is not None:  # the map takes the scan once the tracker has associated it
            self.sensor.after_tracking(self.episode, dets, self._clutter_probabilities())  # type: ignore[attr-defined]
        return ScanResult(self.k, t, dets, tracks)


def at_least(pd: FloatArray, n: int) -> FloatArray:
    """P(at least ``n`` of independent detections happen), ``pd`` (R, N) -> (N,) (Poisson-binomial recursion).

    The network chain forms a position from a tuple of ``nu`` receivers' ToAs, so a target yields a position
    measurement when at least ``nu`` of the listening receivers detect it.
    """
    dist = np.zeros((n + 1, *pd.shape[1:]))  # P(j detections so far), j = 0..n-1, and ">= n" in the last row
    dist[0] = 1.0
    for p in pd:  # receivers: a handful
        top = dist[n] + p * dist[n - 1]
        dist[1:n] = dist[1:n] * (1.0 - p) + dist[0 : n - 1] * p
        dist[0] = dist[0] * (1.0 - p)
        dist[n] = top
    return dist[n]


def run_episode(sim: Simulator, seed: int, policy: Callable[[int], ScanPlan], gate_m: float = 10.0) -> TrackAccounting:
    """Play one seeded episode with ``policy(scan_index) -> ScanPlan``; returns its track accounting."""
    sim.reset(seed)
    acc = TrackAccounting(sim.truth.n_targets, gate_m)
    while not sim.done:
        res = sim.step(policy(sim.k + 1))
        x, _ = res.tracks.combined()
        acc.add(
            res.tracks.ids,
            res.tracks.confirmed,
            x[:, [0, 2]],
            sim.truth.states[res.scan_index][:, [0, 2]],
            sim.truth.alive[res.scan_index],
        )
    return acc


def round_robin(sensor: Sensor) -> Callable[[int], ScanPlan]:
    """Seed 003's open-loop schedule: every transmitter cycles through the library, all receivers listen."""
    plans = [ScanPlan.all_listening(w, sensor.n_tx, sensor.n_rx) for w in range(len(sensor.library))]
    return lambda k: plans[k % len(plans)]
