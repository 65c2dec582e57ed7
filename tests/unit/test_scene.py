"""Scene and truth: the seed-003 path, segment kinematics, births, motion models, room walks, determinism."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import expm

from uwb_env import scenarios
from uwb_env.config import MotionModelTrajectoryConfig, MotionSegmentConfig, SegmentedTrajectoryConfig
from uwb_env.rng import RngStreams
from uwb_env.scenarios.urban_intersection import seed003_path
from uwb_env.scene import (
    SceneLayout,
    ct_transition,
    nca_transition,
    ncv_transition,
    process_noise,
    sample_truth,
    segments_cross,
)
from uwb_env.scene.trajectories import motion_model_states, room_walk_polyline, segmented_states


def test_seed003_path_starts_and_ends_at_the_seeds_points():
    path = seed003_path()
    s, valid = segmented_states(path, np.array([0.0, path.duration_s]))
    assert valid.all()
    np.testing.assert_allclose(s[0, [0, 2]], (1950.0, 1500.0), atol=1e-12)
    assert math.dist(s[1, [0, 2]], (2068.8, 1667.8)) < 1.0
    # the whole path takes the seed's 140 scans of 0.25 s (35 s) to within one scan
    assert abs(path.duration_s - 35.0) < 0.25


def test_seed003_path_kinematics_by_hand():
    """Hand-computed: 50 m at 10 m/s, decelerate 10 -> 5 m/s over 37.5 m, left quarter turn of radius 5/(pi/20)."""
    path = seed003_path()
    t = np.array([4.0, 10.0, 20.0, 25.0])
    s, _ = segmented_states(path, t)
    r = 5.0 / (math.pi / 20.0)
    np.testing.assert_allclose(s[0], [1990.0, 10.0, 1500.0, 0.0, 0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(s[1, :4], [2037.5, 5.0, 1500.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(s[2, [0, 1, 2, 3]], [2037.5 + r, 0.0, 1500.0 + r, 5.0], atol=1e-9)
    # mid-turn (heading pi/4) the acceleration is centripetal: |a| = w v = pi/20 * 5, towards the turn centre
    mid, _ = segmented_states(path, np.array([15.0]))
    h = math.pi / 4
    np.testing.assert_allclose(mid[0, [0, 2]], [2037.5 + r * math.sin(h), 1500.0 + r * (1 - math.cos(h))], atol=1e-9)
    np.testing.assert_allclose(mid[0, [4, 5]], math.pi / 20 * 5.0 * np.array([-math.sin(h), math.cos(h)]), atol=1e-12)
    np.testing.assert_allclose(s[3, :4], [2037.5 + r, 0.0, 1500.0 + r + 37.5, 10.0], atol=1e-9)


def test_segment_speed_continuity_and_turn_geometry():
    path = SegmentedTrajectoryConfig(
        (0.0, 0.0),
        (3.0, 4.0),
        (
            MotionSegmentConfig("ca", 2.0, acceleration_mps2=0.5),
            MotionSegmentConfig("ct", math.pi, turn_rate_rps=-0.5),
        ),
    )
    t = np.linspace(0, path.duration_s, 2001)
    s, _ = segmented_states(path, t)
    speed = np.hypot(s[:, 1], s[:, 3])
    np.testing.assert_allclose(speed[t <= 2.0], 5.0 + 0.5 * t[t <= 2.0], atol=1e-9)
    np.testing.assert_allclose(speed[t >= 2.0], 6.0, atol=1e-9)
    # velocity is the derivative of position (central differences)
    dt = t[1] - t[0]
    np.testing.assert_allclose(np.gradient(s[:, 0], dt)[5:-5], s[5:-5, 1], atol=2e-3)
    # a right turn of rate -0.5 for pi seconds rotates the heading by -pi/2
    h0, h1 = math.atan2(4, 3), math.atan2(s[-1, 3], s[-1, 1])
    assert math.isclose(math.remainder(h1 - h0 + math.pi / 2, 2 * math.pi), 0.0, abs_tol=1e-9)


def test_deceleration_that_would_stop_the_target_is_rejected():
    path = SegmentedTrajectoryConfig((0.0, 0.0), (1.0, 0.0), (MotionSegmentConfig("ca", 2.0, acceleration_mps2=-1.0),))
    with pytest.raises(ValueError, match=r"segments\[0\].acceleration_mps2 = -1.0"):
        segmented_states(path, np.array([0.0]))


def test_urban_truth_has_births_and_deaths():
    cfg = scenarios.get("urban-intersection")
    truth = sample_truth(cfg, RngStreams.from_seed(0).truth)
    assert truth.states.shape == (141, 2, 6)
    t = truth.times_s
    # second target is born 10 s later on the same path
    np.testing.assert_array_equal(truth.alive[:, 1], (t >= 10.0) & (t - 10.0 <= seed003_path().duration_s))
    k = round(12.0 / 0.25)
    np.testing.assert_allclose(truth.states[k, 1], truth.states[k - 40, 0], atol=1e-9)
    assert not truth.alive[-1, 0] and truth.alive[-1, 1]


def test_motion_matrices_are_exact_discretisations():
    T, w = 0.25, 0.3
    A = np.zeros((6, 6))
    A[0, 1] = A[2, 3] = 1.0
    F, _ = ncv_transition(T)
    np.testing.assert_allclose(F[:4, :4], expm(A * T)[:4, :4], atol=1e-14)
    A_ct = np.zeros((6, 6))
    A_ct[0, 1] = A_ct[2, 3] = 1.0
    A_ct[1, 3], A_ct[3, 1] = -w, w
    F, _ = ct_transition(T, w)
    np.testing.assert_allclose(F[:4, :4], expm(A_ct * T)[:4, :4], atol=1e-14)
    A_ca = np.zeros((6, 6))
    A_ca[0, 1] = A_ca[2, 3] = A_ca[1, 4] = A_ca[3, 5] = 1.0
    np.testing.assert_allclose(nca_transition(T)[0], expm(A_ca * T), atol=1e-14)
    # CT -> NCV as the turn rate -> 0, and the seed's Q = sigma^2 G G^T
    np.testing.assert_allclose(ct_transition(T, 1e-9)[0], ncv_transition(T)[0], atol=1e-9)
    _, G = ncv_transition(T)
    np.testing.assert_allclose(process_noise(G, 2.0)[0, :2], 4.0 * np.array([T**4 / 4, T**3 / 2]))


def test_ncv_truth_velocity_is_a_random_walk_with_the_right_variance():
    """v_k - v_0 ~ N(0, k T^2 sigma^2) per axis; checked over 4000 seeded paths within 4 standard errors."""
    cfg = MotionModelTrajectoryConfig((0.0, 0.0), (5.0, 0.0), "ncv", duration_s=5.0, accel_noise_std_mps2=0.7)
    rng = np.random.default_rng(3)
    T = 0.25
    v = np.array([motion_model_states(cfg, np.array([5.0]), T, rng)[0][0, [1, 3]] for _ in range(4000)])
    var_expected = 20 * T**2 * 0.7**2
    sample_var = (v - [5.0, 0.0]).var(axis=0)
    np.testing.assert_array_less(np.abs(sample_var / var_expected - 1.0), 4 * math.sqrt(2 / 4000))


@pytest.mark.parametrize("seed", range(8))
def test_room_walk_never_crosses_a_wall_and_has_the_right_length(seed):
    cfg = scenarios.get("indoor-monostatic")
    lay = SceneLayout.from_config(cfg)
    walk_cfg = cfg.targets[0].trajectory
    pts = room_walk_polyline(walk_cfg, lay.wall_start, lay.wall_end, np.random.default_rng(seed))
    assert not segments_cross(pts[:-1], pts[1:], lay.wall_start, lay.wall_end).any()
    length = np.linalg.norm(np.diff(pts, axis=0), axis=1).sum()
    assert length == pytest.approx(math.ceil(20.0 / walk_cfg.step_m) * walk_cfg.step_m)


def test_room_walks_pass_through_doors_between_rooms():
    """Over a few walks, some visit more than one room (they pass doors), none leaves the floor."""
    cfg = scenarios.get("indoor-monostatic")
    lay = SceneLayout.from_config(cfg)

    def room(p):
        return (0 if p[1] < 6 else 3) + (int(p[0] >= 7) + int(p[0] >= 13) if p[1] < 6 else int(p[0] >= 10))

    rooms_visited = []
    for seed in range(20):
        pts = room_walk_polyline(cfg.targets[0].trajectory, lay.wall_start, lay.wall_end, np.random.default_rng(seed))
        assert (pts >= 0).all() and (pts[:, 0] <= 20).all() and (pts[:, 1] <= 12).all()
        rooms_visited.append(len({room(p) for p in pts}))
    assert max(rooms_visited) >= 2


def test_truth_is_deterministic_per_seed_and_differs_across_seeds():
    cfg = scenarios.get("indoor-monostatic")
    a = sample_truth(cfg, RngStreams.from_seed(7).truth)
    b = sample_truth(cfg, RngStreams.from_seed(7).truth)
    c = sample_truth(cfg, RngStreams.from_seed(8).truth)
    np.testing.assert_array_equal(a.states, b.states)
    assert not np.array_equal(a.states, c.states)


def test_segments_cross_kernel_by_hand():
    p0, p1 = np.array([[0.0, 0.0], [0.0, 2.0]]), np.array([[2.0, 2.0], [2.0, 2.0]])
    a, b = np.array([[0.0, 2.0], [3.0, 0.0]]), np.array([[2.0, 0.0], [3.0, 5.0]])
    np.testing.assert_array_equal(segments_cross(p0, p1, a, b), [[True, False], [True, False]])
