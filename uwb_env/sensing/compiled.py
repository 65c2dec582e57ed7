r"""Compiled (numba) sensor-model kernel: one pair's mean-SNR link and Pd at a few points, fused.

The tracker (its Pd at the predicted positions, every receiver update) and the lookahead (Pd and R of every
candidate waveform, every pair) ask the parametric sensor model about a handful of positions several times a scan.
The numpy reference (``ParametricSensor._links`` -> ``_mean_link``: ``leg_lengths``, ``pair_obstruction``,
``in_field_of_view``, ``blind_zone``, the radar equation, ``detection_probability``) costs about 0.25 ms a call in
call overhead at these sizes; this kernel does the same arithmetic in one compiled pass over the points.
``tests/unit/test_sensing_compiled.py`` checks it against the reference to rounding error on every scenario.

    mean_link   coverage (range limits, blind zone, opaque walls, array field of view, formed pair), azimuth,
                mean SNR per waveform (radar equation with wall loss, the array's beam gain) and Pd (Swerling I /
                III closed forms, averaged over the clutter-residue quadrature when the sensor has one, OR a
                noise peak in the truth-matching window: 1 - (1 - Pd) (1 - p_noise), ``uwb_env.sensing.pd``)

Swerling 0 (Marcum Q) has no compiled form here; the caller evaluates it on the returned SNR.
"""

from __future__ import annotations

import cmath
import math

import numba as nb
import numpy as np

_jit = nb.njit(cache=True, fastmath=False, nogil=True)


@_jit
def _leg_obstruction(nx, ny, px, py, wall_a, wall_b, wall_loss, wall_delay):  # pragma: no cover - compiled
    """Summed loss [dB] (inf through an opaque wall) and excess delay [s] of the leg node -> point.

    The crossing test of ``scene.geometry.segments_cross``: p0 + t d = a + u e with t, u in [0, 1].
    """
    loss = 0.0
    delay = 0.0
    opaque = False
    dx, dy = px - nx, py - ny
    for w in range(wall_a.shape[0]):
        ex, ey = wall_b[w, 0] - wall_a[w, 0], wall_b[w, 1] - wall_a[w, 1]
        wx, wy = wall_a[w, 0] - nx, wall_a[w, 1] - ny
        denom = dx * ey - dy * ex
        if abs(denom) < 1e-12:
            continue
        t = (wx * ey - wy * ex) / denom
        u = (wx * dy - wy * dx) / denom
        if t >= 0.0 and t <= 1.0 and u >= 0.0 and u <= 1.0:
            if math.isinf(wall_loss[w]):
                opaque = True
            else:
                loss += wall_loss[w]
            delay += wall_delay[w]
    if opaque:
        loss = math.inf
    return loss, delay


@_jit
def _beam_gain(u, sines, kd, n_el):  # pragma: no cover - compiled
    """max_m |AF_m|^2 / L^2 at u = sin(off-boresight angle) (``sensing.beams.beam_gain``)."""
    best = 0.0
    for m in range(sines.shape[0]):
        h = 0.5 * kd * (u - sines[m])
        s = math.sin(h)
        g = 1.0 if abs(s) < 1e-12 else (math.sin(n_el * h) / (n_el * s)) ** 2
        best = max(best, g)
    return best


