r"""Linear multitarget integrated PDA (LMIPDA) with IMM, seed 003 section 4.2.4 (Musicki and La Scala 2008).

For tracks t, models r and the measurements i of one receiver scan. Likelihoods are truncated to the gate,
p_i^{t,r} = N(nu; 0, S_i^{t,r}) / P_G inside it and 0 outside, and enter only through the likelihood ratios
lambda_i^{t,r} = p_i^{t,r} / rho_i against the clutter intensity rho_i (nothing can overflow or underflow):

    lambda_i^t = sum_r mu_r^t lambda_i^{t,r}                              (mixture over the predicted model probs)
    P_i^t      = P_D P_G psi^t lambda_i^t / sum_j lambda_j^t              (a priori: measurement i is track t's)
    Omega_i^t / rho_i = 1 + sum_{s != t} lambda_i^s P_i^s / (1 - P_i^s)   (LMIPDA: the other tracks as clutter)
    delta^t    = P_D P_G (1 - sum_i lambda_i^t rho_i / Omega_i^t)
    psi^t+     = (1 - delta^t) psi^t / (1 - delta^t psi^t)                 (existence update)
    delta^{t,r}= P_D P_G (1 - sum_i lambda_i^{t,r} rho_i / Omega_i^t)
    mu_r^t+    = mu_r^t (1 - delta^{t,r}) / (1 - delta^t)                   (model probabilities)
    beta_0^{t,r} = (1 - P_D P_G) / (1 - delta^{t,r}),   beta_i^{t,r} = P_D P_G lambda_i^{t,r} rho_i / Omega_i^t /
    (1 - delta^{t,r})                                                      (association, conditioned on existence)

The seed's printed versions drop the model weights in p_i^t and write beta_i with "1 - P_D P_G p_i"; the lines
above are the consistent forms (beta sums to 1 and sum_r mu_r (1 - delta^{t,r}) = 1 - delta^t; both tested).
IPDA is one track. PDA is existence fixed at 1 in the association (``fixed_existence=True``): every track claims
measurements as if it existed (P_i uses psi = 1); beta does not depend on psi anyway (it is conditioned on
existence), and psi is still updated, as the track-quality measure that confirmation and deletion need.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from uwb_env.config import TrackerConfig
from uwb_env.sensing.records import Detections
from uwb_env.tracking.kernels import gaussian_log_likelihood
from uwb_env.typing import BoolArray, FloatArray, IntArray


def lmipda(
    log_ratio: FloatArray,
    gated: BoolArray,
    mu: FloatArray,
    psi: FloatArray,
    pd: FloatArray,
    pg: float,
    fixed_existence: bool = False,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """One LMIPDA step.

    Args:
        log_ratio: ``(N, r, M)`` log(p_i^{t,r} / rho_i) with p the gate-truncated likelihood (ignored where not
            gated); gated: ``(N, r, M)``; mu: ``(N, r)`` predicted model probabilities (0 for inactive models);
        psi: ``(N,)`` predicted existence; pd: ``(N,)`` detection probability of each track; pg: gate probability.

    Returns:
        psi_post ``(N,)``, mu_post ``(N, r)``, beta ``(N, r, M + 1)`` (beta[..., 0] is "no measurement").
    """
    lam_tr = np.where(gated, np.exp(np.where(gated, log_ratio, 0.0)), 0.0)  # (N, r, M)
    lam_t = np.einsum("nr,nrm->nm", mu, lam_tr)  # (N, M)
    pdpg = pd * pg  # (N,)
    total = lam_t.sum(axis=-1, keepdims=True)
    psi_claim = np.ones_like(psi) if fixed_existence else psi
    P = np.where(total > 0, pdpg[:, None] * psi_claim[:, None] * lam_t / np.where(total > 0, total, 1.0), 0.0)
    P = np.minimum(P, 1.0 - 1e-12)  # numerical guard: P_i -> 1 only when P_D P_G psi -> 1
    odds = lam_t * P / (1.0 - P)  # (N, M): each track's claim on each measurement
    # (N, M): Omega_i^t / rho_i; the others' claims are summed first so a huge own claim cannot cancel the 1
    omega = 1.0 + np.maximum(odds.sum(axis=0, keepdims=True) - odds, 0.0)
    share_tr = lam_tr / omega[:, None, :]  # (N, r, M)
    delta_r = pdpg[:, None] * (1.0 - share_tr.sum(axis=-1))  # (N, r)
    delta = np.einsum("nr,nr->n", mu, delta_r)  # = P_D P_G (1 - sum_i lambda_i^t / omega), mu sums to 1
    one_minus = 1.0 - delta
    # <= 1 exactly (1 - delta psi - (1 - delta) psi = 1 - psi >= 0), but its rounding can exceed 1 by an ulp when
    # psi ~ 1 and delta < 0 (claims summing past 1): bounded at the exact value's bound, so 1 - psi stays >= 0
    psi_post = np.minimum(one_minus * psi / (1.0 - delta * psi), 1.0)
    mu_post = np.where(
        one_minus[:, None] > 0, mu * (1.0 - delta_r) / np.where(one_minus > 0, one_minus, 1.0)[:, None], mu
    )
    denom = 1.0 - delta_r
    ok = denom > 0
    safe = np.where(ok, denom, 1.0)
    beta0 = np.where(ok, (1.0 - pdpg[:, None]) / safe, 1.0)
    beta_i = np.where(ok[..., None], pdpg[:, None, None] * share_tr / safe[..., None], 0.0)
    return psi_post, mu_post, np.concatenate([beta0[..., None], beta_i], axis=-1)


def predict_existence(psi: FloatArray, p_survive: float, p_birth: float = 0.0) -> FloatArray:
    """Markov-chain existence prediction psi_k|k-1 = p11 psi + p21 (1 - psi) (seed 003 section 4.2.4)."""
    return p_survive * psi + p_birth * (1.0 - psi)


class Association(NamedTuple):
    """One pair's LMIPDA association over the (track, model, measurement) triples inside the gate.

    ``ti``, ``ri``, ``mi`` (K,) the triples; ``cols`` (J,) the measurements some track gates and ``j`` (K,) each
    triple's column in them; ``psi`` (N,), ``mu`` (N, r), ``beta`` (N, r, J + 1) :func:`lmipda`'s posteriors;
    ``owned`` (J,) P(some track exists and measurement ``cols`` is its) = sum_t psi_t+ sum_r mu_r+ beta_i^{t,r}.
    """

    ti: IntArray
    ri: IntArray
    mi: IntArray
    cols: IntArray
    j: IntArray
    psi: FloatArray
    mu: FloatArray
    beta: FloatArray
    owned: FloatArray


def associate(
    det: Detections,
    nu: FloatArray,
    S0: FloatArray,
    triples: tuple[IntArray, IntArray, IntArray],
    g2: float,
    mu: FloatArray,
    psi: FloatArray,
    pd: FloatArray,
    cfg: TrackerConfig,
) -> Association:
    """LMIPDA of one pair's detections from pre-gated innovations (``ambiguity.gated_innovations``).

    ``nu`` (N, r, M, m) and ``S0`` (N, r, m, m) the innovations and predicted measurement covariances, ``triples``
    the pre-gate's (track, model, measurement) indices, ``g2`` the chi-square gate; ``mu`` (N, r) the active models'
    probabilities, ``psi`` (N,) existence, ``pd`` (N,). The exact gate d^2 < g2, then the gate-truncated likelihood
    ratios against the clutter intensity floored at ``cfg.min_clutter_intensity`` (module docstring), over the gated
    measurements only (the others change no track's posteriors).
    """
    ti, ri, mi = triples
    loglik, d2 = gaussian_log_likelihood(nu[ti, ri, mi], S0[ti, ri] + det.R[mi])
    keep = d2 < g2
    ti, ri, mi, loglik = ti[keep], ri[keep], mi[keep], loglik[keep]
    cols, j = np.unique(mi, return_inverse=True)
    N, r = mu.shape
    rho = np.maximum(det.clutter_intensity[cols], cfg.min_clutter_intensity)
    log_ratio = np.zeros((N, r, cols.size))
    gated = np.zeros((N, r, cols.size), bool)
    log_ratio[ti, ri, j] = loglik - np.log(cfg.gate_probability) - np.log(rho[j])
    gated[ti, ri, j] = True
    psi_post, mu_post, beta = lmipda(log_ratio, gated, mu, psi, pd, cfg.gate_probability, cfg.fixed_existence)
    owned = np.einsum("n,nr,nrj->j", psi_post, mu_post, beta[:, :, 1:])
    return Association(ti, ri, mi, cols, j, psi_post, mu_post, beta, owned)
