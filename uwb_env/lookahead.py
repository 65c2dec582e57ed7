r"""One-step lookahead: the expected cost of every scan plan after the next scan (seed 003 eq. 7), pure.

For the confirmed tracks (the reward's; before any track is confirmed, the tentative ones, whose confirmation the
next scan decides), from the tracker's predicted state (IMM mixing + prediction to the next scan time,
combined), and for every candidate plan a:

    P_a <- P_pred
    for each formed pair (tx, rx) the plan uses, in the tracker's order:
        H       = C^T P_pred^-1                         statistical linearisation of the tracker's filter (the
                                                         unscented transform; the Jacobian for the EKF) at the
                                                         predicted state (action-independent, once per pair)
        Omega   = S0 - H P_pred H^T                     its linearisation error (0 for the EKF), there too
        R_a     = the waveform's covariance at the mean SNR of the predicted position (sensor model), DOA appended
        P_D,a   = the sensor model's detection probability there (capped like the tracker's)
        S       = H P_a H^T + Omega + R_a,   K = P_a H^T S^-1
        P_a    <- P_a - P_D,a q_2 K S K^T                  expected PDA posterior covariance
    cost_a = (1 / T) sum_t trace(P_a^(t) [position block])

Seed 003 evaluates (7) with the UKF covariance update (q_2 = 1, P_D = 1): for P_a = P_pred the step above is exactly
the tracker's UKF update P - K S K^T with S = S0 + R_a and K = C S^-1 (without Omega, S would miss the unscented
transform's linearisation error and the expected covariance would be overconfident). We keep the detection
probability (the expected Riccati update of a filter that is updated with probability P_D) and write the
information-reduction factor q_2 of PDA in clutter (Kershaw and Evans) as an argument: ``q2 = 1`` (the default) is
the seed's clutter-free value; ``q2 = "pda"`` reads q_2(m, P_D, lambda_G) from ``tracking.reduction`` with the
expected false measurements in each plan's gate, lambda_G = rho c_m gamma^(m/2) |S|^(1/2), rho the sensor model's
clutter map at the track's predicted measurement h(x) (``ParametricSensor.clutter_intensity_at``, floored like the
tracker's). On urban-intersection it changes the myopic scheduler's results by less than their 95 % interval.

Shared prefixes: pair p's update of plan a depends only on P_a before it and on what the plan does at the pair
(whether its receiver listens, the waveform its transmitter sends), so plans that do the same at pairs 0..p share
P_a after them and are updated once (``_PlanTable.pair_groups``; exact, the per-(plan, track) updates being
independent). Per-transmitter plans (``action_kind="per-tx"``, W^T joint plans) update the first transmitter's pairs
once per waveform (W groups), the last transmitter's once per joint plan; the waveform plans share nothing.

The whole computation is batched over plans x tracks, draws nothing and changes no state. The lookahead reads the
tracker only through its seam (``uwb_env.tracking.protocol``): the scored tracks' predicted Gaussians, the prediction
between scans and each pair's expected update (``uwb_env.tracking.expectation``, one numba call; its numpy twin is in
``uwb_env.tracking.reference``). Particle trackers give their moment-matched Gaussians, so every scheduler runs on
every tracker.

Deeper lookahead (``sequence_costs``): the same recursion over sequences of d plans, scan after scan,

    cost(a_1 .. a_d) = sum_l gamma^(l-1) (1 / T) sum_t trace(P^(t)_l [position block])

where between scans the combined estimate is predicted by the tracker's moment-matched prediction
(``predict_gaussians``; for the IMM tracker every active model j from the combined (x, P): x_j = F_j x,
P_j = F_j P F_j^T + Q_j, mixed with the predicted model probabilities mu^- = Pi^T mu and the spread of the x_j; the
VS-IMM set of that scan, with the tracker's switch rule for mu).
Means stay at their predictions (the expected innovation is zero). A beam of width B keeps, after every scan, the
B cheapest partial sequences (``beam=None``: all A^d), so depth d costs A + (d - 1) B A expected updates.

Receiver warm-up (``ready_rx``, the environments' ``receiver_warmup``): a receiver delivers detections only if it
also listened in the previous scan (it spends its first listening scan re-acquiring its background and clock). The
one-step cost then uses the plan's listening receivers that are ready now; along a sequence, the receivers ready at
scan l + 1 are those the sequence's plan l listens with. This is what makes one-step lookahead short-sighted there:
a receiver switched in pays off one scan later, which depth 1 cannot see.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from uwb_env.sensing.parametric import ParametricSensor
from uwb_env.sensing.records import ScanPlan
from uwb_env.tracking.expectation import reduction_model
from uwb_env.tracking.measurement import measure
from uwb_env.tracking.protocol import MultiTargetTracker, Prediction
from uwb_env.typing import BoolArray, FloatArray
from uwb_env.waveforms.chirp import range_migration_gain


def scored_prediction(
    tracker: MultiTargetTracker, time_s: float, scan_index: int
) -> tuple[FloatArray, FloatArray, FloatArray, BoolArray] | None:
    """The tracks a lookahead scores, predicted to the next scan (pure, ``MultiTargetTracker.scored_prediction``).

    The confirmed ones, or every (tentative) track when none is; ``None`` without any track.
    Returns their combined ``x (N, 6)``, ``P (N, 6, 6)``, model probabilities ``(N, r)`` and model set ``(r,)``.
    """
    pred = tracker.scored_prediction(time_s, scan_index)
    return None if pred is None else (pred.x, pred.P, pred.mu, pred.active)


def check_search(depth: int, beam: int | None, discount: float) -> None:
    """Validate the sequence search's depth >= 1, beam >= 1 or ``None``, discount in (0, 1]."""
    if depth < 1:
        raise ValueError(f"depth={depth}: must be >= 1")
    if beam is not None and beam < 1:
        raise ValueError(f"beam={beam}: must be >= 1 or None (no pruning)")
    if not 0.0 < discount <= 1.0:
        raise ValueError(f"discount={discount}: must be in (0, 1]")


