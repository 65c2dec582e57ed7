r"""Detection probability of a square-law detector on one integrated scan sample, per Swerling case.

Test statistic y = |x|^2, x = a + n, n ~ CN(0, 1), |a|^2 = SNR (E/N0 of the integrated scan). The threshold for a
false-alarm probability Pfa is V_T = -ln Pfa. Closed forms (single look, scan-to-scan fluctuation):

* Swerling 0: Pd = Q_1(sqrt(2 SNR), sqrt(2 V_T)) (Marcum Q; y is non-central chi-square / 2).
* Swerling I: Pd = exp(-V_T / (1 + SNR)) = Pfa^(1 / (1 + SNR)).
* Swerling III: Pd = exp(-V_T / (1 + SNR/2)) [1 + (SNR/2) V_T / (1 + SNR/2)^2].
  Derivation: averaging E[e^{-t y} | s] = exp(-t s / (1 + t)) / (1 + t) over s ~ Gamma(2, SNR/2) gives
  (1 + t) / (1 + a t)^2, a = 1 + SNR/2, a mixture of Exp(a) (weight 1/a) and Gamma(2, a) (weight (a-1)/a),
  whose survival function at V_T is the line above.

A peak detector with a truth-matching window (``noise_window_probability``, ``windowed_detection_probability``):
the signal path counts a target as detected when a peak lies within the window around its echo, and a noise peak
there counts as well. With n independent cells at the per-cell Pfa in the window, the target is missed only when
both the echo's own test and every noise cell stay below the threshold:

    P = 1 - (1 - Pd_echo(SNR)) (1 - Pfa)^n,                P -> 1 - (1 - Pfa)^n  as SNR -> 0.
"""

from __future__ import annotations

import numpy as np
from scipy import stats

from uwb_env.typing import FloatArray


def threshold_from_pfa(pfa: float) -> float:
    """Normalised square-law threshold V_T = -ln Pfa."""
    return float(-np.log(pfa))


def pd_swerling0(snr: FloatArray, pfa: float) -> FloatArray:
    """Non-fluctuating target (Marcum Q)."""
    vt = threshold_from_pfa(pfa)
    return stats.ncx2.sf(2.0 * vt, 2, 2.0 * np.asarray(snr, dtype=float))


def pd_swerling1(snr: FloatArray, pfa: float) -> FloatArray:
    """Swerling I (exponential RCS)."""
    return np.exp(-threshold_from_pfa(pfa) / (1.0 + np.asarray(snr, dtype=float)))


def pd_swerling3(snr: FloatArray, pfa: float) -> FloatArray:
    """Swerling III (chi-square 4 dof RCS)."""
    vt = threshold_from_pfa(pfa)
    a = 1.0 + 0.5 * np.asarray(snr, dtype=float)
    return np.exp(-vt / a) * (1.0 + (a - 1.0) * vt / a**2)


_PD = {0: pd_swerling0, 1: pd_swerling1, 3: pd_swerling3}


def noise_window_probability(pfa: float, cells: float) -> float:
    """P(a noise peak in the truth-matching window) = 1 - (1 - Pfa)^n for ``cells`` = n (0: none)."""
    if cells < 0.0:
        raise ValueError(f"cells = {cells!r}: must be >= 0")
    return float(-np.expm1(cells * np.log1p(-pfa))) if cells > 0.0 else 0.0


def windowed_detection_probability(pd_echo: FloatArray, pfa: float, cells: float) -> FloatArray:
    """P = 1 - (1 - Pd_echo) (1 - Pfa)^n (module docstring): the echo's test OR a noise peak among n cells.

    ``cells`` = 0 returns ``pd_echo`` unchanged (bit for bit).
    """
    p_noise = noise_window_probability(pfa, cells)
    pd_echo = np.asarray(pd_echo, dtype=float)
    return pd_echo + p_noise - pd_echo * p_noise if p_noise > 0.0 else pd_echo


def detection_probability(snr: FloatArray, pfa: float, swerling: int) -> FloatArray:
    """Pd at mean SNR ``snr`` (linear E/N0) for Swerling case 0, 1 or 3."""
    if swerling not in _PD:
        raise ValueError(f"swerling = {swerling!r}: must be one of {sorted(_PD)}")
    return _PD[swerling](snr, pfa)
