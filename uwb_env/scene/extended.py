r"""A walking person as a few scattering centres (``SignalConfig.target_model = "extended"``).

The body model is :class:`uwb_env.config.BodyModelConfig` (its docstring gives the centres, the gait and the RCS
shares with their sources: Boulic et al. 1990's walking model as used by V. C. Chen, *The Micro-Doppler Effect in
Radar*, 2011). Everything here is vectorised: over scans x targets for the gait, over pairs x targets x centres for
the specular points, delays and occlusions.

Centres, in the order of :data:`CENTRES`: torso, head, left arm, right arm, left leg, right leg. Body frame: x along
the heading (the velocity's direction), y to the left.
"""

from __future__ import annotations

import math

import numpy as np

from uwb_env.config import BodyModelConfig
from uwb_env.typing import BoolArray, FloatArray

CENTRES: tuple[str, ...] = ("torso", "head", "left_arm", "right_arm", "left_leg", "right_leg")
BOULIC_CYCLE_S = 1.346  # Boulic et al. 1990: cycle duration D_c = 1.346 / sqrt(RV) s, RV = v / H_t
BOULIC_MAX_RV = 2.3  # the model's validity range of the relative velocity
MIN_WALKING_SPEED_MPS = 0.05  # below: standing (no swing; the heading kept from the last walking scan)
_ARMS = np.array([False, False, True, True, False, False])


def relative_velocity(speed: FloatArray, body: BodyModelConfig) -> FloatArray:
    """Boulic's RV = v / H_t, clipped to [0, 2.3]."""
    return np.clip(np.asarray(speed, dtype=float) / body.hip_height_m, 0.0, BOULIC_MAX_RV)


def gait_period_s(speed: FloatArray, body: BodyModelConfig) -> FloatArray:
    """Cycle duration (two steps) D_c = 1.346 / sqrt(RV) [s]; ``inf`` for a standing person."""
    rv = relative_velocity(speed, body)
    with np.errstate(divide="ignore"):
        return np.where(rv > 0.0, BOULIC_CYCLE_S / np.sqrt(rv), np.inf)


def swing_sine(speed: FloatArray, body: BodyModelConfig) -> FloatArray:
    """The sine of the limbs' swing angle theta: stride / (4 H_t) = 1.346 sqrt(RV) / 4 (0 below walking speed)."""
    rv = relative_velocity(speed, body)
    return np.where(np.asarray(speed) >= MIN_WALKING_SPEED_MPS, BOULIC_CYCLE_S * np.sqrt(rv) / 4.0, 0.0)


def gait_phase(speed: FloatArray, times_s: FloatArray, body: BodyModelConfig, phase0: FloatArray) -> FloatArray:
    """``(S, K)`` gait phase [rad] at scan times ``times_s`` (S,) of speeds ``speed`` (S, K).

    phase0 (K,) + 2 pi x the sum over the earlier scans j of (t_{j+1} - t_j) / D_c(v_j) (0 while standing).
    """
    dt = np.diff(np.asarray(times_s, dtype=float))[:, None]  # (S - 1, 1)
    step = 2.0 * math.pi * dt / gait_period_s(np.asarray(speed)[:-1], body)
    cum = np.concatenate([np.zeros((1, np.shape(speed)[1])), np.cumsum(step, axis=0)], axis=0)
    return np.asarray(phase0)[None] + cum


def headings(velocity: FloatArray) -> FloatArray:
    """``(S, K)`` heading [rad] from velocities ``(S, K, 2)``, held over the scans a target stands (0 before any)."""
    speed = np.linalg.norm(velocity, axis=-1)
    raw = np.arctan2(velocity[..., 1], velocity[..., 0])
    moving = speed >= MIN_WALKING_SPEED_MPS
    S = velocity.shape[0]
    idx = np.maximum.accumulate(np.where(moving, np.arange(S)[:, None], -1), axis=0)
    held = np.take_along_axis(raw, np.maximum(idx, 0), axis=0)
    return np.where(idx >= 0, held, 0.0)


def centre_offsets(phase: FloatArray, speed: FloatArray, body: BodyModelConfig) -> FloatArray:
    """``(..., 6, 2)`` centres in the body frame for gait ``phase`` and ``speed`` (...,)."""
    phase, speed = np.asarray(phase, dtype=float), np.asarray(speed, dtype=float)
    swing = swing_sine(speed, body) * np.sin(phase)  # (...,) sin theta x the gait's phase
    leg = 0.5 * body.hip_height_m * swing
    arm = 0.5 * body.arm_length_m * swing
    zero = np.zeros_like(swing)
    y_arm = 0.5 * body.torso_width_m + body.arm_radius_m
    x = np.stack([zero, zero, -arm, arm, leg, -leg], axis=-1)  # each arm in anti-phase with its leg
    y = np.broadcast_to(np.array([0.0, 0.0, y_arm, -y_arm, body.hip_half_width_m, -body.hip_half_width_m]), x.shape)
    return np.stack([x, y], axis=-1)


