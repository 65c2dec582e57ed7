r"""The tracker: VS-IMM of UKF/EKF with LMIPDA association, initiation and existence-based termination.

One scan (``Tracker.step``), seed 003 section 4.2, in the order data flows:

1. VS-IMM: each track's active model set for this scan (``TrackerConfig.active_models``), set changes by the rule
   of ``uwb_env.tracking.imm``;
2. IMM mixing with the transition matrix restricted to the active set, then exact Kalman prediction per model,
   existence prediction by the Markov chain;
3. receiver by receiver (the pairs' ``Detections`` in order), sequentially: predicted measurement moments per
   track and model (UKF or EKF), per-measurement innovation covariances S_i = S0 + R_i (each detection has its own
   R, from its SNR; a folded range-rate unwrapped around the prediction or marginalised, ``tracking.ambiguity``),
   ellipsoidal gating with the chi-square threshold of P_G, LMIPDA over all tracks, then each
   model's PDA update as the exact Gaussian-mixture reduction of {no update, Joseph update with measurement i}
   weighted by beta (this includes the spread-of-innovations term), existence and model probabilities updated;
4. initiation from the measurements that belong to no track with probability above 1/2
   (``uwb_env.tracking.initiation``);
5. confirmation above ``confirm_existence``; deletion below ``terminate_existence``, when the position
   uncertainty exceeds ``max_position_std_m`` (such a track no longer localises anything), when a tentative
   track is not confirmed within ``tentative_max_age`` scans (confirmation time-out), or when the estimate has left
   the surveillance area by more than the area's own width or height (a track coasting away from every sensor's
   coverage, which existence alone ends only after tens of scans: with a fast ``max_speed_mps`` or a large process
   noise it would otherwise leave the environments' observation bounds), or when its speed exceeds 10
   ``max_speed_mps`` (the targets' speed limit of initiation's velocity gate: such an estimate follows no target).

Every track keeps a stable id, its status, age, existence, model probabilities and model-conditioned estimates;
``TrackSet.combined()`` gives the IMM output. A single-model tracker with ``fixed_existence`` is seed 003's
open-loop baseline (one NCV UKF) -- the same code.

The detection probability of a track at a pair can be given by a sensor model (``pd_model(tx, rx, positions)``,
e.g. the parametric sensor's radar equation at the predicted position); otherwise the configured constant is used.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numba as nb
import numpy as np
from scipy.stats import chi2

from uwb_env.config import TrackerConfig
from uwb_env.scene.layout import SceneLayout
from uwb_env.scene.motion_models import model_transition, process_noise
from uwb_env.sensing.records import Detections
from uwb_env.tracking import ambiguity, compiled
from uwb_env.tracking.expectation import GaussianLookahead, filter_args
from uwb_env.tracking.imm import imm_combine, restrict_transition, switch_model_sets, switch_probabilities
from uwb_env.tracking.initiation import (
    initiate_compiled,
    range_azimuth_candidates,
    range_only_candidates,
    ridge_range,
)
from uwb_env.tracking.kernels import (
    symmetrise,
)
from uwb_env.tracking.lmipda import associate, predict_existence
from uwb_env.tracking.trackset import FIELDS as _FIELDS
from uwb_env.tracking.trackset import Prediction, TrackSet
from uwb_env.typing import BoolArray, FloatArray, IntArray

PdModel = Callable[[int, int, FloatArray], FloatArray]
_DETECTION_FIELDS = tuple(f.name for f in dataclasses.fields(Detections))
ZERO_ACCELERATION_STD = 0.01
_PV = np.array([0, 2, 1, 3])  # state indices of (x, y, vx, vy)
"""Acceleration std [m/s^2] kept by models without acceleration (NCV, CT) so covariances stay positive definite."""


def motion_matrices(
    kind: str, dt: float, turn_rate_rps: float, accel_std_mps2: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``(F (6, 6), Q (6, 6), G (6, 2))`` of a motion model over ``dt`` (``scene.motion_models``), as trackers use it.

    Seed 003's NCV / CT zero the acceleration rows, which leaves P singular; they carry the acceleration as zero-mean
    with the tiny variance ``ZERO_ACCELERATION_STD``^2 instead, so P stays positive definite.
    """
    F, G = model_transition(kind, dt, turn_rate_rps)
    Q = process_noise(G, accel_std_mps2)
    if kind != "nca":
        Q[4, 4] = Q[5, 5] = ZERO_ACCELERATION_STD**2
    return F, Q, G


