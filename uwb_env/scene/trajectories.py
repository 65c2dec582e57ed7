"""Truth trajectories: deterministic segment paths, motion-model paths and indoor room walks.

Every generator returns states ``(S, 6)`` = ``[x, vx, y, vy, ax, ay]`` at the requested local times (seconds
since the target's birth) and a boolean ``(S,)`` mask of the times that lie inside the trajectory's lifetime.
"""

from __future__ import annotations

import math

import numpy as np

from uwb_env.config import (
    MotionModelTrajectoryConfig,
    MotionSegmentConfig,
    RoomWalkTrajectoryConfig,
    SegmentedTrajectoryConfig,
)
from uwb_env.scene.geometry import point_segment_distance, segments_cross
from uwb_env.scene.motion_models import model_transition
from uwb_env.typing import BoolArray, FloatArray


def _segment_states(
    seg: MotionSegmentConfig, p0: FloatArray, speed: float, heading: float, tau: FloatArray
) -> FloatArray:
    """States ``(n, 6)`` at times ``tau`` (n,) [s] since the start of one segment.

    cv: p = p0 + s u t. ca: speed s + a t along fixed heading u. ct: heading h0 + w t at constant speed,
    p = p0 + (s / w) [sin h - sin h0, cos h0 - cos h], acceleration w s [-sin h, cos h] (centripetal).
    """
    out = np.zeros((tau.size, 6))
    if seg.kind == "ct":
        w = seg.turn_rate_rps
        h = heading + w * tau
        out[:, 0] = p0[0] + speed / w * (np.sin(h) - math.sin(heading))
        out[:, 2] = p0[1] + speed / w * (math.cos(heading) - np.cos(h))
        out[:, 1], out[:, 3] = speed * np.cos(h), speed * np.sin(h)
        out[:, 4], out[:, 5] = -w * speed * np.sin(h), w * speed * np.cos(h)
        return out
    a = seg.acceleration_mps2
    dist = speed * tau + 0.5 * a * tau**2
    s = speed + a * tau
    u = np.array([math.cos(heading), math.sin(heading)])
    out[:, 0], out[:, 2] = p0[0] + dist * u[0], p0[1] + dist * u[1]
    out[:, 1], out[:, 3] = s * u[0], s * u[1]
    out[:, 4], out[:, 5] = a * u[0], a * u[1]
    return out


def segmented_states(cfg: SegmentedTrajectoryConfig, t: FloatArray) -> tuple[FloatArray, BoolArray]:
    """Evaluate a segment path analytically at local times ``t`` (S,) [s].

    Returns:
        states ``(S, 6)``, valid ``(S,)`` (``0 <= t <= duration``). Invalid rows hold the nearest end state.

    Raises:
        ValueError: if a deceleration would stop or reverse the target inside its segment.
    """
    t = np.asarray(t, dtype=float)
    states = np.zeros((t.size, 6))
    p0 = np.asarray(cfg.start_position_m, dtype=float)
    speed = math.hypot(*cfg.start_velocity_mps)
    heading = math.atan2(cfg.start_velocity_mps[1], cfg.start_velocity_mps[0])
    start = 0.0
    tc = np.clip(t, 0.0, cfg.duration_s)
    for i, seg in enumerate(cfg.segments):  # a handful of segments per path
        end_speed = speed + seg.acceleration_mps2 * seg.duration_s
        if end_speed <= 0:
            raise ValueError(
                f"SegmentedTrajectoryConfig.segments[{i}].acceleration_mps2 = {seg.acceleration_mps2}: the speed "
                f"{speed:.3g} m/s would reach {end_speed:.3g} m/s; it must stay > 0"
            )
        last = i == len(cfg.segments) - 1
        sel = (tc >= start) & ((tc < start + seg.duration_s) | last)
        states[sel] = _segment_states(seg, p0, speed, heading, tc[sel] - start)
        end = _segment_states(seg, p0, speed, heading, np.array([seg.duration_s]))[0]
        p0 = end[[0, 2]]
        speed = math.hypot(end[1], end[3])
        heading = math.atan2(end[3], end[1])
        start += seg.duration_s
    return states, (t >= 0.0) & (t <= cfg.duration_s + 1e-9)


