"""Relative track slots (``uwb_env.envs.relative``): invariance under rotations, mirrors and translations of the scene,
a hand-computed geometry, the compiled kernel against its numpy reference, and the degenerate cases."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uwb_env import scenarios
from uwb_env.envs.features import slot_order, track_features_reference
from uwb_env.envs.relative import (
    check_geometry,
    model_groups,
    relative_feature_count,
    relative_feature_names,
    relative_track_features,
    relative_track_features_reference,
    scene_arguments,
)
from uwb_env.scene.layout import SceneLayout

MODELS = ("ncv", "nca", "ct_left", "ct_right")  # seed 003's set (uwb_env.tracking.imm.SEED003_MODELS)
MIRROR_SWAP = np.array([0, 1, 3, 2])  # a mirror turns a left turn into a right one


def _scene(rng, n_tx, n_rx, n_tracks):
    """Random nodes (some receivers without array, sometimes a monostatic pair), tracks (positive definite P), some
    tracks exactly on a node or at rest."""
    tx = rng.uniform(-40.0, 40.0, size=(n_tx, 2))
    rx = rng.uniform(-40.0, 40.0, size=(n_rx, 2))
    if rng.uniform() < 0.5:
        rx[0] = tx[0]  # monostatic pair
    boresight = np.where(rng.uniform(size=n_rx) < 0.7, rng.uniform(-np.pi, np.pi, size=n_rx), np.nan)
    pairs = np.array([(t, j) for t in range(n_tx) for j in range(n_rx) if rng.uniform() < 0.7], np.int64).reshape(-1, 2)
    x = rng.normal(scale=[20.0, 5.0, 20.0, 5.0, 1.0, 1.0], size=(n_tracks, 6))
    if n_tracks > 1:
        x[0, 0:3:2] = rx[-1]  # exactly on a receiver
        x[1, 1:4:2] = 0.0  # at rest
    A = rng.normal(size=(n_tracks, 6, 6)) * rng.uniform(0.1, 3.0, size=(n_tracks, 1, 1))
    P = A @ np.swapaxes(A, -1, -2) + 0.05 * np.eye(6)
    existence = rng.uniform(size=n_tracks)
    confirmed = rng.uniform(size=n_tracks) < 0.5
    mu = rng.dirichlet(np.ones(4), size=n_tracks)
    return tx, rx, boresight, pairs, existence, confirmed, mu, x, P


def _map(A, pts, shift):
    """Points ``(n, 2)`` under p -> A p + shift, elementwise (the same rounding for a track and a node it sits on)."""
    return np.stack(
        [A[0, 0] * pts[:, 0] + A[0, 1] * pts[:, 1] + shift[0], A[1, 0] * pts[:, 0] + A[1, 1] * pts[:, 1] + shift[1]],
        axis=1,
    )


def _transform(A, shift, tx, rx, boresight, x, P, mu):
    """The scene under p -> A p + shift (A orthogonal: a rotation, or a mirror if det A = -1): positions, velocities,
    accelerations, covariances P -> G P G^T (G: A on each (x, y) pair of the state), boresights; a mirror swaps
    CT-left and CT-right."""
    G = np.zeros((6, 6))
    for i, j in ((0, 2), (1, 3), (4, 5)):
        G[np.ix_([i, j], [i, j])] = A
    b = _map(A, np.stack([np.cos(boresight), np.sin(boresight)], axis=-1), np.zeros(2))
    x2 = np.empty_like(x)
    x2[:, 0:3:2] = _map(A, x[:, 0:3:2], shift)
    x2[:, 1:4:2] = _map(A, x[:, 1:4:2], np.zeros(2))
    x2[:, 4:6] = _map(A, x[:, 4:6], np.zeros(2))
    mirrored = np.linalg.det(A) < 0
    return (
        _map(A, tx, shift),
        _map(A, rx, shift),
        np.arctan2(b[:, 1], b[:, 0]),  # nan stays nan
        x2,
        G @ P @ G.T,
        mu[:, MIRROR_SWAP] if mirrored else mu,
    )


def _rotation(theta):
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s], [s, c]])


def _reflection(phi):
    """Reflection about the line through the origin at angle phi (with a shift: about any line)."""
    c, s = math.cos(2.0 * phi), math.sin(2.0 * phi)
    return np.array([[c, s], [s, -c]])


def _features(tx, rx, boresight, pairs, existence, confirmed, mu, x, P, n_slots=8):
    return relative_track_features_reference(
        existence, confirmed, mu, MODELS, x, P, tx, rx, boresight, pairs, 50.0, 15.0, n_slots
    )


@settings(max_examples=150, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n_tx=st.integers(1, 3),
    n_rx=st.integers(1, 4),
    n_tracks=st.integers(1, 10),
    theta=st.floats(-20.0, 20.0),
    mirror=st.booleans(),
    phi=st.floats(0.0, math.pi),
    shift=st.tuples(st.floats(-1e3, 1e3), st.floats(-1e3, 1e3)),
)
def test_features_are_invariant_under_rotation_mirror_and_translation(
    seed, n_tx, n_rx, n_tracks, theta, mirror, phi, shift
):
    """Every feature equal to 1e-9 on the scene and on its image under a rotation by any angle, an optional mirror
    about a line at any angle and a translation (CT-left and CT-right swapped by the mirror); the absolute slots of
    ``features.track_features_reference`` differ under the mirror (the test has teeth)."""
    rng = np.random.default_rng(seed)
    tx, rx, boresight, pairs, existence, confirmed, mu, x, P = _scene(rng, n_tx, n_rx, n_tracks)
    A = _rotation(theta) @ (_reflection(phi) if mirror else np.eye(2))
    shift = np.array(shift)
    tx2, rx2, boresight2, x2, P2, mu2 = _transform(A, shift, tx, rx, boresight, x, P, mu)
    before = _features(tx, rx, boresight, pairs, existence, confirmed, mu, x, P)
    after = _features(tx2, rx2, boresight2, pairs, existence, confirmed, mu2, x2, P2)
    assert np.isfinite(before).all()
    np.testing.assert_allclose(after, before, rtol=0, atol=1e-9)
    if mirror:
        centre, half = np.array([3.0, -2.0]), np.array([45.0, 45.0])
        old = track_features_reference(existence, confirmed, mu, x, P, centre, half, 15.0, 8)
        old2 = track_features_reference(existence, confirmed, mu2, x2, P2, A @ centre + shift, half, 15.0, 8)
        assert np.abs(old2 - old).max() > 1e-3


def test_the_mirrored_urban_intersection_gives_the_same_features_and_the_absolute_ones_do_not():
    """Seed 003's intersection and its mirror image about the area's vertical centre line (the scene the committed
    urban policy failed on): relative slots equal to 1e-12 relative; the absolute slots' (x - cx) / hx, vx / v_max
    and corr_xy change sign, and the CT-left / CT-right probabilities swap."""
    cfg = scenarios.get("urban-intersection")
    lay = SceneLayout.from_config(cfg)
    pairs = np.array(cfg.radar_pairs, np.int64)
    names = tuple(m.name for m in cfg.tracker.models)
    assert names == MODELS
    rng = np.random.default_rng(3)
    _, _, _, _, existence, confirmed, mu, x, P = _scene(rng, 1, 1, 6)
    centre = np.array([lay.area[:2].mean(), lay.area[2:].mean()])
    half = np.array([np.diff(lay.area[:2])[0], np.diff(lay.area[2:])[0]]) / 2
    x[:, 0:3:2] += centre
    A = np.diag([-1.0, 1.0])
    shift = np.array([2.0 * centre[0], 0.0])
    tx2, rx2, boresight2, x2, P2, mu2 = _transform(A, shift, lay.tx_pos, lay.rx_pos, lay.rx_boresight_rad, x, P, mu)
    v_max = cfg.tracker.max_speed_mps
    args = (pairs, 200.0, v_max, 8)
    before = relative_track_features_reference(
        existence, confirmed, mu, names, x, P, lay.tx_pos, lay.rx_pos, lay.rx_boresight_rad, *args
    )
    after = relative_track_features_reference(existence, confirmed, mu2, names, x2, P2, tx2, rx2, boresight2, *args)
    np.testing.assert_allclose(after, before, rtol=1e-12, atol=1e-14)
    old = track_features_reference(existence, confirmed, mu, x, P, centre, half, v_max, 8)
    old2 = track_features_reference(existence, confirmed, mu2, x2, P2, centre, half, v_max, 8)
    np.testing.assert_allclose(old2[:6, [3, 5, 9]], -old[:6, [3, 5, 9]], rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(old2[:6, [12, 13]], old[:6, [13, 12]])
    assert np.abs(old2[:6, 3]).min() > 0 and np.abs(old2 - old).max() > 0.1


def test_hand_computed_track_and_two_nodes():
    """tx at (0, 0), rx at (10, 0) with boresight +y, one track at (5, 12) moving (1, 2) m/s; position covariance
    diag(9, 1) rotated onto the direction of the track seen from tx, u_t = (5, 12) / 13.

    tx: r = 13, dr/dt = (5 + 24) / 13 = 29 / 13; the track sees tx at -u_t: cos = -29 / (13 sqrt 5),
    |sin| = |(5, 12) x (1, 2)| / (13 sqrt 5) = 2 / (13 sqrt 5); radial frame = principal axes: var_r 9, var_c 1,
    rho 0. rx: r = 13, dr/dt = (-5 + 24) / 13 = 19 / 13, cos = -19 / (13 sqrt 5), |sin| = |(-5, 12) x (1, 2)| /
    (13 sqrt 5) = 22 / (13 sqrt 5); the angle beta between u_r = (-5, 12) / 13 and the principal axis has
    cos beta = 119 / 169, sin beta = 120 / 169, so var_r = 9 cos^2 + sin^2 = 141849 / 28561, var_c = 10 - var_r,
    |cov| = 8 cos beta sin beta; off boresight acos(12 / 13) / pi. Pair: half bistatic range (26 - 10) / 2 = 8,
    half rate (u_t + u_r) . v / 2 = (0, 24 / 13) . (1, 2) / 2 = 24 / 13; gradient along +y, so its variance is
    C_yy = 9 (12 / 13)^2 + (5 / 13)^2 = 1321 / 169."""
    tx, rx = np.array([[0.0, 0.0]]), np.array([[10.0, 0.0]])
    boresight = np.array([math.pi / 2])
    pairs = np.array([[0, 0]], np.int64)
    c, s = 5.0 / 13.0, 12.0 / 13.0
    Rot = np.array([[c, -s], [s, c]])
    P = np.eye(6)
    P[np.ix_([0, 2], [0, 2])] = Rot @ np.diag([9.0, 1.0]) @ Rot.T
    P = P[None]
    x = np.array([[5.0, 1.0, 12.0, 2.0, 0.0, 0.0]])
    mu = np.array([[0.1, 0.2, 0.6, 0.1]])
    range_scale, v_max = 20.0, 4.0
    f = relative_track_features_reference(
        np.array([0.9]), np.array([True]), mu, MODELS, x, P, tx, rx, boresight, pairs, range_scale, v_max, 2
    )
    assert f.shape == (2, 4 + 7 + 8 + 3 + 2 + 2)
    r5 = 13.0 * math.sqrt(5.0)
    var_r = 141849.0 / 28561.0
    cos_b, sin_b = 119.0 / 169.0, 120.0 / 169.0
    want = [
        1.0, 0.9, 1.0, math.sqrt(5.0) / v_max,
        13.0 / range_scale, 29.0 / 13.0 / v_max, -29.0 / r5, 2.0 / r5, math.log10(9.0) / 4, 0.0, 0.0,
        13.0 / range_scale, 19.0 / 13.0 / v_max, -19.0 / r5, 22.0 / r5,
        math.log10(var_r) / 4, math.log10(10.0 - var_r) / 4, 8.0 * cos_b * sin_b / math.sqrt(var_r * (10.0 - var_r)),
        math.acos(12.0 / 13.0) / math.pi,
        8.0 / range_scale, 24.0 / 13.0 / v_max, math.log10(1321.0 / 169.0) / 4,
        0.1, 0.2, 0.7, 0.5,
    ]  # fmt: skip
    np.testing.assert_allclose(f[0], want, rtol=1e-13, atol=1e-15)
    assert not f[1].any()
    got = relative_track_features(
        np.array([0.9]), np.array([True]), mu, x, P, tx, rx, boresight, pairs, *model_groups(MODELS),
        range_scale, v_max, 2,
    )  # fmt: skip
    np.testing.assert_allclose(got, f, rtol=1e-13, atol=1e-15)


def test_a_track_on_a_node_and_at_rest_has_defined_values():
    """On the transmitter of a monostatic pair (tx = rx = (0, 0)), at rest, position covariance [[4, 1], [1, 2]]:
    range, rate, cos, |sin|, off boresight and |rho| 0, var_r = var_c = trace / 2 = 3, the pair's range 0, its
    rate 0 and its gradient-direction variance trace / 2 (g = 0); the other receiver 5 m away along u = (0.6, 0.8):
    rate 0, the bearing's cos and |sin| 0 (no heading), var_r = u^T C u = (9 * 4 + 2 * 12 + 16 * 2) / 25 = 92 / 25,
    var_c = (16 * 4 - 2 * 12 + 9 * 2) / 25 = 58 / 25."""
    tx, rx = np.array([[0.0, 0.0]]), np.array([[0.0, 0.0], [-3.0, -4.0]])
    boresight = np.array([0.3, 1.0])
    pairs = np.array([[0, 0], [0, 1]], np.int64)
    P = np.eye(6)
    P[np.ix_([0, 2], [0, 2])] = [[4.0, 1.0], [1.0, 2.0]]
    P = P[None]
    x = np.zeros((1, 6))
    mu = np.array([[0.25, 0.25, 0.25, 0.25]])
    f = relative_track_features_reference(
        np.array([0.5]), np.array([False]), mu, MODELS, x, P, tx, rx, boresight, pairs, 10.0, 5.0, 1
    )[0]
    assert np.isfinite(f).all()
    half = math.log10(3.0) / 4
    np.testing.assert_allclose(f[3:11], [0.0, 0.0, 0.0, 0.0, 0.0, half, half, 0.0], atol=1e-15)
    np.testing.assert_allclose(f[11:19], [0.0, 0.0, 0.0, 0.0, half, half, 0.0, 0.0], atol=1e-15)
    rho = 31.0 / math.sqrt(92.0 * 58.0)  # u^T C w = -31 / 25, w = (-0.8, 0.6)
    off = (1.0 - math.atan2(4.0, 3.0)) / math.pi
    want_rx1 = [0.5, 0.0, 0.0, 0.0, math.log10(92.0 / 25.0) / 4, math.log10(58.0 / 25.0) / 4, rho, off]
    np.testing.assert_allclose(f[19:27], want_rx1, rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(f[27:30], [0.0, 0.0, half], atol=1e-15)  # pair (0, 0): g = 0
    # pair (0, 1): on its baseline's end, (0 + 5 - 5) / 2 = 0; g = u_r = (0.6, 0.8)
    np.testing.assert_allclose(f[30:33], [0.0, 0.0, math.log10(92.0 / 25.0) / 4], rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(f[33:], [0.25, 0.25, 0.5, 0.0], atol=0)
    got = relative_track_features(
        np.array([0.5]), np.array([False]), mu, x, P, tx, rx, boresight, pairs, *model_groups(MODELS), 10.0, 5.0, 1
    )
    np.testing.assert_allclose(got[0], f, rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize("n", [0, 1, 5, 8, 13, 30])
def test_compiled_equals_the_numpy_reference(n):
    """Random scenes (tracks on a node and at rest among them), fewer and more tracks than slots: every feature to
    1e-12, the slots in ``slot_order`` (confirmed, then existence), the rest zero; the pair features' bounds."""
    rng = np.random.default_rng(100 + n)
    tx, rx, boresight, pairs, existence, confirmed, mu, x, P = _scene(rng, 2, 3, n)
    existence[: n // 2] = 0.5  # ties keep index order
    want = relative_track_features_reference(
        existence, confirmed, mu, MODELS, x, P, tx, rx, boresight, pairs, 50.0, 15.0, 8
    )
    got = relative_track_features(
        existence, confirmed, mu, x, P, tx, rx, boresight, pairs, *model_groups(MODELS), 50.0, 15.0, 8
    )
    assert got.shape == want.shape == (8, relative_feature_count(2, 3, pairs.shape[0], 2, 1))
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    if n:
        order = slot_order(existence, confirmed)[:8]
        np.testing.assert_array_equal(got[: order.size, 1], existence[order])
        np.testing.assert_array_equal(got[: order.size, 2], confirmed[order])
        np.testing.assert_array_equal(got[: order.size, 0], 1.0)
        np.testing.assert_allclose(got[: order.size, -3], mu[order, 1], rtol=0, atol=0)  # nca, last single
        assert np.isfinite(got).all()
        # a pair's half range and half rate are on a node's scale: <= the larger node range, |rate| <= speed
        n0 = 4 + 7 * 2 + 8 * 3
        for q, (t, j) in enumerate(pairs):
            node_range = np.maximum(got[:, 4 + 7 * t], got[:, 4 + 7 * 2 + 8 * j])
            assert (got[:, n0 + 3 * q] <= node_range + 1e-15).all() and (got[:, n0 + 3 * q] >= -1e-15).all()
            assert (np.abs(got[:, n0 + 3 * q + 1]) <= got[:, 3] + 1e-15).all()
    assert not got[min(n, 8) :].any()


def test_empty_track_set_and_slot_truncation():
    """No track: zeros of width F. Three tracks into two slots: the confirmed one first, then the higher existence."""
    tx, rx, boresight = np.array([[0.0, 0.0]]), np.array([[10.0, 0.0]]), np.array([np.nan])
    pairs = np.array([[0, 0]], np.int64)
    groups = model_groups(MODELS)
    empty = relative_track_features(
        np.zeros(0), np.zeros(0, bool), np.zeros((0, 4)), np.zeros((0, 6)), np.zeros((0, 6, 6)),
        tx, rx, boresight, pairs, *groups, 10.0, 5.0, 3,
    )  # fmt: skip
    np.testing.assert_array_equal(empty, np.zeros((3, 4 + 7 + 8 + 3 + 4)))
    x = np.zeros((3, 6))
    x[:, 0] = [1.0, 2.0, 3.0]  # range to tx 1, 2, 3
    x[:, 2] = 1e-3
    P = np.broadcast_to(np.eye(6), (3, 6, 6)).copy()
    mu = np.full((3, 4), 0.25)
    existence, confirmed = np.array([0.9, 0.3, 0.6]), np.array([False, True, False])
    got = relative_track_features(existence, confirmed, mu, x, P, tx, rx, boresight, pairs, *groups, 10.0, 5.0, 2)
    np.testing.assert_allclose(got[:, 4], [0.2, 0.1], rtol=1e-6)  # track 1 (confirmed), then track 0 (0.9)
    want = relative_track_features_reference(
        existence, confirmed, mu, MODELS, x, P, tx, rx, boresight, pairs, 10.0, 5.0, 2
    )
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)


