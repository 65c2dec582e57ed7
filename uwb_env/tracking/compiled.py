r"""Compiled (numba) scan kernels of the tracker: the same equations as the numpy kernels, fused per scan.

The numpy kernels (``kernels``, ``imm``, ``lmipda``, ``initiation``) are the readable, tested reference; each
function here fuses a chain of them into one compiled call over (tracks x models x measurements), because at the
tracker's sizes (tens of tracks, 3-4 models, tens of detections) the cost of the numpy chain is call overhead,
not arithmetic. ``tests/unit/test_compiled.py`` checks every kernel against its reference to rounding error, and
the whole tracker with both back ends on the same detections.

    predict_models     IMM mixing (imm.imm_mix) + exact Kalman prediction (kernels.kf_predict)
    combine            moment matching (kernels.mixture_reduce / imm.imm_combine)
    receiver_update    predicted-measurement moments (UKF or EKF), pre-gate and ellipsoidal gate, gate-truncated
                       likelihood ratios, LMIPDA (lmipda.lmipda), Kalman updates in Joseph form
                       (kernels.joseph_update) and the PDA mixture reduction,
                       and which measurements some track owns (Tracker._update)
    fuse_candidates, two_point_pairs, range_azimuth_candidates   (initiation)

Measurement components are integer codes (:data:`KIND_CODES`); state ``[x, vx, y, vy, ax, ay]``.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from uwb_env.tracking.ambiguity import RESOLVED_STDS
from uwb_env.typing import FloatArray

KIND_CODES = {"bistatic_range": 0, "range_rate": 1, "azimuth": 2, "x": 3, "y": 4}
_RANGE_RATE = 1
_ANGULAR = 2
_NS = 6  # state dimension
_LOG_2PI = math.log(2.0 * math.pi)

_jit = nb.njit(cache=True, fastmath=False, nogil=True)


def kind_codes(names: tuple[str, ...]) -> np.ndarray:
    """``(m,)`` int64 codes of the named measurement components."""
    return np.array([KIND_CODES[n] for n in names], dtype=np.int64)


# ------------------------------------------------------------------------------------------- small dense algebra
@_jit
def _cholesky(A, L):  # pragma: no cover - compiled
    """Lower Cholesky factor of the SPD matrix A into L; False if A is not positive definite."""
    n = A.shape[0]
    for i in range(n):
        for j in range(i + 1):
            s = A[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            if i == j:
                if s <= 0.0:
                    return False
                L[i, i] = math.sqrt(s)
            else:
                L[i, j] = s / L[j, j]
        for j in range(i + 1, n):
            L[i, j] = 0.0
    return True


@_jit
def _chol_solve(L, B, X):  # pragma: no cover - compiled
    """X = (L L^T)^-1 B for B (n, k)."""
    n, k = B.shape
    for c in range(k):
        for i in range(n):
            s = B[i, c]
            for j in range(i):
                s -= L[i, j] * X[j, c]
            X[i, c] = s / L[i, i]
        for i in range(n - 1, -1, -1):
            s = X[i, c]
            for j in range(i + 1, n):
                s -= L[j, i] * X[j, c]
            X[i, c] = s / L[i, i]


@_jit
def _linearised_h(Pn, C, n, r, L, Cl, Y, H):  # pragma: no cover - compiled
    """H = C^T P^-1 ``(m, 6)`` into H (kernels.linearised_h) for P = ``Pn`` (6, 6), C = ``C[n, r]`` (6, m).

    L (6, 6), Cl, Y (6, m) are workspaces. False if P is not positive definite.
    """
    if not _cholesky(Pn, L):
        return False
    m = H.shape[0]
    for s in range(_NS):
        for c in range(m):
            Cl[s, c] = C[n, r, s, c]
    _chol_solve(L, Cl, Y)  # P^-1 C
    for c in range(m):
        for s in range(_NS):
            H[c, s] = Y[s, c]
    return True


@_jit
def _linearisation_error(S0, C, n, r, H, Om):  # pragma: no cover - compiled
    """Omega = S0 - H C ``(m, m)`` into Om (kernels.linearisation_error), symmetrised; 0 to rounding for the EKF.

    S0 = ``S0[n, r]``, C = ``C[n, r]``, H = C^T P^-1 from :func:`_linearised_h`.
    """
    m = H.shape[0]
    for c in range(m):
        for e in range(c + 1):
            hc, he = 0.0, 0.0
            for s in range(_NS):
                hc += H[c, s] * C[n, r, s, e]
                he += H[e, s] * C[n, r, s, c]
            v = 0.5 * ((S0[n, r, c, e] + S0[n, r, e, c]) - (hc + he))
            Om[c, e] = v
            Om[e, c] = v


@_jit
def _range_rate_column(kinds):  # pragma: no cover - compiled
    """The range-rate column of a measurement's ``kinds``, or -1."""
    for c in range(kinds.shape[0]):
        if kinds[c] == _RANGE_RATE:
            return c
    return -1


@_jit
def _folded_column(kinds, period):  # pragma: no cover - compiled
    """The range-rate column when it is folded (a finite period > 0), else -1."""
    if not (period > 0.0 and period < np.inf):
        return -1
    return _range_rate_column(kinds)


@_jit
def _marginalise_unresolved(S0, C, d, period):  # pragma: no cover - compiled
    """ambiguity.unresolved + ambiguity.marginalise in place on ``S0 (N, a, m, m)``, ``C (N, a, 6, m)``.

    Returns ``(N, a)`` True where the folded range-rate was marginalised (its std above period / RESOLVED_STDS).
    """
    N, a, m = S0.shape[0], S0.shape[1], S0.shape[2]
    blind = np.zeros((N, a), np.bool_)
    if d < 0:
        return blind
    thr = (period / RESOLVED_STDS) ** 2
    var = period * period / (2.0 * math.pi)
    for n in range(N):
        for r in range(a):
            if S0[n, r, d, d] > thr:
                blind[n, r] = True
                for c in range(m):
                    S0[n, r, d, c] = 0.0
                    S0[n, r, c, d] = 0.0
                S0[n, r, d, d] = var
                for s_ in range(_NS):
                    C[n, r, s_, d] = 0.0
    return blind


