r"""A ceiling: the best open-loop schedule, by exhaustive (pruned) search on the expected covariance recursion.

Clairvoyant, open-loop, on the model. Along an episode's TRUE target trajectories (``Simulator.truth``), every
target n carries a covariance that follows seed 003's expected covariance recursion (eq. 7, ``uwb_env.lookahead``)
under the plans a_1, a_2, ... played at scans k + 1, k + 2, ...:

    P_n(b_n)   = P0                                       at its birth scan b_n (first alive scan; the tracker's
                                                          two-point initiation covariance, ``initiation_covariance``,
                                                          or a given P0)
    P_n^-(l)   = the tracker's moment-matched prediction of (x_n(l - 1), P_n(l - 1))  (``predict_combined``)
    P_n(l)     = expected posterior of P_n^-(l) under plan a_l, linearised at the true state x_n(l), with the
                 sensor model's P_D and R at the true position and velocity (``expected_posterior``: per formed pair
                 S = H P H^T + Omega + R, K = P H^T S^-1, P <- P - P_D q_2 K S K^T)
    cost(a_1 .. a_H from scan k) = sum_{l = k+1}^{k+H} mean over the targets alive at l of trace(P_n(l) [x, y])

The model probabilities mu of a target start uniform over its birth scan's model set and follow mu^- = Pi^T mu
(no measurement moves them in the recursion); they and the linearisation points do not depend on the plans.

The optimum over all A^H plan sequences is found by a level-wise search, batched over the frontier (numpy; one
expected-update call per level), with two exact prunings:

(a) branch and bound: every step's cost is >= 0, so a prefix whose cost reaches the incumbent (the cheapest complete
    sequence found so far) cannot lead to a cheaper one and is cut. Incumbents come early from greedy rollouts
    (myopic on the truth) of the root and of the cheapest prefixes of every level (the children ordered by their
    cost so far).
(b) dominance (Vitus, Zhang, Abate, Hu, Tomlin, "On efficient sensor scheduling for linear dynamical systems",
    Automatica 48 (2012)): at the same depth, a prefix whose covariances are >= another prefix's in the Loewner order
    for every alive target, with a cost so far >= the other's (and, under receiver warm-up, no ready receiver the
    other lacks), is dropped: the recursion is monotone in P, so every continuation of it costs at least as much as
    the same continuation of the other. Monotonicity needs the measurement matrix H to be independent of P: it
    holds for the EKF form (H the Jacobian at the true state, Omega = 0; the expected update
    P - P_D K S K^T = (1 - P_D) P + P_D (P^-1 + H^T R^-1 H)^-1 is monotone, and so are the prediction
    sum_j mu_j (F_j P F_j^T + Q_j) + spread and the range-rate ambiguity switch, which drops the range-rate row
    only where S0 = H P H^T is large, i.e. for the larger P first). The unscented transform's statistical
    linearisation H = C^T P^-1 and its Omega depend on P, which breaks the argument, and so does q_2 = "pda"
    (q_2 depends on S). The recursion therefore linearises with the EKF by default (``linearisation="ekf"``,
    whatever the tracker filters with: at the true state the Jacobian is the exact local model); with ``"ukf"`` or
    ``q2="pda"`` the dominance prune is switched off and only (a) is used, which stays exact. The Loewner test is
    an eigenvalue test to a relative tolerance ``DOMINANCE_RTOL`` (rounding): the result is exact to that. Only the
    ``MAX_DOMINATORS`` cheapest prefixes of a level are tried as dominators (a dominator is the cheaper one; the
    all-pairs test grew as M^2 and took 77 s per window at H = 7 on UrbanWideband-v2): dropping fewer stays exact.

Cost of the search (``benchmarks/ceiling.py``, UrbanWideband-v2, A = 8, medians over 10 windows on a shared 2-core
machine): H = 4 in 16 ms (brute force 233 ms), 7.6 % of the A^H leaves scored; H = 5 104 ms (2.9 s), 3.8 %;
H = 6 193 ms, 2.4 % (branch and bound alone: 902 ms, 60 %).

What this is and is not: an optimistic reference for the schedulers of ``agents.schedulers``. It knows the truth,
ignores the tracker's actual state (association, missed detections, false tracks) and optimises the model's
expected cost; its realised metrics in an episode (``Ceiling``) are those of an open-loop schedule computed from
the truth, not of a causal scheduler. ``schedule_cost`` scores any schedule (a campaign's logged actions) on the
same model.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from uwb_env.lookahead import _delivering, check_q2, expected_posterior, position_trace, predict_combined
from uwb_env.sensing.records import ScanPlan
from uwb_env.tracking import compiled
from uwb_env.tracking.expectation import gaussian_expected_update
from uwb_env.typing import BoolArray, FloatArray, IntArray

LINEARISATIONS = ("ekf", "ukf")
DOMINANCE_RTOL = 1e-9
"""Relative tolerance of the Loewner and cost comparisons of the dominance prune (rounding, not modelling)."""
MAX_DOMINATORS = 256
"""The cheapest prefixes of a level tried as dominators of the others (``_undominated``)."""
_PAIR_CHUNK = 2_000_000  # most (i, j, target, diagonal) entries compared at once in the dominance prune
_EIG_CHUNK = 32_768  # most pairs whose difference's eigenvalues are computed at once


# ---------------------------------------------------------------------------------------------- recursion state
@dataclass(frozen=True, slots=True)
class RecursionState:
    """B states of the recursion after scan ``scan`` (B prefixes of a search, or B schedules being scored).

    Attributes:
        scan: the scan just played (0: the reset instant).
        P: ``(B, K, n, n)`` each target's covariance (only the targets ``alive`` at ``scan`` matter).
        mu: ``(K, r)`` model probabilities (plan-independent, shared by the B rows); active: ``(r,)`` the model set.
        ready: ``(B, R)`` the receivers able to deliver at the next scan (receiver warm-up); None without warm-up.
    """

    scan: int
    P: FloatArray
    mu: FloatArray
    active: BoolArray
    ready: BoolArray | None

    @property
    def size(self) -> int:
        """B, the number of rows."""
        return int(self.P.shape[0])

    def rows(self, index: IntArray | BoolArray) -> RecursionState:
        """The rows ``index`` (an index or mask array)."""
        return RecursionState(
            self.scan, self.P[index], self.mu, self.active, None if self.ready is None else self.ready[index]
        )

    def repeat(self, n: int) -> RecursionState:
        """Each row repeated ``n`` times (row-major: row b becomes rows b n .. b n + n - 1)."""
        return self.rows(np.repeat(np.arange(self.size), n))


# ------------------------------------------------------------------------------------------------- recursions
class _Linearised:
    """The tracker as ``expected_posterior`` sees it, with a chosen linearisation (``"ekf"`` / ``"ukf"``)."""

    def __init__(self, cfg: Any, filter: str) -> None:
        self.cfg, self.filter = cfg, filter

    def expected_update(self, Pa, x, P, names, tx_pos, rx_pos, R, pd, reduction, rho, period) -> FloatArray:
        """``expectation.gaussian_expected_update`` with this linearisation."""
        return gaussian_expected_update(self.filter, Pa, x, P, names, tx_pos, rx_pos, R, pd, reduction, rho, period)


def initiation_covariance(tracker_cfg: Any, scan_period_s: float, position_std_m: float | None = None) -> FloatArray:
    """``(6, 6)`` the covariance the tracker gives a new track, for candidates of position std ``position_std_m``.

    Two-point differencing (seed 003 section 4.2.1, ``compiled.new_track_states``) of two isotropic candidates
    of variance ``position_std_m^2`` one scan apart: the velocity from their difference with the prior
    N(0, (v_max / 2)^2), acceleration std ``initial_accel_std_mps2``. Default std: ``init_max_position_std_m``, the
    coarsest candidate the tracker accepts (a conservative start, the same for every schedule compared).
    """
    std = tracker_cfg.init_max_position_std_m if position_std_m is None else position_std_m
    if not (isinstance(std, (int, float)) and np.isfinite(std) and std > 0):
        raise ValueError(f"position_std_m={position_std_m!r}: must be a finite number > 0 [m]")
    if not (np.isfinite(scan_period_s) and scan_period_s > 0):
        raise ValueError(f"scan_period_s={scan_period_s!r}: must be a finite number > 0 [s]")
    cov = np.eye(2)[None] * float(std) ** 2
    _, P = compiled.new_track_states(
        np.zeros((1, 2)), cov, np.zeros((1, 2)), cov.copy(), float(scan_period_s),
        float(tracker_cfg.max_speed_mps), float(tracker_cfg.initial_accel_std_mps2),
    )  # fmt: skip
    return P[0]


class TruthRecursion:
    """The expected covariance recursion along an episode's true trajectories (module docstring).

    Args:
        sensor: the parametric sensor model (``ParametricSensor``: ``expected_measurements``, ``pairs``, ...).
        tracker: the tracker whose motion models predict (``predict_gaussians``) and whose ``cfg`` gives the
            sensor-model assumptions (assumed RCS, Pd cap, range-rate floor).
        plans: the env's plan list (action a is ``plans[a]``).
        states: ``(S, K, 6)`` true ``[x, vx, y, vy, ax, ay]`` per scan 0 .. S - 1; alive: ``(S, K)``.
        scan_period_s: the scan period [s].
        P0: ``(6, 6)`` start covariance of every target at its birth scan; None: ``initiation_covariance``.
        position_std_m: the candidate std of ``initiation_covariance`` (only without P0).
        linearisation: ``"ekf"`` (default; the dominance prune is exact) or ``"ukf"`` (the unscented transform at
            the true state with the predicted P; dominance off).
        q2: the information-reduction factor (``lookahead.check_q2``); ``"pda"`` switches dominance off.
        receiver_warmup: a receiver delivers only if it listened in the previous scan (``uwb_env.lookahead``).
        valid: ``(A,)`` the actions the search may use (``action_masks()``); None: all.
    """

    def __init__(
        self,
        sensor: Any,
        tracker: Any,
        plans: Sequence[ScanPlan],
        states: FloatArray,
        alive: BoolArray,
        scan_period_s: float,
        *,
        P0: FloatArray | None = None,
        position_std_m: float | None = None,
        linearisation: str = "ekf",
        q2: float | str = 1.0,
        receiver_warmup: bool = False,
        valid: BoolArray | None = None,
    ) -> None:
        if linearisation not in LINEARISATIONS:
            raise ValueError(f"linearisation={linearisation!r}: must be one of {LINEARISATIONS}")
        check_q2(q2)
        states, alive = np.asarray(states, dtype=float), np.asarray(alive)
        if states.ndim != 3 or states.shape[2] != 6 or states.shape[0] < 2:
            raise ValueError(f"states shape {states.shape}: must be (S >= 2, K, 6)")
        if alive.shape != states.shape[:2] or alive.dtype != bool:
            raise ValueError(f"alive shape {alive.shape} dtype {alive.dtype}: must be bool {states.shape[:2]}")
        if not np.isfinite(states[alive]).all():
            raise ValueError("states: not finite where alive")
        self.plans = list(plans)
        A = len(self.plans)
        self.valid = np.ones(A, bool) if valid is None else np.asarray(valid, dtype=bool)
        if self.valid.shape != (A,) or not self.valid.any():
            raise ValueError(f"valid={valid!r}: must be a bool array of shape ({A},) with at least one True")
        self.P0 = (
            initiation_covariance(tracker.cfg, scan_period_s, position_std_m)
            if P0 is None
            else _check_covariance("P0", P0, 6)
        )
        self.sensor, self.tracker, self.states, self.alive = sensor, tracker, states, alive
        self.scan_period_s = float(scan_period_s)
        self.linearisation, self.q2, self.receiver_warmup = linearisation, q2, bool(receiver_warmup)
        self._linearised = _Linearised(tracker.cfg, linearisation)
        self._listening = np.array([p.active_rx for p in self.plans])
        self._plan_lists: dict[tuple[int, ...], list[ScanPlan]] = {}

    @classmethod
    def from_env(cls, env: Any, **kwargs: Any) -> TruthRecursion:
        """The recursion of the episode ``env`` is playing (after ``reset``): its truth, sensor, tracker, plans.

        Takes the env's q_2, receiver warm-up and action mask unless given in ``kwargs``.
        """
        e = env.unwrapped
        kwargs.setdefault("q2", e.lookahead_q2)
        kwargs.setdefault("receiver_warmup", e.receiver_warmup)
        kwargs.setdefault("valid", e.action_masks())
        truth = e.sim.truth
        return cls(
            e.sim.sensor, e.sim.tracker, e.plans, truth.states, truth.alive, e.cfg.sensing.scan_period_s, **kwargs
        )

    # ---------------------------------------------------------------------------------------- the recursion
    @property
    def n_scans(self) -> int:
        """The last scan index S - 1."""
        return self.states.shape[0] - 1

    @property
    def actions(self) -> IntArray:
        """The valid actions, in order."""
        return np.flatnonzero(self.valid)

    @property
    def dominance_exact(self) -> bool:
        """Whether the recursion is monotone in P (EKF form, constant q_2): the dominance prune is exact."""
        return self.linearisation == "ekf" and not isinstance(self.q2, str)

    def _model_set(self, scan: int) -> BoolArray:
        names = self.tracker.model_names
        if len(names) == 1:
            return np.ones(1, bool)
        active = self.tracker.cfg.active_models(scan)
        return np.array([n in active for n in names])

    def initial_state(self) -> RecursionState:
        """The state at scan 0: every target alive then at P0, mu uniform over the model set, all receivers ready."""
        active = self._model_set(0)
        K = self.states.shape[1]
        mu = np.broadcast_to(active / active.sum(), (K, active.size)).copy()
        R = self._listening.shape[1]
        ready = np.ones((1, R), bool) if self.receiver_warmup else None
        return RecursionState(0, np.broadcast_to(self.P0, (1, K, 6, 6)).copy(), mu, active, ready)

    def cost_targets(self, scan: int) -> BoolArray:
        """``(K,)`` the targets whose covariance counts at ``scan`` (and the dominance test compares)."""
        return self.alive[scan]

    def _plans(self, actions: IntArray) -> list[ScanPlan]:
        key = tuple(int(a) for a in actions)
        plans = self._plan_lists.get(key)
        if plans is None:
            if len(self._plan_lists) > 64:
                self._plan_lists.clear()
            plans = self._plan_lists[key] = [self.plans[a] for a in key]
        return plans

    def expand(self, state: RecursionState, actions: IntArray) -> tuple[RecursionState, FloatArray]:
        """Every row of ``state`` under every action of ``actions`` (A'), one scan on.

        Returns the children (A' B rows, action-major: row i B + b is row b under ``actions[i]``) and their step
        costs ``(A', B)`` [m^2]: the mean over the targets alive at the new scan of trace(P [x, y]) (0: none).
        """
        k = state.scan + 1
        if k > self.n_scans:
            raise ValueError(f"scan {k}: past the episode's last scan {self.n_scans}")
        actions = np.asarray(actions, dtype=np.int64)
        A, B = actions.size, state.size
        K = self.states.shape[1]
        alive, before = self.alive[k], self.alive[k - 1]
        cont = np.flatnonzero(alive & before)
        born = alive & ~before
        P = np.empty((A, B, K, 6, 6))
        P[:] = state.P[None]
        P[:, :, born] = self.P0
        mu = state.mu.copy()
        active = self._model_set(k)
        if cont.size:
            n = cont.size
            r = state.mu.shape[1]
            x_prev = np.broadcast_to(self.states[k - 1, cont], (B, n, 6)).reshape(-1, 6)
            mu_rows = np.broadcast_to(state.mu[cont], (B, n, r)).reshape(-1, r)
            _, Pp, mu_p, active = predict_combined(
                x_prev, state.P[:, cont].reshape(-1, 6, 6), mu_rows, state.active, self.tracker, self.scan_period_s, k
            )
            mu[cont] = mu_p[:n]
            delivering = (
                None if state.ready is None else _delivering(self._listening[actions], state.ready, n)
            )  # (A, B n, R)
            x_true = np.broadcast_to(self.states[k, cont], (B, n, 6)).reshape(-1, 6)
            Pa = expected_posterior(
                x_true, Pp, self.sensor, self._linearised, self._plans(actions), self.q2, delivering
            )
            P[:, :, cont] = Pa.reshape(A, B, n, 6, 6)
        mu[born] = active / active.sum()
        counted = self.cost_targets(k)
        step = position_trace(P[:, :, counted]).mean(axis=-1) if counted.any() else np.zeros((A, B))
        ready = None
        if state.ready is not None:
            ready = np.broadcast_to(self._listening[actions][:, None], (A, B, state.ready.shape[1]))
            ready = ready.reshape(A * B, -1).copy()
        return RecursionState(k, P.reshape(A * B, K, 6, 6), mu, active, ready), step


class LinearGaussianRecursion:
    r"""The Kalman filter's expected Riccati recursion of K targets with one linear model (tests, examples).

    P^- = F P F^T + Q;   plan a: S = H_a P^- H_a^T + R_a, K = P^- H_a^T S^-1, P = P^- - P_D,a K S K^T
    (the expected covariance of a filter updated with probability P_D,a). Step cost: mean over the K targets of
    trace(P[cost_index]). H independent of P: monotone, the dominance prune is exact.

    Args: F, Q ``(n, n)``; H ``(A, m, n)``, R ``(A, m, m)``, pd ``(A,)`` in [0, 1]; P0 ``(K, n, n)`` or ``(n, n)``;
    cost_index: the state components whose variances are summed (default all); n_scans: the horizon available.
    """

    def __init__(
        self,
        F: FloatArray,
        Q: FloatArray,
        H: FloatArray,
        R: FloatArray,
        pd: FloatArray,
        P0: FloatArray,
        cost_index: Sequence[int] | None = None,
        n_scans: int = 1000,
    ) -> None:
        F, Q, H, R, pd = (np.asarray(v, dtype=float) for v in (F, Q, H, R, pd))
        n = F.shape[0]
        if F.shape != (n, n):
            raise ValueError(f"F shape {F.shape}: must be square (n, n)")
        _check_covariance("Q", Q, n, semi=True)
        if H.ndim != 3 or H.shape[2] != n:
            raise ValueError(f"H shape {H.shape}: must be (A, m, {n})")
        A, m = H.shape[:2]
        for a in range(A):  # a few plans: validation only
            _check_covariance(f"R[{a}]", R[a] if R.shape == (A, m, m) else R, m)
        if R.shape != (A, m, m):
            raise ValueError(f"R shape {R.shape}: must be ({A}, {m}, {m})")
        if pd.shape != (A,) or not ((pd >= 0) & (pd <= 1)).all():
            raise ValueError(f"pd={pd!r}: must be ({A},) values in [0, 1]")
        P0 = np.asarray(P0, dtype=float)
        P0 = P0[None] if P0.ndim == 2 else P0
        for i in range(P0.shape[0]):
            _check_covariance(f"P0[{i}]", P0[i], n)
        self.F, self.Q, self.H, self.R, self.pd, self.P0 = F, Q, H, R, pd, P0
        self.cost_index = np.arange(n) if cost_index is None else np.asarray(cost_index, dtype=np.int64)
        self.n_scans = int(n_scans)
        self.actions = np.arange(A)
        self.dominance_exact = True

    def initial_state(self) -> RecursionState:
        """Scan 0, every target at its P0 (one model, no warm-up)."""
        K = self.P0.shape[0]
        return RecursionState(0, self.P0[None].copy(), np.ones((K, 1)), np.ones(1, bool), None)

    def cost_targets(self, scan: int) -> BoolArray:
        """Every target counts at every scan."""
        return np.ones(self.P0.shape[0], bool)

    def expand(self, state: RecursionState, actions: IntArray) -> tuple[RecursionState, FloatArray]:
        """``TruthRecursion.expand`` for the linear model: children action-major and step costs ``(A', B)``."""
        if state.scan + 1 > self.n_scans:
            raise ValueError(f"scan {state.scan + 1}: past the last scan {self.n_scans}")
        actions = np.asarray(actions, dtype=np.int64)
        Pp = self.F @ state.P @ self.F.T + self.Q  # (B, K, n, n)
        H, R, pd = self.H[actions][:, None, None], self.R[actions][:, None, None], self.pd[actions]
        PHt = Pp[None] @ np.swapaxes(H, -1, -2)  # (A, B, K, n, m)
        S = H @ PHt + R
        P = Pp[None] - pd[:, None, None, None, None] * PHt @ np.linalg.solve(S, np.swapaxes(PHt, -1, -2))
        P = 0.5 * (P + np.swapaxes(P, -1, -2))
        ci = self.cost_index
        step = P[..., ci, ci].sum(axis=-1).mean(axis=-1)
        A, B = step.shape
        return RecursionState(state.scan + 1, P.reshape(A * B, *P.shape[2:]), state.mu, state.active, None), step


def _check_covariance(name: str, P: FloatArray, n: int, semi: bool = False) -> FloatArray:
    """``P`` as a float ``(n, n)`` array, raising unless it is finite, symmetric and positive (semi-)definite."""
    P = np.asarray(P, dtype=float)
    if P.shape != (n, n) or not np.isfinite(P).all() or not np.allclose(P, P.T, rtol=1e-9, atol=1e-12):
        raise ValueError(f"{name}: must be a finite symmetric ({n}, {n}) matrix (got shape {P.shape})")
    lo = np.linalg.eigvalsh(P).min()
    if lo < 0 or (lo == 0 and not semi):
        raise ValueError(f"{name}: must be positive {'semi-' if semi else ''}definite (least eigenvalue {lo:g})")
    return P


# ---------------------------------------------------------------------------------------------- scoring
def advance(recursion: Any, state: RecursionState, actions: IntArray) -> tuple[RecursionState, FloatArray]:
    """Row b of ``state`` under its own action ``actions[b]``, one scan on; returns the rows and their costs ``(B,)``.

    One ``expand`` per distinct action (at most A calls), not per row.
    """
    actions = np.asarray(actions, dtype=np.int64)
    if actions.shape != (state.size,):
        raise ValueError(f"actions shape {actions.shape}: must be ({state.size},), one per row")
    P = np.empty_like(state.P)
    ready = None if state.ready is None else np.empty_like(state.ready)
    cost = np.empty(state.size)
    mu, active = state.mu, state.active
    for a in np.unique(actions):  # the distinct actions: at most A
        rows = np.flatnonzero(actions == a)
        child, step = recursion.expand(state.rows(rows), np.array([a]))
        P[rows], cost[rows], mu, active = child.P, step[0], child.mu, child.active
        if ready is not None:
            ready[rows] = child.ready
    return RecursionState(state.scan + 1, P, mu, active, ready), cost


def schedule_cost(recursion: Any, actions: Any, start: RecursionState | None = None) -> FloatArray:
    """The recursion's cost of action sequences ``actions`` ``(H,)`` or ``(M, H)`` from ``start`` [m^2].

    ``start``: a one-row state (default: scan 0); the sequences play scans start.scan + 1 .. start.scan + H. Returns
    a float for one sequence, ``(M,)`` for M. Use it to score any schedule (a campaign's logged actions) on the model.
    """
    seq = np.asarray(actions)
    if seq.dtype.kind not in "iu" or seq.ndim not in (1, 2) or seq.shape[-1] < 1:
        raise ValueError(f"actions shape {seq.shape} dtype {seq.dtype}: must be integer (H,) or (M, H), H >= 1")
    rows = seq[None] if seq.ndim == 1 else seq
    n_actions = len(recursion.plans) if hasattr(recursion, "plans") else recursion.H.shape[0]
    if rows.min() < 0 or rows.max() >= n_actions:
        raise ValueError(f"actions: values in [{rows.min()}, {rows.max()}]; must be in [0, {n_actions - 1}]")
    state = (recursion.initial_state() if start is None else start).repeat(1)
    if state.size != 1:
        raise ValueError(f"start: {state.size} rows; must be one")
    state = state.repeat(rows.shape[0])
    total = np.zeros(rows.shape[0])
    for col in rows.T:  # the H scans
        state, cost = advance(recursion, state, col)
        total += cost
    return total[0] if seq.ndim == 1 else total


def greedy_schedule(recursion: Any, state: RecursionState, horizon: int) -> tuple[IntArray, FloatArray, int]:
    """Myopic on the recursion: every row plays, scan after scan, the action of least step cost (ties: lowest).

    Returns the actions ``(B, horizon)``, the total costs ``(B,)`` and the number of nodes scored (A B horizon).
    """
    acts = recursion.actions
    seqs = np.zeros((state.size, horizon), np.int64)
    total = np.zeros(state.size)
    scored = 0
    for level in range(horizon):
        children, step = recursion.expand(state, acts)  # (A, B)
        best = np.argmin(step, axis=0)
        B = state.size
        state = children.rows(best * B + np.arange(B))
        seqs[:, level] = acts[best]
        total += step[best, np.arange(B)]
        scored += step.size
    return seqs, total, scored


# ------------------------------------------------------------------------------------------------- search
@dataclass(frozen=True, slots=True)
class SearchResult:
    """The optimal schedule of a window and the work it took.

    Attributes:
        actions: ``(H,)`` the optimal actions; cost: their cost [m^2].
        expanded: nodes whose children were scored (partial sequences, root included).
        scored: nodes (partial and complete sequences) whose covariances the search computed.
        leaves: complete sequences scored.
        rollout_scored: nodes scored by the greedy rollouts that supply incumbents.
        n_actions: A (valid actions); horizon: H.
    """

    actions: IntArray
    cost: float
    expanded: int
    scored: int
    leaves: int
    rollout_scored: int
    n_actions: int
    horizon: int

    @property
    def full_leaves(self) -> int:
        """A^H: the complete sequences of an exhaustive enumeration."""
        return self.n_actions**self.horizon

    @property
    def full_scored(self) -> int:
        """A + A^2 + ... + A^H: the nodes of the unpruned tree."""
        return sum(self.n_actions**level for level in range(1, self.horizon + 1))


def optimal_schedule(
    recursion: Any,
    start: RecursionState | None,
    horizon: int,
    *,
    dominance: bool | None = None,
    rollouts: int = 4,
    max_dominators: int = MAX_DOMINATORS,
) -> SearchResult:
    """The cheapest ``horizon``-scan action sequence from ``start`` (module docstring: (a) and (b)).

    Args:
        recursion: a ``TruthRecursion`` (or ``LinearGaussianRecursion``); start: a one-row state (None: scan 0).
        dominance: prune dominated prefixes; None: where exact (``recursion.dominance_exact``); True where it is not
            exact raises.
        rollouts: greedy rollouts per level from the cheapest surviving prefixes (incumbents; 0: root only).
        max_dominators: the cheapest prefixes of a level tried as dominators (``_undominated``), >= 1.
    """
    if not isinstance(horizon, (int, np.integer)) or isinstance(horizon, bool) or horizon < 1:
        raise ValueError(f"horizon={horizon!r}: must be an integer >= 1")
    if not isinstance(rollouts, (int, np.integer)) or isinstance(rollouts, bool) or rollouts < 0:
        raise ValueError(f"rollouts={rollouts!r}: must be an integer >= 0")
    if not isinstance(max_dominators, (int, np.integer)) or isinstance(max_dominators, bool) or max_dominators < 1:
        raise ValueError(f"max_dominators={max_dominators!r}: must be an integer >= 1")
    exact = bool(recursion.dominance_exact)
    if dominance is None:
        dominance = exact
    elif dominance and not exact:
        raise ValueError(
            "dominance=True: the recursion is not monotone in P (UKF linearisation or q2='pda'): must be None or False"
        )
    state = recursion.initial_state() if start is None else start
    if state.size != 1:
        raise ValueError(f"start: {state.size} rows; must be one")
    last = recursion.n_scans
    if state.scan + horizon > last:
        raise ValueError(f"horizon={horizon}: scans {state.scan + 1}..{state.scan + horizon} pass the last scan {last}")
    acts = recursion.actions
    A = acts.size
    inc_seq, inc_cost, rollout_scored = greedy_schedule(recursion, state, horizon)  # the first incumbent
    inc_seq, inc_cost = inc_seq[0], float(inc_cost[0])
    seqs = np.zeros((1, 0), np.int64)
    cum = np.zeros(1)
    expanded = scored = leaves = 0
    for level in range(horizon):
        B = state.size
        children, step = recursion.expand(state, acts)
        expanded += B
        scored += A * B
        total = (cum[None] + step).ravel()  # action-major, like the children
        child_seqs = np.concatenate([np.tile(seqs, (A, 1)), np.repeat(acts, B)[:, None]], axis=1)
        if level == horizon - 1:
            leaves = total.size
            best = int(np.argmin(total))
            if total[best] < inc_cost:
                inc_cost, inc_seq = float(total[best]), child_seqs[best]
            break
        keep = np.flatnonzero(total < inc_cost)  # (a) branch and bound: step costs are >= 0
        keep = keep[np.argsort(total[keep], kind="stable")]  # cheapest first
        if dominance and keep.size > 1:
            kept = children.rows(keep)
            compared = kept.P[:, recursion.cost_targets(kept.scan)]
            keep = keep[_undominated(compared, total[keep], kept.ready, max_dominators)]
        state, cum, seqs = children.rows(keep), total[keep], child_seqs[keep]
        if rollouts and state.size and level < horizon - 2:  # incumbents from the cheapest prefixes
            n = min(rollouts, state.size)
            tail, tail_cost, work = greedy_schedule(recursion, state.rows(np.arange(n)), horizon - level - 1)
            rollout_scored += work
            j = int(np.argmin(cum[:n] + tail_cost))
            if cum[j] + tail_cost[j] < inc_cost:
                inc_cost, inc_seq = float(cum[j] + tail_cost[j]), np.concatenate([seqs[j], tail[j]])
            cut = cum < inc_cost
            state, cum, seqs = state.rows(cut), cum[cut], seqs[cut]
        if state.size == 0:  # every prefix cut: the incumbent is optimal
            break
    return SearchResult(
        np.asarray(inc_seq, np.int64), inc_cost, expanded, scored, leaves, rollout_scored, A, int(horizon)
    )


def _undominated(
    P: FloatArray, cost: FloatArray, ready: BoolArray | None, max_dominators: int = MAX_DOMINATORS
) -> IntArray:
    """Indices of the prefixes that no other dominates (module docstring (b)), in order.

    ``P (M, N, n, n)`` the compared targets' covariances, ``cost (M,)`` sorted ascending, ``ready (M, R)`` or None.
    i dominates j: cost_i <= cost_j, P_j - P_i >= 0 for every target (least eigenvalue >= -rtol trace P_j) and
    ready_i >= ready_j. Only the ``max_dominators`` cheapest prefixes are tried as dominators (dropping fewer is
    still exact; a dominator must be cheaper, so the cheap ones are where they are). Of prefixes that dominate each
    other (equal to rounding) the first is kept. Candidate pairs pass the necessary conditions on costs and
    diagonals (chunked), then the eigenvalue test (chunked; a prefix already dropped is not tested again).
    """
    M, N, n = P.shape[0], P.shape[1], P.shape[2]
    if N == 0:  # nothing to compare: every prefix is as good as the cheapest for the future
        return np.arange(min(M, 1))
    D = min(M, max_dominators)
    diag = np.diagonal(P, axis1=-2, axis2=-1).reshape(M, N * n)
    scale = np.trace(P, axis1=-2, axis2=-1)  # (M, N)
    tol_diag = DOMINANCE_RTOL * np.repeat(scale, n, axis=1)  # (M, N n)
    cost_tol = cost * (1.0 + DOMINANCE_RTOL) + 1e-300
    rows = max(1, _PAIR_CHUNK // max(1, M * N * n))
    pi, pj = [], []
    for lo in range(0, D, rows):  # chunks of candidate dominators i
        i = np.arange(lo, min(lo + rows, D))
        cand = cost[i][:, None] <= cost_tol[None, :]
        cand &= (diag[i][:, None] <= diag[None] + tol_diag[None]).all(axis=-1)
        if ready is not None:
            cand &= (ready[i][:, None] | ~ready[None]).all(axis=-1)
        cand[np.arange(i.size), i] = False
        a, b = np.nonzero(cand)
        pi.append(i[a])
        pj.append(b)
    ii, jj = np.concatenate(pi), np.concatenate(pj)
    keep = np.ones(M, bool)
    inner = jj < D  # among the dominators: ties resolved by order
    di, dj = ii[inner], jj[inner]
    if di.size:
        ok = _loewner_ge(P, scale, dj, di)
        di, dj = di[ok], dj[ok]
        mutual = np.isin(dj * M + di, di * M + dj)
        keep[dj[~mutual | (di < dj)]] = False
    oi, oj = ii[~inner], jj[~inner]  # the others: any dominator drops them (they dominate nobody here)
    for lo in range(0, oi.size, _EIG_CHUNK):
        i, j = oi[lo : lo + _EIG_CHUNK], oj[lo : lo + _EIG_CHUNK]
        live = keep[j]
        i, j = i[live], j[live]
        if i.size:
            keep[j[_loewner_ge(P, scale, j, i)]] = False
    return np.flatnonzero(keep)


def _loewner_ge(P: FloatArray, scale: FloatArray, j: IntArray, i: IntArray) -> BoolArray:
    """``(pairs,)`` P[j] >= P[i] in the Loewner order for every target, to ``DOMINANCE_RTOL`` (chunked)."""
    out = np.empty(i.size, bool)
    for lo in range(0, i.size, _EIG_CHUNK):
        a, b = i[lo : lo + _EIG_CHUNK], j[lo : lo + _EIG_CHUNK]
        least = np.linalg.eigvalsh(P[b] - P[a]).min(axis=-1)  # (pairs, N)
        out[lo : lo + _EIG_CHUNK] = (least >= -DOMINANCE_RTOL * scale[b]).all(axis=-1)
    return out


def brute_force_schedule(recursion: Any, start: RecursionState | None, horizon: int) -> tuple[IntArray, float]:
    """The cheapest sequence by scoring all A^H with ``schedule_cost`` (no pruning; for tests and small A^H)."""
    acts = recursion.actions
    seqs = np.array(list(itertools.product(acts, repeat=horizon)), dtype=np.int64)
    costs = schedule_cost(recursion, seqs, start)
    best = int(np.argmin(costs))
    return seqs[best], float(costs[best])


# ----------------------------------------------------------------------------------------------- scheduler
class Ceiling:
    """Clairvoyant receding-horizon scheduler on the truth recursion: the optimal H-scan schedule's first action.

    At every scan it optimises the next ``horizon`` scans (``optimal_schedule``, exact) on the episode's truth
    recursion from the state reached by the actions it played, plays the first action and re-plans (receding
    horizon: cheaper per window than block-wise plans and it never commits to a window's last, end-effect actions;
    near the episode's end the horizon shrinks to the scans left). It reads the truth from ``env.unwrapped.sim`` at
    the first scan of an episode and ignores the tracker's actual state: an open-loop schedule computed from the
    truth, an optimistic reference, not a causal scheduler.

    Args: horizon H >= 1; linearisation, position_std_m: the recursion's (``TruthRecursion``).
    """

    def __init__(self, horizon: int = 3, linearisation: str = "ekf", position_std_m: float | None = None) -> None:
        if not isinstance(horizon, (int, np.integer)) or isinstance(horizon, bool) or horizon < 1:
            raise ValueError(f"horizon={horizon!r}: must be an integer >= 1")
        if linearisation not in LINEARISATIONS:
            raise ValueError(f"linearisation={linearisation!r}: must be one of {LINEARISATIONS}")
        self.horizon, self.linearisation, self.position_std_m = int(horizon), linearisation, position_std_m
        self.name = f"ceiling-{horizon}"
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        """Forget the episode (the next ``act`` reads the new truth); deterministic, ``seed`` unused."""
        self._recursion: TruthRecursion | None = None
        self._truth: Any = None
        self._state: RecursionState | None = None
        self._played: list[int] = []
        self.last_search: SearchResult | None = None

    def act(self, obs: Any, env: Any) -> Any:
        """The env's action for the first plan of the optimal schedule of the next ``horizon`` scans.

        The search runs over plan indices (``env.plans``); the returned action is the env's for that plan
        (``action_of_plan``: the index itself for a ``Discrete`` space, per-transmitter waveforms for
        ``MultiDiscrete``).
        """
        e = env.unwrapped
        k = int(e.sim.k)
        if self._recursion is None or e.sim.truth is not self._truth or k < len(self._played):
            self._recursion = TruthRecursion.from_env(
                env, linearisation=self.linearisation, position_std_m=self.position_std_m
            )
            self._truth, self._played = e.sim.truth, []
            self._state = self._recursion.initial_state()
        assert self._state is not None
        if k != len(self._played):
            raise RuntimeError(
                f"Ceiling: the env is at scan {k} but this scheduler chose {len(self._played)} actions this "
                "episode: it must choose every action of the episode"
            )
        h = min(self.horizon, self._recursion.n_scans - k)
        result = optimal_schedule(self._recursion, self._state, h)
        a = int(result.actions[0])
        self.last_search = result
        self._state, _ = advance(self._recursion, self._state, np.array([a]))
        self._played.append(a)
        return e.action_of_plan(a)
