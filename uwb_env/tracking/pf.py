r"""Seed 002's particle filter: passive navigation of one person by a network of monostatic UWB radars.

``TrackerConfig.kind = "pf"`` (``uwb_env.tracking.registry``), configured by ``TrackerConfig.pf`` (``PfConfig``).
The belief of the target position is N_p weighted particles (seed 002 eq. 12), propagated by a Gaussian mobility
model (eqs. 13, 15) and reweighted by the perception model of the scan's ranges (eqs. 14, 19-20):

Mobility (eq. 15: p_k ~ N(mu_m, sigma_m^2 I), per particle):

- SKDU, speed known direction unknown (eq. 16): mu_m = p_{k-1} + v T (cos theta, sin theta), theta ~ U[-pi, pi].
  The displacement d = p_k - p_{k-1} has E[d] = 0 and Cov[d] = (v^2 T^2 / 2 + sigma_m^2) I.
- SDL, speed and direction learnt (eqs. 17-18): mu_m = p_{k-1} + v_el T with v_el the mean velocity of the last
  N_v estimates. The seed's eq. 17 is garbled in print (a sum over a window of differences of past estimates,
  a stray "2"); we read it as the window average v_el = (p^_{k-1} - p^_{k-1-N_v}) / (N_v T) (the mean of the N_v
  successive differences over T). E[d] = v_el T, Cov[d] = sigma_m^2 I. Until N_v + 1 estimates exist the SDL
  filter moves its particles as SKDU does (the seed does not say how its window starts; our choice).
- sigma_m: the seed's rule "with probability 0.9 the new position is within a circle centred on mu_m of radius
  v T": for a 2-D isotropic Gaussian P(|d - mu| < r) = 1 - exp(-r^2 / (2 sigma^2)), so
  sigma_m = v T / sqrt(-2 ln 0.1) = 0.093 m at T = 0.2 s (the seed prints "sigma_m = 1m", which contradicts its own
  rule; we read the rule). ``PfConfig.mobility_std_m > 0`` fixes it instead.
- Walls (``PfConfig.respect_walls``; the seed is silent, our choice): a move whose segment crosses a wall is redrawn
  up to ``wall_redraws`` times, then the particle stays where it was; vectorised segment intersection over
  particles x walls (``blocked_moves``: the compiled twin of ``uwb_env.scene.geometry.segments_cross``). No particle
  ever crosses a wall.

Every particle carries a velocity, its last displacement over the scan interval (d / T): the 6-D state the other
trackers report ``[x, vx, y, vy, ax, ay]``, with zero acceleration.

Perception (eqs. 19-20, and section III's Gaussian ToA error with the wall bias mu_i(p)): for each radar pair that
listened and each of its detections j (bistatic range z_j = 2 d_j for a monostatic radar),

    h(p)  = |p - s_tx| + |p - s_rx| + c tau_walls(p)     (tau_walls: the walls' excess delay on both legs, the bias
                                                          of section II-D, ``uwb_env.channel.walls``; 0 without
                                                          ``wall_bias``)
    s_j^2 = R_j                 likelihood "snr": each detection's own variance, i.e. the energy detector's
                                three-region sigma(SNR) of eq. 9 (``uwb_env.waveforms.toa_models``, applied by the
                                sensor when it formed the detection)
          = (2 sigma_p)^2       likelihood "seed": eq. 20's fixed sigma_p on the one-way distance
          = R_j + (2 sigma_p)^2 likelihood "both"

Eq. 19 multiplies one Gaussian per radar and assumes every radar measures the target. Real scans miss the person
(walls, the RCS fades) and carry false detections, on which the seed is silent; we use the single-target PDA
likelihood of each pair (Bar-Shalom's probabilistic data association for one target):

    p(Z_i | p) propto (1 - P_D(p)) + P_D(p) sum_j N(z_j; h(p), s_j^2) / lambda_j,

with P_D(p) the sensor model's Pd at the particle (``pd_model``; the constant ``detection_probability`` without
one), floored at ``detection_probability_floor`` and capped at ``max_detection_probability``, and lambda_j the
clutter density in bistatic range: the detection's ``clutter_intensity``, at least the pair's
``expected_false_alarms`` spread over its bistatic-range span of the surveillance area. A radar that listened and
saw nothing contributes 1 - P_D(p) (negative information). The weights are updated in the log domain.

Resampling: systematic, when the effective sample size 1 / sum w^2 falls below ``resample_threshold`` N_p.

Initialisation: at the first scan with any detection, N_p particles uniform over the surveillance area (with
``init_std_m > 0``: on the iso-range ellipses of that scan's detections -- a monostatic radar's circles --,
Gaussian across them, ``ellipse_samples``) are weighted by that
scan's likelihood. From then on the filter has one track; it is confirmed while the ESS after the update is at
least ``confirm_ess_fraction`` N_p (a cloud whose weights collapse onto a handful of particles no longer
represents the belief; the track stays, tentative, and recovers by resampling and moving).

Estimate: the seed estimates the position as the maximiser of the belief (MAP); we report the weighted mean and
covariance of the particles (MMSE; the MAP of a particle cloud needs a density estimate), which is what the other
trackers' consumers read. ``scored_prediction`` is the exact first and second moment of the next cloud (the
mobility model's displacement is independent of the particle; exact away from walls -- a move redrawn at a wall
is not in the moments), computed analytically, so it neither changes the filter nor draws from its generator.
``predict_gaussians`` applies the same moment map to a Gaussian: position p + d, velocity d / dt, with
d ~ (E[d], Cov[d]) of the model (SDL with a full window: E[d] = the Gaussian's mean velocity x dt, the learnt
velocity held over the step). The lookahead's expected update is that of these Gaussians under the UKF
(``filter = "ukf"``, ``tracking.expectation``).

Against the seed (``python benchmarks/pf_throughput.py --neo``: 80 % point of the NEO over 5 random 20 m walks on
``indoor-monostatic``, T = 0.2 s, SKDU; LOS = the same floor with walls transparent to the radio). With the seed's
own perception model (likelihood "seed") the LOS Fig. 2 is reproduced, trend included: 0.72 / 1.03 / 1.32 m for
N_pulse 32 / 128 / 512 against the seed's 0.8 / 1.0 / 1.2 m; Fig. 3's T_int trend is flatter (0.96 / 1.03 /
1.09 m against 0.6 / 0.9 / 1.5 m). Behind walls (OLOS) the fixed sigma_p loses the person (4.7-5.7 m against
the seed's 2.0-2.9 m; 1.10 m at N_pulse 32): most detections then come from the low-SNR region of eq. 9, metres
wide. The default likelihood ("snr", each detection's own sigma(SNR)) does better than the seed everywhere: LOS
0.37 / 0.53 / 0.70 m, OLOS 0.84 / 0.92 / 1.11 m (N_pulse) and 0.72 / 0.92 / 0.97 m (T_int 2 / 4 / 6 ns).
Fig. 4 (OLOS): SKDU 0.94 / 0.92 / 1.45 m at T = 0.5 / 0.2 / 0.1 s (seed: below 2.7 m at 0.5 and 0.2 s); SDL
2.81 / 3.57 / 5.47 m -- worse than SKDU at every T, where the seed finds them equal at 0.2 s and SDL best at
0.1 s: the window velocity of N_v = 5 noisy estimates spans only N_v T (0.5 s at T = 0.1 s), and with
sigma_m ~ v T (0.047 m at 0.1 s) the particles cannot leave a wrong learnt velocity. The seed's sigma_m also makes
the SKDU cloud overconfident: position NEES ~6 (2 expected) at T = 0.2 s on ``indoor-monostatic``, ~2.5 with
sigma_m = 0.2 m (which also lowers the 80 % point to 0.72 m). With sigma_m = 0.2 m SDL and SKDU are close at
T = 0.2 s (0.79 / 0.72 m, as the seed finds) and SKDU stays better at 0.1 s (0.51 against 0.87 m).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numba as nb
import numpy as np

from uwb_env.config import PfConfig, TrackerConfig
from uwb_env.constants import SPEED_OF_LIGHT_MPS
from uwb_env.scene.layout import SceneLayout
from uwb_env.sensing.records import Detections
from uwb_env.tracking.expectation import ReductionModel, gaussian_expected_update
from uwb_env.tracking.trackset import Prediction, TrackSet
from uwb_env.typing import FloatArray

PdModel = Callable[[int, int, FloatArray], FloatArray]
ACCELERATION_STD = 0.01
"""Std [m/s^2] of the (zero) acceleration the filter reports, so the 6-D covariance stays positive definite."""
DEFAULT_SEED = 0
"""Seed of the generator ``reset(None)`` uses (deterministic default)."""
_LOG_2PI = math.log(2.0 * math.pi)
_jit = nb.njit(cache=True, fastmath=False, nogil=True)


# --------------------------------------------------------------------------- compiled wall tests (particles x walls)
@_jit
def _crosses(p0x, p0y, p1x, p1y, ax, ay, bx, by):  # pragma: no cover - compiled
    """Whether segment p0 -> p1 crosses segment a -> b: ``uwb_env.scene.geometry.segments_cross``'s arithmetic."""
    dx, dy = p1x - p0x, p1y - p0y
    ex, ey = bx - ax, by - ay
    wx, wy = ax - p0x, ay - p0y
    denom = dx * ey - dy * ex
    if abs(denom) < 1e-12:
        return False
    t = (wx * ey - wy * ex) / denom
    u = (wx * dy - wy * dx) / denom
    return t >= 0.0 and t <= 1.0 and u >= 0.0 and u <= 1.0


