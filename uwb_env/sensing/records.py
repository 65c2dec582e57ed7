"""The records that flow between stages: the scan plan (what to do) and the detections of a pair (what was seen)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from uwb_env.typing import BoolArray, FloatArray, IntArray


@dataclass(frozen=True, slots=True)
class ScanPlan:
    """What one scan does (step 1 of a scan).

    Attributes:
        waveform: ``(T,)`` waveform index per transmitter (into the scenario's library).
        active_rx: ``(R,)`` which receivers listen.

    The arrays are copied and made read-only, so a plan cannot change after it has been validated.
    """

    waveform: IntArray
    active_rx: BoolArray

    def __post_init__(self) -> None:
        for name in ("waveform", "active_rx"):
            arr = np.array(getattr(self, name))
            arr.flags.writeable = False
            object.__setattr__(self, name, arr)

    @classmethod
    def all_listening(cls, waveform: int, n_tx: int, n_rx: int) -> ScanPlan:
        """Every transmitter sends ``waveform`` and every receiver listens."""
        return cls(np.full(n_tx, waveform, dtype=np.int64), np.ones(n_rx, dtype=bool))

    def validate(self, n_tx: int, n_rx: int, n_waveforms: int) -> None:
        """Raise ``ValueError`` naming the field and value unless the plan fits the scenario."""
        w, a = self.waveform, self.active_rx
        if (
            isinstance(w, np.ndarray)
            and isinstance(a, np.ndarray)
            and w.shape == (n_tx,)
            and a.shape == (n_rx,)
            and w.dtype.kind in "iu"
            and a.dtype == np.bool_
        ):
            wl = w.tolist()
            if min(wl) >= 0 and max(wl) < n_waveforms and True in a.tolist():
                return  # fast path: the common valid plan
        w, a = np.asarray(w), np.asarray(a)
        if w.shape != (n_tx,):
            raise ValueError(f"ScanPlan.waveform has shape {w.shape}: must be ({n_tx},), one index per transmitter")
        if not np.issubdtype(w.dtype, np.integer):
            raise ValueError(f"ScanPlan.waveform = {w!r}: must hold integers (got dtype {w.dtype})")
        bad = (w < 0) | (w >= n_waveforms)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise ValueError(
                f"ScanPlan.waveform[{i}] = {int(w[i])}: must be in [0, {n_waveforms}) "
                f"(the library has {n_waveforms} waveforms)"
            )
        if a.shape != (n_rx,):
            raise ValueError(f"ScanPlan.active_rx has shape {a.shape}: must be ({n_rx},), one flag per receiver")
        if a.dtype != np.bool_:
            raise ValueError(f"ScanPlan.active_rx = {a!r}: must be a boolean mask (got dtype {a.dtype})")
        if not a.any():
            raise ValueError("ScanPlan.active_rx is all False: at least one receiver must listen")


@dataclass(slots=True)
class Detections:
    """Detections of one transmitter-receiver pair in one scan (step 3 of a scan).

    Rows are sorted by bistatic range, so the order reveals nothing about their origin.

    Attributes:
        tx, rx: node indices; waveform: library index used by ``tx``; time_s: scan time [s].
        z: ``(n, m)`` measurements, columns ``measurement_names`` (bistatic range [m], range-rate [m/s] for
            chirps, azimuth [rad] for array receivers when enabled).
        R: ``(n, m, m)`` measurement covariances.
        snr: ``(n,)`` linear E/N0 attached to each detection (true SNR for targets, apparent for false alarms).
        origin: ``(n,)`` index of the true target, -1 for clutter. For evaluation only: never for the tracker.
        clutter_intensity: ``(n,)`` the known clutter map at each measurement: expected false detections per unit
            measurement-space volume (the rho_i of PDA / LMIPDA; 0 where no clutter can fall).
        expected_false_alarms: expected number of false detections of the pair in a scan.
        range_rate_period_mps: the range-rate column is measured modulo this period (a chirp train's lambda / T1,
            folded into [-P/2, P/2)); inf where it is unambiguous (``uwb_env.tracking.ambiguity``).
    """

    tx: int
    rx: int
    waveform: int
    time_s: float
    z: FloatArray
    R: FloatArray
    snr: FloatArray
    origin: IntArray
    measurement_names: tuple[str, ...]
    clutter_intensity: FloatArray
    expected_false_alarms: float
    range_rate_period_mps: float = math.inf

    def __len__(self) -> int:
        return int(self.z.shape[0])