def motion_model_states(
    cfg: MotionModelTrajectoryConfig, t: FloatArray, dt: float, rng: np.random.Generator
) -> tuple[FloatArray, BoolArray]:
    """Sample a motion-model path on a ``dt`` grid and read it at local times ``t`` (S,) [s].

    The path is propagated exactly with the model's ``(F, G)`` and ``w_k ~ N(0, sigma_w^2 I)`` from ``rng``
    (seed 003 eq. 4). Times between grid points take the state of the previous grid point.
    """
    F, G = model_transition(cfg.model, dt, cfg.turn_rate_rps)
    n = math.ceil(cfg.duration_s / dt - 1e-9) + 1
    w = rng.standard_normal((n - 1, 2)) * cfg.accel_noise_std_mps2
    x = np.zeros((n, 6))
    x[0, [0, 2]] = cfg.start_position_m
    x[0, [1, 3]] = cfg.start_velocity_mps
    for k in range(n - 1):  # sequential recursion over time (not over targets or detections)
        x[k + 1] = F @ x[k] + G @ w[k]
    idx = np.clip(np.floor(np.asarray(t) / dt + 1e-9).astype(int), 0, n - 1)
    return x[idx], (np.asarray(t) >= 0.0) & (np.asarray(t) <= cfg.duration_s + 1e-9)


def room_walk_polyline(
    cfg: RoomWalkTrajectoryConfig,
    wall_a: FloatArray,
    wall_b: FloatArray,
    rng: np.random.Generator,
    max_tries: int = 200,
) -> FloatArray:
    """Draw a walk of ``cfg.length_m`` that never crosses a wall (seed 002's random 20 m trajectories).

    Args:
        wall_a, wall_b: ``(W, 2)`` wall end points [m] (door gaps are simply where no wall segment is).

    Returns:
        ``(n, 2)`` vertices of the walk, ``step_m`` apart.

    Raises:
        RuntimeError: when no admissible step can be found (the start region is walled in).
    """
    region = cfg.start_region
    has_walls = wall_a.shape[0] > 0
    for _ in range(max_tries):
        p = np.array([rng.uniform(region.x_min_m, region.x_max_m), rng.uniform(region.y_min_m, region.y_max_m)])
        if not has_walls or point_segment_distance(p[None], wall_a, wall_b).min() >= cfg.wall_clearance_m:
            break
    else:
        raise RuntimeError("RoomWalkTrajectoryConfig.start_region: no start point clear of the walls")
    n_steps = math.ceil(cfg.length_m / cfg.step_m)
    pts = [p]
    heading = rng.uniform(-math.pi, math.pi)
    for _ in range(n_steps):  # sequential walk: each step depends on the last
        for attempt in range(max_tries):
            spread = cfg.heading_change_std_rad * (1.0 + attempt / 10.0)  # widen the search when cornered
            h = heading + spread * rng.standard_normal()
            q = pts[-1] + cfg.step_m * np.array([math.cos(h), math.sin(h)])
            if not has_walls:
                break
            crosses = segments_cross(pts[-1][None], q[None], wall_a, wall_b).any()
            if not crosses and point_segment_distance(q[None], wall_a, wall_b).min() >= cfg.wall_clearance_m:
                break
        else:
            raise RuntimeError("room walk: no admissible step found; the walk is walled in")
        heading = h
        pts.append(q)
    return np.asarray(pts)


def polyline_states(vertices: FloatArray, speed_mps: float, t: FloatArray) -> tuple[FloatArray, BoolArray]:
    """Move along a polyline at constant speed; states ``(S, 6)`` at local times ``t`` (S,) [s].

    Velocity is the speed along the current leg; acceleration is reported as zero (piecewise constant velocity).
    """
    legs = np.diff(vertices, axis=0)
    leg_len = np.linalg.norm(legs, axis=1)
    cum = np.concatenate([[0.0], np.cumsum(leg_len)])
    total = cum[-1]
    s = np.clip(np.asarray(t, dtype=float) * speed_mps, 0.0, total)
    i = np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(legs) - 1)
    frac = (s - cum[i]) / leg_len[i]
    pos = vertices[i] + frac[:, None] * legs[i]
    vel = legs[i] / leg_len[i][:, None] * speed_mps
    out = np.zeros((s.size, 6))
    out[:, 0], out[:, 2] = pos[:, 0], pos[:, 1]
    out[:, 1], out[:, 3] = vel[:, 0], vel[:, 1]
    tt = np.asarray(t)
    return out, (tt >= 0.0) & (tt * speed_mps <= total + 1e-9)
