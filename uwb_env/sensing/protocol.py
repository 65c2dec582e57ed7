"""The sensing seam (one seam per stage): what a sensor offers, and a registry keyed by (fidelity, waveform family).

Every sensor turns the episode's truth and a scan plan into per-pair :class:`Detections` (the one-step data flow, item
3), and offers the sensor model the tracker and the lookahead use (Pd, the measurement covariance and the clutter
map at predicted positions). The simulator (``uwb_env.sim``), the env (``uwb_env.envs.scheduling``), the lookahead
(``uwb_env.lookahead``) and the scripts use exactly the members of :class:`Sensor`; they never branch on which
implementation they hold. Signal-level sensors delegate the sensor model to the parametric model of the same
scenario, so every lookahead option works at every fidelity.

Registry: ``register_sensor(fidelity, family)`` decorates a sensor class; ``make_sensor(cfg)`` builds the one of
``cfg.sensing.fidelity`` and the library's waveform family (``ChirpWaveformConfig.kind``, ``ImpulseWaveformConfig
.kind``). Registered (``uwb_env.sensing`` imports every implementation):

    ("parametric", "chirp"), ("parametric", "impulse")   ParametricSensor       (sensing.parametric)
    ("signal", "impulse")                                 SignalSensor           (sensing.signal.sensor)
    ("signal", "chirp")                                   ChirpSignalSensor      (sensing.signal.chirp_sensor)
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

from uwb_env.config import ScenarioConfig
from uwb_env.rng import RngStreams
from uwb_env.scene.layout import SceneLayout
from uwb_env.scene.truth import Truth
from uwb_env.sensing.records import Detections, ScanPlan
from uwb_env.typing import FloatArray, IntArray
from uwb_env.waveforms.library import WaveformLibrary


@runtime_checkable
class Sensor(Protocol):
    """What the simulator, the env, the lookahead and the scripts use of a sensor.

    Attributes:
        cfg: the scenario. layout: its geometry. library: its waveforms (index = plan's waveform).
        pairs: ``(P, 2)`` formed (tx, rx) pairs. n_tx, n_rx: node counts.
    """

    cfg: ScenarioConfig
    layout: SceneLayout
    library: WaveformLibrary
    pairs: IntArray
    n_tx: int
    n_rx: int

    def new_episode(self, truth: Truth, rngs: RngStreams) -> Any:
        """Per-episode state (geometry, plan-independent draws); the argument ``sense`` takes."""
        ...

    def sense(self, episode: Any, k: int, plan: ScanPlan, time_s: float = 0.0) -> tuple[Detections, ...]:
        """Detections of the plan's active formed pairs in scan ``k`` (random draws independent of the plan)."""
        ...

    def detection_probability_at(
        self, tx: int, rx: int, positions: FloatArray, waveform: int, rcs_m2: float = 1.0, swerling: int = 1
    ) -> FloatArray:
        """Pd ``(N,)`` of pair (tx, rx) with ``waveform`` at ``positions`` (N, 2) [m] (the tracker's sensor model)."""
        ...

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
        """The lookahead's ``(Pd (W, N), R (W, N, m, m))`` of pair (tx, rx) at ``positions`` for ``waveforms``."""
        ...

    def clutter_intensity_at(
        self, tx: int, rx: int, z: FloatArray, R: FloatArray, waveforms: IntArray | None = None
    ) -> FloatArray:
        """Clutter map ``(W, N)`` of pair (tx, rx) at measurements ``z`` (N, m), covariances ``R`` (W, N, m, m).

        ``waveforms`` (W,): the library's waveforms of R (default: the whole library in order).
        """
        ...

    def measurement_names(self, rx: int) -> tuple[str, ...]:
        """Components of receiver ``rx``'s per-pair measurements."""
        ...


SensorFactory = Callable[[ScenarioConfig], Sensor]
_SENSORS: dict[tuple[str, str], SensorFactory] = {}


def register_sensor(fidelity: str, *families: str) -> Callable[[type], type]:
    """Class decorator: register a sensor for ``fidelity`` and each waveform family (duplicates raise ``KeyError``)."""
    if not families:
        raise ValueError(f"register_sensor({fidelity!r}): name at least one waveform family")

    def deco(cls: type) -> type:
        for family in families:  # a handful
            key = (fidelity, family)
            if key in _SENSORS:
                raise KeyError(f"sensor for (fidelity={fidelity!r}, waveform family={family!r}) already registered")
            _SENSORS[key] = cls
        return cls

    return deco


def registered_sensors() -> dict[tuple[str, str], SensorFactory]:
    """A copy of the registry: {(fidelity, waveform family): sensor class}."""
    return dict(_SENSORS)


def waveform_family(cfg: ScenarioConfig) -> str:
    """The library's waveform family (``kind`` of its waveform configs); a mixed library raises ``ValueError``."""
    kinds = sorted({w.kind for w in cfg.waveforms})
    if len(kinds) != 1:
        raise ValueError(f"waveforms of {cfg.name!r}: kinds {kinds}; a sensor serves one waveform family")
    return kinds[0]


def make_sensor(cfg: ScenarioConfig) -> Sensor:
    """The registered sensor of ``cfg.sensing.fidelity`` and the library's waveform family, built on ``cfg``."""
    key = (cfg.sensing.fidelity, waveform_family(cfg))
    factory = _SENSORS.get(key)
    if factory is None:
        allowed = ", ".join(f"{f}/{w}" for f, w in sorted(_SENSORS))
        raise ValueError(
            f"sensing.fidelity = {key[0]!r} with {key[1]} waveforms ({cfg.name!r}): no sensor registered "
            f"(registered fidelity/waveform family: {allowed})"
        )
    return factory(cfg)
