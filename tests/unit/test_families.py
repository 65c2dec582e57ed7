"""Scene families (issue 20 item 3): physics kept under D4, group laws, seeded draws, valid variants, splits."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uwb_env import scenarios
from uwb_env.config import MotionModelConfig, to_dict
from uwb_env.envs import UWBSchedulingEnv
from uwb_env.rng import RngStreams
from uwb_env.scenarios import families as F
from uwb_env.scenarios.families import SceneVariant
from uwb_env.scene import sample_truth
from uwb_env.scene.geometry import point_segment_distance
from uwb_env.scene.trajectories import segmented_states
from uwb_env.sensing.protocol import make_sensor

FAMILY = F.get_family("urban-intersection")
SEED_SCENE = SceneVariant(0, 0, (0.0, 10.0))  # the seed's own scene: left turn, two vehicles 10 s apart


def _leaves(obj, prefix=""):
    """Flatten a config's ``to_dict`` into (path, value) leaves."""
    if isinstance(obj, dict):
        return [leaf for k, v in obj.items() for leaf in _leaves(v, f"{prefix}.{k}")]
    if isinstance(obj, list):
        return [leaf for i, v in enumerate(obj) for leaf in _leaves(v, f"{prefix}[{i}]")]
    return [(prefix, obj)]


def assert_configs_close(a, b, atol=1e-9):
    """Same structure and strings; every number within ``atol`` (float round-off of the affine maps)."""
    la, lb = _leaves(to_dict(a)), _leaves(to_dict(b))
    assert [p for p, _ in la] == [p for p, _ in lb]
    for (path, x), (_, y) in zip(la, lb, strict=True):
        if isinstance(x, float) and isinstance(y, float) and math.isfinite(x):
            assert abs(x - y) <= atol, path
        else:
            assert x == y, path


def test_the_identity_left_two_vehicle_variant_is_the_seed_scenario():
    base = scenarios.get("urban-intersection")
    cfg = FAMILY.build(SEED_SCENE)
    assert dataclasses.replace(cfg, name=base.name, description=base.description) == base


@pytest.mark.parametrize("orientation", range(1, 8))
def test_every_orientation_keeps_ranges_range_rates_snr_coverage_and_pd(orientation):
    """Bistatic range, range-rate, SNR per unit radar constant (walls, beams), coverage, clutter map and Pd at every
    scan, pair and target equal the seed scene's to 1e-9 relative; azimuths and positions are the mapped ones."""
    cfg0, cfg = FAMILY.build(SEED_SCENE), FAMILY.build(dataclasses.replace(SEED_SCENE, orientation=orientation))
    s0, s = make_sensor(cfg0), make_sensor(cfg)
    t0 = sample_truth(cfg0, RngStreams.from_seed(0).truth)
    t = sample_truth(cfg, RngStreams.from_seed(0).truth)
    M, c = F.orientation_matrix(orientation), np.array(F.INTERSECTION_CENTRE)
    alive = t0.alive
    np.testing.assert_array_equal(t.alive, alive)
    np.testing.assert_allclose(t.states[alive][:, [0, 2]], c + (t0.states[alive][:, [0, 2]] - c) @ M.T, atol=1e-9)
    g0, g = s0.episode_geometry(t0), s.episode_geometry(t)
    np.testing.assert_array_equal(g.covered, g0.covered)
    assert g0.covered.sum() > 400  # of 141 scans x 2 pairs x 2 vehicles: the test sees covered links
    for name in ("bistatic_range", "range_rate", "unit_snr"):
        a, b = getattr(g, name)[g0.covered], getattr(g0, name)[g0.covered]
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9 * np.abs(b).max(), err_msg=name)
    az0, az = g0.azimuth[alive[:, None, :].repeat(2, 1)], g.azimuth[alive[:, None, :].repeat(2, 1)]
    np.testing.assert_allclose(np.stack([np.cos(az), np.sin(az)], -1), np.stack([np.cos(az0), np.sin(az0)], -1) @ M.T,
                               atol=1e-9)  # fmt: skip
    np.testing.assert_allclose(s._clutter_mean, s0._clutter_mean, rtol=1e-9)  # the clutter map the tracker reads
    np.testing.assert_allclose(s.direct_path_snr, s0.direct_path_snr, rtol=1e-9)
    # Pd of every pair and waveform at the alive targets, with their velocities (the Doppler notch of the vegetation)
    k, j = np.nonzero(alive)
    for w in range(len(cfg.waveforms)):
        for rx in range(2):
            pd0 = s0.detection_probability_at(0, rx, t0.states[k, j][:, [0, 2]], w, 10.0, 1, t0.states[k, j][:, [1, 3]])
            pd = s.detection_probability_at(0, rx, t.states[k, j][:, [0, 2]], w, 10.0, 1, t.states[k, j][:, [1, 3]])
            np.testing.assert_allclose(pd, pd0, rtol=1e-9, atol=1e-12)
            assert pd0.max() > 0.9 and pd0.min() < 0.1  # from shadow to full detection along the path