def test_layout_names_and_model_groups():
    """F = 4 + 7 T + 8 R + 3 Q + a + 2 b; names at the documented indices; left / right pairs by name, checked against
    the turn rates."""
    pairs = np.array([[0, 0], [1, 1], [0, 2]], np.int64)
    names = relative_feature_names(2, 3, pairs, MODELS)
    assert len(names) == relative_feature_count(2, 3, 3, 2, 1) == 4 + 14 + 24 + 9 + 2 + 2
    assert names[4 + 7 * 1 + 1] == "tx1.range_rate"
    assert names[4 + 7 * 2 + 8 * 2 + 7] == "rx2.abs_off_boresight"
    assert names[4 + 14 + 24 + 3 * 2 + 2] == "pair2(tx0,rx2).log_var_gradient"
    assert names[-4:] == ["mu.ncv", "mu.nca", "mu.ct_left+ct_right", "mu.|ct_left-ct_right|"]
    single, turns = model_groups(("ct_right", "ncv", "ct_left"), np.array([-0.1, 0.0, 0.1]))
    np.testing.assert_array_equal(single, [1])
    np.testing.assert_array_equal(turns, [[2, 0]])
    single, turns = model_groups(("ncv",))
    assert single.tolist() == [0] and turns.shape == (0, 2)
    with pytest.raises(ValueError, match="'ct_left' has no mirror twin 'ct_right'"):
        model_groups(("ncv", "ct_left"))
    with pytest.raises(ValueError, match=r"turn_rates_rps\[1\]=0.2 \('ct_fast'\)"):
        model_groups(("ncv", "ct_fast"), np.array([0.0, 0.2]))
    with pytest.raises(ValueError, match="must be opposite and non-zero"):
        model_groups(MODELS, np.array([0.0, 0.0, 0.1, -0.2]))


