r"""The tracker seam: the one interface the simulator, the environments, the lookahead and the campaigns use.

A tracker (``TrackerConfig.kind``, built by ``uwb_env.tracking.registry.make_tracker``) turns each scan's
``Detections`` into a ``TrackSet`` and gives the lookahead what it needs to score a plan, nothing else:

- ``reset(rng)``: forget everything; ``rng`` is the episode's ``tracker`` stream (``uwb_env.rng``), the only
  randomness a tracker may use (particle trackers draw from it; the IMM tracker draws nothing).
- ``step(detections, time_s, scan_index) -> TrackSet``: one scan, every pair's detections in order.
- ``tracks``: the ``TrackSet`` after the last step: ids, confirmed flags, existence, per-model estimates and model
  probabilities (a tracker without motion models reports one model, ``model_names = ("single",)`` or its own name);
  ``TrackSet.combined()`` gives the (N, 6) means and (N, 6, 6) covariances every consumer reads.
- ``scored_prediction(time_s, scan_index) -> Prediction | None``: the tracks a lookahead scores (the confirmed ones,
  else every tentative one; None without any track) predicted to the next scan as Gaussians. A particle tracker
  gives each scored track's moment-matched Gaussian (the weighted mean and covariance of its particles or of the
  extracted mixture component, predicted with its motion model).
- ``predict_gaussians(pred, dt, scan_index) -> Prediction``: the moment-matched prediction of Gaussians one scan on
  (multi-step lookahead), with the tracker's own motion model(s).
- ``expected_update(...)``: one transmitter-receiver pair's expected posterior covariance of the scored Gaussians
  under every candidate plan (``uwb_env.tracking.expectation``: the tracker's filter linearisation, UKF or EKF, at the
  predicted state, then the expected Riccati update with the plan's Pd, R and q_2). Every tracker of this project
  inherits it from ``expectation.GaussianLookahead`` with the linearisation it uses (``filter``), which is how the
  expected covariance is defined for particle trackers: the update of their moment-matched Gaussian.
- ``cfg``: the ``TrackerConfig`` (the lookahead reads its sensor-model assumptions: assumed RCS and Swerling case,
  Pd cap, range-rate noise floor, gate probability, clutter floor).
- optional (``imm-lmipda`` only): ``record_association(on)`` and ``clutter_probabilities()``, per detection record of
  the last step each detection's a-posteriori clutter probability (1 - the tracks' LMIPDA claims on it); the
  ``Simulator`` looks them up (``getattr``) only when the sensor's clutter map counts unassociated detections
  (``SignalConfig.clutter_map_count = "unassociated"``, Musicki & Evans 2004), and says so when the tracker lacks them.

State layout everywhere: ``[x, vx, y, vy, ax, ay]`` [m, m/s, m/s^2].
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol, runtime_checkable

import numpy as np

from uwb_env.config import TrackerConfig
from uwb_env.sensing.records import Detections
from uwb_env.tracking.trackset import Prediction, TrackSet
from uwb_env.typing import FloatArray


@runtime_checkable
class MultiTargetTracker(Protocol):
    """What every tracker offers (module docstring)."""

    kind: str
    cfg: TrackerConfig
    model_names: tuple[str, ...]
    filter: str

    @property
    def tracks(self) -> TrackSet:
        """The tracks after the last step."""
        ...

    def reset(self, rng: np.random.Generator | None = None) -> None:
        """Forget every track; ``rng``: the episode's ``tracker`` stream."""
        ...

    def step(self, detections: Sequence[Detections], time_s: float, scan_index: int) -> TrackSet:
        """Process one scan (every pair's detections, in order); returns the updated tracks."""
        ...

    def scored_prediction(self, time_s: float, scan_index: int) -> Prediction | None:
        """The scored tracks predicted to ``time_s`` as Gaussians (pure); None without any track."""
        ...

    def predict_gaussians(self, pred: Prediction, dt: float, scan_index: int) -> Prediction:
        """Moment-matched prediction of ``pred`` ``dt`` later, to ``scan_index`` (pure)."""
        ...

    def expected_update(
        self,
        Pa: FloatArray,
        x: FloatArray,
        P: FloatArray,
        names: tuple[str, ...],
        tx_pos: FloatArray,
        rx_pos: FloatArray,
        R: FloatArray,
        pd: FloatArray,
        reduction: object,
        rho: FloatArray,
        period: FloatArray,
    ) -> FloatArray:
        """One pair's expected update of ``Pa (A, N, 6, 6)`` (``expectation.gaussian_expected_update``)."""
        ...