@_jit
def blocked_moves(p0, p1, wall_a, wall_b):  # pragma: no cover - compiled
    """``(N,)`` whether each move ``p0[i] -> p1[i]`` (N, 2) crosses any wall ``wall_a[w] -> wall_b[w]`` (W, 2)."""
    n, w = p0.shape[0], wall_a.shape[0]
    out = np.zeros(n, np.bool_)
    for i in range(n):
        for j in range(w):
            if _crosses(p0[i, 0], p0[i, 1], p1[i, 0], p1[i, 1], wall_a[j, 0], wall_a[j, 1], wall_b[j, 0], wall_b[j, 1]):
                out[i] = True
                break
    return out


@_jit
def leg_delays(node, pos, wall_a, wall_b, delay_s):  # pragma: no cover - compiled
    """``(N,)`` summed excess delay [s] of the walls crossed by each leg ``node (2,) -> pos[i]`` (N, 2).

    The compiled twin of ``uwb_env.channel.walls.leg_crossings`` followed by ``@ delay_s`` (tested equal).
    """
    n, w = pos.shape[0], wall_a.shape[0]
    out = np.zeros(n)
    for i in range(n):
        acc = 0.0
        for j in range(w):
            if _crosses(node[0], node[1], pos[i, 0], pos[i, 1], wall_a[j, 0], wall_a[j, 1], wall_b[j, 0], wall_b[j, 1]):
                acc += delay_s[j]
        out[i] = acc
    return out


