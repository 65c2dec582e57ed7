r"""Fast (parametric) sensing: detections drawn from calibrated models (SPEC.md "Fidelities").

For every transmitter-receiver pair and target in a scan:

1. mean SNR from the bistatic radar equation with the 802.15.4a path loss and the wall losses of both legs
   (``uwb_env.channel``); the waveform sets the energy and spectrum through the radar constant Gamma;
2. the scan's RCS is drawn per pair and target (Swerling 0 / I / III, scan-to-scan; pairs see the target from
   different aspects, so their fluctuations are independent);
3. detection is the square-law test itself: |sqrt(SNR) + n|^2 > -ln Pfa with n ~ CN(0, 1). Averaged over the RCS
   this has exactly the Pd of ``uwb_env.sensing.pd`` for the Swerling case (tested);
4. a detected target is measured as h(x) + v, v ~ N(0, R(SNR)), R the waveform's CRLB at the scan's true SNR
   (bistatic range; range-rate for chirps; azimuth from the ULA CRLB for array receivers when enabled); walls add
   the excess delay of seed 002 as a positive range bias;
5. false detections: a spatial Poisson process of ``clutter.density_per_m2`` over the surveillance area, part of it
   around the clutter scatterers, drawn independently per pair and thinned to the pair's coverage. Their apparent
   SNR is that of noise over the threshold (V_T + Exp(1) - 1) and their range-rate is uniform.

A target is not detected by a pair when it is not alive, beyond ``max_range_m`` from either node, inside the blind
zone (seed 000 section IV-G), hidden by an opaque wall, or outside the array's field of view.

Randomness and common random numbers: per scan the rcs, noise and clutter streams are consumed in blocks whose
size does not depend on the plan (every pair is drawn, inactive ones are discarded), so two plans on the same seed
see the same RCS, noise and clutter realisations, and the truth is never touched.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from uwb_env.channel.coverage import blind_zone, in_field_of_view
from uwb_env.channel.radar_equation import bistatic_radar_constant, leg_lengths
from uwb_env.channel.rcs import rcs_fluctuation
from uwb_env.channel.walls import pair_obstruction
from uwb_env.config import ScenarioConfig
from uwb_env.constants import SPEED_OF_LIGHT_MPS
from uwb_env.rng import RngStreams
from uwb_env.scene.layout import SceneLayout
from uwb_env.scene.truth import Truth
from uwb_env.sensing.pd import threshold_from_pfa
from uwb_env.sensing.records import Detections, ScanPlan
from uwb_env.typing import BoolArray, FloatArray
from uwb_env.units import dbm_to_watts
from uwb_env.waveforms.library import WaveformLibrary


@dataclass(frozen=True, slots=True)
class EpisodeGeometry:
    """Truth-dependent quantities of every scan, computed once per episode (they never depend on actions).

    Shapes: S scans, T transmitters, R receivers, K targets.

    Attributes:
        bistatic_range: ``(S, T, R, K)`` [m], excess delay bias included as range.
        range_rate: ``(S, T, R, K)`` [m/s].
        azimuth: ``(S, R, K)`` [rad] global azimuth seen from each receiver.
        off_boresight: ``(S, R, K)`` [rad] (nan for receivers without array).
        unit_snr: ``(S, T, R, K)`` SNR per unit radar constant: sigma_mean / (l_t l_r / d0^2)^rho / L_walls.
        covered: ``(S, T, R, K)`` alive, in range, out of the blind zone, not blocked, in the field of view.
    """

    bistatic_range: FloatArray
    range_rate: FloatArray
    azimuth: FloatArray
    off_boresight: FloatArray
    unit_snr: FloatArray
    covered: BoolArray


def azimuth_variance(snr_total: FloatArray, n_elements: FloatArray, spacing_m: FloatArray,
                     wavelength_m: float, off_boresight_rad: FloatArray) -> FloatArray:
    r"""ULA direction-of-arrival CRLB [rad^2] for one source, deterministic signal.

    var(theta) = 6 / (SNR_e L (L^2 - 1) (2 pi d cos(theta) / lambda)^2), SNR_e = SNR_total / L per element
    (phase-slope estimation across L elements, each phase with variance 1 / (2 SNR_e)).
    """
    snr_e = snr_total / n_elements
    k = 2.0 * math.pi * spacing_m * np.cos(off_boresight_rad) / wavelength_m
    return 6.0 / (snr_e * n_elements * (n_elements**2 - 1.0) * k**2)


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
        self.rcs_mean = np.array([t.rcs_mean_m2 for t in cfg.targets])
        # Radar constant per (waveform, tx, rx): the energy and spectrum of the waveform, the nodes' gains.
        self.radar_constant = np.array([[[
            bistatic_radar_constant(
                wf.scan_energy_j(dbm_to_watts(tx.power_dbm)), wf.center_freq_hz, wf.rms_bandwidth_hz,
                tx.antenna_gain_db, rx.antenna_gain_db, rx.noise_figure_db,
                rx.array.n_elements if rx.array else 1, cfg.channel)
            for rx in cfg.receivers] for tx in cfg.transmitters] for wf in self.library.waveforms])
        self.pairs = np.array(cfg.radar_pairs, dtype=np.int64).reshape(-1, 2)  # (P, 2) formed (tx, rx)
        self.pair_mask = np.zeros((self.n_tx, self.n_rx), dtype=bool)
        self.pair_mask[self.pairs[:, 0], self.pairs[:, 1]] = True
        self.use_doa = cfg.sensing.measure_doa
        names = list(self.library.measurement_names)
        self._doa_rx = lay.rx_has_array & self.use_doa
        self._names = {r: tuple(names + (["azimuth"] if self._doa_rx[r] else [])) for r in range(self.n_rx)}
        self._clutter_mean, self.gate_volume = self._clutter_statistics()

    # ------------------------------------------------------------------------------------------------ geometry
    def episode_geometry(self, truth: Truth) -> EpisodeGeometry:
        """All truth-dependent geometry of the episode, vectorised over scans x pairs x targets."""
        lay, sens, ch = self.layout, self.cfg.sensing, self.cfg.channel
        S, K = truth.states.shape[:2]
        T, R = self.n_tx, self.n_rx
        pos = truth.states[..., [0, 2]].reshape(-1, 2)
        vel = truth.states[..., [1, 3]].reshape(-1, 2)
        lt, lr = leg_lengths(lay.tx_pos, lay.rx_pos, pos)  # (T, SK), (R, SK)
        lt_s, lr_s = np.maximum(lt, 1e-6), np.maximum(lr, 1e-6)
        ut = (pos[None] - lay.tx_pos[:, None]) / lt_s[..., None]
        ur = (pos[None] - lay.rx_pos[:, None]) / lr_s[..., None]
        rdot = np.einsum("tnd,nd->tn", ut, vel)[:, None] + np.einsum("rnd,nd->rn", ur, vel)[None]
        rng_bi = lt[:, None] + lr[None]  # (T, R, SK)
        loss_db, delay_s = pair_obstruction(lay.tx_pos, lay.rx_pos, pos, lay.wall_start, lay.wall_end,
                                            lay.wall_loss_db, lay.wall_delay_s)
        in_view, az, off = in_field_of_view(lay.rx_pos, lay.rx_boresight_rad, lay.rx_fov_rad, pos)
        d0 = ch.reference_distance_m
        product = (lt_s[:, None] * lr_s[None]) / d0**2
        rcs = np.tile(self.rcs_mean, S)
        with np.errstate(over="ignore"):
            unit_snr = rcs / product**ch.path_loss_exponent * 10.0 ** (-loss_db / 10.0)
        alive = truth.alive.reshape(-1)
        covered = (
            alive[None, None]
            & (lt[:, None] <= sens.max_range_m) & (lr[None] <= sens.max_range_m)
            & ~blind_zone(rng_bi, self.baseline, sens.blind_zone_excess_m)
            & np.isfinite(loss_db) & in_view[None] & self.pair_mask[..., None]
        )

        def per_scan(a: np.ndarray) -> np.ndarray:
            return np.moveaxis(a.reshape(*a.shape[:-1], S, K), -2, 0)

        return EpisodeGeometry(
            bistatic_range=per_scan(rng_bi + SPEED_OF_LIGHT_MPS * delay_s),
            range_rate=per_scan(rdot),
            azimuth=per_scan(az),
            off_boresight=per_scan(off),
            unit_snr=per_scan(unit_snr),
            covered=per_scan(covered),
        )

    def mean_snr(self, geom: EpisodeGeometry, k: int, plan: ScanPlan) -> FloatArray:
        """``(T, R, K)`` mean SNR (at mean RCS) of scan ``k`` under ``plan`` (0 where not covered)."""
        gamma = self.radar_constant[plan.waveform, np.arange(self.n_tx)]  # (T, R)
        return np.where(geom.covered[k], gamma[..., None] * geom.unit_snr[k], 0.0)

    # ------------------------------------------------------------------------------------------------- clutter
    def _clutter_statistics(self, cell_m: float = 1.0) -> tuple[FloatArray, FloatArray]:
        """Expected false detections per pair and scan, and each pair's gate volume in measurement space."""
        lay, sens, cl = self.layout, self.cfg.sensing, self.cfg.sensing.clutter
        x0, x1, y0, y1 = lay.area
        xs = np.arange(x0 + cell_m / 2, x1, cell_m)
        ys = np.arange(y0 + cell_m / 2, y1, cell_m)
        grid = np.stack(np.meshgrid(xs, ys), -1).reshape(-1, 2)
        uniform_in = self._in_gate(grid).mean(axis=-1)  # (T, R) fraction of the area inside each gate
        area = (x1 - x0) * (y1 - y0)
        mean = (1.0 - cl.discrete_fraction) * cl.density_per_m2 * area * uniform_in
        if cl.discrete_fraction > 0:
            mean = mean + cl.discrete_fraction * cl.density_per_m2 * area * self._in_gate(lay.clutter_points).mean(-1)
        r_lo = self.baseline + sens.blind_zone_excess_m
        volume = np.maximum(2.0 * sens.max_range_m - r_lo, 1e-9)
        if self.library.measurement_dim == 2:
            volume = volume * 2.0 * cl.range_rate_max_mps
        doa_extent = np.where(self._doa_rx, 2.0 * np.nan_to_num(lay.rx_fov_rad, nan=math.pi), 1.0)
        return mean, volume * doa_extent[None, :]

    def _in_gate(self, pts: FloatArray) -> BoolArray:
        """``(T, R, N)`` whether points lie in each pair's coverage gate (range limits, blind zone, view)."""
        lay, sens = self.layout, self.cfg.sensing
        lt, lr = leg_lengths(lay.tx_pos, lay.rx_pos, pts)
        ok = (lt[:, None] <= sens.max_range_m) & (lr[None] <= sens.max_range_m)
        ok &= ~blind_zone(lt[:, None] + lr[None], self.baseline, sens.blind_zone_excess_m)
        in_view, _, _ = in_field_of_view(lay.rx_pos, lay.rx_boresight_rad, lay.rx_fov_rad, pts)
        return ok & in_view[None] & self.pair_mask[..., None]

    def _draw_clutter(self, rng: np.random.Generator) -> tuple[np.ndarray, FloatArray]:
        """Poisson false-alarm positions for every formed pair: ``(pair index (N,) into self.pairs, positions)``."""
        lay, cl = self.layout, self.cfg.sensing.clutter
        n_pairs = self.pairs.shape[0]
        x0, x1, y0, y1 = lay.area
        total = cl.density_per_m2 * (x1 - x0) * (y1 - y0)
        counts = rng.poisson([(1.0 - cl.discrete_fraction) * total, cl.discrete_fraction * total], (n_pairs, 2))
        n_u, n_d = counts[:, 0], counts[:, 1]
        u = rng.random((int(n_u.sum()), 2))
        pts_u = np.column_stack([x0 + u[:, 0] * (x1 - x0), y0 + u[:, 1] * (y1 - y0)])
        n_dt = int(n_d.sum())
        if n_dt:
            which = rng.integers(0, lay.clutter_points.shape[0], n_dt)
            pts_d = lay.clutter_points[which] + cl.discrete_spread_m * rng.standard_normal((n_dt, 2))
        else:
            pts_d = np.zeros((0, 2))
        pair = np.concatenate([np.repeat(np.arange(n_pairs), n_u), np.repeat(np.arange(n_pairs), n_d)])
        return pair, np.concatenate([pts_u, pts_d])

    # ----------------------------------------------------------------------------------------------------- scan
    def sense(self, geom: EpisodeGeometry, k: int, plan: ScanPlan, rngs: RngStreams,
              time_s: float = 0.0) -> tuple[Detections, ...]:
        """Detections of every active pair in scan ``k`` (plan validated here), ordered by (tx, rx)."""
        plan.validate(self.n_tx, self.n_rx, len(self.library))
        T, R, K = self.n_tx, self.n_rx, self.swerling.shape[0]
        lay, sens, cl = self.layout, self.cfg.sensing, self.cfg.sensing.clutter
        m = self.library.measurement_dim

        # Targets: RCS, square-law detection, measurement noise (fixed-size draws: common random numbers).
        snr = self.mean_snr(geom, k, plan) * rcs_fluctuation(self.swerling, (T, R), rngs.rcs)
        n = rngs.noise.standard_normal((3 + m, T, R, K))
        stat = (np.sqrt(snr) + n[0] * math.sqrt(0.5)) ** 2 + (n[1] * math.sqrt(0.5)) ** 2
        detected = geom.covered[k] & (stat > self.threshold) & plan.active_rx[None, :, None]

        # Clutter for every pair, thinned to the pair's gate.
        c_pair, c_pos = self._draw_clutter(rngs.clutter)
        nc = c_pair.shape[0]
        c_extra = rngs.clutter.random((2, nc))
        c_tx, c_rx = self.pairs[c_pair, 0], self.pairs[c_pair, 1]
        lt = np.linalg.norm(c_pos - lay.tx_pos[c_tx], axis=1)
        dr = c_pos - lay.rx_pos[c_rx]
        lr = np.linalg.norm(dr, axis=1)
        c_range = lt + lr
        c_ok = (lt <= sens.max_range_m) & (lr <= sens.max_range_m)
        c_ok &= c_range - self.baseline[c_tx, c_rx] >= sens.blind_zone_excess_m
        c_az = np.arctan2(dr[:, 1], dr[:, 0])
        has_arr = lay.rx_has_array[c_rx]
        c_off = np.angle(np.exp(1j * (c_az - lay.rx_boresight_rad[c_rx])))
        c_ok &= ~has_arr | (np.abs(np.where(has_arr, c_off, 0.0)) <= np.nan_to_num(lay.rx_fov_rad[c_rx]))
        c_ok &= plan.active_rx[c_rx]
        c_snr = self.threshold - np.log1p(-c_extra[0]) - 1.0  # noise over threshold: V_T + Exp(1), minus noise
        c_rdot = (2.0 * c_extra[1] - 1.0) * cl.range_rate_max_mps

        out = []
        for p, (t, r) in enumerate(self.pairs.tolist()):  # the formed pairs: a small fixed set
            if plan.active_rx[r]:
                w = int(plan.waveform[t])
                out.append(self._pair_detections(t, r, w, self.library[w], geom, k, snr, detected, n,
                                                 c_ok & (c_pair == p), c_range, c_rdot, c_az, c_snr, time_s, m))
        return tuple(out)

    def _pair_detections(self, t: int, r: int, w: int, wf, geom: EpisodeGeometry, k: int, snr: FloatArray,
                         detected: BoolArray, n: FloatArray, c_sel: BoolArray, c_range: FloatArray,
                         c_rdot: FloatArray, c_az: FloatArray, c_snr: FloatArray, time_s: float,
                         m: int) -> Detections:
        lay = self.layout
        idx = np.flatnonzero(detected[t, r])
        s = snr[t, r, idx]
        doa = bool(self._doa_rx[r])
        # True detections: h(x) + chol(R) e.
        h = [geom.bistatic_range[k, t, r, idx]]
        if m == 2:
            h.append(geom.range_rate[k, t, r, idx])
        cov = wf.covariance(s)  # (n, m, m)
        e = n[3:3 + m, t, r, idx].T  # (n, m)
        z_t = np.column_stack(h) + np.einsum("nij,nj->ni", np.linalg.cholesky(cov), e)
        # False detections.
        c_idx = np.flatnonzero(c_sel)
        cs = c_snr[c_idx]
        z_c = c_range[c_idx][:, None] if m == 1 else np.column_stack([c_range[c_idx], c_rdot[c_idx]])
        cov_c = wf.covariance(cs)
        if doa:
            args = (lay.rx_n_elements[r], lay.rx_spacing_m[r], wf.wavelength_m)
            off_t = geom.off_boresight[k, r, idx]
            var_t = azimuth_variance(s, *args, off_t)
            az_t = np.angle(np.exp(1j * (geom.azimuth[k, r, idx] + np.sqrt(var_t) * n[2, t, r, idx])))
            z_t = np.column_stack([z_t, az_t])
            off_c = np.angle(np.exp(1j * (c_az[c_idx] - lay.rx_boresight_rad[r])))
            var_c = azimuth_variance(cs, *args, off_c)
            z_c = np.column_stack([z_c, c_az[c_idx]])
            cov = _append_block(cov, var_t)
            cov_c = _append_block(cov_c, var_c)
        z = np.concatenate([z_t, z_c])
        order = np.argsort(z[:, 0], kind="stable")
        origin = np.concatenate([idx, np.full(c_idx.size, -1)]).astype(np.int64)
        return Detections(
            tx=t, rx=r, waveform=w, time_s=time_s,
            z=z[order], R=np.concatenate([cov, cov_c])[order], snr=np.concatenate([s, cs])[order],
            origin=origin[order], measurement_names=self._names[r],
            gate_volume=float(self.gate_volume[t, r]),
            clutter_density=float(self._clutter_mean[t, r] / self.gate_volume[t, r]),
        )

    @property
    def expected_clutter(self) -> FloatArray:
        """``(T, R)`` expected number of false detections per scan in each pair's gate."""
        return self._clutter_mean


def _append_block(cov: FloatArray, var: FloatArray) -> FloatArray:
    """Block-diagonal ``(n, m+1, m+1)`` from ``cov`` (n, m, m) and a scalar variance (n,)."""
    n, m = cov.shape[0], cov.shape[1]
    out = np.zeros((n, m + 1, m + 1))
    out[:, :m, :m] = cov
    out[:, m, m] = var
    return out
