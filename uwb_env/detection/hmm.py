r"""Hidden-Markov estimation of the bistatic delay from cluttered CIRs (seed 004, McCracken & Patwari, section 2).

Every kernel works on a batch of observation sequences ``(B, N)``: one row per transmitter-receiver link and
person position, N range bins of duration T (bin k holds the CIR energy r_k of eq. 3). Everything is vectorised
over the batch; the only Python loop is the forward-backward recursion over the N bins (N ~ 50), each step
vectorised over the batch and the two states.

Change statistic (section 2.2). Per range bin, r_k is modelled as Gaussian, N(mu_p, s_p^2) in the calibration
(empty-room) captures and N(mu_q, s_q^2) in the captures under test, each estimated by the sample mean and the
unbiased sample variance of the captures. The observation is the symmetric Kullback-Leibler divergence
D(p||q) + D(q||p); with D(p||q) = log(s_q / s_p) + (s_p^2 + (mu_p - mu_q)^2) / (2 s_q^2) - 1/2 the log terms cancel
and (eq. 5, which the extracted text gives correctly; re-derived here)

    O_k = 1/2 (s_p^2 / s_q^2 + s_q^2 / s_p^2 + (mu_p - mu_q)^2 (s_p^2 + s_q^2) / (s_p^2 s_q^2)) - 1  >= 0.

Two-state HMM (sections 2.3-2.5). X_k = 0: the person does not change bin k; X_k = 1: it does (k >= k_*, the bin of
the bistatic delay). Emissions are log-normal, log O_k | X_k = i ~ N(m_i, v_i) (section 2.4). The densities are
evaluated on y = log O; the density of O itself carries the extra Jacobian 1 / O_k, common to both states, so the
posteriors are unchanged and every log-likelihood here is that of O up to the data constant -sum log O_k.

* Initial lambda from a training room with known k_* (eqs. 6-7 and Rabiner's eq. 40a-b with the states known):
  pi_i = fraction of sequences whose first bin is in state i; P_0j = counted transitions out of state 0; the split
  at k_* has no 1 -> 0 transition, so P_10 = eps (section 2.4's small return probability), P_11 = 1 - eps;
  (m_i, v_i) = ML log-normal fit to D_i = {O_k : k < k_*} and {O_k : k >= k_*}.
* Forward-backward in the log domain gives gamma_k(i) = P(X_k = i | O, lambda) (eq. 9) and the likelihood.
* Baum-Welch (Rabiner, several sequences sharing lambda): pi and P from the expected counts; the emissions by the
  posterior-weighted ML log-normal fit ("soft", the exact M-step: the likelihood never decreases). The seed (eq. 11)
  refits the emissions on the hard split D_i = {O_k : X_hat_k = i}; that variant ("hard") is kept for the replica,
  but it is not an exact M-step and its likelihood can decrease.
* The delay estimate (eq. 12): the first bin with P(X_k = 1 | O, lambda) > 1/2 (-1 when there is none, a false
  negative).

Bin convention. Section 2.3 writes k_* = floor(tau_* / T) with bins centred on k T (eq. 3), eq. 16 the ceil of the
excess path over c T; they differ by half a bin. The replica uses eq. 16's: bin k holds the excess delays
((k - 1) T, k T] over the direct path, k_* = ceil(tau_* / T) >= 1, for the estimators and the truth alike. The
kernels here only see array indices; the caller maps them to bins.

Baselines (section 2.6 and 4.1):

* first threshold crossing, eq. 13: the first k with O_k > gamma; the replica picks gamma with hindsight (the
  minimum RMSE over a grid of thresholds on the data under test) and, as the seed also does, trained on the other
  room;
* Zetik et al. (eqs. 20-22) on the complex CIR samples: background b^i = alpha b^(i-1) + (1 - alpha) m^i started
  from the calibration mean, s^i = m^i - b^i, threshold t^i = 0.3 ||s^i||_inf + 0.7 n^i with n^i the peak noise
  level of m^i (its largest magnitude in the noise-only samples before the direct path), the first sample with
  |s^i| > t^i. The seed leaves alpha and the combination of the captures open: the caller chooses alpha, and the
  estimate of the link is the median over its test captures of the per-capture bin.
"""

