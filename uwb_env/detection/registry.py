r"""Registries of the in-sensor detection stages, keyed by the ``sensing.signal`` fields that name them.

STYLE B1 / B2: one seam per stage, a registry of callables checked for duplicates, no if/elif factory. Two
registries live here:

* :data:`CFAR_DETECTORS` (``sensing.signal.cfar``): name -> :class:`CfarDetector`, a pair of a threshold-factor
  *design* (run once, when the sensor is built: ``alpha`` for the design ``cfar_pfa``) and a detector *kernel* (run
  every scan on the rectified differences ``d`` ``(B, N)`` -> decisions ``(B, N)``). Registered: ``dtb``, ``ca``,
  ``g``, ``os`` (:mod:`uwb_env.detection.cfar`, seed 000 section IV-E), with exactly the calls the sensor made
  before the registry (byte-identical decisions).
* :data:`TOA_ESTIMATORS` (``sensing.signal.toa_estimator``): name -> :class:`ToaEstimator`, the stage that turns one
  scan's decisions into ToAs. ``median`` and ``peak`` (seed 000's 1-D clustering and seed 003's peak fit) carry a
  kernel ``estimate(decisions, d, sig, fs) -> (row, toa [samples], weight, peak)``; an estimator that replaces the
  whole CFAR chain (``energy-detector``: seed 002, run by the sensor's own chain) registers ``estimate=None`` and
  ``replaces_cfar=True``. ``interval``: seed 001's ToA of distributed targets (:mod:`uwb_env.detection.
  toa_association`). Further estimators (seed 004's HMM) register here the same way.
* :data:`NORMALIZATIONS` (``sensing.signal.normalization``): ``none`` or seed 001's ``advance`` normalization.

Lookup of an unknown name raises ``ValueError`` naming the field, the value and the allowed names.
"""

from __future__ import annotations

import difflib
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Generic, TypeVar

from uwb_env.detection.cfar import (
    ca_cfar,
    ca_threshold_factor,
    dtb_cfar,
    g_cfar,
    os_cfar,
    os_threshold_factor,
)
from uwb_env.detection.clustering import cluster_detections
from uwb_env.detection.toa_association import advance_normalization, interval_toas
from uwb_env.typing import BoolArray, FloatArray, IntArray

if TYPE_CHECKING:  # the config is read, never imported at run time (detection sits below sensing)
    from uwb_env.config import SignalConfig

T = TypeVar("T")

Clusters = tuple[IntArray, FloatArray, IntArray, FloatArray]
"""Flat ToA records of a batch of scans: ``(row (D,), toa (D,) [samples], weight (D,), peak (D,))``."""


