"""``parametric.WaveformRows``: false-alarm rows measured per waveform on first use equal the all-at-reset rows.

Each waveform's rows are one ``_measure`` call on the episode's fixed inputs, so the order in which waveforms are
measured, and which ones are, must not change a bit; a scan reads only what its plan sends.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import uwb_env
from uwb_env.sensing.parametric import WaveformRows

gym.register_envs(uwb_env)


def _episode(seed: int) -> object:
    env = gym.make("uwb_env/UrbanDistributed-v0")
    env.reset(seed=seed)
    return env


def test_rows_do_not_depend_on_measuring_order() -> None:
    """Waveforms measured last-to-first and first-to-last (two resets of one seed): identical bytes, all W."""
    a, b = _episode(4).unwrapped.sim.episode.clutter_rows, _episode(4).unwrapped.sim.episode.clutter_rows
    assert isinstance(a, WaveformRows) and a.shape == b.shape and a.shape[0] == 8 and a.shape[1] > 1000
    assert not any(r is not None for r in a._measured)  # nothing measured at reset
    backward = [a.waveform(w) for w in reversed(range(a.shape[0]))][::-1]
    forward = [b.waveform(w) for w in range(b.shape[0])]
    for x, y in zip(backward, forward, strict=True):
        assert x.shape == (a.shape[1], a.shape[2]) and x.tobytes() == y.tobytes()
    assert np.asarray(a).tobytes() == np.stack(forward).tobytes()


def test_indexing_matches_the_full_array() -> None:
    """``rows[w, a:b]`` and the per-row gather ``rows[w_rows, idx]`` equal indexing the materialised array."""
    rows = _episode(2).unwrapped.sim.episode.clutter_rows
    lazy = _episode(2).unwrapped.sim.episode.clutter_rows
    full = np.asarray(rows)
    assert np.array_equal(lazy[3, 100:250], full[3, 100:250])
    assert sum(r is not None for r in lazy._measured) == 1  # only waveform 3 measured
    rng = np.random.default_rng(0)
    idx = np.arange(500, 900)
    w_rows = rng.choice([1, 6], idx.size)
    assert np.array_equal(lazy[w_rows, idx], full[w_rows, idx])
    assert [r is not None for r in lazy._measured] == [w in (1, 3, 6) for w in range(8)]


def test_an_episode_measures_only_the_waveforms_it_sends() -> None:
    """After ten scans of three joint plans, the measured waveforms are exactly those the plans sent."""
    env = _episode(1)
    u = env.unwrapped
    sent = set()
    for k in range(10):
        action = (0, 5, 21)[k % 3]  # three of the 64 joint plans
        sent.update(int(w) for w in u.plans[u.plan_index(action)].waveform)
        env.step(action)
    measured = {w for w, r in enumerate(u.sim.episode.clutter_rows._measured) if r is not None}
    assert measured == sent and len(sent) < 8
