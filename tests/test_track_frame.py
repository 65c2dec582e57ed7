"""The env's ``track_frame="relative"`` observation: the slots of ``uwb_env.envs.relative`` in the env, single and
batched, the same numbers for a scene and its rotated or mirrored copy, end to end."""

from __future__ import annotations

import numpy as np
import pytest

from uwb_env.envs import UWBSchedulingEnv
from uwb_env.envs.relative import relative_track_features_reference
from uwb_env.envs.vector import UWBVectorEnv
from uwb_env.scenarios import families as F
from uwb_env.scenarios.families import SceneVariant

FAMILY = F.get_family("urban-intersection")
# Clutter-free, EKF (a UKF's Cholesky sigma points are equivariant only under sign flips of the axes, and false alarms
# are drawn in the area's frame: tests/unit/test_families.py), the right-turn path, two vehicles 10 s apart.
QUIET = {"sensing.clutter.density_per_m2": 0.0, "sensing.ghost_rate": 0.0, "tracker.filter": "ekf"}


def _episode(orientation: int, frame: str, scans: int = 80) -> np.ndarray:
    env = UWBSchedulingEnv(FAMILY.build(SceneVariant(orientation, 2, (0.0, 10.0))), track_frame=frame, **QUIET)
    obs, _ = env.reset(seed=3)
    return np.array([obs, *(env.step(k % 6)[0] for k in range(scans))])


def test_relative_observations_are_the_same_in_every_orientation_and_absolute_ones_are_not():
    """All 8 elements of D4 (rotations by quarter turns, mirrors): the relative observations of every scan agree to
    1e-9 (the features are O(1)); a track is held from scan 29 to the end (slot 0 present in 52 of the 81
    observations: the comparison covers tracks), and the absolute observations of the mirror image differ (the test
    has teeth)."""
    rel = np.array([_episode(g, "relative") for g in range(8)])
    np.testing.assert_allclose(rel, rel[[0]].repeat(8, 0), rtol=0, atol=1e-9)
    present = rel[0, :, 0]  # slot 0's `present` flag
    assert present[:29].sum() == 0 and present[29:].all()
    ab = np.array([_episode(g, "absolute") for g in (0, 4)])
    assert np.abs(ab[0] - ab[1]).max() > 0.1


def test_the_env_slots_are_the_reference_kernel_on_its_tracks():
    env = UWBSchedulingEnv("urban-intersection", track_frame="relative")
    env.reset(seed=5)
    for _ in range(40):
        obs = env.step(1)[0]
    tracks = env.sim.tracker.tracks
    assert len(tracks) >= 2
    x, P = tracks.combined()
    scene = env._relative_scene
    want = relative_track_features_reference(
        tracks.existence, tracks.confirmed, tracks.mu, tuple(env.sim.tracker.model_names), x, P, scene[0], scene[1],
        scene[2], scene[3], scene[6], env._v_max, env.n_slots,
    )  # fmt: skip
    n = env.n_slots * env.slot_features
    np.testing.assert_allclose(obs[:n].reshape(env.n_slots, env.slot_features), want, rtol=0, atol=1e-6)  # float32
    assert env.observation_space.contains(obs)


def test_the_batched_env_gives_the_single_envs_relative_observations():
    vec = UWBVectorEnv(3, scenario="urban-intersection", track_frame="relative", include_lookahead=True)
    singles = [UWBSchedulingEnv("urban-intersection", track_frame="relative", include_lookahead=True) for _ in range(3)]
    obs, _ = vec.reset(seed=[11, 12, 13])
    ref = [e.reset(seed=s)[0] for e, s in zip(singles, (11, 12, 13), strict=True)]
    np.testing.assert_array_equal(obs, np.array(ref))
    for k in range(30):
        actions = np.array([k % 6, (k + 1) % 6, 5])
        obs = vec.step(actions)[0]
        ref = [e.step(int(a))[0] for e, a in zip(singles, actions, strict=True)]
        np.testing.assert_array_equal(obs, np.array(ref))


def test_a_bad_track_frame_is_refused_naming_it():
    with pytest.raises(ValueError, match=r"track_frame='polar'.*\('absolute', 'relative'\)"):
        UWBSchedulingEnv("urban-intersection", track_frame="polar")
    with pytest.raises(TypeError, match="track_frame=1"):
        UWBSchedulingEnv("urban-intersection", track_frame=1)