@_jit
def mean_link(
    tx_xy,
    rx_xy,
    pos,
    wall_a,
    wall_b,
    wall_loss,
    wall_delay,
    boresight,
    fov,
    max_range,
    baseline,
    blind_excess,
    formed,
    d0,
    rho,
    beam_sines,
    beam_kd,
    n_elements,
    k,
    rcs,
    gain,
    weights,
    pfa,
    swerling,
    p_noise=0.0,
):  # pragma: no cover - compiled
    """One pair's link at ``pos`` (N, 2) for W waveforms.

    Args:
        tx_xy, rx_xy: ``(2,)`` node positions [m]; wall_a, wall_b ``(Wl, 2)``, wall_loss ``(Wl,)`` [dB] (inf =
        opaque), wall_delay ``(Wl,)`` [s]; boresight, fov [rad] of the receiver's array (nan boresight: no array);
        max_range [m] per leg, baseline [m], blind_excess [m]; formed: the pair is a radar pair; d0 [m], rho: path
        loss; beam_sines ``(M,)``, beam_kd = 2 pi d / lambda, n_elements L: the receiver's beams
        (``sensing.beams``; M = 0: gain 1); k ``(W,)``: radar constant per waveform, rcs: assumed RCS [m^2];
        gain ``(W, J)``: the detector's SCNR gain per residue node (J = 1, gain 1 without residue), weights
        ``(J,)``; pfa; swerling 1 or 3 (else Pd = nan); p_noise: the probability of a noise peak in the detector's
        truth-matching window, 1 - (1 - Pfa)^n (``pd.noise_window_probability``; 0: the single-cell test).

    Returns:
        ``(azimuth (N,) [rad], covered (N,), snr (W, N), pd (W, N))``; snr and pd are 0 where not covered.
    """
    N = pos.shape[0]
    W = k.shape[0]
    J = weights.shape[0]
    az = np.empty(N)
    ok = np.zeros(N, dtype=np.bool_)
    snr = np.zeros((W, N))
    pd = np.zeros((W, N))
    vt = -math.log(pfa)
    has_array = not math.isnan(boresight)
    for n in range(N):
        px, py = pos[n, 0], pos[n, 1]
        lt = math.sqrt((px - tx_xy[0]) ** 2 + (py - tx_xy[1]) ** 2)
        lr = math.sqrt((px - rx_xy[0]) ** 2 + (py - rx_xy[1]) ** 2)
        a = math.atan2(py - rx_xy[1], px - rx_xy[0])
        az[n] = a
        if not formed or lt > max_range or lr > max_range or (lt + lr) - baseline < blind_excess:
            continue
        if has_array and abs(cmath.phase(cmath.exp(1j * (a - boresight)))) > fov:
            continue
        loss_t, _ = _leg_obstruction(tx_xy[0], tx_xy[1], px, py, wall_a, wall_b, wall_loss, wall_delay)
        loss_r, _ = _leg_obstruction(rx_xy[0], rx_xy[1], px, py, wall_a, wall_b, wall_loss, wall_delay)
        loss = loss_t + loss_r
        if math.isinf(loss):
            continue
        ok[n] = True
        product = (max(lt, 1e-6) * max(lr, 1e-6)) / d0**2
        unit = 1.0 / product**rho * 10.0 ** (-loss / 10.0)
        if beam_sines.shape[0] > 0 and has_array:
            unit *= _beam_gain(math.sin(cmath.phase(cmath.exp(1j * (a - boresight)))), beam_sines, beam_kd, n_elements)
        for w in range(W):
            s = k[w] * (rcs * unit)
            snr[w, n] = s
            p = 0.0
            for j in range(J):
                x = s * gain[w, j]
                if swerling == 1:
                    pj = math.exp(-vt / (1.0 + x))
                elif swerling == 3:
                    h = 1.0 + 0.5 * x
                    pj = math.exp(-vt / h) * (1.0 + (h - 1.0) * vt / h**2)
                else:
                    pj = math.nan
                p += pj * weights[j]
            if p_noise > 0.0:
                p = p + p_noise - p * p_noise
            pd[w, n] = p
    return az, ok, snr, pd