def expected_posterior(
    x: FloatArray,
    P: FloatArray,
    sensor: ParametricSensor,
    tracker: MultiTargetTracker,
    plans: Sequence[ScanPlan],
    q2: float | str = 1.0,
    delivering: BoolArray | None = None,
) -> FloatArray:
    """Expected posterior covariances ``(A, N, 6, 6)`` of N predicted tracks ``x (N, 6)``, ``P (N, 6, 6)``.

    ``q2``: a constant information-reduction factor, or ``"pda"`` for q_2(P_D, lambda_G) of PDA in the sensor
    model's clutter (``tracking.reduction``; lambda_G from the clutter map at each track's predicted measurement
    and the plan's S). ``delivering`` ``(A, N, R)``: which receivers' detections reach track n under plan a
    (default: the plan's listening receivers for every track); a pair updates only where its receiver delivers.
    """
    check_q2(q2)
    A, N = len(plans), x.shape[0]
    x, P = np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(P, dtype=float)
    if N == 0:
        return np.repeat(P[None], A, axis=0)
    cfg = tracker.cfg
    table = _plan_table(plans)
    pairs = sensor.pairs.tolist()
    groups = None if delivering is not None else table.pair_groups(pairs)
    # without shared prefixes: every plan's own covariances; with them, one per group of plans (module docstring)
    Pa = np.repeat(P[None], A, axis=0) if groups is None else P[None]
    floor, floor_sq = cfg.range_rate_noise_floor_mps > 0.0, cfg.range_rate_noise_floor_mps**2
    rate_period = sensor.library.range_rate_periods
    steps = []  # per pair: (sent, rows, used_rows, sent_by_row) of its updated plans
    for p, (tx, rx) in enumerate(pairs):
        if delivering is None:
            steps.append(table.pair_rows(tx, rx, groups, p))
        else:
            used = delivering[:, :, rx].any(axis=1)
            sent = np.unique(table.waveforms[used, tx])  # the waveforms the plans send: a small set
            rows = np.full(A, sent.size, np.int64)  # row of [pd_w; 0] per plan: its waveform's, or the zero row
            rows[used] = np.searchsorted(sent, table.waveforms[used, tx])
            steps.append((sent, rows, used, table.waveforms[:, tx]))
    # the sensor model of every pair that some plan uses (it does not depend on the covariances)
    using = [p for p, step in enumerate(steps) if step[0].size]
    found = _pair_models(sensor, cfg, [pairs[p] for p in using], x, [steps[p][0] for p in using])
    models = dict(zip(using, found, strict=True))
    for p, (tx, rx) in enumerate(pairs):
        if groups is not None:  # the groups after pair p, each from its parent group before it
            parent = groups[0][p][1]
            if parent is not None:
                Pa = Pa[parent]
        sent, rows, used_rows, sent_by_row = steps[p]
        if sent.size == 0:  # no plan listens with rx
            continue
        names = sensor.measurement_names(rx)
        m = len(names)
        pd_w, R_w = models[p]
        if floor and "range_rate" in names:
            d = names.index("range_rate")
            R_w = R_w.copy()
            R_w[..., d, d] += floor_sq  # as the tracker's filter sees it
        tx_pos, rx_pos = sensor.layout.tx_pos[tx], sensor.layout.rx_pos[rx]
        rho_w = None
        if q2 == "pda":  # the clutter map at the predicted measurements, floored like the tracker's
            z_pred, _ = measure(names, x, tx_pos, rx_pos)
            rho_w = np.maximum(sensor.clutter_intensity_at(tx, rx, z_pred, R_w, sent), cfg.min_clutter_intensity)
        # each updated plan's (group representative's) rows: plan a's waveform's, zeros where rx does not listen
        if rows is None:  # plan a sends waveform sent[a] and every plan is updated: no gather
            pd, R, period = pd_w, R_w, rate_period[sent]
            rho = np.zeros((sent.size, N)) if rho_w is None else rho_w
        elif used_rows is None:  # every row's plan listens: a gather
            pd, R, period = pd_w[rows], R_w[rows], rate_period[sent_by_row]
            rho = np.zeros((rows.size, N)) if rho_w is None else rho_w[rows]
        else:
            pd = np.concatenate([pd_w, np.zeros((1, N))])[rows]
            R = np.concatenate([R_w, np.zeros((1, N, m, m))])[rows]
            period = np.where(used_rows, rate_period[sent_by_row], np.inf)  # tracking.ambiguity; inf: unused
            rho = np.zeros((rows.size, N)) if rho_w is None else np.concatenate([rho_w, np.zeros((1, N))])[rows]
        if delivering is not None:
            pd = pd * delivering[:, :, rx]
        reduction = reduction_model(q2, m, cfg.gate_probability)
        Pa = tracker.expected_update(Pa, x, P, names, tx_pos, rx_pos, R, pd, reduction, rho, period)
    return Pa if groups is None or groups[1] is None else Pa[groups[1]]