@_jit
def _wrap(v):  # pragma: no cover - compiled
    """Angle difference wrapped to [-pi, pi) (measurement.wrap_residual), without the float modulo."""
    if -math.pi <= v < math.pi:
        return v
    return v - 2.0 * math.pi * math.floor((v + math.pi) / (2.0 * math.pi))


@_jit
def _measure(X, k, kinds, tx, rx, Z, U, jac, want_jac):  # pragma: no cover - compiled
    """Measurement components of state row ``X[k]`` (6,) into ``Z[k]`` (m,), Jacobian into jac (m, 6) if asked.

    Rows are indexed rather than sliced: in compiled loops an array view costs more than the arithmetic. The
    azimuth is also returned as its unit vector ``U[k] = (cos, sin)`` (the UKF averages and differences angles
    through it, without trigonometric calls); ``Z[k]`` gets the azimuth itself only with the Jacobian (EKF).
    """
    dtx, dty = X[k, 0] - tx[0], X[k, 2] - tx[1]
    drx, dry = X[k, 0] - rx[0], X[k, 2] - rx[1]
    lt = max(math.sqrt(dtx * dtx + dty * dty), 1e-9)
    lr = max(math.sqrt(drx * drx + dry * dry), 1e-9)
    utx, uty, urx, ury = dtx / lt, dty / lt, drx / lr, dry / lr
    vx, vy = X[k, 1], X[k, 3]
    for c in range(kinds.shape[0]):
        kind = kinds[c]
        if want_jac:
            for s in range(_NS):
                jac[c, s] = 0.0
        if kind == 0:
            Z[k, c] = lt + lr
            if want_jac:
                jac[c, 0] = utx + urx
                jac[c, 2] = uty + ury
        elif kind == 1:
            ut_v, ur_v = utx * vx + uty * vy, urx * vx + ury * vy
            Z[k, c] = ut_v + ur_v
            if want_jac:  # (I - u u^T) v / |d| per leg, and u_t + u_r
                jac[c, 0] = (vx - utx * ut_v) / lt + (vx - urx * ur_v) / lr
                jac[c, 2] = (vy - uty * ut_v) / lt + (vy - ury * ur_v) / lr
                jac[c, 1] = utx + urx
                jac[c, 3] = uty + ury
        elif kind == 2:
            U[k, 0] = urx
            U[k, 1] = ury
            if want_jac:
                Z[k, c] = math.atan2(dry, drx)
                jac[c, 0] = -ury / lr
                jac[c, 2] = urx / lr
        elif kind == 3:
            Z[k, c] = X[k, 0]
            if want_jac:
                jac[c, 0] = 1.0
        else:
            Z[k, c] = X[k, 2]
            if want_jac:
                jac[c, 2] = 1.0


# ---------------------------------------------------------------------------------------------------- IMM steps
@_jit
def predict_models(mu, Pi, x, P, F, Q, act):  # pragma: no cover - compiled
    """IMM mixing then Kalman prediction of the models ``act`` (imm.imm_mix + kernels.kf_predict), in place.

    Args: mu ``(N, r)``; Pi ``(a, a)`` the transition matrix on the active set ``act`` ``(a,)`` (rows "from");
    x ``(N, r, 6)``; P ``(N, r, 6, 6)``; F, Q ``(a, 6, 6)``. x, P and mu (normalised cbar) of the active models
    are overwritten with the predicted ones.
    """
    N, a = mu.shape[0], act.shape[0]
    cbar = np.zeros(a)
    x0 = np.empty((a, _NS))
    P0 = np.empty((a, _NS, _NS))
    FP = np.empty((_NS, _NS))
    for n in range(N):
        for j in range(a):
            cb = 0.0
            for i in range(a):
                cb += Pi[i, j] * mu[n, act[i]]
            cbar[j] = cb
            if cb > 0.0:
                for s in range(_NS):
                    acc = 0.0
                    for i in range(a):
                        acc += Pi[i, j] * mu[n, act[i]] / cb * x[n, act[i], s]
                    x0[j, s] = acc
                for s in range(_NS):
                    for t in range(_NS):
                        P0[j, s, t] = 0.0
                for i in range(a):
                    w = Pi[i, j] * mu[n, act[i]] / cb
                    for s in range(_NS):
                        ds = x[n, act[i], s] - x0[j, s]
                        for t in range(_NS):
                            P0[j, s, t] += w * (P[n, act[i], s, t] + ds * (x[n, act[i], t] - x0[j, t]))
            else:  # a model nobody moves to keeps its own estimate
                for s in range(_NS):
                    x0[j, s] = x[n, act[j], s]
                    for t in range(_NS):
                        P0[j, s, t] = P[n, act[j], s, t]
        total = 0.0
        for j in range(a):
            total += cbar[j]
        for j in range(a):
            k = act[j]
            mu[n, k] = cbar[j] / total
            for s in range(_NS):
                acc = 0.0
                for t in range(_NS):
                    acc += F[j, s, t] * x0[j, t]
                x[n, k, s] = acc
            for s in range(_NS):
                for t in range(_NS):
                    acc = 0.0
                    for u in range(_NS):
                        acc += F[j, s, u] * P0[j, u, t]
                    FP[s, t] = acc
            for s in range(_NS):  # lower triangle; symmetric by construction
                for t in range(s + 1):
                    acc = 0.0
                    for u in range(_NS):
                        acc += FP[s, u] * F[j, t, u]
                    acc += 0.5 * (Q[j, s, t] + Q[j, t, s])
                    P[n, k, s, t] = acc
                    P[n, k, t, s] = acc


@_jit
def combine(w, x, P):  # pragma: no cover - compiled
    """Moment-matched mixture over axis 1: w ``(N, J)``, x ``(N, J, 6)``, P ``(N, J, 6, 6)``.

    Returns ``(N, 6)``, ``(N, 6, 6)`` (kernels.mixture_reduce).
    """
    N, J = w.shape
    xb = np.zeros((N, _NS))
    Pb = np.zeros((N, _NS, _NS))
    for n in range(N):
        for j in range(J):
            for s in range(_NS):
                xb[n, s] += w[n, j] * x[n, j, s]
        for j in range(J):
            wj = w[n, j]
            if wj == 0.0:
                continue
            for s in range(_NS):
                ds = x[n, j, s] - xb[n, s]
                for t in range(s + 1):
                    Pb[n, s, t] += wj * (P[n, j, s, t] + ds * (x[n, j, t] - xb[n, t]))
        for s in range(_NS):
            for t in range(s):
                Pb[n, t, s] = Pb[n, s, t]
    return xb, Pb