def confirm_and_keep(
    cfg: TrackerConfig,
    area: FloatArray,
    existence: FloatArray,
    confirmed: BoolArray,
    age: IntArray,
    x: FloatArray,
    P: FloatArray,
) -> tuple[BoolArray, BoolArray]:
    """Step 5 (module docstring) on N tracks: ``(confirmed (N,), keep (N,))`` after confirmation and deletion.

    ``x (N, 6)``, ``P (N, 6, 6)`` the combined estimates; ``area`` ``[x_min, x_max, y_min, y_max]``. Elementwise,
    so the tracks of several trackers of one configuration may be concatenated (``tracking.batch``).
    """
    x0, x1, y0, y1 = area
    width, height = x1 - x0, y1 - y0
    return _confirm_and_keep(
        existence, confirmed, age, x, P, cfg.confirm_existence, cfg.terminate_existence,
        2.0 * cfg.max_position_std_m**2, cfg.tentative_max_age, (x0 + x1) / 2, (y0 + y1) / 2, 1.5 * width,
        1.5 * height, (10.0 * cfg.max_speed_mps) ** 2,
    )  # fmt: skip


@nb.njit(cache=True, fastmath=False, nogil=True)
def _confirm_and_keep(
    existence, confirmed, age, x, P, confirm_at, terminate_at, max_trace, max_age, cx, cy, half_x, half_y, max_speed_sq
):  # pragma: no cover - compiled
    """:func:`confirm_and_keep` per track, compiled: the same comparisons of the same numbers.

    Confirmed: already, or existence >= ``confirm_at``. Kept: existence >= ``terminate_at``, position-covariance
    trace <= ``max_trace`` [m^2], not tentative at age >= ``max_age``, within ``half_x``, ``half_y`` [m] of the
    area's centre (cx, cy) and slower than sqrt(``max_speed_sq``) (no target is that fast).
    """
    n = existence.shape[0]
    now = np.empty(n, np.bool_)
    keep = np.empty(n, np.bool_)
    for i in range(n):
        c = confirmed[i] or existence[i] >= confirm_at
        lost = P[i, 0, 0] + P[i, 2, 2] > max_trace  # position-covariance trace
        stale = not c and age[i] >= max_age  # confirmation time-out
        gone = abs(x[i, 0] - cx) > half_x or abs(x[i, 2] - cy) > half_y
        gone = gone or x[i, 1] * x[i, 1] + x[i, 3] * x[i, 3] > max_speed_sq
        now[i] = c
        keep[i] = existence[i] >= terminate_at and not lost and not stale and not gone
    return now, keep


@dataclass(slots=True)
class _Candidates:
    """Initiation candidates kept from the previous scan."""

    p: FloatArray = field(default_factory=lambda: np.zeros((0, 2)))
    cov: FloatArray = field(default_factory=lambda: np.zeros((0, 2, 2)))
    time_s: float = -np.inf


