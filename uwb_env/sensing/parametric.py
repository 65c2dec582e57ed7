r"""Fast (parametric) sensing: detections drawn from calibrated models (the fast fidelity).

For every transmitter-receiver pair and target in a scan:

1. mean SNR from the bistatic radar equation with the 802.15.4a path loss and the wall losses of both legs
   (``uwb_env.channel``); the waveform sets the energy and spectrum through the radar constant Gamma;
2. the scan's RCS is drawn per pair and target (Swerling 0 / I / III, scan-to-scan; pairs see the target from
   different aspects, so their fluctuations are independent);
3. detection is the square-law test itself: |sqrt(SNR) + n|^2 > -ln Pfa with n ~ CN(0, 1). Averaged over the RCS
   this has exactly the Pd of ``uwb_env.sensing.pd`` for the Swerling case (tested); the test sees the SNR times
   ``SensingConfig.detection_gain_db`` (the signal path's peak search over neighbouring cells and beams, calibrated
   by ``scripts/calibrate_chirp.py``; 0 dB by default); a covered target is also detected when a noise peak falls in
   the signal detector's truth-matching window around its echo, probability 1 - (1 - Pfa)^n for the window's n
   cells (``SensingConfig.noise_window_cells``; 0 by default), so Pd = 1 - (1 - Pd_echo) (1 - Pfa)^n
   (``uwb_env.sensing.pd.windowed_detection_probability``, in the sensing and in the sensor model alike); such a
   detection is measured like the echo (R at the echo's SNR), and the false alarms keep their own density;
4. a detected target is measured as h(x) + v, v ~ N(0, R(SNR)), R the waveform's CRLB at the scan's true SNR
   (bistatic range; range-rate for chirps; azimuth from the ULA CRLB for array receivers when enabled); walls add
   the excess delay of seed 002 as a positive range bias, which a radar that knows its walls removes
   (``SensingConfig.compensate_walls``, :meth:`ParametricSensor._wall_compensation`);
5. false detections: a spatial Poisson process of ``clutter.density_per_m2`` over the surveillance area, part of it
   around the clutter scatterers, drawn independently per pair and thinned to the pair's coverage. Their apparent
   SNR is that of noise over the threshold (V_T + Exp(1) - 1), their true range-rate is uniform in
   +-``range_rate_max_mps``, and they are measured through the same waveform as targets (noise of R at their
   apparent SNR), so no statistic but the likelihood tells a false alarm from a target. With
   ``clutter.reference_bandwidth_hz`` the density is per waveform, x B_w / reference (a detector's false alarms
   scale with its resolution cells): drawn at the library's largest rate and thinned per waveform with one spare
   uniform each, so a narrower waveform's false alarms are a subset of a wider one's (:meth:`_draw_clutter`);
6. every detection carries ``clutter_intensity``, the known clutter map in measurement space at its value (the
   rho_i of PDA / LMIPDA): the pair's density of false alarms in bistatic range -- or, for array receivers that
   measure azimuth, in (range, azimuth), broadened by the direction-finding noise -- precomputed by quadrature
   over the area and the scatterers, x the density of a false alarm's measured range-rate,
   N(0, R_dd + rdot_max^2 / 3) (uniform truth plus measurement noise), or 1 / period for a chirp train whose
   range-rate is measured folded (every measured range-rate, target or not, is folded into the waveform's
   ambiguity interval lambda / T1: ``fold_range_rate``); with ``clutter.reference_bandwidth_hz``, x the waveform's
   factor B_w / reference (item 5).

7. multipath ghosts (``SensingConfig.ghost_rate``, calibrated on the chirp signal path): detections on a covered
   target's paths through a scatterer, beyond its bistatic range (:meth:`ParametricSensor._draw_ghosts`); to the
   tracker they are false alarms.

A target is not detected by a pair when it is not alive, beyond ``max_range_m`` from either node, inside the blind
zone (seed 000 section IV-G), hidden by an opaque wall, or outside the array's field of view.

Randomness and common random numbers: at the start of an episode (:meth:`ParametricSensor.new_episode`) the RCS,
noise and clutter streams draw, for every scan and every formed pair, everything a scan can need -- RCS factors,
detection and measurement noise, and the gated false alarms. Nothing drawn depends on the plan, so two plans (two
schedulers) on the same seed see the same RCS, noise and clutter realisations, and the truth is never touched; a
scan (:meth:`ParametricSensor.sense`) then only applies the plan, which is what makes it cheap.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numba as nb
import numpy as np
from scipy.special import roots_genlaguerre

from uwb_env.channel.background_mti import (
    MtiTable,
    amplitude_fluctuation,
    envelope_std_s,
    retained_fraction_history,
)
from uwb_env.channel.coverage import blind_zone, in_field_of_view
from uwb_env.channel.doppler_notch import (
    bistatic_range_rate,
    clutter_cnr_profile,
    doppler_notch_gain,
    doppler_notch_gain_at,
    notch_terms,
    train_doppler_spread_hz,
)
from uwb_env.channel.radar_equation import bistatic_radar_constant, direct_path_snr, leg_lengths
from uwb_env.channel.rcs import rcs_fluctuation, swerling_weights
from uwb_env.channel.walls import pair_obstruction
from uwb_env.config import ReceiverConfig, ScenarioConfig, TransmitterConfig
from uwb_env.constants import SPEED_OF_LIGHT_MPS
from uwb_env.rng import RngStreams
from uwb_env.scene.geometry import segments_cross
from uwb_env.scene.layout import SceneLayout
from uwb_env.scene.truth import Truth
from uwb_env.sensing.beams import beam_gain, beam_sines
from uwb_env.sensing.compiled import expected_covariance, mean_link, walk_gain, walk_scale
from uwb_env.sensing.pd import (
    detection_probability,
    noise_window_probability,
    threshold_from_pfa,
    windowed_detection_probability,
)
from uwb_env.sensing.protocol import register_sensor
from uwb_env.sensing.records import Detections, ScanPlan
from uwb_env.typing import BoolArray, FloatArray, IntArray
from uwb_env.units import dbm_to_watts
from uwb_env.waveforms.chirp import fold_periodic as fold_range_rate  # range-rate modulo lambda / T1
from uwb_env.waveforms.chirp import range_migration_accuracy
from uwb_env.waveforms.library import Waveform, WaveformLibrary

_RESIDUE_NODES = 24  # Gauss-Laguerre nodes of the residue-level average (1e-4 in Pd: tests/unit/test_parametric.py)


def residue_quadrature(looks: float) -> tuple[FloatArray, FloatArray]:
    """Nodes and weights ``(J,)`` of E_X[f(X)] for the clutter residue level X ~ Gamma(looks, 1 / looks).

    Generalised Gauss-Laguerre with ``_RESIDUE_NODES`` nodes (mean 1); ``looks = 0`` is a constant residue, X = 1.
    The parametric Pd is E_X[Pd(SNR / (1 + kappa SNR_dp X))] (``SensingConfig.clutter_residue_ratio``).
    """
    if looks <= 0.0:
        return np.ones(1), np.ones(1)
    nodes, weights = roots_genlaguerre(_RESIDUE_NODES, looks - 1.0)
    return nodes / looks, weights / weights.sum()


@dataclass(frozen=True, slots=True)
class EpisodeGeometry:
    """Truth-dependent quantities of every scan, computed once per episode (they never depend on actions).

    Shapes: S scans, T transmitters, R receivers, K targets.

    Attributes:
        bistatic_range: ``(S, T, R, K)`` [m], excess delay bias included as range.
        range_rate: ``(S, T, R, K)`` [m/s].
        azimuth: ``(S, R, K)`` [rad] global azimuth seen from each receiver.
        unit_snr: ``(S, T, R, K)`` SNR per unit radar constant: sigma_mean / (l_t l_r / d0^2)^rho / L_walls.
        covered: ``(S, T, R, K)`` alive, in range, out of the blind zone, not blocked, in the field of view.
    """

    bistatic_range: FloatArray
    range_rate: FloatArray
    azimuth: FloatArray
    unit_snr: FloatArray
    covered: BoolArray


# Row layout of a detection inside the sensor (m = measurement dimension of the library):
#   [pair index, z_0 .. z_{m-1}, azimuth, SNR, origin, clutter intensity, azimuth variance]
def _link_budget(
    wf: Waveform, tx: TransmitterConfig, rx: ReceiverConfig
) -> tuple[float, float, float, float, float, float]:
    """The link arguments the radar constant and the direct-path SNR share.

    Scan energy [J], centre frequency and RMS bandwidth [Hz], Tx and Rx antenna gains [dB], Rx noise figure [dB].
    """
    return (
        wf.scan_energy_j(dbm_to_watts(tx.power_dbm)),
        wf.center_freq_hz,
        wf.rms_bandwidth_hz,
        tx.antenna_gain_db,
        rx.antenna_gain_db,
        rx.noise_figure_db,
    )


def receiver_beams(
    cfg: ScenarioConfig, layout: SceneLayout, library: WaveformLibrary
) -> list[tuple[FloatArray | None, int, float, float]]:
    """Per receiver: (beam sines (M,) or None, L, d [m], lambda [m]) of ``sensing.array_beams`` (``beams``).

    Beams are formed at the carrier: a library of several carriers with array receivers needs ``steered``.
    """
    kind = cfg.sensing.array_beams
    carriers = {w.wavelength_m for w in library.waveforms}
    lam = library[0].wavelength_m
    if kind != "steered" and layout.rx_has_array.any() and len(carriers) > 1:
        raise ValueError(
            f"sensing.array_beams = {kind!r} in {cfg.name!r}: beams are formed at one carrier, the library has "
            f"{len(carriers)}; use 'steered' or one carrier"
        )
    out: list[tuple[FloatArray | None, int, float, float]] = []
    for r in range(layout.n_rx):  # receivers: a handful
        if not layout.rx_has_array[r]:
            out.append((None, 1, 0.0, lam))
            continue
        n_el, spacing = int(layout.rx_n_elements[r]), float(layout.rx_spacing_m[r])
        out.append((beam_sines(kind, n_el, spacing, lam), n_el, spacing, lam))
    return out


def _columns(m: int) -> dict[str, int]:
    cols = {"pair": 0, "z": 1, "az": 1 + m, "snr": 2 + m, "origin": 3 + m, "rho": 4 + m, "az_var": 5 + m}
    # walk_r, walk_d: variance factors of range and range-rate from the range walk (target rows; 0 elsewhere: 1)
    return {**cols, "walk_r": 6 + m, "walk_d": 7 + m, "n": 8 + m}


class WaveformRows:
    """False-alarm rows ``(W, N, n)`` measured per waveform on first use (``EpisodeSensing.clutter_rows``).

    Waveform w's rows are ``ParametricSensor._measure`` of the episode's noise-free false alarms through w: the same
    call on the same inputs whenever it runs, so measuring only the waveforms an episode sends gives the same
    numbers as measuring all W at reset (an episode of a scheduler sends a few of the library's). Reads:
    ``rows[w, sl]`` (one waveform) and ``rows[w_rows, idx]`` (per-row waveforms ``(n,)`` with row indices ``(n,)``);
    ``np.asarray(rows)`` measures every waveform.
    """

    __slots__ = ("_measure_waveform", "_measured", "shape")

    def __init__(self, shape: tuple[int, int, int], measure_waveform: Callable[[int], FloatArray]) -> None:
        self.shape = shape
        self._measure_waveform = measure_waveform
        self._measured: list[FloatArray | None] = [None] * shape[0]

    def waveform(self, w: int) -> FloatArray:
        """Waveform ``w``'s rows ``(N, n)`` (measured on the first call)."""
        rows = self._measured[w]
        if rows is None:
            rows = self._measured[w] = self._measure_waveform(w)
        return rows

    def __getitem__(self, key: tuple) -> FloatArray:
        w, *rest = key if isinstance(key, tuple) else (key,)
        if isinstance(w, (int, np.integer)):
            return self.waveform(int(w))[tuple(rest)]
        w = np.asarray(w)
        if len(rest) == 1 and w.ndim == 1 and np.shape(rest[0]) == w.shape:  # per-row waveforms (sense)
            idx = np.asarray(rest[0])
            out = np.empty((w.size, self.shape[2]))
            for u in np.unique(w):  # the waveforms sent in one scan: a few
                sel = w == u
                out[sel] = self.waveform(int(u))[idx[sel]]
            return out
        return np.asarray(self)[key]

    def __array__(self, dtype: object = None, copy: object = None) -> FloatArray:
        out = np.stack([self.waveform(w) for w in range(self.shape[0])]) if self.shape[0] else np.zeros(self.shape)
        return out if dtype is None else out.astype(dtype)

    def __len__(self) -> int:
        return self.shape[0]


class _ClutterMeasurement:
    """``ParametricSensor._measure`` of an episode's false alarms through one waveform (a picklable callable)."""

    __slots__ = ("args", "base", "sensor")

    def __init__(self, sensor: ParametricSensor, base: FloatArray, args: tuple) -> None:
        self.sensor, self.base, self.args = sensor, base, args

    def __call__(self, w: int) -> FloatArray:
        e, az, n_az, tx, rx, m, azimuth_cache, scale = self.args
        rows = self.base.copy()
        self.sensor._measure(rows, e, az, n_az, tx, rx, w, m, azimuth_cache, scale)
        return rows


@dataclass(frozen=True, slots=True)
class EpisodeSensing:
    """Everything a scan can return in one episode, for every waveform of the library (module docstring).

    A detection's SNR, its detection decision, its noisy measurement and its clutter intensity depend only on
    the pre-drawn randomness and on the waveform that lit it, so they are computed here, once per waveform; a scan
    then only selects by plan. Memory is W x S x T x R x K rows for targets and W x N rows for false alarms.

    Attributes:
        geometry: the truth-dependent geometry.
        target_rows: ``(W, S, T, R, K, 8 + m)`` every possible target detection in the row layout above.
        target_hit: ``(W, S, T, R, K)`` the square-law decision |sqrt(SNR) + n|^2 > V_T, or a noise peak in the
            truth-matching window (``SensingConfig.noise_window_cells``) (False where not covered).
        clutter_rows: ``(W, N, 8 + m)`` the false alarms that fall in their pair's gate, sorted by scan then pair
            (:class:`WaveformRows`: each waveform's measured when first read).
        clutter_tx, clutter_rx: ``(N,)`` their nodes.
        clutter_start: ``(S + 1,)`` offsets of each scan's false alarms.
        clutter_keep: ``(W, N)`` whether each waveform keeps each row (the per-waveform false-alarm rate,
            ``ClutterConfig.reference_bandwidth_hz``; multipath ghosts are kept by every waveform), or None: every
            waveform keeps every row.
    """

    geometry: EpisodeGeometry
    target_rows: FloatArray
    target_hit: BoolArray
    clutter_rows: WaveformRows
    clutter_tx: np.ndarray
    clutter_rx: np.ndarray
    clutter_start: np.ndarray
    clutter_keep: BoolArray | None = None


def accuracy_snr_caps(unit_covariances: list[FloatArray | None], min_range_std_m: float) -> FloatArray:
    r"""``(W,)`` the SNR above which each waveform's measurement accuracy stops improving.

    The CRLB models scale as R(SNR) = R_1 / SNR without bound, so a strong enough echo (a valid +100 dBm
    transmitter, a target next to a receiver) gives range variances of 1e-20 m^2 and below: far under anything a
    receiver can resolve, and under the rounding error of the tracker's covariance update (``P`` of ~1 m^2 loses
    positive-definiteness at 1e-16 relative). A real receiver's range accuracy is floored by its timing: the
    sampling clock's jitter and the ToA interpolation's residual error, sigma_t = ``min_range_std_m`` / c
    (``SensingConfig.min_range_std_m``; the default 50 um is 0.17 ps, a low-jitter sampling clock, below every
    CRLB of the built-in scenarios at their configured powers). The floor is applied as an accuracy SNR

    .. math:: \mathrm{SNR}_\mathrm{acc} = \min(\mathrm{SNR}, R_1[0, 0] / \sigma_\mathrm{min}^2),

    so R keeps its R_1 / SNR form (range, range-rate and the array's azimuth variance saturate together, at the
    SNR where the range std reaches the floor) and the noise draws keep their streams. Detection (Pd) uses the
    uncapped SNR. Waveforms whose model has its own floor (the energy detector's T_int / sqrt 12, ``unit_covariance``
    None) get ``inf``.
    """
    floor = float(min_range_std_m) ** 2
    return np.array([np.inf if u is None else float(u[0, 0]) / floor for u in unit_covariances])


def azimuth_variance(
    snr_total: FloatArray,
    n_elements: FloatArray,
    spacing_m: FloatArray,
    wavelength_m: float,
    off_boresight_rad: FloatArray,
) -> FloatArray:
    r"""ULA direction-of-arrival CRLB [rad^2] for one source, deterministic signal.

    var(theta) = 6 / (SNR_e L (L^2 - 1) (2 pi d cos(theta) / lambda)^2), SNR_e = SNR_total / L per element
    (phase-slope estimation across L elements, each phase with variance 1 / (2 SNR_e)).
    """
    snr_e = snr_total / n_elements
    k = 2.0 * math.pi * spacing_m * np.cos(off_boresight_rad) / wavelength_m
    return 6.0 / (snr_e * n_elements * (n_elements**2 - 1.0) * k**2)


_NO_TABLE, _NO_ROW = np.zeros((1, 1)), np.zeros(1)  # _moving_link's placeholders without notch or walk tables


@nb.njit(cache=True, fastmath=False, nogil=True)
def _moving_link_kernel(
    tx_xy, rx_xy, pos, vel, wall_a, wall_b, wall_loss, wall_delay, boresight, fov, max_range, baseline, blind_excess,
    formed, d0, rho, beam_sines, beam_kd, n_elements, k, rcs, gain, weights, pfa, p_noise, w, notch_on, cnr_table,
    step, wavelength_m, pri_s, sigma_f_hz, walk_on, walk_pd_table, walk_peak_table, walk_step,
):  # pragma: no cover - compiled  # fmt: skip
    """``mean_link``, ``bistatic_range_rate``, ``notch_terms`` and ``walk_gain`` (x2) of one pair in one call.

    The same compiled functions on the same arguments as ``ParametricSensor.expected_measurements``' numpy path
    (so the same numbers); Pd is left to the caller (numpy's exp). Returns ``(azimuth (N,), covered (N,),
    snr (W, N), range-rate (N,), cnr (W, N), exponent (W, N), walk gain for Pd (W, N), for the peak (W, N))``.
    """
    az, ok, snr, _ = mean_link(
        tx_xy, rx_xy, pos, wall_a, wall_b, wall_loss, wall_delay, boresight, fov, max_range, baseline, blind_excess,
        formed, d0, rho, beam_sines, beam_kd, n_elements, k, rcs, gain, weights, pfa, 1, p_noise,
    )  # fmt: skip
    rng, rdot = bistatic_range_rate(pos, vel, tx_xy, rx_xy)
    W, N = w.shape[0], pos.shape[0]
    if notch_on:
        cnr, arg = notch_terms(cnr_table, step, wavelength_m, pri_s, sigma_f_hz, w, rng, rdot)
    else:
        cnr, arg = np.zeros((W, N)), np.zeros((W, N))
    if walk_on:
        walk_pd = walk_gain(w, rdot, walk_pd_table, walk_step)
        walk_peak = walk_gain(w, rdot, walk_peak_table, walk_step)
    else:
        walk_pd, walk_peak = np.ones((W, N)), np.ones((W, N))
    return az, ok, snr, rdot, cnr, arg, walk_pd, walk_peak


@nb.njit(cache=True, fastmath=False, nogil=True)
def _moving_links_kernel(
    txy, rxy, pos, vel, wall_a, wall_b, wall_loss, wall_delay, boresight, fov, max_range, baseline, blind_excess,
    formed, d0, rho, sines, n_sines, kd, n_el, k, rcs, gain, weights, pfa, p_noise, w, starts, notch_on, cnr_tables,
    step, wavelength_m, pri_s, sigma_f_hz, walk_on, walk_pd_table, walk_peak_table, walk_step,
):  # pragma: no cover - compiled  # fmt: skip
    """:func:`_moving_link_kernel` of P pairs in one call: pair p's waveforms are rows ``starts[p]:starts[p + 1]``.

    Per pair ``txy``, ``rxy`` ``(P, 2)``, boresight, fov, baseline ``(P,)``, formed ``(P,)``, beams ``sines (P, M)``
    (the first ``n_sines[p]``), ``kd``, ``n_el`` ``(P,)``, ``cnr_tables`` ``(P, W_lib, G)``; per row k, gain, w. The
    same functions on the same numbers as pair by pair. Returns ``az, ok, rdot (P, N)`` and ``snr, cnr, exponent,
    walk gains (S, N)``.
    """
    P, N, S = txy.shape[0], pos.shape[0], w.shape[0]
    az, ok, rdot = np.empty((P, N)), np.empty((P, N), np.bool_), np.empty((P, N))
    snr, cnr, arg = np.empty((S, N)), np.zeros((S, N)), np.zeros((S, N))
    walk_pd, walk_peak = np.ones((S, N)), np.ones((S, N))
    for p in range(P):
        lo, hi = starts[p], starts[p + 1]
        az_p, ok_p, snr_p, _ = mean_link(
            txy[p], rxy[p], pos, wall_a, wall_b, wall_loss, wall_delay, boresight[p], fov[p], max_range, baseline[p],
            blind_excess, formed[p], d0, rho, sines[p, : n_sines[p]], kd[p], n_el[p], k[lo:hi], rcs, gain[lo:hi],
            weights, pfa, 1, p_noise,
        )  # fmt: skip
        rng_p, rdot_p = bistatic_range_rate(pos, vel, txy[p], rxy[p])
        az[p], ok[p], rdot[p], snr[lo:hi] = az_p, ok_p, rdot_p, snr_p
        if notch_on:
            cnr_p, arg_p = notch_terms(cnr_tables[p], step, wavelength_m, pri_s, sigma_f_hz, w[lo:hi], rng_p, rdot_p)
            cnr[lo:hi], arg[lo:hi] = cnr_p, arg_p
        if walk_on:
            walk_pd[lo:hi] = walk_gain(w[lo:hi], rdot_p, walk_pd_table, walk_step)
            walk_peak[lo:hi] = walk_gain(w[lo:hi], rdot_p, walk_peak_table, walk_step)
    return az, ok, rdot, snr, cnr, arg, walk_pd, walk_peak


@nb.njit(cache=True, fastmath=False, nogil=True)
def _expected_covariances_kernel(
    az, ok, snr, starts, snr_cap, unit_cov, doa, boresight, n_elements, spacing, wavelengths, w, rdot, walk_on,
    gain, c_range, c_rate, half_dwell, period, walk_step,
):  # pragma: no cover - compiled  # fmt: skip
    """``expected_covariance`` then ``walk_scale`` of P pairs (rows ``starts[p]:starts[p + 1]``), ``(S, N, m, m)``.

    The same functions on the same numbers as pair by pair; every pair with one measurement dimension m
    (``doa`` all equal).
    """
    S, N = snr.shape
    m = unit_cov.shape[1] + (1 if doa[0] else 0)
    R = np.empty((S, N, m, m))
    for p in range(starts.shape[0] - 1):
        lo, hi = starts[p], starts[p + 1]
        R_p = expected_covariance(
            az[p], ok[p], snr[lo:hi], snr_cap[lo:hi], unit_cov[lo:hi], doa[p], boresight[p], n_elements[p], spacing[p],
            wavelengths[lo:hi],
        )  # fmt: skip
        if walk_on and m >= 2:
            R_p = walk_scale(R_p, w[lo:hi], rdot[p], gain, c_range, c_rate, half_dwell, period, walk_step)
        R[lo:hi] = R_p
    return R


@register_sensor("parametric", "chirp", "impulse")
class ParametricSensor:
    """Turns truth and a scan plan into per-pair :class:`Detections` (component tier: config + kernels)."""

    def __init__(self, cfg: ScenarioConfig) -> None:
        self.cfg = cfg
        self.layout = SceneLayout.from_config(cfg)
        self.library = WaveformLibrary(cfg.waveforms)
        lay = self.layout
        self.n_tx, self.n_rx = lay.n_tx, lay.n_rx
        self.baseline = lay.baselines
        self.threshold = threshold_from_pfa(cfg.sensing.false_alarm_probability)
        self.swerling = np.array([t.swerling for t in cfg.targets], dtype=np.int64)
        self._beams = receiver_beams(cfg, lay, self.library)
        self.rcs_mean = np.array([t.rcs_mean_m2 for t in cfg.targets])
        self._swerling_w = swerling_weights(self.swerling)
        # the detection test's own Swerling case (SensingConfig.detection_swerling; None: each target's, as above):
        # the signal path and the MTI's nu keep reading ``self.swerling``, only new_episode's RCS draws take this
        ds = cfg.sensing.detection_swerling
        self._detect_swerling_w = self._swerling_w if ds is None else swerling_weights(np.full_like(self.swerling, ds))
        # Radar constant per (waveform, tx, rx): the energy and spectrum of the waveform, the nodes' gains.
        self.radar_constant = self._per_link(
            lambda wf, tx, rx, _: bistatic_radar_constant(
                *_link_budget(wf, tx, rx), rx.array.n_elements if rx.array else 1, cfg.channel
            )
        )
        # Direct-path SNR over each baseline (at least d0); with clutter_residue_ratio kappa the detector sees
        # SCNR = SNR / (1 + kappa SNR_dp X) (SensingConfig).
        d0 = np.maximum(lay.baselines, cfg.channel.reference_distance_m)
        self.direct_path_snr = self._per_link(
            lambda wf, tx, rx, tr: direct_path_snr(*_link_budget(wf, tx, rx), d0[tr], cfg.channel)
        )
        kappa, looks = cfg.sensing.clutter_residue_ratio, cfg.sensing.clutter_residue_looks
        self._residue = kappa > 0.0
        self._residue_nodes, self._residue_weights = residue_quadrature(looks)
        # The detector's SNR gain over the single-cell square-law test (SensingConfig.detection_gain_db plus each
        # impulse waveform's own, ImpulseWaveformConfig.detection_gain_db), for Pd only: (W,).
        gain_db = [cfg.sensing.detection_gain_db + getattr(w, "detection_gain_db", 0.0) for w in cfg.waveforms]
        self._pd_gain = 10.0 ** (np.array(gain_db, dtype=float) / 10.0)
        self._any_pd_gain = bool(np.any(self._pd_gain != 1.0))
        # A noise peak in the truth-matching window also detects the target (SensingConfig.noise_window_cells).
        self._window_cells = float(cfg.sensing.noise_window_cells)
        self._p_noise = noise_window_probability(cfg.sensing.false_alarm_probability, self._window_cells)
        self.detection_gain = self._pd_gain[:, None, None, None] / (
            1.0 + kappa * self.direct_path_snr[..., None] * self._residue_nodes
        )
        self.pairs = np.array(cfg.radar_pairs, dtype=np.int64).reshape(-1, 2)  # (P, 2) formed (tx, rx)
        self.pair_mask = np.zeros((self.n_tx, self.n_rx), dtype=bool)
        self.pair_mask[self.pairs[:, 0], self.pairs[:, 1]] = True
        self.use_doa = cfg.sensing.measure_doa
        names = list(self.library.measurement_names)
        self._doa_rx = lay.rx_has_array & self.use_doa
        self._names = {r: tuple(names + (["azimuth"] if self._doa_rx[r] else [])) for r in range(self.n_rx)}
        self._boresight = np.nan_to_num(lay.rx_boresight_rad)
        self._clutter_mean, self._range_table = self._clutter_statistics()
        # Per-scan constants, precomputed for the hot path.
        self._pair_list = [tuple(p) for p in self.pairs.tolist()]
        self._pair_keys = np.array([t * self.n_rx + r for t, r in self._pair_list], dtype=np.int64)
        self._expected_false = [float(self._clutter_mean[t, r]) for t, r in self._pair_list]
        self._pair_of_key = np.full(self.n_tx * self.n_rx, -1, dtype=np.int64)
        self._pair_of_key[self._pair_keys] = np.arange(len(self._pair_list))
        self._pair_of_tr = self._pair_of_key.reshape(self.n_tx, self.n_rx).astype(float)
        self._pair_index = np.arange(len(self._pair_list), dtype=float)
        self._bin_scale = (len(self._range_edges) - 1) / self._range_edges[-1]
        self._az_r_scale = (len(self._az_range_edges) - 1) / self._az_range_edges[-1]
        self._az_scale = (len(self._az_edges) - 1) / (2.0 * math.pi)
        self._m = self.library.measurement_dim
        self._az_slot = np.full(self.pairs.shape[0], -1, dtype=np.int64)
        for i, p in enumerate(sorted(self._az_tables)):
            self._az_slot[p] = i
        self._az_stack = np.stack([self._az_tables[p] for p in sorted(self._az_tables)]) if self._az_tables else None
        self._all_doa = bool((self._az_slot >= 0).all())
        self._rdot_var = cfg.sensing.clutter.range_rate_max_mps**2 / 3.0
        self._rdot_max = cfg.sensing.clutter.range_rate_max_mps
        self._any_array = bool(lay.rx_has_array.any())
        self._any_doa = bool(self._doa_rx.any())
        self._fov = np.where(lay.rx_has_array, np.nan_to_num(lay.rx_fov_rad), np.inf)
        self._tx_index = np.arange(self.n_tx)
        area = (lay.area[1] - lay.area[0]) * (lay.area[3] - lay.area[2])
        self._clutter_total = cfg.sensing.clutter.density_per_m2 * area
        # false alarms per waveform (ClutterConfig.reference_bandwidth_hz): factor B_w / reference, drawn at the
        # largest and thinned per waveform where the factors differ
        self.false_alarm_scale = false_alarm_scale(cfg)  # (W,)
        self._fa_scaled = bool(np.any(self.false_alarm_scale != 1.0))
        self._fa_max = float(self.false_alarm_scale.max())
        self._fa_thin = bool(np.any(self.false_alarm_scale != self._fa_max))
        self._expected_false_w = [
            [float(self._clutter_mean[t, r] * f) for t, r in self._pair_list] for f in self.false_alarm_scale.tolist()
        ]
        self._unit_cov = [w.unit_covariance for w in self.library.waveforms]
        self._snr_cap = accuracy_snr_caps(self._unit_cov, cfg.sensing.min_range_std_m)
        self._geometry_cache: tuple[FloatArray, BoolArray, EpisodeGeometry] | None = None
        self._compensate_walls = bool(cfg.sensing.compensate_walls) and lay.wall_start.shape[0] > 0
        self._valid_plans: dict[int, tuple[ScanPlan, tuple[bool, int, bool, list[int]]]] = {}
        self._bx, self._by = np.cos(self._boresight), np.sin(self._boresight)
        self._rx_x, self._rx_y = lay.rx_pos[:, 0].copy(), lay.rx_pos[:, 1].copy()
        self._cos_fov = np.cos(np.minimum(self._fov, math.pi))
        self._unit_chol = [None if c is None else np.linalg.cholesky(c) for c in self._unit_cov]
        self._all_unit_chol = all(c is not None for c in self._unit_chol)
        self._unit_chol_stack = np.stack(self._unit_chol) if self._all_unit_chol else None
        self._unit_cov_stack = np.stack(self._unit_cov) if self._all_unit_chol else None
        self._wavelengths = np.array([w.wavelength_m for w in self.library.waveforms])
        self.range_rate_period = self.library.range_rate_periods  # (W,) lambda / T1 of chirp trains; inf: unambiguous
        self._unit_gain = self._pd_gain[:, None].copy()  # no clutter residue: one node
        self._unit_weight = np.ones(1)
        self._link_cache: dict[tuple[int, ...], tuple] = {}  # mean_link's arguments per (tx, rx, waveforms...)
        self._covariance_args: dict[tuple[int, ...], tuple] = {}  # expected_covariance's, keyed alike
        self._pack_cache: dict[tuple, tuple] = {}  # the multi-pair kernels' arguments per pairs' keys
        self._notch = self._static_clutter_tables()
        self._migration = self._migration_tables()
        self._mti = self._background_mti_table()

    def _static_clutter_tables(self) -> tuple[FloatArray, float, FloatArray, FloatArray, FloatArray] | None:
        """The zero-Doppler clutter notch of chirp trains (``uwb_env.channel.doppler_notch``), or None.

        Returns ``(cnr (W, T, R, G), grid step [m], pri (W,), sigma_f (W,), wavelength (W,))``: each pair's CNR of
        the static scatterers over bistatic range (grid from 0 in steps of 0.5 m), per waveform.
        """
        cl = self.cfg.sensing.clutter
        pts = self.layout.clutter_points
        chirps = [w for w in self.library.waveforms if hasattr(w, "range_rate_ambiguity_mps")]
        if cl.scatterer_rcs_m2 <= 0.0 or pts.shape[0] == 0 or len(chirps) != len(self.library):
            return None
        every = slice(None)
        lt, lr, _, delay_s, _, covered, unit_snr = self._links(every, every, pts)  # (T, C), (R, C), (T, R, C)
        r_c = lt[:, None] + lr[None] + SPEED_OF_LIGHT_MPS * delay_s
        snr_unit = np.where(covered, unit_snr * cl.scatterer_rcs_m2, 0.0)
        step = 0.5
        grid = np.arange(0.0, 2.0 * self.cfg.sensing.max_range_m + float(self.baseline.max()) + 20.0, step)
        W = len(self.library)
        cnr = np.zeros((W, self.n_tx, self.n_rx, grid.size))
        for w, wf in enumerate(self.library.waveforms):  # the library: a small fixed set
            spread = wf.range_spread_m
            for t in range(self.n_tx):  # nodes: a small fixed set
                for r in range(self.n_rx):
                    cnr[w, t, r] = self.radar_constant[w, t, r] * clutter_cnr_profile(
                        r_c[t, r], snr_unit[t, r], grid, spread
                    )
        pri = np.array([w.config.pri_s for w in self.library.waveforms])
        sigma_f = np.array(
            [train_doppler_spread_hz(w.config.n_pulses, w.config.pri_s, cl.doppler_spread_hz) for w in chirps]
        )
        return cnr, step, pri, sigma_f, self._wavelengths.copy()

    # ------------------------------------------------------------------------ seed 001's background MTI (through-wall)
    def _background_mti_table(self) -> MtiTable | None:
        """g(|rdot|) per waveform of the exponential background's MTI (``uwb_env.channel.background_mti``), or None.

        Active only for a scenario whose signal chain subtracts seed 001's exponential average from coherent echoes
        (``SignalConfig.coherent_echoes``, ``background = "exponential-coherent"``: ``through-wall``); every other
        scenario gets None and is unchanged. The retained fraction is the targets' Swerling case's (amplitude
        fluctuation nu drawn per scan; the first target's case: one Swerling case per scenario here), at the scan
        period, the average's factor and the envelope's LPF of the chain, for each waveform's Gaussian pulse.
        """
        sig = self.cfg.sensing.signal
        if not (sig.coherent_echoes and sig.background == "exponential-coherent"):
            return None
        wfs = self.library.waveforms
        nu = amplitude_fluctuation(int(self.swerling[0])) if self.swerling.size else 0.0
        return MtiTable.build(
            np.array([w.center_freq_hz for w in wfs]),
            np.array([envelope_std_s(w.rms_bandwidth_hz) for w in wfs]),
            sig.background_alpha,
            self.cfg.sensing.scan_period_s,
            sig.envelope_lpf_s,
            nu,
        )

    def mti_history(self, geom: EpisodeGeometry) -> FloatArray:
        """``(W, S, T, R, K)`` what the exponential background leaves of each echo, from its delay history.

        ``background_mti.retained_fraction_history`` on the episode's bistatic delays (scan 1 over the empty room's
        reference: 1; the average's start-up and a turning person's range-rate history exact, where
        :meth:`mti_gain` assumes a constant range-rate); all ones where the MTI is inactive.
        """
        W = len(self.library)
        out = np.ones((W, *geom.bistatic_range.shape))
        if self._mti is None:
            return out
        sig = self.cfg.sensing.signal
        nu = amplitude_fluctuation(int(self.swerling[0])) if self.swerling.size else 0.0
        delay = geom.bistatic_range[1:] / SPEED_OF_LIGHT_MPS  # scans 1..S (index 0: the initial state, not sensed)
        done: dict[tuple[float, float], FloatArray] = {}
        for w, wf in enumerate(self.library.waveforms):  # the library: a small fixed set (one pulse shape here)
            key = (float(wf.center_freq_hz), float(envelope_std_s(wf.rms_bandwidth_hz)))
            if key not in done:
                done[key] = retained_fraction_history(
                    delay, sig.background_alpha, key[1], key[0], sig.envelope_lpf_s, nu
                )
            out[w, 1:] = done[key]
        return out

    def mti_gain(self, w: IntArray, range_rate: FloatArray) -> FloatArray:
        """The echo power the exponential background leaves at bistatic ``range_rate`` [m/s] (1 where inactive).

        ``w`` and ``range_rate`` broadcast (:meth:`_background_mti_table`, the steady state of a constant range-rate).
        """
        if self._mti is None:
            return np.ones(np.broadcast_shapes(np.shape(range_rate), np.shape(w)))
        return self._mti(w, range_rate)

    # Range-walk tables: |range-rate| grid [m/s] (bistatic; vehicles stay far below its end, held beyond it).
    _WALK_STEP_MPS = 0.02
    _WALK_MAX_MPS = 120.0

    def _migration_tables(self) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray] | None:
        """Per chirp train, tabulated over |range-rate| (``_WALK_STEP_MPS`` up to ``_WALK_MAX_MPS``), or None.

        Returns ``(gain, c_range, c_rate)`` each ``(W, G)``, the half-dwell T1 (B - 1) / 2 ``(W,)`` [s] and the
        range-rate period ``(W,)`` [m/s] (``uwb_env.waveforms.chirp.range_migration_accuracy``, evaluated once here:
        the lookahead asks for them every scan, for every track and waveform, and a table lookup with linear
        interpolation costs a fraction of the B-pulse sums; its error is < 1e-5 of the values).
        """
        wfs = self.library.waveforms
        if not all(hasattr(w, "migration_gain") for w in wfs):
            return None
        grid = np.arange(0.0, self._WALK_MAX_MPS + self._WALK_STEP_MPS, self._WALK_STEP_MPS)
        tables = [range_migration_accuracy(grid, w.range_spread_m, w.config.pri_s, w.config.n_pulses)[:3] for w in wfs]
        gain, c_range, c_rate = (np.stack([t[i] for t in tables]) for i in range(3))
        half_dwell = np.array([w.config.pri_s * 0.5 * (w.config.n_pulses - 1) for w in wfs])
        period = np.array([w.range_rate_ambiguity_mps for w in wfs])
        # detection's gain (detection_migration_gain): G x the resolution cells the walk 2D spans, capped at 1
        resolution = np.array([SPEED_OF_LIGHT_MPS / w.config.bandwidth_hz for w in wfs])  # c / B_w [m]
        cells = 2.0 * grid[None, :] * half_dwell[:, None] / resolution[:, None]
        self._migration_pd = np.where(cells > 1.0, np.minimum(gain * cells, 1.0), gain)
        return gain, c_range, c_rate, half_dwell, period

    def _walk_lookup(
        self, w: IntArray, range_rate: FloatArray, tables: tuple[FloatArray, ...] | None = None
    ) -> tuple[FloatArray, ...]:
        """``(gain, c_range, c_rate)`` (or ``tables``) of waveforms ``w`` at ``range_rate`` [m/s] (broadcast)."""
        tables = self._migration[:3] if tables is None else tables
        x = np.minimum(np.abs(np.asarray(range_rate, dtype=float)) / self._WALK_STEP_MPS, tables[0].shape[1] - 1.000001)
        i = x.astype(np.int64)
        t = x - i
        w = np.asarray(w, dtype=np.int64)
        return tuple(tab[w, i] * (1.0 - t) + tab[w, i + 1] * t for tab in tables)

    def walk_factors(self, w: IntArray, range_rate: FloatArray, var0: FloatArray) -> FloatArray:
        """``(..., 2)`` factors of the range and range-rate variances from the range walk across each train.

        ``w`` and ``range_rate`` [m/s] broadcast to the rows' shape; ``var0`` ``(..., 2)`` the CRLB at the echo's
        SNR, which already carries the walk's peak loss G (:meth:`migration_gain`): the unwalked bound is G var0.
        ``uwb_env.waveforms.chirp.range_migration_accuracy``: G var0 / c^2 to first order, capped by G var0 + D^2 / 3
        in range (the estimate wanders over the walk D) and by a uniform error over the range-rate period (P^2 / 12).
        """
        w = np.asarray(w, dtype=np.int64)
        if self._migration is None:
            return np.ones((*np.broadcast_shapes(w.shape, np.shape(range_rate)), 2))
        g, c_r, c_d = self._walk_lookup(w, range_rate)
        walk = np.abs(range_rate) * self._migration[3][w]
        period = self._migration[4][w]
        f = np.empty((*np.broadcast_shapes(g.shape, var0.shape[:-1]), 2))
        f[..., 0] = np.minimum(g / np.maximum(c_r, 1e-6) ** 2, g + walk**2 / (3.0 * var0[..., 0]))
        cap = np.maximum(period**2 / (12.0 * var0[..., 1]), 1.0)
        f[..., 1] = np.clip(g / np.maximum(c_d, 1e-6) ** 2, 1.0, cap)
        return f

    def detection_migration_gain(self, w: IntArray, range_rate: FloatArray) -> FloatArray:
        """The range walk's power gain for detection (Pd): :meth:`migration_gain` G x M, capped at 1 -- a fit.

        M = 2 D / (c / B_w), the range resolution cells that the walk 2 D = |rdot| T1 (B - 1) spans, where above 1
        (else G itself). A walked echo leaves a ridge of delay cells, each integrating about B / M pulses at the
        peak's power G (so with a Doppler lobe M times wider), and the detector takes the largest peak in the truth
        window: more near-peak cells with partly independent noise, but one Swerling I amplitude for the whole scan,
        so the cells miss together when it is small. That is not one cell at G M; G x M is an empirical rule fitted on
        the chain: on urban-intersection-wideband's 160 MHz chirp at 9 dB (``scripts/calibrate_chirp.py`` geometry)
        the Pd over |rdot| 8-12 / 12-16 / 16-20 m/s (G -3.0 / -4.1 / -6.4 dB, M 1.3 / 1.8 / 2.3) was that of
        -1.6 / -2.6 / -3.2 dB (G alone under-predicted it by 0.09-0.17), and over the calibration's geometry the
        model's Pd matches (0.416 against 0.419). Known error: a Monte Carlo of the ridge (the chain's delay-Doppler
        grid, correlated noise, Swerling I, largest local maximum in the window) gives effective gains of -1.2 / -2.1
        / -3.1 / -4.1 / -5.3 dB at M = 1 / 1.5 / 2 / 2.5 / 3, where G x M says -1.8 / -1.8 / -2.5 / -3.3 / -4.1 dB:
        Pd off by -0.04 to +0.06 (+0.09 at M = 3), the errors of low and high M cancelling in the calibration's mix.
        A table of that ridge model per waveform would replace the rule. The accuracy keeps G (the fit measures one
        peak: :meth:`walk_factors`). The seed's 40 MHz chirps walk less than one cell (M < 1) below 31 m/s at 10 ms and
        44 m/s at 7 ms: G there, as before.
        """
        if self._migration is None:
            return np.ones(np.broadcast_shapes(np.shape(range_rate), np.shape(w)))
        return self._walk_lookup(w, range_rate, (self._migration_pd,))[0]

    def migration_gain(self, w: IntArray, range_rate: FloatArray) -> FloatArray:
        """Power gain (<= 1) of each waveform's coherent train for targets walking at ``range_rate`` [m/s].

        ``w`` and ``range_rate`` broadcast; 1 for libraries without pulse trains
        (``uwb_env.waveforms.chirp.range_migration_gain``: seed 003's filter does not follow the range walk).
        """
        if self._migration is None:
            return np.ones(np.broadcast_shapes(np.shape(range_rate), np.shape(w)))
        return self._walk_lookup(w, range_rate)[0]

    def clutter_to_noise(self, w: IntArray, tx: IntArray, rx: IntArray, bistatic_range: FloatArray) -> FloatArray:
        """CNR(r) of the static scatterers at ``bistatic_range`` [m] (0 without static clutter); arguments broadcast."""
        if self._notch is None:
            return np.zeros(np.broadcast_shapes(np.shape(bistatic_range), np.shape(w)))
        cnr_table, step = self._notch[0], self._notch[1]
        g = np.clip(np.rint(np.asarray(bistatic_range) / step).astype(np.int64), 0, cnr_table.shape[-1] - 1)
        return cnr_table[w, tx, rx, g]

    def notch_gain(
        self, w: IntArray, tx: IntArray, rx: IntArray, bistatic_range: FloatArray, range_rate: FloatArray
    ) -> FloatArray:
        """SCNR / SNR of targets at ``bistatic_range`` [m] and ``range_rate`` [m/s] (1 without static clutter).

        Every argument broadcasts (waveform, tx and rx indices included); ``uwb_env.channel.doppler_notch``.
        """
        if self._notch is None:
            return np.ones(np.broadcast_shapes(np.shape(bistatic_range), np.shape(w)))
        cnr_table, step, pri, sigma_f, lam = self._notch
        eta = self.cfg.sensing.clutter.residue_fraction
        if (
            isinstance(tx, int | np.integer)
            and isinstance(rx, int | np.integer)
            and isinstance(w, np.ndarray)
            and w.ndim == 2
            and w.shape[1] == 1
            and isinstance(bistatic_range, np.ndarray)
            and bistatic_range.ndim == 2
            and bistatic_range.shape[0] == 1
            and isinstance(range_rate, np.ndarray)
            and range_rate.shape == bistatic_range.shape
        ):  # one pair, waveforms (W, 1) x targets (1, N) (expected_measurements): compiled, the same numbers
            c = np.ascontiguousarray
            return doppler_notch_gain_at(
                cnr_table[:, tx, rx], step, lam, pri, sigma_f, eta, c(w[:, 0], dtype=np.int64),
                c(bistatic_range[0], dtype=float), c(range_rate[0], dtype=float),
            )  # fmt: skip
        g = np.clip(np.rint(np.asarray(bistatic_range) / step).astype(np.int64), 0, cnr_table.shape[-1] - 1)
        cnr = cnr_table[w, tx, rx, g]
        return doppler_notch_gain(cnr, range_rate, lam[w], pri[w], sigma_f[w], eta)

    def _per_link(self, fn) -> FloatArray:
        """``(W, T, R)`` array of ``fn(waveform, tx config, rx config, (t, r))`` over the library and node pairs."""
        cfg = self.cfg
        return np.array(
            [
                [
                    [fn(wf, tx, rx, (t, r)) for r, rx in enumerate(cfg.receivers)]
                    for t, tx in enumerate(cfg.transmitters)
                ]
                for wf in self.library.waveforms
            ]
        )

    # ------------------------------------------------------------------------------------------------ geometry
    def _links(self, tx: slice, rx: slice, pos: FloatArray) -> tuple[FloatArray, ...]:
        """Geometry and coverage of the (tx, rx) links to points ``pos`` (N, 2): the one place the coverage rules live.

        Returns ``(lt (T, N), lr (R, N), loss_db (T, R, N), delay_s (T, R, N), azimuth (R, N), covered (T, R, N),
        unit_snr (T, R, N))``: covered = both legs within ``max_range_m``, out of the blind zone, not behind an opaque
        wall, in the array's field of view and a formed pair; unit_snr = 1 / (l_t l_r / d0^2)^rho / L_walls (per
        unit radar constant and RCS).
        """
        lay, sens, ch = self.layout, self.cfg.sensing, self.cfg.channel
        tx_pos, rx_pos = lay.tx_pos[tx], lay.rx_pos[rx]
        lt, lr = leg_lengths(tx_pos, rx_pos, pos)
        loss_db, delay_s = pair_obstruction(
            tx_pos, rx_pos, pos, lay.wall_start, lay.wall_end, lay.wall_loss_db, lay.wall_delay_s
        )
        in_view, az, off = in_field_of_view(rx_pos, lay.rx_boresight_rad[rx], lay.rx_fov_rad[rx], pos)
        covered = (
            (lt[:, None] <= sens.max_range_m)
            & (lr[None] <= sens.max_range_m)
            & ~blind_zone(lt[:, None] + lr[None], self.baseline[tx, rx], sens.blind_zone_excess_m)
            & np.isfinite(loss_db)
            & in_view[None]
            & self.pair_mask[tx, rx][..., None]
        )
        product = (np.maximum(lt, 1e-6)[:, None] * np.maximum(lr, 1e-6)[None]) / ch.reference_distance_m**2
        with np.errstate(over="ignore"):
            unit_snr = 1.0 / product**ch.path_loss_exponent * 10.0 ** (-loss_db / 10.0)
        unit_snr = unit_snr * self._receiver_beam_gain(rx, off)[None]
        return lt, lr, loss_db, delay_s, az, covered, unit_snr

    def _receiver_beam_gain(self, rx: slice, off: FloatArray) -> FloatArray:
        """``(R, N)`` beam gain g(psi) of receivers ``rx`` at off-boresight angles ``off`` (R, N) [rad] (``beams``)."""
        gain = np.ones(off.shape)
        for i, r in enumerate(range(self.n_rx)[rx]):  # receivers: a handful
            sines, n_el, spacing, lam = self._beams[r]
            if sines is not None and n_el > 1:
                gain[i] = beam_gain(np.nan_to_num(off[i]), sines, n_el, spacing, lam)
        return gain

    def episode_geometry(self, truth: Truth) -> EpisodeGeometry:
        """All truth-dependent geometry of the episode, vectorised over scans x pairs x targets."""
        lay = self.layout
        S, K = truth.states.shape[:2]
        pos = truth.states[..., [0, 2]].reshape(-1, 2)
        vel = truth.states[..., [1, 3]].reshape(-1, 2)
        every = slice(None)
        lt, lr, _, delay_s, az, covered, unit_snr = self._links(every, every, pos)  # (T, SK), (R, SK), (T, R, SK)
        lt_s, lr_s = np.maximum(lt, 1e-6), np.maximum(lr, 1e-6)
        ut = (pos[None] - lay.tx_pos[:, None]) / lt_s[..., None]
        ur = (pos[None] - lay.rx_pos[:, None]) / lr_s[..., None]
        rdot = np.einsum("tnd,nd->tn", ut, vel)[:, None] + np.einsum("rnd,nd->rn", ur, vel)[None]
        covered &= truth.alive.reshape(-1)[None, None]

        def per_scan(a: np.ndarray) -> np.ndarray:
            return np.moveaxis(a.reshape(*a.shape[:-1], S, K), -2, 0)

        return EpisodeGeometry(
            bistatic_range=per_scan(lt[:, None] + lr[None] + SPEED_OF_LIGHT_MPS * delay_s),
            range_rate=per_scan(rdot),
            azimuth=per_scan(az),
            unit_snr=per_scan(unit_snr * np.tile(self.rcs_mean, S)),
            covered=per_scan(covered),
        )

    def _cached_geometry(self, truth: Truth) -> EpisodeGeometry:
        """Geometry of ``truth``, reused while the truth is unchanged (deterministic scenarios)."""
        cached = self._geometry_cache
        if (
            cached is not None
            and cached[0].shape == truth.states.shape
            and np.array_equal(cached[0], truth.states)
            and np.array_equal(cached[1], truth.alive)
        ):
            return cached[2]
        geom = self.episode_geometry(truth)
        self._geometry_cache = (truth.states.copy(), truth.alive.copy(), geom)
        return geom

    def mean_snr(self, geom: EpisodeGeometry, k: int, plan: ScanPlan) -> FloatArray:
        """``(T, R, K)`` mean SNR (at mean RCS) of scan ``k`` under ``plan`` (0 where not covered)."""
        return np.where(geom.covered[k], self._gamma(plan)[..., None] * geom.unit_snr[k], 0.0)

    def _gamma(self, plan: ScanPlan) -> FloatArray:
        """``(T, R)`` radar constants of the waveforms the plan sends."""
        return self.radar_constant[plan.waveform, self._tx_index]

    # ------------------------------------------------------------------------------------------------- clutter
    def _clutter_statistics(self, cell_m: float = 1.0, n_bins: int = 1000) -> tuple[FloatArray, FloatArray]:
        """Expected false detections per pair and scan ``(T, R)``, and each formed pair's bistatic-range density.

        Quadrature of the clutter intensity: the uniform part on a ``cell_m`` grid over the area, the discrete part
        with a 5 x 5 Gauss-Hermite rule around each scatterer; both thinned to each pair's gate and histogrammed in
        bistatic range. Sets ``self._range_edges`` (n_bins + 1,) and returns the density table ``(P, n_bins + 2)``
        [false alarms per metre], zero-padded at both ends for out-of-range look-ups.
        """
        lay, sens, cl = self.layout, self.cfg.sensing, self.cfg.sensing.clutter
        x0, x1, y0, y1 = lay.area
        xs = np.arange(x0 + cell_m / 2, x1, cell_m)
        ys = np.arange(y0 + cell_m / 2, y1, cell_m)
        pts = np.stack(np.meshgrid(xs, ys), -1).reshape(-1, 2)
        area = (x1 - x0) * (y1 - y0)
        w = np.full(pts.shape[0], (1.0 - cl.discrete_fraction) * cl.density_per_m2 * area / pts.shape[0])
        if cl.discrete_fraction > 0:
            node, weight = np.polynomial.hermite_e.hermegauss(5)
            weight = weight / weight.sum()
            off = cl.discrete_spread_m * np.stack(np.meshgrid(node, node), -1).reshape(-1, 2)
            w_off = np.outer(weight, weight).reshape(-1)
            per_point = cl.discrete_fraction * cl.density_per_m2 * area / lay.clutter_points.shape[0]
            disc = (lay.clutter_points[:, None] + off[None]).reshape(-1, 2)
            pts = np.concatenate([pts, disc])
            w = np.concatenate([w, np.tile(per_point * w_off, lay.clutter_points.shape[0])])
        in_gate = self._in_gate(pts)  # (T, R, N)
        lt, lr = leg_lengths(lay.tx_pos, lay.rx_pos, pts)
        edges = np.linspace(0.0, 2.0 * sens.max_range_m, n_bins + 1)
        self._range_edges = edges
        table = np.zeros((self.pairs.shape[0], n_bins + 2))
        mean = np.zeros((self.n_tx, self.n_rx))
        for p, (t, r) in enumerate(self.pairs.tolist()):  # formed pairs, at construction only
            sel = in_gate[t, r]
            hist, _ = np.histogram(lt[t, sel] + lr[r, sel], bins=edges, weights=w[sel])
            table[p, 1:-1] = hist / np.diff(edges)
            mean[t, r] = w[sel].sum()
        self._az_tables = self._azimuth_range_tables(pts, w, in_gate, lt, lr)
        return mean, table

    def _azimuth_range_tables(
        self,
        pts: FloatArray,
        w: FloatArray,
        in_gate: BoolArray,
        lt: FloatArray,
        lr: FloatArray,
        n_range: int = 300,
        n_az: int = 360,
    ) -> dict[int, FloatArray]:
        """Clutter maps in (bistatic range, azimuth) of the pairs whose receiver measures azimuth.

        The same quadrature histogrammed in range x measured azimuth [false alarms / (m rad)], then broadened
        along azimuth by the direction-finding noise of a false alarm: the ULA CRLB at its mean apparent SNR
        (V_T) and at each angle (the library's first carrier). Returns {pair index: ``(n_range + 2, n_az + 2)``},
        zero-padded; sets ``self._az_range_edges`` and ``self._az_edges``.
        """
        lay, sens = self.layout, self.cfg.sensing
        r_edges = np.linspace(0.0, 2.0 * sens.max_range_m, n_range + 1)
        a_edges = np.linspace(-math.pi, math.pi, n_az + 1)
        self._az_range_edges, self._az_edges = r_edges, a_edges
        centres = 0.5 * (a_edges[1:] + a_edges[:-1])
        tables = {}
        for p, (t, r) in enumerate(self.pairs.tolist()):  # formed pairs with a DOA receiver, at construction only
            if not self._doa_rx[r]:
                continue
            sel = in_gate[t, r]
            az = np.arctan2(pts[sel, 1] - lay.rx_pos[r, 1], pts[sel, 0] - lay.rx_pos[r, 0])
            hist, _, _ = np.histogram2d(lt[t, sel] + lr[r, sel], az, bins=(r_edges, a_edges), weights=w[sel])
            off = _wrap(centres - self._boresight[r])
            var = azimuth_variance(
                np.full(n_az, self.threshold),
                lay.rx_n_elements[r],
                lay.rx_spacing_m[r],
                self.library[0].wavelength_m,
                off,
            )
            d = _wrap(centres[:, None] - centres[None, :])  # (measured j, true k)
            kernel = np.exp(-0.5 * d**2 / var[None, :]) / np.sqrt(2.0 * math.pi * var[None, :])
            dens = (hist / np.diff(r_edges)[:, None]) @ kernel.T  # per metre and per radian
            tables[p] = np.pad(dens, 1)
        return tables

    def _in_gate(self, pts: FloatArray) -> BoolArray:
        """``(T, R, N)`` whether points lie in each pair's coverage gate (range limits, blind zone, view)."""
        lay, sens = self.layout, self.cfg.sensing
        lt, lr = leg_lengths(lay.tx_pos, lay.rx_pos, pts)
        ok = (lt[:, None] <= sens.max_range_m) & (lr[None] <= sens.max_range_m)
        ok &= ~blind_zone(lt[:, None] + lr[None], self.baseline, sens.blind_zone_excess_m)
        in_view, _, _ = in_field_of_view(lay.rx_pos, lay.rx_boresight_rad, lay.rx_fov_rad, pts)
        return ok & in_view[None] & self.pair_mask[..., None]

    def _draw_clutter(
        self, n_scans: int, rng: np.random.Generator
    ) -> tuple[np.ndarray, FloatArray, FloatArray, FloatArray]:
        """Poisson false alarms of every scan and formed pair, at the library's largest rate.

        Returns:
            key ``(N,)`` = scan x P + pair (sorted), x and y ``(N,)`` [m], spare uniforms ``(2, N)`` (for the
            apparent SNR and the range-rate), or ``(3, N)`` where waveforms thin the draws (the third: the thinning
            uniform, ``ClutterConfig.reference_bandwidth_hz``; the same stream as without it up to that row).
        """
        lay, cl = self.layout, self.cfg.sensing.clutter
        x0, x1, y0, y1 = lay.area
        rate = self._clutter_total * self._fa_max if self._fa_scaled else self._clutter_total
        counts = rng.poisson(rate, n_scans * self.pairs.shape[0])
        u = rng.random((6 if self._fa_thin else 5, int(counts.sum())))
        x = x0 + u[0] * (x1 - x0)
        y = y0 + u[1] * (y1 - y0)
        if cl.discrete_fraction > 0:
            disc = np.flatnonzero(u[2] < cl.discrete_fraction)
            # given u2 < f, u2 / f is uniform on [0, 1): reuse it to pick the scatterer
            n_pts = lay.clutter_points.shape[0]
            which = np.minimum((u[2, disc] * (n_pts / cl.discrete_fraction)).astype(np.int64), n_pts - 1)
            spread = cl.discrete_spread_m * rng.standard_normal((2, disc.size))
            x[disc] = lay.clutter_points[which, 0] + spread[0]
            y[disc] = lay.clutter_points[which, 1] + spread[1]
        return np.repeat(np.arange(counts.size), counts), x, y, u[3:]

    def new_episode(self, truth: Truth, rngs: RngStreams) -> EpisodeSensing:
        """Geometry and all plan-independent draws of an episode (rcs, noise and clutter streams), per waveform."""
        lay, sens = self.layout, self.cfg.sensing
        geom = self._cached_geometry(truth)
        S, T, R, K = geom.unit_snr.shape
        m = self.library.measurement_dim
        col = _columns(m)
        W = len(self.library)
        # Targets: RCS, detection noise (2), azimuth noise (1), measurement noise (m) for every cell.
        fluct = rcs_fluctuation(self.swerling, (S, T, R), rngs.rcs, self._detect_swerling_w)
        fading = np.where(geom.covered, geom.unit_snr * fluct, 0.0)
        noise = rngs.noise.standard_normal((S, 3 + m, T, R, K))
        level2 = self.threshold - 0.5 * noise[:, 1] ** 2
        level = np.where(geom.covered, np.where(level2 >= 0, np.sqrt(np.maximum(level2, 0.0)), -1.0), np.inf)
        offset = _SQRT_HALF * noise[:, 0]
        template = np.zeros((S, T, R, K, col["n"]))
        template[..., col["pair"]] = self._pair_of_tr[None, :, :, None]
        template[..., 1] = geom.bistatic_range
        if m == 2:
            template[..., 2] = geom.range_rate
        template[..., col["origin"]] = np.arange(K)
        e_t = np.moveaxis(noise[:, 3:], 1, -1).reshape(-1, m)
        az_t = np.broadcast_to(geom.azimuth[:, None], (S, T, R, K)).reshape(-1)
        pos_t = None  # the targets' true positions per row: only the wall compensation uses them
        if self._compensate_walls:
            pos_t = np.broadcast_to(np.nan_to_num(truth.states[:, None, None, :, :][..., [0, 2]]), (S, T, R, K, 2))
            pos_t = pos_t.reshape(-1, 2)
        n_az_t = noise[:, 2].reshape(-1)

        # False alarms of every scan and pair, gated, with their own measurement and azimuth noise.
        key, x, y, u = self._draw_clutter(S, rngs.clutter)
        scan, pair = np.divmod(key, self.pairs.shape[0])
        c_t, c_r = self.pairs[pair, 0], self.pairs[pair, 1]
        if T == 1:
            dxt, dyt = x - lay.tx_pos[0, 0], y - lay.tx_pos[0, 1]
        else:
            dxt, dyt = x - lay.tx_pos[c_t, 0], y - lay.tx_pos[c_t, 1]
        dxr, dyr = x - self._rx_x[c_r], y - self._rx_y[c_r]
        lt2 = dxt * dxt + dyt * dyt
        lr2 = dxr * dxr + dyr * dyr
        max2 = sens.max_range_m**2
        ok = (lt2 <= max2) & (lr2 <= max2)
        if self._any_array:  # field of view: d . b >= |d| cos(fov), b the boresight unit vector
            ok &= dxr * self._bx[c_r] + dyr * self._by[c_r] >= np.sqrt(lr2) * self._cos_fov[c_r]
        c_range = np.sqrt(lt2) + np.sqrt(lr2)
        ok &= c_range - self.baseline[c_t, c_r] >= sens.blind_zone_excess_m
        idx = np.flatnonzero(ok)
        n_c = idx.size
        c_base = np.zeros((n_c, col["n"]))
        c_base[:, col["pair"]] = pair[idx]
        c_base[:, 1] = c_range[idx]
        if m == 2:
            c_base[:, 2] = (2.0 * u[1, idx] - 1.0) * sens.clutter.range_rate_max_mps
        c_base[:, col["snr"]] = self.threshold - np.log1p(-u[0, idx]) - 1.0  # V_T + Exp(1) minus the unit noise
        c_base[:, col["origin"]] = -1.0
        c_e = rngs.clutter.standard_normal((n_c, m + 1))
        # each waveform keeps a false alarm with probability rate_w / rate_max (ClutterConfig.reference_bandwidth_hz)
        c_keep = u[2, idx][None] < (self.false_alarm_scale / self._fa_max)[:, None] if self._fa_thin else None
        c_az = np.arctan2(dyr[idx], dxr[idx]) if self._any_doa else np.zeros(n_c)
        c_r, c_t = c_r[idx], c_t[idx]
        r_t = np.broadcast_to(np.arange(R)[None, None, :, None], (S, T, R, K)).reshape(-1)
        t_t = np.broadcast_to(np.arange(T)[None, :, None, None], (S, T, R, K)).reshape(-1)

        clutter_azimuth: dict[float, tuple[FloatArray, FloatArray]] = {}  # false alarms: per carrier, not waveform
        snr_all = self.radar_constant[:, None, :, :, None] * fading[None]  # (W, S, T, R, K)
        if self._residue:  # clutter-limited detection: the residue level of every scan and pair
            looks = sens.clutter_residue_looks
            x = rngs.clutter.gamma(looks, 1.0 / looks, (S, T, R)) if looks > 0.0 else np.ones((S, T, R))
            gain = 1.0 / (1.0 + sens.clutter_residue_ratio * self.direct_path_snr[:, None] * x[None])  # (W, S, T, R)
            scnr = snr_all * gain[..., None]
        else:
            scnr = snr_all
        if self._any_pd_gain:
            scnr = scnr * self._pd_gain[:, None, None, None, None]
        if self._notch is not None:  # static clutter at the blind speeds of each waveform's PRI
            gain = self.notch_gain(
                np.arange(W)[:, None, None, None, None],
                np.arange(T)[None, None, :, None, None],
                np.arange(R)[None, None, None, :, None],
                geom.bistatic_range[None],
                geom.range_rate[None],
            )
            scnr = scnr * gain
            snr_all = snr_all * gain  # the clutter shares the target's delay-Doppler cell: R at the SCNR too
        if self._migration is not None:  # the range walk across each train's dwell (seed 003's filter: no keystone)
            w_all = np.arange(W)[:, None, None, None, None]
            scnr = scnr * self.detection_migration_gain(w_all, geom.range_rate[None])  # the ridge's cells: Pd
            snr_all = snr_all * self.migration_gain(w_all, geom.range_rate[None])  # the peak: accuracy
        if self._mti is not None:  # seed 001's exponential background leaves g of the echo (through-wall)
            mti = self.mti_history(geom)  # (W, S, T, R, K), from each echo's delay history
            scnr = scnr * mti
            snr_all = snr_all * mti  # the residue is what the ToA measures: R at its SNR too
        target_hit = np.abs(np.sqrt(scnr) + offset[None]) > level[None]
        if self._p_noise > 0.0:  # or a noise peak in the echo's window: drawn after the stream's other draws
            window = rngs.noise.random((S, T, R, K)) < self._p_noise
            target_hit |= (geom.covered & self.pair_mask[None, :, :, None] & window)[None]
        if self._all_unit_chol:  # every waveform in one batch (per-row waveform index)
            n_t = e_t.shape[0]
            rows = np.tile(template.reshape(-1, col["n"]), (W, 1))
            rows[:, col["snr"]] = snr_all.reshape(-1)
            tile = lambda a: np.tile(a, (W, 1)) if a.ndim == 2 else np.tile(a, W)  # noqa: E731
            self._measure(
                rows,
                tile(e_t),
                tile(az_t),
                tile(n_az_t),
                tile(t_t),
                tile(r_t),
                np.repeat(np.arange(W), n_t),
                m,
                target_pos=None if pos_t is None else tile(pos_t),
            )
            target_rows = rows.reshape(W, *template.shape)
        else:
            target_rows = np.empty((W, *template.shape))
            for w in range(W):  # the waveform library: a small fixed set
                rows = template.reshape(-1, col["n"]).copy()
                rows[:, col["snr"]] = snr_all[w].reshape(-1)
                self._measure(rows, e_t, az_t, n_az_t, t_t, r_t, w, m, target_pos=pos_t)
                target_rows[w] = rows.reshape(template.shape)
        c_scan = scan[idx]
        if sens.ghost_rate > 0.0:  # multipath ghosts of covered targets, merged into the false alarms by (scan, pair)
            g_scan, g_base, g_e, g_az, g_t, g_r = self._draw_ghosts(geom, rngs.clutter, col, m)
            order = np.argsort(np.concatenate([c_scan, g_scan]) * self.pairs.shape[0] + np.concatenate(
                [c_base[:, col["pair"]], g_base[:, col["pair"]]]), kind="stable")  # fmt: skip
            c_scan = np.concatenate([c_scan, g_scan])[order]
            c_base = np.concatenate([c_base, g_base])[order]
            c_e = np.concatenate([c_e, g_e])[order]
            c_az = np.concatenate([c_az, g_az])[order]
            c_t, c_r = np.concatenate([c_t, g_t])[order], np.concatenate([c_r, g_r])[order]
            if c_keep is not None:  # ghosts: every waveform's
                c_keep = np.concatenate([c_keep, np.ones((W, g_scan.size), dtype=bool)], axis=1)[:, order]
            n_c = c_base.shape[0]
        c_scale = 1.0 / np.sqrt(c_base[:, col["snr"]])  # false alarms' SNR is the same for every waveform
        clutter_rows = WaveformRows(
            (W, n_c, col["n"]),
            _ClutterMeasurement(self, c_base, (c_e[:, :m], c_az, c_e[:, m], c_t, c_r, m, clutter_azimuth, c_scale)),
        )
        if self._any_doa:  # waveforms of one carrier share the azimuth columns of the first measured: in order
            for w in range(W):  # the waveform library: a small fixed set
                clutter_rows.waveform(w)
        return EpisodeSensing(
            geometry=geom,
            target_rows=target_rows,
            target_hit=target_hit,
            clutter_rows=clutter_rows,
            clutter_tx=c_t,
            clutter_rx=c_r,
            clutter_start=np.searchsorted(c_scan, np.arange(S + 1)),
            clutter_keep=c_keep,
        )

    def _draw_ghosts(
        self, geom: EpisodeGeometry, rng: np.random.Generator, col: dict[str, int], m: int
    ) -> tuple[IntArray, FloatArray, FloatArray, FloatArray, IntArray, IntArray]:
        """Multipath ghosts of every covered target, formed pair and scan (``SensingConfig.ghost_rate``).

        A Poisson number of mean ``ghost_rate`` per covered (scan, pair, target); each lies an exponential excess of
        mean ``ghost_range_offset_m`` beyond the target's bistatic range, with the target's range-rate plus
        N(0, ``ghost_range_rate_std_mps``^2), at the apparent SNR of a threshold crossing (V_T + Exp(1) - 1, like a
        false alarm) and the target's azimuth; origin -1. Returns the scans ``(G,)``, the noise-free rows
        ``(G, n)``, their measurement noise ``(G, m + 1)``, azimuths, transmitters and receivers.
        """
        sens = self.cfg.sensing
        covered = geom.covered & self.pair_mask[None, :, :, None]
        s_i, t_i, r_i, k_i = np.nonzero(covered)
        rep = np.repeat(np.arange(s_i.size), rng.poisson(sens.ghost_rate, s_i.size))
        s_i, t_i, r_i, k_i = s_i[rep], t_i[rep], r_i[rep], k_i[rep]
        n = rep.size
        u = rng.random((2, n))
        rdot_offset = sens.ghost_range_rate_std_mps * rng.standard_normal(n)
        e = rng.standard_normal((n, m + 1))
        base = np.zeros((n, col["n"]))
        base[:, col["pair"]] = self._pair_of_tr[t_i, r_i]
        base[:, 1] = geom.bistatic_range[s_i, t_i, r_i, k_i] - sens.ghost_range_offset_m * np.log1p(-u[0])
        if m == 2:
            base[:, 2] = geom.range_rate[s_i, t_i, r_i, k_i] + rdot_offset
        base[:, col["snr"]] = self.threshold - np.log1p(-u[1]) - 1.0
        base[:, col["origin"]] = -1.0
        return s_i, base, e, geom.azimuth[s_i, r_i, k_i], t_i, r_i

    def _measure(
        self,
        rows: FloatArray,
        e: FloatArray,
        az: FloatArray,
        n_az: FloatArray,
        tx: np.ndarray,
        rx: np.ndarray,
        w: int | np.ndarray,
        m: int,
        azimuth_cache: dict[float, tuple[FloatArray, FloatArray]] | None = None,
        inv_sqrt_snr: FloatArray | None = None,
        target_pos: FloatArray | None = None,
    ) -> None:
        """Measure noise-free rows through waveform ``w`` (in place).

        Adds the measurement noise and fills the azimuth, azimuth-variance and clutter-intensity columns;
        ``e`` (n, m) and ``n_az`` (n,) are standard normals. ``w`` is one waveform, or ``(n,)`` waveform indices
        when every waveform's R scales as 1 / SNR. When the rows' SNR does not depend on the waveform (false
        alarms), ``azimuth_cache`` shares the azimuth columns (and their map bins) between waveforms of the same
        carrier, and ``inv_sqrt_snr`` (n,) the noise scaling. ``target_pos`` (n, 2): the true positions of target
        rows, given when the radar compensates its walls (``SensingConfig.compensate_walls``): the measured range
        less :meth:`_wall_compensation` before the clutter intensity is read at it.
        """
        col = _columns(m)
        snr = rows[:, col["snr"]]
        # cells with no echo are never detected; keep their rows finite (false alarms always have snr > 0)
        # accuracy SNR: capped where the range std reaches SensingConfig.min_range_std_m (accuracy_snr_caps)
        cap = self._snr_cap[w]
        if inv_sqrt_snr is None:
            safe = np.minimum(np.where(snr > 0, snr, 1.0), cap)
        else:
            safe = np.minimum(snr, cap)
            inv_sqrt_snr = np.maximum(inv_sqrt_snr, 1.0 / np.sqrt(cap))
        walked = m == 2 and inv_sqrt_snr is None and self._migration is not None  # target rows of chirp trains
        z0 = rows[:, 1 : 1 + m].copy() if walked else None  # noise-free truth: its range-rate drives the walk below
        if isinstance(w, np.ndarray):  # per-row waveforms, all with R = R1 / snr
            scaled = e / np.sqrt(safe)[:, None]
            rows[:, 1 : 1 + m] += np.einsum("nij,nj->ni", self._unit_chol_stack[w], scaled)
            R1 = self._unit_cov_stack[w]
            ridge = R1[:, 0, 1] / R1[:, 1, 1] if m == 2 else 0.0
            rdot_var = R1[:, 1, 1] / safe if m == 2 else None
            range_var = R1[:, 0, 0] / safe
            wavelength = self._wavelengths[w]
        elif self._unit_chol[w] is not None:  # R = R1 / snr: noise chol(R1) e / sqrt(snr)
            L = self._unit_chol[w]
            scaled = e * (1.0 / np.sqrt(safe) if inv_sqrt_snr is None else inv_sqrt_snr)[:, None]
            for i in range(m):  # m <= 2 measurement components
                rows[:, 1 + i] += scaled[:, : i + 1] @ L[i, : i + 1]
            R1 = self._unit_cov[w]
            ridge = R1[0, 1] / R1[1, 1] if m == 2 else 0.0
            rdot_var = R1[1, 1] / safe if m == 2 else None
            range_var = R1[0, 0] / safe
            wavelength = self._wavelengths[w]
        else:
            cov = self.library[w].covariance(safe)
            rows[:, 1 : 1 + m] += np.einsum("nij,nj->ni", np.linalg.cholesky(cov), e)
            ridge = cov[:, 0, 1] / cov[:, 1, 1] if m == 2 else 0.0
            rdot_var = cov[:, 1, 1] if m == 2 else None
            range_var = cov[:, 0, 0]
            wavelength = self._wavelengths[w]
        if walked:  # the range walk's accuracy loss scales the noise just added
            var0 = np.stack(np.broadcast_arrays(range_var, rdot_var), axis=-1)  # (n, 2) the CRLB at the rows' SNR
            f = self.walk_factors(np.broadcast_to(w, safe.shape), z0[:, 1], var0)  # (n, 2)
            rows[:, 1:3] = z0 + (rows[:, 1:3] - z0) * np.sqrt(f)
            rows[:, col["walk_r"]], rows[:, col["walk_d"]] = f[:, 0], f[:, 1]
            ridge = ridge * np.sqrt(f[:, 0] / f[:, 1])
            rdot_var = rdot_var * f[:, 1]
        if target_pos is not None:  # the radar removes the known walls' delay (SensingConfig.compensate_walls)
            rows[:, 1] -= self._wall_compensation(rows[:, 1], tx, rx, target_pos)
        period = self.range_rate_period[w] if m == 2 else None
        if m == 2:  # the train measures the Doppler modulo 1 / T1: the range-rate is reported folded (chirp.py)
            rows[:, 2] = fold_range_rate(rows[:, 2], period)
        if self._any_doa:
            key = float(np.max(wavelength))  # the cache is used with one waveform (one carrier) per call
            cached = None if azimuth_cache is None else azimuth_cache.get(key)
            if cached is None:
                doa = self._doa_rx[rx]
                off = _wrap(az - self._boresight[rx])
                var = azimuth_variance(
                    safe, self.layout.rx_n_elements[rx], self.layout.rx_spacing_m[rx], wavelength, off
                )
                cached = (
                    np.where(doa, _wrap(az + np.sqrt(np.where(doa, var, 0.0)) * n_az), 0.0),
                    np.where(doa, var, 0.0),
                )
                if azimuth_cache is not None:
                    azimuth_cache[key] = cached
            rows[:, col["az"]], rows[:, col["az_var"]] = cached[:2]
        az_bins = None
        if self._any_doa and azimuth_cache is not None:
            entry = azimuth_cache[key]
            if len(entry) == 2:  # first waveform of this carrier: bin the azimuths once
                entry = (*entry, self._azimuth_bins(rows[:, col["az"]]))
                azimuth_cache[key] = entry
            az_bins = entry[2]
        rows[:, col["rho"]] = self._clutter_intensity(rows, ridge, rdot_var, az_bins, period, w)

    def _wall_compensation(self, z: FloatArray, tx: IntArray, rx: IntArray, pos: FloatArray) -> FloatArray:
        """The known walls' excess delay c tau [m] on the legs to each detection's uncompensated position estimate.

        Seed 001's wall-effect compensation as the signal path does it (``uwb_env.localization.couples.
        compensate_walls``: the crossings of the legs to the uncompensated intersection p_0, removed, then
        intersected again), for a detection that is one bistatic range ``z`` (n,) [m] of pair (``tx``, ``rx``) (n,):
        its p_0 is the point of its measured ellipse nearest the true position ``pos`` (n, 2) [m], to first order
        p_0 = p + (z - r(p)) g / |g|^2, g = grad r(p) the free-space range's gradient -- so p_0 carries the range
        noise and the walls' own delay, as the couple's p_0 does (the couple's cross-range error, which a single
        range does not have, is left out). The delay is that of the walls the legs Tx -> p_0 and p_0 -> Rx cross
        (``uwb_env.channel.walls``: a fixed delay per crossing, the layout's walls and delays, known to the radar as
        in the signal path). It removes the delay exactly when p_0 and p lie on the same side of every wall (seed
        001: a wall parallel to the array, every person behind it); elsewhere the residual (a crossing counted or
        missed) stays in the measurement. Why here rather than in the tracker's measurement model: the radar, not
        the tracker, knows the wall (seed 001 compensates before its localization), and the tracker's free-space
        bistatic range then holds for both fidelities.
        """
        lay = self.layout
        t_pos, r_pos = lay.tx_pos[tx], lay.rx_pos[rx]
        dt, dr = pos - t_pos, pos - r_pos
        lt, lr = np.linalg.norm(dt, axis=1), np.linalg.norm(dr, axis=1)
        g = dt / np.maximum(lt, 1e-9)[:, None] + dr / np.maximum(lr, 1e-9)[:, None]
        g2 = np.einsum("nd,nd->n", g, g)
        step = np.where(g2 > 1e-6, (np.nan_to_num(z) - lt - lr) / np.maximum(g2, 1e-6), 0.0)
        p0 = pos + step[:, None] * g
        crossed = segments_cross(t_pos, p0, lay.wall_start, lay.wall_end).astype(float)
        crossed += segments_cross(r_pos, p0, lay.wall_start, lay.wall_end)
        return SPEED_OF_LIGHT_MPS * (crossed @ lay.wall_delay_s)

    # ----------------------------------------------------------------------------------------------------- scan
    def sense(self, episode: EpisodeSensing, k: int, plan: ScanPlan, time_s: float = 0.0) -> tuple[Detections, ...]:
        """Detections of every active formed pair in scan ``k``, ordered by (tx, rx); the plan is validated here.

        Selects the scan's rows of the waveforms the plan sends, sorts them by (pair, range) and splits per pair.
        """
        all_active, w0, single, waveform_of_tx = self._validate(plan)
        m = self.library.measurement_dim
        col = _columns(m)
        active = plan.active_rx
        if single:
            target_rows, clutter_rows = self.single_waveform_rows(episode, k, w0, active, all_active)
        else:  # each transmitter's echoes come from the waveform it sends
            a, b = episode.clutter_start[k], episode.clutter_start[k + 1]
            target_rows = np.concatenate(
                [
                    episode.target_rows[w, k, t][episode.target_hit[w, k, t] & active[:, None]]
                    for t, w in enumerate(waveform_of_tx)
                ]
            )
            wf_row = np.asarray(waveform_of_tx)[episode.clutter_tx[a:b]]
            clutter_rows = episode.clutter_rows[wf_row, np.arange(a, b)]
            keep = None if episode.clutter_keep is None else episode.clutter_keep[wf_row, np.arange(a, b)]
            if not all_active:
                keep = active[episode.clutter_rx[a:b]] if keep is None else keep & active[episode.clutter_rx[a:b]]
            if keep is not None:
                clutter_rows = clutter_rows[keep]
        rows = np.concatenate([target_rows, clutter_rows])
        rows = rows.take(np.argsort(rows[:, 0] * _KEY_SPAN + rows[:, 1]), axis=0)  # pair, then range (<< span)
        snr = rows[:, col["snr"]]
        cov = (
            self._unit_cov[w0][None] / np.minimum(snr, self._snr_cap[w0])[:, None, None]
            if single
            else self._covariances(np.asarray(waveform_of_tx)[self.pairs[rows[:, 0].astype(np.int64), 0]], snr)
        )
        if m == 2 and self._migration is not None:  # the range walk's accuracy loss (target rows; 0 means 1)
            d = np.sqrt(np.maximum(rows[:, [col["walk_r"], col["walk_d"]]], 1.0))
            cov = cov * d[:, :, None] * d[:, None, :]
        bounds = [*np.searchsorted(rows[:, 0], self._pair_index).tolist(), rows.shape[0]]
        origin = rows[:, col["origin"]].astype(np.int64)
        return self.pair_records(rows, cov, snr, origin, bounds, active, waveform_of_tx, time_s)

    def single_waveform_rows(
        self, episode: EpisodeSensing, k: int, w: int, active: BoolArray, all_active: bool
    ) -> tuple[FloatArray, FloatArray]:
        """Scan ``k``'s target and false-alarm rows when every transmitter sends waveform ``w`` (unsorted).

        The targets hit at the listening receivers, and the false alarms the waveform keeps (its thinning,
        ``ClutterConfig.reference_bandwidth_hz``) at the listening receivers. Shared with ``sensing.batch.sense_many``.
        """
        a, b = episode.clutter_start[k], episode.clutter_start[k + 1]
        hit = episode.target_hit[w, k]
        if not all_active:
            hit = hit & active[None, :, None]
        clutter_rows = episode.clutter_rows[w, a:b]
        keep = None if episode.clutter_keep is None else episode.clutter_keep[w, a:b]
        if not all_active:
            keep = active[episode.clutter_rx[a:b]] if keep is None else keep & active[episode.clutter_rx[a:b]]
        return episode.target_rows[w, k][hit], clutter_rows if keep is None else clutter_rows[keep]

    def pair_records(
        self,
        rows: FloatArray,
        cov: FloatArray,
        snr: FloatArray,
        origin: IntArray,
        bounds: list[int],
        active: BoolArray,
        waveform_of_tx: list[int],
        time_s: float,
    ) -> tuple[Detections, ...]:
        """One scan's ``Detections`` per active formed pair from its sorted ``rows`` (:meth:`sense`'s last step).

        Pair p's rows are ``bounds[p]:bounds[p + 1]`` of rows, cov, snr and origin (views, not copies); the array
        receivers' azimuth variance is appended to their covariances. Shared with ``sensing.batch.sense_many``.
        """
        m = self.library.measurement_dim
        col = _columns(m)
        out = []
        for p, (t, r) in enumerate(self._pair_list):  # the formed pairs: a small fixed set
            if not active[r]:
                continue
            lo, hi = bounds[p], bounds[p + 1]
            if self._doa_rx[r]:
                z, R = rows[lo:hi, 1 : 2 + m], append_block(cov[lo:hi], rows[lo:hi, col["az_var"]])
            else:
                z, R = rows[lo:hi, 1 : 1 + m], cov[lo:hi]
            out.append(
                Detections(
                    tx=t,
                    rx=r,
                    waveform=waveform_of_tx[t],
                    time_s=time_s,
                    z=z,
                    R=R,
                    snr=snr[lo:hi],
                    origin=origin[lo:hi],
                    measurement_names=self._names[r],
                    clutter_intensity=rows[lo:hi, col["rho"]],
                    expected_false_alarms=self._expected_false_w[waveform_of_tx[t]][p],
                    range_rate_period_mps=float(self.range_rate_period[waveform_of_tx[t]]),
                )
            )
        return tuple(out)

    def _azimuth_bins(self, az: FloatArray) -> np.ndarray:
        """Azimuth bin indices (padded table) of measured azimuths [rad]."""
        return np.minimum(((az + math.pi) * self._az_scale).astype(np.int64) + 1, self._az_stack.shape[2] - 1)

    def _clutter_intensity(
        self,
        rows: FloatArray,
        ridge: FloatArray | float,
        rdot_var: FloatArray | None,
        az_bins: np.ndarray | None = None,
        period: FloatArray | float | None = None,
        waveform: IntArray | int | None = None,
    ) -> FloatArray:
        """``(n,)`` known clutter map at each row's measurement, azimuth factor apart (module docstring, item 6).

        Args:
            rows: detections in the sensor's row layout; ridge: R_rd / R_dd; rdot_var: R_dd ``(n,)`` (None for
                range-only waveforms); period: the range-rate period of the rows' waveforms (scalar or ``(n,)``;
                inf where unambiguous); waveform: the rows' waveform (scalar or ``(n,)``), for the per-waveform
                factor of the density (``ClutterConfig.reference_bandwidth_hz``; needed when it is set).

        A false alarm's true range-rate is uniform over +-rdot_max; folded into the period its density at f is the
        number of aliases f + k P inside +-rdot_max over 2 rdot_max (``folded_uniform_density``; 1 / P when 2
        rdot_max is a whole number of periods).

        For chirps the measurement noise lies along the delay-Doppler ridge, so a false alarm's range error is
        fixed by its range-rate error: the range map is read at the ridge-corrected range r - (R_rd / R_dd) rdot.
        """
        pair = rows[:, 0].astype(np.int64)
        r = rows[:, 1] if rdot_var is None else rows[:, 1] - ridge * rows[:, 2]
        slot = self._az_slot[pair]
        range_only = slot < 0
        rho = np.empty(rows.shape[0])
        if not self._all_doa:  # pairs without azimuth: the bistatic-range map
            i = slice(None) if self._az_stack is None else np.flatnonzero(range_only)  # no DOA pair: every row
            b = (np.clip(r[i], -1.0, self._range_edges[-1]) * self._bin_scale).astype(np.int64) + 1
            rho[i] = self._range_table[pair[i], np.minimum(b, self._range_table.shape[1] - 1)]
        if self._az_stack is not None:  # pairs with a DOA receiver: their (range, azimuth) map, one look-up
            i = slice(None) if self._all_doa else np.flatnonzero(~range_only)
            nr = self._az_stack.shape[1]
            br = (np.clip(r[i], -1.0, self._az_range_edges[-1]) * self._az_r_scale).astype(np.int64) + 1
            ba = self._azimuth_bins(rows[i, 1 + self._m]) if az_bins is None else az_bins[i]
            rho[i] = self._az_stack[slot[i], np.minimum(br, nr - 1), ba]
        if rdot_var is not None:
            folded = np.isfinite(period)
            if np.ndim(period) == 0 and folded:  # one folded period: the unfolded Gaussian is not needed
                rho = rho * folded_uniform_density(rows[:, 2], period, self._rdot_max)
            else:
                var = rdot_var + self._rdot_var
                gauss = np.exp(-0.5 * rows[:, 2] ** 2 / var) / np.sqrt(2.0 * math.pi * var)
                rho = rho * np.where(folded, folded_uniform_density(rows[:, 2], period, self._rdot_max), gauss)
        if self._fa_scaled:  # false alarms per waveform: false_alarm_scale (bandwidth rule x false_alarm_factor)
            rho = rho * self.false_alarm_scale[waveform]
        return rho

    def _covariances(self, waveform_of_row: np.ndarray, snr: FloatArray) -> FloatArray:
        """``(n, m, m)`` covariances of rows sent with different waveforms (a small fixed set)."""
        m = self.library.measurement_dim
        cov = np.empty((snr.shape[0], m, m))
        for w in set(waveform_of_row.tolist()):
            sel = waveform_of_row == w
            cov[sel] = self.library[w].covariance(np.minimum(snr[sel], self._snr_cap[w]))
        return cov

    def _validate(self, plan: ScanPlan) -> tuple[bool, int, bool, list[int]]:
        """Validate a plan and derive what a scan needs from it, once.

        Plans are immutable, so a validated plan is remembered by identity. Returns whether every receiver
        listens, the first waveform, whether one waveform with a 1/SNR covariance serves all transmitters, and the
        waveform of each transmitter.
        """
        hit = self._valid_plans.get(id(plan))
        if hit is not None and hit[0] is plan:
            return hit[1]
        plan.validate(self.n_tx, self.n_rx, len(self.library))
        waveforms = set(plan.waveform.tolist())
        w0 = int(plan.waveform[0])
        derived = (
            bool(plan.active_rx.all()),
            w0,
            len(waveforms) == 1 and self._unit_chol[w0] is not None,
            plan.waveform.tolist(),
        )
        if len(self._valid_plans) > 256:
            self._valid_plans.clear()
        self._valid_plans[id(plan)] = (plan, derived)
        return derived

    def _mean_link(
        self,
        tx: int,
        rx: int,
        positions: FloatArray,
        waveforms: IntArray | int,
        rcs_m2: float,
        swerling: int,
        link: tuple | None = None,
    ) -> tuple[FloatArray, BoolArray, FloatArray, FloatArray]:
        """Mean-SNR link of pair (tx, rx) at ``positions`` (N, 2) for each of ``waveforms`` (W,).

        Returns ``(azimuth (N,), covered (N,), mean SNR (W, N), Pd (W, N))``: the geometry once, the radar
        constant per waveform. One compiled pass (``sensing.compiled.mean_link``, the rules of ``_links``);
        Swerling 0's Marcum Q is evaluated here on the returned SNR. The pair's and the waveforms' arguments are
        read-only arrays of the sensor, gathered once per (pair, waveforms) (``_link_args``; ``link``: the caller's).
        """
        pos = np.ascontiguousarray(positions, dtype=float).reshape(-1, 2)
        pair_args, k, gain, weights = self._link_args(tx, rx, waveforms) if link is None else link
        sens = self.cfg.sensing
        az, ok, snr, pd = mean_link(
            *pair_args[:2],
            pos,
            *pair_args[2:],
            k,
            float(rcs_m2),
            gain,
            weights,
            sens.false_alarm_probability,
            int(swerling),
            self._p_noise,
        )
        if swerling not in (1, 3):  # no compiled form: the numpy Pd on the compiled SNR
            scnr = snr[..., None] * gain[:, None, :]
            pfa = sens.false_alarm_probability
            pd_echo = detection_probability(scnr.reshape(-1), pfa, swerling).reshape(scnr.shape) @ weights
            pd = np.where(ok, windowed_detection_probability(pd_echo, pfa, self._window_cells), 0.0)
        return az, ok, snr, pd

    def _link_args(
        self, tx: int, rx: int, waveforms: IntArray | int
    ) -> tuple[tuple, FloatArray, FloatArray, FloatArray]:
        """``mean_link``'s arguments of pair (tx, rx) and ``waveforms``: (pair's geometry, k (W,), gain, weights).

        Cached per (tx, rx, waveforms) (a handful: the lookahead's sets and single waveforms).
        """
        key = (tx, rx, waveforms) if isinstance(waveforms, int) else (tx, rx, *np.asarray(waveforms).ravel().tolist())
        args = self._link_cache.get(key)
        if args is None:
            lay, sens, ch = self.layout, self.cfg.sensing, self.cfg.channel
            w = np.asarray(waveforms, dtype=np.int64).reshape(-1)
            pair = (
                lay.tx_pos[tx],
                lay.rx_pos[rx],
                lay.wall_start,
                lay.wall_end,
                lay.wall_loss_db,
                lay.wall_delay_s,
                float(lay.rx_boresight_rad[rx]),
                float(lay.rx_fov_rad[rx]),
                sens.max_range_m,
                float(self.baseline[tx, rx]),
                sens.blind_zone_excess_m,
                bool(self.pair_mask[tx, rx]),
                ch.reference_distance_m,
                ch.path_loss_exponent,
                *self._compiled_beam(rx),
            )
            if self._residue:
                gain, weights = self.detection_gain[w, tx, rx], self._residue_weights
            else:
                gain, weights = self._unit_gain[w], self._unit_weight
            args = (pair, np.ascontiguousarray(self.radar_constant[w, tx, rx]), np.ascontiguousarray(gain), weights)
            if len(self._link_cache) > 1024:
                self._link_cache.clear()
            self._link_cache[key] = args
        return args

    def _compiled_beam(self, rx: int) -> tuple[FloatArray, float, int]:
        """``mean_link``'s beam arguments of receiver ``rx``: sines ``(M,)`` (empty: gain 1), 2 pi d / lambda, L."""
        sines, n_el, spacing, lam = self._beams[rx]
        if sines is None or n_el <= 1:
            return np.zeros(0), 0.0, 1
        return np.ascontiguousarray(sines, dtype=float), 2.0 * math.pi * spacing / lam, n_el

    def _mean_link_reference(
        self, tx: int, rx: int, positions: FloatArray, waveforms: IntArray, rcs_m2: float, swerling: int
    ) -> tuple[FloatArray, BoolArray, FloatArray, FloatArray]:
        """The numpy reference of :meth:`_mean_link` (``_links`` and ``detection_probability``), for the tests."""
        pos = np.asarray(positions, dtype=float).reshape(-1, 2)
        *_, az, covered, unit_snr = self._links(slice(tx, tx + 1), slice(rx, rx + 1), pos)
        ok = covered[0, 0]
        k = self.radar_constant[waveforms, tx, rx][:, None]
        snr = np.where(ok, k * (rcs_m2 * unit_snr[0, 0]), 0.0)
        pfa = self.cfg.sensing.false_alarm_probability
        if self._residue:  # average over the residue level (quadrature nodes J)
            scnr = snr[..., None] * self.detection_gain[waveforms, tx, rx][:, None, :]  # (W, N, J)
            pd = detection_probability(scnr.reshape(-1), pfa, swerling).reshape(scnr.shape) @ self._residue_weights
        else:
            pd = detection_probability(snr * self._pd_gain[waveforms][:, None], pfa, swerling)
        pd = np.where(ok, windowed_detection_probability(pd, pfa, self._window_cells), 0.0)
        return az[0], ok, snr, pd

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
        """Pd ``(N,)`` of pair (tx, rx) with ``waveform`` for targets at ``positions`` (N, 2) [m].

        The sensor model a tracker or a lookahead may use: the radar equation with walls, range limits, blind zone
        and field of view at the given positions (the rules of the sensing itself), for an assumed mean RCS and
        Swerling case. With ``velocities`` (N, 2) [m/s] and seed 001's background MTI active (through-wall), at the
        echo's SNR after the MTI's loss at the pair's bistatic range-rate (:meth:`mti_gain`: 0.12 for a still
        Swerling III target, 0 for a steady one); elsewhere ``velocities`` changes nothing.
        """
        if velocities is not None and self._mti is not None:
            return self.expected_measurements(
                tx, rx, positions, np.array([int(waveform)]), rcs_m2, swerling, velocities
            )[0][0]
        return self._mean_link(tx, rx, positions, int(waveform), rcs_m2, swerling)[3][0]

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
        """Sensor model of one pair for the lookahead: ``(Pd (W, N), R (W, N, m, m))`` for each of ``waveforms``.

        At ``positions`` (N, 2) [m], for the waveforms ``(W,)``.
        R is the waveform's covariance at the mean SNR (assumed RCS) with the azimuth variance of the array
        receiver appended (columns ``measurement_names(rx)``); uncovered positions get Pd = 0 and R at unit SNR.
        The CRLB waveform models go through one compiled pass (``sensing.compiled.expected_covariance``);
        ``_expected_covariance_reference`` is its numpy reference and serves the other models.
        With ``velocities`` (N, 2) [m/s], Pd and R are taken at the SCNR of the zero-Doppler clutter notch
        (:meth:`notch_gain`) and after the train's range-migration loss (:meth:`migration_gain`): what makes the PRI
        and the bandwidth choices.
        """
        waveforms = np.ascontiguousarray(waveforms, dtype=np.int64).reshape(-1)
        key = (tx, rx, *waveforms.tolist())  # _link_args' key
        link = self._link_cache.get(key)
        if link is None:
            link = self._link_args(tx, rx, waveforms)
        pos = np.ascontiguousarray(positions, dtype=float).reshape(-1, 2)
        walk = None  # the range-rates (N,) [m/s] with velocities and chirp trains
        moving = velocities is not None and (
            self._notch is not None or self._migration is not None or self._mti is not None
        )
        if moving and self._mti is None:  # the link, range-rates, notch terms and walk gains in one compiled call
            vel = np.ascontiguousarray(velocities, dtype=float).reshape(-1, 2)
            az, ok, snr, rdot, cnr, arg, walk_pd, walk_peak = self._moving_link(
                link, pos, vel, waveforms, rcs_m2, tx, rx
            )
            snr, snr_pd = self._notch_and_walk(snr, cnr, arg, walk_pd, walk_peak)
            if self._migration is not None:
                walk = rdot
        elif moving:
            az, ok, snr, pd = self._mean_link(tx, rx, pos, waveforms, rcs_m2, swerling, link)
            vel = np.ascontiguousarray(velocities, dtype=float).reshape(-1, 2)
            lay = self.layout
            # l_t + l_r and (d_t / l_t + d_r / l_r) . v, compiled (numpy's operations, the same numbers)
            rng, rdot = bistatic_range_rate(pos, vel, lay.tx_pos[tx], lay.rx_pos[rx])
            if self._notch is not None:  # notch_gain's compiled form for one pair (the same numbers; 1 without)
                cnr_table, step, pri, sigma_f, lam = self._notch
                eta = self.cfg.sensing.clutter.residue_fraction
                snr = snr * doppler_notch_gain_at(
                    cnr_table[:, tx, rx], step, lam, pri, sigma_f, eta, waveforms, rng, rdot
                )
            # seed 001's exponential background (through-wall): the echo's residue
            snr = snr * self.mti_gain(waveforms[:, None], rdot[None])
            snr_pd = snr
            if self._migration is not None:  # compiled: every scan asks for it, per pair (sensing.compiled)
                walk = rdot
                snr_pd = snr * walk_gain(waveforms, rdot, self._migration_pd, self._WALK_STEP_MPS)  # detection
                snr = snr * walk_gain(waveforms, rdot, self._migration[0], self._WALK_STEP_MPS)  # the peak: R
        else:
            az, ok, snr, pd = self._mean_link(tx, rx, pos, waveforms, rcs_m2, swerling, link)
        if moving:
            pd = np.where(ok, self._echo_pd(snr_pd, *link[2:], swerling), 0.0)
        if not self._all_unit_chol:
            R = self._expected_covariance_reference(rx, az, ok, snr, waveforms)
            return pd, self._walk_scaled(R, waveforms, walk)
        R = expected_covariance(az, ok, snr, *self._covariance_arguments(key, rx, waveforms))
        if walk is None or R.shape[-1] < 2:
            return pd, R
        # _walk_scaled on R, which is ours (fresh from expected_covariance): scaled in place, no copy
        gain_w, c_range, c_rate, half_dwell, period = self._migration
        return pd, walk_scale(R, waveforms, walk, gain_w, c_range, c_rate, half_dwell, period, self._WALK_STEP_MPS)

    def expected_measurements_pairs(
        self,
        pairs: list[tuple[int, int]],
        positions: FloatArray,
        waveforms: list[IntArray],
        rcs_m2: float = 1.0,
        swerling: int = 1,
        velocities: FloatArray | None = None,
    ) -> list[tuple[FloatArray, FloatArray]]:
        """:meth:`expected_measurements` of each pair ``pairs[p]`` = (tx, rx) for its ``waveforms[p]`` ``(W_p,)``.

        Returns ``[(Pd (W_p, N), R (W_p, N, m, m))]``. With velocities (notch or chirp trains, no MTI, the CRLB
        models, one detector node): each pair's compiled link (:meth:`_moving_link`), then the numpy part of Pd
        (notch, walk, Swerling, noise window) once over the pairs' rows stacked, elementwise: the same numbers as
        pair by pair. Otherwise pair by pair.
        """
        fast = (
            velocities is not None
            and self._mti is None
            and (self._notch is not None or self._migration is not None)
            and self._all_unit_chol
            and len(pairs) > 1
        )
        links = []
        for (tx, rx), w in zip(pairs, waveforms, strict=True):
            w = np.ascontiguousarray(w, dtype=np.int64).reshape(-1)
            key = (tx, rx, *w.tolist())  # _link_args' key
            link = self._link_cache.get(key)
            if link is None:
                link = self._link_args(tx, rx, w)
            fast = fast and link[3].shape[0] == 1 and link[3][0] == 1.0  # one node of weight 1 (x @ [1] = x)
            links.append((tx, rx, w, key, link))
        if not fast:
            return [
                self.expected_measurements(tx, rx, positions, w, rcs_m2, swerling, velocities)
                for tx, rx, w, _, _ in links
            ]
        pos = np.ascontiguousarray(positions, dtype=float).reshape(-1, 2)
        vel = np.ascontiguousarray(velocities, dtype=float).reshape(-1, 2)
        pack = self._pairs_pack(links)
        if pack is None:  # receivers of different measurement dimensions: pair by pair
            return [
                self.expected_measurements(tx, rx, positions, w, rcs_m2, swerling, velocities)
                for tx, rx, w, _, _ in links
            ]
        link_args, cov_args, starts = pack
        az, ok, rdot, snr, cnr, arg, walk_pd, walk_peak = _moving_links_kernel(
            *link_args[:2], pos, vel, *link_args[2:19], float(rcs_m2), *link_args[19:]
        )
        snr, snr_pd = self._notch_and_walk(snr, cnr, arg, walk_pd, walk_peak)
        pd_echo = self._echo_pd(snr_pd, link_args[19], links[0][4][3], swerling)
        R = _expected_covariances_kernel(az, ok, snr, starts, *cov_args, rdot, *self._walk_args())
        return [
            (np.where(ok[p], pd_echo[starts[p] : starts[p + 1]], 0.0), R[starts[p] : starts[p + 1]])
            for p in range(len(links))
        ]

    def _notch_and_walk(
        self, snr: FloatArray, cnr: FloatArray, arg: FloatArray, walk_pd: FloatArray, walk_peak: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """The moving-link kernels' numpy tail, ``(W, N)`` each: SNR at the peak (for R) and for detection (for Pd).

        The notch's SCNR = SNR / (1 + eta CNR exp(exponent)) (``doppler_notch_gain_at``'s tail, numpy's exp: the
        same numbers), then the range walk's coherent losses, one for detection and one for the peak.
        """
        if self._notch is not None:
            eta = self.cfg.sensing.clutter.residue_fraction
            snr = snr * (1.0 / (1.0 + eta * cnr * np.exp(arg)))
        if self._migration is None:
            return snr, snr
        return snr * walk_peak, snr * walk_pd

    def _echo_pd(self, snr_pd: FloatArray, gain: FloatArray, weights: FloatArray, swerling: int) -> FloatArray:
        """``(W, N)`` Pd of the echo at ``snr_pd`` with the detector's ``gain`` ``(W, J)`` over nodes ``weights`` (J,).

        The detector's gain as in ``_mean_link`` (detection_gain_db and, with a clutter residue, its quadrature), then
        the noise peak of the truth-matching window, P = P_e + p_n - P_e p_n (``windowed_detection_probability``'s,
        the same float). One node of weight 1 skips x @ [1] = x.
        """
        pfa = self.cfg.sensing.false_alarm_probability
        if weights.shape[0] == 1 and weights[0] == 1.0:
            pd_echo = detection_probability(snr_pd * gain, pfa, swerling)
        else:
            scnr = snr_pd[..., None] * gain[:, None, :]  # (W, N, J)
            pd_echo = detection_probability(scnr.reshape(-1), pfa, swerling).reshape(scnr.shape) @ weights
        p_noise = self._p_noise
        return pd_echo + p_noise - pd_echo * p_noise if p_noise > 0.0 else pd_echo

    def _kernel_tables(self, cnr: FloatArray | None, no_cnr: FloatArray) -> tuple:
        """The moving-link kernels' notch and walk arguments: (on, cnr, step, lambda, pri, sigma_f, on, pd, peak).

        ``cnr`` the pairs' CNR tables (None without static clutter, when ``no_cnr`` of the kernel's dimensions
        stands in).
        """
        if self._notch is not None:
            _, step, pri, sigma_f, lam = self._notch
            notch = (True, cnr, float(step), lam, pri, sigma_f)
        else:
            notch = (False, no_cnr, 1.0, _NO_ROW, _NO_ROW, _NO_ROW)
        if self._migration is None:
            return (*notch, False, _NO_TABLE, _NO_TABLE)
        return (*notch, True, self._migration_pd, self._migration[0])

    def _walk_args(self) -> tuple:
        """``walk_scale``'s tables after R: (on, gain, c_range, c_rate, half_dwell, period, step)."""
        if self._migration is None:
            return (False, _NO_TABLE, _NO_TABLE, _NO_TABLE, _NO_ROW, _NO_ROW, self._WALK_STEP_MPS)
        return (True, *self._migration, self._WALK_STEP_MPS)

    def _pairs_pack(self, links: list[tuple]) -> tuple | None:
        """The multi-pair kernels' arguments for ``links`` ``[(tx, rx, w, key, link)]`` (cached by their keys).

        Returns ``(link arguments, covariance arguments, row starts (P + 1,))``, or None when the receivers' measurement
        dimensions differ. The per-pair values are those of ``_link_args`` and ``_covariance_arguments``, stacked.
        """
        key = tuple(k for _, _, _, k, _ in links)
        hit = self._pack_cache.get(key)
        if hit is not None:
            return hit
        doa = np.array([bool(self._doa_rx[rx]) for _, rx, _, _, _ in links])
        if doa.any() and not doa.all():
            return None
        pairs = [link[0] for *_, link in links]
        sizes = [w.size for _, _, w, _, _ in links]
        starts = np.zeros(len(links) + 1, np.int64)
        starts[1:] = np.cumsum(sizes)
        n_sines = np.array([p[14].size for p in pairs], np.int64)
        sines = np.zeros((len(pairs), max(1, int(n_sines.max()))))
        for i, p in enumerate(pairs):
            sines[i, : p[14].size] = p[14]
        first = pairs[0]
        cnr = None
        if self._notch is not None:
            cnr = np.ascontiguousarray(np.stack([self._notch[0][:, tx, rx] for tx, rx, *_ in links]))
        w_all = np.concatenate([w for _, _, w, _, _ in links])
        link_args = (
            np.array([p[0] for p in pairs], dtype=float),  # tx (P, 2)
            np.array([p[1] for p in pairs], dtype=float),  # rx (P, 2)
            *first[2:6],  # the walls (shared)
            np.array([p[6] for p in pairs], dtype=float),  # boresight
            np.array([p[7] for p in pairs], dtype=float),  # fov
            first[8],  # max range
            np.array([p[9] for p in pairs], dtype=float),  # baseline
            first[10],  # blind-zone excess
            np.array([p[11] for p in pairs], dtype=np.bool_),  # formed
            first[12],  # d0
            first[13],  # path-loss exponent
            sines,
            n_sines,
            np.array([p[15] for p in pairs], dtype=float),  # 2 pi d / lambda
            np.array([p[16] for p in pairs], dtype=np.int64),  # L
            np.concatenate([link[1] for *_, link in links]),  # k (S,)
            # rcs goes here (the caller's)
            np.concatenate([link[2] for *_, link in links]),  # gain (S, J)
            links[0][4][3],  # weights (J,) (one node of weight 1: the caller checked)
            self.cfg.sensing.false_alarm_probability,
            self._p_noise,
            w_all,
            starts,
            *self._kernel_tables(cnr, np.zeros((1, 1, 1))),
            self._WALK_STEP_MPS,
        )
        covs = [self._covariance_arguments(k, rx, w) for _, rx, w, k, _ in links]
        cov_args = (
            np.concatenate([c[0] for c in covs]),  # snr caps (S,)
            np.concatenate([c[1] for c in covs]),  # unit covariances (S, m0, m0)
            doa,
            np.array([c[3] for c in covs], dtype=float),  # boresight (nan -> 0)
            np.array([c[4] for c in covs], dtype=float),  # L
            np.array([c[5] for c in covs], dtype=float),  # spacing
            np.concatenate([c[6] for c in covs]),  # wavelengths (S,)
            w_all,
        )
        if len(self._pack_cache) > 256:
            self._pack_cache.clear()
        out = self._pack_cache[key] = (link_args, cov_args, starts)
        return out

    def _covariance_arguments(self, key: tuple, rx: int, waveforms: IntArray) -> tuple:
        """``expected_covariance``'s arguments after the link for receiver ``rx`` and ``waveforms`` (cached by key)."""
        cov = self._covariance_args.get(key)
        if cov is None:
            lay = self.layout
            if len(self._covariance_args) > 1024:
                self._covariance_args.clear()
            cov = self._covariance_args[key] = (
                self._snr_cap[waveforms],
                self._unit_cov_stack[waveforms],
                bool(self._doa_rx[rx]),
                float(self._boresight[rx]),
                float(lay.rx_n_elements[rx]),
                float(lay.rx_spacing_m[rx]),
                self._wavelengths[waveforms],
            )
        return cov

    def _moving_link(
        self, link: tuple, pos: FloatArray, vel: FloatArray, waveforms: IntArray, rcs_m2: float, tx: int, rx: int
    ) -> tuple[FloatArray, ...]:
        """``expected_measurements``' compiled part for targets at ``pos`` moving at ``vel`` (N, 2), one call.

        Returns the link ``(azimuth (N,), covered (N,), mean SNR (W, N))`` (``_mean_link``), the range-rates
        ``(N,)`` [m/s], the notch's CNR and exponent ``(W, N)`` (``doppler_notch.notch_terms``; zeros without static
        clutter) and the walk gains for detection and for the peak ``(W, N)`` (``walk_gain``; ones without chirp
        trains): the kernels the numpy path calls one by one, with the same arguments (:func:`_moving_link_kernel`).
        """
        pair_args, k, gain, weights = link
        cnr = None if self._notch is None else self._notch[0][:, tx, rx]
        return _moving_link_kernel(
            *pair_args[:2], pos, vel, *pair_args[2:], k, float(rcs_m2), gain, weights,
            self.cfg.sensing.false_alarm_probability, self._p_noise, waveforms, *self._kernel_tables(cnr, _NO_TABLE),
            self._WALK_STEP_MPS,
        )  # fmt: skip

    def _walk_scaled(self, R: FloatArray, waveforms: IntArray, rdot: FloatArray | None) -> FloatArray:
        """``R`` ``(W, N, m, m)`` times the range walk's variance factors on range and range-rate (walk_factors).

        Compiled (``sensing.compiled.walk_scale``); ``walk_factors`` is its numpy reference.
        """
        if rdot is None or R.shape[-1] < 2:
            return R
        gain, c_range, c_rate, half_dwell, period = self._migration
        return walk_scale(
            np.array(R, dtype=float), waveforms, rdot, gain, c_range, c_rate, half_dwell, period, self._WALK_STEP_MPS
        )

    def _expected_covariance_reference(
        self, rx: int, az: FloatArray, ok: BoolArray, snr: FloatArray, waveforms: IntArray
    ) -> FloatArray:
        """R ``(W, N, m, m)`` of ``expected_measurements`` from the link ``(az, ok, snr)`` of ``_mean_link`` (numpy)."""
        safe = np.minimum(np.where(ok & (snr > 1.0), snr, 1.0), self._snr_cap[waveforms][:, None])
        if self._all_unit_chol:  # R = R(SNR = 1) / SNR (the CRLB models), every waveform at once
            R = (1.0 / safe)[..., None, None] * self._unit_cov_stack[waveforms][:, None]
        else:
            R = np.stack([self.library[int(w)].covariance(safe[i]) for i, w in enumerate(waveforms)])
        if self._doa_rx[rx]:
            lay = self.layout
            off = _wrap(az - self._boresight[rx])
            n_el, spacing = lay.rx_n_elements[rx], lay.rx_spacing_m[rx]
            var = azimuth_variance(safe, n_el, spacing, self._wavelengths[waveforms][:, None], off)  # (W, N)
            m = R.shape[-1] + 1
            R = append_block(R.reshape(-1, m - 1, m - 1), var.reshape(-1)).reshape(*var.shape, m, m)
        return R

    def clutter_intensity_at(
        self, tx: int, rx: int, z: FloatArray, R: FloatArray, waveforms: IntArray | None = None
    ) -> FloatArray:
        """The known clutter map ``(W, N)`` of pair (tx, rx) at measurements ``z`` (N, m) [measurement units].

        ``R`` ``(W, N, m, m)``: the measurement covariances of W waveforms there (columns ``measurement_names(rx)``),
        the library's ``waveforms`` ``(W,)`` (default: the whole library in order);
        the same map as the detections' ``clutter_intensity`` (module docstring, item 6), e.g. at a track's
        predicted measurement for the lookahead's clutter-dependent q_2.
        """
        p = self._formed_pair(tx, rx)
        m, (W, N) = self._m, R.shape[:2]
        col = _columns(m)
        rows = np.zeros((W * N, col["n"]))
        rows[:, col["pair"]] = p
        rows[:, 1 : 1 + m] = np.tile(z[:, :m], (W, 1))
        if self._doa_rx[rx]:
            rows[:, col["az"]] = np.tile(z[:, m], W)
        Rf = R.reshape(W * N, *R.shape[2:])
        ridge, rdot_var = (Rf[:, 0, 1] / Rf[:, 1, 1], Rf[:, 1, 1]) if m == 2 else (0.0, None)
        period = None  # range-only waveforms (impulses) measure no range-rate
        w = np.arange(len(self.library)) if waveforms is None else np.asarray(waveforms, dtype=np.int64).ravel()
        if m == 2 or self._fa_scaled:  # R's W waveforms (default the whole library)
            if w.size != W:
                raise ValueError(f"clutter_intensity_at: R has {W} waveforms but waveforms names {w.size}")
        if m == 2:  # each waveform's folded range-rate
            period = np.repeat(self.range_rate_period[w], N)
            rows[:, 2] = fold_range_rate(rows[:, 2], period)
        wf = np.repeat(w, N) if self._fa_scaled else None
        return self._clutter_intensity(rows, ridge, rdot_var, None, period, wf).reshape(W, N)

    def measurement_names(self, rx: int) -> tuple[str, ...]:
        """Measurement components of receiver ``rx``'s detections."""
        return self._names[rx]

    def range_density(self, tx: int, rx: int) -> tuple[FloatArray, FloatArray]:
        """The pair's clutter density in bistatic range: bin edges ``(n + 1,)`` [m], density ``(n,)`` [1/m]."""
        return self._range_edges, self._range_table[self._formed_pair(tx, rx), 1:-1]

    def _formed_pair(self, tx: int, rx: int) -> int:
        """Index of the formed pair (tx, rx) in ``pairs``; a clear error for any other (tx, rx)."""
        p = int(self._pair_of_key[tx * self.n_rx + rx]) if 0 <= tx < self.n_tx and 0 <= rx < self.n_rx else -1
        if p < 0:
            raise ValueError(f"pair (tx={tx}, rx={rx}) is not a formed radar pair of {self.cfg.name!r}")
        return p

    @property
    def expected_clutter(self) -> FloatArray:
        """``(T, R)`` expected number of false detections per scan in each pair's gate, at ``density_per_m2``.

        A waveform's: x ``false_alarm_scale[w]`` (bandwidth rule x ``false_alarm_factor``).
        """
        return self._clutter_mean


def false_alarm_scale(cfg: ScenarioConfig) -> FloatArray:
    """``(W,)`` each waveform's false-alarm density over ``ClutterConfig.density_per_m2``.

    B_w / reference bandwidth: a detector at a fixed per-cell Pfa makes false detections in proportion to its
    resolution cells, c / B_w each in range (``reference_bandwidth_hz`` 0, the default: 1 for every waveform); times
    an impulse waveform's ``false_alarm_factor`` (a chain whose false detections are background residues that grow with
    the waveform's energy; chirps: 1).
    """
    ref = cfg.sensing.clutter.reference_bandwidth_hz
    cells = [w.bandwidth_hz / ref if ref > 0.0 else 1.0 for w in cfg.waveforms]
    return np.array([c * getattr(w, "false_alarm_factor", 1.0) for c, w in zip(cells, cfg.waveforms, strict=True)])


_SQRT_HALF = math.sqrt(0.5)
_KEY_SPAN = 1e9  # composite sort key: pair key x span + range [m]


def folded_uniform_density(f: FloatArray, period: FloatArray | float, half_width: float) -> FloatArray:
    """Density at folded values ``f`` (n,) of U(-half_width, half_width) folded into [-P/2, P/2) [1 / (m/s)].

    The aliases f + k P inside the interval, counted: floor((w - f) / P) - ceil((-w - f) / P) + 1, over 2 w.
    Inf periods give 1 / (2 w) (callers use the unfolded model there).
    """
    p = np.where(np.isfinite(period), period, 1.0)
    n = np.floor((half_width - f) / p) - np.ceil((-half_width - f) / p) + 1.0
    return np.where(np.isfinite(period), np.maximum(n, 0.0) / (2.0 * half_width), 1.0 / (2.0 * half_width))


def _wrap(angle: FloatArray) -> FloatArray:
    """Wrap angles [rad] to [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def append_block(cov: FloatArray, var: FloatArray) -> FloatArray:
    """Block-diagonal ``(n, m+1, m+1)`` from ``cov`` (n, m, m) and a scalar variance (n,)."""
    n, m = cov.shape[0], cov.shape[1]
    out = np.zeros((n, m + 1, m + 1))
    out[:, :m, :m] = cov
    out[:, m, m] = var
    return out