# ------------------------------------------------------------------------------------------- receiver update
@_jit
def measurement_moments(x, P, act, kinds, tx, rx, wm, wc, sigma_scale, use_ukf):  # pragma: no cover - compiled
    """Predicted-measurement moments of every track and active model (kernels.ukf_moments / ekf_moments).

    Args: x ``(N, r, 6)``, P ``(N, r, 6, 6)``, act ``(a,)`` the models to use; kinds ``(m,)``; tx, rx ``(2,)``;
    wm, wc ``(13,)``, sigma_scale; use_ukf (else EKF).

    Returns: z_hat ``(N, a, m)``, S0 ``(N, a, m, m)`` (without R), C ``(N, a, 6, m)`` the state-measurement
    cross-covariance, ok (False if some P was not positive definite; its entries are left at 0).
    """
    N, a = x.shape[0], act.shape[0]
    m = kinds.shape[0]
    n_sig = 2 * _NS + 1
    ok = True
    z_hat = np.zeros((N, a, m))
    S0 = np.zeros((N, a, m, m))
    C = np.zeros((N, a, _NS, m))
    L = np.zeros((_NS, _NS))
    chi = np.empty((n_sig, _NS))
    Z = np.empty((n_sig, m))
    U = np.zeros((n_sig, 2))
    jac = np.zeros((m, _NS))
    az = -1  # the azimuth component, if any (at most one)
    for c in range(m):
        if kinds[c] == _ANGULAR:
            az = c
    xl = np.empty((1, _NS))
    Pl = np.empty((_NS, _NS))
    for n in range(N):
        for r in range(a):
            for s_ in range(_NS):
                xl[0, s_] = x[n, act[r], s_]
                for t in range(_NS):
                    Pl[s_, t] = P[n, act[r], s_, t]
            if not _cholesky(Pl, L):
                ok = False
                continue
            if use_ukf:
                for k in range(n_sig):
                    for s_ in range(_NS):
                        chi[k, s_] = xl[0, s_]
                for s_ in range(_NS):
                    for c in range(_NS):
                        d = sigma_scale * L[s_, c]  # column c of L is sigma direction c
                        chi[1 + c, s_] += d
                        chi[1 + _NS + c, s_] -= d
                for k in range(n_sig):
                    _measure(chi, k, kinds, tx, rx, Z, U, jac, False)
                for c in range(m):
                    acc = 0.0
                    for k in range(n_sig):
                        acc += wm[k] * Z[k, c]
                    z_hat[n, r, c] = acc
                if az >= 0:  # circular mean, and differences wrapped to (-pi, pi] through unit vectors
                    sn, cs = 0.0, 0.0
                    for k in range(n_sig):
                        cs += wm[k] * U[k, 0]
                        sn += wm[k] * U[k, 1]
                    z_hat[n, r, az] = math.atan2(sn, cs)
                    norm = math.sqrt(cs * cs + sn * sn)
                    ux, uy = cs / norm, sn / norm
                    for k in range(n_sig):
                        Z[k, az] = math.atan2(ux * U[k, 1] - uy * U[k, 0], ux * U[k, 0] + uy * U[k, 1])
                for k in range(n_sig):
                    for c in range(m):
                        if c != az:
                            Z[k, c] -= z_hat[n, r, c]
                for c in range(m):
                    for e in range(c + 1):
                        acc = 0.0
                        for k in range(n_sig):
                            acc += Z[k, c] * wc[k] * Z[k, e]
                        S0[n, r, c, e] = acc
                        S0[n, r, e, c] = acc
                    for s_ in range(_NS):
                        acc = 0.0
                        for k in range(n_sig):
                            acc += (chi[k, s_] - xl[0, s_]) * wc[k] * Z[k, c]
                        C[n, r, s_, c] = acc
            else:
                _measure(xl, 0, kinds, tx, rx, Z, U, jac, True)
                for c in range(m):
                    z_hat[n, r, c] = Z[0, c]
                for s_ in range(_NS):
                    for c in range(m):
                        acc = 0.0
                        for t in range(_NS):
                            acc += Pl[s_, t] * jac[c, t]
                        C[n, r, s_, c] = acc
                for c in range(m):
                    for e in range(c + 1):
                        acc = 0.0
                        for s_ in range(_NS):
                            acc += jac[c, s_] * C[n, r, s_, e]
                        S0[n, r, c, e] = acc
                        S0[n, r, e, c] = acc
    return z_hat, S0, C, ok


@nb.njit(cache=True, fastmath=False, nogil=True, inline="always")
def _small_mahalanobis(S0, R, nu, n, r, i, m):  # pragma: no cover - compiled
    """``(nu^T S^-1 nu, det S)`` for S = S0[n, r] + R[i] of size m <= 3, by cofactors.

    det S is returned as 0 when S is not positive definite (a non-positive leading minor, Sylvester's criterion).
    """
    a = S0[n, r, 0, 0] + R[i, 0, 0]
    v0 = nu[n, r, i, 0]
    if m == 1:
        return (v0 * v0 / a, a) if a > 0.0 else (0.0, 0.0)
    b = S0[n, r, 0, 1] + R[i, 0, 1]
    d = S0[n, r, 1, 1] + R[i, 1, 1]
    v1 = nu[n, r, i, 1]
    if m == 2:
        det = a * d - b * b
        if not (a > 0.0 and det > 0.0):
            return 0.0, 0.0
        return (d * v0 * v0 - 2.0 * b * v0 * v1 + a * v1 * v1) / det, det
    c = S0[n, r, 0, 2] + R[i, 0, 2]
    e = S0[n, r, 1, 2] + R[i, 1, 2]
    f = S0[n, r, 2, 2] + R[i, 2, 2]
    v2 = nu[n, r, i, 2]
    c11, c12, c13 = d * f - e * e, c * e - b * f, b * e - c * d
    c22, c23, c33 = a * f - c * c, b * c - a * e, a * d - b * b
    det = a * c11 + b * c12 + c * c13
    if not (a > 0.0 and c33 > 0.0 and det > 0.0):
        return 0.0, 0.0
    q = c11 * v0 * v0 + c22 * v1 * v1 + c33 * v2 * v2 + 2.0 * (c12 * v0 * v1 + c13 * v0 * v2 + c23 * v1 * v2)
    return q / det, det


