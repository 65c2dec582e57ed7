"""Receiver warm-up: the scenario where one-step lookahead is short-sighted (issue 6 item 3)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import uwb_env  # noqa: F401  (registers the ids)
from uwb_env.agents import MultiStepLookahead, Myopic
from uwb_env.lookahead import expected_posterior, lookahead_costs, position_trace, predict_combined, sequence_costs
from uwb_env.sensing.records import ScanPlan

ENV_ID = "uwb_env/IndoorSubsetWarmup-v1"


@pytest.fixture(scope="module")
def tracking_env():
    """The warm-up env 12 scans into an episode on subset 0, with a confirmed track."""
    env = gym.make(ENV_ID).unwrapped
    env.reset(seed=3)
    for _ in range(12):
        env.step(0)
    assert env.sim.tracker.tracks.confirmed.any()
    return env


def test_cold_receivers_deliver_nothing_and_the_ready_set_follows_the_plan():
    env = gym.make(ENV_ID).unwrapped
    env.reset(seed=0)
    assert env.ready_rx.all()  # calibrated listening before the episode
    plans = env.plans
    a = next(i for i, p in enumerate(plans) if p.active_rx.tolist() == [True, True, True, False, False, False])
    b = next(i for i, p in enumerate(plans) if p.active_rx.tolist() == [True, False, False, True, True, False])
    env.step(a)  # all ready: the three listening receivers deliver
    assert sorted(d.rx for d in env._last.detections) == [0, 1, 2]
    np.testing.assert_array_equal(env.ready_rx, plans[a].active_rx)
    np.testing.assert_array_equal(env.observation_space.shape, env._observation().shape)
    assert env._observation()[-6:].tolist() == [1, 1, 1, 0, 0, 0]  # the ready receivers end the observation
    env.step(b)  # receivers 3 and 4 were not listening: only receiver 0 delivers
    assert [d.rx for d in env._last.detections] == [0]
    np.testing.assert_array_equal(env.ready_rx, plans[b].active_rx)
    c = next(i for i, p in enumerate(plans) if p.active_rx.tolist() == [False, True, True, False, False, True])
    k_before = env.sim.k
    env.step(c)  # disjoint from b: nobody delivers, the tracker only predicts
    assert env._last.detections == () and env.sim.k == k_before + 1
    # without warm-up every listening receiver delivers
    plain = gym.make("uwb_env/IndoorSensorSubset-v1").unwrapped
    plain.reset(seed=0)
    plain.step(a)
    plain.step(b)
    assert plain.ready_rx is None and sorted(d.rx for d in plain._last.detections) == [0, 3, 4]


@pytest.mark.parametrize("fidelity", ["parametric", "signal"])
def test_warmup_keeps_common_random_numbers(fidelity):
    """The same seed gives the same detections of ready receivers whatever was (not) delivered before."""
    envs = [gym.make(ENV_ID, fidelity=fidelity).unwrapped for _ in range(2)]
    for env in envs:
        env.reset(seed=7)
    for a0, a1 in ((0, 0), (0, 19), (0, 0), (0, 0)):  # env 1: receivers 3-5 cold, then 0-2 cold, then ready
        envs[0].step(a0)
        envs[1].step(a1)
    d0 = {d.rx: d.z for d in envs[0]._last.detections}
    d1 = {d.rx: d.z for d in envs[1]._last.detections}
    assert d0.keys() == d1.keys() and len(d0) >= 1
    for r in d0:
        np.testing.assert_array_equal(d0[r], d1[r])


def test_one_step_costs_use_only_the_ready_receivers(tracking_env):
    env = tracking_env
    k = env.sim.k + 1
    t = k * env.cfg.sensing.scan_period_s
    ready = env.ready_rx
    effective = [ScanPlan(p.waveform, p.active_rx & ready) for p in env.plans]
    np.testing.assert_allclose(
        env.lookahead_costs(), lookahead_costs(env.sim.sensor, env.sim.tracker, effective, t, k), rtol=1e-12
    )


def test_observed_lookahead_holds_the_warmup_and_the_all_ready_costs(tracking_env):
    env = tracking_env
    k = env.sim.k + 1
    t = k * env.cfg.sensing.scan_period_s
    seen = gym.make(ENV_ID, include_lookahead=True, observation="dict").unwrapped
    seen.reset(seed=3)
    for _ in range(12):
        obs, *_ = seen.step(0)
    all_ready = lookahead_costs(env.sim.sensor, env.sim.tracker, env.plans, t, k)
    np.testing.assert_allclose(obs["lookahead"], (np.log10(env.lookahead_costs() + 1e-9) + 9) / 11, rtol=1e-6)
    np.testing.assert_allclose(obs["lookahead_all_ready"], (np.log10(all_ready + 1e-9) + 9) / 11, rtol=1e-6)
    np.testing.assert_array_equal(obs["ready_receivers"], env.ready_rx.astype(np.float32))
    assert (all_ready <= env.lookahead_costs() * (1 + 1e-12)).all()  # more ready receivers never cost more


def test_myopic_is_stuck_on_its_subset(tracking_env):
    """The docstring's argument: no other subset's one-step cost is below the current one's, so myopic stays."""
    env = tracking_env
    costs = env.lookahead_costs()
    current = env._previous
    assert costs[current] == costs.min()
    assert np.all(costs[np.arange(costs.size) != current] > costs[current])  # strictly: some receiver is cold
    assert Myopic().act(None, env) == current