from __future__ import annotations

import dataclasses
import warnings

import numba as nb
import numpy as np

from uwb_env.typing import FloatArray, IntArray

LOG_FLOOR = 1e-300
"""O_k is floored here before its log (O = 0 only for identical sample moments)."""


# ---------------------------------------------------------------------------------------------- change statistic
def gaussian_symmetric_kl(mu_p: FloatArray, var_p: FloatArray, mu_q: FloatArray, var_q: FloatArray) -> FloatArray:
    """Symmetric KL divergence D(p||q) + D(q||p) of two Gaussians, elementwise (eq. 5)."""
    mu_p, var_p, mu_q, var_q = (np.asarray(a, dtype=float) for a in (mu_p, var_p, mu_q, var_q))
    d2 = np.square(mu_p - mu_q)
    return 0.5 * (var_p / var_q + var_q / var_p + d2 * (var_p + var_q) / (var_p * var_q)) - 1.0


def kl_observations(calibration: FloatArray, test: FloatArray, var_floor: float = 0.0) -> FloatArray:
    """Observation O ``(..., N)`` of eq. 5 from bin energies ``(..., n_cal, N)`` and ``(..., n_test, N)``.

    The sample variances (ddof = 1) are floored at ``var_floor`` (relative to nothing: same units as r_k^2).
    """
    cal, tst = np.asarray(calibration, dtype=float), np.asarray(test, dtype=float)
    var_p = np.maximum(cal.var(axis=-2, ddof=1), var_floor)
    var_q = np.maximum(tst.var(axis=-2, ddof=1), var_floor)
    return gaussian_symmetric_kl(cal.mean(axis=-2), var_p, tst.mean(axis=-2), var_q)


CHI2_1_LOG_MEAN = -1.2703628454614782
"""E[log X] of X ~ chi^2 with 1 degree of freedom (digamma(1/2) + log 2): state 0 of the single-capture statistic."""
CHI2_1_LOG_VAR = 4.934802200544679
"""Var[log X] of X ~ chi^2_1 (pi^2 / 2)."""


def single_capture_observations(
    scan: FloatArray,
    ref: FloatArray,
    start: FloatArray,
    bin_len: float,
    n_bins: int,
    var_scan: float,
    var_ref: float,
    rel_std: float = 0.0,
) -> FloatArray:
    """O ``(B, n_bins)`` of one capture against an empty-room reference, both real scans ``(B, S)``.

    The signal sensor sees one scan per pair, not the seed's ten captures, but knows its noise: white, variance
    ``var_scan`` per sample in the scan and ``var_ref`` in the (averaged) reference. With the bin energies r_k of
    the scan and rbar_k of the reference over bins of ``bin_len`` samples (m_k) from ``start`` (B,) [samples], eq. 5
    with both distributions' variance the known variance v_k of r_k - rbar_k in an unchanged room gives

        O_k = (r_k - rbar_k - m_k (var_scan - var_ref))^2 / v_k,
        v_k = 4 S_k (var_scan + var_ref) + 2 m_k (var_scan^2 + var_ref^2) + (rel_std S_k)^2,

    (the noise's mean energy differs between scan and reference), S_k the bin's noise-free energy, estimated as
    max(rbar_k - m_k var_ref, 0), ``rel_std`` the relative std of a bin's background energy from scan to reference
    (a background that does not repeat exactly: the paths' fluctuation). In an unchanged bin O_k is chi^2 with one
    degree of freedom, to the Gaussian approximation of a bin's energy (state 0: :data:`CHI2_1_LOG_MEAN`,
    :data:`CHI2_1_LOG_VAR`, or exactly with ``HmmParams.chi2_state0``). Bins past the scan's end are NaN (missing).
    """
    from uwb_env.detection.energy_detector import bin_energies

    scan, ref = np.asarray(scan, dtype=float), np.asarray(ref, dtype=float)
    r = bin_energies(scan, start, bin_len, n_bins)
    rb = bin_energies(ref, start, bin_len, n_bins)
    m = bin_energies(np.ones(ref.shape), start, bin_len, n_bins)  # samples per bin
    S = np.maximum(rb - m * var_ref, 0.0)  # the bin's noise-free energy, unbiased before the clip
    v = 4.0 * S * (var_scan + var_ref) + 2.0 * m * (var_scan**2 + var_ref**2) + np.square(rel_std * S)
    return np.square(r - rb - m * (var_scan - var_ref)) / v