def test_every_orientation_plays_the_same_episode_with_an_equivariant_filter():
    """End to end: clutter-free (the false alarms are drawn in the area's frame), EKF tracker (a UKF's Cholesky sigma
    points are equivariant only under sign flips of the axes), the same seed and actions: the same rewards to 1e-9
    relative in all 8 orientations, on the right-turn path."""
    quiet = {"sensing.clutter.density_per_m2": 0.0, "sensing.ghost_rate": 0.0, "tracker.filter": "ekf"}
    rewards, counts = [], []
    for g in range(8):
        env = UWBSchedulingEnv(FAMILY.build(SceneVariant(g, 2, (0.0, 10.0))), **quiet)
        env.reset(seed=3)
        steps = [env.step(k % 6) for k in range(env.cfg.n_scans)]
        rewards.append([s[1] for s in steps])
        counts.append([(s[4]["confirmed_tracks"], s[4]["missed_targets"]) for s in steps])
    r = np.array(rewards)
    np.testing.assert_allclose(r, r[[0]].repeat(8, 0), rtol=1e-9, atol=1e-9 * np.abs(r).max())
    assert all(c == counts[0] for c in counts)
    confirmed = np.array(counts[0])[:, 0]
    assert (confirmed > 0).sum() == 107 and r[0].sum() == pytest.approx(-14548.43, abs=0.01)  # tracks were held


# --------------------------------------------------------------------------------------------------- group laws
def test_group_laws_on_configs():
    cfg = FAMILY.build(SceneVariant(0, 2, (0.0, 10.0, 20.0)))
    turned = cfg
    for _ in range(4):
        turned = F.rotate(turned, 1, F.INTERSECTION_CENTRE)
    assert_configs_close(turned, cfg)
    assert_configs_close(F.rotate(F.rotate(cfg, 1), 1), F.rotate(cfg, 2))
    assert_configs_close(F.rotate(cfg, -1), F.rotate(cfg, 3))
    for axis in ("vertical", "horizontal"):
        assert F.mirror(F.mirror(cfg, axis), axis) == cfg  # exact: the seed's coordinates are binary fractions
    # composition table: transform(transform(cfg, a), b) = transform(cfg, b o a)
    for a in range(8):
        for b in range(8):
            assert_configs_close(
                F.transform(F.transform(cfg, a, F.INTERSECTION_CENTRE), b, F.INTERSECTION_CENTRE),
                F.transform(cfg, F.compose(a, b), F.INTERSECTION_CENTRE),
            )
    inverses = [[b for b in range(8) if F.compose(a, b) == 0] for a in range(8)]
    assert inverses == [[0], [3], [2], [1], [4], [5], [6], [7]]  # rotations invert, reflections are involutions


@settings(max_examples=25, deadline=None)
@given(
    x=st.floats(1900, 2200), y=st.floats(1300, 1750), heading=st.floats(-180, 180), g=st.integers(0, 7),
    cx=st.floats(1950, 2150), cy=st.floats(1350, 1700),
)  # fmt: skip
def test_a_transformed_receiver_sees_a_transformed_point_at_the_same_off_boresight_magnitude(x, y, heading, g, cx, cy):
    """Property: the array's boresight moves with the scene, so |off-boresight angle| of any point is preserved
    (mirrors flip its sign), and distances between points are preserved."""
    base = scenarios.get("urban-intersection")
    cfg = F.transform(base, g, (cx, cy))
    f = F._Map(g, (cx, cy))
    rx0, rx = base.receivers[0], cfg.receivers[0]
    p = (x, y)
    q = f.point(p)

    def off(rxc, point):
        az = math.atan2(point[1] - rxc.position_m[1], point[0] - rxc.position_m[0])
        return math.remainder(az - math.radians(rxc.array.boresight_deg), 2 * math.pi)

    assert abs(abs(off(rx, q)) - abs(off(rx0, p))) < 1e-9
    assert abs(math.dist(q, rx.position_m) - math.dist(p, rx0.position_m)) < 1e-9
    assert abs(math.dist(q, cfg.transmitters[0].position_m) - math.dist(p, base.transmitters[0].position_m)) < 1e-9


