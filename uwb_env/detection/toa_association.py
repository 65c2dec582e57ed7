r"""Seed 001's weak-signal enhancement, ToA estimation of distributed targets and ToA association (section 3.2).

Seed 001 (Rovňáková & Kocur, through-wall tracking with a handheld M-sequence UWB radar: one transmitter between two
receivers on a line) replaces the usual per-receiver ToA estimation plus a separate data association with one step,
"ToA association", whose seven steps run on the detector outputs ``h_d^k(t, tau)`` of the two receivers k = 1, 2
for every observation time tau (one scan). The kernels here:

* :func:`advance_normalization`: the weak-signal enhancement of section 2 (the seed cites [14], "normalization
  based on hierarchical searching of maxima", without a formula: ours below);
* :func:`interval_toas`: steps 1-3, the ToA of each distributed target (kernel of the ``interval`` ToA estimator,
  registered in :mod:`uwb_env.detection.registry`);
* :func:`associate_toas`: steps 4-7, the ToA couples of the two receivers that belong to one target (ghost pairs
  rejected by the appendix's theorem), with step 6's completion from the previous scan's couples -- of a moving
  target's trace only: an isolated ToA that has not moved since the previous couple (``STILL_S``) is not completed
  (ours; the seed is silent on static echoes in step 6).

Times: the ToA of a receiver is the propagation time transmitter -> target -> receiver (time zero at emission, the
seed's "time-zero setting"), i.e. the bistatic range / c; the association works on seconds, the ToA estimator on
samples of the scan.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from uwb_env.typing import BoolArray, FloatArray, IntArray

STILL_S = 1.5 / 4.5e9
"""Step 6's stillness bound [s]: an isolated ToA closer than this to its receiver's ToA in the previous couple has
not moved since the previous scan (:func:`associate_toas`). One and a half samples of seed 001's 4.5 GHz M-sequence
clock: the interval ToA (eq. 3) sits on the sample grid and a motionless echo's interval start flickers by one
sample, so this means "moved by at most one sample", 0.10 m of bistatic range (5 cm of range) in one scan; a person
walking radially at 0.8 m/s moves 0.12 m of bistatic range in the seed's 0.074 s."""


# ------------------------------------------------------------------------------------------ advance normalization
def advance_normalization(x: FloatArray, target_samples: int = 0) -> FloatArray:
    r"""Seed 001's advance normalization (section 2, [14]): each sample over the hierarchical maximum beyond it.

    Args: x ``(..., N)`` non-negative magnitudes along propagation time (the background-subtracted envelope);
    target_samples: w, a target's extent [samples] (seed 001: W_p = 15, a person), the samples a maximum owns after it
    (0: the literal sample-wise hierarchy).
    Returns: ``(..., N)`` the normalized scan in [0, 1]; an all-zero tail stays zero.

    Notes:
        The seed names the method ("signal normalization based on hierarchical searching of maxima") and its purpose
        -- lifting the echo of a farther target that the nearest target's echo dominates -- but prints no formula;
        this is our reading of the hierarchical search. The scan's maximum n_0 = argmax_{n} x[n] normalizes every
        sample up to it; the maximum n_1 of what lies after n_0 normalizes the samples in (n_0, n_1]; and so on to
        the scan's end:

        .. math:: y[n] = x[n] / x[n_j],\quad n \in (n_{j-1}, n_j],\quad n_j = \arg\max_{n > n_{j-1}} x[n].

        Because n_j is the maximum of everything after n_{j-1}, x[n_j] = max_{k >= n} x[k] for every n in the
        segment, so the hierarchy is the reverse cumulative maximum, computed in one pass. Each target's echo
        peaks at 1 when nothing stronger lies beyond it.

        Taken sample by sample (w = 0) the hierarchy degenerates on an echo's decaying tail: every sample of a
        monotone tail is the maximum of what follows it, so the tail becomes a plateau of ones down to the level of
        whatever lies beyond (on the signal path, the noise: the plateau spans the whole body echo's trailing part).
        A cell-averaging CFAR then finds that plateau in its lagging reference cells and misses the echo's leading
        edge -- the very samples the interval ToA (eq. 3) is read from, in each receiver differently (on the
        seed 001 replica: receiver 2's ToAs 0.1-0.3 m later than receiver 1's, positions pulled 0.5-1 m towards the
        array's axis; the persons held in half the scans). A maximum belongs to a target that extends over w
        samples, so the search for the next maximum starts after it: a sample n is normalized by the largest sample
        from n - w on, :math:`y[n] = x[n] / \max_{k \ge n - w} x[k]` -- a target's own tail keeps its shape
        under its peak, the noise and weaker echoes beyond it are lifted as before.
    """
    x = np.asarray(x, dtype=float)
    peak = np.flip(np.maximum.accumulate(np.flip(x, axis=-1), axis=-1), axis=-1)
    if target_samples > 0:  # the maximum from n - w on: the reverse cumulative maximum read w samples earlier
        peak = peak[..., np.maximum(np.arange(x.shape[-1]) - int(target_samples), 0)]
    return np.divide(x, peak, out=np.zeros_like(x), where=peak > 0.0)