class Tracker(GaussianLookahead):
    """VS-IMM / LMIPDA multi-target tracker (component tier: configuration + kernels, state in ``tracks``).

    ``TrackerConfig.kind = "imm-lmipda"``: a ``uwb_env.tracking.protocol.MultiTargetTracker``.

    Args:
        cfg: tracker configuration; tx_pos, rx_pos: ``(T, 2)``, ``(R, 2)`` node positions [m];
        area: surveillance area ``[x_min, x_max, y_min, y_max]`` [m] (candidates outside are dropped);
        pd_model: optional ``(tx, rx, positions (N, 2)) -> Pd (N,)``;

    The kernels are compiled (``uwb_env.tracking.compiled``, fused per scan); ``uwb_env.tracking.reference`` holds
    the numpy twin (``ReferenceTracker``) the tests compare them with (the same tracks to rounding error).
    """

    kind = "imm-lmipda"

    def __init__(
        self,
        cfg: TrackerConfig,
        tx_pos: FloatArray,
        rx_pos: FloatArray,
        area: FloatArray,
        pd_model: PdModel | None = None,
    ) -> None:
        self.cfg = cfg
        self.tx_pos, self.rx_pos = np.asarray(tx_pos, float), np.asarray(rx_pos, float)
        self.area = np.asarray(area, float)
        self.pd_model = pd_model
        self.model_names = tuple(m.name for m in cfg.models)
        self.r = len(cfg.models)
        self.transition = np.array(cfg.transition, dtype=float)
        self._masks: dict[tuple[str, ...], BoolArray] = {}
        self._mask_at: dict[int, BoolArray] = {}  # cfg.active_models is a function of the scan index (frozen cfg)
        self._indices: dict[bytes, IntArray] = {}
        self._restricted: dict[tuple[float, bytes], tuple[FloatArray, FloatArray, FloatArray]] = {}
        self._matrices: dict[float, tuple[FloatArray, FloatArray]] = {}
        self._gates = {
            m: float(chi2.ppf(cfg.gate_probability, m)) if cfg.gate_probability < 1 else np.inf for m in (1, 2, 3, 4)
        }
        x0, x1, y0, y1 = self.area
        cx, cy, hx, hy = (x0 + x1) / 2, (y0 + y1) / 2, (x1 - x0) / 4, (y1 - y0) / 4
        self._starts = np.array(
            [[cx, cy], [cx - hx, cy - hy], [cx + hx, cy - hy], [cx - hx, cy + hy], [cx + hx, cy + hy]]
        )
        # the compiled initiation unless a subclass brings its own selection (the numpy reference)
        self._fused_initiation = type(self)._form_tracks is Tracker._form_tracks
        self._record = False  # record_association: each scan's association probabilities (off: nothing computed)
        self.reset()

    @classmethod
    def from_layout(cls, cfg: TrackerConfig, layout: SceneLayout, pd_model: PdModel | None = None) -> Tracker:
        """The registry's factory (``uwb_env.tracking.registry``): the tracker of the scene ``layout``."""
        return cls(cfg, layout.tx_pos, layout.rx_pos, layout.area, pd_model)

    @property
    def filter(self) -> str:
        """The filter's linearisation, ``"ukf"`` or ``"ekf"`` (``TrackerConfig.filter``)."""
        return self.cfg.filter

    # ----------------------------------------------------------------------------------------------- state
    def reset(self, rng: np.random.Generator | None = None) -> None:
        """Forget every track and candidate (``rng`` is unused: this tracker draws nothing)."""
        self.tracks = TrackSet.empty(self.r)
        self._next_id = 0
        self._previous = _Candidates()
        self._time: float | None = None
        self._pd_cache: dict[tuple[int, int], FloatArray] = {}
        self._owned: list[FloatArray] = []

    def _active_mask(self, scan_index: int) -> BoolArray:
        """``(r,)`` the models active at this scan (cached per scan index and per set; read-only)."""
        mask = self._mask_at.get(scan_index)
        if mask is None:
            names = self.cfg.active_models(scan_index)
            mask = self._masks.get(names)
            if mask is None:
                mask = self._masks[names] = np.array([n in names for n in self.model_names])
                mask.flags.writeable = False
            self._mask_at[scan_index] = mask
        return mask

    def _active_index(self, mask: BoolArray) -> IntArray:
        """``(a,)`` int64 indices of the active models."""
        key = mask.tobytes()
        if key not in self._indices:
            self._indices[key] = np.flatnonzero(mask).astype(np.int64)
        return self._indices[key]

    def _model_matrices(self, dt: float) -> tuple[FloatArray, FloatArray]:
        """``(r, 6, 6)`` transition and process noise for period ``dt`` (cached per dt rounded to 1e-12 s).

        Computed from the rounded period, so the matrices are a function of the key alone: scan times k T differ from
        their neighbours by T plus a few ulps, and a cache filled with whichever unrounded period came first made an
        episode's last bits depend on the episodes the same tracker had played before.
        """
        key = round(dt, 12)
        if key not in self._matrices:
            Fs, Qs = [], []
            for m in self.cfg.models:  # the model set: a small fixed set
                F, Q, _ = motion_matrices(m.kind, key, m.turn_rate_rps, m.accel_noise_std_mps2)
                Fs.append(F)
                Qs.append(Q)
            self._matrices[key] = (np.stack(Fs), np.stack(Qs))
        return self._matrices[key]

    def _restricted_matrices(self, dt: float, mask: BoolArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Transition matrix restricted to the active set ``(a, a)`` and the active models' F, Q ``(a, 6, 6)``."""
        key = (round(dt, 12), mask.tobytes())
        if key not in self._restricted:
            a = self._active_index(mask)
            F, Q = self._model_matrices(dt)
            Pi = restrict_transition(self.transition, mask[None])[0][a][:, a]
            self._restricted[key] = (np.ascontiguousarray(Pi), np.ascontiguousarray(F[a]), np.ascontiguousarray(Q[a]))
        return self._restricted[key]

    def prediction_models(self, dt: float, scan_index: int) -> tuple[BoolArray, FloatArray, FloatArray, FloatArray]:
        """The model set of ``scan_index`` for period ``dt`` (read-only, cached).

        Returns: active mask ``(r,)``, restricted transition matrix ``(a, a)``, the active models' F, Q ``(a, 6, 6)``.
        """
        mask = self._active_mask(scan_index)
        return (mask, *self._restricted_matrices(dt, mask))

    # ------------------------------------------------------------------------------------------------ scan
    def step(self, detections: Sequence[Detections], time_s: float, scan_index: int) -> TrackSet:
        """Process one scan of detections (all pairs) and return the updated tracks."""
        if self._time is not None and len(self.tracks):
            self._predict(time_s - self._time, scan_index)
        self._time = time_s
        self._pd_cache: dict[tuple[int, int], FloatArray] = {}
        unused = []
        record = self._record
        if record:
            self._owned = []
        for det in detections:  # receiver by receiver, sequentially (seed 003)
            if len(self.tracks) and len(det):
                floored = self._with_floor(det)
                if record:  # from the tracks before this receiver's update (the update works in place)
                    self._owned.append(self.association_probabilities(floored))
                used = self._update(floored)
            else:
                used = np.zeros(len(det), bool)
                if record:
                    self._owned.append(np.zeros(len(det)))
            unused.append((det, ~used))
        self._initiate(unused, time_s, scan_index)
        return self._confirm_and_prune()

    def record_association(self, on: bool = True) -> None:
        """Record, from the next ``step`` on, each detection's association probabilities (``clutter_probabilities``).

        An optional capability (not in ``tracking.protocol``): ``Simulator`` turns it on for a sensor whose clutter map
        counts the unassociated detections; off, ``step`` computes nothing more.
        """
        self._record = bool(on)

    def clutter_probabilities(self) -> tuple[FloatArray, ...]:
        """Per record of the last ``step`` (in order), ``(M,)`` each detection's a-posteriori clutter probability.

        ``1 - sum_t P(track t exists and made detection i)`` (``association_probabilities``), clipped to [0, 1]
        (LMIPDA's per-track approximations need not sum to at most 1 exactly). Needs ``record_association()``
        before the step; a record the tracker met without tracks: every detection 1 (no track can have made it).
        """
        if not self._record:
            raise RuntimeError("clutter_probabilities: call record_association() before step() to record them")
        return tuple(np.clip(1.0 - o, 0.0, 1.0) for o in self._owned)

    def association_probabilities(self, det: Detections) -> FloatArray:
        """``(M,)`` P(some track exists and detection i is its) of one pair's ``det`` against the current tracks (pure).

        Musicki & La Scala's LMIPDA (``uwb_env.tracking.lmipda``) on the tracks as they stand before this pair's
        update: the same gating (chi-square ``gate_probability``), gate-truncated likelihood ratios against the
        floored clutter intensity and Pd as ``_update``; then, with psi^t+ the posterior existence, mu_r^t+ the
        posterior model probabilities and beta_i^{t,r} the association probabilities conditioned on existence,

            P_i = sum_t psi^t+ sum_r mu_r^t+ beta_i^{t,r}

        (the quantity whose > 1/2 marks a detection taken, ``compiled.receiver_update``; the numpy twin computes
        it the same way, ``reference.ReferenceTracker._update``). Moments by the compiled filter kernel.
        """
        cfg, t = self.cfg, self.tracks
        names, M = det.measurement_names, len(det)
        owned = np.zeros(M)
        if not len(t) or not M:
            return owned
        a = self._active_index(t.active[0])
        tx, rx = self.tx_pos[det.tx], self.rx_pos[det.rx]
        kinds, wm, wc, sigma_scale, use_ukf = self.compiled_filter_args(names)
        z_hat, S0, C, ok = compiled.measurement_moments(t.x, t.P, a, kinds, tx, rx, wm, wc, sigma_scale, use_ukf)
        if not ok:
            raise np.linalg.LinAlgError("association_probabilities: a covariance is not positive definite")
        g2 = self._gates[len(names)]
        S0, C, nu, triples = ambiguity.gated_innovations(det, z_hat, S0, C, g2)  # as ReferenceTracker._update
        assoc = associate(det, nu, S0, triples, g2, t.mu[:, a], t.existence, self._pd(det, t), cfg)
        owned[assoc.cols] = assoc.owned
        return owned

    def _confirm_and_prune(self) -> TrackSet:
        """Step 5 of the scan (module docstring): confirmation, then deletion; returns the tracks kept."""
        t = self.tracks
        x, P = t.combined()
        t.confirmed, keep = confirm_and_keep(self.cfg, self.area, t.existence, t.confirmed, t.age, x, P)
        if not keep.all():
            self.tracks = t.select(keep)
        return self.tracks

    def _with_floor(self, det: Detections) -> Detections:
        """``det`` with ``range_rate_noise_floor_mps``^2 added to its range-rate variances (a copy; TrackerConfig)."""
        floor = self.cfg.range_rate_noise_floor_mps
        if floor == 0.0 or "range_rate" not in det.measurement_names:
            return det
        d = det.measurement_names.index("range_rate")
        R = det.R.copy()
        R[:, d, d] += floor**2
        if type(det) is not Detections:
            return dataclasses.replace(det, R=R)
        out = object.__new__(Detections)  # dataclasses.replace(det, R=R) without its field introspection
        for name in _DETECTION_FIELDS:
            setattr(out, name, getattr(det, name))
        out.R = R
        return out

    def _predict(self, dt: float, scan_index: int) -> None:
        t = self.tracks
        t.mu, t.active, t.x, t.P = self._predict_models(t.mu, t.active, t.x, t.P, dt, scan_index)
        t.existence = predict_existence(t.existence, self.cfg.survival_probability)
        t.age = t.age + 1

    def _predict_models(
        self, mu: FloatArray, active: BoolArray, x: FloatArray, P: FloatArray, dt: float, scan_index: int
    ) -> tuple[FloatArray, BoolArray, FloatArray, FloatArray]:
        """VS-IMM set switch, IMM mixing and Kalman prediction of ``(mu, active, x, P)``, ``dt`` later.

        Works in place on the given arrays where it can; returns the predicted ``(mu, active, x, P)``.
        """
        mask = self._active_mask(scan_index)
        if (active != mask).any():  # VS-IMM set change (rare): the switch rule of uwb_env.tracking.imm
            new = np.broadcast_to(mask, active.shape)
            mu, x, P = switch_model_sets(active, new, mu, x, P)
            active = new.copy()
        # Every track shares the scan's model set: mix and predict the active models only (inactive ones are
        # re-initialised from the combined estimate by the switch rule if they come back).
        a = self._active_index(mask)
        Pi, F, Q = self._restricted_matrices(dt, mask)
        self._mix_predict(mu, Pi, x, P, F, Q, a)
        return mu, active, x, P

    def _mix_predict(
        self, mu: FloatArray, Pi: FloatArray, x: FloatArray, P: FloatArray, F: FloatArray, Q: FloatArray, a: IntArray
    ) -> None:
        """IMM mixing and Kalman prediction of the active models ``a``, in place (compiled)."""
        compiled.predict_models(mu, Pi, x, P, F, Q, a)

    def predicted(self, time_s: float, scan_index: int) -> TrackSet:
        """The tracks predicted to ``time_s`` (IMM mixing and prediction, existence), without changing the tracker.

        Pure: works on copies and draws nothing.
        """
        t = self.tracks
        saved = self.tracks
        self.tracks = TrackSet(*(getattr(t, f).copy() for f in _FIELDS))
        try:
            if self._time is not None and len(self.tracks):
                self._predict(time_s - self._time, scan_index)
            return self.tracks
        finally:
            self.tracks = saved

    def predicted_estimates(
        self, time_s: float, scan_index: int, keep: BoolArray
    ) -> tuple[FloatArray, FloatArray, FloatArray, BoolArray]:
        """The combined estimates of the tracks ``keep`` (N,) predicted to ``time_s`` (the lookahead's input).

        The numbers of ``predicted`` for those tracks, without copying the others. Pure.
        Returns: combined x ``(n, 6)``, P ``(n, 6, 6)``, model probabilities mu ``(n, r)``, model set ``(r,)``.
        """
        t = self.tracks
        keep = np.asarray(keep, dtype=bool)
        mu, active, x, P = t.mu[keep], t.active[keep], t.x[keep], t.P[keep]  # boolean indexing: copies
        if self._time is not None and mu.shape[0]:
            mu, active, x, P = self._predict_models(mu, active, x, P, time_s - self._time, scan_index)
        xc, Pc = compiled.combine(mu, x, P)
        return xc, Pc, mu, (active[0] if active.shape[0] else self._active_mask(scan_index))

    # ------------------------------------------------------------------------------- the lookahead's hooks
    def scored_prediction(self, time_s: float, scan_index: int) -> Prediction | None:
        """The tracks a lookahead scores, predicted to ``time_s`` (pure, ``predicted_estimates``).

        The confirmed ones, or every (tentative) track when none is; ``None`` without any track.
        """
        confirmed = self.tracks.confirmed  # prediction does not change the status
        if not confirmed.size:
            return None
        return Prediction(*self.predicted_estimates(time_s, scan_index, confirmed if confirmed.any() else ~confirmed))

    def predict_gaussians(self, pred: Prediction, dt: float, scan_index: int) -> Prediction:
        """Moment-matched IMM prediction of combined estimates to ``scan_index``, ``dt`` later (pure).

        Every active model j from the combined (x, P): x_j = F_j x, P_j = F_j P F_j^T + Q_j, mixed with the
        predicted model probabilities mu^- = Pi^T mu and the spread of the x_j; the VS-IMM set of that scan with the
        switch rule for mu (``uwb_env.tracking.imm``).
        """
        x, P, mu, active = pred.x, pred.P, pred.mu, pred.active
        mask, Pi, F, Q = self.prediction_models(dt, scan_index)
        if (mask != active).any():
            mu = switch_probabilities(np.broadcast_to(active, mu.shape), np.broadcast_to(mask, mu.shape), mu)
        a = np.flatnonzero(mask)
        mu_pred = np.zeros_like(mu)
        mu_pred[:, a] = mu[:, a] @ Pi  # (N, a): mu^-_j = sum_i Pi_ij mu_i
        xj = np.einsum("jkl,nl->njk", F, x)  # (N, a, 6)
        Pj = F[None] @ P[:, None] @ np.swapaxes(F, -1, -2)[None] + Q[None]
        xp, Pp = imm_combine(mu_pred[:, a], xj, Pj)
        return Prediction(xp, symmetrise(Pp), mu_pred, mask)

    def _update(self, det: Detections) -> BoolArray:
        """LMIPDA + PDA update of every track with one pair's detections (``compiled.receiver_update``).

        Returns which measurements now belong to some track (kept from initiation).
        """
        # all tracks share the scan's model set (see _predict): work on the active models only
        a = self._active_index(self.tracks.active[0])
        return self._update_compiled(det, a, self.tx_pos[det.tx], self.rx_pos[det.rx])

    def compiled_filter_args(self, names: tuple[str, ...]) -> tuple[np.ndarray, FloatArray, FloatArray, float, bool]:
        """``(kinds, wm, wc, sigma_scale, use_ukf)``: the measurement and filter arguments of the compiled kernels."""
        return filter_args(self.cfg.filter, names)

    def _update_compiled(self, det: Detections, a: IntArray, tx: FloatArray, rx: FloatArray) -> BoolArray:
        """``_update`` with the fused compiled kernel (``compiled.receiver_update``)."""
        cfg, t = self.cfg, self.tracks
        kinds, wm, wc, sigma_scale, use_ukf = self.compiled_filter_args(det.measurement_names)
        psi, taken, ok = compiled.receiver_update(  # x, P, mu updated in place
            t.x,
            t.P,
            t.mu,
            a,
            t.existence,
            np.ascontiguousarray(self._pd(det, t), dtype=float),
            np.ascontiguousarray(det.z, dtype=float),
            np.ascontiguousarray(det.R, dtype=float),
            np.maximum(det.clutter_intensity, cfg.min_clutter_intensity),
            kinds,
            tx,
            rx,
            wm,
            wc,
            sigma_scale,
            use_ukf,
            self._gates[len(det.measurement_names)],
            cfg.gate_probability,
            cfg.fixed_existence,
            det.range_rate_period_mps,
        )
        if not ok:
            raise np.linalg.LinAlgError("tracker update: a covariance is not positive definite")
        t.existence = psi
        return taken

    def _pd(self, det: Detections, t: TrackSet) -> FloatArray:
        """Detection probability of each track at this pair: the sensor model at the scan's predicted positions.

        Evaluated once per scan for all pairs (the prediction is the same for every receiver of the scan).
        """
        if self.pd_model is None:
            return np.full(len(t), self.cfg.detection_probability)
        if not self._pd_cache:
            x, _ = t.combined()
            self._pd_positions = x[:, [0, 2]]
        key = (det.tx, det.rx)
        if key not in self._pd_cache:
            self._pd_cache[key] = np.asarray(self.pd_model(det.tx, det.rx, self._pd_positions), dtype=float)
        return self._pd_cache[key]

    # ------------------------------------------------------------------------------------------ initiation
    def _initiate(self, unused: list[tuple[Detections, BoolArray]], time_s: float, scan_index: int) -> None:
        """Step 4 (module docstring): candidates from the free detections, then ``_form_tracks``' selection.

        Fused positions and array receivers' candidates per pair; the range-only pairs' nu-tuples and the selection,
        fusion and two-point differencing in one compiled call (``initiation.initiate_compiled``, the batched
        trackers' kernel with one environment); a subclass that overrides ``_form_tracks`` (the numpy reference)
        gets the numpy candidates (``initiation.range_only_candidates``) and its own ``_form_tracks``.
        """
        ps, covs, range_dets = [], [], []
        for det, free in unused:  # per pair: a small fixed set
            if not free.any():
                continue
            names = det.measurement_names
            if names == ("x", "y"):  # fused positions (the signal path's network chain): candidates as they are
                ps.append(det.z[free])
                covs.append(det.R[free])
                continue
            if "azimuth" in names:
                tx, rx = self.tx_pos[det.tx], self.rx_pos[det.rx]
                found = self._azimuth_candidates(det, free, tx, rx)
                if found is None:
                    found = self._range_azimuth_candidates(det, free, tx, rx)
                ps.append(found[0])
                covs.append(found[1])
                continue
            range_dets.append((det, free))
        if not self._fused_initiation:
            self._initiate_numpy(ps, covs, range_dets, time_s, scan_index)
            return
        extra = None
        if ps:
            extra = (np.concatenate(ps), np.concatenate(covs)) if len(ps) > 1 else (ps[0], covs[0])
        x, P, _, rest_p, rest_cov, _ = initiate_compiled(
            [range_dets],
            [extra],
            [self._previous],
            [time_s],
            self.tx_pos,
            self.rx_pos,
            self.area,
            self._starts,
            self._gates[2],
            self.cfg,
        )
        if x.shape[0]:
            self._append_tracks(x, P, scan_index)
        self._previous = _Candidates(rest_p, rest_cov, time_s)

    def _range_azimuth_candidates(
        self, det: Detections, free: BoolArray, tx: FloatArray, rx: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """Array-receiver candidates with numpy (``initiation.range_azimuth_candidates``; the reference's path)."""
        cfg, names = self.cfg, det.measurement_names
        # strongest first, so that any cap below keeps the strongest detections (dense clutter)
        order = np.argsort(-det.snr[free], kind="stable")[: cfg.init_max_candidates]
        z, R = det.z[free][order], det.R[free][order]
        r, var_r = ridge_range(z, R, names, 2.0 * cfg.max_speed_mps)
        a = names.index("azimuth")
        p, cov, ok = range_azimuth_candidates(r, var_r, z[:, a], R[:, a, a], tx, rx)
        return p[ok], cov[ok]

    def _initiate_numpy(
        self,
        ps: list[FloatArray],
        covs: list[FloatArray],
        range_dets: list[tuple[Detections, BoolArray]],
        time_s: float,
        scan_index: int,
    ) -> None:
        """The range-only candidates with numpy (``initiation.range_only_candidates``), then ``_form_tracks``."""
        cfg = self.cfg
        range_groups = []
        for det, free in range_dets:
            # strongest first, so that any cap below keeps the strongest detections (dense clutter)
            order = np.argsort(-det.snr[free], kind="stable")[: cfg.init_max_candidates]
            z, R = det.z[free][order], det.R[free][order]
            r, var_r = ridge_range(z, R, det.measurement_names, 2.0 * cfg.max_speed_mps)
            range_groups.append((r, var_r, self.tx_pos[det.tx], self.rx_pos[det.rx]))
        if len(range_groups) >= 2:
            nu = min(3, len(range_groups))
            per_rx = max(1, int(cfg.init_max_candidates ** (1.0 / nu)))  # tuples <= init_max_candidates per subset
            range_groups = [(r[:per_rx], v[:per_rx], tx, rx) for r, v, tx, rx in range_groups]  # strongest kept
            p, cov = range_only_candidates(range_groups, nu, self.area, self._starts)
            ps.append(p)
            covs.append(cov)
        if not ps:
            p, cov = np.zeros((0, 2)), np.zeros((0, 2, 2))
        else:
            p, cov = (np.concatenate(ps), np.concatenate(covs)) if len(ps) > 1 else (ps[0], covs[0])
        self._form_tracks(p, cov, time_s, scan_index)

    def _azimuth_candidates(
        self, det: Detections, free: BoolArray, tx: FloatArray, rx: FloatArray
    ) -> tuple[FloatArray, FloatArray] | None:
        """Position candidates ``(p (n, 2), cov (n, 2, 2))`` of one array receiver's free detections (compiled)."""
        names, cfg = det.measurement_names, self.cfg
        return compiled.azimuth_candidates(
            np.ascontiguousarray(det.z, dtype=float),
            np.ascontiguousarray(det.R, dtype=float),
            np.ascontiguousarray(det.snr, dtype=float),
            free,
            names.index("azimuth"),
            names.index("range_rate") if "range_rate" in names else -1,
            tx,
            rx,
            2.0 * cfg.max_speed_mps,
            cfg.init_max_candidates,
        )

    def _form_tracks(self, p: FloatArray, cov: FloatArray, time_s: float, scan_index: int) -> None:
        """Select, fuse and pair this scan's candidates with the previous scan's; new tentative tracks (compiled).

        Candidates outside the area or with position spread above 2 ``init_max_position_std_m``^2 are dropped, at
        most ``init_max_candidates`` (the most precise) kept, those within the gate of each other fused, and pairs
        within the velocity gate form tracks (two-point differencing, ``compiled.new_track_states``); the rest wait
        a scan.
        """
        cfg, prev = self.cfg, self._previous
        x, P, rest_p, rest_cov = compiled.initiate(
            p,
            cov,
            prev.p,
            prev.cov,
            time_s - prev.time_s,
            self.area,
            2.0 * cfg.init_max_position_std_m**2,
            cfg.init_max_candidates,
            self._gates[2],
            cfg.max_speed_mps,
            cfg.initial_accel_std_mps2,
        )
        if x.shape[0]:
            self._append_tracks(x, P, scan_index)
        self._previous = _Candidates(rest_p, rest_cov, time_s)

    def _append_tracks(self, x: FloatArray, P: FloatArray, scan_index: int) -> None:
        """Append new tentative tracks with states ``x (n, 6)``, ``P (n, 6, 6)`` in every model, fresh ids.

        Existence ``initial_existence``, uniform model probabilities over the scan's model set, age 0. Each field
        is filled into a new array by slice assignment (cheaper than concatenation at these sizes).
        """
        n, t = x.shape[0], self.tracks
        n0 = len(t)
        mask = self._active_mask(scan_index)

        def grown(old: np.ndarray, new: object) -> np.ndarray:
            out = np.empty((n0 + n, *old.shape[1:]), dtype=old.dtype)
            out[:n0] = old
            out[n0:] = new
            return out

        self.tracks = TrackSet(
            ids=grown(t.ids, np.arange(self._next_id, self._next_id + n)),
            confirmed=grown(t.confirmed, False),
            age=grown(t.age, 0),
            born=grown(t.born, scan_index),
            existence=grown(t.existence, self.cfg.initial_existence),
            mu=grown(t.mu, mask / mask.sum()),
            active=grown(t.active, mask),
            x=grown(t.x, x[:, None]),
            P=grown(t.P, P[:, None]),
        )
        self._next_id += n