def cross_sections(body: BodyModelConfig) -> FloatArray:
    """``(6, 2)`` semi-axes (along the heading, across) of the centres' horizontal cross-sections [m]."""
    t = (0.5 * body.torso_depth_m, 0.5 * body.torso_width_m)
    return np.array(
        [t, (body.head_radius_m,) * 2, (body.arm_radius_m,) * 2, (body.arm_radius_m,) * 2]
        + [(body.leg_radius_m,) * 2] * 2
    )


def shares(body: BodyModelConfig) -> FloatArray:
    """``(6,)`` RCS shares of the centres, summing to 1."""
    s = np.array([body.torso_share, body.head_share, body.arm_share, body.arm_share, body.leg_share, body.leg_share])
    return s / s.sum()


def rotate(v: FloatArray, angle: FloatArray) -> FloatArray:
    """Vectors ``v`` (..., 2) rotated by ``angle`` (broadcast against v's leading axes) [rad]."""
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)


def _unit(v: FloatArray) -> FloatArray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.where(n > 1e-12, v / np.maximum(n, 1e-300), np.array([1.0, 0.0]))


def specular_points(
    position: FloatArray,
    heading: FloatArray,
    offsets: FloatArray,
    tx: FloatArray,
    rx: FloatArray,
    body: BodyModelConfig,
) -> FloatArray:
    """``(A, K, 6, 2)`` points that scatter towards pair ``a`` (tx (A, 2), rx (A, 2)) of targets at ``position``.

    Each centre (offsets ``(K, 6, 2)`` in the body frame, heading ``(K,)``) reflects from the point of its
    cross-section ellipse (semi-axes a, b) whose outward normal n is the bisector of the directions from the body to
    the transmitter and to the receiver: (a^2 n_x, b^2 n_y) / sqrt(a^2 n_x^2 + b^2 n_y^2) in the body frame.
    """
    d = position[None]  # (1, K, 2)
    bis = _unit(_unit(tx[:, None] - d) + _unit(rx[:, None] - d))  # (A, K, 2)
    n = rotate(bis, -heading[None])[:, :, None]  # (A, K, 1, 2) body frame
    ab2 = cross_sections(body) ** 2  # (6, 2)
    num = ab2 * n  # (A, K, 6, 2)
    den = np.sqrt(np.maximum(np.sum(ab2 * n * n, axis=-1, keepdims=True), 1e-300))
    local = offsets[None] + num / den
    return d[:, :, None] + rotate(local, heading[None, :, None])


def torso_blocks(
    position: FloatArray, heading: FloatArray, start: FloatArray, node: FloatArray, body: BodyModelConfig
) -> BoolArray:
    """Whether the ray from ``start`` (A, K, 6, 2) towards ``node`` (A, 2) crosses the torso ellipse of each target.

    Only rays from outside the torso count; the torso's own centre and the rays that leave it never block.
    """
    a, b = 0.5 * body.torso_depth_m, 0.5 * body.torso_width_m
    o = rotate(start - position[None, :, None], -heading[None, :, None])  # (A, K, 6, 2) body frame
    u = rotate(_unit(node[:, None, None] - start), -heading[None, :, None])
    scale = np.array([1.0 / a, 1.0 / b])
    os_, us = o * scale, u * scale
    qa = np.sum(us * us, axis=-1)
    qb = 2.0 * np.sum(os_ * us, axis=-1)
    qc = np.sum(os_ * os_, axis=-1) - 1.0
    return (qc > 1e-9) & (qb < 0.0) & (qb * qb - 4.0 * qa * qc > 0.0)


def occlusion_loss_db(
    position: FloatArray,
    heading: FloatArray,
    offsets: FloatArray,
    tx: FloatArray,
    rx: FloatArray,
    body: BodyModelConfig,
) -> FloatArray:
    """``(A, K, 6)`` loss [dB] of the arms hidden behind the torso from the transmitter and/or the receiver."""
    start = position[None, :, None] + rotate(offsets, heading[:, None])[None]  # (1, K, 6, 2) the arms' axes
    start = np.broadcast_to(start, (tx.shape[0], *start.shape[1:]))
    blocked = torso_blocks(position, heading, start, tx, body).astype(float) + torso_blocks(
        position, heading, start, rx, body
    )
    return np.where(_ARMS, body.occlusion_loss_db * blocked, 0.0)