def check_q2(q2: float | str) -> None:
    """Validate the information-reduction option: a number in (0, 1] or ``"pda"``."""
    if isinstance(q2, str):
        if q2 != "pda":
            raise ValueError(f"q2={q2!r}: must be a number in (0, 1] or 'pda'")
    elif isinstance(q2, (bool, np.bool_)) or not isinstance(q2, (int, float, np.integer, np.floating)):
        raise TypeError(f"q2={q2!r}: must be a number in (0, 1] or 'pda' (got {type(q2).__name__})")
    elif not 0.0 < float(q2) <= 1.0:
        raise ValueError(f"q2={q2!r}: must be a number in (0, 1] or 'pda'")


def lookahead_costs(
    sensor: ParametricSensor,
    tracker: MultiTargetTracker,
    plans: Sequence[ScanPlan],
    time_s: float,
    scan_index: int,
    q2: float | str = 1.0,
    ready_rx: BoolArray | None = None,
) -> FloatArray:
    """Expected mean position-covariance trace ``(A,)`` [m^2] over the scored tracks after the next scan.

    ``ready_rx`` ``(R,)``: the receivers able to deliver this scan (warm-up, module docstring); None: all.
    Zero for every plan when there is no track. Pure: no tracker state changes, no random draw.
    """
    scored = scored_prediction(tracker, time_s, scan_index)
    if scored is None:
        return np.zeros(len(plans))
    x, P, _, _ = scored
    delivering = None if ready_rx is None else _delivering(_plan_table(plans).listening, ready_rx[None], x.shape[0])
    return position_trace(expected_posterior(x, P, sensor, tracker, plans, q2, delivering)).sum(axis=1) / x.shape[0]