@_jit
def expected_covariance(
    az, ok, snr, snr_cap, unit_cov, doa, boresight, n_elements, spacing, wavelengths
):  # pragma: no cover - compiled  # fmt: skip
    """The lookahead's measurement covariances ``(W, N, m, m)`` at the mean SNR (``expected_measurements``).

    R = R(SNR = 1) / SNR for the CRLB waveform models, ``unit_cov`` ``(W, m0, m0)``, at ``snr`` ``(W, N)`` where
    covered (``ok`` ``(N,)``) and above 1, else at SNR = 1, then capped at the waveform's accuracy SNR ``snr_cap``
    ``(W,)`` (``parametric.accuracy_snr_caps``: the range-variance floor; in this order, so a floor above the unit-SNR
    variance holds at every SNR, as for the sensed detections); with ``doa`` the array's azimuth CRLB
    (``parametric.azimuth_variance``, element SNR = SNR / L, off-boresight angle wrapped to [-pi, pi)) is appended
    as a last row and column, m = m0 + 1. ``wavelengths`` ``(W,)`` [m].
    """
    W, N = snr.shape
    m0 = unit_cov.shape[1]
    m = m0 + 1 if doa else m0
    R = np.zeros((W, N, m, m))
    L = n_elements
    for w in range(W):
        for n in range(N):
            s = min(snr[w, n] if ok[n] and snr[w, n] > 1.0 else 1.0, snr_cap[w])
            inv = 1.0 / s
            for i in range(m0):
                for j in range(m0):
                    R[w, n, i, j] = inv * unit_cov[w, i, j]
            if doa:
                off = (az[n] - boresight + math.pi) % (2.0 * math.pi) - math.pi
                kk = 2.0 * math.pi * spacing * math.cos(off) / wavelengths[w]
                R[w, n, m0, m0] = 6.0 / ((s / L) * L * (L**2 - 1.0) * kk**2)
    return R


@_jit
def _walk_interp(table, w, rdot, step):  # pragma: no cover - compiled
    """Linear interpolation of ``table[w]`` at |rdot| (held beyond the grid) -- ParametricSensor._walk_lookup."""
    x = min(abs(rdot) / step, table.shape[1] - 1.000001)
    i = int(x)
    t = x - i
    return table[w, i] * (1.0 - t) + table[w, i + 1] * t


@_jit
def walk_gain(waveforms, rdot, gain_table, step):  # pragma: no cover - compiled
    """``(W, N)`` range-walk power gain of waveforms ``(W,)`` at range-rates ``(N,)`` [m/s] (the tables' G)."""
    out = np.empty((waveforms.shape[0], rdot.shape[0]))
    for a in range(waveforms.shape[0]):
        for n in range(rdot.shape[0]):
            out[a, n] = _walk_interp(gain_table, waveforms[a], rdot[n], step)
    return out


@_jit
def walk_scale(R, waveforms, rdot, gain, c_range, c_rate, half_dwell, period, step):  # pragma: no cover - compiled
    """Scale the (range, range-rate) block of ``R`` ``(W, N, m, m)`` in place by the range walk's variance factors.

    The compiled :meth:`ParametricSensor.walk_factors`: f_r = min(G / c_r^2, G + D^2 / (3 R_rr)),
    f_d = clip(G / c_d^2, 1, P^2 / (12 R_dd)); R_ij -> R_ij sqrt(f_i f_j) for i, j in (range, range-rate).
    """
    m = R.shape[2]
    for a in range(waveforms.shape[0]):
        w = waveforms[a]
        for n in range(rdot.shape[0]):
            g = _walk_interp(gain, w, rdot[n], step)
            c_r = max(_walk_interp(c_range, w, rdot[n], step), 1e-6)
            c_d = max(_walk_interp(c_rate, w, rdot[n], step), 1e-6)
            walk = abs(rdot[n]) * half_dwell[w]
            f_r = min(g / (c_r * c_r), g + walk * walk / (3.0 * R[a, n, 0, 0]))
            cap = max(period[w] * period[w] / (12.0 * R[a, n, 1, 1]), 1.0)
            f_d = min(max(g / (c_d * c_d), 1.0), cap)
            s_r, s_d = math.sqrt(f_r), math.sqrt(f_d)
            for i in range(m):
                d_i = s_r if i == 0 else (s_d if i == 1 else 1.0)
                for j in range(m):
                    d_j = s_r if j == 0 else (s_d if j == 1 else 1.0)
                    R[a, n, i, j] *= d_i * d_j
    return R
