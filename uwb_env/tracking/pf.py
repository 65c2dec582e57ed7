r"""Seed 002's particle filter: passive navigation of one person by a network of monostatic UWB radars.

``TrackerConfig.kind = "pf"`` (``uwb_env.tracking.registry``), configured by ``TrackerConfig.pf`` (``PfConfig``).
The belief of the target position is N_p weighted particles (seed 002 eq. 12), propagated by a Gaussian mobility
model (eqs. 13, 15) and reweighted by the perception model of the scan's ranges (eqs. 14, 19-20):

Mobility (eq. 15: p_k ~ N(mu_m, sigma_m^2 I), per particle):

- SKDU, speed known direction unknown (eq. 16): mu_m = p_{k-1} + v T (cos theta, sin theta), theta ~ U[-pi, pi].
  The displacement d = p_k - p_{k-1} has E[d] = 0 and Cov[d] = (v^2 T^2 / 2 + sigma_m^2) I.
- SDL, speed and direction learnt (eqs. 17-18): mu_m = p_{k-1} + v_el T with v_el learnt from the last N_v + 1
  position estimates. The seed's eq. 17 is garbled in print (a sum over a window of differences of past estimates,
  a stray "2"); read literally it is the window average v_el = (p^_{k-1} - p^_{k-1-N_v}) / (N_v T) (the mean of the
  N_v successive differences over T), every particle moving by the same v_el T + N(0, sigma_m^2 I). The seed leaves
  the estimator, the window and the learnt velocity's uncertainty open; our choices (``PfConfig``), each below
  with what it fixes on Fig. 4's case (``sdl_estimator = "difference"``, ``sdl_window_s = 0``,
  ``sdl_velocity_spread = False`` restore the literal reading, N_v = ``sdl_window`` = 5):

  * ``sdl_estimator = "lsq"``: v_el = sum_i a_i p^_i, the least-squares slope of the window's estimates against
    their times, a_i = (t_i - t_bar) / S_tt, S_tt = sum (t_i - t_bar)^2 (``sdl_coefficients``): the unbiased linear
    estimator of least variance for independent estimates of equal covariance, s^2 / S_tt = 12 s^2 / (T^2 n (n^2 -
    1)) per axis with n = N_v + 1, against the difference's 2 s^2 / (N_v T)^2 (29 % less at N_v = 5; equal at
    N_v = 2). It refers to the window's mean time t_bar.
  * ``sdl_window_s`` = 1 s, the window in time: N_v = round(1 s / T) = 2 / 5 / 10 at T = 0.5 / 0.2 / 0.1 s (the
    seed's N_v = 5 at its T = 0.2 s). A fixed N_v = 5 spans 2.5 s at T = 0.5 s (the walk turns within it: lag)
    and 0.5 s at T = 0.1 s (the estimates' noise, ~0.5 m, over 0.5 s: ~1 m/s).
  * ``sdl_velocity_spread``: each particle draws its own velocity v ~ N(v_el, C_v) (``sdl_displacements``), with
    C_v = sum_i a_i^2 P_i (P_i: the cloud's position covariance at estimate i, the estimates taken as independent)
    + (sigma_a tau)^2 I, the manoeuvre over the lag tau = t_{k-1} + T / 2 - t_bar from the window's mean time to
    the middle of the move, sigma_a = ``sdl_accel_std_mps2`` = 1 m/s^2 (a walker at 1 m/s turning at ~1 rad/s;
    the scenario's walks turn at 1.1 rad/s on average). E[d] = v_el T, Cov[d] = C_v T^2 + sigma_m^2 I.

  Why (OLOS Fig. 4 case, 20 walks, T = 0.5 / 0.2 / 0.1 s): the literal SDL's learnt velocity is off by as much as
  the speed itself (median |v_el - v| 0.96 / 0.91 / 0.93 m/s), and every particle follows it with sigma_m of 0.23 /
  0.09 / 0.05 m per scan: the cloud cannot leave the wrong velocity (position NEES median 7.6 / 21 / 32, 2
  expected), its estimate feeds the next v_el (estimate -> velocity -> move -> estimate) and the track drifts (80 %
  error 3.2 / 3.2 / 4.0 m, SKDU 1.35 / 1.15 / 1.73 m). With the three choices: |v_el - v| 0.71 / 0.66 / 0.70 m/s,
  its NEES mean 0.7 / 1.5 / 2.5 (2 expected: C_v covers the velocity's error), position NEES median 1.0 / 2.1 / 5.1,
  80 % error 1.17 / 0.91 / 1.10 m. The spread is what matters: without it (least squares, 1 s window) 1.97 / 3.91 /
  3.70 m; without the manoeuvre term C_v is too small (velocity NEES median 1.4 / 9.1 / 40) and 1.26 / 1.88 / 2.71
  m; with the spread but the seed's N_v = 5 steps 1.08 / 0.91 / 1.49 m. Even from exact positions a 1 s window's
  velocity lags the turning walk by 0.41 / 0.33 / 0.32 m/s (median); the estimates' noise brings it to ~0.7 m/s: the
  learnt direction is a weak prior, and C_v says so. Sensitivity (20 walks, 80 % error at T = 0.5 / 0.2 / 0.1 s):
  window 0.5 s 1.36 / 0.90 / 1.49 m, 2 s 1.05 / 0.82 / 1.05 m; sigma_a 0.5 m/s^2 1.14 / 1.34 / 1.87 m, 2 m/s^2 1.29
  / 0.78 / 0.95 m; estimator "difference" 1.17 / 0.93 / 1.17 m.

  Until the window holds N_v + 1 estimates the SDL filter moves its particles as SKDU does (the seed does not say
  how its window starts; our choice). Open failure mode: where the scans say little for a while, the cloud moves
  at v_el and its estimates confirm v_el (dead reckoning; Cov(v_el) takes the estimates as independent, which the
  feedback makes them not): the track can run away at walking speed where SKDU's diffuse cloud waits. Seen on 1 of
  the 60 SDL runs above (walk 6 at T = 0.2 s: 80 % error 11.5 m, SKDU 1.6 m) and on walk 0 at T = 0.1 s with
  N_pulse = 32 (error growing ~1 m/s from 1 s on; SKDU stays below 1.7 m).
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
trackers' consumers read. Measured on Fig. 4's case (10 walks, MAP taken as the particle at the mode of a 0.3 m
kernel density of the cloud): the MAP's 80 % points are the MMSE's within 0.07 m for both models at every T, and
the MAP fed to SDL's learnt velocity is worse (0.89 -> 1.24 m at T = 0.2 s, 0.97 -> 1.27 m at 0.1 s).
``scored_prediction`` is the exact first and second moment of the next cloud (the
mobility model's displacement is independent of the particle; exact away from walls -- a move redrawn at a wall
is not in the moments), computed analytically, so it neither changes the filter nor draws from its generator.
``predict_gaussians`` applies the same moment map to a Gaussian: position p + d, velocity d / dt, with
d ~ (E[d], Cov[d]) of the model (SDL with a full window: E[d] = the Gaussian's mean velocity x dt, the learnt
velocity held over the step, Cov[d] = C_v dt^2 + sigma_m^2 I). The lookahead's expected update is that of
these Gaussians under the UKF (``filter = "ukf"``, ``tracking.expectation``).

Against the seed (``python scripts/seed002_neo.py --walks 5 [--likelihood seed]``: 80 % point of the NEO over 5
random 20 m walks on ``indoor-monostatic``, T = 0.2 s, SKDU; LOS = the same floor with walls transparent to the
radio). With the seed's
own perception model (likelihood "seed") the LOS Fig. 2 keeps the seed's trend, a little below it: 0.68 / 0.76 /
1.05 m for N_pulse 32 / 128 / 512 against the seed's 0.8 / 1.0 / 1.2 m; Fig. 3's T_int trend is flatter (0.70 /
0.76 / 0.81 m against 0.6 / 0.9 / 1.5 m). Behind walls (OLOS) the fixed sigma_p holds the person at 1.18-1.48 m
(the seed's 2.0-2.9 m) but loses it at N_pulse 512 (5.34 m): most detections then come from the low-SNR region of
eq. 9, metres wide. The default likelihood ("snr", each detection's own sigma(SNR)) does better than the seed
everywhere: LOS 0.36 / 0.47 / 0.63 m (N_pulse) and 0.31 / 0.47 / 0.58 m (T_int 2 / 4 / 6 ns), OLOS 0.98 / 0.88 /
1.06 m and 1.07 / 0.88 / 1.04 m, where the seed's OLOS orderings no longer hold (on 20 walks N_pulse 1.50 / 1.31 /
1.26 m, T_int 1.27 / 1.31 / 1.40 m). Figures of the per-waveform calibration of ``indoor-monostatic``.
Fig. 4 (OLOS, ``python scripts/seed002_neo.py --walks 5``): SKDU 1.06 / 0.88 / 1.40 m at T = 0.5 / 0.2 / 0.1 s
(seed: below 2.7 m at 0.5 and 0.2 s); SDL 1.08 / 0.66 / 1.25 m (seed: 5.0 and 2.7 m at 0.5 and 0.2 s, best at
0.1 s): the seed's order at 0.2 and 0.1 s, a tie at 0.5 s on these 5 walks. On 20 walks SKDU 1.31 / 1.31 / 1.72 m,
SDL 1.17 / 0.94 / 1.19 m (before the recalibration SKDU 1.35 / 1.15 / 1.73 m, SDL 1.17 / 0.91 / 1.10 m, SDL
minus SKDU -0.19 [-0.35, -0.05], -0.23 [-0.41, +0.02], -0.63 [-1.09, -0.24] m, 90 % bootstrap over walks; not
rerun): at 0.5 s the two are a few tenths apart (SDL falls back to a broad cloud when
its velocity is uncertain: C_v per axis ~0.75 m/s at 0.5 s against SKDU's v / sqrt 2); SDL's advantage grows as
T shrinks, as the seed finds, but not because its learnt velocity gets more accurate (|v_el - v| ~0.7 m/s at
every T with the 1 s window): SKDU degrades. Its cloud spreads per axis by v sqrt(T t (1/2 + 1/(2 ln 10))) in t
seconds (a step of v T in a new random direction each scan, plus sigma_m ~ v T): 0.60 / 0.38 / 0.27 m in 1 s
while the walker moves 1 m in one direction; its position NEES median grows 1.5 / 3.2 / 8.3 (20 walks). The
literal SDL (N_v = 5, no spread) gives 2.81 / 3.57 / 5.47 m on the 5 walks: the seed's order at 0.5 s (its 5 m),
worse than SKDU at every T (the SDL bullet above). The seed's sigma_m also makes the SKDU cloud overconfident:
position NEES ~6 (2 expected) at T = 0.2 s on ``indoor-monostatic``, ~2.5 with sigma_m = 0.2 m (which also lowers
the 80 % point to 0.72 m). These diagnostics (velocity errors, NEES, the literal SDL, the spread, window, sigma_a and
MAP figures above) were measured before the per-waveform recalibration of ``indoor-monostatic`` and not rerun; the
80 % points of ``seed002_neo`` above are the recalibrated ones.
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
from uwb_env.tracking.expectation import GaussianLookahead
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


def sdl_displacements(
    n: int,
    velocity: FloatArray,
    dt: float,
    sigma_m: float,
    rng: np.random.Generator,
    velocity_cov: FloatArray | None = None,
) -> FloatArray:
    """``(n, 2)`` SDL displacements (eq. 18 in eq. 15): v dt + N(0, sigma_m^2 I), ``velocity`` (2,) [m/s].

    ``velocity_cov`` (2, 2) [m^2/s^2]: each particle draws its own v ~ N(``velocity``, ``velocity_cov``) (the learnt
    velocity's uncertainty, module docstring); None or zero: every particle moves by the same v_el (the seed's).
    """
    v = np.asarray(velocity, float)
    if velocity_cov is not None and np.any(velocity_cov):
        chol = np.linalg.cholesky(np.asarray(velocity_cov, float) + 1e-12 * np.eye(2))
        v = v + rng.standard_normal((n, 2)) @ chol.T
    return v * dt + sigma_m * rng.standard_normal((n, 2))


def sdl_coefficients(times: FloatArray, window: int, estimator: str = "difference") -> FloatArray | None:
    """``(window + 1,)`` weights a_i of the learnt velocity v_el = sum_i a_i p^_i, the last ``window + 1`` estimates.

    ``difference`` (eq. 17 as read): the mean of the window's successive differences, (p^_last - p^_first) / span;
    ``lsq``: the least-squares slope of the estimates against their ``times`` (K,) [s], a_i = (t_i - t_bar) / S_tt
    with S_tt = sum (t_i - t_bar)^2 (the unbiased linear estimator of smallest variance for independent estimates of
    equal covariance). None with fewer than ``window + 1`` times or a zero span.
    """
    if times.shape[0] < window + 1:
        return None
    t = np.asarray(times[-1 - window :], float)
    if t[-1] - t[0] <= 0.0:
        return None
    if estimator == "lsq":
        c = t - t.mean()
        return c / float(c @ c)
    a = np.zeros(window + 1)
    a[0], a[-1] = -1.0 / (t[-1] - t[0]), 1.0 / (t[-1] - t[0])
    return a


def sdl_velocity(
    estimates: FloatArray,
    times: FloatArray,
    window: int,
    estimator: str = "difference",
    covs: FloatArray | None = None,
) -> FloatArray | None:
    """v_el (eq. 17, module docstring): ``(2,)`` velocity learnt from the last ``window`` steps of estimates.

    ``estimates``: ``(K, 2)`` past position estimates, oldest first, at ``times`` (K,) [s] (N_v T apart at a
    regular scan period T); None with fewer than ``window + 1``. ``estimator``: ``sdl_coefficients``.
    """
    out = sdl_velocity_moments(estimates, times, window, estimator, covs)
    return None if out is None else out[0]


def sdl_velocity_moments(
    estimates: FloatArray,
    times: FloatArray,
    window: int,
    estimator: str = "difference",
    covs: FloatArray | None = None,
) -> tuple[FloatArray, FloatArray, float] | None:
    """``(v_el (2,), Cov(v_el) (2, 2), t_ref)``: the learnt velocity, its covariance and the time it refers to.

    v_el = sum_i a_i p^_i (``sdl_coefficients``); with the estimates' covariances ``covs`` (K, 2, 2) taken as
    independent, Cov(v_el) = sum_i a_i^2 P_i (zero without ``covs``). t_ref = the window's mean time (a linear
    velocity is exact there; for equally spaced estimates the midpoint of the window for both estimators).
    """
    a = sdl_coefficients(times, window, estimator)
    if a is None:
        return None
    p = np.asarray(estimates[-1 - window :], float)
    v = a @ p
    cov = np.zeros((2, 2))
    if covs is not None:
        cov = np.einsum("i,ijk->jk", a * a, np.asarray(covs[-1 - window :], float))
    return v, cov, float(np.mean(times[-1 - window :]))


def sdl_window_steps(pf: PfConfig, dt: float) -> int:
    """N_v at scan interval ``dt`` [s]: round(``sdl_window_s`` / dt) (at least 1), or ``sdl_window`` when it is 0."""
    if pf.sdl_window_s > 0.0:
        return max(1, round(pf.sdl_window_s / dt))
    return pf.sdl_window


def displacement_moments(
    pf: PfConfig, dt: float, velocity: FloatArray | None, velocity_cov: FloatArray | None = None
) -> tuple[FloatArray, FloatArray]:
    """Mean ``(2,)`` and covariance ``(2, 2)`` of one displacement of the mobility model over ``dt``.

    SKDU (or SDL before its window fills, ``velocity`` None): mean 0, covariance (v^2 dt^2 / 2 + sigma_m^2) I (the
    uniform heading's (cos, sin) has per-axis variance 1/2); SDL: mean ``velocity`` dt, covariance
    ``velocity_cov`` dt^2 + sigma_m^2 I (the particles' velocity spread, ``sdl_displacements``).
    """
    sigma = mobility_std(pf, dt)
    if pf.mobility == "sdl" and velocity is not None:
        cov = sigma**2 * np.eye(2)
        if velocity_cov is not None:
            cov = cov + np.asarray(velocity_cov, float) * dt**2
        return np.asarray(velocity, float) * dt, cov
    return np.zeros(2), (0.5 * (pf.speed_mps * dt) ** 2 + sigma**2) * np.eye(2)


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
    x: FloatArray, P: FloatArray, d_mean: FloatArray, d_cov: FloatArray, dt: float
) -> tuple[FloatArray, FloatArray]:
    """Moment map of ``x (N, 6)``, ``P (N, 6, 6)``: position + d, velocity d / dt, d independent of the state.

    d ~ (``d_mean`` (N, 2), ``d_cov`` (2, 2) or (N, 2, 2)).
    """
    n = x.shape[0]
    xo = np.zeros_like(x)
    Po = np.zeros_like(P)
    pos_i, vel_i = np.array([0, 2]), np.array([1, 3])
    d_cov = np.broadcast_to(np.asarray(d_cov, float), (n, 2, 2))
    xo[:, pos_i] = x[:, pos_i] + d_mean
    xo[:, vel_i] = d_mean / dt
    Po[:, pos_i[:, None], pos_i[None]] = P[:, pos_i[:, None], pos_i[None]] + d_cov
    Po[:, vel_i[:, None], vel_i[None]] = d_cov / dt**2
    Po[:, pos_i[:, None], vel_i[None]] = d_cov / dt
    Po[:, vel_i[:, None], pos_i[None]] = d_cov / dt
    Po[:, 4, 4] = Po[:, 5, 5] = ACCELERATION_STD**2
    return xo.reshape(n, 6), Po


class ParticleFilterTracker(GaussianLookahead):
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
        self._estimate_covs: list[FloatArray] = []
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

    def _velocity(self, dt: float) -> tuple[FloatArray, FloatArray] | None:
        """SDL's learnt velocity for a move of ``dt`` from the last scan, and the covariance its particles draw from.

        None: SKDU, or the window is not full yet. The covariance (``sdl_velocity_spread``) is Cov(v_el) from the
        estimates' covariances plus the manoeuvre over the lag tau from the window's time to the move's midpoint,
        sigma_a^2 tau^2 I (module docstring); zero without the spread (the seed's).
        """
        pf = self.pf
        if pf.mobility != "sdl" or not self._estimates:
            return None
        out = sdl_velocity_moments(
            np.asarray(self._estimates),
            np.asarray(self._estimate_times),
            sdl_window_steps(pf, dt),
            pf.sdl_estimator,
            np.asarray(self._estimate_covs),
        )
        if out is None:
            return None
        v, cov, t_ref = out
        if not pf.sdl_velocity_spread:
            return v, np.zeros((2, 2))
        lag = self._estimate_times[-1] + 0.5 * dt - t_ref
        return v, cov + (pf.sdl_accel_std_mps2 * lag) ** 2 * np.eye(2)

    def _draw(self, dt: float) -> Callable[[int], FloatArray]:
        pf, rng = self.pf, self._rng
        sigma = mobility_std(pf, dt)
        learnt = self._velocity(dt)
        if learnt is None:
            return lambda n: skdu_displacements(n, pf.speed_mps, dt, sigma, rng)
        velocity, cov = learnt
        return lambda n: sdl_displacements(n, velocity, dt, sigma, rng, cov)

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
        self._estimate_covs.append(P[np.ix_([0, 2], [0, 2])].copy())
        self._estimate_times.append(time_s)
        # keep the last sdl_window + 1 estimates, and every one of the last 2 sdl_window_s seconds
        old = sum(1 for t in self._estimate_times if t < time_s - 2.0 * pf.sdl_window_s)
        drop = max(0, min(old, len(self._estimates) - (pf.sdl_window + 1)))
        del self._estimates[:drop], self._estimate_covs[:drop], self._estimate_times[:drop]
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
            learnt = self._velocity(dt)
            velocity, cov = (None, None) if learnt is None else learnt
            d_mean, d_cov = displacement_moments(self.pf, dt, velocity, cov)
            x, P = _predict_moments(x[None], P[None], d_mean[None], d_cov, dt)
        else:
            x, P = x[None], P[None]
        return Prediction(x=x, P=P, mu=np.ones((1, 1)), active=np.ones(1, bool))

    def predict_gaussians(self, pred: Prediction, dt: float, scan_index: int) -> Prediction:
        """Moment-matched prediction of ``pred`` ``dt`` later with the mobility model (module docstring; pure)."""
        if dt <= 0.0:
            return pred
        x = np.asarray(pred.x, float)
        learnt = self._velocity(dt) if self.pf.mobility == "sdl" else None
        if learnt is not None:  # SDL moves as SKDU until its window fills
            d_mean = x[:, [1, 3]] * dt
            d_cov = displacement_moments(self.pf, dt, learnt[0], learnt[1])[1]
        else:
            d_mean, d_cov = displacement_moments(self.pf, dt, None)
            d_mean = np.broadcast_to(d_mean, (x.shape[0], 2))
        xo, Po = _predict_moments(x, np.asarray(pred.P, float), d_mean, d_cov, dt)
        return Prediction(x=xo, P=Po, mu=pred.mu, active=pred.active)