def _pair_model(sensor: ParametricSensor, cfg, tx: int, rx: int, x: FloatArray, sent: np.ndarray) -> tuple:
    """The sensor model's ``(Pd (W, N), R (W, N, m, m))`` of pair (tx, rx) for the waveforms ``sent``, at tracks x.

    ``x (N, 6)``: positions and velocities (notch and range walk); the tracker's assumed RCS; Pd capped like the
    tracker's.
    """
    pd, R = sensor.expected_measurements(
        tx, rx, x[:, 0:3:2], sent, cfg.assumed_rcs_m2, cfg.assumed_swerling, velocities=x[:, 1:4:2]
    )
    return np.minimum(pd, cfg.max_detection_probability), R


def _pair_models(sensor: ParametricSensor, cfg, pairs: list, x: FloatArray, sents: list) -> list[tuple]:
    """``_pair_model`` of each pair ``(tx, rx)`` for its waveforms ``sents[p]``: ``[(Pd (W_p, N), R)]``.

    In one call where the sensor model has it (``ParametricSensor.expected_measurements_pairs``: the same numbers).
    """
    batched = getattr(sensor, "expected_measurements_pairs", None)
    if batched is None:
        return [_pair_model(sensor, cfg, tx, rx, x, sent) for (tx, rx), sent in zip(pairs, sents, strict=True)]
    out = batched(pairs, x[:, 0:3:2], sents, cfg.assumed_rcs_m2, cfg.assumed_swerling, velocities=x[:, 1:4:2])
    return [(np.minimum(pd, cfg.max_detection_probability), R) for pd, R in out]


def detection_probabilities(
    sensor: ParametricSensor, tracker: MultiTargetTracker, plans: Sequence[ScanPlan], time_s: float, scan_index: int
) -> FloatArray | None:
    """Expected Pd ``(A, N, Q)`` of the N confirmed tracks at the Q formed pairs under each plan (0: pair unused).

    The sensor model's Pd at each track's predicted position and velocity (Doppler notch and range migration
    included, ``ParametricSensor.expected_measurements``) for the assumed RCS, capped like the tracker's. ``None``
    without a confirmed track. Pure.
    """
    pred = tracker.scored_prediction(time_s, scan_index) if tracker.tracks.confirmed.any() else None
    if pred is None:
        return None
    x, cfg, table = pred.x, tracker.cfg, _plan_table(plans)
    pd = np.zeros((len(plans), x.shape[0], sensor.pairs.shape[0]))
    for q, (tx, rx) in enumerate(sensor.pairs.tolist()):
        used, sent, which, _ = table.pair_waveforms(tx, rx)
        if not used.any():
            continue
        pd[used, :, q] = _pair_model(sensor, cfg, tx, rx, x, sent)[0][which]
    return pd