# ------------------------------------------------------------------------------------------ steps 1-3: ToA estimation
def interval_toas(
    decisions: BoolArray, d: FloatArray, width: int, threshold: int
) -> tuple[IntArray, FloatArray, IntArray, FloatArray]:
    r"""Steps 1-3 of seed 001 section 3.2: one ToA per continuous interval of detections (a distributed target).

    Args:
        decisions: ``(B, N)`` detector outputs h_d(t) (CFAR decisions) of B scans.
        d: ``(B, N)`` the detector's input (for the interval's peak, a strength diagnostic).
        width: W_p, the summation window [samples] (the seed: 15 samples ~ 1 m, a person).
        threshold: T_LIM, the least number of detections in the window (1 <= T_LIM <= W_p).

    Returns:
        ``(row (D,), toa (D,) [samples], weight (D,), peak (D,))``: the scan of each simple target, its ToA
        h_0 - T_LIM (eq. 3), the interval's length and the largest ``d`` in it; sorted by (row, toa).

    Notes:
        Step 1 (eq. 1): :math:`\bar h(t_i) = \sum_{w=0}^{W_p-1} h_d(t_{i-w})` (causal window). Step 2 (eq. 2):
        :math:`\tilde h(t) = [\bar h(t) \ge T_{LIM}]`. Step 3 (eqs. 3-4): the start h_0 of every interval of ones,
        i.e. every t_n with :math:`\tilde h(t_n) = 1, \tilde h(t_{n-1}) = 0, \tilde h(t_{n+1}) = 1` (eq. 4, with
        :math:`\tilde h(t_1) = 0`: an interval must be two samples long and cannot start at the first sample), gives
        :math:`TOA_0 = h_0 - T_{LIM}` (eq. 3, t_LIM = T_LIM samples): the window first holds T_LIM detections at
        h_0, the target's first detection lies about T_LIM samples earlier.
    """
    dec = np.ascontiguousarray(np.asarray(decisions, dtype=bool))
    dd = np.ascontiguousarray(np.asarray(d, dtype=float))
    return _interval_rows(dec, dd, int(width), int(threshold))