# ------------------------------------------------------------------------------------------------------ the HMM
@dataclasses.dataclass(frozen=True)
class HmmParams:
    """lambda = [pi_i, P_ij, f_O,i] (eq. 8) with log-normal f_O,i: log O | X = i ~ N(mean[i], var[i]).

    ``chi2_state0``: state 0's density is the exact one of the single-capture statistic (O ~ chi^2_1, so
    log f(y) = y / 2 - e^y / 2 - log(2 pi) / 2 for y = log O) instead of its log-normal fit, whose right tail is
    far heavier (at O = 45: -4.3 against -21.5).
    """

    pi: FloatArray  # (2,)
    P: FloatArray  # (2, 2), rows sum to 1
    mean: FloatArray  # (2,) of log O
    var: FloatArray  # (2,) of log O
    chi2_state0: bool = False  # state 0's O exactly chi^2_1 (mean[0], var[0] unused; Baum-Welch keeps it)

    def __post_init__(self) -> None:
        for name in ("pi", "P", "mean", "var"):
            object.__setattr__(self, name, np.asarray(getattr(self, name), dtype=float))
        object.__setattr__(self, "chi2_state0", bool(self.chi2_state0))


def log_observations(obs: FloatArray) -> FloatArray:
    """Y = log O with O floored at :data:`LOG_FLOOR` (NaN, a missing bin, stays NaN)."""
    return np.log(np.fmax(np.asarray(obs, dtype=float), LOG_FLOOR))


def log_emissions(y: FloatArray, params: HmmParams) -> FloatArray:
    """``(B, N, 2)`` log N(y; mean_i, var_i) of log-observations ``y`` ``(B, N)``; a missing (NaN) bin gives 0."""
    d = y[..., None] - params.mean
    out = -0.5 * (np.log(2.0 * np.pi * params.var) + d * d / params.var)
    if params.chi2_state0:
        with np.errstate(over="ignore"):
            out[..., 0] = 0.5 * (y - np.exp(y) - np.log(2.0 * np.pi))
    return np.where(np.isnan(out), 0.0, out)


def _log(x: FloatArray) -> FloatArray:
    with np.errstate(divide="ignore"):
        return np.log(x)