@_jit
def receiver_update(
    x, P, mu, act, psi, pd, z, R, rho, kinds, tx, rx, wm, wc, sigma_scale, use_ukf, g2, pg, fixed_existence,
    period,
):  # pragma: no cover - compiled  # fmt: skip
    """LMIPDA + PDA update of every track with one pair's detections (Tracker._update, numpy reference).

    Args:
        x ``(N, r, 6)``, P ``(N, r, 6, 6)``, mu ``(N, r)``: updated in place for the models ``act`` ``(a,)``
        (the active set); psi, pd ``(N,)``;
        z ``(M, m)``, R ``(M, m, m)``, rho ``(M,)`` clutter intensities (floored); kinds ``(m,)`` codes;
        tx, rx ``(2,)``; wm, wc ``(13,)`` unscented weights, sigma_scale = sqrt(n + lambda); use_ukf (else EKF);
        g2 chi-square gate; pg gate probability; fixed_existence (PDA); period: the range-rate's period [m/s]
        (inf: unambiguous), unwrapped or marginalised per track and model as tracking.ambiguity says.

    Returns:
        psi_post ``(N,)``, taken ``(M,)`` (owned with p > 1/2) -- x, P, mu are updated in place --
        ok: False if some covariance was not positive definite (the caller raises).
    """
    N, a = mu.shape[0], act.shape[0]
    M, m = z.shape
    z_hat, S0, C, ok = measurement_moments(x, P, act, kinds, tx, rx, wm, wc, sigma_scale, use_ukf)
    fold_col = _folded_column(kinds, period)
    blind = _marginalise_unresolved(S0, C, fold_col, period)

    # gating and gate-truncated likelihood ratios
    lam = np.zeros((N, a, M))
    gated = np.zeros((N, a, M), np.bool_)
    n_gated = np.zeros((N, a), np.int64)
    nu = np.zeros((N, a, M, m))
    Sm = np.empty((m, m))
    Ls = np.zeros((m, m))
    y = np.empty(m)
    log_pg = math.log(pg)
    log_rho = np.log(rho)
    for n in range(N):
        for r in range(a):
            for i in range(M):
                inside = True
                for c in range(m):  # exact pre-gate: nu^T S^-1 nu >= nu_c^2 / S_cc; the range fails first
                    d = z[i, c] - z_hat[n, r, c]
                    if kinds[c] == _ANGULAR:
                        d = _wrap(d)
                    elif c == fold_col:  # the alias nearest the prediction, or nothing when unresolved
                        d = 0.0 if blind[n, r] else d - period * math.floor(d / period + 0.5)
                    nu[n, r, i, c] = d
                    if d * d > g2 * (S0[n, r, c, c] + R[i, c, c]):
                        inside = False
                        break
                if not inside:
                    continue
                if m <= 3:  # closed forms: the gate test runs for every pre-gated pair, most of them outside
                    d2, det_s = _small_mahalanobis(S0, R, nu, n, r, i, m)
                    if not det_s > 0.0:
                        ok = False
                        continue
                else:
                    for c in range(m):
                        for e in range(m):
                            Sm[c, e] = S0[n, r, c, e] + R[i, c, e]
                    if not _cholesky(Sm, Ls):
                        ok = False
                        continue
                    d2, det_s = 0.0, 1.0
                    for c in range(m):
                        s = nu[n, r, i, c]
                        for e in range(c):
                            s -= Ls[c, e] * y[e]
                        y[c] = s / Ls[c, c]
                        d2 += y[c] * y[c]
                        det_s *= Ls[c, c] * Ls[c, c]
                if d2 < g2:
                    logdet = math.log(det_s)
                    gated[n, r, i] = True
                    n_gated[n, r] += 1
                    loglik = -0.5 * (d2 + logdet + m * _LOG_2PI)
                    lam[n, r, i] = math.exp(loglik - log_pg - log_rho[i])

    # LMIPDA (lmipda.lmipda)
    lam_t = np.zeros((N, M))
    for n in range(N):
        for r in range(a):
            for i in range(M):
                lam_t[n, i] += mu[n, act[r]] * lam[n, r, i]
    odds = np.zeros((N, M))
    for n in range(N):
        total = 0.0
        for i in range(M):
            total += lam_t[n, i]
        claim = pd[n] * pg * (1.0 if fixed_existence else psi[n])
        for i in range(M):
            p_i = claim * lam_t[n, i] / total if total > 0.0 else 0.0
            p_i = min(p_i, 1.0 - 1e-12)
            odds[n, i] = lam_t[n, i] * p_i / (1.0 - p_i)
    odds_sum = np.zeros(M)
    for n in range(N):
        for i in range(M):
            odds_sum[i] += odds[n, i]
    psi_post = np.empty(N)
    mu_post = np.empty((N, a))
    beta = np.zeros((N, a, M + 1))
    for n in range(N):
        pdpg = pd[n] * pg
        delta = 0.0
        for r in range(a):
            share = 0.0
            for i in range(M):
                if gated[n, r, i]:
                    omega = 1.0 + max(odds_sum[i] - odds[n, i], 0.0)
                    beta[n, r, i + 1] = lam[n, r, i] / omega
                    share += beta[n, r, i + 1]
            delta_r = pdpg * (1.0 - share)
            delta += mu[n, act[r]] * delta_r
            denom = 1.0 - delta_r
            if denom > 0.0:
                beta[n, r, 0] = (1.0 - pdpg) / denom
                for i in range(M):
                    beta[n, r, i + 1] *= pdpg / denom
            else:
                beta[n, r, 0] = 1.0
                for i in range(M):
                    beta[n, r, i + 1] = 0.0
            mu_post[n, r] = denom  # 1 - delta_r, normalised below
        one_minus = 1.0 - delta
        psi_post[n] = min(one_minus * psi[n] / (1.0 - delta * psi[n]), 1.0)  # <= 1 exactly; its rounding: lmipda.py
        for r in range(a):
            mu_post[n, r] = mu[n, act[r]] * mu_post[n, r] / one_minus if one_minus > 0.0 else mu[n, act[r]]

    # PDA: Gaussian-mixture reduction of {no update, Kalman update with each gated measurement}; each update is
    # kernels.joseph_update: (I - K H) P (I - K H)^T + K (R_i + Omega) K^T = P - K S_i K^T
    xs = np.empty((M + 1, _NS))
    Ps = np.empty((M + 1, _NS, _NS))
    K = np.empty((_NS, m))
    A = np.empty((_NS, _NS))
    AP = np.empty((_NS, _NS))
    KR = np.empty((_NS, m))
    Ct = np.empty((m, _NS))
    Kt = np.empty((m, _NS))
    used = np.zeros(M + 1, np.bool_)
    H = np.empty((m, _NS))
    Om = np.empty((m, m))
    Cl = np.empty((_NS, m))
    Pl = np.empty((_NS, _NS))
    L = np.zeros((_NS, _NS))
    Y = np.empty((_NS, m))
    xb = np.empty(_NS)
    Pb = np.empty((_NS, _NS))
    for n in range(N):
        for r in range(a):
            if n_gated[n, r] == 0:  # beta_0 = 1: the prediction stands
                continue
            used[:] = False
            used[0] = True
            have_h = False
            for s_ in range(_NS):
                xs[0, s_] = x[n, act[r], s_]
                for t in range(_NS):
                    Ps[0, s_, t] = Pl[s_, t] = P[n, act[r], s_, t]
            for i in range(M):
                if not gated[n, r, i]:
                    continue
                if not have_h:  # once per track and model that gates something
                    _linearised_h(Pl, C, n, r, L, Cl, Y, H)
                    _linearisation_error(S0, C, n, r, H, Om)
                    have_h = True
                used[i + 1] = True
                for c in range(m):
                    for e in range(m):
                        Sm[c, e] = S0[n, r, c, e] + R[i, c, e]
                _cholesky(Sm, Ls)
                for s in range(_NS):
                    for c in range(m):
                        Ct[c, s] = C[n, r, s, c]
                _chol_solve(Ls, Ct, Kt)  # K^T = S^-1 C^T
                for s in range(_NS):
                    acc = xs[0, s]
                    for c in range(m):
                        K[s, c] = Kt[c, s]
                        acc += Kt[c, s] * nu[n, r, i, c]
                    xs[i + 1, s] = acc
                for s in range(_NS):
                    for t in range(_NS):
                        acc = 1.0 if s == t else 0.0
                        for c in range(m):
                            acc -= K[s, c] * H[c, t]
                        A[s, t] = acc
                for s in range(_NS):
                    for t in range(_NS):
                        acc = 0.0
                        for u in range(_NS):
                            acc += A[s, u] * Ps[0, u, t]
                        AP[s, t] = acc
                for s in range(_NS):
                    for c in range(m):
                        acc = 0.0
                        for e in range(m):
                            acc += K[s, e] * (R[i, e, c] + Om[e, c])
                        KR[s, c] = acc
                for s in range(_NS):
                    for t in range(s + 1):
                        acc = 0.0
                        for u in range(_NS):
                            acc += AP[s, u] * A[t, u]
                        for c in range(m):
                            acc += KR[s, c] * K[t, c]
                        Ps[i + 1, s, t] = acc
                for s in range(_NS):  # lower triangle computed; symmetric by construction
                    for t in range(s):
                        Ps[i + 1, t, s] = Ps[i + 1, s, t]
            xb[:] = 0.0
            for j in range(M + 1):
                if used[j]:
                    for s in range(_NS):
                        xb[s] += beta[n, r, j] * xs[j, s]
            Pb[:, :] = 0.0
            for j in range(M + 1):
                if used[j]:
                    w = beta[n, r, j]
                    for s in range(_NS):
                        ds = xs[j, s] - xb[s]
                        for t in range(s + 1):
                            Pb[s, t] += w * (Ps[j, s, t] + ds * (xs[j, t] - xb[t]))
            for s in range(_NS):
                x[n, act[r], s] = xb[s]
                for t in range(s + 1):
                    P[n, act[r], s, t] = Pb[s, t]
                    P[n, act[r], t, s] = Pb[s, t]

    # a measurement is taken when it belongs to some track with probability > 1/2
    taken = np.zeros(M, np.bool_)
    for i in range(M):
        owned = 0.0
        for n in range(N):
            for r in range(a):
                owned += psi_post[n] * mu_post[n, r] * beta[n, r, i + 1]
        taken[i] = owned > 0.5
    for n in range(N):
        for r in range(a):
            mu[n, act[r]] = mu_post[n, r]
    return psi_post, taken, ok


