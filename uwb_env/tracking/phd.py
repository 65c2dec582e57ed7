r"""Seed 000's particle PHD tracker (section V-D): SMC-PHD, EM peak extraction, labelled tracks with a state machine.

One scan (``PhdTracker.step``), in the order data flows:

1. Measurements. The signal path's network chain hands one ``Detections`` of fused positions (``("x", "y")``,
   ``rx = -1``, R the position covariances, ``clutter_intensity`` per m^2): used as they are. Per-pair bistatic
   ranges (the parametric sensor, or the signal path with ``output = "ranges"``) are fused here with the project's
   network chain (``uwb_env.localization.locate``: nu-tuple ellipse intersection, residual filter, 2-D clustering,
   geometry covariance) exactly as seed 000 feeds its PHD filter; their clutter intensity is
   ``PhdConfig.false_position_density_per_m2``. The ranges carry no seed weight omega, so every tuple has weight 1
   and the weight threshold is off (the residual threshold does the filtering); other columns (range-rate,
   azimuth) are not used.
2. Prediction (seed eq. 32): each particle ``[x, vx, y, vy]`` moves by the NCV model with white acceleration noise
   (``accel_noise_std_mps2``, drawn through the model's gain G), its weight times the survival probability p_S
   (``survival_probability``; 0 beyond ``area_margin_m`` outside the surveillance area). No spawning (seed 000's
   spawning term is not used in its case study; a person does not spawn people).
3. Update (seed eq. 33) with the measurement-driven (adaptive) birth of Ristic, Clark, Vo and Vo (IEEE TAES 2012):
   with g(z|x) = N(z; Hx, R_z) and C(z) = sum_i P_D(x_i) g(z|x_i) w_i,

       L(z) = kappa(z) + C(z) + nu_b,     w_i <- [1 - P_D(x_i) + sum_z P_D(x_i) g(z|x_i) / L(z)] w_i,

   and ``particles_per_birth`` newborn particles per measurement, position N(z, R_z), velocity
   N(0, ``birth_velocity_std_mps``^2 I), sharing the newborn mass nu_b / L(z). The birth density is conditioned on
   z (the seed's "new particles are initialised around each measurement"), which is why it enters L(z) with its
   intensity nu_b = ``birth_intensity_per_m2`` and is not weighted by a likelihood; nu_b is an intensity in the
   measurement space like kappa, so a measurement explained by no particle is a new target with probability
   nu_b / (kappa + nu_b). P_D(x) is the sensor model's ``pd_model(0, -1, positions)`` (the network's probability
   of a fused position) on a grid of ``pd_grid_m`` cells (the radar equation varies over metres, a cell of
   0.25 m changes nothing and costs a few dozen evaluations instead of thousands), else
   ``TrackerConfig.detection_probability``; kappa the measurement's ``clutter_intensity`` (floored at
   ``TrackerConfig.min_clutter_intensity``).
4. Resampling (systematic, from the tracker's generator): the particle count is ``particles_per_target`` per unit
   of PHD mass (the expected number of targets, the sum of the weights), within [``min_particles``,
   ``max_particles``]; the mass is kept.
5. Peak extraction (seed: "the M_hat largest peaks of the PHD ... through an EM algorithm fitting the discretised
   PHD with M_hat Gaussians") from the updated persistent particles, before the newborn join the cloud: the newborn
   are the birth intensity of the next scan, not targets of this one (Ristic, Clark, Vo and Vo 2012; counted here,
   every isolated false position became an estimate of mass nu_b / (kappa + nu_b)). M_hat = round(persistent mass).
   EM on the weighted particles in the 4-D state, initialised by assigning each particle to the nearest seed in
   position; seeds are the measurements in the order of the persistent mass they take C(z) / L(z), then the tracks'
   predicted positions, then particles drawn from the generator. Up to ``em_extra_components`` more components than
   M_hat (seeded at measurements holding at least ``em_min_seed_mass``) absorb the clutter mass, which would
   otherwise pull a single Gaussian towards itself; the M_hat heaviest components are the estimates (mean and
   covariance; acceleration zero with variance ``tracker.ZERO_ACCELERATION_STD``^2). Then the resampling of step 4.
6. Association (seed section V-E): the minimum-cost assignment of estimates to the tracks' predicted heads
   (Hungarian algorithm, cost the position distance) is valid as a whole when its total cost is at most
   ``max_hypothesis_cost_m``; otherwise each pair is valid iff the estimate lies in the chi-square gate
   (``TrackerConfig.gate_probability``, 2 dof) of the predicted head's and the estimate's position covariances.
   State machine: a new track is unconfirmed; confirmed after ``confirm_updates`` consecutive updated scans (birth
   included); an unconfirmed track without a valid association dies; a confirmed one turns silent (predicted with
   the NCV model), a silent one with a valid association is confirmed again, a silent one dies after
   ``silent_max_scans`` scans without one (or when its prediction leaves the area by more than ``area_margin_m``).

``TrackSet``: one model (``ncv``): ``mu = 1``, ``active = True``; ``confirmed`` = confirmed or silent; existence =
the matched component's PHD mass clipped to [0, 1] (the PHD's expected number of targets in that peak: 1 for a
well-detected target, the birth probability for a fresh one), times p_S for every scan a track is silent.

Where the seed is silent (particle counts, birth, noise, EM details, thresholds) the choices are those of an SMC-PHD
in the manner of Stone Soup's (systematic resampling, constant particles per target) with Ristic et al.'s adaptive
birth; ``PhdConfig`` documents the numbers. Randomness only from the generator given to ``reset`` (the episode's
``tracker`` stream); ``reset(None)`` uses ``np.random.default_rng(0)``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.stats import chi2

from uwb_env.config import TrackerConfig
from uwb_env.localization import locate
from uwb_env.scene.layout import SceneLayout
from uwb_env.sensing.records import Detections
from uwb_env.tracking.expectation import GaussianLookahead
from uwb_env.tracking.pd_grid import occupied_cells
from uwb_env.tracking.protocol import Prediction
from uwb_env.tracking.tracker import ZERO_ACCELERATION_STD, TrackSet, motion_matrices
from uwb_env.typing import BoolArray, FloatArray, IntArray

PdModel = Callable[[int, int, FloatArray], FloatArray]
UNCONFIRMED, CONFIRMED, SILENT = 0, 1, 2
"""Track states (a dead track is removed)."""
_LOG_2PI = math.log(2.0 * math.pi)
_POSITION_NAMES = ("x", "y")


# --------------------------------------------------------------------------------------------------------- kernels
def systematic_resample(weights: FloatArray, n: int, rng: np.random.Generator) -> IntArray:
    """``(n,)`` indices drawn by systematic resampling of ``weights`` (N,) (non-negative, not all zero)."""
    cdf = np.cumsum(weights)
    cdf /= cdf[-1]
    u = (rng.random() + np.arange(n)) / n
    return np.minimum(np.searchsorted(cdf, u, side="right"), weights.shape[0] - 1)


def position_likelihood(pos: FloatArray, z: FloatArray, R: FloatArray) -> FloatArray:
    """``(N, M)`` Gaussian densities N(z_m; pos_n, R_m) of positions ``pos`` (N, 2), ``z`` (M, 2), ``R`` (M, 2, 2)."""
    a, b, c = R[:, 0, 0], R[:, 0, 1], R[:, 1, 1]
    det = a * c - b * b
    dx = z[None, :, 0] - pos[:, None, 0]
    dy = z[None, :, 1] - pos[:, None, 1]
    maha = (c * dx * dx - 2.0 * b * dx * dy + a * dy * dy) / det
    return np.exp(-0.5 * maha) / (2.0 * math.pi * np.sqrt(det))


def phd_update(
    pos: FloatArray, w: FloatArray, pd: FloatArray, z: FloatArray, R: FloatArray, kappa: FloatArray, birth: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The SMC-PHD update (module docstring, step 3) of particles at ``pos`` (N, 2) with weights ``w`` (N,).

    Returns the updated weights ``(N,)``, the newborn mass of each measurement nu_b / L(z) ``(M,)`` and the
    persistent mass each measurement takes C(z) / L(z) ``(M,)``.
    """
    if z.shape[0] == 0:
        return w * (1.0 - pd), np.zeros(0), np.zeros(0)
    g = position_likelihood(pos, z, R)
    pdw = pd * w
    C = pdw @ g
    L = kappa + C + birth
    return w * (1.0 - pd) + pdw * (g @ (1.0 / L)), birth / L, C / L


