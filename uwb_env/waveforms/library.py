"""The waveform library of a scenario: one object per configured waveform, indexed by action."""

from __future__ import annotations

from typing import Protocol

import numpy as np

from uwb_env.config import ChirpWaveformConfig, ImpulseWaveformConfig, WaveformConfig
from uwb_env.typing import FloatArray
from uwb_env.waveforms.chirp import ChirpWaveform
from uwb_env.waveforms.impulse import ImpulseWaveform


class Waveform(Protocol):
    """What sensing, lookahead and schedulers need from a waveform."""

    measurement_dim: int
    measurement_names: tuple[str, ...]

    @property
    def name(self) -> str: ...  # noqa: D102

    @property
    def center_freq_hz(self) -> float: ...  # noqa: D102

    @property
    def wavelength_m(self) -> float: ...  # noqa: D102

    @property
    def rms_bandwidth_hz(self) -> float: ...  # noqa: D102

    @property
    def dwell_time_s(self) -> float: ...  # noqa: D102

    @property
    def unit_covariance(self) -> FloatArray | None: ...  # noqa: D102

    def scan_energy_j(self, tx_power_w: float) -> float: ...  # noqa: D102

    def covariance(self, snr: FloatArray) -> FloatArray: ...  # noqa: D102


_BUILDERS = {ChirpWaveformConfig: ChirpWaveform, ImpulseWaveformConfig: ImpulseWaveform}


def build_waveform(cfg: WaveformConfig) -> Waveform:
    """The waveform object for one config."""
    return _BUILDERS[type(cfg)](cfg)


class WaveformLibrary:
    """Ordered waveforms; index ``i`` is what a scan plan (and a ``Discrete`` action) selects."""

    def __init__(self, configs: tuple[WaveformConfig, ...]) -> None:
        if not configs:
            raise ValueError("WaveformLibrary.configs = (): must hold at least one waveform")
        self.waveforms: tuple[Waveform, ...] = tuple(build_waveform(c) for c in configs)
        dims = {w.measurement_dim for w in self.waveforms}
        if len(dims) != 1:
            raise ValueError(f"WaveformLibrary: measurement dimensions {sorted(dims)} differ; use one kind")
        self.measurement_dim = dims.pop()
        self.measurement_names = self.waveforms[0].measurement_names
        # (W,) the period of each waveform's measured range-rate [m/s]: lambda / T1 for a chirp train, inf where the
        # range-rate is unambiguous or not measured (tracking.ambiguity); read-only
        self.range_rate_periods = np.array(
            [getattr(w, "range_rate_ambiguity_mps", np.inf) for w in self.waveforms], dtype=float
        )
        self.range_rate_periods.flags.writeable = False

    def __len__(self) -> int:
        return len(self.waveforms)

    def __getitem__(self, i: int) -> Waveform:
        return self.waveforms[i]

    @property
    def names(self) -> tuple[str, ...]:
        """Waveform names in action order."""
        return tuple(w.name for w in self.waveforms)
