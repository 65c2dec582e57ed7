"""Valid configurations at the ends of their allowed ranges run whole episodes (issue 16: the allowed ranges match
what the code can hold).

Before: ``tracker.max_speed_mps`` 100 (indoor) or a motion model's ``accel_noise_std_mps2`` 100 let a confirmed track
coast out of the room (``FloatingPointError``: observation outside its bounds), ``tracker.initial_accel_std_mps2``
1e6 raised ``LinAlgError``, and ``sensing.clutter_residue_looks`` above 171 gave NaN quadrature weights silently
(now refused above 100).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from uwb_env.envs import UWBSchedulingEnv
from uwb_env.sensing.parametric import residue_quadrature

INDOOR = [
    {"tracker.max_speed_mps": 100.0},
    {"tracker.max_speed_mps": 1e4},
    {"tracker.initial_accel_std_mps2": 1000.0},
    {"tracker.models.0.accel_noise_std_mps2": 100.0},
    {"tracker.models.0.accel_noise_std_mps2": 1000.0, "tracker.models.1.accel_noise_std_mps2": 1000.0},
    {"tracker.gate_probability": 1.0},
    {"tracker.min_clutter_intensity": 1.0},
    {"tracker.max_position_std_m": 1e6},
    {"sensing.false_alarm_probability": 0.1},
    {"sensing.clutter_residue_ratio": 1e6, "sensing.clutter_residue_looks": 100.0},
    {"sensing.clutter_residue_looks": 1e-3},
    {"sensing.scan_period_s": 1e-6},
    {"sensing.max_range_m": 1e-3},
    {"transmitters.0.power_dbm": -100.0},
    {"transmitters.0.power_dbm": 100.0, "receivers.0.antenna_gain_db": 60.0, "transmitters.0.antenna_gain_db": 60.0},
    {"channel.path_loss_exponent": 1.0},
    {"channel.reference_distance_m": 1e-9},
    {"targets.0.rcs_mean_m2": 1e12},
    {"waveforms.0.n_pulses": 10**12},
    {"sensing.ghost_rate": 100.0},
    {"sensing.min_range_std_m": 1e-5, "transmitters.0.power_dbm": 100.0},
]


@pytest.mark.parametrize("overrides", INDOOR, ids=lambda o: ",".join(f"{k}={v}" for k, v in o.items()))
def test_indoor_extremes_play_finite_episodes(overrides):
    env = UWBSchedulingEnv("indoor-rsn", action_kind="subset", **overrides)
    rng = np.random.default_rng(0)
    for seed in range(3):
        obs, _ = env.reset(seed=seed)
        truncated = terminated = False
        while not (terminated or truncated):
            obs, reward, terminated, truncated, _ = env.step(int(rng.integers(env.action_space.n)))
            assert env.observation_space.contains(obs) and math.isfinite(reward)
        tracks = env.sim.tracker.tracks
        if len(tracks):
            assert np.linalg.eigvalsh(tracks.combined()[1]).min() > 0.0


@pytest.mark.parametrize("looks", [1e-3, 1.0, 100.0])
def test_residue_quadrature_is_a_distribution_with_mean_1_over_the_allowed_looks(looks):
    nodes, weights = residue_quadrature(looks)
    assert np.isfinite(nodes).all() and np.isfinite(weights).all()
    assert weights.sum() == pytest.approx(1.0)
    assert (nodes * weights).sum() == pytest.approx(1.0, rel=1e-6)  # E[X] = 1
    assert ((nodes - 1.0) ** 2 * weights).sum() == pytest.approx(1.0 / looks, rel=1e-3)  # Var[X] = 1 / m