@_jit
def receiver_update_batch(
    x, P, mu, active, track_start, envs, psi, pd, z, R, rho, det_start, kinds, tx, rx, wm, wc, sigma_scale, use_ukf,
    g2, pg, fixed_existence, periods,
):  # pragma: no cover - compiled  # fmt: skip
    """``receiver_update`` of one pair for several independent environments, in one call (batched vector env).

    The environments' tracks are concatenated: env e owns rows ``track_start[e]:track_start[e + 1]`` of x
    ``(N, r, 6)``, P, mu ``(N, r)``, active ``(N, r)`` (its model set: every track of an env shares it), psi and
    pd ``(N,)``. The pair's detections of the environments ``envs`` ``(E,)`` are concatenated too: the j-th's are
    rows ``det_start[j]:det_start[j + 1]`` of z ``(M, m)``, R, rho, with its range-rate period ``periods[j]``.
    Each environment is updated exactly as ``receiver_update`` would on its own (LMIPDA couples tracks within an
    environment only); x, P, mu and psi are updated in place.

    Returns: taken ``(M,)`` and ok (False if some covariance was not positive definite).
    """
    taken = np.zeros(z.shape[0], np.bool_)
    ok = True
    for j in range(envs.shape[0]):
        e = envs[j]
        a0, a1 = track_start[e], track_start[e + 1]
        d0, d1 = det_start[j], det_start[j + 1]
        act = np.flatnonzero(active[a0])
        psi_e, taken_e, ok_e = receiver_update(
            x[a0:a1], P[a0:a1], mu[a0:a1], act, psi[a0:a1], pd[a0:a1], z[d0:d1], R[d0:d1], rho[d0:d1], kinds,
            tx, rx, wm, wc, sigma_scale, use_ukf, g2, pg, fixed_existence, periods[j],
        )  # fmt: skip
        psi[a0:a1] = psi_e
        taken[d0:d1] = taken_e
        ok = ok and ok_e
    return taken, ok