def test_a_mirror_flips_turn_rates_and_swaps_the_tracker_turn_models():
    cfg = FAMILY.build(SEED_SCENE)
    m = F.mirror(cfg, "vertical", F.INTERSECTION_CENTRE)
    turn = next(s for s in m.targets[0].trajectory.segments if s.kind == "ct")
    assert turn.turn_rate_rps == pytest.approx(-math.pi / 20)  # the left turn became a right turn
    assert m.targets[0].trajectory.start_velocity_mps == (-10.0, 0.0)
    assert m.targets[0].trajectory.start_position_m == (2185.0, 1500.0)  # 2 x 2067.5 - 1950
    assert m.receivers[0].array.boresight_deg == 50.0  # 180 - 130
    assert m.tracker.model_set_windows[0].models == ("nca", "ct_right", "ct_left")
    assert m.tracker.transition == cfg.tracker.transition  # seed 003's matrix is symmetric in the turn models
    assert F.rotate(cfg, 1, F.INTERSECTION_CENTRE).tracker == cfg.tracker
    # an asymmetric transition is permuted: T'[pi(i), pi(j)] = T[i, j]
    rows = ((0.9, 0.1, 0.0, 0.0), (0.1, 0.7, 0.2, 0.0), (0.0, 0.05, 0.95, 0.0), (0.0, 0.01, 0.0, 0.99))
    skew = dataclasses.replace(cfg, tracker=dataclasses.replace(cfg.tracker, transition=rows))
    assert F.mirror(skew).tracker.transition[1] == (0.1, 0.7, 0.0, 0.2)
    assert F.mirror(skew).tracker.transition[3] == (0.0, 0.05, 0.0, 0.95)


def test_a_mirror_refuses_what_it_cannot_map():
    cfg = scenarios.get("urban-intersection")
    lone = dataclasses.replace(
        cfg.tracker,
        models=(*cfg.tracker.models[:3], MotionModelConfig("ct_fast", "ct", 0.5, -0.3)),
        model_set_windows=(),
    )
    with pytest.raises(ValueError, match=r"'ct_left' .* has no mirror partner"):
        F.mirror(dataclasses.replace(cfg, tracker=lone))
    four = tuple(dataclasses.replace(r, array=dataclasses.replace(r.array, n_elements=4)) for r in cfg.receivers)
    even = dataclasses.replace(cfg, receivers=four)
    with pytest.raises(ValueError, match=r"rx1.*'dft' beams at u = .* not symmetric"):
        F.mirror(even)
    F.rotate(even, 1)  # a rotation keeps the handedness: allowed
    with pytest.raises(ValueError, match="orientation=8"):
        F.transform(cfg, 8)
    with pytest.raises(ValueError, match="axis='diagonal'"):
        F.mirror(cfg, "diagonal")


# ------------------------------------------------------------------------------------------------------- the paths
def test_the_three_paths_by_hand():
    """Left: the seed's, ends at (2069.3, 1667.8) heading north. Right: first leg 3.5 s, ends at x = 2022.5 + 31.83
    heading south at y = 1332.2 (the left end mirrored about y = 1500). Straight: 50 + 37.5 + 50 + 37.5 m to
    x = 2125, then to x = 2195. All: 10 m/s, 1 m/s^2 slow-down to 5 m/s over 5 s."""
    radius = 5.0 / (math.pi / 20)
    ends = {}
    for name, path in F.URBAN_PATHS:
        s, valid = segmented_states(path, np.array([0.0, 10.0, path.duration_s]))
        assert valid.all()
        np.testing.assert_allclose(np.hypot(s[:, 1], s[:, 3]), [10.0, 5.0, 10.0], atol=1e-9)
        ends[name] = s[-1]
    np.testing.assert_allclose(ends["left"][[0, 2]], [2037.5 + radius, 1667.8], atol=1e-9)
    np.testing.assert_allclose(ends["right"][[0, 2]], [2022.5 + radius, 1332.2], atol=1e-9)
    np.testing.assert_allclose(ends["right"][[1, 3]], [0.0, -10.0], atol=1e-9)
    np.testing.assert_allclose(ends["straight"][[0, 1, 2, 3]], [2195.0, 10.0, 1500.0, 0.0], atol=1e-9)
    assert ends["right"][0] == pytest.approx(2054.33, abs=0.01)