# --------------------------------------------------------------------------------------- mobility models (eqs. 15-18)
def mobility_std(pf: PfConfig, dt: float) -> float:
    """sigma_m [m] over ``dt`` [s]: ``mobility_std_m``, or the seed's 90 %-in-radius-v-T rule (module docstring)."""
    if pf.mobility_std_m > 0.0:
        return pf.mobility_std_m
    return pf.speed_mps * dt / math.sqrt(-2.0 * math.log(1.0 - pf.mobility_containment))


def skdu_displacements(n: int, speed_mps: float, dt: float, sigma_m: float, rng: np.random.Generator) -> FloatArray:
    """``(n, 2)`` SKDU displacements (eq. 16 in eq. 15): v dt (cos theta, sin theta) + N(0, sigma_m^2 I)."""
    theta = rng.uniform(-math.pi, math.pi, n)
    step = speed_mps * dt * np.column_stack((np.cos(theta), np.sin(theta)))
    return step + sigma_m * rng.standard_normal((n, 2))


def sdl_displacements(n: int, velocity: FloatArray, dt: float, sigma_m: float, rng: np.random.Generator) -> FloatArray:
    """``(n, 2)`` SDL displacements (eq. 18 in eq. 15): v_el dt + N(0, sigma_m^2 I), ``velocity`` (2,) [m/s]."""
    return np.asarray(velocity, float) * dt + sigma_m * rng.standard_normal((n, 2))