# ------------------------------------------------------------------------------------------------- initiation
@_jit
def _read_table(table, grid, pd, log_lam):  # pragma: no cover - compiled
    """Bilinear read of a q_2 table at (pd, log(1 + lambda)), edges held (reduction.interpolate).

    grid = (first P_D, P_D step, log(1 + lambda) step) of the table (reduction.table_grid).
    """
    n_p, n_l = table.shape
    fi = min(max((pd - grid[0]) / grid[1], 0.0), n_p - 1.0)
    fj = min(max(log_lam / grid[2], 0.0), n_l - 1.0)
    i0 = min(int(fi), n_p - 2)
    j0 = min(int(fj), n_l - 2)
    a, b = fi - i0, fj - j0
    return (
        (1 - a) * (1 - b) * table[i0, j0]
        + a * (1 - b) * table[i0 + 1, j0]
        + (1 - a) * b * table[i0, j0 + 1]
        + a * b * table[i0 + 1, j0 + 1]
    )


@_jit
def read_table(table, grid, pd, log_lam):  # pragma: no cover - compiled
    """``_read_table`` at every (pd[k], log_lam[k]) of two ``(K,)`` arrays (reduction.interpolate)."""
    out = np.empty(pd.shape[0])
    for k in range(pd.shape[0]):
        out[k] = _read_table(table, grid, pd[k], log_lam[k])
    return out


@_jit
def expected_update(
    Pa, x, P, kinds, tx, rx, wm, wc, sigma_scale, use_ukf, R, pd, q2, rho, table, grid, gate_volume, period
):  # pragma: no cover - compiled
    """Expected PDA posterior covariances of the lookahead (lookahead.expected_posterior), one pair, in place.

    Args:
        Pa ``(A, N, 6, 6)``: every plan's covariances so far, updated in place;
        x ``(N, 6)``, P ``(N, 6, 6)``: the predicted combined estimates, where H = C^T P^-1 is linearised
        (measurement_moments, kernels.linearised_h); kinds, tx, rx, wm, wc, sigma_scale, use_ukf as there;
        R ``(A, N, m, m)`` the plans' measurement covariances; pd ``(A, N)`` detection probabilities (0: no
        update); q2: the information-reduction factor, a constant unless ``table`` (tracking.reduction, shape
        ``(len(PD_GRID), len(LOG_LAMBDA_GRID))``, on ``grid``) is non-empty: then q_2(P_D, lambda_G) with the
        expected false measurements in the gate lambda_G = rho gate_volume |S|^(1/2), rho ``(A, N)`` the clutter
        density at the predicted measurement and gate_volume = c_m gamma^(m/2); period ``(A,)`` the range-rate
        period of each plan's waveform [m/s] (inf: unambiguous): where the prediction does not resolve it
        (tracking.ambiguity), the plan's range-rate brings no information (its row of H is zero).

    Per (a, n): S = H Pa H^T + Omega + R, K = Pa H^T S^-1, Pa <- sym(Pa - q_2 P_D K S K^T) (K S K^T =
    K (Pa H^T)^T), with the linearisation error Omega = S0 - H P H^T at the prediction (kernels.linearisation_error;
    0 for the EKF): where Pa = P this is the filter's own update, S = S0 + R and K = C S^-1.
    Returns ok (False if some P or S was not positive definite).
    """
    A, N = Pa.shape[0], Pa.shape[1]
    m = kinds.shape[0]
    _, S0, C, ok = measurement_moments(
        x.reshape(N, 1, _NS),
        P.reshape(N, 1, _NS, _NS),
        np.zeros(1, np.int64),
        kinds,
        tx,
        rx,
        wm,
        wc,
        sigma_scale,
        use_ukf,
    )
    L = np.zeros((_NS, _NS))
    Ls = np.zeros((m, m))
    Cl = np.empty((_NS, m))
    Y = np.empty((_NS, m))
    H = np.empty((m, _NS))
    Om = np.empty((m, m))
    PHt = np.empty((_NS, m))
    PHtT = np.empty((m, _NS))
    Sm = np.empty((m, m))
    Kt = np.empty((m, _NS))
    Hb = np.empty((m, _NS))
    Omb = np.empty((m, m))
    fold_col = _range_rate_column(kinds)
    for n in range(N):
        if not _linearised_h(P[n], C, n, 0, L, Cl, Y, H):
            return False
        _linearisation_error(S0, C, n, 0, H, Om)
        for a in range(A):
            if pd[a, n] == 0.0:
                continue
            Ha, Oma = H, Om
            pa = period[a]
            if fold_col >= 0 and pa > 0.0 and pa < np.inf and S0[n, 0, fold_col, fold_col] > (pa / RESOLVED_STDS) ** 2:
                for c in range(m):  # the marginalised range-rate (ambiguity.marginalise): no row of H, S_dd = P^2/2pi
                    for t in range(_NS):
                        Hb[c, t] = 0.0 if c == fold_col else H[c, t]
                    for e in range(m):
                        Omb[c, e] = 0.0 if (c == fold_col or e == fold_col) else Om[c, e]
                Omb[fold_col, fold_col] = pa * pa / (2.0 * math.pi)
                Ha, Oma = Hb, Omb
            for s_ in range(_NS):
                for c in range(m):
                    acc = 0.0
                    for t in range(_NS):
                        acc += Pa[a, n, s_, t] * Ha[c, t]
                    PHt[s_, c] = acc
                    PHtT[c, s_] = acc
            for c in range(m):
                for e in range(m):
                    acc = R[a, n, c, e] + Oma[c, e]
                    for t in range(_NS):
                        acc += Ha[c, t] * PHt[t, e]
                    Sm[c, e] = acc
            if not _cholesky(Sm, Ls):
                return False
            g = pd[a, n] * q2
            if table.shape[0] > 0:
                sqrt_det = 1.0
                for c in range(m):
                    sqrt_det *= Ls[c, c]
                g = pd[a, n] * _read_table(table, grid, pd[a, n], math.log1p(rho[a, n] * gate_volume * sqrt_det))
            _chol_solve(Ls, PHtT, Kt)  # K^T = S^-1 (P H^T)^T
            for s_ in range(_NS):
                for t in range(s_ + 1):
                    acc = 0.0
                    for c in range(m):
                        acc += PHt[s_, c] * Kt[c, t] + PHt[t, c] * Kt[c, s_]
                    v = 0.5 * ((Pa[a, n, s_, t] + Pa[a, n, t, s_]) - g * acc)
                    Pa[a, n, s_, t] = v
                    Pa[a, n, t, s_] = v
    return ok