def search_information(sensor: ParametricSensor, plans: Sequence[ScanPlan], max_range_rate: float) -> FloatArray:
    """``(A,)`` range information a new target's detections would bring under each plan (search scans).

    Sum over the plan's formed pairs (tx sends w, rx listens) of the radar constant (energy, gains, noise) times the
    waveform's mean range-migration gain over range-rates uniform in +-``max_range_rate`` (the tracker's initiation
    prior) over its range variance at 10 dB: E[SNR] / var(r) up to the target's unknown RCS and range. This is what
    sets the two-ellipse initiation's accuracy (and its cross-range, with receivers close together). Pure.
    """
    model = getattr(sensor, "model", sensor)  # a signal sensor's parametric model (sensing.signal.model_hooks)
    lib = model.library.waveforms
    rdot = np.linspace(-max_range_rate, max_range_rate, 41)
    per_snr = np.array([float(w.covariance(np.full(1, 10.0))[0][0, 0]) * 10.0 for w in lib])  # var(r) x SNR
    walk = np.array([  # (W,) the mean walk gain; impulses do not walk
        range_migration_gain(rdot, w.range_spread_m, w.config.pri_s, w.config.n_pulses).mean()
        if hasattr(w, "range_spread_m") else 1.0
        for w in lib
    ])  # fmt: skip
    table = _plan_table(plans)
    info = np.zeros(len(plans))
    for tx, rx in model.pairs.tolist():
        used, _, _, _ = table.pair_waveforms(tx, rx)
        w = table.waveforms[used, tx]
        info[used] += model.radar_constant[w, tx, rx] * walk[w] / per_snr[w]
    return info