def test_bad_geometry_is_named():
    tx, rx, b = np.zeros((1, 2)), np.ones((2, 2)), np.full(2, np.nan)
    ok = np.array([[0, 1]], np.int64)
    check_geometry(tx, rx, b, ok, 10.0, 5.0, 4)
    with pytest.raises(
        ValueError, match=r"pairs=\[\[0, 2\]\]: tx indices must lie in \[0, 1\), rx indices in \[0, 2\)"
    ):
        check_geometry(tx, rx, b, np.array([[0, 2]], np.int64), 10.0, 5.0, 4)
    with pytest.raises(ValueError, match=r"range_scale_m=0\.0: must be finite and > 0"):
        check_geometry(tx, rx, b, ok, 0.0, 5.0, 4)
    with pytest.raises(ValueError, match="rx_boresight_rad="):
        check_geometry(tx, rx, np.zeros(3), ok, 10.0, 5.0, 4)
    with pytest.raises(ValueError, match=r"mu has shape \(1, 3\): must be \(1, 4\)"):
        relative_track_features_reference(
            np.ones(1), np.ones(1, bool), np.ones((1, 3)), MODELS, np.zeros((1, 6)), np.eye(6)[None], tx, rx, b, ok,
            10.0, 5.0, 1,
        )  # fmt: skip


