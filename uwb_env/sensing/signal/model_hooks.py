"""The sensor model of a signal-level sensor: its calibrated parametric model's (``self.model``).

A signal sensor synthesises the detections, but the tracker's Pd and the lookahead's Pd, R and clutter map come from
the parametric model of the same scenario (both fidelities share one sensor model). Both signal sensors inherit these
four forwarding methods of the ``Sensor`` protocol instead of repeating them.
"""

from __future__ import annotations

from uwb_env.sensing.parametric import ParametricSensor
from uwb_env.typing import FloatArray, IntArray


class ParametricModelHooks:
    """The protocol's sensor-model methods, forwarded to ``self.model`` (a :class:`ParametricSensor`)."""

    model: ParametricSensor

    def detection_probability_at(
        self,
        tx: int,
        rx: int,
        positions: FloatArray,
        waveform: int,
        rcs_m2: float = 1.0,
        swerling: int = 1,
        velocities: FloatArray | None = None,
    ) -> FloatArray:
        """The parametric model's Pd (:meth:`ParametricSensor.detection_probability_at`).

        ``velocities`` (N, 2) [m/s]: at the echo's SNR after seed 001's background MTI where it is active
        (through-wall: its loss at the pair's bistatic range-rate); elsewhere it changes nothing.
        """
        return self.model.detection_probability_at(tx, rx, positions, waveform, rcs_m2, swerling, velocities)

    def expected_measurements(
        self,
        tx: int,
        rx: int,
        positions: FloatArray,
        waveforms: IntArray,
        rcs_m2: float = 1.0,
        swerling: int = 1,
        velocities: FloatArray | None = None,
    ) -> tuple[FloatArray, FloatArray]:
        """The parametric model's lookahead inputs (:meth:`ParametricSensor.expected_measurements`)."""
        return self.model.expected_measurements(tx, rx, positions, waveforms, rcs_m2, swerling, velocities)

    def clutter_intensity_at(
        self, tx: int, rx: int, z: FloatArray, R: FloatArray, waveforms: IntArray | None = None
    ) -> FloatArray:
        """The parametric model's clutter map (:meth:`ParametricSensor.clutter_intensity_at`)."""
        return self.model.clutter_intensity_at(tx, rx, z, R, waveforms)

    def measurement_names(self, rx: int) -> tuple[str, ...]:
        """Components of the per-pair measurements the tracker and the lookahead see."""
        return self.model.measurement_names(rx)