def sdl_velocity(estimates: FloatArray, times: FloatArray, window: int) -> FloatArray | None:
    """v_el (eq. 17 as read, module docstring): ``(2,)`` mean velocity over the last ``window`` steps.

    ``estimates``: ``(K, 2)`` past position estimates, oldest first, at ``times`` (K,) [s] (N_v T apart at a
    regular scan period T); None with fewer than ``window + 1``.
    """
    if estimates.shape[0] < window + 1:
        return None
    span = times[-1] - times[-1 - window]
    return (estimates[-1] - estimates[-1 - window]) / span if span > 0.0 else None


def displacement_moments(pf: PfConfig, dt: float, velocity: FloatArray | None) -> tuple[FloatArray, float]:
    """Mean ``(2,)`` and per-axis variance of one displacement of the mobility model over ``dt``.

    SKDU (or SDL before its window fills, ``velocity`` None): mean 0, variance v^2 dt^2 / 2 + sigma_m^2 (the uniform
    heading's (cos, sin) has per-axis variance 1/2); SDL: mean ``velocity`` dt, variance sigma_m^2.
    """
    sigma = mobility_std(pf, dt)
    if pf.mobility == "sdl" and velocity is not None:
        return np.asarray(velocity, float) * dt, sigma**2
    return np.zeros(2), 0.5 * (pf.speed_mps * dt) ** 2 + sigma**2


def move_particles(
    pos: FloatArray,
    draw: Callable[[int], FloatArray],
    wall_a: FloatArray,
    wall_b: FloatArray,
    redraws: int,
) -> tuple[FloatArray, FloatArray]:
    """Move ``pos (N, 2)`` by ``draw(n) -> (n, 2)`` displacements, never across a wall segment ``wall_a -> wall_b``.

    A move crossing a wall is redrawn (only those particles) up to ``redraws`` times; a particle still blocked
    stays put (zero displacement). Returns the new positions and the displacements ``(N, 2)``.
    """
    d = draw(pos.shape[0])
    if wall_a.shape[0] == 0:
        return pos + d, d
    blocked = np.flatnonzero(blocked_moves(pos, pos + d, wall_a, wall_b))
    for _ in range(redraws):
        if blocked.size == 0:
            break
        d[blocked] = draw(blocked.size)
        still = blocked_moves(pos[blocked], pos[blocked] + d[blocked], wall_a, wall_b)
        blocked = blocked[still]
    d[blocked] = 0.0
    return pos + d, d


# ------------------------------------------------------------------------------------------ perception (eqs. 19-20)
def predicted_ranges(
    pos: FloatArray, tx: FloatArray, rx: FloatArray, wall_a: FloatArray, wall_b: FloatArray, wall_delay_s: FloatArray
) -> FloatArray:
    """``(N,)`` bistatic range h(p) = |p - tx| + |p - rx| + c tau_walls(p) of particles ``pos (N, 2)``.

    tau_walls: the excess delay of the walls crossed by the tx-target and target-rx legs (seed 002 section II-D,
    ``uwb_env.channel.walls``; a monostatic radar counts its one leg twice). Pass no walls for no bias.
    """
    h = np.linalg.norm(pos - tx, axis=1) + np.linalg.norm(pos - rx, axis=1)
    if wall_a.shape[0] == 0 or not np.any(wall_delay_s):
        return h
    pos = np.ascontiguousarray(pos, dtype=float)
    delay = leg_delays(tx, pos, wall_a, wall_b, wall_delay_s)
    delay = delay + (leg_delays(rx, pos, wall_a, wall_b, wall_delay_s) if np.any(tx != rx) else delay)
    return h + SPEED_OF_LIGHT_MPS * delay