def forward_backward(log_b: FloatArray, pi: FloatArray, P: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Log-domain forward-backward on ``(B, N, 2)`` log emission densities (compiled; a missing bin has log_b = 0).

    Returns:
        log_alpha ``(B, N, 2)`` = log p(O_1..k, X_k = i), log_beta ``(B, N, 2)`` = log p(O_k+1..N | X_k = i),
        loglik ``(B,)`` = log p(O | lambda).
    """
    log_b = np.ascontiguousarray(log_b, dtype=float)
    return _forward_backward(log_b, _log(np.asarray(pi, dtype=float)), _log(np.asarray(P, dtype=float)))


@nb.njit(cache=True, nogil=True)
def _lse2(a: float, b: float) -> float:  # pragma: no cover - compiled
    m = max(a, b)
    if m == -np.inf:
        return -np.inf
    return m + np.log(np.exp(a - m) + np.exp(b - m))


@nb.njit(cache=True, nogil=True)
def _forward_backward(log_b, lpi, lP):  # pragma: no cover - compiled
    B, N, S = log_b.shape
    la = np.empty_like(log_b)
    lb = np.empty_like(log_b)
    ll = np.empty(B)
    for r in range(B):
        for i in range(S):
            la[r, 0, i] = lpi[i] + log_b[r, 0, i]
        for k in range(1, N):
            for j in range(S):
                la[r, k, j] = log_b[r, k, j] + _lse2(la[r, k - 1, 0] + lP[0, j], la[r, k - 1, 1] + lP[1, j])
        for i in range(S):
            lb[r, N - 1, i] = 0.0
        for k in range(N - 2, -1, -1):
            for i in range(S):
                lb[r, k, i] = _lse2(
                    lP[i, 0] + log_b[r, k + 1, 0] + lb[r, k + 1, 0], lP[i, 1] + log_b[r, k + 1, 1] + lb[r, k + 1, 1]
                )
        ll[r] = _lse2(la[r, N - 1, 0], la[r, N - 1, 1])
    return la, lb, ll


def posteriors(obs: FloatArray, params: HmmParams) -> tuple[FloatArray, FloatArray]:
    """Gamma ``(B, N, 2)`` = P(X_k = i | O, lambda) (eq. 9) and log p(O | lambda) ``(B,)`` (of log O, see module)."""
    log_b = log_emissions(log_observations(obs), params)
    la, lb, ll = forward_backward(log_b, params.pi, params.P)
    return np.exp(la + lb - ll[:, None, None]), ll


def changed_posterior(obs: FloatArray, params: HmmParams) -> FloatArray:
    """alpha_k = P(X_k = 1 | O, lambda) ``(B, N)`` (section 2.7's soft information)."""
    return posteriors(obs, params)[0][..., 1]


def hmm_delay(alpha: FloatArray) -> IntArray:
    """Eq. 12: the first bin with P(X_k = 1 | O) > 1/2, ``(B,)``; -1 where there is none."""
    above = np.asarray(alpha) > 0.5
    return np.where(above.any(axis=-1), np.argmax(above, axis=-1), -1)


def _lognormal_fit(y: FloatArray, w: FloatArray, var_floor: float) -> tuple[float, float]:
    sw = w.sum()
    m = float((w * y).sum() / sw)
    v = float((w * (y - m) ** 2).sum() / sw)
    return m, max(v, var_floor)


def supervised_params(obs: FloatArray, k_star: IntArray, eps: float = 0.01, var_floor: float = 1e-3) -> HmmParams:
    """Initial lambda from a training room with known k_* (eqs. 6-7; Rabiner 40a-b with the states known).

    ``obs`` ``(B, N)``; ``k_star`` ``(B,)`` (a sequence in state 1 from bin k_*; k_* >= N: never changed).
    """
    obs = np.asarray(obs, dtype=float)
    N = obs.shape[1]
    k = np.arange(N)
    state = (k >= np.asarray(k_star)[:, None]).astype(int)  # (B, N)
    y = log_observations(obs)
    pi1 = float(state[:, 0].mean())
    pi = np.array([1.0 - pi1, pi1])
    n00 = float(np.sum((state[:, :-1] == 0) & (state[:, 1:] == 0)))
    n01 = float(np.sum((state[:, :-1] == 0) & (state[:, 1:] == 1)))
    p01 = n01 / max(n00 + n01, 1.0)
    P = np.array([[1.0 - p01, p01], [eps, 1.0 - eps]])
    fits = [_lognormal_fit(y, (state == i).astype(float), var_floor) for i in (0, 1)]
    return HmmParams(pi, P, np.array([f[0] for f in fits]), np.array([f[1] for f in fits]))


def single_capture_params(
    p01: float, p10: float, change_log_mean: float, change_log_var: float, chi2_state0: bool = True
) -> HmmParams:
    """The lambda of :func:`single_capture_observations`: state 0 the chi^2_1 statistic's log-normal fit, state 1 given.

    pi = (1 - p01, p01): the first bin is a change with the per-bin change probability. ``chi2_state0``: state 0
    the exact chi^2_1 (default) rather than its log-normal fit (:data:`CHI2_1_LOG_MEAN`, :data:`CHI2_1_LOG_VAR`).
    """
    return HmmParams(
        [1.0 - p01, p01],
        [[1.0 - p01, p01], [p10, 1.0 - p10]],
        [CHI2_1_LOG_MEAN, change_log_mean],
        [CHI2_1_LOG_VAR, change_log_var],
        chi2_state0,
    )


@dataclasses.dataclass(frozen=True)
class BaumWelchResult:
    """Parameters after every iteration (``params[0]`` the initial lambda) and the total log-likelihood of each."""

    params: list[HmmParams]
    loglik: FloatArray  # (n_iter + 1,), log p(O | params[n]) summed over sequences

    @property
    def final(self) -> HmmParams:
        """The last parameters."""
        return self.params[-1]


def baum_welch(
    obs: FloatArray,
    init: HmmParams,
    n_iter: int = 15,
    tol: float | None = None,
    emission: str = "soft",
    var_floor: float = 1e-3,
    prob_floor: float = 0.0,
    fix_p10: float | None = None,
    fix_pi: bool = False,
) -> BaumWelchResult:
    """Baum-Welch re-estimation of lambda on sequences ``obs`` ``(B, N)`` sharing it (Rabiner, eqs. 40a-c, 109-110).

    ``emission``: "soft" (posterior-weighted log-normal fit, the exact M-step) or "hard" (the seed's eq. 11 split
    on X_hat_k = argmax_i gamma_k(i)). Stops after ``n_iter`` iterations or when the log-likelihood rises by less
    than ``tol``. ``prob_floor`` keeps pi and P away from 0 (0: none; a floor makes the M-step inexact).
    ``fix_p10``: hold P_10 = eps (and P_11 = 1 - eps) fixed, the seed's single-change model (section 2.4); the
    M-step over the remaining parameters is still exact (row 0 of P is re-estimated on its own), so the likelihood
    still never decreases. None: re-estimate P_10 as well. ``fix_pi``: hold pi at the initial lambda's (the M-step
    over the rest is still exact).
    """
    if emission not in ("soft", "hard"):
        raise ValueError(f"emission={emission!r}: 'soft' or 'hard'")
    y = log_observations(obs)
    params = [init]
    lls = []
    p = init
    for it in range(n_iter + 1):
        log_b = log_emissions(y, p)
        la, lb, ll = forward_backward(log_b, p.pi, p.P)
        lls.append(float(ll.sum()))
        if it == n_iter or (tol is not None and it > 0 and lls[-1] - lls[-2] < tol):
            break
        gamma = np.exp(la + lb - ll[:, None, None])  # (B, N, 2)
        # xi_k(i, j) summed over k and sequences
        lxi = la[:, :-1, :, None] + _log(p.P) + (log_b[:, 1:] + lb[:, 1:])[:, :, None, :] - ll[:, None, None, None]
        xi = np.exp(lxi).sum(axis=(0, 1))  # (2, 2)
        pi = p.pi.copy() if fix_pi else gamma[:, 0].mean(axis=0)
        P = xi / xi.sum(axis=1, keepdims=True)
        if fix_p10 is not None:
            P[1] = (fix_p10, 1.0 - fix_p10)
        if prob_floor > 0:
            pi = np.maximum(pi, prob_floor)
            pi /= pi.sum()
            P = np.maximum(P, prob_floor)
            P /= P.sum(axis=1, keepdims=True)
        if emission == "soft":
            w = gamma
        else:
            hard = np.argmax(gamma, axis=-1)
            w = np.stack([hard == 0, hard == 1], axis=-1).astype(float)
        mean, var = p.mean.copy(), p.var.copy()
        for i in (1,) if p.chi2_state0 else (0, 1):
            if w[..., i].sum() > 1e-9:
                mean[i], var[i] = _lognormal_fit(np.nan_to_num(y), w[..., i] * ~np.isnan(y), var_floor)
        p = HmmParams(pi, P, mean, var, p.chi2_state0)
        params.append(p)
    return BaumWelchResult(params[: len(lls)], np.array(lls))


# ---------------------------------------------------------------------------------------------------- baselines
def first_crossing(obs: FloatArray, thresholds: FloatArray) -> IntArray:
    """Eq. 13 for every threshold: ``(G, B)`` first k with O_k > gamma_g; -1 where none."""
    above = np.asarray(obs)[None] > np.asarray(thresholds, dtype=float)[:, None, None]  # (G, B, N)
    return np.where(above.any(axis=-1), np.argmax(above, axis=-1), -1)


def delay_errors(k_hat: IntArray, k_true: IntArray, n_bins: int, bin_ns: float = 1.0) -> FloatArray:
    """Eps = T (k_hat - k_*) [ns]; a missed detection (k_hat = -1) is scored as k_hat = n_bins (the window's end)."""
    k_hat = np.asarray(k_hat)
    return bin_ns * (np.where(k_hat < 0, n_bins, k_hat) - np.asarray(k_true))


def rmse(errors: FloatArray, axis: int = -1) -> FloatArray:
    """Root mean square along ``axis``."""
    return np.sqrt(np.mean(np.square(errors), axis=axis))


def ftc_rmse_curve(obs: FloatArray, k_true: IntArray, thresholds: FloatArray, bin_ns: float = 1.0) -> FloatArray:
    """``(G,)`` RMSE [ns] of first threshold crossing for every threshold (misses scored as in delay_errors)."""
    k_hat = first_crossing(obs, thresholds)
    return rmse(delay_errors(k_hat, k_true[None], np.shape(obs)[-1], bin_ns))


def zetik_delay(
    calibration: np.ndarray,
    test: np.ndarray,
    noise_samples: slice,
    bin_of_sample: IntArray,
    alpha: float,
) -> IntArray:
    """Zetik et al.'s threshold (eqs. 20-22) on complex CIR captures; the link's bin = median over its captures.

    Args:
        calibration: ``(B, n_cal, S)`` complex CIR samples of the empty room (the background starts at their mean);
        test: ``(B, n_test, S)`` captures under test, in time order;
        noise_samples: the samples before the direct path (noise only), where n^i = max |m^i| is taken;
        bin_of_sample: ``(S,)`` range bin of every sample (-1 before the first bin; such crossings count as bin 0);
        alpha: the background's forgetting factor.

    Returns:
        ``(B,)`` bins; -1 where no capture crosses (not possible: the maximum of |s| always exceeds 0.3 of itself
        plus 0.7 n unless n >= ||s||_inf).
    """
    b = calibration.mean(axis=1)  # (B, S)
    n_test = test.shape[1]
    ks = np.full((test.shape[0], n_test), -1, dtype=np.int64)
    for i in range(n_test):  # over captures (10), vectorised over links and samples
        m = test[:, i]
        b = alpha * b + (1.0 - alpha) * m
        s = np.abs(m - b)
        s_inf = s.max(axis=-1)
        n = np.abs(m[:, noise_samples]).max(axis=-1)
        t = 0.3 * s_inf + 0.7 * n
        above = s > t[:, None]
        first = np.argmax(above, axis=-1)
        ks[:, i] = np.where(above.any(axis=-1), np.maximum(bin_of_sample[first], 0), -1)
    with warnings.catch_warnings():  # a link without any crossing: all-nan row, median nan
        warnings.simplefilter("ignore", RuntimeWarning)
        med = np.nanmedian(np.where(ks >= 0, ks, np.nan), axis=1)
    return np.where(np.isfinite(med), np.round(np.nan_to_num(med)), -1).astype(np.int64)