# --------------------------------------------------------------------------------------------------------- draws
def test_draws_are_seeded_and_vary():
    v1, c1 = FAMILY.draw(7)
    v2, c2 = FAMILY.draw(7)
    assert v1 == v2 and c1 == c2
    assert FAMILY.draw(np.random.default_rng(7)) == (v1, c1)  # a seed or the generator it seeds
    variants = [FAMILY.draw(s)[0] for s in range(600)]
    assert len(set(variants[:50])) >= 45  # different seeds, different variants
    assert {v.cell for v in variants} == set(FAMILY.cells("all"))  # 24 cells; P(one missed) = 24 (23/24)^600 < 1e-9
    counts = np.bincount([v.n_targets for v in variants], minlength=4)[1:] / 600
    np.testing.assert_allclose(counts, 1 / 3, atol=4 * math.sqrt(2 / 9 / 600))  # uniform 1..3, 4 sigma
    births = np.array([b - 10.0 * i for v in variants for i, b in enumerate(v.birth_times_s)])
    assert births.min() == 0.0 and births.max() == 2.0 and np.allclose(births * 4, np.round(births * 4))
    assert abs(births.mean() - 1.0) < 4 * math.sqrt((9**2 - 1) / 12 / 16 / births.size)  # uniform 0..8 scans


def test_every_drawn_variant_is_valid_and_stays_in_the_streets():
    """Validated configs; every alive truth position inside the surveillance area, >= 5 m from every building face
    (the family's check and an independent one on the sampled truth)."""
    least = np.inf
    for seed in range(40):
        variant, cfg = FAMILY.draw(seed)
        assert len(cfg.targets) == variant.n_targets
        assert FAMILY.check_paths(cfg) >= 5.0
        truth = sample_truth(cfg, RngStreams.from_seed(seed).truth)
        pos = truth.states[truth.alive][:, [0, 2]]
        a = cfg.surveillance_area
        assert ((pos[:, 0] >= a.x_min_m) & (pos[:, 0] <= a.x_max_m) & (pos[:, 1] >= a.y_min_m)
                & (pos[:, 1] <= a.y_max_m)).all()  # fmt: skip
        walls = [w for w in cfg.walls if math.isinf(w.material.loss_db)]
        d = point_segment_distance(pos, np.array([w.start_m for w in walls]), np.array([w.end_m for w in walls]))
        least = min(least, d.min())
    assert least == pytest.approx(11.76, abs=0.01)  # the right turn's closest approach to the south-west block


def test_check_paths_catches_a_path_through_a_building():
    cfg = FAMILY.build(SEED_SCENE)
    bad = dataclasses.replace(
        cfg.targets[0], trajectory=dataclasses.replace(cfg.targets[0].trajectory, start_position_m=(1950.0, 1470.0))
    )
    with pytest.raises(ValueError, match=r"vehicle-1.*from a building"):
        F.check_paths(dataclasses.replace(cfg, targets=(bad,)))
    far = dataclasses.replace(cfg.targets[0], trajectory=F.seed003_straight_path(2300.0))
    with pytest.raises(ValueError, match="leaves the surveillance area"):
        F.check_paths(dataclasses.replace(cfg, targets=(far,)))


# --------------------------------------------------------------------------------------------------------- splits
def test_splits_are_disjoint_cover_the_family_and_are_respected():
    train, held, every = (set(FAMILY.cells(s)) for s in F.SPLITS)
    assert not train & held and train | held == every and len(every) == 24 and len(held) == 7
    # each kind of unseen variant the check names: a rotation, a mirror, the other turn
    assert {(1, p) for p in range(3)} <= held  # rot90
    assert {(4, p) for p in range(3)} <= held  # mirror-vertical (its left turn: the mirror image)
    assert (0, 2) in held and (0, 0) in train  # the seed's scene turning right is held out, turning left trained
    for seed in range(300):
        assert FAMILY.draw(seed, "train")[0].cell in train
        assert FAMILY.draw(seed, "heldout")[0].cell in held
    assert FAMILY.split_of(SEED_SCENE) == "train"
    # the three kinds are splits of their own and partition the held-out cells
    kinds = {k: set(FAMILY.cells(f"heldout-{k}")) for k in ("rotated", "mirrored", "turn")}
    assert kinds == {"rotated": {(1, 0), (1, 1), (1, 2)}, "mirrored": {(4, 0), (4, 1), (4, 2)}, "turn": {(0, 2)}}
    assert set().union(*kinds.values()) == held
    assert {FAMILY.draw(seed, "heldout-turn")[0].cell for seed in range(20)} == {(0, 2)}
    with pytest.raises(ValueError, match=r"'turn' .* subset of heldout"):
        dataclasses.replace(FAMILY, heldout_kinds=(("turn", ((0, 0),)),))
    with pytest.raises(ValueError, match="split='test'"):
        FAMILY.cells("test")


def test_the_wideband_family_has_the_wideband_library():
    wide = F.get_family("urban-intersection-wideband")
    assert len(wide.draw(0)[1].waveforms) == 8 and wide.cells("heldout") == FAMILY.cells("heldout")
    assert F.family_names() == ("urban-intersection", "urban-intersection-wideband")
    with pytest.raises(KeyError, match="unknown scene family 'urban'"):
        F.get_family("urban")