@_jit
def _inv2(a, b, c):  # pragma: no cover - compiled
    """Inverse of the symmetric [[a, b], [b, c]] as its (a, b, c)."""
    det = a * c - b * b
    return c / det, -b / det, a / det


@_jit
def fuse_candidates(p, cov, gate_d2):  # pragma: no cover - compiled
    """initiation.fuse_candidates: mutual nearest neighbours within the gate fused, information-weighted."""
    n = p.shape[0]
    if n <= 1:
        return p.copy(), cov.copy()
    nn = np.empty(n, np.int64)
    best = np.empty(n)
    for i in range(n):
        best[i] = np.inf
        nn[i] = 0 if i != 0 else 1
        for j in range(n):
            if j == i:
                continue
            dx, dy = p[i, 0] - p[j, 0], p[i, 1] - p[j, 1]
            a = cov[i, 0, 0] + cov[j, 0, 0]
            b = cov[i, 0, 1] + cov[j, 0, 1]
            c = cov[i, 1, 1] + cov[j, 1, 1]
            d2 = (c * dx * dx - 2.0 * b * dx * dy + a * dy * dy) / (a * c - b * b)
            if d2 < best[i]:
                best[i] = d2
                nn[i] = j
    single = np.ones(n, np.bool_)
    fused_a = np.empty(n, np.int64)
    n_fused = 0
    for i in range(n):
        j = nn[i]
        if nn[j] == i and best[i] < gate_d2 and i < j:
            fused_a[n_fused] = i
            n_fused += 1
            single[i] = False
            single[j] = False
    n_single = 0
    for i in range(n):
        n_single += single[i]
    p_out = np.empty((n_single + n_fused, 2))
    c_out = np.empty((n_single + n_fused, 2, 2))
    k = 0
    for i in range(n):
        if single[i]:
            for u in range(2):
                p_out[k, u] = p[i, u]
                for v in range(2):
                    c_out[k, u, v] = cov[i, u, v]
            k += 1
    for f in range(n_fused):  # information-weighted fusion, 2 x 2 inverses in closed form
        i = fused_a[f]
        j = nn[i]
        ia = _inv2(cov[i, 0, 0], cov[i, 0, 1], cov[i, 1, 1])
        ib = _inv2(cov[j, 0, 0], cov[j, 0, 1], cov[j, 1, 1])
        pf = _inv2(ia[0] + ib[0], ia[1] + ib[1], ia[2] + ib[2])
        vx = ia[0] * p[i, 0] + ia[1] * p[i, 1] + ib[0] * p[j, 0] + ib[1] * p[j, 1]
        vy = ia[1] * p[i, 0] + ia[2] * p[i, 1] + ib[1] * p[j, 0] + ib[2] * p[j, 1]
        p_out[k, 0] = pf[0] * vx + pf[1] * vy
        p_out[k, 1] = pf[1] * vx + pf[2] * vy
        c_out[k, 0, 0], c_out[k, 0, 1], c_out[k, 1, 0], c_out[k, 1, 1] = pf[0], pf[1], pf[1], pf[2]
        k += 1
    return p_out, c_out


@_jit
def two_point_pairs(p, cov, p_prev, cov_prev, dt, max_speed):  # pragma: no cover - compiled
    """initiation.two_point_pairs (same gate and the same conflict resolution)."""
    C, Cp = p.shape[0], p_prev.shape[0]
    if C == 0 or Cp == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    ii = np.empty(C * Cp, np.int64)
    jj = np.empty(C * Cp, np.int64)
    cost = np.empty(C * Cp)
    k = 0
    for i in range(C):
        for j in range(Cp):
            good = True
            cst = 0.0
            for ax in range(2):
                v = (p[i, ax] - p_prev[j, ax]) / dt
                lim = max_speed + 2.0 * math.sqrt(cov[i, ax, ax] + cov_prev[j, ax, ax]) / dt
                if abs(v) > lim:
                    good = False
                    break
                cst += (v / lim) ** 2
            if good:
                ii[k] = i
                jj[k] = j
                cost[k] = cst
                k += 1
    order = np.argsort(cost[:k], kind="mergesort")
    first_i = _first_of_each(order, ii, C)  # cheapest pair of each current candidate ...
    kept = _first_of_each(first_i, jj, Cp)  # ... then the cheapest of those for each previous one
    return ii[kept], jj[kept]


@_jit
def _first_of_each(rows, key, n_keys):  # pragma: no cover - compiled
    """The entries of ``rows`` whose ``key[row]`` appears for the first time, in order (np.unique return_index)."""
    seen = np.zeros(n_keys, np.bool_)
    out = np.empty(rows.size, np.int64)
    n = 0
    for q in range(rows.size):
        o = rows[q]
        if not seen[key[o]]:
            seen[key[o]] = True
            out[n] = o
            n += 1
    return out[:n]


def weights_arrays(weights) -> tuple[FloatArray, FloatArray, float]:
    """(mean weights, covariance weights, sqrt(n + lambda)) of an ``UnscentedWeights``."""
    return weights.mean, weights.cov, math.sqrt(weights.n + weights.lam)


