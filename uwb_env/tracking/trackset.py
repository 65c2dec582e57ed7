"""What trackers give: the ``TrackSet`` of the current tracks and the ``Prediction`` a lookahead scores."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from uwb_env.tracking import compiled
from uwb_env.typing import BoolArray, FloatArray, IntArray


@dataclass(slots=True)
class TrackSet:
    """The tracks (mutable per-episode state), arrays over N tracks and the r models of the tracker.

    Attributes:
        ids: ``(N,)`` stable ids; confirmed: ``(N,)``; age: ``(N,)`` scans since birth; born: ``(N,)`` scan index.
        existence: ``(N,)`` probability of existence; mu: ``(N, r)`` model probabilities; active: ``(N, r)``.
        x: ``(N, r, 6)`` and P: ``(N, r, 6, 6)`` model-conditioned estimates.
    """

    ids: IntArray
    confirmed: BoolArray
    age: IntArray
    born: IntArray
    existence: FloatArray
    mu: FloatArray
    active: BoolArray
    x: FloatArray
    P: FloatArray

    @classmethod
    def empty(cls, r: int) -> TrackSet:
        """No tracks."""
        return cls(
            np.zeros(0, np.int64),
            np.zeros(0, bool),
            np.zeros(0, np.int64),
            np.zeros(0, np.int64),
            np.zeros(0),
            np.zeros((0, r)),
            np.zeros((0, r), bool),
            np.zeros((0, r, 6)),
            np.zeros((0, r, 6, 6)),
        )

    def __len__(self) -> int:
        return int(self.ids.shape[0])

    def select(self, keep: BoolArray) -> TrackSet:
        """The tracks where ``keep`` (N,) is True (copies; ``take`` on the indices is the cheapest at these sizes)."""
        index = np.flatnonzero(keep)
        return TrackSet(*(getattr(self, f).take(index, axis=0) for f in FIELDS))

    def combined(self) -> tuple[FloatArray, FloatArray]:
        """IMM output: combined means ``(N, 6)`` and covariances ``(N, 6, 6)`` (compiled imm_combine)."""
        return compiled.combine(self.mu, self.x, self.P)


FIELDS = ("ids", "confirmed", "age", "born", "existence", "mu", "active", "x", "P")


@dataclass(frozen=True, slots=True)
class Prediction:
    """Scored tracks predicted to a scan, as Gaussians (the lookahead's input, ``tracking.protocol``).

    Attributes:
        x: ``(N, 6)`` means; P: ``(N, 6, 6)`` covariances; mu: ``(N, r)`` model probabilities (r = 1 for a tracker
        without a model set); active: ``(r,)`` the model set in force at that scan.
    """

    x: FloatArray
    P: FloatArray
    mu: FloatArray
    active: BoolArray