def em_mixture(
    X: FloatArray,
    w: FloatArray,
    seeds: FloatArray,
    seed_dims: Sequence[int],
    iterations: int,
    tolerance: float,
    reg: float = 1e-6,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Weighted EM of a Gaussian mixture on points ``X`` (N, d) with weights ``w`` (N,) >= 0.

    Initialised by a hard assignment of each point to the nearest of ``seeds`` (K, d) over the dimensions
    ``seed_dims``; components left without weight are dropped. At most ``iterations`` E-M rounds, stopping when the
    weighted mean log-likelihood changes by less than ``tolerance`` times its magnitude; ``reg`` is added to each
    covariance's diagonal. Returns component masses ``(K',)`` (sums of ``w`` times responsibilities: they add up to
    ``w.sum()``), means ``(K', d)`` and covariances ``(K', d, d)``.
    """
    N, d = X.shape
    dims = list(seed_dims)
    total = float(w.sum())
    d2 = ((X[:, None, dims] - seeds[None, :, dims]) ** 2).sum(axis=-1)
    resp = np.zeros((N, seeds.shape[0]))
    resp[np.arange(N), np.argmin(d2, axis=1)] = 1.0
    eye = reg * np.eye(d)
    ll_old = -np.inf
    for it in range(iterations + 1):
        # M-step
        rw = resp * w[:, None]
        mass = rw.sum(axis=0)
        keep = mass > 1e-12 * total
        if not keep.all():
            rw, mass = rw[:, keep], mass[keep]
        means = (rw.T @ X) / mass[:, None]
        D = X[None] - means[:, None]  # (K, N, d)
        covs = (np.swapaxes(D * rw.T[:, :, None], 1, 2) @ D) / mass[:, None, None] + eye
        if it == iterations or mass.shape[0] == 1:  # one component: the weighted moments are the fixed point
            break
        # E-step
        Lc = np.linalg.cholesky(covs)
        y = np.linalg.solve(Lc, np.swapaxes(D, 1, 2))  # (K, d, N)
        logdet = 2.0 * np.log(np.diagonal(Lc, axis1=1, axis2=2)).sum(axis=1)
        logp = (np.log(mass / total) - 0.5 * (logdet + d * _LOG_2PI))[:, None] - 0.5 * (y * y).sum(axis=1)  # (K, N)
        top = logp.max(axis=0)
        lse = top + np.log(np.exp(logp - top).sum(axis=0))
        resp = np.exp(logp - lse).T
        ll = float(w @ lse) / total
        if abs(ll - ll_old) <= tolerance * abs(ll):
            rw = resp * w[:, None]  # the M-step of the converged responsibilities
            mass = rw.sum(axis=0)
            keep = mass > 1e-12 * total
            rw, mass = rw[:, keep], mass[keep]
            means = (rw.T @ X) / mass[:, None]
            D = X[None] - means[:, None]
            covs = (np.swapaxes(D * rw.T[:, :, None], 1, 2) @ D) / mass[:, None, None] + eye
            break
        ll_old = ll
    return mass, means, covs


# --------------------------------------------------------------------------------------------------------- tracker
class PhdTracker(GaussianLookahead):
    """Seed 000's particle PHD tracker (module docstring); a ``MultiTargetTracker``.

    Args:
        cfg: tracker configuration (``cfg.phd`` the PHD's own numbers); tx_pos, rx_pos: ``(T, 2)``, ``(R, 2)`` node
        positions [m]; area: ``[x_min, x_max, y_min, y_max]`` [m]; pd_model: optional
        ``(tx, rx, positions (N, 2)) -> Pd (N,)``, called with ``rx = -1`` (the fused position measurement).
    """

    kind = "phd"
    filter = "ukf"
    model_names = ("ncv",)

    def __init__(
        self,
        cfg: TrackerConfig,
        tx_pos: FloatArray,
        rx_pos: FloatArray,
        area: FloatArray,
        pd_model: PdModel | None = None,
    ) -> None:
        self.cfg = cfg
        self.phd = cfg.phd
        self.tx_pos, self.rx_pos = np.asarray(tx_pos, float), np.asarray(rx_pos, float)
        self.area = np.asarray(area, float)
        self.pd_model = pd_model
        self._gate2 = float(chi2.ppf(cfg.gate_probability, 2)) if cfg.gate_probability < 1 else np.inf
        self._matrices: dict[float, tuple[FloatArray, FloatArray, FloatArray]] = {}
        self.reset()

    @classmethod
    def from_layout(cls, cfg: TrackerConfig, layout: SceneLayout, pd_model: PdModel | None = None) -> PhdTracker:
        """The registry's factory (``uwb_env.tracking.registry``)."""
        return cls(cfg, layout.tx_pos, layout.rx_pos, layout.area, pd_model)

    # ----------------------------------------------------------------------------------------------- state
    def reset(self, rng: np.random.Generator | None = None) -> None:
        """Forget every particle and track; ``rng``: the episode's ``tracker`` stream (None: ``default_rng(0)``)."""
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self.particles = np.zeros((0, 4))  # [x, vx, y, vy]
        self.weights = np.zeros(0)
        self._time: float | None = None
        self._next_id = 0
        self._status = np.zeros(0, np.int8)
        self._hits = np.zeros(0, np.int64)
        self._misses = np.zeros(0, np.int64)
        self._tracks = TrackSet.empty(1)
        self.estimates: tuple[FloatArray, FloatArray, FloatArray] = (np.zeros(0), np.zeros((0, 6)), np.zeros((0, 6, 6)))

    @property
    def tracks(self) -> TrackSet:
        """The tracks after the last step."""
        return self._tracks

    @property
    def status(self) -> IntArray:
        """``(N,)`` each track's state (``UNCONFIRMED``, ``CONFIRMED``, ``SILENT``)."""
        return self._status

    @property
    def expected_targets(self) -> float:
        """The PHD's expected number of targets: the sum of the particle weights."""
        return float(self.weights.sum())

    def _model(self, dt: float) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``(F (6, 6), Q (6, 6), G (6, 2))`` of the NCV model for period ``dt`` (cached).

        Computed from the period rounded to 1e-12 s, so the matrices do not depend on which unrounded period came
        first (``Tracker._model_matrices``).
        """
        key = round(dt, 12)
        m = self._matrices.get(key)
        if m is None:
            m = self._matrices[key] = motion_matrices("ncv", key, 0.0, self.phd.accel_noise_std_mps2)
        return m

    def _predict_gaussians(self, x: FloatArray, P: FloatArray, dt: float) -> tuple[FloatArray, FloatArray]:
        F, Q, _ = self._model(dt)
        return x @ F.T, F @ P @ F.T + Q

    # ------------------------------------------------------------------------------------------------ scan
    def step(self, detections: Sequence[Detections], time_s: float, scan_index: int) -> TrackSet:
        """Process one scan (every pair's detections); returns the updated tracks (module docstring)."""
        phd = self.phd
        dt = None if self._time is None else time_s - self._time
        self._time = time_s
        t = self._tracks
        if dt is not None:
            self._predict_particles(dt)
            if len(t):
                t.x[:, 0], t.P[:, 0] = self._predict_gaussians(t.x[:, 0], t.P[:, 0], dt)
        z, R, kappa = self.measurements(detections)
        pos = self.particles[:, [0, 2]]
        pd = self._pd(pos) if pos.shape[0] else np.zeros(0)
        w, newborn, held = phd_update(pos, self.weights, pd, z, R, kappa, phd.birth_intensity_per_m2)
        # Peaks of the persistent intensity only: the newborn particles are the birth of the next scan, not targets
        # of this one (Ristic, Clark, Vo and Vo 2012, section III); counting them made every isolated false position
        # an estimate of mass nu_b / (kappa + nu_b).
        self.estimates = self._extract(self.particles, w, z, held)
        X, W = self.particles, w
        if z.shape[0]:
            J = phd.particles_per_birth
            eps = self.rng.standard_normal((z.shape[0], J, 4))
            Lr = np.linalg.cholesky(R)
            born = np.empty((z.shape[0], J, 4))
            born[:, :, [0, 2]] = z[:, None] + np.einsum("mij,mnj->mni", Lr, eps[:, :, :2])
            born[:, :, [1, 3]] = phd.birth_velocity_std_mps * eps[:, :, 2:]
            X = np.concatenate([X, born.reshape(-1, 4)])
            W = np.concatenate([W, np.repeat(newborn / J, J)])
        self._resample(X, W)
        return self._associate(*self.estimates, scan_index)

    def measurements(self, detections: Sequence[Detections]) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The scan's position measurements: ``z (M, 2)``, ``R (M, 2, 2)``, clutter intensity ``kappa (M,)`` [1/m^2].

        Fused positions as given; per-pair bistatic ranges through the network chain (module docstring, step 1).
        """
        cfg, phd = self.cfg, self.phd
        zs, Rs, ks, ranges = [], [], [], []
        for det in detections:  # pairs: a handful
            names = det.measurement_names
            if names == _POSITION_NAMES:
                if len(det):
                    zs.append(det.z)
                    Rs.append(det.R)
                    ks.append(np.maximum(det.clutter_intensity, cfg.min_clutter_intensity))
            elif "bistatic_range" in names:
                if len(det):
                    ranges.append(det)
            else:
                raise ValueError(f"PhdTracker: measurements {names} are neither fused positions nor bistatic ranges")
        if len({(d.tx, d.rx) for d in ranges}) >= phd.nu:
            r = np.concatenate([d.z[:, d.measurement_names.index("bistatic_range")] for d in ranges])
            pair = np.concatenate([np.full(len(d), i, np.int64) for i, d in enumerate(ranges)])
            tx = np.concatenate([np.broadcast_to(self.tx_pos[d.tx], (len(d), 2)) for d in ranges])
            rx = np.concatenate([np.broadcast_to(self.rx_pos[d.rx], (len(d), 2)) for d in ranges])
            p, cov, _ = locate(
                r,
                np.ones_like(r),
                pair,
                tx,
                rx,
                self.area,
                phd.nu,
                0.0,
                phd.max_residual_m,
                phd.cluster_distance_m,
                phd.linkage,
                phd.range_std_m,
            )
            if p.shape[0]:
                zs.append(p)
                Rs.append(cov)
                ks.append(np.full(p.shape[0], max(phd.false_position_density_per_m2, cfg.min_clutter_intensity)))
        if not zs:
            return np.zeros((0, 2)), np.zeros((0, 2, 2)), np.zeros(0)
        if len(zs) == 1:
            return np.asarray(zs[0], float), np.asarray(Rs[0], float), np.asarray(ks[0], float)
        return np.concatenate(zs), np.concatenate(Rs), np.concatenate(ks)

    def _pd(self, pos: FloatArray) -> FloatArray:
        """P_D of the fused position measurement at ``pos`` (N, 2) (the sensor model on a ``pd_grid_m`` grid)."""
        if self.pd_model is None:
            return np.full(pos.shape[0], self.cfg.detection_probability)
        g = self.phd.pd_grid_m
        if g == 0.0:
            return np.asarray(self.pd_model(0, -1, pos), dtype=float)
        centres, inverse = occupied_cells(pos, self.area[[0, 2]], g)
        return np.asarray(self.pd_model(0, -1, centres), dtype=float)[inverse]

    def _predict_particles(self, dt: float) -> None:
        """Prediction of the particles (module docstring, step 2)."""
        n = self.particles.shape[0]
        if n == 0:
            return
        F, _, G = self._model(dt)
        a = self.rng.standard_normal((n, 2)) * self.phd.accel_noise_std_mps2
        X = self.particles @ F[:4, :4].T + a @ G[:4].T
        m = self.phd.area_margin_m
        x0, x1, y0, y1 = self.area
        inside = (X[:, 0] >= x0 - m) & (X[:, 0] <= x1 + m) & (X[:, 2] >= y0 - m) & (X[:, 2] <= y1 + m)
        w = self.weights * self.phd.survival_probability
        if not inside.all():
            X, w = X[inside], w[inside]
        self.particles, self.weights = X, w

    def _resample(self, X: FloatArray, W: FloatArray) -> None:
        """Systematic resampling to ``particles_per_target`` per unit of mass (module docstring, step 4)."""
        phd = self.phd
        mass = float(W.sum())
        if X.shape[0] == 0 or mass <= 0.0:
            self.particles, self.weights = np.zeros((0, 4)), np.zeros(0)
            return
        n = int(min(max(round(mass * phd.particles_per_target), phd.min_particles), phd.max_particles))
        idx = systematic_resample(W, n, self.rng)
        self.particles = X[idx]
        self.weights = np.full(n, mass / n)

    def _extract(
        self, X: FloatArray, w: FloatArray, z: FloatArray, z_mass: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """EM peak extraction (module docstring, step 5).

        Returns masses ``(K,)``, states ``(K, 6)`` and covariances ``(K, 6, 6)`` of the K = round(mass) peaks.
        """
        phd = self.phd
        m_hat = round(float(w.sum()))
        if m_hat == 0 or X.shape[0] == 0:
            return np.zeros(0), np.zeros((0, 6)), np.zeros((0, 6, 6))
        order = np.argsort(-z_mass, kind="stable")
        extra = int((z_mass[order[m_hat:]] >= phd.em_min_seed_mass).sum()) if z.shape[0] > m_hat else 0
        k = m_hat + min(extra, phd.em_extra_components)
        seeds = [z[order[:k]]]
        short = k - seeds[0].shape[0]
        if short > 0 and len(self._tracks):
            heads = self._tracks.x[:, 0][:, [0, 2]]
            seeds.append(heads[:short])
            short -= seeds[-1].shape[0]
        if short > 0:
            seeds.append(X[systematic_resample(w, short, self.rng)][:, [0, 2]])
        s2 = np.concatenate(seeds)
        s4 = np.zeros((s2.shape[0], 4))
        s4[:, [0, 2]] = s2
        mass, means, covs = em_mixture(X, w, s4, (0, 2), phd.em_iterations, phd.em_tolerance)
        top = np.argsort(-mass, kind="stable")[:m_hat]
        mass, means, covs = mass[top], means[top], covs[top]
        x = np.zeros((top.size, 6))
        x[:, :4] = means
        P = np.zeros((top.size, 6, 6))
        P[:, :4, :4] = covs
        P[:, 4, 4] = P[:, 5, 5] = ZERO_ACCELERATION_STD**2
        return mass, x, P

    def _associate(self, mass: FloatArray, x: FloatArray, P: FloatArray, scan_index: int) -> TrackSet:
        """Association of the estimates to the tracks and the state machine (module docstring, step 6)."""
        phd, t = self.phd, self._tracks
        T, K = len(t), x.shape[0]
        updated = np.zeros(T, bool)
        used = np.zeros(K, bool)
        if T and K:
            head = t.x[:, 0][:, [0, 2]]
            cost = np.linalg.norm(head[:, None] - x[None][:, :, [0, 2]], axis=-1)
            ri, ci = linear_sum_assignment(cost)
            if cost[ri, ci].sum() > phd.max_hypothesis_cost_m:  # gate each association
                S = t.P[ri, 0][:, [0, 2]][:, :, [0, 2]] + P[ci][:, [0, 2]][:, :, [0, 2]]
                nu = x[ci][:, [0, 2]] - head[ri]
                d2 = np.einsum("ni,ni->n", nu, np.linalg.solve(S, nu[:, :, None])[:, :, 0])
                ok = d2 <= self._gate2
                ri, ci = ri[ok], ci[ok]
            updated[ri] = used[ci] = True
            t.x[ri, 0], t.P[ri, 0] = x[ci], P[ci]
            t.existence[ri] = np.clip(mass[ci], 0.0, 1.0)
        status, hits, misses = self._status.copy(), self._hits.copy(), self._misses.copy()
        hits = np.where(updated, hits + 1, 0)
        misses = np.where(updated, 0, misses + 1)
        status[updated & (status == SILENT)] = CONFIRMED
        status[updated & (status == UNCONFIRMED) & (hits >= phd.confirm_updates)] = CONFIRMED
        status[~updated & (status == CONFIRMED)] = SILENT
        t.existence[~updated] *= phd.survival_probability
        m = phd.area_margin_m
        x0, x1, y0, y1 = self.area
        xs, ys = t.x[:, 0, 0], t.x[:, 0, 2]
        outside = (xs < x0 - m) | (xs > x1 + m) | (ys < y0 - m) | (ys > y1 + m)
        dead = ~updated & ((status == UNCONFIRMED) | (misses > phd.silent_max_scans) | outside)
        keep = ~dead
        t.age = t.age + 1
        new = np.flatnonzero(~used)
        n = new.size
        first = CONFIRMED if phd.confirm_updates <= 1 else UNCONFIRMED
        self._status = np.concatenate([status[keep], np.full(n, first, np.int8)])
        self._hits = np.concatenate([hits[keep], np.ones(n, np.int64)])
        self._misses = np.concatenate([misses[keep], np.zeros(n, np.int64)])
        self._tracks = TrackSet(
            ids=np.concatenate([t.ids[keep], np.arange(self._next_id, self._next_id + n, dtype=np.int64)]),
            confirmed=self._status != UNCONFIRMED,
            age=np.concatenate([t.age[keep], np.zeros(n, np.int64)]),
            born=np.concatenate([t.born[keep], np.full(n, scan_index, np.int64)]),
            existence=np.concatenate([t.existence[keep], np.clip(mass[new], 0.0, 1.0)]),
            mu=np.ones((len(self._status), 1)),
            active=np.ones((len(self._status), 1), bool),
            x=np.concatenate([t.x[keep], x[new][:, None]]),
            P=np.concatenate([t.P[keep], P[new][:, None]]),
        )
        self._next_id += n
        return self._tracks

    # ------------------------------------------------------------------------------------------- lookahead
    def scored_prediction(self, time_s: float, scan_index: int) -> Prediction | None:
        """The confirmed (and silent) tracks, else every track, predicted to ``time_s`` as Gaussians (pure)."""
        t = self._tracks
        if not len(t):
            return None
        keep: BoolArray = t.confirmed if t.confirmed.any() else np.ones(len(t), bool)
        x, P = t.x[keep, 0], t.P[keep, 0]
        if self._time is not None and time_s != self._time:
            x, P = self._predict_gaussians(x, P, time_s - self._time)
        else:
            x, P = x.copy(), P.copy()
        return Prediction(x, P, np.ones((x.shape[0], 1)), np.ones(1, bool))

    def predict_gaussians(self, pred: Prediction, dt: float, scan_index: int) -> Prediction:
        """``pred`` predicted ``dt`` later with the NCV model (pure)."""
        x, P = self._predict_gaussians(pred.x, pred.P, dt)
        return Prediction(x, P, pred.mu.copy(), pred.active.copy())
