r"""Signal-level sensing of chirp pulse trains (seed 003 sections 3.2, 4.1 and V): ``fidelity="signal"``, chirps.

Per scan and formed pair (one transmitter, its receivers), the received pulse train over every propagation path
with at most three reflections (``uwb_env.channel.multipath``) is synthesised in the frequency domain,
matched-filtered, combined into receive beams and turned into delay-Doppler images (``sensing.signal.chirp_chain``);
seed 003's section 4.1 detector (``uwb_env.detection.delay_doppler``) subtracts the background, thresholds each
cell, finds the peaks iteratively and fits them. Each pair's detections become one :class:`Detections` record,
z = [bistatic range, range-rate folded into [-P/2, P/2)], P = lambda / T1, with R from the fitted curvature; with
``sensing.measure_doa`` an array receiver's detections add the azimuth, the ML direction from the L orthogonal
beams' complex values at the peak cell (``beams.ml_direction``), with the parametric model's variance
(:meth:`ChirpSignalSensor._with_azimuth`).

Choices (the seed leaves them open; each one is shared with the parametric model so that both fidelities agree):

* Receive beams (``SensingConfig.array_beams``, ``uwb_env.sensing.beams``). Eq. 6's plain element sum is a fixed
  beam at boresight whose nulls (+-41.8 deg for L = 3, d = lambda / 2) sit next to the urban vehicles (25-35 deg
  off boresight). A radar forms L orthogonal beams by an element-space DFT instead: every beam's image is detected
  on, and the detections of one delay-Doppler cell (within one resolution cell) over the beams are merged, keeping
  the strongest (non-maximum suppression across beams). The parametric model gives a target at direction theta the
  gain max_m |AF_m(theta)|^2 / L^2 of that best beam (1 at a beam centre, 4/9 midway between two).
* Element pattern: a sector of +-``field_of_view_deg`` around boresight (the parametric field-of-view rule): paths
  arriving from outside it are not received.
* Static clutter (the vegetation points, RCS ``ClutterConfig.scatterer_rcs_m2``, and the direct blast). Every
  tx-scatterer-rx and tx-scatterer-scatterer-rx path has a random phase per scan (seed 003 eq. 2: the foliage moves
  by more than lambda / 2 = 3.75 cm between scans) and a diffuse part, ``clutter_diffuse_fraction`` of its power, that
  decorrelates within the dwell with a Gaussian Doppler spectrum of standard deviation ``clutter_doppler_spread_hz``
  (wind in the leaves; Billingsley's windblown clutter has an AC / DC power ratio of ~0.12 and a ~4 Hz spread at
  4 GHz in a light breeze). Weak paths (image SNR below ``_FLUCTUATION_SNR_FLOOR``) and the direct blast keep one
  random phase for the episode. Where several paths share a delay cell, the per-scan phases make the cell's
  magnitude fluctuate (a Rayleigh residue after the mean-magnitude subtraction); the diffuse part spreads the
  residue around zero Doppler. Together they are the clutter notch that the parametric model writes as
  SCNR = SNR / (1 + eta CNR G(f)) (``uwb_env.channel.doppler_notch``), whose eta and Doppler spread are fitted on
  this path (``scripts/calibrate_chirp.py``).
* Background and threshold (seed 003 section 4.1): J = ``background_scans`` clutter-only scans per waveform at the
  start of the episode give, per pair and beam, the mean magnitude A_bar (subtracted from every image) and the
  per-cell threshold for the per-cell false-alarm probability ``SensingConfig.false_alarm_probability`` (noise power
  known: B eta N0 L per cell). ``ChirpSignalConfig.threshold``: ``clutter_map`` (default) also adapts each clutter
  cell's threshold to the fluctuation of |A| measured over the J scans (:func:`clutter_map_threshold`): the foliage
  residue then raises the threshold at zero Doppler and masks a target there (the clutter notch) instead of making
  false peaks; ``rice`` models every cell as a constant static return plus noise (``delay_doppler``), which keeps
  the targets at blind speeds visible and lets the residue through as false peaks.
* Peak cap: at most ``ChirpSignalConfig.max_peaks`` peaks per beam image of the library's narrowest bandwidth, and
  as many per image cell for the others (:func:`peak_caps`: 38 for a 160 MHz image of 4x the delay rows next to 10
  for the 40 MHz ones), so that a wide band's noise peaks (~4x as many at the same per-cell Pfa) do not crowd out a
  weak echo: with one cap of 10 the 160 MHz images kept a third of their noise peaks per cell (0.105 against 0.36
  per cell and unit Pfa uncapped) and lost echoes ranked below them; with the scaled cap they keep 0.35, the 40 MHz
  images 0.32 (``scripts/calibrate_chirp.py`` section C).
* Gate: peaks closer to the direct path than ``blind_zone_excess_m`` or beyond 2 ``max_range_m`` are dropped (the
  parametric coverage); images span the bistatic ranges from the baseline to 2 ``max_range_m``.
* Clutter map: a detection's ``clutter_intensity`` is the false-peak density of its pair and waveform, uniform in
  (range, folded range-rate): the expected false peaks per scan ``false_peak_factor(Pfa)`` x Pfa x searched cells x
  beams (measured on urban-intersection, ``scripts/calibrate_chirp.py``) over the gate's range x the period.
* Covariance: the fitted curvature and the train's matched second moments give each detection's range and
  range-rate variances (the sandwich R of ``delay_doppler``: right also for a peak flattened by the range walk);
  their correlation is
  the waveform's (``ChirpWaveform.covariance``: 1e-5 for the seed's trains). The fitted cross-curvature of a 3 x 3
  window is noise at these SNRs (correlations of +-0.1, i.e. ridge slopes R_rd / R_dd of +-1 m per m/s given the
  cells' 1.9 m x 0.075 m/s aspect), and the tracker reads that slope as the delay-Doppler ridge (initiation).
* Truth origin (evaluation only): ``Detections.origin`` is the target index or -1; the finer code of
  ``delay_doppler.truth_origin`` (-1 static path, -2 multipath ghost, -3 noise) is in the scan's trace
  (:attr:`ChirpEpisode.last_trace`).

Measured on urban-intersection (``scripts/calibrate_chirp.py`` -> ``results/calibration-urban/report.md``): the
fitted SNR of a strong echo is 0.93-1.0 x the parametric SNR over the whole field of view (the beam gain holds); Pd
over SNR is the parametric Pd 1 - (1 - Pd_echo) (1 - Pfa)^n (the Swerling I test at a +0.8 dB detector gain OR a
noise peak among the n = 62 cells of the truth-matching window) within 0.025 for every waveform; 5.0 false
peaks per pair and scan at Pfa 1e-4 (4.4 noise, 0.7 static clutter); 0.007 multipath ghosts per covered target,
pair and scan, 7-33 m beyond the target; range and range-rate spread 1.0-1.25 x the pulse-train CRLB at 20-30 dB,
the reported R within 0.86-1.04 of the spread; the clutter notch fits eta = 0.06 with no extra Doppler spread.
``benchmarks/urban_signal_sensor.py``: ~300 scans/s for both pairs (3.3 ms a scan), 0.2 s of episode set-up.

Randomness and common random numbers: each scan k draws from children of the episode's streams spawned at
``new_episode`` (scan k's generators start from the same state whatever was sensed before, and if k is sensed
again): ``rcs`` the Swerling factor per
target and formed pair; ``clutter`` the static paths' phases and diffuse parts; ``signal`` the thermal noise of
every formed pair (the largest waveform's shape) and the target paths' phases (their number depends on the truth and
the RCS only). Every formed pair draws whatever the plan; only the active pairs are imaged and detected.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numba as nb
import numpy as np
import numpy.typing as npt
import scipy.stats

from uwb_env.channel.multipath import (
    PathKind,
    Paths,
    ScattererGeometry,
    gain_floor,
    scatterer_geometry,
    static_paths,
    target_paths,
)
from uwb_env.channel.radar_equation import noise_psd
from uwb_env.channel.rcs import rcs_fluctuation
from uwb_env.config import ChirpWaveformConfig, ScenarioConfig
from uwb_env.constants import SPEED_OF_LIGHT_MPS
from uwb_env.detection.delay_doppler import (
    BackgroundModel,
    DelayDopplerAxes,
    DelayDopplerDetections,
    background_model,
    detect_delay_doppler,
    detection_threshold,
    truth_origin,
)
from uwb_env.rng import RngStreams
from uwb_env.scene.truth import Truth
from uwb_env.sensing.beams import beam_weights, ml_direction
from uwb_env.sensing.parametric import (
    ParametricSensor,
    append_block,
    azimuth_variance,
    fold_range_rate,
    receiver_beams,
)
from uwb_env.sensing.protocol import register_sensor
from uwb_env.sensing.records import Detections, ScanPlan
from uwb_env.sensing.signal import chirp_chain as cc
from uwb_env.sensing.signal.model_hooks import ParametricModelHooks
from uwb_env.typing import BoolArray, FloatArray, IntArray
from uwb_env.units import db_to_linear, dbm_to_watts

ComplexArray = npt.NDArray[np.complex128]

_FLUCTUATION_SNR_FLOOR = 0.01
"""Static clutter paths whose image SNR (weakest waveform, beam centre) is below this keep one phase per episode:
their scan-to-scan residue would be 20 dB below the noise."""
_FALSE_PEAK_FACTOR = ((1e-4, 0.537), (3e-4, 0.456), (1e-3, 0.280))
"""(per-cell Pfa, false peaks per scan / (Pfa x searched cells x beams)): noise and static-clutter residue, merged
over the beams, measured on urban-intersection (``scripts/calibrate_chirp.py``, section C); it falls with Pfa as the
guard cells of nearby noise peaks suppress each other. Interpolated in log Pfa, held constant outside."""
_KL_ENERGY = 1.0 - 1e-4
"""Slow-time Karhunen-Loeve modes of the diffuse clutter kept per waveform: this fraction of its energy."""
_C = SPEED_OF_LIGHT_MPS
DOA_GRID_STEP_RAD = math.radians(0.05)
"""Grid of the ML direction search (refined between points by a parabola): 1/40 of the azimuth std at 40 dB."""
_jit = nb.njit(cache=True, fastmath=False, nogil=True)


@dataclass(frozen=True, slots=True)
class PairTrace:
    """One active pair's detections in one scan, for calibration and pictures (evaluation only).

    Attributes:
        pair: formed-pair index. waveform: library index. detections: merged over the beams, inside the gate,
        sorted by range, ``origin`` the fine truth code (target index, -1 static path, -2 ghost, -3 noise).
        beam: ``(n,)`` the beam each detection was taken from. source: ``(n,)`` the target whose path (direct or
        multipath) the detection lies on, within one resolution cell (the nearest), -1 for none. azimuth_rad:
        ``(n,)`` the ML direction of arrival [rad, global] from the beams' values at the peak cell, or None where the
        pair's receiver does not measure azimuth.
    """

    pair: int
    waveform: int
    detections: DelayDopplerDetections
    beam: IntArray
    source: IntArray
    azimuth_rad: FloatArray | None = None


@dataclass(slots=True)
class ChirpEpisode:
    """Per-episode state of the chirp signal path (:meth:`ChirpSignalSensor.new_episode`).

    Attributes:
        truth: the episode's truth. backgrounds: ``[w][pair][beam]`` the section-4.1 background models.
        thresholds: ``[w]`` ``(P, M, n_delay, n_doppler)`` per-cell thresholds on A_k.
        fixed: ``{grid key: (P, M, N)}`` spectrum (unit energy, no matched-filter weight) of the static paths whose
        phase is fixed for the episode. scan_seeds: per scan index, the seeds of its (rcs, clutter, signal)
        generators (children of the episode's streams; a scan sensed twice draws the same numbers).
        expected_false_peaks: ``(W, P)`` false peaks per scan. last_trace: the last sensed scan's traces.
    """

    truth: Truth
    backgrounds: list[list[list[BackgroundModel]]]
    thresholds: list[FloatArray]
    fixed: dict[tuple[int, float], ComplexArray]
    scan_seeds: list[tuple[np.random.SeedSequence, ...]]
    expected_false_peaks: FloatArray
    last_trace: tuple[PairTrace, ...] | None = None


@dataclass(frozen=True, slots=True)
class _PairStatics:
    """Static paths of one pair (their beam-space phasors per grid: ``ChirpSignalSensor._statics_v``, ``_fixed_v``)."""

    paths: Paths  # every kept static path (evaluation)
    fixed_index: IntArray  # indices into ``paths`` of the fixed-phase paths
    fluct_index: IntArray  # indices into ``paths`` of the fluctuating paths
    diffuse_index: IntArray  # indices into ``fluct_index`` of the paths whose diffuse part is synthesised


@dataclass(frozen=True, slots=True)
class _ScanDraws:
    """Every random number of one scan, for every formed pair (plan-independent)."""

    rcs: FloatArray  # (P, K) RCS factors
    clutter_phase: ComplexArray  # (n_fluct_total,) e^{j phi}
    diffuse: ComplexArray  # (Q, n_diffuse_total) CN(0, 1)
    noise: ComplexArray  # (P, M, B_max, N_max) CN(0, 1)
    signal: np.random.Generator  # the scan's signal generator (after the noise: the target paths' phases)


@register_sensor("signal", "chirp")
class ChirpSignalSensor(ParametricModelHooks):
    """Seed 003's chirp chain as a sensor (component tier); the parametric model is ``self.model``."""

    def __init__(self, cfg: ScenarioConfig) -> None:
        self.cfg = cfg
        sens = cfg.sensing
        self.sc = sc = sens.signal.chirp
        self.model = ParametricSensor(cfg)
        self.layout, self.library = self.model.layout, self.model.library
        self.n_tx, self.n_rx = self.model.n_tx, self.model.n_rx
        self.pairs = self.model.pairs
        lay = self.layout
        if not all(isinstance(w.config, ChirpWaveformConfig) for w in self.library.waveforms):
            raise ValueError(f"waveforms of {cfg.name!r}: the chirp signal path synthesises chirp pulse trains only")
        if sens.measure_doa and sens.array_beams != "dft":
            raise ValueError(
                f"sensing.array_beams = {sens.array_beams!r} with measure_doa = True: the chirp signal path estimates "
                "the direction from the L orthogonal beams' values at a peak; use 'dft' (or measure_doa = False)"
            )
        if sens.array_beams == "steered":
            raise ValueError(
                "sensing.array_beams = 'steered': no signal path can steer a beam at targets it does not know; "
                "use 'dft' or 'boresight'"
            )
        self.pfa = sens.false_alarm_probability
        self.baseline = lay.baselines[self.pairs[:, 0], self.pairs[:, 1]]  # (P,)
        self.gate = (self.baseline + sens.blind_zone_excess_m, 2.0 * sens.max_range_m)  # range gate [m]
        lam = self.library[0].wavelength_m
        self.wavelength = lam
        # Receive beams per pair (sensing.beams); every formed pair's receiver must form the same number.
        beams = receiver_beams(cfg, lay, self.library)
        self.beam_w: list[ComplexArray] = []
        self.elements: list[tuple[int, float, float, float]] = []  # (L, d, boresight, fov) per pair
        for r in self.pairs[:, 1].tolist():  # formed pairs: a handful
            sines, n_el, spacing, _ = beams[r]
            self.beam_w.append(np.ones((1, 1), complex) if sines is None else beam_weights(sines, n_el, spacing, lam))
            has = bool(lay.rx_has_array[r])
            self.elements.append(
                (
                    n_el,
                    spacing,
                    float(lay.rx_boresight_rad[r]) if has else 0.0,
                    float(lay.rx_fov_rad[r]) if has else 0.0,
                )
            )
        n_beams = {w.shape[0] for w in self.beam_w}
        if len(n_beams) != 1:
            raise ValueError(
                f"receivers of {cfg.name!r}: the formed pairs form {sorted(n_beams)} beams; the chirp signal path "
                "needs the same number at every receiver"
            )
        self.n_beams = n_beams.pop()
        self.noise_gain = np.array([float(np.sum(np.abs(w[0]) ** 2)) for w in self.beam_w])  # (P,) = L
        # Link constants: transmit energy per pulse, noise PSD, antenna gains.
        self.n0 = np.array([noise_psd(cfg.receivers[r].noise_figure_db) for r in self.pairs[:, 1]])  # (P,)
        p_tx = np.array([dbm_to_watts(cfg.transmitters[t].power_dbm) for t in self.pairs[:, 0]])
        self.pulse_energy = np.array(
            [p_tx * w.config.pulse_duration_s * math.sqrt(math.pi) for w in self.library.waveforms]
        )  # (W, P) [J]
        self.tx_gain = np.array([db_to_linear(cfg.transmitters[t].antenna_gain_db) for t in self.pairs[:, 0]])
        self.rx_gain = np.array([db_to_linear(cfg.receivers[r].antenna_gain_db) for r in self.pairs[:, 1]])
        # Grids per waveform over every formed pair (images from the baseline to 2 max_range_m).
        max_excess = 2.0 * sens.max_range_m - float(self.baseline.min())
        self.grids = [
            cc.chirp_grid(
                w.config,
                self.baseline,
                max_excess,
                sample_rate_factor=sc.sample_rate_factor,
                delay_oversample=sc.delay_oversample,
                doppler_oversample=sc.doppler_oversample,
            )
            for w in self.library.waveforms
        ]
        self._grid_key = [(g.n_fft, g.sample_rate_hz) for g in self.grids]
        self.max_peaks = peak_caps(self.grids, sc.max_peaks, sc.scale_max_peaks)  # (W,) per beam image
        # each train's matched second moments M_0 (band-limited): the sandwich R of walked peaks (delay_doppler)
        self._matched = [cc.pulse_train_information(g) for g in self.grids]
        self._n_max = max(g.n_fft for g in self.grids)
        self._b_max = max(g.n_pulses for g in self.grids)
        # Paths: floors on the weakest waveform's energy; the longest path any image can hold.
        e_min = float(self.pulse_energy.min())
        b_min = min(g.n_pulses for g in self.grids)
        n0_max = float(self.n0.max())
        self._max_length = 2.0 * sens.max_range_m + _C * max(g.guard_s for g in self.grids)
        self._target_floor = gain_floor(sc.target_snr_floor, n0_max, e_min, b_min, self._max_elements())
        self._geoms: list[ScattererGeometry] = []
        self._statics: list[_PairStatics] = []
        self._statics_v: dict[tuple[int, float], list[ComplexArray]] = {}
        self._fixed_v: dict[tuple[int, float], list[ComplexArray]] = {}
        self._build_static_paths(e_min, b_min)
        self._kl = [self._diffuse_basis(g) for g in self.grids]  # (B, Q) per waveform
        self._q = max(u.shape[1] for u in self._kl)
        self._kl = [np.pad(u, ((0, 0), (0, self._q - u.shape[1]))) for u in self._kl]
        self._fluct_start = np.concatenate([[0], np.cumsum([len(s.fluct_index) for s in self._statics])])
        self._diffuse_start = np.concatenate([[0], np.cumsum([len(s.diffuse_index) for s in self._statics])])
        self.searched_cells = np.stack([self._searched_cells(g) for g in self.grids])  # (W, P) per beam
        unit = [w.unit_covariance for w in self.library.waveforms]
        self._correlation = np.array([u[0, 1] / math.sqrt(u[0, 0] * u[1, 1]) for u in unit])  # (W,)
        # Direction finding (measure_doa): per pair whose receiver measures azimuth, a global-azimuth grid over the
        # field of view and the beams' responses on it (beams.ml_direction); None for the others.
        self._doa_grids: list[tuple[FloatArray, ComplexArray] | None] = []
        for q, r in enumerate(self.pairs[:, 1].tolist()):  # formed pairs: a handful
            if "azimuth" not in self.model.measurement_names(r):
                self._doa_grids.append(None)
                continue
            _, _, bore, fov = self.elements[q]
            grid_rad = bore + np.linspace(-fov, fov, int(np.ceil(2.0 * fov / DOA_GRID_STEP_RAD)) + 1)
            self._doa_grids.append((grid_rad, self._beam_phasors(q, grid_rad)))

    # ------------------------------------------------------------------------------------------------ set-up
    def _max_elements(self) -> int:
        return max(e[0] for e in self.elements)

    def _sector(self, q: int, doa: FloatArray) -> BoolArray:
        """``(n,)`` paths of pair ``q`` arriving inside the receiver's field of view (all without an array)."""
        _, _, bore, fov = self.elements[q]
        if fov <= 0.0:
            return np.ones(np.shape(doa), dtype=bool)
        return np.abs(np.angle(np.exp(1j * (np.asarray(doa) - bore)))) <= fov

    def _beam_phasors(self, q: int, doa: FloatArray) -> ComplexArray:
        """``(n, M)`` beam responses of pair ``q``'s receiver to unit plane waves from ``doa`` (n,) [rad]."""
        n_el, spacing, bore, _ = self.elements[q]
        if n_el <= 1:
            return np.ones((np.shape(doa)[0], 1), complex)
        ph = cc.element_phases(doa, bore, n_el, spacing, self.wavelength)  # (n, L)
        return ph @ self.beam_w[q].conj().T

    def _build_static_paths(self, e_min: float, b_min: int) -> None:
        """Static paths per pair, split into fixed-phase and fluctuating ones, and their beam-space spectra."""
        lay, cl = self.layout, self.cfg.sensing.clutter
        opaque = ~np.isfinite(lay.wall_loss_db)
        wa, wb = lay.wall_start[opaque], lay.wall_end[opaque]
        points = lay.clutter_points if cl.scatterer_rcs_m2 > 0.0 else np.zeros((0, 2))
        sc = self.sc
        for q, (t, r) in enumerate(self.pairs.tolist()):  # formed pairs: a handful
            geom = scatterer_geometry(lay.tx_pos[t], lay.rx_pos[r], points, cl.scatterer_rcs_m2, wa, wb)
            self._geoms.append(geom)
            sp = static_paths(
                geom,
                wavelength_m=self.wavelength,
                tx_gain=float(self.tx_gain[q]),
                rx_gain=float(self.rx_gain[q]),
                max_bounces=sc.max_bounces,
                min_gain=gain_floor(sc.static_snr_floor, float(self.n0[q]), e_min, b_min, 1),
                max_length_m=self._max_length,
            )
            sp = sp.select(self._sector(q, sp.doa_rad))
            snr = sp.gain * e_min * b_min / float(self.n0[q]) * self.elements[q][0]  # image SNR, beam centre
            fluct = (sp.kind != PathKind.DIRECT) & (snr >= _FLUCTUATION_SNR_FLOOR)
            diffuse = np.flatnonzero(sc.clutter_diffuse_fraction * snr[fluct] >= _FLUCTUATION_SNR_FLOOR)
            self._statics.append(_PairStatics(sp, np.flatnonzero(~fluct), np.flatnonzero(fluct), diffuse))
        for key in sorted(set(self._grid_key)):  # distinct (N, fs): one or two
            g = self.grids[self._grid_key.index(key)]
            fl, fx = [], []
            for q, st in enumerate(self._statics):  # formed pairs: a handful
                v = self._path_phasors(g, q, st.paths)  # (n, M, N)
                fl.append(v[st.fluct_index])
                fx.append(v[st.fixed_index])
            self._statics_v[key], self._fixed_v[key] = fl, fx

    def _path_phasors(self, grid: cc.ChirpGrid, q: int, paths: Paths) -> ComplexArray:
        """``(n, M, N)`` sqrt(gain) x beam response x e^{-j 2 pi f_k (L / c - tau_0)} of static paths of pair ``q``."""
        tau = paths.length_m / _C - grid.window_start_s[q]
        keep = cc.keep_in_window(grid, np.full(len(paths), q), paths.length_m)
        amp = np.sqrt(paths.gain) * keep  # paths beyond the window (+- guard / 2) are not synthesised
        phase = np.exp(-2j * math.pi * tau[:, None] * grid.freq_hz[None, :])  # (n, N)
        return (amp[:, None] * self._beam_phasors(q, paths.doa_rad))[:, :, None] * phase[:, None, :]

    def _diffuse_basis(self, grid: cc.ChirpGrid) -> FloatArray:
        """``(B, Q)`` slow-time KL basis (columns scaled by sqrt(eigenvalue)) of the diffuse clutter's correlation.

        Gaussian Doppler spectrum of standard deviation s: E[c_b c*_b'] = exp(-2 pi^2 s^2 T1^2 (b - b')^2).
        """
        b = np.arange(grid.n_pulses)
        s = self.sc.clutter_doppler_spread_hz
        corr = np.exp(-2.0 * (math.pi * s * grid.pri_s) ** 2 * (b[:, None] - b[None, :]) ** 2)
        val, vec = np.linalg.eigh(corr)
        val, vec = np.clip(val[::-1], 0.0, None), vec[:, ::-1]
        q = int(np.searchsorted(np.cumsum(val) / val.sum(), _KL_ENERGY) + 1)
        return vec[:, :q] * np.sqrt(val[:q])

    def _searched_cells(self, grid: cc.ChirpGrid) -> FloatArray:
        """``(P,)`` image cells (rows in the gate x Doppler columns) the detector searches per beam."""
        rng = _C * grid.delay_axis_s()  # (P, n_delay)
        rows = (rng >= self.gate[0][:, None]) & (rng <= self.gate[1])
        rows[:, :1] = rows[:, -1:] = False  # the fit's half-window at the edges
        return rows.sum(axis=1) * grid.n_doppler

    # ------------------------------------------------------------------------------------------------ episode
    def new_episode(self, truth: Truth, rngs: RngStreams) -> ChirpEpisode:
        """Spawn the per-scan generators; fixed static phases; J background scans per waveform; thresholds."""
        n = truth.states.shape[0]
        rcs_g = rngs.rcs.spawn(n)
        clutter_g = rngs.clutter.spawn(n + 1)
        signal_g = rngs.signal.spawn(n + 1)
        bg_clutter, bg_signal = clutter_g[0], signal_g[0]
        P, M = self.pairs.shape[0], self.n_beams
        # Fixed-phase static paths: one random phase each for the episode (seed 003 eq. 2).
        fixed = {}
        phases = [np.exp(1j * bg_clutter.uniform(-math.pi, math.pi, len(s.fixed_index))) for s in self._statics]
        for key, vs in self._fixed_v.items():  # distinct grids: one or two
            fixed[key] = np.stack([np.tensordot(ph, v, axes=(0, 0)) for ph, v in zip(phases, vs, strict=True)])
        backgrounds, thresholds = [], []
        for w, grid in enumerate(self.grids):  # the library: a small fixed set
            J = self.sc.background_scans
            draws = [self._draw(bg_clutter, bg_signal, None) for _ in range(J)]
            z = np.stack([self._clutter_spectra(w, fixed, d, np.arange(P)) for d in draws])  # (J, P, M, B, N)
            mag = np.abs(cc.delay_doppler_images(grid, z))  # (J, P, M, D, F)
            noise = cc.image_noise_power(grid, self.n0, self.noise_gain)  # (P,)
            bgs = [[background_model(mag[:, q, m], noise_power=float(noise[q])) for m in range(M)] for q in range(P)]
            backgrounds.append(bgs)
            threshold = _THRESHOLDS[self.sc.threshold]
            thresholds.append(
                np.stack([[threshold(mag[:, q, m], bgs[q][m], self.pfa) for m in range(M)] for q in range(P)])
            )
        false_peaks = false_peak_factor(self.pfa) * self.pfa * self.searched_cells * M  # (W, P)
        return ChirpEpisode(
            truth=truth,
            backgrounds=backgrounds,
            thresholds=thresholds,
            fixed=fixed,
            scan_seeds=[
                tuple(g.bit_generator.seed_seq for g in gens)
                for gens in zip(rcs_g, clutter_g[1:], signal_g[1:], strict=True)
            ],
            expected_false_peaks=false_peaks,
        )

    # ------------------------------------------------------------------------------------------------ draws
    def _draw(
        self, clutter: np.random.Generator, signal: np.random.Generator, rcs: np.random.Generator | None
    ) -> _ScanDraws:
        """All plan-independent draws of one scan, for every formed pair, in a fixed order."""
        P, M, K = self.pairs.shape[0], self.n_beams, len(self.cfg.targets)
        fl = rcs_fluctuation(self.model.swerling, (P,), rcs, self.model._swerling_w) if rcs is not None else None
        n_f = int(self._fluct_start[-1])
        phase = np.exp(1j * clutter.uniform(-math.pi, math.pi, n_f))
        n_d = int(self._diffuse_start[-1])
        diffuse = clutter.standard_normal((self._q, n_d, 2)).view(complex)[..., 0] * math.sqrt(0.5)
        noise = signal.standard_normal((P, M, self._b_max, self._n_max, 2)).view(complex)[..., 0] * math.sqrt(0.5)
        return _ScanDraws(fl if fl is not None else np.ones((P, K)), phase, diffuse, noise, signal)

    # ------------------------------------------------------------------------------------------------ synthesis
    def _clutter_spectra(
        self, w: int, fixed: dict[tuple[int, float], ComplexArray], draws: _ScanDraws, pairs: IntArray
    ) -> ComplexArray:
        """``(len(pairs), M, B, N)`` matched-filtered spectra of the static paths plus thermal noise (compiled)."""
        grid = self.grids[w]
        key = self._grid_key[w]
        B, N, M = grid.n_pulses, grid.n_fft, self.n_beams
        eta = self.sc.clutter_diffuse_fraction
        out = np.empty((len(pairs), M, B, N), dtype=complex)
        for i, q in enumerate(pairs.tolist()):  # active pairs: a handful
            a, b = self._fluct_start[q], self._fluct_start[q + 1]
            c, d = self._diffuse_start[q], self._diffuse_start[q + 1]
            _clutter_pair(
                out[i],
                fixed[key][q],
                self._statics_v[key][q],
                draws.clutter_phase[a:b],
                math.sqrt(1.0 - eta),
                self._statics[q].diffuse_index,
                draws.diffuse[:, c:d],
                self._kl[w],
                math.sqrt(eta),
                math.sqrt(self.pulse_energy[w, q]) * grid.mf_weight,
                math.sqrt(grid.n_fft * self.n0[q] / grid.sample_rate_hz * self.noise_gain[q]) * grid.spectrum.conj(),
                draws.noise[q, :, :B, :N],
            )
        return out

    def _target_paths(self, k: int, truth: Truth, rcs_factor: FloatArray) -> list[Paths]:
        """Per formed pair, the paths through the targets alive at scan ``k`` (target = global index), in view."""
        alive = np.flatnonzero(truth.alive[k])
        out = []
        if alive.size == 0:
            return [Paths.empty() for _ in range(self.pairs.shape[0])]
        state = truth.states[k][alive]
        pos, vel = state[:, [0, 2]], state[:, [1, 3]]
        rcs = self.model.rcs_mean[alive] * rcs_factor[:, alive]  # (P, K_alive)
        for q in range(self.pairs.shape[0]):  # formed pairs: a handful
            p = target_paths(
                self._geoms[q],
                pos,
                vel,
                rcs[q],
                wavelength_m=self.wavelength,
                tx_gain=float(self.tx_gain[q]),
                rx_gain=float(self.rx_gain[q]),
                max_bounces=self.sc.max_bounces,
                min_gain=self._target_floor,
                max_length_m=self._max_length,
            )
            p = p.select(self._sector(q, p.doa_rad))
            out.append(Paths(p.length_m, p.range_rate_mps, p.doa_rad, p.gain, alive[p.target], p.kind, p.scatterer))
        return out

    def _spectra(
        self,
        w: int,
        fixed: dict[tuple[int, float], ComplexArray],
        draws: _ScanDraws,
        moving: list[Paths],
        phi: FloatArray,
        active: IntArray,
    ) -> ComplexArray:
        """``(A, M, B, N)`` spectra of the active pairs: static paths, noise and the moving paths ``moving``.

        ``phi``: the random phases of every formed pair's moving paths, concatenated (drawn once per scan).
        """
        grid = self.grids[w]
        z = self._clutter_spectra(w, fixed, draws, active)
        counts = [len(p) for p in moving]
        starts = np.concatenate([[0], np.cumsum(counts)])
        sel = [q for q in active.tolist() if counts[q]]
        if not sel:
            return z
        amp = np.concatenate(
            [
                (np.sqrt(self.pulse_energy[w, q] * moving[q].gain) * np.exp(1j * phi[starts[q] : starts[q + 1]]))[
                    :, None
                ]
                * self._beam_phasors(q, moving[q].doa_rad)
                for q in sel
            ]
        )
        row = np.full(self.pairs.shape[0], -1)
        row[active] = np.arange(active.size)
        idx = np.concatenate([np.full(counts[q], row[q]) for q in sel])
        length = np.concatenate([moving[q].length_m for q in sel])
        rdot = np.concatenate([moving[q].range_rate_mps for q in sel])
        sub = _sub_grid(grid, active)
        z += cc.matched_filter_spectra(
            sub, idx, length, rdot, amp, static=None, noise_psd_w_per_hz=0.0, noise_gain=np.ones(1), rng=draws.signal
        )
        return z

    # ------------------------------------------------------------------------------------------------ detection
    def _detect(
        self, episode: ChirpEpisode, w: int, spectra: ComplexArray, active: IntArray, paths: list[Paths]
    ) -> tuple[PairTrace, ...]:
        """Images, section-4.1 detection per beam, merge over the beams, gate, truth origin; one trace per pair."""
        grid = self.grids[w]
        images = cc.delay_doppler_images(grid, spectra)  # (A, M, D, F) complex
        mag = np.abs(images)
        out = []
        for i, q in enumerate(active.tolist()):  # active pairs: a handful
            axes = grid.axes(q)
            per_beam = [
                detect_delay_doppler(
                    mag[i, m],
                    episode.backgrounds[w][q][m],
                    axes,
                    threshold=episode.thresholds[w][q, m],
                    max_peaks=int(self.max_peaks[w]),
                    matched=self._matched[w],
                )
                for m in range(self.n_beams)  # beams: L, a handful
            ]
            det, beam = _merge_beams(per_beam, axes.guard_cells, grid.n_doppler)
            keep = (det.range_m >= self.gate[0][q]) & (det.range_m <= self.gate[1])
            det, beam = _select(det, keep), beam[keep]
            order = np.argsort(det.range_m, kind="stable")
            det, beam = _select(det, order), beam[order]
            static = self._statics[q].paths
            p = paths[q]
            det.origin = truth_origin(
                det.range_m,
                det.range_rate_mps,
                np.concatenate([static.length_m, p.length_m]),
                np.concatenate([static.range_rate_mps, p.range_rate_mps]),
                np.concatenate([static.target, p.target]),
                np.concatenate([static.kind, p.kind]) == PathKind.TARGET,
                axes,
            )
            doa = self._doa_grids[q]
            azimuth = None if doa is None else ml_direction(images[i][:, det.row, det.col].T, doa[1], doa[0])
            out.append(PairTrace(q, w, det, beam, _source_target(det, p, axes), azimuth))
        return tuple(out)

    # ------------------------------------------------------------------------------------------------ a scan
    def scan(self, episode: ChirpEpisode, k: int, plan: ScanPlan) -> tuple[PairTrace, ...]:
        """Scan ``k`` with ``plan``: every formed pair's draws, the active pairs' images and detections."""
        plan.validate(self.n_tx, self.n_rx, len(self.library))
        active = np.flatnonzero(plan.active_rx[self.pairs[:, 1]])
        r_rcs, r_cl, r_sig = (np.random.default_rng(seq) for seq in episode.scan_seeds[k])
        draws = self._draw(r_cl, r_sig, r_rcs)
        moving = self._target_paths(k, episode.truth, draws.rcs)
        phi = r_sig.uniform(-math.pi, math.pi, sum(len(p) for p in moving))  # every formed pair's target paths
        traces: list[PairTrace] = []
        for w in sorted(set(plan.waveform[self.pairs[active, 0]].tolist())):  # one waveform per transmitter
            sel = active[plan.waveform[self.pairs[active, 0]] == w]
            spectra = self._spectra(w, episode.fixed, draws, moving, phi, sel)
            traces += self._detect(episode, w, spectra, sel, moving)
        traces.sort(key=lambda t: t.pair)
        return tuple(traces)

    def sense(self, episode: ChirpEpisode, k: int, plan: ScanPlan, time_s: float = 0.0) -> tuple[Detections, ...]:
        """Detections of every active formed pair in scan ``k`` (module docstring); the traces go to the episode."""
        traces = self.scan(episode, k, plan)
        episode.last_trace = traces
        return tuple(self._record(episode, tr, time_s) for tr in traces)

    def _record(self, episode: ChirpEpisode, tr: PairTrace, time_s: float) -> Detections:
        """One pair's :class:`Detections` from its trace."""
        t, r = (int(v) for v in self.pairs[tr.pair])
        det, w = tr.detections, tr.waveform
        period = float(self.model.range_rate_period[w])
        lam_fp = float(episode.expected_false_peaks[w, tr.pair])
        density = lam_fp / ((self.gate[1] - self.gate[0][tr.pair]) * period)
        n = len(det)
        z = np.stack([det.range_m, fold_range_rate(det.range_rate_mps, period)], axis=1)
        R = self.covariance(det.R, w)
        if tr.azimuth_rad is not None:
            z, R, density = self._with_azimuth(tr, z, R, density)
        return Detections(
            tx=t,
            rx=r,
            waveform=w,
            time_s=time_s,
            z=z,
            R=R,
            snr=det.snr,
            origin=np.where(det.origin >= 0, det.origin, -1),
            measurement_names=self.model.measurement_names(r),
            clutter_intensity=np.full(n, density),
            expected_false_alarms=lam_fp,
            range_rate_period_mps=period,
        )

    def _with_azimuth(
        self, tr: PairTrace, z: FloatArray, R: FloatArray, density: float
    ) -> tuple[FloatArray, FloatArray, float]:
        """Append the ML azimuth to ``z`` ``(n, 2)``, its variance to ``R`` ``(n, 2, 2)``, and spread the density.

        The variance is the parametric model's (``parametric.azimuth_variance`` at the peak's fitted SNR, the
        detecting beam's), scaled like the range by the accuracy floor (:meth:`covariance`). The ML direction uses
        every beam and reaches the CRLB at the array's SNR, which is the beam's / its gain g: at a beam centre the
        two agree; off it this variance is 1 / g too large (up to 2.25 midway between the DFT beams), as the
        parametric model's draws are -- conservative and the same at both fidelities (tests/unit/test_chirp_sensor.py).
        False peaks are taken as uniform in azimuth over the field of view: the clutter density per m x m/s is
        divided by its width.
        """
        q = tr.pair
        n_el, spacing, bore, fov = self.elements[q]
        az = tr.azimuth_rad
        off = np.angle(np.exp(1j * (az - bore)))
        var = azimuth_variance(np.maximum(tr.detections.snr, 1e-12), n_el, spacing, self.wavelength, off)
        var = var * self._floor_scale(tr.detections.R)
        return np.column_stack([z, np.angle(np.exp(1j * az))]), append_block(R, var), density / (2.0 * fov)

    def covariance(self, R: FloatArray, w: int) -> FloatArray:
        """``(n, 2, 2)`` the fitted variances with the waveform's range-range-rate correlation (module docstring).

        Both variances are scaled up together where the range std is below ``SensingConfig.min_range_std_m``: the
        parametric model's accuracy floor (``uwb_env.sensing.parametric.accuracy_snr_caps``) at the fitted SNR.
        """
        out = R * self._floor_scale(R)[:, None, None]
        c = self._correlation[w] * np.sqrt(out[:, 0, 0] * out[:, 1, 1])
        out[:, 0, 1] = out[:, 1, 0] = c
        return out

    def _floor_scale(self, R: FloatArray) -> FloatArray:
        """``(n,)`` the factor lifting each fitted range variance of ``R`` ``(n, 2, 2)`` to the accuracy floor."""
        floor = self.cfg.sensing.min_range_std_m**2
        return np.maximum(1.0, floor / np.maximum(R[:, 0, 0], 1e-300))

    # ------------------------------------------------------------------------------------------------ calibration
    def controlled_scan(
        self,
        episode: ChirpEpisode,
        waveform: int,
        pair: int,
        length_m: FloatArray,
        range_rate_mps: FloatArray,
        doa_rad: FloatArray,
        snr: FloatArray,
        *,
        rng: np.random.Generator,
    ) -> PairTrace:
        """Calibration input: one scan of ``pair`` with point echoes (tx-target-rx paths) of chosen image SNR.

        ``length_m``, ``range_rate_mps``, ``doa_rad``, ``snr`` ``(K,)``: bistatic range [m], range-rate [m/s],
        direction of arrival [rad] and the echo's SNR at the parametric model's definition (E/N0 of the scan x L x
        the beam gain at ``doa_rad``: what ``ParametricSensor`` computes for that echo; Swerling factors are the
        caller's). The static clutter, its fluctuation, the noise and the echo phases are drawn from ``rng``.
        """
        length_m, rdot, doa, snr = (np.atleast_1d(np.asarray(a, dtype=float)) for a in (length_m, range_rate_mps,
                                                                                         doa_rad, snr))  # fmt: skip
        grid = self.grids[waveform]
        n_el = self.elements[pair][0]
        _, gains_m = self._beam_gain(pair, doa)
        gain = snr * self.n0[pair] / (self.pulse_energy[waveform, pair] * grid.n_pulses * n_el * gains_m)
        k = length_m.shape[0]
        moving = [Paths.empty() for _ in range(self.pairs.shape[0])]
        moving[pair] = Paths(
            length_m, rdot, doa, gain, np.arange(k), np.full(k, int(PathKind.TARGET)), -np.ones((k, 2), dtype=np.int64)
        )
        draws = self._draw(rng, rng, None)
        active = np.array([pair])
        phi = rng.uniform(-math.pi, math.pi, k)
        spectra = self._spectra(waveform, episode.fixed, draws, moving, phi, active)
        return self._detect(episode, waveform, spectra, active, moving)[0]

    def _beam_gain(self, q: int, doa: FloatArray) -> tuple[ComplexArray, FloatArray]:
        """Beam responses ``(n, M)`` and the best beam's g = max_m |AF_m|^2 / L^2 ``(n,)`` of pair ``q``."""
        ph = self._beam_phasors(q, doa)
        n_el = self.elements[q][0]
        return ph, (np.abs(ph) ** 2).max(axis=1) / n_el**2


def _sub_grid(grid: cc.ChirpGrid, pairs: IntArray) -> cc.ChirpGrid:
    """The grid restricted to ``pairs`` (their window starts), for synthesising the active pairs only."""
    if pairs.size == grid.n_pairs and np.array_equal(pairs, np.arange(grid.n_pairs)):
        return grid
    return replace(grid, window_start_s=grid.window_start_s[pairs])


def peak_caps(grids: list[cc.ChirpGrid], max_peaks: int, scale: bool = True) -> IntArray:
    """``(W,)`` the most peaks per beam image of each waveform (``ChirpSignalConfig.scale_max_peaks``).

    ``max_peaks`` holds for the smallest image (delay rows x Doppler columns) of the library's narrowest bandwidth,
    the reference; every image gets max(``max_peaks``, round(``max_peaks`` x its cells / the reference's cells)):
    one cap per image cell, so that a wider band's image, with more delay rows and as many more noise peaks at the
    same per-cell Pfa, is not truncated harder than the reference's. ``scale`` False: ``max_peaks`` for every image.
    """
    cells = np.array([g.n_delay * g.n_doppler for g in grids], dtype=float)
    band = np.array([g.bandwidth_hz for g in grids])
    if not scale:
        return np.full(len(grids), max_peaks, dtype=np.int64)
    ref = float(cells[band == band.min()].min())
    return np.maximum(max_peaks, np.round(max_peaks * cells / ref)).astype(np.int64)


def false_peak_factor(pfa: float) -> float:
    """False peaks per scan / (Pfa x searched cells x beams) at per-cell ``pfa`` (:data:`_FALSE_PEAK_FACTOR`)."""
    x, y = zip(*_FALSE_PEAK_FACTOR, strict=True)
    return float(np.interp(math.log(pfa), np.log(x), y))


def rice_threshold(images: FloatArray, background: BackgroundModel, pfa: float) -> FloatArray:
    """The detector's per-cell threshold on A_k for static returns of constant amplitude (``detection_threshold``)."""
    del images
    return detection_threshold(background, pfa)


def clutter_map_threshold(images: FloatArray, background: BackgroundModel, pfa: float) -> FloatArray:
    """Per-cell threshold on A_k that also adapts to the fluctuation measured over the J background images.

    A cell consistent with noise (the gate of ``delay_doppler.detection_threshold``) keeps the exact noise
    threshold. Elsewhere T = max(T_Rice, t_{J-1}^{-1}(1 - Pfa) sqrt(s^2 (1 + 1 / J))), s^2 the sample variance of
    |A_j| over the J images: the clutter-map CFAR of a fluctuating return (foliage), A_k = |A| - A_bar taken as
    Student-t with J - 1 degrees of freedom. A target in such a cell needs the residue's margin: the clutter notch.

    Args:
        images: ``(J, n_delay, n_doppler)`` background magnitudes; background: their :class:`BackgroundModel`;
        pfa: per-cell false-alarm probability.
    """
    j = images.shape[0]
    rice = detection_threshold(background, pfa)
    sigma = math.sqrt(background.noise_power)
    gate = sigma * (0.5 * math.sqrt(math.pi) + 2.0 * math.sqrt((1.0 - math.pi / 4.0) / j))
    spread = float(scipy.stats.t.isf(pfa, j - 1)) * np.sqrt(images.var(axis=0, ddof=1) * (1.0 + 1.0 / j))
    return np.where(background.mean_magnitude <= gate, rice, np.maximum(rice, spread))


_THRESHOLDS = {"rice": rice_threshold, "clutter_map": clutter_map_threshold}
"""``ChirpSignalConfig.threshold``: the per-cell threshold of the section-4.1 detector."""


def _source_target(det: DelayDopplerDetections, paths: Paths, axes: DelayDopplerAxes) -> IntArray:
    """``(n,)`` target of the nearest target path (direct or multipath) within one resolution cell, else -1."""
    if len(paths) == 0 or len(det) == 0:
        return np.full(len(det), -1, dtype=np.int64)
    span = axes.wavelength_m * axes.doppler_span_hz
    dr = (det.range_m[:, None] - paths.length_m[None, :]) / (_C * axes.delay_resolution_s)
    dv = det.range_rate_mps[:, None] - paths.range_rate_mps[None, :]
    dv = (np.mod(dv + 0.5 * span, span) - 0.5 * span) / (axes.wavelength_m * axes.doppler_resolution_hz)
    dist = np.where((np.abs(dr) <= 1.0) & (np.abs(dv) <= 1.0), dr * dr + dv * dv, np.inf)
    best = np.argmin(dist, axis=1)
    return np.where(np.isfinite(dist[np.arange(len(det)), best]), paths.target[best], -1)


def _select(det: DelayDopplerDetections, idx: BoolArray | IntArray) -> DelayDopplerDetections:
    """The detections picked by a mask or an index array."""
    return DelayDopplerDetections(
        det.range_m[idx],
        det.range_rate_mps[idx],
        det.R[idx],
        det.snr[idx],
        det.delay_s[idx],
        det.doppler_hz[idx],
        det.row[idx],
        det.col[idx],
        det.origin[idx],
    )


def _merge_beams(
    per_beam: list[DelayDopplerDetections], guard: tuple[int, int], n_doppler: int
) -> tuple[DelayDopplerDetections, IntArray]:
    """One cell's detections over the beams -> the strongest (non-maximum suppression within one resolution cell).

    All beams share the image grid, so cells compare by (row, column); columns wrap (Doppler is periodic).
    """
    beam = np.concatenate([np.full(len(d), m, dtype=np.int64) for m, d in enumerate(per_beam)])
    det = DelayDopplerDetections(
        *(np.concatenate([getattr(d, f) for d in per_beam]) for f in DelayDopplerDetections.__slots__)
    )
    n = len(det)
    if n <= 1 or len(per_beam) == 1:
        return det, beam
    dr = np.abs(det.row[:, None] - det.row[None, :])
    dc = np.abs(det.col[:, None] - det.col[None, :])
    dc = np.minimum(dc, n_doppler - dc)
    near = (dr <= guard[0]) & (dc <= guard[1]) & (beam[:, None] != beam[None, :])
    idx = np.arange(n)
    tie = (det.snr[None, :] == det.snr[:, None]) & (idx[None] < idx[:, None])
    stronger = (det.snr[None, :] > det.snr[:, None]) | tie
    keep = ~(near & stronger).any(axis=1)
    return _select(det, keep), beam[keep]


@_jit
def _clutter_pair(
    out, fixed, v, phase, steady_scale, diffuse_index, coef, kl, diffuse_scale, amp_mf, noise_mf, noise
):  # pragma: no cover - compiled
    """One pair's static-path and noise spectra, ``out`` ``(M, B, N)`` (module docstring, static clutter).

    out[m, b, n] = amp_mf[n] (fixed[m, n] + steady_scale sum_p phase_p v[p, m, n]
                              + diffuse_scale sum_q kl[b, q] sum_i coef[q, i] phase_p(i) v[p(i), m, n])
                   + noise_mf[n] noise[m, b, n],    p(i) = diffuse_index[i].

    fixed ``(M, N)``: fixed-phase paths; v ``(P, M, N)``: the fluctuating paths' unit phasors; phase ``(P,)``: their
    scan phases; coef ``(Q, D)``: CN(0, 1) slow-time KL coefficients of the diffuse parts; kl ``(B, Q)``: the KL basis
    x sqrt(eigenvalues); amp_mf ``(N,)``: sqrt(E_pulse) |S_k|^2; noise_mf ``(N,)``: noise scale x conj(S_k).
    """
    n_p, n_m, n_n = v.shape
    n_b, n_q = kl.shape
    steady = fixed.copy()
    for p in range(n_p):
        c = steady_scale * phase[p]
        for m in range(n_m):
            for n in range(n_n):
                steady[m, n] += c * v[p, m, n]
    x = np.zeros((n_q, n_m, n_n), dtype=np.complex128)
    for i in range(diffuse_index.shape[0]):
        p = diffuse_index[i]
        for q in range(n_q):
            c = diffuse_scale * coef[q, i] * phase[p]
            for m in range(n_m):
                for n in range(n_n):
                    x[q, m, n] += c * v[p, m, n]
    for m in range(n_m):
        for b in range(n_b):
            for n in range(n_n):
                acc = steady[m, n]
                for q in range(n_q):
                    acc += kl[b, q] * x[q, m, n]
                out[m, b, n] = amp_mf[n] * acc + noise_mf[n] * noise[m, b, n]