def test_depth_two_with_warmup_equals_brute_force(tracking_env):
    """Every (a1, a2): a1 with the ready receivers, a2 with those a1 listened with."""
    env = tracking_env
    sensor, tracker, plans = env.sim.sensor, env.sim.tracker, env.plans
    period = env.cfg.sensing.scan_period_s
    k = env.sim.k + 1
    pred = tracker.predicted(k * period, k)
    sel = pred.select(pred.confirmed)
    x, P = sel.combined()
    ready = env.ready_rx
    best = np.full(len(plans), np.inf)
    for a1, p1 in enumerate(plans):
        P1 = expected_posterior(x, P, sensor, tracker, [ScanPlan(p1.waveform, p1.active_rx & ready)])[0]
        x2, P2, _, _ = predict_combined(x, P1, sel.mu, sel.active[0], tracker, period, k + 1)
        P2a = expected_posterior(
            x2, P2, sensor, tracker, [ScanPlan(p2.waveform, p2.active_rx & p1.active_rx) for p2 in plans]
        )
        best[a1] = position_trace(P1).mean() + position_trace(P2a).mean(axis=1).min()
    got = sequence_costs(sensor, tracker, plans, k * period, k, period, depth=2, beam=None, ready_rx=ready)
    np.testing.assert_allclose(got, best, rtol=1e-12)
    np.testing.assert_allclose(env.sequence_costs(2, beam=None), got, rtol=0)
    np.testing.assert_array_equal(env.sequence_costs(1), env.lookahead_costs())


def test_multistep_lookahead_leaves_the_first_subset_and_myopic_does_not():
    """Over an episode, myopic keeps one subset; depth 2 switches towards the walking person and ends far lower."""
    results = {}
    for name, agent in (("myopic", Myopic()), ("lookahead-2", MultiStepLookahead(2))):
        env = gym.make(ENV_ID).unwrapped
        obs, _ = env.reset(seed=11)
        actions, traces = [], []
        done = False
        while not done:
            a = agent.act(obs, env)
            obs, _, terminated, truncated, info = env.step(a)
            done = terminated or truncated
            actions.append(a)
            if info["confirmed_tracks"]:
                traces.append(info["covariance_trace"])
        results[name] = (actions, float(np.mean(traces)))
    assert len(set(results["myopic"][0])) == 1
    assert len(set(results["lookahead-2"][0])) >= 2
    assert results["lookahead-2"][1] < 0.2 * results["myopic"][1]
