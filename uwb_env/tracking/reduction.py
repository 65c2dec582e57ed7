r"""PDA information-reduction factor q_2 (Kershaw and Evans 1994; Fortmann et al. 1985) for the lookahead.

With clutter, a PDA update does not remove the full K S K^T from the predicted covariance. Averaged over the
measurement set (Poisson clutter of density rho in measurement space, the target detected with P_D and inside the
gate with P_G), the expected posterior covariance of one PDA update with gain K and innovation covariance S is

    E[P+] = P - q_2 P_D K S K^T,

q_2 depending only on the measurement dimension m, P_D, P_G and the expected number of false measurements in the
gate, lambda_G = rho V_G, V_G = c_m gamma^(m/2) |S|^(1/2) (c_m the unit-ball volume, gamma the chi-square gate).

Derivation (our normalisation: q_2 = 1 with P_G = 1 and no clutter, the seed-003 lookahead). In whitened
coordinates w = S^(-1/2) nu the PDA posterior (Bar-Shalom) is

    P+ = P - G [ (1 - beta_0) I - (sum_i beta_i w_i w_i^T - wbar wbar^T) ] G^T,   G = K S^(1/2),  wbar = sum beta_i w_i,

and the distribution of the w_i is rotation invariant, so the bracket's expectation is a multiple of I:

    P_D q_2 = E[ (1 - beta_0) - (sum_i beta_i |w_i|^2 - |wbar|^2) / m ].

The weights are the tracker's (LMIPDA with existence 1, i.e. PDA with gate-truncated likelihoods):
beta_i proportional to P_D exp(-|w_i|^2 / 2) / ((2 pi)^(m/2) rho_w), beta_0 to 1 - P_D P_G, with
rho_w = lambda_G / (c_m gamma^(m/2)) the clutter density in whitened space. The expectation has no closed form;
it is tabulated by Monte Carlo over (P_D, lambda_G) with common random numbers across the grid (a fixed seed, so
the table is deterministic), and read by bilinear interpolation in (P_D, log(1 + lambda_G)).

Limits (tested): lambda_G = 0 gives q_2 = P_G; q_2 decreases with lambda_G and tends to 0.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from scipy import stats

from uwb_env.tracking import compiled
from uwb_env.typing import FloatArray

PD_GRID = np.linspace(0.02, 1.0, 50)
"""Detection probabilities of the table's rows (a P_D below 0.02 reads the first row)."""
LAMBDA_MAX = 200.0
LOG_LAMBDA_GRID = np.linspace(0.0, math.log1p(LAMBDA_MAX), 61)
"""log(1 + lambda_G) of the table; lambda_G beyond LAMBDA_MAX uses the last column."""
N_SAMPLES = 4000
SEED = 20261122


def unit_ball_volume(m: int) -> float:
    """Volume of the unit ball in m dimensions, c_m = pi^(m/2) / Gamma(m/2 + 1)."""
    return math.pi ** (m / 2.0) / math.gamma(m / 2.0 + 1.0)


def _uniform_in_ball(rng: np.random.Generator, shape: tuple[int, ...], m: int, radius: float) -> FloatArray:
    """``(*shape, m)`` points uniform in the ball of ``radius``."""
    d = rng.normal(size=(*shape, m))
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    return d * (radius * rng.uniform(size=shape) ** (1.0 / m))[..., None]


def _truncated_normal_in_ball(rng: np.random.Generator, n: int, m: int, gamma: float) -> FloatArray:
    """``(n, m)`` standard normal points conditioned on |w|^2 < gamma (radius by the chi-square inverse CDF)."""
    d = rng.normal(size=(n, m))
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    u = rng.uniform(size=n) * stats.chi2.cdf(gamma, m)
    return d * np.sqrt(stats.chi2.ppf(u, m))[:, None]