def pair_log_likelihood(
    h: FloatArray, z: FloatArray, var: FloatArray, pd: FloatArray, clutter_density: FloatArray
) -> FloatArray:
    """``(N,)`` log p(Z | p) of one pair's scan (module docstring), up to a constant independent of the particle.

    Args:
        h: ``(N,)`` predicted bistatic ranges; z: ``(M,)`` measured ones; var: ``(M,)`` their variances;
        pd: ``(N,)`` detection probability at each particle; clutter_density: ``(M,)`` lambda_j [1/m].

    log[(1 - P_D) + P_D sum_j N(z_j; h, var_j) / lambda_j], by a log-sum-exp over the M + 1 hypotheses.
    """
    pd = np.asarray(pd, float)
    log_miss = np.log1p(-np.minimum(pd, 1.0 - 1e-12))
    if z.shape[0] == 0:
        return log_miss
    r = z[None, :] - h[:, None]  # (N, M)
    log_det = np.log(pd)[:, None] - 0.5 * (r * r / var + np.log(var) + _LOG_2PI) - np.log(clutter_density)
    top = np.maximum(log_det.max(axis=1), log_miss)
    return top + np.log(np.exp(log_miss - top) + np.exp(log_det - top[:, None]).sum(axis=1))


def ellipse_samples(
    tx: FloatArray, rx: FloatArray, z: FloatArray, pick: FloatArray, std_m: float, rng: np.random.Generator
) -> FloatArray:
    """``(N, 2)`` points on the iso-range ellipses of the detections ``pick`` (N,), angle uniform.

    Detections: bistatic ranges ``z`` (M,), foci ``tx``, ``rx`` (M, 2); each point's range is spread by
    N(0, ``std_m``^2). Ellipse |p - tx| + |p - rx| = r: centre (tx + rx) / 2, semi-axes a = r / 2 and
    b = sqrt(a^2 - f^2), f the half baseline, rotated to the baseline; a monostatic radar's: the circle of radius r / 2.
    """
    t, r = tx[pick], rx[pick]
    f = 0.5 * np.linalg.norm(r - t, axis=1)
    a = np.maximum(0.5 * np.abs(z[pick] + std_m * rng.standard_normal(pick.size)), f)
    b = np.sqrt(a * a - f * f)
    theta = rng.uniform(-math.pi, math.pi, pick.size)
    base = r - t
    phi = np.arctan2(base[:, 1], base[:, 0])
    u, v = a * np.cos(theta), b * np.sin(theta)
    c = 0.5 * (t + r)
    return c + np.column_stack((u * np.cos(phi) - v * np.sin(phi), u * np.sin(phi) + v * np.cos(phi)))


def systematic_resample(weights: FloatArray, rng: np.random.Generator) -> FloatArray:
    """Indices ``(N,)`` of systematic resampling of normalised ``weights (N,)`` (one uniform draw)."""
    n = weights.shape[0]
    u = (rng.uniform() + np.arange(n)) / n
    cdf = np.cumsum(weights)
    cdf[-1] = 1.0
    return np.searchsorted(cdf, u, side="right").clip(0, n - 1)


def effective_sample_size(weights: FloatArray) -> float:
    """1 / sum w^2 of normalised ``weights``."""
    return float(1.0 / np.dot(weights, weights))