@nb.njit(cache=True, nogil=True)
def _interval_rows(dec, d, width, threshold):  # pragma: no cover - compiled
    """Steps 1-3 on every row of ``dec`` (B, N): one pass per row with a running window count."""
    B, N = dec.shape
    cap = B * (N // 2 + 1)
    rows = np.empty(cap, dtype=np.int64)
    toas = np.empty(cap)
    weights = np.empty(cap, dtype=np.int64)
    peaks = np.empty(cap)
    out = 0
    h = np.zeros(N, dtype=np.bool_)
    for b in range(B):
        count = 0
        for i in range(N):  # eq. 1 (causal window of width W_p) and eq. 2
            if dec[b, i]:
                count += 1
            if i >= width and dec[b, i - width]:
                count -= 1
            h[i] = count >= threshold
        h[0] = False  # eq. 4's initialisation
        i = 1
        while i < N - 1:  # eq. 4: a start needs the sample before off and the one after on
            if h[i] and not h[i - 1] and h[i + 1]:
                j = i
                peak = d[b, i]
                while j + 1 < N and h[j + 1]:
                    j += 1
                    peak = max(peak, d[b, j])
                rows[out] = b
                toas[out] = i - threshold  # eq. 3
                weights[out] = j - i + 1
                peaks[out] = peak
                out += 1
                i = j + 1
            else:
                i += 1
    return rows[:out], toas[:out], weights[:out], peaks[:out]


# ------------------------------------------------------------------------------------------ steps 4-7: association
@nb.njit(cache=True, nogil=True)
def _merge(t, half):  # pragma: no cover - compiled
    """Union of the widened intervals [t - half, t + half] of sorted t: region starts and ends."""
    n = t.shape[0]
    rs = np.empty(n)
    re = np.empty(n)
    r = -1
    for i in range(n):
        s, e = t[i] - half, t[i] + half
        if r >= 0 and s <= re[r]:
            re[r] = max(re[r], e)
        else:
            r += 1
            rs[r] = s
            re[r] = e
    return rs[: r + 1], re[: r + 1]


@nb.njit(cache=True, nogil=True)
def _associate(t1, t2, m, prev_c, prev_w, prev_o, still):  # pragma: no cover - compiled
    half = 0.5 * m
    rs1, re1 = _merge(t1, half)
    rs2, re2 = _merge(t2, half)
    cap = rs1.size + rs2.size + t1.size + t2.size + 1
    cc = np.empty(cap)
    ww = np.empty(cap)
    oo = np.empty(cap, dtype=np.int64)
    done = np.zeros(cap, dtype=np.bool_)
    n = 0
    # step 5: the intervals where h_A = 3 (both receivers' widened regions overlap)
    i = 0
    j = 0
    while i < rs1.size and j < rs2.size:
        lo = max(rs1[i], rs2[j])
        hi = min(re1[i], re2[j])
        if lo <= hi:
            cc[n] = 0.5 * (lo + hi)
            ww[n] = hi - lo
            # the order of Rx1's ToA: 1 when Rx1's region opened first (h_A = 1 just before the run of 3)
            if rs1[i] < rs2[j] or (rs1[i] == rs2[j] and re1[i] <= re2[j]):
                oo[n] = 1
            else:
                oo[n] = 2
            n += 1
        if re1[i] < re2[j]:
            i += 1
        else:
            j += 1
    n_assoc = n
    # step 6: isolated simple targets (h_A = k over their whole widened interval) completed by a previous couple
    used = np.zeros(prev_c.size, dtype=np.bool_)
    for q in range(prev_c.size):  # a previous couple continued by a current one is not reused
        for p in range(n_assoc):
            if abs(prev_c[q] - cc[p]) <= half:
                used[q] = True
    for k in range(2):
        t = t1 if k == 0 else t2
        os_ = rs2 if k == 0 else rs1
        oe = re2 if k == 0 else re1
        for a in range(t.size):
            lo, hi = t[a] - half, t[a] + half
            isolated = True
            for b in range(os_.size):
                if os_[b] <= hi and oe[b] >= lo:
                    isolated = False
                    break
            if not isolated:
                continue
            best = -1
            best_gap = np.inf
            for q in range(prev_c.size):
                # the previous couple's ToA of this receiver (eq. 11): an isolated ToA within ``still`` of it has
                # not moved since the previous scan -- a static residue, not a moving target's trace
                off = 0.5 * (m - prev_w[q])
                sgn = 1.0 if prev_o[q] == 1 else -1.0
                prev_k = prev_c[q] - sgn * off if k == 0 else prev_c[q] + sgn * off
                if abs(t[a] - prev_k) < still:
                    continue
                if not used[q] and lo <= prev_c[q] <= hi and abs(prev_c[q] - t[a]) < best_gap:
                    best = q
                    best_gap = abs(prev_c[q] - t[a])
            if best >= 0:
                used[best] = True
                cc[n] = prev_c[best]
                ww[n] = prev_w[best]
                oo[n] = prev_o[best]
                done[n] = True
                n += 1
    # step 7: eq. 11 (derived: the printed form is garbled) -- the couple's ToAs from its width, centre and order
    toa1 = np.empty(n)
    toa2 = np.empty(n)
    for p in range(n):
        off = 0.5 * (m - ww[p])
        sgn = 1.0 if oo[p] == 1 else -1.0
        toa1[p] = cc[p] - sgn * off
        toa2[p] = cc[p] + sgn * off
    order = np.argsort(cc[:n], kind="mergesort")
    return toa1[order], toa2[order], cc[:n][order], ww[:n][order], oo[:n][order], done[:n][order]


def associate_toas(
    toa1: FloatArray,
    toa2: FloatArray,
    m: float,
    prev_centre: FloatArray | None = None,
    prev_width: FloatArray | None = None,
    prev_order: IntArray | None = None,
    still_s: float = STILL_S,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, IntArray, BoolArray]:
    r"""Steps 4-7 of seed 001 section 3.2: the ToA couples of receivers 1 and 2 that can belong to one target.

    Args:
        toa1, toa2: ``(n1,)``, ``(n2,)`` potential simple targets' ToAs of Rx1 and Rx2 [s] (any order).
        m: the widening (eq. 5) [s]: the largest ToA difference one target can make, 2 d / c + t_corr.
        prev_centre, prev_width, prev_order: ``(P,)`` C_l, W_l [s] and O_Rx1,l of the previous scan's couples (step
            6), or None.
        still_s: step 6's stillness bound [s] (``STILL_S``): a previous couple does not complete an isolated ToA
            closer than this to the couple's own ToA of that receiver (0: the seed's literal step 6).

    Returns:
        ``(toa1 (L,), toa2 (L,), centre (L,), width (L,), order (L,), completed (L,))`` per couple, sorted by centre
        [s]: the couple's ToAs (eq. 11), C_l, W_l, O_Rx1,l and whether step 6 completed it from the previous scan.

    Notes:
        Step 4 (eq. 6): every ToA is widened to [TOA - m/2, TOA + m/2] (value k on receiver k's sequence; widened
        intervals of one receiver that overlap form one region). Step 5 (eqs. 7-8): h_A = h_W^1 + h_W^2; the runs
        where h_A = 3 are the associated couples, each with width W_l, centre C_l and O_Rx1,l = 1 when Rx1's region
        began first. Two widened intervals overlap iff |TOA^1 - TOA^2| <= m, and the appendix's theorem bounds the
        ToA difference of one target by |Rx1 Rx2| / c (2 d / c with Tx in the middle), so a couple whose ToAs
        differ by more than m cannot be one target: such ghost pairs never form a run of 3. Step 6 (eqs. 9-10): a
        ToA whose widened interval holds no 3 (an isolated simple target) is completed when a previous couple's
        centre C_l(tau_{j-1}) lies in that interval: the couple is repeated with its previous W_l, C_l, O_Rx1,l (our
        choices where the seed is silent: each previous couple completes at most one ToA, the nearest, and none that
        a current couple already continues -- its centre within m/2 of a current centre; which couples count as
        the previous scan's is the caller's: the signal sensor passes the ones steps 4-5 found).

        Step 6 is a moving target's: the seed completes "the missing TOA, if only one receiving channel has detected
        an echo due to a target", and behind the wall a target is seen only through its motion (the exponential-
        averaging background subtraction removes what stands still). The seed is silent on an echo that does not
        move. We complete an isolated ToA t_i of receiver k from couple l only when t_i has moved since the couple's
        own ToA of that receiver, :math:`|t_i - TOA^k_l(\tau_{j-1})| \ge` ``still_s`` (TOA^k_l by eq. 11 from
        W_l, C_l, O_Rx1,l). What stays on the same sample scan after scan is a residue of the background
        subtraction at a static path's delay (the path's fluctuation, or its shadowing by a person, that the
        exponential average follows only slowly), seen by both receivers in one scan and by one in the next;
        completing it repeats the residue's couple (eq. 10) and adds detections at one point, on which the tracker
        confirms a track. On the seed 001 replica (``agents/studies/seed001_through_wall.py``, runs 0-39, the literal
        step 6): of the isolated ToAs step 6 completed into false-alarm couples 97 % (of 297) had moved by at most
        one sample, of those completed into a person's couple 47 % (of 430); a static residue on the array's axis
        1.25 m from it (both receivers' ToAs at 2.57 m of bistatic range, wall compensated) held 9 of the 14 ghost
        tracks, and none of the 5 left with this rule. A person who moved less than ``still_s`` (walking across the
        range) loses the completion for that scan only: the couple of the scan before is what eq. 10 would have
        repeated. Step 7 (eq. 11): for a
        single pair of ToAs a_1 < a_2 (O = 1) the run of 3 is [a_2 - m/2, a_1 + m/2], so W = m - (a_2 - a_1) and
        C = (a_1 + a_2)/2, whence

        .. math:: TOA^k_l = C_l - (3 - 2k)\,\frac{m - W_l}{2}\ (O_{Rx1,l} = 1),\qquad
                  TOA^k_l = C_l + (3 - 2k)\,\frac{m - W_l}{2}\ (O_{Rx1,l} = 2).

        The printed eq. 11 is garbled in our copy of the seed ("C_l(tau) -+ W_l/2 - (3 - 2k) m"); the form above is
        derived from eqs. 6-8 and returns a single couple's ToAs exactly.
    """
    t1 = np.sort(np.asarray(toa1, dtype=float))
    t2 = np.sort(np.asarray(toa2, dtype=float))
    pc = np.zeros(0) if prev_centre is None else np.asarray(prev_centre, dtype=float)
    pw = np.zeros(0) if prev_width is None else np.asarray(prev_width, dtype=float)
    po = np.zeros(0, dtype=np.int64) if prev_order is None else np.asarray(prev_order, dtype=np.int64)
    return _associate(t1, t2, float(m), pc, pw, po, float(still_s))


def all_couples(toa1: FloatArray, toa2: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Every Rx1 x Rx2 combination (no association: the couples from which ghosts arise), ``(n1 n2,)`` each."""
    a, b = np.meshgrid(np.asarray(toa1, dtype=float), np.asarray(toa2, dtype=float), indexing="ij")
    return a.ravel(), b.ravel()
