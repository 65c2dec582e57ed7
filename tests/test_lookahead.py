"""Deeper lookahead: the moment-matched IMM prediction and the beam search over plan sequences."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import uwb_env  # noqa: F401  (registers the ids)
from uwb_env.agents import MultiStepLookahead, Myopic, make_scheduler
from uwb_env.config import open_loop_tracker
from uwb_env.lookahead import expected_posterior, lookahead_costs, position_trace, predict_combined, sequence_costs
from uwb_env.tracking.kernels import kf_predict
from uwb_env.tracking.tracker import Tracker


@pytest.fixture(scope="module")
def mid_episode():
    """An urban env 40 scans in (inside the 3-model window), with confirmed tracks."""
    env = gym.make("uwb_env/UrbanWaveform-v3").unwrapped
    env.reset(seed=5)
    for k in range(40):
        env.step(k % 4)
    assert env.sim.tracker.tracks.confirmed.sum() >= 1
    return env


def _args(env):
    k = env.sim.k + 1
    period = env.cfg.sensing.scan_period_s
    return env.sim.sensor, env.sim.tracker, env.plans, k * period, k, period


def test_depth_one_is_the_myopic_lookahead(mid_episode):
    sensor, tracker, plans, t, k, period = _args(mid_episode)
    np.testing.assert_array_equal(
        sequence_costs(sensor, tracker, plans, t, k, period, depth=1), lookahead_costs(sensor, tracker, plans, t, k)
    )


def test_depth_two_exhaustive_equals_brute_force(mid_episode):
    """Every (a1, a2) sequence evaluated one by one with the kernels, no batching over sequences."""
    env = mid_episode
    sensor, tracker, plans, t, k, period = _args(env)
    pred = tracker.predicted(t, k)
    sel = pred.select(pred.confirmed)
    x, P = sel.combined()
    best = np.full(len(plans), np.inf)
    for a1, p1 in enumerate(plans):
        P1 = expected_posterior(x, P, sensor, tracker, [p1])[0]
        x2, P2, _, _ = predict_combined(x, P1, sel.mu, sel.active[0], tracker, period, k + 1)
        for p2 in plans:
            P2a = expected_posterior(x2, P2, sensor, tracker, [p2])[0]
            cost = position_trace(P1).mean() + position_trace(P2a).mean()
            best[a1] = min(best[a1], cost)
    got = sequence_costs(sensor, tracker, plans, t, k, period, depth=2, beam=None)
    np.testing.assert_allclose(got, best, rtol=1e-12)
    # a beam as wide as the tree prunes nothing; a beam of 1 keeps only the myopic first plan
    np.testing.assert_array_equal(sequence_costs(sensor, tracker, plans, t, k, period, depth=2, beam=len(plans)), got)
    greedy = sequence_costs(sensor, tracker, plans, t, k, period, depth=2, beam=1)
    myopic = int(np.argmin(lookahead_costs(sensor, tracker, plans, t, k)))
    assert np.isfinite(greedy).sum() == 1 and np.isfinite(greedy[myopic])


def test_predict_combined_closed_forms(mid_episode):
    """One model: the Kalman prediction. Models sharing F: F P F^T + sum_j mu_j^- Q_j (no spread)."""
    tracker = mid_episode.sim.tracker
    rng = np.random.default_rng(0)
    n = 5
    x = rng.normal(size=(n, 6))
    L = rng.normal(size=(n, 6, 6))
    P = L @ np.swapaxes(L, -1, -2) + 6 * np.eye(6)
    k = 50  # window {nca, ct_left, ct_right}
    mask, Pi, F, Q = tracker.prediction_models(0.25, k)
    mu = np.zeros((n, tracker.r))
    mu[:, mask] = rng.dirichlet(np.ones(mask.sum()), size=n)
    xp, _, mup, mask2 = predict_combined(x, P, mu, mask, tracker, 0.25, k)
    assert (mask2 == mask).all()
    np.testing.assert_allclose(mup[:, mask], mu[:, mask] @ Pi)
    xj = np.einsum("jkl,nl->njk", F, x)
    np.testing.assert_allclose(xp, np.einsum("nj,njk->nk", mup[:, mask], xj))
    # a one-hot mu on model 0 mixes the models with the transition row Pi[0], spread included
    one = np.zeros_like(mu)
    one[:, np.flatnonzero(mask)[0]] = 1.0
    x1, P1, *_ = predict_combined(x, P, one, mask, tracker, 0.25, k)
    w = Pi[0]
    xj = np.einsum("jkl,nl->njk", F, x)
    xbar = np.einsum("j,njk->nk", w, xj)
    d = xj - xbar[:, None]
    Pj = F[None] @ P[:, None] @ np.swapaxes(F, -1, -2)[None] + Q[None]
    np.testing.assert_allclose(x1, xbar, rtol=1e-12)
    np.testing.assert_allclose(P1, np.einsum("j,njkl->nkl", w, Pj) + np.einsum("j,njk,njl->nkl", w, d, d), rtol=1e-10)
    # a single-model tracker (seed 003's open loop): exactly the Kalman prediction
    solo = Tracker(open_loop_tracker(tracker.cfg), tracker.tx_pos, tracker.rx_pos, tracker.area)
    _, _, Fs, Qs = solo.prediction_models(0.25, k)
    xs, Ps, mus, _ = predict_combined(x, P, np.ones((n, 1)), np.ones(1, bool), solo, 0.25, k)
    xk, Pk = kf_predict(x, P, Fs, Qs)
    np.testing.assert_allclose(xs, xk, rtol=1e-12)
    np.testing.assert_allclose(Ps, Pk, rtol=1e-12)
    assert (mus == 1.0).all()


def test_sequence_costs_are_pure_and_validate(mid_episode):
    env = mid_episode
    sensor, tracker, plans, t, k, period = _args(env)
    before = {f: getattr(tracker.tracks, f).copy() for f in ("x", "P", "mu", "existence")}
    state = env.sim.rngs.noise.bit_generator.state
    sequence_costs(sensor, tracker, plans, t, k, period, depth=3)
    for f, v in before.items():
        np.testing.assert_array_equal(getattr(tracker.tracks, f), v)
    assert env.sim.rngs.noise.bit_generator.state == state
    with pytest.raises(ValueError, match="depth=0"):
        sequence_costs(sensor, tracker, plans, t, k, period, depth=0)
    with pytest.raises(ValueError, match="beam=0"):
        sequence_costs(sensor, tracker, plans, t, k, period, depth=2, beam=0)
    with pytest.raises(ValueError, match="discount=0"):
        sequence_costs(sensor, tracker, plans, t, k, period, depth=2, discount=0.0)


def test_lookahead_agents_by_name(mid_episode):
    env = mid_episode
    assert make_scheduler("lookahead-1").act(None, env) == Myopic().act(None, env)
    agent = make_scheduler("lookahead-3")
    assert isinstance(agent, MultiStepLookahead) and agent.depth == 3
    assert make_scheduler("fixed-2").act(None, env) == 2
    with pytest.raises(ValueError, match="scheduler='greedy'"):
        make_scheduler("greedy")


def test_expected_measurements_batch_the_waveforms(mid_episode):
    """One geometry for W waveforms: each row equals the single-waveform sensor model."""
    sensor = mid_episode.sim.sensor
    x, _ = mid_episode.sim.tracker.tracks.combined()
    pos = x[:, [0, 2]]
    pd, R = sensor.expected_measurements(0, 1, pos, np.array([0, 2, 3]), 10.0, 1)
    assert pd.shape == (3, len(pos)) and R.shape == (3, len(pos), 2, 2)  # range, range-rate (the seed's set)
    for i, w in enumerate((0, 2, 3)):
        np.testing.assert_array_equal(pd[i], sensor.detection_probability_at(0, 1, pos, w, 10.0, 1))
        _, one_R = sensor.expected_measurements(0, 1, pos, np.array([w]), 10.0, 1)
        np.testing.assert_array_equal(one_R[0], R[i])
    assert (pd[1] >= pd[0]).all()  # the long pulse carries 2.75x the energy of the short one


def test_pda_q2_costs_are_never_below_the_clutter_free_ones():
    """q_2 <= P_G < 1 removes less of K S K^T than seed 003's q_2 = 1, so every action's expected trace is higher;
    the env validates the option."""
    env = gym.make("uwb_env/UrbanWaveform-v3", lookahead_q2="pda").unwrapped
    env.reset(seed=5)
    for k in range(30):
        env.step(k % 4)
    pda = env.lookahead_costs()
    env.lookahead_q2 = 1.0
    free = env.lookahead_costs()
    assert np.all(pda >= free)
    assert np.all(pda > free * (1.0 + 1e-6))  # tracks exist, so the difference is real, not rounding
    with pytest.raises(ValueError, match="q2="):
        gym.make("uwb_env/UrbanWaveform-v3", lookahead_q2="kershaw")


def _without_shared_prefixes(monkeypatch) -> None:
    """Every plan its own expected update (``_PlanTable.pair_groups`` off), fresh plan tables."""
    from uwb_env import lookahead

    monkeypatch.setattr(lookahead._PlanTable, "pair_groups", lambda self, pairs: None)
    monkeypatch.setattr(lookahead, "_PLAN_TABLES", {})


@pytest.mark.parametrize("env_id", ["uwb_env/UrbanDistributed-v0", "uwb_env/IndoorJoint-v1"])
def test_shared_prefixes_are_exact(env_id, monkeypatch):
    """Plans that do the same at the first pairs share one update there: the costs are those of every plan's own."""
    env = gym.make(env_id).unwrapped
    env.reset(seed=3)
    agent = Myopic()
    while env.sim.k < 60:
        env.step(agent.act(None, env))
    assert env.sim.tracker.tracks.confirmed.any()
    shared = (env.lookahead_costs(), env.sequence_costs(2, 3))
    with monkeypatch.context() as m:
        _without_shared_prefixes(m)
        plain = (env.lookahead_costs(), env.sequence_costs(2, 3))
    np.testing.assert_array_equal(shared[0], plain[0])
    np.testing.assert_array_equal(shared[1], plain[1])


def test_shared_prefix_groups_of_per_tx_plans():
    """Per-tx plans (tx-se slowest): 8 groups over tx-se's two pairs, 64 over tx-nw's; none for waveform plans."""
    from uwb_env.lookahead import _plan_table

    env = gym.make("uwb_env/UrbanDistributed-v0").unwrapped
    pairs = env.sim.sensor.pairs.tolist()
    chain, final = _plan_table(env.plans).pair_groups(pairs)
    sizes = [64 if rep is None else rep.size for rep, _ in chain]
    assert sizes == [8, 8, 64, 64]
    np.testing.assert_array_equal(chain[0][0], np.arange(0, 64, 8))  # representatives: tx-nw sends waveform 0
    np.testing.assert_array_equal(chain[2][1], np.repeat(np.arange(8), 8))  # each joint plan's tx-se group
    assert chain[1][1] is None and chain[3][1] is None and final is None  # identities: nothing gathered
    assert chain[2][0] is None and chain[3][0] is None  # every plan its own group from tx-nw's first pair
    urban = gym.make("uwb_env/UrbanWaveform-v3").unwrapped
    assert _plan_table(urban.plans).pair_groups(urban.sim.sensor.pairs.tolist()) is None
