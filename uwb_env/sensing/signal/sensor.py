r"""Signal-level sensing: synthesised scans through seed 000's in-sensor and network chains (``fidelity="signal"``).

One scan, for the pairs the plan activates:

1. synthesis (:mod:`uwb_env.sensing.signal.synthesis`): the room's static background (direct path and seed 002's
   exponential multipath, fixed by ``signal.background_seed``) with slowly fluctuating amplitudes, shadowed where a
   target stands on a path's legs; the targets' echoes at their bistatic delays with radar-equation amplitudes,
   Swerling RCS and random carrier phase (``signal.target_model = "extended"``: a walking person's six scattering
   centres, each at its own delay with its own share of the RCS, Swerling factor and phase, :mod:`uwb_env.scene.
   extended`); the scan's timing jitter; unit AWGN (after pulse integration);
2. in-sensor chain (:mod:`uwb_env.detection`): envelope, direct-path ToA, alignment onto the reference (empty room or
   exponential-averaging background), rectified difference, blind zone, CFAR, 1-D clustering -> ToAs and weights;
   or, with ``signal.toa_estimator = "energy-detector"``, seed 002's energy detector on the coherent difference
   (:mod:`uwb_env.detection.energy_detector`): at most one ToA per pair, the first T_int energy bin above the
   threshold;
3. network chain (:mod:`uwb_env.localization`): nu-tuple ellipse intersection, weight / residual filtering, 2-D
   clustering -> one :class:`Detections` record of 2-D positions (``measurement_names = ("x", "y")``, ``rx = -1``).

Every random draw is made for every formed pair, whatever the plan, so the streams never depend on the actions
(common random numbers). The parametric sensor of the same scenario (``self.model``) supplies the geometry, the
radar constants and the sensor model a tracker or lookahead uses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from uwb_env.channel.rcs import rcs_fluctuation
from uwb_env.config import ScenarioConfig
from uwb_env.constants import SPEED_OF_LIGHT_MPS
from uwb_env.detection import (
    align_to_reference,
    direct_path_toa,
    exponential_background,
    fractional_shift,
    hmm,
    parabolic_peak,
    rectified_difference,
    square_law_envelope,
)
from uwb_env.detection.clutter_map import ClutterMap
from uwb_env.detection.energy_detector import (
    accumulated_noise_energy,
    bin_energies,
    energy_detector_toa,
    noise_energy_threshold,
    valid_extremes,
    zonal_bandpass,
    zonal_noise_variance,
)
from uwb_env.detection.registry import NORMALIZATIONS, cfar_detector, toa_estimator
from uwb_env.detection.toa_association import all_couples, associate_toas
from uwb_env.localization import locate
from uwb_env.localization.couples import array_frame, compensate_walls, couple_covariance, couple_positions
from uwb_env.rng import RngStreams
from uwb_env.scene import extended
from uwb_env.scene.truth import Truth
from uwb_env.sensing.parametric import EpisodeGeometry, ParametricSensor
from uwb_env.sensing.protocol import register_sensor
from uwb_env.sensing.records import Detections, ScanPlan
from uwb_env.sensing.signal.model_hooks import ParametricModelHooks
from uwb_env.sensing.signal.synthesis import (
    ar1_step,
    exponential_profile,
    points_on_ellipse,
    pulse_envelope_std_s,
    segment_distance,
    unit_pulses,
)
from uwb_env.typing import BoolArray, FloatArray, IntArray
from uwb_env.units import db_to_linear
from uwb_env.waveforms.impulse import ImpulseWaveform
from uwb_env.waveforms.toa_models import energy_detector_toa_std

ORIGIN_TOLERANCE_M = 0.3  # a ToA within this bistatic range of a target's echo is attributed to it (evaluation only)
_POSITION_NAMES = ("x", "y")


STILL_SAMPLES = 1.5
"""Step 6's stillness bound of the ToA association in samples of the chain's clock (``toa_association.STILL_S`` is
1.5 samples of seed 001's 4.5 GHz M-sequence clock): an interval ToA sits on the sample grid and a motionless echo's
interval start flickers by one sample."""


@dataclass(slots=True)
class SignalEpisode:
    """Per-episode state of the signal path: geometry, the empty-room references, the clutter and background state."""

    geom: EpisodeGeometry
    truth: Truth
    rngs: RngStreams
    fluctuation: FloatArray  # (P, L) AR(1) relative amplitude fluctuation of the background paths
    reference: FloatArray  # (W, P, N) reference envelopes (empty room, or the exponential background)
    reference_scan: FloatArray  # (W, P, N) the empty room's averaged raw scans (the coherent background)
    reference_toa: FloatArray  # (W, P) direct-path ToA of the references [samples]
    reference_peak: FloatArray  # (W, P) direct-path peak of the references [samples] (time origin of the ranges)
    ed_uniform: FloatArray | None = None  # (P, bins) the scan's draws of the ED's pulse-accumulation noise, or None
    body_heading: FloatArray | None = None  # (S, K) extended targets: heading [rad] of every scan, or None
    body_speed: FloatArray | None = None  # (S, K) extended targets: speed [m/s]
    body_phase: FloatArray | None = None  # (S, K) extended targets: gait phase [rad]
    couples: dict[int, tuple[FloatArray, FloatArray, IntArray]] | None = None  # network "couples": tx -> (C, W, O)
    echo_phase: FloatArray | None = None  # (P, K) coherent_echoes: the targets' carrier phases, held (first scan's)
    centre_phase: FloatArray | None = None  # (P, K, C) coherent_echoes: the body centres' carrier phases, held
    clutter_map: ClutterMap | None = None  # signal.clutter_map: the position detections' clutter map, this episode's
    map_previous: tuple[FloatArray, IntArray] | None = None  # clutter_map_count "still": last scan's couples (r, tx)
    map_pending: tuple[FloatArray, bool] | None = None  # "unassociated": this scan's positions (n, 2), observed


@dataclass(frozen=True, slots=True)
class ScanTrace:
    """Every intermediate of one scan's in-sensor chain, for pictures and calibration. Rows = the active pairs.

    scans, envelope (aligned onto the reference), reference, difference (rectified, blind zone removed),
    decisions: ``(P, N)``; pairs: ``(P,)`` pair indices; toa_row, toa_samples, weight, peak: the clusters (flat);
    ranges: ``(D,)`` bistatic ranges [m]; origin: ``(D,)`` target index or -1 (evaluation only).
    """

    scans: FloatArray
    envelope: FloatArray
    reference: FloatArray
    difference: FloatArray
    decisions: BoolArray
    pairs: IntArray
    toa_row: IntArray
    toa_samples: FloatArray
    weight: IntArray
    peak: FloatArray
    ranges: FloatArray
    origin: IntArray


@register_sensor("signal", "impulse")
class SignalSensor(ParametricModelHooks):
    """Synthesises each scan and runs the detection and localization chains (component tier)."""

    def __init__(self, cfg: ScenarioConfig) -> None:
        self.cfg = cfg
        self.sig = sig = cfg.sensing.signal
        self.model = ParametricSensor(cfg)
        self.layout, self.library = self.model.layout, self.model.library
        self.n_tx, self.n_rx = self.model.n_tx, self.model.n_rx
        if not all(isinstance(w, ImpulseWaveform) for w in self.library.waveforms):
            raise ValueError(
                f"sensing.fidelity = 'signal' in {cfg.name!r}: the signal path synthesises impulse waveforms only "
                f"(library: {[w.name for w in self.library.waveforms]})"
            )
        lay = self.layout
        self.pairs = self.model.pairs  # (P, 2)
        P = self.pairs.shape[0]
        self.fs = sig.sample_rate_hz
        self.t = np.arange(sig.n_samples) / self.fs
        self.baseline = lay.baselines[self.pairs[:, 0], self.pairs[:, 1]]  # (P,)
        tx_pos, rx_pos = lay.tx_pos[self.pairs[:, 0]], lay.rx_pos[self.pairs[:, 1]]
        self.fc = np.array([w.center_freq_hz for w in self.library.waveforms])
        self.pulse_s = np.array([pulse_envelope_std_s(w.rms_bandwidth_hz) for w in self.library.waveforms])
        if len(set(self.fc.tolist())) > 1 or len(set(self.pulse_s.tolist())) > 1:
            raise ValueError(
                f"waveforms of {cfg.name!r}: the signal path needs one pulse shape (centre frequency and bandwidth) "
                "for the whole library; the waveforms may differ in pulse integration (n_pulses) only"
            )
        self.dp_snr = self.model.direct_path_snr[:, self.pairs[:, 0], self.pairs[:, 1]]  # (W, P)
        # The room: background paths of every pair, drawn once from background_seed (the same in every episode).
        room = np.random.default_rng(sig.background_seed)
        L = sig.n_multipath
        power = db_to_linear(sig.multipath_power_ratio_db)
        profiles = [
            exponential_profile(room, L, sig.multipath_spacing_s, sig.multipath_decay_s, power) for _ in range(P)
        ]
        excess, amp, phase = (np.array(x).reshape(P, L) for x in zip(*profiles, strict=True))
        self.path_delay_s = np.concatenate([np.zeros((P, 1)), excess], axis=1)  # (P, L + 1) excess over the DP
        self.path_amplitude = np.concatenate([np.ones((P, 1)), amp], axis=1)
        self.path_phase = np.concatenate([np.zeros((P, 1)), phase], axis=1)
        angle = room.uniform(0.0, 2.0 * math.pi, (P, L))
        self.bounce = np.stack(  # (P, L, 2) virtual reflection point of each multipath on its delay ellipse
            [
                points_on_ellipse(tx_pos[i], rx_pos[i], self.baseline[i] + SPEED_OF_LIGHT_MPS * excess[i], angle[i])
                for i in range(P)
            ]
        )
        self.dp_sample = sig.direct_path_offset_s * self.fs
        fc, s = float(self.fc[0]), float(self.pulse_s[0])
        self._pulse = (fc, s)
        self.path_waveforms = unit_pulses(  # (P, L + 1, N) unit-energy paths on the reference time base
            self.t, sig.direct_path_offset_s + self.path_delay_s, self.path_phase, fc, s, self.fs
        )
        self._legs = (
            np.broadcast_to(tx_pos[:, None], (P, L + 1, 2)),
            np.concatenate([rx_pos[:, None], self.bounce], axis=1),
            np.concatenate([rx_pos[:, None], np.broadcast_to(rx_pos[:, None], (P, L, 2))], axis=1),
        )
        self.lpf = sig.envelope_lpf_s * self.fs
        self.jump_back = max(1, round(sig.dp_jump_back_s * self.fs))
        self.blind = cfg.sensing.blind_zone_excess_m / SPEED_OF_LIGHT_MPS * self.fs
        self.half_window = max(4, round(4.0 * s * self.fs))
        self.cfar = cfar_detector(sig.cfar)  # registry: threshold-factor design + detector kernel
        self.alpha = self.cfar.design(sig, sig.n_samples)  # threshold factor of CA / G / OS (DTB: its own weights)
        self.toa = toa_estimator(sig.toa_estimator)
        self.normalize = NORMALIZATIONS.get(sig.normalization)
        self.position_receivers = 2 if sig.network == "couples" else sig.nu  # receivers behind a fused position
        # Musicki's refinement: the clutter map waits for the tracker's association of the scan (after_tracking)
        self.needs_association = bool(sig.clutter_map and sig.clutter_map_count == "unassociated")
        if sig.network == "couples":
            self._init_couples()
        # the trackers' range std: the floor, and an extended person's spread about its centre (BodyModelConfig)
        body_std = sig.body.range_std_m if sig.target_model == "extended" else 0.0
        self.range_std_m = math.hypot(sig.range_std_floor_m, body_std)
        self.origin_tolerance_m = ORIGIN_TOLERANCE_M
        if sig.toa_estimator == "energy-detector":
            self._init_energy_detector()
        if sig.toa_estimator == "hmm":  # seed 004: bins from the blind zone's end to the scan's end, lambda
            self.hmm_bin = sig.hmm_bin_s * self.fs
            self.hmm_n_bins = max(1, math.floor((sig.n_samples - self.dp_sample - self.blind) / self.hmm_bin))
            self.hmm_params = hmm.single_capture_params(
                sig.hmm_p01, sig.hmm_p10, sig.hmm_change_log_mean, sig.hmm_change_log_var
            )
        area = lay.area
        self._area_m2 = float((area[1] - area[0]) * (area[3] - area[2]))

    def _init_couples(self) -> None:
        """Seed 001's arrays (``network = "couples"``): per transmitter its two receivers on a line through it.

        ``self.couple_groups``: ``(tx, pair of Rx1, pair of Rx2, e, n, beta, m [s])`` per transmitter, Rx1 the
        receiver at the smaller offset along the array, n towards the surveillance area, m the widening of eq. 5
        generalised to |Rx1 Rx2| / c + t_corr (with the transmitter in the middle, 2 d / c + t_corr: the appendix's
        bound is the triangle inequality on Rx1 Rx2 T).
        """
        lay, cfg = self.layout, self.cfg
        area = lay.area
        centre = np.array([0.5 * (area[0] + area[1]), 0.5 * (area[2] + area[3])])
        self.couple_groups = []
        for t in range(self.n_tx):  # transmitters: one or a few
            idx = np.flatnonzero(self.pairs[:, 0] == t)
            if idx.size != 2:
                raise ValueError(
                    f"sensing.signal.network = 'couples' in {cfg.name!r}: transmitter {t} forms {idx.size} pairs; "
                    "seed 001's ToA couples need exactly two receivers per transmitter"
                )
            tx = lay.tx_pos[t]
            rx = lay.rx_pos[self.pairs[idx, 1]]
            e, n, beta = array_frame(tx, rx[0], rx[1], centre)
            if np.any(np.abs((rx - tx) @ n) > 1e-6):
                raise ValueError(
                    f"sensing.signal.network = 'couples' in {cfg.name!r}: transmitter {t} and its receivers must lie "
                    "on one line (seed 001's handheld array)"
                )
            idx = idx[np.argsort(beta)]
            beta = np.sort(beta)
            m = float(np.linalg.norm(rx[0] - rx[1])) / SPEED_OF_LIGHT_MPS + self.sig.association_correction_s
            self.couple_groups.append((t, int(idx[0]), int(idx[1]), e, n, beta, m))
        # step 6's stillness bound: 1.5 samples of this chain's clock (toa_association.STILL_S at seed 001's 4.5 GHz)
        self.still_s = STILL_SAMPLES / self.fs

    def _init_energy_detector(self) -> None:
        """Constants of seed 002's energy detector: BPZF band, bins, noise statistics, absolute threshold xi_0.

        The BPZF keeps the pulse's -10 dB band fc +- B/2 (97 % of a Gaussian-spectrum pulse's energy). The noise of
        the coherent difference has per-sample variance 1 + 1 / ``empty_room_scans`` (the scan's and the averaged
        reference's) times the BPZF's kept fraction f, its bin energy Gamma of shape W T_int + 1/2 (2 W T_int + 1
        degrees of freedom, W = f fs / 2); non-coherent accumulation of N pulses adds Gamma of (N - 1) times that
        shape and mean (N - 1) M f
        (``energy_detector`` module). The sum's mean and variance give the Gamma of xi_0 (moment matching), per
        waveform (``ed_noise_mean``, ``ed_floor``: ``[accumulated?, waveform]``). The echo's integrated SNR is
        estimated from the largest bin: (z_max - noise mean) / (2 eta), eta the pulse energy the BPZF keeps (a path
        of integrated SNR carries sum p^2 = 2 SNR, ``synthesis``).
        """
        sig, cfg = self.sig, self.cfg
        eds = {w.config.energy_detector for w in self.library.waveforms}
        if len(eds) > 1:
            raise ValueError(
                f"waveforms of {cfg.name!r}: toa_estimator = 'energy-detector' needs one energy_detector "
                "configuration (integration time, observation window) for the whole library"
            )
        ed = self.energy_detector = eds.pop()
        w0 = self.library.waveforms[0].config
        self.ed_band = (w0.center_freq_hz - 0.5 * w0.bandwidth_hz, w0.center_freq_hz + 0.5 * w0.bandwidth_hz)
        self.ed_bin = ed.integration_time_s * self.fs  # samples per bin
        self.ed_n_bins = max(1, math.floor(ed.observation_window_s / ed.integration_time_s + 1e-9))
        kept = zonal_noise_variance(sig.n_samples, self.fs, *self.ed_band)
        self.ed_pulse_mean = self.ed_bin * kept  # one unit-variance scan's bin noise energy
        self.ed_shape = kept * 0.5 * self.fs * ed.integration_time_s + 0.5  # W T_int + 1/2
        self.ed_extra_pulses = np.array([w.config.n_pulses - 1 for w in self.library.waveforms], dtype=float)
        ref = 1.0 + 1.0 / sig.empty_room_scans
        extra = np.stack([np.zeros_like(self.ed_extra_pulses), self.ed_extra_pulses])  # (2, W)
        self.ed_noise_mean = self.ed_pulse_mean * (ref + extra)
        var = self.ed_pulse_mean**2 / self.ed_shape * (ref**2 + extra)
        shape = self.ed_noise_mean**2 / var
        self.ed_floor = np.array(
            [
                noise_energy_threshold(sig.ed_false_alarm_probability, self.ed_n_bins, m, a)
                for m, a in zip(self.ed_noise_mean.ravel(), shape.ravel(), strict=True)
            ]
        ).reshape(self.ed_noise_mean.shape)
        fc, s = self._pulse
        probe = unit_pulses(self.t, np.array(self.t[-1] / 2.0), np.zeros(()), fc, s, self.fs)
        self.ed_pulse_energy = float(np.sum(zonal_bandpass(probe, self.fs, *self.ed_band) ** 2))
        self.origin_tolerance_m = max(ORIGIN_TOLERANCE_M, SPEED_OF_LIGHT_MPS * ed.integration_time_s)

    # ------------------------------------------------------------------------------------------------ episode
    def new_episode(self, truth: Truth, rngs: RngStreams) -> SignalEpisode:
        """Geometry, empty-room references (``empty_room_scans`` averaged noisy scans per waveform), clutter state.

        The static paths' relative amplitudes fluctuate (AR(1), std ``clutter_fluctuation``, drawn here for scan 0).
        A fixed reference (``background`` "empty_room", "coherent") was recorded before the episode on their nominal
        gains; an adaptive one ("exponential", "exponential-coherent": seed 001's running average) has been averaging
        the room all along and starts on the paths as they are at scan 0. On the nominal gains it left the whole
        fluctuation in the first scans' residue, a burst of one static couple (README, seed 001: through-wall room 7).
        """
        sig = self.sig
        P, L = self.path_delay_s.shape[0], sig.n_multipath
        W = len(self.library)
        noise = rngs.signal.standard_normal((W, P, sig.n_samples)) / math.sqrt(sig.empty_room_scans)
        fluctuation = sig.clutter_fluctuation * rngs.signal.standard_normal((P, L))
        adaptive = sig.background in ("exponential", "exponential-coherent")
        gain = self._background_gain(self.path_amplitude, fluctuation) if adaptive else self.path_amplitude
        background = np.einsum("pl,pln->pn", gain, self.path_waveforms)
        er = np.sqrt(2.0 * self.dp_snr)[..., None] * background[None] + noise
        env = square_law_envelope(er, self.lpf)
        toa = direct_path_toa(env, sig.dp_threshold_ratio, self.jump_back)
        episode = SignalEpisode(
            geom=self.model._cached_geometry(truth),
            truth=truth,
            rngs=rngs,
            fluctuation=fluctuation,
            reference=env,
            reference_scan=er,
            reference_toa=toa,
            reference_peak=self._peak_near(env, toa),
        )
        if sig.clutter_map:  # an empty map every episode (Musicki's map learns the episode's own clutter)
            episode.clutter_map = ClutterMap.over(
                self.layout.area,
                sig.clutter_map_cell_m,
                sig.clutter_map_memory_scans,
                sig.false_position_density_per_m2,
            )
        if sig.target_model == "extended":
            # gait of every scan: heading from the velocity, phase integrated from the speed (Boulic's cycle), a
            # random initial phase per target from the RCS stream (drawn once per episode, whatever the plans)
            vel = np.where(truth.alive[..., None], np.nan_to_num(truth.states[..., [1, 3]]), 0.0)  # undefined if dead
            episode.body_heading = extended.headings(vel)
            episode.body_speed = np.linalg.norm(vel, axis=-1)
            phase0 = rngs.rcs.uniform(0.0, 2.0 * math.pi, truth.states.shape[1])
            episode.body_phase = extended.gait_phase(episode.body_speed, truth.times_s, sig.body, phase0)
        return episode

    def _peak_near(self, env: FloatArray, toa: FloatArray) -> FloatArray:
        """The envelope's peak after the direct-path crossing ``toa``, parabola-refined [samples]."""
        n = env.shape[-1]
        k0 = np.clip(np.floor(toa).astype(np.int64), 0, n - 1)
        idx = np.clip(k0[..., None] + np.arange(self.half_window + 1), 1, n - 2)
        k = np.take_along_axis(idx, np.argmax(np.take_along_axis(env, idx, axis=-1), axis=-1)[..., None], -1)[..., 0]
        y = [np.take_along_axis(env, (k + d)[..., None], axis=-1)[..., 0] for d in (-1, 0, 1)]
        return k + parabolic_peak(*y)

    # --------------------------------------------------------------------------------------------- synthesis
    def synthesise(self, episode: SignalEpisode, k: int, plan: ScanPlan) -> tuple[FloatArray, IntArray]:
        """The received scans ``(P_active, N)`` of scan ``k`` and the active pair indices ``(P_active,)``.

        Draws (for every formed pair, whatever the plan): timing jitter, clutter innovations, RCS, echo phases, noise.
        """
        sig, rng, geom = self.sig, episode.rngs, episode.geom
        P, K = self.pairs.shape[0], geom.unit_snr.shape[-1]
        jitter = sig.scan_jitter_s * self.fs * rng.signal.standard_normal(P)
        episode.fluctuation = ar1_step(
            episode.fluctuation,
            sig.clutter_correlation,
            sig.clutter_fluctuation,
            rng.signal.standard_normal(episode.fluctuation.shape),
        )
        phase = rng.signal.uniform(0.0, 2.0 * math.pi, (P, K))
        if sig.coherent_echoes:  # the scan's draw is made (streams unchanged) but the first scan's phase is kept
            if episode.echo_phase is None:
                episode.echo_phase = phase
            phase = episode.echo_phase
        fluct = rcs_fluctuation(self.model.swerling, (self.n_tx, self.n_rx), rng.rcs, self.model._swerling_w)
        noise = rng.signal.standard_normal((P, sig.n_samples))
        if sig.toa_estimator == "energy-detector" and sig.ed_pulse_integration == "noncoherent":
            episode.ed_uniform = rng.signal.uniform(0.0, 1.0, (P, self.ed_n_bins))
        if sig.target_model == "extended":  # per centre: Swerling factor (every pair) and carrier phase
            C = len(extended.CENTRES)
            body_fluct = rcs_fluctuation(
                self.model.swerling, (self.n_tx, self.n_rx, C), rng.rcs, self.model._swerling_w
            )
            body_phase = rng.signal.uniform(0.0, 2.0 * math.pi, (P, K, C))
            if sig.coherent_echoes:  # each centre keeps its phase: its echo moves with its delay (an MTI sees it)
                if episode.centre_phase is None:
                    episode.centre_phase = body_phase
                body_phase = episode.centre_phase
        active = np.flatnonzero(plan.active_rx[self.pairs[:, 1]])
        w = plan.waveform[self.pairs[active, 0]]
        t_i, r_i = self.pairs[active, 0], self.pairs[active, 1]
        alive = episode.truth.alive[k]
        pos = episode.truth.states[k][:, [0, 2]]
        # Background with clutter fluctuation and target shadowing.
        a, b, c = (leg[active] for leg in self._legs)
        near = np.zeros(a.shape[:2], dtype=bool)
        for j in np.flatnonzero(alive):  # targets: a handful
            near |= (segment_distance(pos[j], a, b) < sig.shadow_radius_m) | (
                segment_distance(pos[j], b, c) < sig.shadow_radius_m
            )
        gain = self._background_gain(self.path_amplitude[active], episode.fluctuation[active])
        gain = np.where(near, gain * 10.0 ** (-sig.shadow_loss_db / 20.0), gain)
        background = np.sqrt(2.0 * self.dp_snr[w, active])[:, None] * np.einsum(
            "pl,pln->pn", gain, self.path_waveforms[active]
        )
        if sig.target_model == "extended":
            excess, snr, echo_phase = self._body_echoes(episode, k, active, w, body_fluct, body_phase)
            return self._compose(background, excess, snr, echo_phase, jitter[active], noise[active]), active
        # Echoes: integrated SNR = radar constant x unit SNR x RCS fluctuation; delay relative to the direct path.
        snr = self.model.radar_constant[w, t_i, r_i][:, None] * geom.unit_snr[k, t_i, r_i] * fluct[t_i, r_i]
        snr = np.where(alive[None], snr, 0.0)
        excess = (geom.bistatic_range[k, t_i, r_i] - self.baseline[active][:, None]) / SPEED_OF_LIGHT_MPS
        excess = np.where(alive[None], excess, -1.0)  # dead targets: far before the window (and zero SNR)
        return self._compose(background, excess, snr, phase[active], jitter[active], noise[active]), active

    def _body_echoes(
        self,
        episode: SignalEpisode,
        k: int,
        active: IntArray,
        w: IntArray,
        body_fluct: FloatArray,
        body_phase: FloatArray,
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The extended targets' echoes of scan ``k`` on the active pairs: ``(A, K x 6)`` delays [s], SNRs, phases.

        Each scattering centre (``scene.extended``) at its specular point for the pair: bistatic range = the body
        centre's (walls' excess delay included) plus the centre's extra path; SNR = radar constant x the body
        centre's unit SNR (mean RCS, walls, beam) x (l_t l_r / l_t,c l_r,c)^rho x the centre's RCS share x its
        Swerling factor ``body_fluct`` (T, R, 6, K) x its torso occlusion; carrier phase ``body_phase`` (P, K, 6).
        """
        body, geom, truth = self.sig.body, episode.geom, episode.truth
        t_i, r_i = self.pairs[active, 0], self.pairs[active, 1]
        tx, rx = self.layout.tx_pos[t_i], self.layout.rx_pos[r_i]  # (A, 2)
        alive = truth.alive[k]
        pos = truth.states[k][:, [0, 2]]
        heading = episode.body_heading[k]
        offsets = extended.centre_offsets(episode.body_phase[k], episode.body_speed[k], body)  # (K, 6, 2)
        pts = extended.specular_points(pos, heading, offsets, tx, rx, body)  # (A, K, 6, 2)
        lt = np.maximum(np.linalg.norm(pts - tx[:, None, None], axis=-1), 1e-6)
        lr = np.maximum(np.linalg.norm(pts - rx[:, None, None], axis=-1), 1e-6)
        lt0 = np.maximum(np.linalg.norm(pos[None] - tx[:, None], axis=-1), 1e-6)[..., None]  # (A, K, 1)
        lr0 = np.maximum(np.linalg.norm(pos[None] - rx[:, None], axis=-1), 1e-6)[..., None]
        rng_m = geom.bistatic_range[k, t_i, r_i][..., None] + (lt + lr) - (lt0 + lr0)
        gain = (lt0 * lr0 / (lt * lr)) ** self.cfg.channel.path_loss_exponent * extended.shares(body)
        gain = gain * 10.0 ** (-extended.occlusion_loss_db(pos, heading, offsets, tx, rx, body) / 10.0)
        unit = self.model.radar_constant[w, t_i, r_i][:, None] * geom.unit_snr[k, t_i, r_i]  # (A, K)
        snr = unit[..., None] * gain * np.moveaxis(body_fluct[t_i, r_i], -1, -2)  # (A, K, 6)
        snr = np.where(alive[None, :, None], snr, 0.0)
        excess = (rng_m - self.baseline[active][:, None, None]) / SPEED_OF_LIGHT_MPS
        excess = np.where(alive[None, :, None], excess, -1.0)
        A = active.size
        return excess.reshape(A, -1), snr.reshape(A, -1), body_phase[active].reshape(A, -1)

    @staticmethod
    def _background_gain(amplitude: FloatArray, fluctuation: FloatArray) -> FloatArray:
        """``(B, L + 1)`` path gains: the direct path's, and the multipaths' times (1 + their fluctuation)."""
        return amplitude * np.concatenate([np.ones((fluctuation.shape[0], 1)), 1.0 + fluctuation], axis=1)

    def _compose(
        self,
        background: FloatArray,
        excess_s: FloatArray,
        snr: FloatArray,
        phase: FloatArray,
        jitter: FloatArray,
        noise: FloatArray,
    ) -> FloatArray:
        """Scans ``(B, N)``: the background plus echoes, delayed by ``jitter`` [samples], plus unit ``noise``.

        The echoes ``(B, K)`` lie ``excess_s`` after the direct path with integrated ``snr`` and carrier ``phase``.
        """
        fc, s = self._pulse
        echoes = unit_pulses(self.t, self.sig.direct_path_offset_s + excess_s, phase, fc, s, self.fs)
        scan = background + np.einsum("pk,pkn->pn", np.sqrt(2.0 * snr), echoes)
        return fractional_shift(scan, jitter) + noise

    # ------------------------------------------------------------------------------------------- in-sensor
    def detect(self, episode: SignalEpisode, k: int, plan: ScanPlan, scans: FloatArray, active: IntArray) -> ScanTrace:
        """The in-sensor chain on the scans of the active pairs; ToAs as bistatic ranges [m]."""
        w = plan.waveform[self.pairs[active, 0]]
        ref = episode.reference[w, active]
        aligned, d, decisions, (row, toa_s, weight, peak), ranges = self.in_sensor(
            scans,
            ref,
            episode.reference_toa[w, active],
            episode.reference_peak[w, active],
            active,
            episode.reference_scan[w, active],
            waveform=w,
            ed_uniform=None if episode.ed_uniform is None else episode.ed_uniform[active],
        )
        if self.sig.background == "exponential":
            episode.reference[w, active] = exponential_background(ref, aligned, self.sig.background_alpha)
        elif self.sig.background == "exponential-coherent":  # seed 001: b <- alpha b + (1 - alpha) x, raw scans
            episode.reference_scan[w, active] = exponential_background(
                episode.reference_scan[w, active], scans, self.sig.background_alpha
            )
        truth_range = episode.geom.bistatic_range[k, self.pairs[active, 0], self.pairs[active, 1]][row]  # (D, K)
        err = np.where(episode.truth.alive[k][None], np.abs(truth_range - ranges[:, None]), np.inf)
        origin = np.where(
            err.min(axis=1, initial=np.inf) < self.origin_tolerance_m,
            np.argmin(err, axis=1) if err.shape[1] else -1,
            -1,
        )
        return ScanTrace(scans, aligned, ref, d, decisions, active, row, toa_s, weight, peak, ranges, origin)

    def in_sensor(
        self,
        scans: FloatArray,
        ref: FloatArray,
        ref_toa: FloatArray,
        ref_peak: FloatArray,
        pair: IntArray,
        ref_scan: FloatArray | None = None,
        waveform: IntArray | None = None,
        ed_uniform: FloatArray | None = None,
    ) -> tuple[FloatArray, FloatArray, BoolArray, tuple, FloatArray]:
        """Seed 000's in-sensor chain on scans ``(B, N)`` of pairs ``pair`` (B,) against references ``(B, N)``.

        ``ref_scan`` ``(B, N)``: the raw empty-room scans, needed by ``background = "coherent"``. With
        ``toa_estimator = "energy-detector"`` the chain is :meth:`_energy_detector` (``waveform`` (B,) the rows'
        waveforms, 0 if None; ``ed_uniform`` (B, bins) the draws of its pulse-accumulation noise). Returns the aligned
        envelopes, the difference (rectified envelope difference, or the envelope of the raw difference; blind zone
        zeroed), the CFAR decisions, the clusters ``(row, toa [samples], weight, peak)`` and their bistatic ranges [m].
        """
        sig = self.sig
        if sig.toa_estimator == "energy-detector":
            return self._energy_detector(scans, ref_peak, pair, ref_scan, waveform, ed_uniform)
        if sig.toa_estimator == "hmm":
            return self._hmm(scans, ref, ref_toa, ref_peak, pair, ref_scan)
        env = square_law_envelope(scans, self.lpf)
        if sig.align_scans:
            toa = direct_path_toa(env, sig.dp_threshold_ratio, self.jump_back)
            aligned, delay = align_to_reference(env, ref, toa, ref_toa, self.half_window)
        else:
            aligned, delay = env, None
        blind = np.arange(env.shape[-1])[None] < (ref_peak + self.blind)[:, None]  # blind zone (seed 000 IV-G)
        if sig.background == "coherent":
            if ref_scan is None:
                raise ValueError("background = 'coherent' needs the raw reference scans (ref_scan)")
            raw = scans if delay is None else fractional_shift(scans, -delay)
            # the envelope of the raw difference where the envelope grew: a target blocking a path (shadowing)
            # lowers the envelope there, and is removed as seed 000's rectification removes it
            d = np.where(aligned > ref, square_law_envelope(raw - ref_scan, self.lpf), 0.0)
            # the raw difference is noise, not zero, in the blind zone: the CFAR learns its level there first
            decisions = self._cfar(d)
            decisions[blind] = False
            d[blind] = 0.0
        elif sig.background == "exponential-coherent":
            if ref_scan is None:
                raise ValueError("background = 'exponential-coherent' needs the raw background scans (ref_scan)")
            # seed 001: the raw scan less its exponential average (a common clock: no alignment), then its amplitude
            # envelope (the square root of the square-law envelope): the CFAR compares d^2, the power, as its
            # threshold factor assumes (on the square-law envelope itself it compared power^2: on exponential powers
            # a design Pfa of 1e-2 gives 5.4e-2)
            d = np.sqrt(square_law_envelope(scans - ref_scan, self.lpf))
            d[blind] = 0.0
            d = self.normalize(d, sig.toa_interval_samples)
            decisions = self._cfar(d)
        else:
            d = rectified_difference(aligned, ref)
            d[blind] = 0.0
            d = self.normalize(d, sig.toa_interval_samples)
            decisions = self._cfar(d)
        clusters = self.toa.estimate(decisions, d, sig, self.fs)
        row, toa_s = clusters[0], clusters[1]
        ranges = self.baseline[pair][row] + SPEED_OF_LIGHT_MPS * (toa_s - ref_peak[row]) / self.fs
        return aligned, d, decisions, clusters, ranges

    def _energy_detector(
        self,
        scans: FloatArray,
        ref_peak: FloatArray,
        pair: IntArray,
        ref_scan: FloatArray | None,
        waveform: IntArray | None,
        ed_uniform: FloatArray | None,
    ) -> tuple[FloatArray, FloatArray, BoolArray, tuple, FloatArray]:
        """Seed 002's energy-detector ToA (``toa_estimator = "energy-detector"``), in :meth:`in_sensor`'s format.

        The raw coherent difference (scan minus the empty room) through the BPZF, squared, integrated in T_int bins
        over the observation window from the end of the blind zone (direct-path peak + blind zone), the samples
        where the filtered scan's envelope did not grow over the empty room's dropped (seed 000's rectification
        against shadowing ghosts); the ToA is the
        centre of the first bin above max(z_min + alpha (z_max - z_min), xi_0); a window with no bin above xi_0 gives
        none. ``ed_pulse_integration = "noncoherent"`` adds the noise energy of the other N_pulse - 1 pulses from the
        draws ``ed_uniform`` (without them -- a direct call -- the bins are the coherent scan's). Returns the
        envelopes (no alignment: a common clock), the squared filtered difference (blind zone zeroed), the samples
        of the crossing bins as decisions, the ToAs as clusters ``(row, toa [samples], weight = the bin's samples,
        peak = the estimated integrated SNR)`` and their bistatic ranges [m].
        """
        sig = self.sig
        if ref_scan is None:
            raise ValueError("toa_estimator = 'energy-detector' needs the raw reference scans (ref_scan)")
        y_scan, y_ref = (zonal_bandpass(x, self.fs, *self.ed_band) for x in (scans, ref_scan))
        # seed 000's rectification, per sample: where the envelope fell below the empty room's (a target shadowing a
        # path: the difference there is the blocked path, a ghost) the difference is dropped
        grew = square_law_envelope(y_scan, self.lpf) > square_law_envelope(y_ref, self.lpf)
        y = np.where(grew, y_scan - y_ref, 0.0)
        start = ref_peak + self.blind
        z = bin_energies(y, start, self.ed_bin, self.ed_n_bins)
        w = np.zeros(scans.shape[0], dtype=np.int64) if waveform is None else np.asarray(waveform)
        acc = int(sig.ed_pulse_integration == "noncoherent" and ed_uniform is not None)
        if acc:
            z = z + accumulated_noise_energy(ed_uniform, self.ed_extra_pulses[w], self.ed_pulse_mean, self.ed_shape)
        floor = self.ed_floor[acc, w]
        toa, hit, k = energy_detector_toa(z, start, self.ed_bin, sig.ed_threshold_ratio, floor)
        row = np.flatnonzero(hit)
        snr = np.maximum(valid_extremes(z)[1] - self.ed_noise_mean[acc, w], 0.0) / (2.0 * self.ed_pulse_energy)
        idx = np.arange(scans.shape[-1])[None]
        d = np.square(y)
        d[idx < start[:, None]] = 0.0
        lo = (start + k * self.ed_bin)[:, None]
        decisions = hit[:, None] & (idx >= lo) & (idx < lo + self.ed_bin)
        weight = np.full(row.size, max(1, round(self.ed_bin)), dtype=np.int64)
        toa_s, peak = toa[row], snr[row]
        ranges = self.baseline[pair][row] + SPEED_OF_LIGHT_MPS * (toa_s - ref_peak[row]) / self.fs
        env = square_law_envelope(scans, self.lpf)
        return env, d, decisions, (row, toa_s, weight, peak), ranges

    def _hmm(
        self,
        scans: FloatArray,
        ref: FloatArray,
        ref_toa: FloatArray,
        ref_peak: FloatArray,
        pair: IntArray,
        ref_scan: FloatArray | None,
    ) -> tuple[FloatArray, FloatArray, BoolArray, tuple, FloatArray]:
        """Seed 004's HMM ToA (``toa_estimator = "hmm"``, :mod:`uwb_env.detection.hmm`), in :meth:`in_sensor`'s format.

        The raw scans, aligned to the reference like the coherent background's (``align_scans``), and the raw empty
        room give bin energies over ``hmm_bin_s`` bins from the blind zone's end; O_k is the single-capture change
        statistic (unit noise in the scan, 1 / ``empty_room_scans`` in the reference, a background bin's energy
        fluctuating by 2 ``clutter_fluctuation``); the HMM's posterior gives the
        first bin with P(X_k = 1 | O) > 1/2, the ToA its centre (at most one per pair). Returns the aligned
        envelopes, O spread over each bin's samples as the difference, the detected bin's samples as decisions, the
        clusters ``(row, toa [samples], weight = the bin's samples, peak = O at the detected bin)`` and the ranges.
        """
        sig = self.sig
        if ref_scan is None:
            raise ValueError("toa_estimator = 'hmm' needs the raw reference scans (ref_scan)")
        env = square_law_envelope(scans, self.lpf)
        aligned, raw = env, scans
        if sig.align_scans:
            toa = direct_path_toa(env, sig.dp_threshold_ratio, self.jump_back)
            aligned, delay = align_to_reference(env, ref, toa, ref_toa, self.half_window)
            raw = fractional_shift(scans, -delay)
        start = ref_peak + self.blind
        obs = hmm.single_capture_observations(
            raw, ref_scan, start, self.hmm_bin, self.hmm_n_bins, 1.0, 1.0 / sig.empty_room_scans,
            2.0 * sig.clutter_fluctuation,  # a path's relative energy std: twice its amplitude's
        )  # fmt: skip
        params = self.hmm_params
        if sig.hmm_iterations:
            params = hmm.baum_welch(obs, params, sig.hmm_iterations).final
        k = hmm.hmm_delay(hmm.changed_posterior(obs, params))
        row = np.flatnonzero(k >= 0)
        toa_s = (start + (k + 0.5) * self.hmm_bin)[row]
        peak = obs[row, k[row]]
        weight = np.full(row.size, max(1, round(self.hmm_bin)), dtype=np.int64)
        ranges = self.baseline[pair][row] + SPEED_OF_LIGHT_MPS * (toa_s - ref_peak[row]) / self.fs
        idx = np.arange(scans.shape[-1])[None]
        j = np.floor((idx - start[:, None]) / self.hmm_bin).astype(np.int64)  # each sample's bin
        inside = (j >= 0) & (j < self.hmm_n_bins)
        d = np.where(inside, np.take_along_axis(np.nan_to_num(obs), np.clip(j, 0, self.hmm_n_bins - 1), axis=1), 0.0)
        decisions = inside & (j == k[:, None]) & (k[:, None] >= 0)
        return aligned, d, decisions, (row, toa_s, weight, peak), ranges

    def ed_range_variance(self, snr: FloatArray, waveform: int) -> FloatArray:
        """``(D,)`` range variance [m^2] of energy-detector ToAs at estimated integrated SNR ``snr`` (D,).

        Seed 002's three-region sigma(SNR) (``waveforms.toa_models``) at the per-pulse SNR snr / N_pulse of the
        waveform, times c, plus ``range_std_floor_m``^2 (what the tracker does not model: the walls' excess delay).
        """
        n_pulses = self.library.waveforms[waveform].config.n_pulses
        per_pulse_db = 10.0 * np.log10(np.maximum(np.asarray(snr, dtype=float), 1e-30) / n_pulses)
        sigma_t = energy_detector_toa_std(per_pulse_db, n_pulses, self.energy_detector)
        return (SPEED_OF_LIGHT_MPS * sigma_t) ** 2 + self.range_std_m**2

    def controlled_scans(
        self,
        rng: np.random.Generator,
        pair: int,
        waveform: int,
        excess_range_m: float,
        snr: FloatArray,
        speed_mps: float = 1.5,
    ) -> FloatArray:
        """Calibration input: scans ``(B, N)`` of one pair with a single echo of integrated SNR ``snr`` (B,).

        The echo lies ``excess_range_m`` beyond the baseline, over the room's background; fluctuation, jitter, echo
        phase and noise are drawn from ``rng``. With ``target_model = "extended"`` the echo is a walking person's
        (:meth:`_controlled_body`, at ``speed_mps``): ``snr`` is the body's mean SNR, ``excess_range_m`` its centre's.
        """
        sig = self.sig
        B = np.asarray(snr).shape[0]
        gain = self._background_gain(
            self.path_amplitude[pair], sig.clutter_fluctuation * rng.standard_normal((B, sig.n_multipath))
        )
        background = math.sqrt(2.0 * self.dp_snr[waveform, pair]) * gain @ self.path_waveforms[pair]
        if sig.target_model == "extended":
            echo = self._controlled_body(rng, pair, excess_range_m, np.asarray(snr, dtype=float), speed_mps)
            excess, echo_snr, phase = echo
        else:
            excess = np.full((B, 1), excess_range_m / SPEED_OF_LIGHT_MPS)
            phase = rng.uniform(0.0, 2.0 * math.pi, (B, 1))
            echo_snr = np.asarray(snr, dtype=float)[:, None]
        jitter = sig.scan_jitter_s * self.fs * rng.standard_normal(B)
        noise = rng.standard_normal(background.shape)
        return self._compose(background, excess, echo_snr, phase, jitter, noise)

    def _controlled_body(
        self, rng: np.random.Generator, pair: int, excess_range_m: float, snr: FloatArray, speed_mps: float
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """A walking person's echoes for :meth:`controlled_scans`: ``(B, 6)`` delays [s], SNRs, carrier phases.

        The body's centre lies ``excess_range_m`` beyond the pair's baseline on the baseline's bisector, on the
        surveillance area's side (a monostatic radar: towards the area's centre); per scan a uniform heading and
        gait phase at ``speed_mps``; each scattering centre as in :meth:`_body_echoes` (specular point, path loss
        relative to the centre's, RCS share, torso occlusion) with the first target's Swerling factor and a uniform
        carrier phase. The centres' SNRs average to ``snr`` (B,) when no arm is occluded and the path losses equal.
        """
        body = self.sig.body
        B, C = snr.shape[0], len(extended.CENTRES)
        t, r = (int(v) for v in self.pairs[pair])
        tx, rx = self.layout.tx_pos[t], self.layout.rx_pos[r]
        area = self.layout.area
        mid, toward = 0.5 * (tx + rx), np.array([0.5 * (area[0] + area[1]), 0.5 * (area[2] + area[3])])
        base, total = float(self.baseline[pair]), float(self.baseline[pair]) + excess_range_m
        if base > 1e-9:
            normal = np.array([tx[1] - rx[1], rx[0] - tx[0]]) / base
            normal = normal if np.dot(toward - mid, normal) >= 0.0 else -normal
            centre = mid + normal * math.sqrt(max(0.25 * total**2 - 0.25 * base**2, 0.0))
        else:
            direction = toward - mid
            centre = mid + 0.5 * total * direction / max(float(np.linalg.norm(direction)), 1e-12)
        position = np.broadcast_to(centre, (B, 2))
        heading = rng.uniform(0.0, 2.0 * math.pi, B)
        offsets = extended.centre_offsets(rng.uniform(0.0, 2.0 * math.pi, B), np.full(B, speed_mps), body)
        pts = extended.specular_points(position, heading, offsets, tx[None], rx[None], body)[0]  # (B, 6, 2)
        lt, lr = np.linalg.norm(pts - tx, axis=-1), np.linalg.norm(pts - rx, axis=-1)
        lt0, lr0 = float(np.linalg.norm(centre - tx)), float(np.linalg.norm(centre - rx))
        gain = (lt0 * lr0 / np.maximum(lt * lr, 1e-12)) ** self.cfg.channel.path_loss_exponent * extended.shares(body)
        occluded = extended.occlusion_loss_db(position, heading, offsets, tx[None], rx[None], body)[0]
        gain = gain * 10.0 ** (-occluded / 10.0)
        fluct = rcs_fluctuation(self.model.swerling[:1], (B, C), rng)[..., 0]
        excess = (excess_range_m + (lt + lr) - (lt0 + lr0)) / SPEED_OF_LIGHT_MPS
        return excess, snr[:, None] * gain * fluct, rng.uniform(0.0, 2.0 * math.pi, (B, C))

    def _cfar(self, d: FloatArray) -> BoolArray:
        """CFAR decisions ``(B, N)`` of the detector ``sensing.signal.cfar`` (:mod:`uwb_env.detection.registry`)."""
        return self.cfar.detect(d, self.alpha, self.sig)

    # -------------------------------------------------------------------------------------------- network
    def sense(self, episode: SignalEpisode, k: int, plan: ScanPlan, time_s: float = 0.0) -> tuple[Detections, ...]:
        """Scan ``k`` with ``plan``: synthesis, in-sensor chain, then the records of ``signal.output``.

        ``positions``: the network chain's one record of 2-D positions; ``ranges``: one record of bistatic ranges per
        active pair.
        """
        plan.validate(self.n_tx, self.n_rx, len(self.library))
        scans, active = self.synthesise(episode, k, plan)
        tr = self.detect(episode, k, plan, scans, active)
        if self.sig.output == "ranges":
            return self.ranges(tr, plan, time_s)
        if self.sig.network == "couples":
            return (self.localize_couples(episode, k, tr, plan, time_s),)
        return (self.localize(tr, plan, time_s, episode),)

    def ranges(self, tr: ScanTrace, plan: ScanPlan, time_s: float) -> tuple[Detections, ...]:
        """The in-sensor ToAs as per-pair bistatic-range detections (no network fusion; the tracker fuses them).

        Variance ``range_std_floor_m``^2 (the energy detector: :meth:`ed_range_variance`); clutter intensity
        ``false_ranges_per_scan`` spread uniformly over the pair's range window beyond the blind zone (the
        false-alarm rate measured by the calibration report).
        """
        sig, out = self.sig, []
        window_m = (
            sig.n_samples - self.dp_sample
        ) / self.fs * SPEED_OF_LIGHT_MPS - self.cfg.sensing.blind_zone_excess_m
        density = sig.false_ranges_per_scan / window_m
        for i, p in enumerate(tr.pairs.tolist()):  # active pairs: a handful
            sel = np.flatnonzero(tr.toa_row == i)
            sel = sel[np.argsort(tr.ranges[sel], kind="stable")]
            n = sel.size
            t, r = (int(v) for v in self.pairs[p])
            if sig.toa_estimator == "energy-detector":
                var = self.ed_range_variance(tr.peak[sel], int(plan.waveform[t]))
            else:
                var = np.full(n, self.range_std_m**2)
            out.append(
                Detections(
                    tx=t,
                    rx=r,
                    waveform=int(plan.waveform[t]),
                    time_s=time_s,
                    z=tr.ranges[sel][:, None],
                    R=var[:, None, None],
                    snr=tr.peak[sel],
                    origin=tr.origin[sel],
                    measurement_names=("bistatic_range",),
                    clutter_intensity=np.full(n, density),
                    expected_false_alarms=sig.false_ranges_per_scan,
                )
            )
        return tuple(out)

    def localize(
        self, tr: ScanTrace, plan: ScanPlan, time_s: float, episode: SignalEpisode | None = None
    ) -> Detections:
        """The network chain on one scan's ToAs (seed 000 section V); ``episode``: its clutter map, if any."""
        sig, lay = self.sig, self.layout
        pair = tr.pairs[tr.toa_row]
        z, R, used = locate(
            tr.ranges,
            tr.weight.astype(float),
            pair,
            lay.tx_pos[self.pairs[pair, 0]],
            lay.rx_pos[self.pairs[pair, 1]],
            lay.area,
            sig.nu,
            sig.min_tuple_weight,
            sig.max_residual_m,
            sig.cluster_2d_distance_m,
            sig.linkage,
            self.range_std_m,
        )
        origin = np.array(
            [int(tr.origin[u][0]) if u.size and np.all(tr.origin[u] == tr.origin[u][0]) else -1 for u in used],
            dtype=np.int64,
        )
        peak = np.array([float(tr.peak[u].mean()) for u in used])
        return self._positions(z, R, peak, origin, plan, time_s, episode, observed=tr.pairs.size > 0)

    def _positions(
        self,
        z: FloatArray,
        R: FloatArray,
        snr: FloatArray,
        origin: IntArray,
        plan: ScanPlan,
        time_s: float,
        episode: SignalEpisode | None = None,
        observed: bool = True,
        map_weight: FloatArray | None = None,
    ) -> Detections:
        """The network's record of fused 2-D positions ``z (n, 2)``, covariances ``R (n, 2, 2)`` (``rx = -1``).

        Clutter intensity ``false_position_density_per_m2`` over the surveillance area; with ``signal.clutter_map``
        (and the ``episode``'s map) each detection's is the map's density at its position, read before the map
        takes this scan's detections (``observed``: the scan looked at the area at all; a scan with every receiver
        off neither adds nor forgets). The expected false alarms stay the prior's. With ``clutter_map_count =
        "unassociated"`` the positions wait in ``episode.map_pending`` for :meth:`after_tracking`.
        """
        density = self.sig.false_position_density_per_m2
        n = z.shape[0]
        cmap = episode.clutter_map if episode is not None else None
        if cmap is not None:
            intensity = cmap.density(z)
            if self.needs_association:  # read now, update once the tracker has associated this scan
                episode.map_pending = (z.copy(), observed)
            elif observed:
                cmap.update(z, map_weight)
        else:
            intensity = np.full(n, density)
        return Detections(
            tx=0,
            rx=-1,
            waveform=int(plan.waveform[0]),
            time_s=time_s,
            z=z,
            R=R,
            snr=snr,
            origin=origin,
            measurement_names=_POSITION_NAMES,
            clutter_intensity=intensity,
            expected_false_alarms=density * self._area_m2,
        )

    def after_tracking(
        self, episode: SignalEpisode, detections: tuple[Detections, ...], clutter: tuple[FloatArray, ...]
    ) -> None:
        """Musicki's clutter-map update of the scan just tracked (``clutter_map_count = "unassociated"``).

        ``detections``: the records the tracker got this scan (``()`` when none were delivered); ``clutter``: per
        record, ``(M,)`` each detection's a-posteriori clutter probability (``Tracker.clutter_probabilities``).
        The scan's positions (``episode.map_pending``, left by ``sense``, which read the map before) enter the map
        each with its clutter probability; positions the tracker did not get count 1 (no track used them); a scan
        that observed nothing neither adds nor forgets. Without the mode, or without a pending scan: nothing.
        """
        pending, episode.map_pending = episode.map_pending, None
        if not self.needs_association or episode.clutter_map is None or pending is None:
            return
        z, observed = pending
        if not observed:
            return
        if len(detections) != len(clutter):
            raise ValueError(
                f"after_tracking: clutter has {len(clutter)} records for {len(detections)} detection records; "
                "one (M,) array per record is allowed"
            )
        weight = np.ones(z.shape[0])
        for det, c in zip(detections, clutter, strict=True):  # records: one (the network's positions)
            if det.rx == -1 and det.z.shape == z.shape:
                c = np.asarray(c, dtype=float)
                if c.shape != (z.shape[0],) or not np.all((c >= 0.0) & (c <= 1.0)):
                    raise ValueError(
                        f"after_tracking: clutter weights {c!r} must be ({z.shape[0]},) probabilities in [0, 1]"
                    )
                weight = c
        episode.clutter_map.update(z, weight)

    # ------------------------------------------------------------------------------- seed 001: ToA couples
    def couples(
        self, episode: SignalEpisode, k: int, tr: ScanTrace, *, associate: bool, update: bool = True
    ) -> tuple[FloatArray, FloatArray, IntArray, IntArray]:
        """Seed 001's localization input and output for scan ``k``: the ToA couples of every transmitter's array.

        Per transmitter (``couple_groups``), the ToAs of its two receivers as propagation times (bistatic range / c):
        with ``associate`` the couples of the ToA association (:func:`~uwb_env.detection.toa_association.
        associate_toas`, step 6 from the couples steps 4-5 found in the previous scan -- our reading of "couples found
        in the previous observation time instant": a completion is not found, so it holds a couple for one scan and
        never chains; ``update`` stores this scan's), without it every
        Rx1 x Rx2 combination; the walls' excess delay removed when ``wall_compensation`` is set; the ellipse
        intersection (:func:`~uwb_env.localization.couples.couple_positions`). A transmitter with a receiver off
        gives no couples. Returns ``(positions (L, 2) [m], ranges (L, 2) [m] as localized, tx (L,), origin (L,))``,
        intersections outside the surveillance area dropped; origin (evaluation only): the target both ranges lie
        within max(``origin_tolerance_m``, 3 ``range_std_m``) of, else -1 (the interval ToA is the body's leading
        edge, a few tenths of a metre before its centre's).
        """
        sig, lay = self.sig, self.layout
        if episode.couples is None:
            episode.couples = {}
        alive = episode.truth.alive[k]
        pos = np.nan_to_num(episode.truth.states[k][:, [0, 2]])
        area = lay.area
        out_p, out_r, out_t, out_o = [np.zeros((0, 2))], [np.zeros((0, 2))], [np.zeros(0, np.int64)], []
        for t, p1, p2, e, n, beta, m in self.couple_groups:  # transmitters: one or a few
            i1, i2 = np.flatnonzero(tr.pairs == p1), np.flatnonzero(tr.pairs == p2)
            if i1.size == 0 or i2.size == 0:
                continue
            toa1 = tr.ranges[tr.toa_row == i1[0]] / SPEED_OF_LIGHT_MPS
            toa2 = tr.ranges[tr.toa_row == i2[0]] / SPEED_OF_LIGHT_MPS
            if associate:
                prev = episode.couples.get(t) if sig.association_completion else None
                a1, a2, centre, width, order, done = associate_toas(
                    toa1, toa2, m, *(prev or (None, None, None)), still_s=self.still_s
                )
                if update:  # step 6 completes from the couples the association found (a completion is not found)
                    episode.couples[t] = (centre[~done], width[~done], order[~done])
            else:
                a1, a2 = all_couples(toa1, toa2)
            r = SPEED_OF_LIGHT_MPS * np.stack([a1, a2], axis=-1)  # (L, 2)
            tx = lay.tx_pos[t]
            rx = lay.rx_pos[self.pairs[[p1, p2], 1]]  # (2, 2)
            p, _ = couple_positions(r[:, 0], r[:, 1], tx, e, n, beta)
            if sig.wall_compensation:
                r = compensate_walls(r, p, tx, rx, lay.wall_start, lay.wall_end, lay.wall_delay_s)
                p, _ = couple_positions(r[:, 0], r[:, 1], tx, e, n, beta)
            inside = (p[:, 0] >= area[0]) & (p[:, 0] <= area[1]) & (p[:, 1] >= area[2]) & (p[:, 1] <= area[3])
            p, r = p[inside], r[inside]
            # evaluation only: the target both ranges lie near (walls' delay removed from the truth when the chain
            # removed it from the measurements)
            if sig.wall_compensation:
                truth = np.linalg.norm(pos - tx, axis=-1)[None] + np.linalg.norm(pos[None] - rx[:, None], axis=-1)
            else:
                truth = episode.geom.bistatic_range[k, t, self.pairs[[p1, p2], 1]]  # (2, K)
            err = np.where(alive[None], np.abs(truth[None] - r[:, :, None]).max(axis=1), np.inf)  # (L, K)
            best = np.argmin(err, axis=1) if err.shape[1] else np.zeros(p.shape[0], np.int64)
            ok = err.min(axis=1, initial=np.inf) < max(self.origin_tolerance_m, 3.0 * self.range_std_m)
            out_o.append(np.where(ok, best, -1))
            out_p.append(p)
            out_r.append(r)
            out_t.append(np.full(p.shape[0], t, dtype=np.int64))
        origin = np.concatenate(out_o) if out_o else np.zeros(0, np.int64)
        return np.concatenate(out_p), np.concatenate(out_r), np.concatenate(out_t), origin.astype(np.int64)

    def localize_couples(
        self, episode: SignalEpisode, k: int, tr: ScanTrace, plan: ScanPlan, time_s: float
    ) -> Detections:
        """Seed 001's network chain (``network = "couples"``): one record of the couples' 2-D positions."""
        sig = self.sig
        p, r, txi, origin = self.couples(episode, k, tr, associate=sig.toa_association)
        R = np.zeros((p.shape[0], 2, 2))
        for t, p1, p2, *_ in self.couple_groups:  # transmitters: one or a few
            sel = txi == t
            if sel.any():
                rx = self.layout.rx_pos[self.pairs[[p1, p2], 1]]
                R[sel] = couple_covariance(
                    p[sel], self.layout.tx_pos[t], rx, self.range_std_m**2, sig.couple_common_std_m**2
                )
        observed = any(np.isin([p1, p2], tr.pairs).all() for _, p1, p2, *_ in self.couple_groups)
        weight = None
        if episode.clutter_map is not None and sig.clutter_map_count == "still":
            weight = self._still_couples(episode, r, txi, observed)
        return self._positions(
            p, R, np.zeros(p.shape[0]), origin, plan, time_s, episode, observed=observed, map_weight=weight
        )

    def _still_couples(self, episode: SignalEpisode, r: FloatArray, txi: IntArray, observed: bool) -> FloatArray:
        """``(L,)`` 1 for a couple that has not moved since the previous scan, else 0 (``clutter_map_count = "still"``).

        Still: both its ranges within step 6's stillness bound (``STILL_SAMPLES`` of the chain's clock, as bistatic
        range) of one couple of the same transmitter in the previous observed scan. A static residue of the
        background subtraction sits on the sample grid and flickers by at most a sample; a walking person's bistatic
        range moves ~1.8 samples per scan (0.8 m/s radially), and its ranges' errors (~0.13 m, two samples) rarely
        repeat both within the bound. The sensor's own stand-in for Musicki's refinement (the tracker's association
        probabilities do not come back to the sensor).
        """
        bound = self.still_s * SPEED_OF_LIGHT_MPS
        prev = episode.map_previous
        still = np.zeros(r.shape[0])
        if prev is not None:
            pr, pt = prev
            for t in np.unique(txi).tolist():  # transmitters: one or a few
                a, b = r[txi == t], pr[pt == t]
                if a.size and b.size:
                    near = (np.abs(a[:, None, :] - b[None]) <= bound).all(axis=-1).any(axis=1)
                    still[txi == t] = near
        if observed:
            episode.map_previous = (r.copy(), txi.copy())
        return still
