"""An episode depends on its seed and actions only, not on the episodes the same env played before.

Campaign workers (local processes or Ray tasks) reuse one env for many runs in whatever order they are handed, and
resumed campaigns replay some runs in fresh processes; their files are byte-identical only if nothing carries over.
(A cache of the motion matrices keyed by the rounded scan period but filled with whichever unrounded period came
first made the last bits of an episode depend on its predecessors.)
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import uwb_env  # noqa: F401  (registers the ids)
from uwb_env.agents import make_scheduler
from uwb_env.agents.campaign import play


@pytest.mark.parametrize(
    ("env_id", "scheduler", "kwargs"),
    [
        ("uwb_env/IndoorSensorSubset-v1", "random", {}),
        ("uwb_env/IndoorSensorSubset-v1", "myopic", {"tracker": "phd"}),
        ("uwb_env/IndoorSensorSubset-v1", "random", {"tracker": "pf"}),
        ("uwb_env/UrbanWaveform-v3", "myopic", {}),
    ],
)
def test_an_episode_is_the_same_fresh_and_after_others(env_id, scheduler, kwargs):
    fresh = play(gym.make(env_id, **kwargs).unwrapped, make_scheduler(scheduler), 2)[0]
    used = gym.make(env_id, **kwargs).unwrapped
    for seed in (0, 1):
        play(used, make_scheduler(scheduler), seed)
    after = play(used, make_scheduler(scheduler), 2)[0]
    np.testing.assert_array_equal(after, fresh)  # bit for bit (NaN where a metric is undefined, in both)