def _moment_state(pos: FloatArray, vel: FloatArray, w: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Weighted mean ``(6,)`` and covariance ``(6, 6)`` of particles in the state layout ``[x, vx, y, vy, ax, ay]``."""
    s = np.column_stack((pos[:, 0], vel[:, 0], pos[:, 1], vel[:, 1]))  # (N, 4)
    m4 = w @ s
    c = s - m4
    P4 = (c * w[:, None]).T @ c
    x = np.zeros(6)
    x[:4] = m4
    P = np.zeros((6, 6))
    P[:4, :4] = 0.5 * (P4 + P4.T) + 1e-9 * np.eye(4)
    P[4, 4] = P[5, 5] = ACCELERATION_STD**2
    return x, P


def _predict_moments(
    x: FloatArray, P: FloatArray, d_mean: FloatArray, d_var: float, dt: float
) -> tuple[FloatArray, FloatArray]:
    """Moment map of ``x (N, 6)``, ``P (N, 6, 6)``: position + d, velocity d / dt, d independent of the state."""
    n = x.shape[0]
    xo = np.zeros_like(x)
    Po = np.zeros_like(P)
    pos_i, vel_i = np.array([0, 2]), np.array([1, 3])
    xo[:, pos_i] = x[:, pos_i] + d_mean
    xo[:, vel_i] = d_mean / dt
    Po[:, pos_i[:, None], pos_i[None]] = P[:, pos_i[:, None], pos_i[None]] + d_var * np.eye(2)
    Po[:, vel_i[:, None], vel_i[None]] = d_var / dt**2 * np.eye(2)
    Po[:, pos_i[:, None], vel_i[None]] = d_var / dt * np.eye(2)
    Po[:, vel_i[:, None], pos_i[None]] = d_var / dt * np.eye(2)
    Po[:, 4, 4] = Po[:, 5, 5] = ACCELERATION_STD**2
    return xo.reshape(n, 6), Po


class ParticleFilterTracker:
    """Seed 002's single-target particle filter behind the tracker seam (``uwb_env.tracking.protocol``).

    Args:
        cfg: the ``TrackerConfig`` (``cfg.pf``: the filter's own parameters); layout: the scene (node positions,
        walls, surveillance area); pd_model: optional ``(tx, rx, positions (N, 2)) -> Pd (N,)``.
    """

    kind = "pf"
    filter = "ukf"

    def __init__(self, cfg: TrackerConfig, layout: SceneLayout, pd_model: PdModel | None = None) -> None:
        self.cfg = cfg
        self.pf = cfg.pf
        self.layout = layout
        self.pd_model = pd_model
        self.model_names = (cfg.pf.mobility,)
        self.tx_pos = np.asarray(layout.tx_pos, float)
        self.rx_pos = np.asarray(layout.rx_pos, float)
        self.area = np.asarray(layout.area, float)
        self._wall_a = np.asarray(layout.wall_start, float).reshape(-1, 2)
        self._wall_b = np.asarray(layout.wall_end, float).reshape(-1, 2)
        self._wall_delay = np.asarray(layout.wall_delay_s, float).reshape(-1)
        x0, x1, y0, y1 = self.area
        corners = np.array([[x0, y0], [x0, y1], [x1, y0], [x1, y1]])
        # each pair's span of bistatic range over the area: where its false alarms fall
        self._span = {
            (t, r): max(
                float(
                    (
                        np.linalg.norm(corners - self.tx_pos[t], axis=1)
                        + np.linalg.norm(corners - self.rx_pos[r], axis=1)
                    ).max()
                ),
                1.0,
            )
            for t in range(self.tx_pos.shape[0])
            for r in range(self.rx_pos.shape[0])
        }
        self.reset()

    @classmethod
    def from_layout(
        cls, cfg: TrackerConfig, layout: SceneLayout, pd_model: PdModel | None = None
    ) -> ParticleFilterTracker:
        """The registry's factory (``uwb_env.tracking.registry``)."""
        return cls(cfg, layout, pd_model)

    # ----------------------------------------------------------------------------------------------- state
    def reset(self, rng: np.random.Generator | None = None) -> None:
        """Forget the target; ``rng``: the episode's ``tracker`` stream (None: a fixed-seed generator)."""
        self._rng = rng if rng is not None else np.random.default_rng(DEFAULT_SEED)
        self._pos: FloatArray | None = None
        self._vel: FloatArray | None = None
        self._w: FloatArray | None = None
        self._time: float | None = None
        self._estimates: list[FloatArray] = []
        self._estimate_times: list[float] = []
        self._born = 0
        self._age = 0
        self.ess = 0.0
        self.resampled = False
        self._tracks = TrackSet.empty(1)

    @property
    def tracks(self) -> TrackSet:
        """The track after the last step: none before the first scan with detections, then one."""
        return self._tracks

    @property
    def particles(self) -> tuple[FloatArray, FloatArray, FloatArray] | None:
        """``(positions (N, 2), velocities (N, 2), weights (N,))`` or None before initialisation (copies)."""
        if self._pos is None or self._vel is None or self._w is None:
            return None
        return self._pos.copy(), self._vel.copy(), self._w.copy()

    def _velocity(self) -> FloatArray | None:
        """SDL's learnt velocity (None: SKDU, or the window is not full yet)."""
        if self.pf.mobility != "sdl":
            return None
        return sdl_velocity(np.asarray(self._estimates), np.asarray(self._estimate_times), self.pf.sdl_window)

    def _draw(self, dt: float) -> Callable[[int], FloatArray]:
        pf, rng = self.pf, self._rng
        sigma = mobility_std(pf, dt)
        velocity = self._velocity()
        if velocity is None:
            return lambda n: skdu_displacements(n, pf.speed_mps, dt, sigma, rng)
        return lambda n: sdl_displacements(n, velocity, dt, sigma, rng)

    def _walls(self) -> tuple[FloatArray, FloatArray]:
        if self.pf.respect_walls:
            return self._wall_a, self._wall_b
        return np.zeros((0, 2)), np.zeros((0, 2))

    # ----------------------------------------------------------------------------------------- likelihood
    def log_likelihood(self, pos: FloatArray, detections: Sequence[Detections]) -> FloatArray:
        """``(N,)`` log p(scan | particle) of particles ``pos (N, 2)`` (module docstring), summed over the pairs."""
        pf, cfg = self.pf, self.cfg
        total = np.zeros(pos.shape[0])
        no_walls = (np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0))
        bias = (self._wall_a, self._wall_b, self._wall_delay) if pf.wall_bias else no_walls
        for det in detections:  # the pairs of a scan: a handful (vectorised over particles and detections)
            tx, rx = int(det.tx), int(det.rx)
            if self.pd_model is not None:
                pd = np.asarray(self.pd_model(tx, rx, pos), float).reshape(-1)
            else:
                pd = np.full(pos.shape[0], cfg.detection_probability)
            pd = np.clip(pd, pf.detection_probability_floor, cfg.max_detection_probability)
            n = len(det)
            if n == 0:
                total += np.log1p(-pd)
                continue
            if det.measurement_names[0] != "bistatic_range":
                raise ValueError(f"pf: the first measurement must be the bistatic range, got {det.measurement_names}")
            z = np.asarray(det.z, float)[:, 0]  # seed 002 measures ToA only: other columns are not used
            r_var = np.asarray(det.R, float)[:, 0, 0]
            seed_var = (2.0 * pf.perception_std_m) ** 2
            var = {"snr": r_var, "seed": np.full(n, seed_var), "both": r_var + seed_var}[pf.likelihood]
            floor = det.expected_false_alarms / self._span[(tx, rx)]
            lam = np.maximum(np.maximum(np.asarray(det.clutter_intensity, float), floor), cfg.min_clutter_intensity)
            h = predicted_ranges(pos, self.tx_pos[tx], self.rx_pos[rx], *bias)
            total += pair_log_likelihood(h, z, var, pd, lam)
        return total

    # ----------------------------------------------------------------------------------------------- scan
    def _initialise(self, detections: Sequence[Detections]) -> None:
        pf, rng = self.pf, self._rng
        n = pf.n_particles
        x0, x1, y0, y1 = self.area
        z = np.concatenate([np.asarray(d.z, float)[:, 0] for d in detections])  # the scan's pairs: a handful
        if pf.init_std_m > 0.0 and z.size:
            counts = [len(d) for d in detections]
            tx = np.repeat(np.array([d.tx for d in detections], np.int64), counts)
            rx = np.repeat(np.array([d.rx for d in detections], np.int64), counts)
            pos = ellipse_samples(self.tx_pos[tx], self.rx_pos[rx], z, rng.integers(0, z.size, n), pf.init_std_m, rng)
            pos = np.column_stack((pos[:, 0].clip(x0, x1), pos[:, 1].clip(y0, y1)))
        else:
            pos = np.column_stack((rng.uniform(x0, x1, n), rng.uniform(y0, y1, n)))
        self._pos = pos
        self._vel = np.zeros((n, 2))
        self._w = np.full(n, 1.0 / n)

    def step(self, detections: Sequence[Detections], time_s: float, scan_index: int) -> TrackSet:
        """One scan: move the particles, weight them by the scan's likelihood, resample when the ESS is low."""
        pf = self.pf
        if self._pos is None:
            if not any(len(d) for d in detections):
                self._time = time_s
                return self._tracks
            self._initialise(detections)
            self._born = scan_index
            self._age = 0
        else:
            assert self._vel is not None
            assert self._w is not None
            dt = time_s - (self._time if self._time is not None else time_s)
            if dt > 0.0:
                wall_a, wall_b = self._walls()
                self._pos, d = move_particles(self._pos, self._draw(dt), wall_a, wall_b, pf.wall_redraws)
                self._vel = d / dt
            self._age += 1
        self._time = time_s
        assert self._pos is not None
        assert self._vel is not None
        assert self._w is not None
        logw = np.log(np.maximum(self._w, 1e-300)) + self.log_likelihood(self._pos, detections)
        logw -= logw.max()
        w = np.exp(logw)
        w /= w.sum()
        self.ess = effective_sample_size(w)
        x, P = _moment_state(self._pos, self._vel, w)
        confirmed = self.ess >= pf.confirm_ess_fraction * pf.n_particles
        self.resampled = self.ess < pf.resample_threshold * pf.n_particles
        if self.resampled:
            idx = systematic_resample(w, self._rng)
            self._pos, self._vel = self._pos[idx], self._vel[idx]
            w = np.full(pf.n_particles, 1.0 / pf.n_particles)
        self._w = w
        self._estimates.append(x[[0, 2]].copy())
        self._estimate_times.append(time_s)
        del self._estimates[: -(pf.sdl_window + 1)], self._estimate_times[: -(pf.sdl_window + 1)]
        self._tracks = TrackSet(
            ids=np.zeros(1, np.int64),
            confirmed=np.array([confirmed]),
            age=np.array([self._age], np.int64),
            born=np.array([self._born], np.int64),
            existence=np.ones(1),
            mu=np.ones((1, 1)),
            active=np.ones((1, 1), bool),
            x=x[None, None],
            P=P[None, None],
        )
        return self._tracks

    # ------------------------------------------------------------------------------------------ lookahead
    def scored_prediction(self, time_s: float, scan_index: int) -> Prediction | None:
        """The track's cloud moved to ``time_s``: its exact moments (pure; module docstring). None without a track."""
        if self._pos is None or self._w is None or self._vel is None:
            return None
        dt = time_s - (self._time if self._time is not None else time_s)
        x, P = _moment_state(self._pos, self._vel, self._w)
        if dt > 0.0:
            d_mean, d_var = displacement_moments(self.pf, dt, self._velocity())
            x, P = _predict_moments(x[None], P[None], d_mean[None], d_var, dt)
        else:
            x, P = x[None], P[None]
        return Prediction(x=x, P=P, mu=np.ones((1, 1)), active=np.ones(1, bool))

    def predict_gaussians(self, pred: Prediction, dt: float, scan_index: int) -> Prediction:
        """Moment-matched prediction of ``pred`` ``dt`` later with the mobility model (module docstring; pure)."""
        if dt <= 0.0:
            return pred
        x = np.asarray(pred.x, float)
        if self.pf.mobility == "sdl" and self._velocity() is not None:  # SDL moves as SKDU until its window fills
            d_mean = x[:, [1, 3]] * dt
            d_var = mobility_std(self.pf, dt) ** 2
        else:
            d_mean, d_var = displacement_moments(self.pf, dt, None)
            d_mean = np.broadcast_to(d_mean, (x.shape[0], 2))
        xo, Po = _predict_moments(x, np.asarray(pred.P, float), d_mean, d_var, dt)
        return Prediction(x=xo, P=Po, mu=pred.mu, active=pred.active)

    def expected_update(
        self,
        Pa: FloatArray,
        x: FloatArray,
        P: FloatArray,
        names: tuple[str, ...],
        tx_pos: FloatArray,
        rx_pos: FloatArray,
        R: FloatArray,
        pd: FloatArray,
        reduction: object,
        rho: FloatArray,
        period: FloatArray,
    ) -> FloatArray:
        """One pair's expected update of the moment-matched Gaussians (``expectation.gaussian_expected_update``)."""
        model: ReductionModel = reduction  # type: ignore[assignment]
        return gaussian_expected_update("ukf", Pa, x, P, names, tx_pos, rx_pos, R, pd, model, rho, period)
