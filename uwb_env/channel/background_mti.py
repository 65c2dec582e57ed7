r"""The exponential-averaging background subtraction as a moving-target indicator: what it leaves of a target's echo.

Seed 001's chain (``sensing.signal.sensor``, ``background = "exponential-coherent"``) subtracts from each raw scan
x_k(t) the exponential average of the previous scans and updates the average after the subtraction
(``detection.envelope.exponential_background``, called after the detection):

    d_k = x_k - b_{k-1},    b_k = lambda b_{k-1} + (1 - lambda) x_k      (lambda = ``SignalConfig.background_alpha``)

so in steady state b_{k-1} = (1 - lambda) sum_{j>=1} lambda^{j-1} x_{k-j} and d_k = sum_{j>=0} h_j x_{k-j} with

    h_0 = 1,   h_j = -(1 - lambda) lambda^{j-1}  (j >= 1),    H(z) = (1 - z^-1) / (1 - lambda z^-1):

the first-order recursive MTI canceller (a single delay-line canceller with feedback; Skolnik, Introduction to
Radar Systems, 3rd ed., section 3.3 "delay-line cancelers", recursive filters; the same filter seen over the scan
index). It removes what stands still: sum_j h_j = H(1) = 0.

A target's echo in scan k is p(t - tau_k), p(t) = a e(t) cos(2 pi f_c t + phi) the synthesis' pulse
(``sensing.signal.synthesis.unit_pulses``: Gaussian envelope e(t) = exp(-t^2 / (2 s^2)), carrier f_c, phase phi
held while the target is the same scatterer, ``SignalConfig.coherent_echoes``). Its delay moves by
delta = rdot T / c per scan (rdot the pair's bistatic range-rate, T the scan period), tau_{k-j} = tau_k - j delta.
Around the echo's peak, t = tau_k + u:

    d_k(tau_k + u) = Re{ e^{i (2 pi f_c u + phi)} A(u) },   A(u) = sum_j h_j e(u + j delta) e^{i 2 pi f_c j delta}.

The chain takes the square-law envelope (the square low-passed by a Gaussian of std sigma_L, ``SignalConfig.
envelope_lpf_s``); averaged over the carrier phase phi the square is |A|^2 / 2 (the 2 f_c term averages out), so
the retained power fraction at the echo's peak -- the residue over the echo the chain would see with no background --
is

    g(rdot) = [G_L * |A|^2](0) / [G_L * e^2](0),        G_L the LPF's kernel (a delta for sigma_L = 0, then
                                                          g = |sum_j h_j e(j delta) e^{i 2 pi f_c j delta}|^2).

g(0) = |H(1)|^2 = 0; for |delta| beyond the envelope's width only h_0 survives and g -> 1 (the classic MTI response
|H(e^{i theta})|^2 = 2 (1 - cos theta) / (1 + lambda^2 - 2 lambda cos theta), theta = 2 pi f_c delta, is the limit of
an envelope much wider than the walk: there the sum is a geometric series, ``canceller_response``).

Scan-to-scan fluctuation of the echo's amplitude (Swerling I / III drawn per scan): a_k = m + f_k with E[a^2] = 1,
m = E[a], var f = nu = 1 - m^2 (``amplitude_fluctuation``). The fluctuating part does not cancel:

    E g = (1 - nu) g_coherent + nu sum_j h_j^2 [G_L * e(. + j delta)^2](0) / [G_L * e^2](0),

at rest nu 2 / (1 + lambda) (Swerling III: nu = 0.116, -9.1 dB; Swerling I: 0.215).

Assumptions: a point scatterer (one body centre), the steady state of the average (lambda^k of the start-up
forgotten: 20 scans at lambda = 0.9 leave 12 %), a constant range-rate over the average's memory (1 / (1 - lambda)
= 10 scans, 0.74 s), the carrier phase averaged over; the envelope detector's LPF as a continuous Gaussian (the chain
filters samples). Tested against the closed form and against the chain's own steps on synthesised scans
(``tests/unit/test_background_mti.py``).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from uwb_env.constants import SPEED_OF_LIGHT_MPS
from uwb_env.typing import FloatArray

_TAIL = 1e-9  # the canceller's weights are summed until lambda^j falls below this


def canceller_weights(alpha: float) -> FloatArray:
    """``(J + 1,)`` h_0 = 1, h_j = -(1 - alpha) alpha^(j - 1): the steady-state residue's weights over past scans."""
    if not 0.0 <= alpha < 1.0:
        raise ValueError(f"background_alpha = {alpha!r}: the exponential average needs 0 <= alpha < 1")
    n = 1 if alpha == 0.0 else max(1, math.ceil(math.log(_TAIL) / math.log(alpha)))
    h = np.empty(n + 1)
    h[0] = 1.0
    h[1:] = -(1.0 - alpha) * alpha ** np.arange(n)
    return h