class _PlanTable:
    """What the lookahead reads of a plan list, computed once per list (plans are read-only once enumerated).

    waveforms ``(A, T)`` the waveform each plan sends per transmitter, listening ``(A, R)``; per pair, the plans
    that use it, the distinct waveforms they send and which one each sends (``pair_waveforms``).
    """

    def __init__(self, plans: Sequence[ScanPlan]) -> None:
        self.plans = plans  # kept alive: the cache is keyed by its identity
        self.waveforms = np.array([p.waveform for p in plans])
        self.listening = _listening(plans)
        self._pairs: dict[tuple[int, int], tuple[BoolArray, np.ndarray, np.ndarray, bool]] = {}
        self._groups: dict[tuple, Any] = {}
        self._rows: dict[tuple, Any] = {}

    def pair_groups(self, pairs: list[list[int]]) -> tuple[list[tuple[np.ndarray, np.ndarray]], np.ndarray] | None:
        """The plans' shared prefixes along the formed ``pairs`` (in the update order), or None if none is shared.

        Pair p's expected update of plan a depends only on the covariance before it and on what the plan does at
        the pair: whether its receiver listens and, if so, the waveform its transmitter sends. Plans that do the same
        at pairs 0..p share their covariance after pair p: one group. Returns, per pair, the groups' representative
        plans ``rep (G_p,)`` and their parent groups before the pair ``(G_p,)``, and every plan's final group
        ``(A,)``, each None where it is the identity (nothing to gather); None when no pair has fewer groups than
        plans (nothing to share: the plain per-plan update).
        Per-tx plans share the first transmitter's pairs: W groups there, not W^T.
        """
        key = tuple(map(tuple, pairs))
        if key not in self._groups:
            A = len(self.plans)
            group = np.zeros(A, np.int64)
            chain = []
            for tx, rx in pairs:
                what = np.where(self.listening[:, rx], self.waveforms[:, tx] + 1, 0)  # 0: not listening
                _, rep, inverse = np.unique(
                    group * (int(what.max()) + 1) + what, return_index=True, return_inverse=True
                )
                parent = group[rep]
                chain.append((rep, parent))
                group = inverse.reshape(A)
            shared = any(rep.size < A for rep, _ in chain)

            def identity(a: np.ndarray, n: int) -> np.ndarray | None:
                return None if a.size == n and np.array_equal(a, np.arange(n)) else a

            sizes = [1] + [rep.size for rep, _ in chain]
            chain = [(identity(r, A), identity(q, sizes[i])) for i, (r, q) in enumerate(chain)]
            self._groups[key] = (chain, identity(group, sizes[-1])) if shared else None
        return self._groups[key]

    def pair_rows(
        self, tx: int, rx: int, groups: tuple | None, p: int
    ) -> tuple[np.ndarray, np.ndarray | None, BoolArray | None, np.ndarray]:
        """Where pair ``p`` = (tx, rx)'s updated plans read their sensor model (``expected_posterior``, cached).

        Returns ``sent (W,)`` (``pair_waveforms``), ``rows (G,)``: each updated plan's row of the pair's model
        ``(W, ...)`` with row W the zeros of a plan whose receiver does not listen (None: row g is plan g's and
        every plan is updated), ``used (G,)`` which rows' plans listen (None: all) and ``waveform (G,)`` the
        waveform each row's plan sends from tx. The updated plans are the groups' representatives after pair p
        (``pair_groups``, ``groups``) or, with ``groups`` None, every plan. Same numbers as scattering the model
        over the A plans and gathering the representatives.
        """
        key = (tx, rx, p, id(groups))
        hit = self._rows.get(key)
        if hit is not None and hit[0] is groups:
            return hit[1]
        used, sent, which, every = self.pair_waveforms(tx, rx)
        rep = None if groups is None else groups[0][p][0]
        rows = np.full(used.size, sent.size, np.int64)
        rows[used] = which
        plans = np.arange(used.size) if rep is None else rep
        used_rows, rows, wf = used[plans], rows[plans], self.waveforms[plans, tx]
        out = (sent, None if every and rep is None else rows, None if used_rows.all() else used_rows, wf)
        self._rows[key] = (groups, out)
        return out

    def pair_waveforms(self, tx: int, rx: int) -> tuple[BoolArray, np.ndarray, np.ndarray, bool]:
        """``(used (A,), sent (W,), which (A_used,), every)`` of pair (tx, rx); every: all plans, sent[a] by plan a."""
        key = (tx, rx)
        if key not in self._pairs:
            used = self.listening[:, rx]
            sent = np.unique(self.waveforms[used, tx])
            which = np.searchsorted(sent, self.waveforms[used, tx])
            every = bool(used.all()) and np.array_equal(which, np.arange(used.size))
            self._pairs[key] = (used, sent, which, every)
        return self._pairs[key]


_PLAN_TABLES: dict[int, _PlanTable] = {}


def _plan_table(plans: Sequence[ScanPlan]) -> _PlanTable:
    """The cached ``_PlanTable`` of this plan list (by identity; a few lists live at a time)."""
    table = _PLAN_TABLES.get(id(plans))
    if table is None or table.plans is not plans:
        if len(_PLAN_TABLES) > 64:
            _PLAN_TABLES.clear()
        table = _PLAN_TABLES[id(plans)] = _PlanTable(plans)
    return table


def _listening(plans: Sequence[ScanPlan]) -> BoolArray:
    """``(A, R)`` the receivers each plan listens with."""
    return np.array([p.active_rx for p in plans])


def _delivering(listening: BoolArray, ready: BoolArray, n_tracks: int) -> BoolArray:
    """``(A, B * N, R)``: plan a's listening receivers ``(A, R)`` that are ready in kept sequence b (``(B, R)``)."""
    both = listening[:, None, None, :] & ready[None, :, None, :]  # (A, B, 1, R)
    A, B, _, R = both.shape
    return np.broadcast_to(both, (A, B, n_tracks, R)).reshape(A, B * n_tracks, R)


def position_trace(P: FloatArray) -> FloatArray:
    """Trace of the position block of ``(..., 6, 6)`` [m^2]."""
    return P[..., 0, 0] + P[..., 2, 2]