def test_scene_arguments_of_the_urban_intersection():
    """The sensor's layout, formed pairs and tracker models in the kernel's order; the range scale is the area's
    half-diagonal, 0.5 hypot(300, 450) m; the compiled call with them equals the reference."""
    cfg = scenarios.get("urban-intersection")
    lay = SceneLayout.from_config(cfg)
    pairs = np.array(cfg.radar_pairs, np.int64)
    scene = scene_arguments(cfg, lay, pairs, MODELS)
    tx, rx, boresight, pairs_out, single, turns, range_scale = scene
    np.testing.assert_array_equal(tx, lay.tx_pos)
    np.testing.assert_array_equal(rx, lay.rx_pos)
    np.testing.assert_array_equal(pairs_out, [[0, 0], [0, 1]])
    assert single.tolist() == [0, 1] and turns.tolist() == [[2, 3]]
    assert range_scale == pytest.approx(0.5 * math.hypot(300.0, 450.0), rel=1e-15)
    rng = np.random.default_rng(5)
    _, _, _, _, existence, confirmed, mu, x, P = _scene(rng, 1, 1, 5)
    x[:, 0:3:2] += lay.rx_pos[0]
    got = relative_track_features(existence, confirmed, mu, x, P, *scene, 20.0, 4)
    want = relative_track_features_reference(
        existence, confirmed, mu, MODELS, x, P, tx, rx, boresight, pairs, range_scale, 20.0, 4
    )
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    assert got.shape == (4, 4 + 7 + 16 + 6 + 2 + 2)