def canceller_response(theta_rad: FloatArray, alpha: float) -> FloatArray:
    """|H(e^{i theta})|^2 = 2 (1 - cos theta) / (1 + alpha^2 - 2 alpha cos theta): the classic MTI response.

    The residue of an echo whose phase turns by ``theta`` per scan and whose envelope does not move (the geometric
    series of the module docstring); 0 at theta = 0, 4 / (1 + alpha)^2 at theta = pi.
    """
    c = np.cos(np.asarray(theta_rad, dtype=float))
    return 2.0 * (1.0 - c) / (1.0 + alpha * alpha - 2.0 * alpha * c)


def amplitude_fluctuation(swerling: int) -> float:
    """The fluctuation nu = var(a) / E[a^2] of the echo's amplitude a = sqrt(RCS factor) drawn independently per scan.

    Swerling 0: 0; I (exponential power): 1 - pi / 4; III (chi-square of 4 degrees, mean 1): 1 - Gamma(5/2)^2 / 2.
    """
    if swerling == 0:
        return 0.0
    if swerling == 1:
        return 1.0 - math.pi / 4.0
    if swerling == 3:
        return 1.0 - math.gamma(2.5) ** 2 / 2.0
    raise ValueError(f"swerling = {swerling!r}: 0, 1 or 3")


def retained_fraction(
    delay_step_s: FloatArray,
    alpha: float,
    envelope_std_s: float,
    carrier_hz: float,
    lpf_std_s: float = 0.0,
    fluctuation: float = 0.0,
) -> FloatArray:
    """g: the power the background subtraction leaves at an echo's peak, over the echo's own (module docstring).

    Args: delay_step_s: the echo's delay change per scan delta = rdot T / c [s], any shape; alpha: the average's
    lambda; envelope_std_s: the pulse envelope's std s [s]; carrier_hz: f_c; lpf_std_s: the square-law envelope's
    low-pass std sigma_L [s] (0: none); fluctuation: nu of the amplitude's scan-to-scan fluctuation
    (``amplitude_fluctuation``). Returns g, the shape of ``delay_step_s``.
    """
    delta = np.asarray(delay_step_s, dtype=float)
    h = canceller_weights(alpha)
    j = np.arange(h.size, dtype=float)
    if lpf_std_s > 0.0:  # the LPF's kernel on a grid of +-4 sigma_L (the chain's truncate = 4)
        u = np.linspace(-4.0 * lpf_std_s, 4.0 * lpf_std_s, 33)
        w_u = np.exp(-0.5 * (u / lpf_std_s) ** 2)
    else:
        u, w_u = np.zeros(1), np.ones(1)
    w_u = w_u / w_u.sum()
    flat = delta.reshape(-1)
    shift = j[None, :] * flat[:, None]  # (G, J) j delta
    env = np.exp(-0.5 * ((u[None, :, None] + shift[:, None, :]) / envelope_std_s) ** 2)  # (G, U, J)
    rot = h[None, :] * np.exp(2j * math.pi * carrier_hz * shift)  # (G, J)
    a = np.einsum("guj,gj->gu", env, rot)  # A(u)
    norm = float(np.sum(w_u * np.exp(-((u / envelope_std_s) ** 2))))  # [G_L * e^2](0)
    coherent = (np.abs(a) ** 2) @ w_u / norm
    g = coherent
    if fluctuation > 0.0:
        incoherent = np.einsum("guj,j,u->g", env**2, h**2, w_u) / norm
        g = (1.0 - fluctuation) * coherent + fluctuation * incoherent
    return g.reshape(delta.shape)