@_jit
def azimuth_candidates(z, R, snr, free, az, rr, tx, rx, max_range_rate, cap):  # pragma: no cover - compiled
    """Initiation candidates of one array receiver's free detections (Tracker._initiate, numpy reference).

    The ``cap`` strongest free detections (stable order of decreasing SNR), their ridge range
    (initiation.ridge_range; ``rr`` the range-rate column or -1) and the bearing-line / iso-range-ellipse point
    (initiation.range_azimuth_candidates, ``az`` the azimuth column). Returns the valid ``(C, 2)``, ``(C, 2, 2)``.
    """
    idx = np.flatnonzero(free)
    order = idx[np.argsort(-snr[idx], kind="mergesort")][:cap]
    n = order.size
    p = np.empty((n, 2))
    cov = np.empty((n, 2, 2))
    ax, ay = rx[0] - tx[0], rx[1] - tx[1]
    base = math.sqrt(ax * ax + ay * ay)
    k = 0
    for q in range(n):
        i = order[q]
        if rr >= 0:
            slope = R[i, 0, rr] / R[i, rr, rr]
            r = z[i, 0] - slope * z[i, rr]
            var_r = R[i, 0, 0] - slope * R[i, 0, rr] + slope * slope * max_range_rate * max_range_rate / 3.0
        else:
            r, var_r = z[i, 0], R[i, 0, 0]
        th, var_th = z[i, az], R[i, az, az]
        ux, uy = math.cos(th), math.sin(th)
        den = 2.0 * (r + ux * ax + uy * ay)
        num = r * r - (ax * ax + ay * ay)
        if not (r > base and den > 0.0):
            continue
        d = num / den
        if not d > 0.0:
            continue
        dd_dr = (2.0 * r * den - 2.0 * num) / (den * den)
        dd_dth = -num * 2.0 * (-uy * ax + ux * ay) / (den * den)
        p[k, 0], p[k, 1] = rx[0] + d * ux, rx[1] + d * uy
        j00, j10 = ux * dd_dr, uy * dd_dr  # J = d p / d (r, theta)
        j01, j11 = ux * dd_dth - d * uy, uy * dd_dth + d * ux
        cov[k, 0, 0] = j00 * j00 * var_r + j01 * j01 * var_th
        cov[k, 1, 1] = j10 * j10 * var_r + j11 * j11 * var_th
        cov[k, 0, 1] = cov[k, 1, 0] = j00 * j10 * var_r + j01 * j11 * var_th
        k += 1
    return p[:k], cov[:k]


@_jit
def select_candidates(p, cov, area, max_spread, cap):  # pragma: no cover - compiled
    """Candidates inside the area with trace(cov) <= max_spread; the ``cap`` most precise if more (stable)."""
    n = p.shape[0]
    keep = np.zeros(n, np.bool_)
    spread = np.empty(n)
    for i in range(n):
        spread[i] = cov[i, 0, 0] + cov[i, 1, 1]
        keep[i] = area[0] <= p[i, 0] <= area[1] and area[2] <= p[i, 1] <= area[3] and spread[i] <= max_spread
    idx = np.flatnonzero(keep)
    if idx.size > cap:
        idx = idx[np.argsort(spread[idx], kind="mergesort")[:cap]]
    return p[idx], cov[idx]


@_jit
def new_track_states(p, cov, p0, cov0, dt, max_speed, accel_std):  # pragma: no cover - compiled
    """Two-point initial states (n, 6) and covariances (n, 6, 6); numpy reference: Tracker._new_track_states."""
    n = p.shape[0]
    x = np.zeros((n, _NS))
    P = np.zeros((n, _NS, _NS))
    prior = 1.0 / (0.5 * max_speed) ** 2
    pv = (0, 2, 1, 3)  # state indices of (x, y, vx, vy)
    blk = np.empty((4, 4))
    for i in range(n):
        s00, s01, s11 = (
            (cov[i, 0, 0] + cov0[i, 0, 0]) / dt**2,
            (cov[i, 0, 1] + cov0[i, 0, 1]) / dt**2,
            (cov[i, 1, 1] + cov0[i, 1, 1]) / dt**2,
        )
        i00, i01, i11 = _inv2(s00, s01, s11)
        c00, c01, c11 = _inv2(i00 + prior, i01, i11 + prior)  # Cov(v)
        k00, k01 = c00 * i00 + c01 * i01, c00 * i01 + c01 * i11  # K = Cov(v) Sigma^-1
        k10, k11 = c01 * i00 + c11 * i01, c01 * i01 + c11 * i11
        vx, vy = (p[i, 0] - p0[i, 0]) / dt, (p[i, 1] - p0[i, 1]) / dt
        x[i, 0], x[i, 2] = p[i, 0], p[i, 1]
        x[i, 1], x[i, 3] = k00 * vx + k01 * vy, k10 * vx + k11 * vy
        for u in range(2):  # cross = cov K^T / dt
            for v in range(2):
                blk[u, v] = cov[i, u, v]
            blk[u, 2] = (cov[i, u, 0] * k00 + cov[i, u, 1] * k01) / dt
            blk[u, 3] = (cov[i, u, 0] * k10 + cov[i, u, 1] * k11) / dt
            blk[2, u], blk[3, u] = blk[u, 2], blk[u, 3]
        blk[2, 2], blk[2, 3], blk[3, 2], blk[3, 3] = c00, c01, c01, c11
        for u in range(4):
            for v in range(4):
                P[i, pv[u], pv[v]] = blk[u, v]
        P[i, 4, 4] = P[i, 5, 5] = accel_std * accel_std
    return x, P


@_jit
def initiate(p, cov, p_prev, cov_prev, dt, area, max_spread, cap, gate2, max_speed, accel_std):  # pragma: no cover
    """The scan's initiation after the candidates, fused (Tracker._initiate, numpy reference).

    select_candidates -> fuse_candidates -> two_point_pairs with the previous scan's unpaired candidates (none
    when ``dt`` is not finite) -> new_track_states. Returns ``(x (n, 6), P (n, 6, 6))`` of the new tentative
    tracks and the candidates ``(C', 2)``, ``(C', 2, 2)`` left unpaired for the next scan.
    """
    p, cov = select_candidates(p, cov, area, max_spread, cap)
    p, cov = fuse_candidates(p, cov, gate2)
    if math.isfinite(dt):
        i, j = two_point_pairs(p, cov, p_prev, cov_prev, dt, max_speed)
    else:
        i, j = np.zeros(0, np.int64), np.zeros(0, np.int64)
    x, P = new_track_states(p[i], cov[i], p_prev[j], cov_prev[j], dt, max_speed, accel_std)
    rest = np.ones(p.shape[0], np.bool_)
    rest[i] = False
    idx = np.flatnonzero(rest)
    return x, P, p[idx], cov[idx]
