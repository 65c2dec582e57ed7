"""The detection-constrained myopic scheduler and its inputs: expected Pd per plan, search information."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import uwb_env  # noqa: F401  (registers the ids)
from uwb_env.agents import DetectionConstrainedMyopic, make_scheduler
from uwb_env.waveforms.chirp import range_migration_gain


@pytest.fixture(scope="module")
def wideband():
    """The wideband urban env 45 scans in with at least one confirmed track (long 160 MHz chirps at 7 ms)."""
    env = gym.make("uwb_env/UrbanWaveform-v3", scenario="urban-intersection-wideband").unwrapped
    env.reset(seed=1)
    assert env.detection_probabilities() is None  # nothing confirmed yet
    for _ in range(45):
        env.step(7)
    assert env.sim.tracker.tracks.confirmed.any()
    return env


def test_plan_pd_is_the_sensor_models_pd_at_the_predicted_tracks(wideband):
    env = wideband
    pd = env.detection_probabilities()
    k = env.sim.k + 1
    tracker, sensor = env.sim.tracker, env.sim.sensor
    x, _, _, _ = tracker.predicted_estimates(k * env.cfg.sensing.scan_period_s, k, tracker.tracks.confirmed)
    cfg = tracker.cfg
    assert pd.shape == (len(env.plans), x.shape[0], sensor.pairs.shape[0])
    for q, (tx, rx) in enumerate(sensor.pairs.tolist()):
        for a, plan in enumerate(env.plans):  # a few plans: the test's reference, one call each
            ref, _ = sensor.expected_measurements(
                tx, rx, x[:, 0:3:2], np.array([plan.waveform[tx]]), cfg.assumed_rcs_m2, cfg.assumed_swerling,
                velocities=x[:, 1:4:2],
            )  # fmt: skip
            np.testing.assert_allclose(pd[a, :, q], np.minimum(ref[0], cfg.max_detection_probability), rtol=1e-12)


def test_search_information_ratio_is_bandwidth_squared_times_mean_walk_gain(wideband):
    """For the long chirps, info_7 / info_5 = (C_7 / C_5) (var_5 / var_7) (G_7 / G_5) by hand: C the radar constant
    (equal energy; the link budgets differ by 0.06 %), var(r) ~ 1 / B^2 (16x less at 160 MHz), G the migration gain
    averaged over rdot uniform in +-2 v_max."""
    env = wideband
    info = env.search_information()
    lib = env.sim.sensor.library.waveforms
    v = 2.0 * env.cfg.tracker.max_speed_mps
    rdot = np.linspace(-v, v, 41)
    g = [range_migration_gain(rdot, lib[w].range_spread_m, lib[w].config.pri_s, 25).mean() for w in (5, 7)]
    var = [lib[w].unit_covariance[0, 0] for w in (5, 7)]
    c = env.sim.sensor.radar_constant[:, 0, :].sum(axis=1)  # one transmitter, both receivers
    assert c[7] / c[5] == pytest.approx(1.0, abs=1e-3)
    assert info[7] / info[5] == pytest.approx((c[7] / c[5]) * (var[0] / var[1]) * (g[1] / g[0]), rel=1e-9)
    assert 10.0 < var[0] / var[1] < 17.0  # ~ (160 / 40)^2, less the pulse's own 1 / (2 kappa^2) term
    assert int(np.argmax(info)) == 7  # the 7 ms wideband chirp: finest range, least walk


class _FakeEnv:
    """What the scheduler reads of an env, set by hand."""

    def __init__(self, pd, costs, info, energy):
        self._pd, self._costs, self._info = pd, np.asarray(costs, float), np.asarray(info, float)
        self.plan_energy_j = np.asarray(energy, float)
        self.unwrapped = self

    def detection_probabilities(self):
        return self._pd

    def lookahead_costs(self):
        return self._costs

    def search_information(self):
        return self._info

    def action_masks(self):
        return np.ones(self._costs.size, bool)


def test_constrained_choice_by_hand():
    s = DetectionConstrainedMyopic(0.5)
    # 3 plans, 2 tracks, 2 pairs. Plan 0 is cheapest but track 1's mean Pd is 0.3; plan 2 is feasible and cheaper
    # than plan 1.
    pd = np.array([
        [[0.9, 0.9], [0.2, 0.4]],
        [[0.9, 0.9], [0.8, 0.8]],
        [[0.7, 0.6], [0.5, 0.5]],
    ])  # fmt: skip
    assert s.act(None, _FakeEnv(pd, [1.0, 3.0, 2.0], [0, 0, 0], [1, 1, 1])) == 2
    # nothing feasible: the plan whose weakest track is best detected (plan 1: 0.45 against 0.3 and 0.2)
    low = np.array([[[0.9, 0.9], [0.2, 0.4]], [[0.9, 0.9], [0.4, 0.5]], [[0.7, 0.6], [0.2, 0.2]]])
    assert s.act(None, _FakeEnv(low, [1.0, 3.0, 2.0], [0, 0, 0], [1, 1, 1])) == 1
    # an unused pair (Pd 0) does not count in the mean: plan 0 listens with pair 0 only, Pd 0.6 >= 0.5
    one = np.array([[[0.6, 0.0]], [[0.9, 0.9]]])
    assert s.act(None, _FakeEnv(one, [1.0, 2.0], [0, 0], [1, 1])) == 0
    # search (no confirmed track): the most range information
    assert s.act(None, _FakeEnv(None, [0.0, 0.0, 0.0], [1.0, 5.0, 2.0], [1, 1, 1])) == 1
    # min_pd 0 is the plain myopic choice
    assert DetectionConstrainedMyopic(0.0).act(None, _FakeEnv(pd, [1.0, 3.0, 2.0], [0, 0, 0], [1, 1, 1])) == 0


@pytest.mark.parametrize("bad", [-0.1, 1.5])
def test_min_pd_validated(bad):
    with pytest.raises(ValueError, match=r"min_pd=.*must be in \[0, 1\]"):
        DetectionConstrainedMyopic(bad)


def test_by_name():
    assert make_scheduler("myopic-pd").min_pd == 0.5
    assert make_scheduler("myopic-pd0.7").min_pd == 0.7
    with pytest.raises(ValueError, match="scheduler='myopic-pd2'"):
        make_scheduler("myopic-pd2")