def predict_combined(
    x: FloatArray,
    P: FloatArray,
    mu: FloatArray,
    active: BoolArray,
    tracker: MultiTargetTracker,
    dt: float,
    scan_index: int,
) -> tuple[FloatArray, FloatArray, FloatArray, BoolArray]:
    """The tracker's moment-matched prediction of combined estimates to ``scan_index``, ``dt`` later (pure).

    Args: x ``(N, 6)``, P ``(N, 6, 6)``, mu ``(N, r)`` model probabilities on the set ``active`` ``(r,)``
    (``MultiTargetTracker.predict_gaussians``). Returns: predicted x, P, mu and the new set's mask.
    """
    pred = tracker.predict_gaussians(Prediction(x, P, mu, active), dt, scan_index)
    return pred.x, pred.P, pred.mu, pred.active


def sequence_costs(
    sensor: ParametricSensor,
    tracker: MultiTargetTracker,
    plans: Sequence[ScanPlan],
    time_s: float,
    scan_index: int,
    scan_period_s: float,
    depth: int,
    beam: int | None = None,
    discount: float = 1.0,
    q2: float | str = 1.0,
    ready_rx: BoolArray | None = None,
) -> FloatArray:
    """``(A,)`` for every first plan, the cheapest d-scan cost of the sequences that start with it (module docstring).

    ``ready_rx`` ``(R,)``: the receivers ready now under receiver warm-up (None: no warm-up). ``inf`` for a first
    plan whose every sequence the beam pruned. Depth 1 is ``lookahead_costs``. Pure.
    """
    check_search(depth, beam, discount)
    A = len(plans)
    scored = scored_prediction(tracker, time_s, scan_index)
    if scored is None:
        return np.zeros(A)
    x, P, mu, active = scored
    N = x.shape[0]
    first = np.zeros(1, np.int64)  # per kept sequence: its first plan (none yet)
    cum = np.zeros(1)  # per kept sequence: its cost so far
    ready = None if ready_rx is None else np.asarray(ready_rx, bool)[None]  # (B, R) per kept sequence
    listening = _plan_table(plans).listening
    xs, Ps, mus = x[None], P[None], mu[None]  # (B, N, ...) per kept sequence
    for level in range(depth):
        B = cum.size
        delivering = None if ready is None else _delivering(listening, ready, N)
        Pa = expected_posterior(xs.reshape(B * N, 6), Ps.reshape(B * N, 6, 6), sensor, tracker, plans, q2, delivering)
        Pa = Pa.reshape(A, B, N, 6, 6)
        step = position_trace(Pa).mean(axis=-1)  # (A, B)
        total = cum[None] + discount**level * step
        starts = np.broadcast_to(np.arange(A)[:, None], (A, B)) if level == 0 else np.broadcast_to(first, (A, B))
        flat = total.ravel()
        order = np.argsort(flat, kind="stable")
        if beam is not None and level < depth - 1:
            order = order[:beam]
        if level == depth - 1:
            costs = np.full(A, np.inf)
            np.minimum.at(costs, starts.ravel()[order], flat[order])
            return costs
        ai, bi = np.unravel_index(order, (A, B))
        first, cum = starts[ai, bi], flat[order]
        if ready is not None:  # the next scan's ready receivers: those this scan's plan listens with
            ready = listening[ai]
        k = scan_index + level + 1
        x2, P2, mu2, active2 = predict_combined(
            xs[bi].reshape(-1, 6),
            Pa[ai, bi].reshape(-1, 6, 6),
            mus[bi].reshape(-1, mu.shape[1]),
            active,
            tracker,
            scan_period_s,
            k,
        )
        xs, Ps, mus, active = x2.reshape(-1, N, 6), P2.reshape(-1, N, 6, 6), mu2.reshape(-1, N, mu.shape[1]), active2
    raise AssertionError("unreachable")