class Registry(Generic[T]):
    """Name -> entry for the config field ``field`` (e.g. ``"sensing.signal.cfar"``); duplicates raise ``KeyError``."""

    def __init__(self, field: str) -> None:
        self.field = field
        self._entries: dict[str, T] = {}

    def register(self, name: str, entry: T) -> T:
        """Add ``entry`` under ``name``; a name registered twice raises ``KeyError``."""
        if name in self._entries:
            raise KeyError(f"{self.field}: {name!r} already registered")
        self._entries[name] = entry
        return entry

    def get(self, name: str) -> T:
        """The entry registered under ``name``; unknown names raise ``ValueError`` with the allowed names."""
        try:
            return self._entries[name]
        except (KeyError, TypeError):
            close = difflib.get_close_matches(str(name), list(self._entries), n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise ValueError(f"{self.field} = {name!r}: must be one of {self.names()}{hint}") from None

    def names(self) -> tuple[str, ...]:
        """Registered names, in registration order."""
        return tuple(self._entries)

    def __contains__(self, name: object) -> bool:
        return name in self._entries

    def __iter__(self) -> Iterator[str]:
        return iter(self._entries)


# --------------------------------------------------------------------------------------------------------- CFAR
@dataclass(frozen=True, slots=True)
class CfarDetector:
    """One CFAR detector: ``design(sig, n_samples) -> alpha`` once, ``detect(d, alpha, sig) -> decisions`` per scan.

    ``design`` gets the :class:`~uwb_env.config.SignalConfig` and the scan length (G-CFAR's reference count depends
    on it); detectors with their own weights (DTB) return 0. ``detect`` takes the rectified differences ``d``
    ``(B, N)``, the designed factor and the config, and returns boolean decisions ``(B, N)``.
    """

    name: str
    design: Callable[[SignalConfig, int], float]
    detect: Callable[[FloatArray, float, SignalConfig], BoolArray]


CFAR_DETECTORS: Registry[CfarDetector] = Registry("sensing.signal.cfar")


def register_cfar(
    name: str,
    design: Callable[[SignalConfig, int], float],
    detect: Callable[[FloatArray, float, SignalConfig], BoolArray],
) -> CfarDetector:
    """Register a CFAR detector under ``name`` (the value of ``sensing.signal.cfar``)."""
    return CFAR_DETECTORS.register(name, CfarDetector(name, design, detect))


def cfar_detector(name: str) -> CfarDetector:
    """The CFAR detector named by ``sensing.signal.cfar`` (unknown -> ``ValueError`` naming the allowed ones)."""
    return CFAR_DETECTORS.get(name)


def _no_factor(sig: Any, n_samples: int) -> float:
    return 0.0


register_cfar(
    "dtb",
    _no_factor,
    lambda d, alpha, sig: dtb_cfar(
        d, sig.dtb_alpha_local, sig.dtb_alpha_global, sig.dtb_buffer, sig.dtb_qmax, sig.dtb_delta
    ),
)
register_cfar(
    "ca",
    lambda sig, n: ca_threshold_factor(sig.cfar_pfa, 2 * sig.cfar_reference),
    lambda d, alpha, sig: ca_cfar(d, alpha, sig.cfar_reference, sig.cfar_guard),
)
register_cfar(
    "g",
    lambda sig, n: ca_threshold_factor(sig.cfar_pfa, n - 2 * sig.cfar_guard - 1),
    lambda d, alpha, sig: g_cfar(d, alpha, sig.cfar_guard),
)
register_cfar(
    "os",
    lambda sig, n: os_threshold_factor(sig.cfar_pfa, 2 * sig.cfar_reference, sig.os_rank),
    lambda d, alpha, sig: os_cfar(d, alpha, sig.cfar_reference, sig.cfar_guard, sig.os_rank),
)


# ---------------------------------------------------------------------------------------------- ToA estimators
@dataclass(frozen=True, slots=True)
class ToaEstimator:
    """One ToA estimator: ``estimate(decisions (B, N), d (B, N), sig, fs [Hz]) -> Clusters``.

    ``replaces_cfar``: the estimator runs its own chain on the raw scans instead of the CFAR decisions (the sensor
    dispatches on this flag, not on the name); such an entry may have ``estimate = None``.
    """

    name: str
    estimate: Callable[[BoolArray, FloatArray, SignalConfig, float], Clusters] | None
    replaces_cfar: bool = False


TOA_ESTIMATORS: Registry[ToaEstimator] = Registry("sensing.signal.toa_estimator")


def register_toa_estimator(
    name: str,
    estimate: Callable[[BoolArray, FloatArray, SignalConfig, float], Clusters] | None,
    *,
    replaces_cfar: bool = False,
) -> ToaEstimator:
    """Register a ToA estimator under ``name`` (the value of ``sensing.signal.toa_estimator``)."""
    return TOA_ESTIMATORS.register(name, ToaEstimator(name, estimate, replaces_cfar))


def toa_estimator(name: str) -> ToaEstimator:
    """The ToA estimator named by ``sensing.signal.toa_estimator`` (unknown -> ``ValueError``)."""
    return TOA_ESTIMATORS.get(name)


def _clustering(use: str) -> Callable[[BoolArray, FloatArray, SignalConfig, float], Clusters]:
    def estimate(decisions: BoolArray, d: FloatArray, sig: SignalConfig, fs: float) -> Clusters:
        return cluster_detections(decisions, d, sig.cluster_distance_s * fs, sig.cluster_min_weight, use)

    return estimate


register_toa_estimator("median", _clustering("median"))
register_toa_estimator("peak", _clustering("peak"))
register_toa_estimator("energy-detector", None, replaces_cfar=True)
register_toa_estimator("hmm", None, replaces_cfar=True)  # seed 004: the sensor's own chain (SignalSensor._hmm)


def _interval(decisions: BoolArray, d: FloatArray, sig: SignalConfig, fs: float) -> Clusters:
    """Seed 001 section 3.2 steps 1-3 (one ToA per interval of a distributed target), plus the configured offset."""
    row, toa, weight, peak = interval_toas(decisions, d, sig.toa_interval_samples, sig.toa_interval_threshold)
    return row, toa + sig.toa_interval_offset_s * fs, weight, peak


register_toa_estimator("interval", _interval)


# --------------------------------------------------------------------------------------------- normalizations
def _identity(d: FloatArray, target_samples: int = 0) -> FloatArray:
    return d


NORMALIZATIONS: Registry[Callable[[FloatArray, int], FloatArray]] = Registry("sensing.signal.normalization")
"""``sensing.signal.normalization``: the weak-signal enhancement before the CFAR, ``(d (B, N), target_samples) ->
(B, N)``; ``target_samples`` a target's extent (the signal path passes ``toa_interval_samples``, seed 001's W_p)."""
NORMALIZATIONS.register("none", _identity)
NORMALIZATIONS.register("advance", advance_normalization)  # seed 001 section 2

__all__ = [
    "CFAR_DETECTORS",
    "NORMALIZATIONS",
    "TOA_ESTIMATORS",
    "CfarDetector",
    "Clusters",
    "Registry",
    "ToaEstimator",
    "cfar_detector",
    "register_cfar",
    "register_toa_estimator",
    "toa_estimator",
]