def retained_fraction_history(
    delay_s: FloatArray,
    alpha: float,
    envelope_std_s: float,
    carrier_hz: float,
    lpf_std_s: float = 0.0,
    fluctuation: float = 0.0,
    present: FloatArray | None = None,
    memory: int = 80,
) -> FloatArray:
    """G of every scan from the echo's own delay history: the exact sum where the steady state assumes jδ.

    ``delay_s`` ``(S, ...)``: the echo's delay in scans 1..S (scan 1 subtracts the empty room's reference, which
    holds no echo: g = 1 there, and scan k's average holds scans 1..k-1 only). The residue at scan k's peak is
    A(u) = sum_j h_j e(u + Delta_j) e^{i 2 pi f_c Delta_j}, Delta_j = tau_k - tau_{k-j} (module docstring; jδ for a
    constant range-rate), over j < ``memory`` (lambda^memory: 2e-4 at lambda = 0.9) and j < k; ``present`` ``(S, ...)``
    (1 / 0) removes the scans without the echo (a dead target). The steady state of ``retained_fraction`` assumes the
    range-rate constant over the average's memory (1 / (1 - lambda) scans); a person turning round, whose range-rate
    passes through 0 in a fraction of that memory, keeps more than g(0) (the average still holds its echoes from
    before the turn at other delays), and walking back over its own recent trail it may keep less than the steady
    state at the same range-rate (a turn of 14 scans: 0.59 where the steady state says 0.79). Returns ``(S, ...)``.
    """
    tau = np.asarray(delay_s, dtype=float)
    S = tau.shape[0]
    flat = tau.reshape(S, -1)
    ok = np.isfinite(flat) if present is None else (np.asarray(present, dtype=float).reshape(S, -1) > 0.0)
    ok = ok & np.isfinite(flat)
    flat = np.where(ok, flat, 0.0)
    h = canceller_weights(alpha)[:memory]
    J = min(h.size, S)
    h = h[:J]
    k = np.arange(S)[:, None]
    past = k - np.arange(J)[None, :]  # (S, J) the scan k - j
    valid = past >= 0
    src = np.clip(past, 0, S - 1)
    delta = flat[:, None, :] - flat[src]  # (S, J, N)
    weight = np.where(valid[..., None], ok[src], False) * h[None, :, None]  # (S, J, N)
    if lpf_std_s > 0.0:
        u = np.linspace(-4.0 * lpf_std_s, 4.0 * lpf_std_s, 33)
        w_u = np.exp(-0.5 * (u / lpf_std_s) ** 2)
    else:
        u, w_u = np.zeros(1), np.ones(1)
    w_u = w_u / w_u.sum()
    norm = float(np.sum(w_u * np.exp(-((u / envelope_std_s) ** 2))))
    env = np.exp(-0.5 * ((u[:, None, None, None] + delta[None]) / envelope_std_s) ** 2)  # (U, S, J, N)
    rot = weight * np.exp(2j * math.pi * carrier_hz * delta)  # (S, J, N)
    a = np.einsum("usjn,sjn->usn", env, rot)
    g = np.einsum("usn,u->sn", np.abs(a) ** 2, w_u) / norm
    if fluctuation > 0.0:
        incoherent = np.einsum("usjn,sjn,u->sn", env**2, weight**2, w_u) / norm
        g = (1.0 - fluctuation) * g + fluctuation * incoherent
    g = np.where(ok, g, 0.0)
    return g.reshape(tau.shape)


def envelope_std_s(rms_bandwidth_hz: float) -> float:
    """The Gaussian pulse envelope's std s [s] at RMS bandwidth sigma_f, 1 / (2 sqrt 2 pi sigma_f).

    The synthesis' pulse (``sensing.signal.synthesis.pulse_envelope_std_s``; repeated here so the parametric model
    does not import the signal path).
    """
    return 1.0 / (2.0 * math.sqrt(2.0) * math.pi * rms_bandwidth_hz)


def delay_step_s(range_rate_mps: FloatArray, scan_period_s: float) -> FloatArray:
    """The delay step delta = rdot T / c [s] by which a bistatic range-rate ``rdot`` [m/s] moves the echo per scan."""
    return np.asarray(range_rate_mps, dtype=float) * scan_period_s / SPEED_OF_LIGHT_MPS


@functools.lru_cache(maxsize=32)
def _table_row(
    fc: float, s: float, alpha: float, period: float, lpf: float, nu: float, step: float, top: float
) -> FloatArray:
    """One waveform's g over |rdot| = 0, step, ... top (cached: every sensor of a scenario builds the same)."""
    grid = np.arange(0.0, top + step, step)
    row = retained_fraction(delay_step_s(grid, period), alpha, s, fc, lpf, nu)
    row.setflags(write=False)
    return row


class MtiTable:
    """g(|rdot|) tabulated per waveform (``retained_fraction``) and read by linear interpolation.

    ``g[w, i]`` at |rdot| = i ``step_mps`` up to ``max_mps``; beyond, the last value (the envelope has moved past
    itself: g ~ 1).
    """

    def __init__(self, g: FloatArray, step_mps: float) -> None:
        self.g = np.asarray(g, dtype=float)
        self.step_mps = float(step_mps)

    @classmethod
    def build(
        cls,
        carriers_hz: FloatArray,
        envelope_std_s: FloatArray,
        alpha: float,
        scan_period_s: float,
        lpf_std_s: float,
        fluctuation: float,
        step_mps: float = 0.01,
        max_mps: float = 3.0,
    ) -> MtiTable:
        """The table of waveforms ``(W,)`` (carriers and envelope stds) for one scan period, average and LPF."""
        rows = [
            _table_row(float(fc), float(s), alpha, scan_period_s, lpf_std_s, fluctuation, step_mps, max_mps)
            for fc, s in zip(np.asarray(carriers_hz).tolist(), np.asarray(envelope_std_s).tolist(), strict=True)
        ]
        return cls(np.stack(rows), step_mps)

    def __call__(self, w: FloatArray, range_rate_mps: FloatArray) -> FloatArray:
        """The retained fraction g of waveforms ``w`` at ``range_rate_mps`` [m/s] (both broadcast)."""
        x = np.minimum(np.abs(np.asarray(range_rate_mps, dtype=float)) / self.step_mps, self.g.shape[1] - 1.000001)
        i = x.astype(np.int64)
        t = x - i
        w = np.asarray(w, dtype=np.int64)
        return self.g[w, i] * (1.0 - t) + self.g[w, i + 1] * t