@lru_cache(maxsize=16)
def reduction_table(m: int, gate_probability: float) -> FloatArray:
    """``(len(PD_GRID), len(LOG_LAMBDA_GRID))`` q_2 for measurement dimension ``m`` (module docstring).

    Monte Carlo with N_SAMPLES measurement sets per grid point, the same draws at every grid point.
    """
    if m < 1:
        raise ValueError(f"m={m}: the measurement dimension must be >= 1")
    if not 0.0 < gate_probability < 1.0:
        raise ValueError(f"gate_probability={gate_probability}: must be in (0, 1)")
    rng = np.random.default_rng([SEED, m, round(gate_probability * 1e9)])
    gamma = float(stats.chi2.ppf(gate_probability, m))
    volume = gate_volume_factor(m, gate_probability)
    lam = np.expm1(LOG_LAMBDA_GRID)
    n_max = int(stats.poisson.ppf(1.0 - 1e-9, LAMBDA_MAX)) + 1
    u_count = rng.uniform(size=N_SAMPLES)  # common across lambda: the counts rise with lambda
    w_target = _truncated_normal_in_ball(rng, N_SAMPLES, m, gamma)
    w_clutter = _uniform_in_ball(rng, (N_SAMPLES, n_max), m, math.sqrt(gamma))
    r2_t = np.sum(w_target**2, axis=-1)
    e_t = np.exp(-0.5 * r2_t)  # (S,)
    r2_c = np.sum(w_clutter**2, axis=-1)
    e_c = np.exp(-0.5 * r2_c)  # (S, n_max)
    # running sums over a sample's clutter points (counts rise with lambda): sum e, sum e |w|^2, sum e w
    zero = np.zeros((N_SAMPLES, 1))
    cum_e = np.concatenate([zero, np.cumsum(e_c, axis=1)], axis=1)
    cum_er2 = np.concatenate([zero, np.cumsum(e_c * r2_c, axis=1)], axis=1)
    cum_ew = np.concatenate([np.zeros((N_SAMPLES, 1, m)), np.cumsum(e_c[..., None] * w_clutter, axis=1)], axis=1)
    rows = np.arange(N_SAMPLES)
    table = np.empty((PD_GRID.size, lam.size))
    for j, lj in enumerate(lam):
        count = stats.poisson.ppf(u_count, lj).astype(np.int64) if lj > 0 else np.zeros(N_SAMPLES, np.int64)
        s_e, s_er2, s_ew = cum_e[rows, count], cum_er2[rows, count], cum_ew[rows, count]
        rho_w = max(lj, 1e-300) / volume
        for i, pd in enumerate(PD_GRID):
            # weights up to a common factor: each point e_i P_D / ((2 pi)^(m/2) rho_w), no measurement 1 - P_D P_G
            scale = pd / ((2.0 * math.pi) ** (m / 2.0) * rho_w)
            none = 1.0 - pd * gate_probability
            terms = []
            for a_t in (scale * e_t, 0.0 * e_t):  # the target's measurement in the gate, or not
                total = none + a_t + scale * s_e
                second = (a_t * r2_t + scale * s_er2) / total
                mean_w = (a_t[:, None] * w_target + scale * s_ew) / total[:, None]
                terms.append((a_t + scale * s_e) / total - (second - np.sum(mean_w**2, axis=-1)) / m)
            # expectation over the target's presence in the gate (probability P_D P_G) taken exactly
            term = pd * gate_probability * terms[0] + none * terms[1]
            table[i, j] = term.mean() / pd
    return table


def information_reduction(m: int, pd: FloatArray, lam_gate: FloatArray, gate_probability: float) -> FloatArray:
    """q_2 at detection probabilities ``pd`` and expected false measurements in the gate ``lam_gate`` (same shape).

    Bilinear interpolation of :func:`reduction_table` in (P_D, log(1 + lambda_G)), the grid's edge values beyond it.
    """
    table = reduction_table(m, float(gate_probability))
    return interpolate(table, np.asarray(pd, dtype=float), np.log1p(np.asarray(lam_gate, dtype=float)))


def interpolate(table: FloatArray, pd: FloatArray, log_lam: FloatArray) -> FloatArray:
    """Bilinear read of ``table`` at (pd, log(1 + lambda)) on (PD_GRID, LOG_LAMBDA_GRID), edges held.

    The one reader the compiled lookahead uses too (``compiled.read_table``); pd and log_lam broadcast.
    """
    pd, log_lam = np.broadcast_arrays(np.asarray(pd, dtype=float), np.asarray(log_lam, dtype=float))
    flat = compiled.read_table(table, table_grid(), pd.ravel().copy(), log_lam.ravel().copy())
    return flat.reshape(pd.shape)


def table_grid() -> FloatArray:
    """``(3,)`` (first P_D, P_D step, log(1 + lambda) step): the table's grid for the compiled reader."""
    return np.array([PD_GRID[0], PD_GRID[1] - PD_GRID[0], LOG_LAMBDA_GRID[1] - LOG_LAMBDA_GRID[0]])


@lru_cache(maxsize=64)
def gate_volume_factor(m: int, gate_probability: float) -> float:
    """c_m gamma^(m/2): the gate volume is this times |S|^(1/2)."""
    gamma = float(stats.chi2.ppf(gate_probability, m))
    return unit_ball_volume(m) * gamma ** (m / 2.0)


__all__ = [
    "LAMBDA_MAX",
    "LOG_LAMBDA_GRID",
    "PD_GRID",
    "gate_volume_factor",
    "information_reduction",
    "interpolate",
    "reduction_table",
    "table_grid",
    "unit_ball_volume",
]
