"""``sensing.batch.sense_many`` gives, episode by episode, what ``ParametricSensor.sense`` gives (to the bit)."""

from __future__ import annotations

import numpy as np
import pytest

from uwb_env import scenarios
from uwb_env.rng import RngStreams
from uwb_env.scene.truth import sample_truth
from uwb_env.sensing.batch import sense_many
from uwb_env.sensing.parametric import ParametricSensor
from uwb_env.sensing.records import ScanPlan

FIELDS = ("tx", "rx", "waveform", "time_s", "z", "R", "snr", "origin", "measurement_names", "clutter_intensity",
          "expected_false_alarms", "range_rate_period_mps")  # fmt: skip


@pytest.mark.parametrize("name", ["urban-intersection", "indoor-rsn", "through-wall"])
def test_sense_many_equals_sense(name: str) -> None:
    cfg = scenarios.get(name)
    sensor = ParametricSensor(cfg)
    episodes = []
    for seed in range(4):
        rngs = RngStreams.from_seed(seed)
        episodes.append(sensor.new_episode(sample_truth(cfg, rngs.truth, sensor.layout), rngs))
    rng = np.random.default_rng(0)
    n_w, T, R = len(sensor.library), sensor.n_tx, sensor.n_rx
    for k in range(1, 30, 3):
        plans = []
        for j in range(len(episodes)):
            active = rng.random(R) < 0.7 if j % 2 else np.ones(R, bool)
            active[rng.integers(R)] = True
            # one plan per episode: a shared waveform, or (odd episodes, several transmitters) a mix (sense's path)
            waveform = rng.integers(0, n_w, T) if j == 3 else np.full(T, rng.integers(n_w))
            plans.append(ScanPlan(waveform, active))
        times = 0.1 * k + np.arange(len(episodes))
        got = sense_many(sensor, episodes, np.full(len(episodes), k), plans, times)
        for j, ep in enumerate(episodes):
            want = sensor.sense(ep, k, plans[j], float(times[j]))
            assert len(got[j]) == len(want)
            for g, w in zip(got[j], want, strict=True):
                for f in FIELDS:
                    a, b = getattr(g, f), getattr(w, f)
                    assert np.array_equal(a, b) if isinstance(a, np.ndarray) else a == b, (name, k, j, f)
