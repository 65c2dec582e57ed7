"""Distributed transmitters (``urban-distributed``, ``UrbanDistributed-v0``): each transmitter its own waveform.

The scenario's nodes and powers, the MultiDiscrete and flat Discrete encodings of the joint plans, their masks,
each pair's detections from its own transmitter's waveform, the joint-plan lookahead against a hand evaluation,
the schedulers on the MultiDiscrete space and the rewards.
"""

from __future__ import annotations

import copy
import itertools

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import uwb_env  # noqa: F401  (registers the ids)
from uwb_env import scenarios
from uwb_env.agents import MultiStepLookahead, Myopic, make_scheduler
from uwb_env.envs.outputs import observations
from uwb_env.envs.scheduling import UWBSchedulingEnv, enumerate_plans
from uwb_env.envs.vector import UWBVectorEnv
from uwb_env.lookahead import position_trace, scored_prediction
from uwb_env.scenarios.urban_distributed import NW_POWER_DBM, median_pulse_snr_db
from uwb_env.scenarios.urban_intersection import SEED_REGIME_POWER_DBM
from uwb_env.sensing.records import ScanPlan
from uwb_env.tracking.expectation import reduction_model

ID = "uwb_env/UrbanDistributed-v0"  # registered with the flat encoding, Discrete(64)
MULTI = {"action_encoding": "multi"}  # MultiDiscrete([8, 8])
W, T = 8, 2


@pytest.fixture(scope="module")
def tracked():
    """UrbanDistributed-v0 after 100 myopic scans of seed 1 (two vehicles on the path, both tracked)."""
    env = gym.make(ID, **MULTI).unwrapped
    env.reset(seed=1)
    agent = Myopic()
    while env.sim.k < 100:
        env.step(agent.act(None, env))
    assert env.sim.tracker.tracks.confirmed.sum() == 2
    return env


def test_scenario_nodes_pairs_and_seed_regime_power():
    cfg = scenarios.get("urban-distributed")
    assert [t.name for t in cfg.transmitters] == ["tx-se", "tx-nw"]
    assert [r.name for r in cfg.receivers] == ["rx-se1", "rx-se2", "rx-nw1", "rx-nw2"]
    assert cfg.radar_pairs == ((0, 0), (0, 1), (1, 2), (1, 3))  # each node's own receivers
    assert [t.power_dbm for t in cfg.transmitters] == [SEED_REGIME_POWER_DBM, NW_POWER_DBM]
    assert len(cfg.waveforms) == 8
    assert {w.bandwidth_hz for w in cfg.waveforms} == {40e6, 160e6}
    assert {w.pri_s for w in cfg.waveforms} == {7e-3, 10e-3}
    assert {w.pulse_duration_s for w in cfg.waveforms} == {0.5e-6, 1.375e-6}
    # the seed's regime per transmitter: one pulse, one element E/N0 of 0.2 (-6.99 dB) at each node's median link
    np.testing.assert_allclose(median_pulse_snr_db(cfg), 10 * np.log10(0.2), atol=0.05)
    # and the seed's own node keeps urban-intersection's figure (the same 4.5 dBm, the same links)
    base = median_pulse_snr_db(scenarios.get("urban-intersection"), ((0, 1),))
    np.testing.assert_allclose(median_pulse_snr_db(cfg)[0], base[0], rtol=0, atol=1e-12)


def test_multidiscrete_and_flat_decode_to_the_same_plans():
    multi = gym.make(ID, **MULTI).unwrapped
    flat = gym.make(ID).unwrapped
    assert UWBSchedulingEnv("urban-distributed", action_kind="per-tx").action_space == multi.action_space
    assert multi.action_space == gym.spaces.MultiDiscrete([W, W])
    assert flat.action_space == gym.spaces.Discrete(W**T)
    assert len(multi.plans) == len(flat.plans) == 64
    for a, (w_se, w_nw) in enumerate(itertools.product(range(W), repeat=T)):  # first transmitter slowest
        action = multi.action_of_plan(a)
        np.testing.assert_array_equal(action, [w_se, w_nw])
        assert multi.action_space.contains(action)
        assert multi.plan_index(action) == flat.plan_index(a) == a == 8 * w_se + w_nw
        assert flat.action_of_plan(a) == a
        np.testing.assert_array_equal(multi.plans[a].waveform, [w_se, w_nw])
        np.testing.assert_array_equal(flat.plans[a].waveform, [w_se, w_nw])
        assert multi.plans[a].active_rx.all()
    # the same seed and plans: the same episode in both encodings (observations, rewards, infos)
    rng = np.random.default_rng(7)
    o_m, _ = multi.reset(seed=3)
    o_f, _ = flat.reset(seed=3)
    np.testing.assert_array_equal(o_m, o_f)
    for a in rng.integers(0, 64, 12).tolist():
        o_m, r_m, *_ = multi.step(multi.action_of_plan(a))
        o_f, r_f, *_ = flat.step(a)
        np.testing.assert_array_equal(o_m, o_f)
        assert r_m == r_f
    # previous action: one-hot per transmitter (2 x 8 entries), not one of 64
    tracks = multi.n_slots * multi.slot_features
    prev = o_m[tracks : tracks + 2 * W]
    np.testing.assert_array_equal(np.flatnonzero(prev), [a // W, W + a % W])
    assert multi.observation_space.shape == (tracks + 2 * W,)


def test_bad_actions_and_encodings_raise():
    multi = gym.make(ID, **MULTI).unwrapped
    multi.reset(seed=0)
    for bad in (np.array([8, 0]), np.array([0, -1]), np.array([1, 2, 3]), 5, np.array([0.0, 1.0])):
        with pytest.raises(ValueError, match="a waveform per transmitter"):
            multi.step(bad)
    with pytest.raises(ValueError, match="action_encoding='multi' with action_kind='waveform'"):
        UWBSchedulingEnv("urban-intersection", action_encoding="multi")
    with pytest.raises(ValueError, match="action_encoding='x'"):
        gym.make(ID, action_encoding="x")
    with pytest.raises(ValueError, match=r"unavailable_waveforms=\{'tx-x'"):
        gym.make(ID, unavailable_waveforms={"tx-x": (0,)})
    with pytest.raises(ValueError, match=r"unavailable_waveforms\['tx-nw'\]"):
        gym.make(ID, unavailable_waveforms={"tx-nw": (9,)})


def test_masks_per_transmitter_flat_and_multi():
    dead = {"tx-nw": (6, 7), 0: ("k0.5us-up",)}  # tx-nw lacks the 160 MHz chirps, tx-se the short up-chirp
    multi = gym.make(ID, unavailable_waveforms=dead, **MULTI).unwrapped
    flat = gym.make(ID, unavailable_waveforms=dead).unwrapped
    se = np.ones(W, bool)
    se[0] = False
    nw = np.ones(W, bool)
    nw[[6, 7]] = False
    # sb3-contrib's MultiDiscrete convention: the per-dimension masks concatenated
    np.testing.assert_array_equal(multi.action_masks(), np.concatenate([se, nw]))
    # the flat mask is their product (plan a = 8 w_se + w_nw valid iff both waveforms are)
    np.testing.assert_array_equal(flat.action_masks(), np.outer(se, nw).ravel())
    np.testing.assert_array_equal(multi.plan_masks(), flat.action_masks())
    assert flat.action_masks().sum() == 7 * 6
    flat.reset(seed=0)
    multi.reset(seed=0)
    with pytest.raises(ValueError, match=r"waveform\(s\) \['k1.375us-up-160mhz'\] unavailable"):
        flat.step(8 * 1 + 6)
    with pytest.raises(ValueError, match=r"tx-se.*\[1, 2, 3, 4, 5, 6, 7\].*tx-nw.*\[0, 1, 2, 3, 4, 5\]"):
        multi.step(np.array([0, 1]))
    # a tuple masks every transmitter's waveform
    both = gym.make(ID, unavailable_waveforms=(7,), **MULTI).unwrapped
    np.testing.assert_array_equal(both.action_masks(), np.tile(np.arange(W) != 7, T))
    # the batched vector env stacks the same masks and takes (N, T) actions
    vec = UWBVectorEnv(2, scenario="urban-distributed", action_kind="per-tx", unavailable_waveforms=dead)
    np.testing.assert_array_equal(vec.action_masks(), np.stack([multi.action_masks()] * 2))
    vec.reset(seed=0)
    with pytest.raises(ValueError, match=r"actions\[1\]"):
        vec.step(np.array([[1, 1], [0, 1]]))


def test_each_pair_uses_its_own_transmitters_waveform():
    """A pair's detections under a mixed plan are those of its transmitter's waveform sent by all (CRN: to the bit)."""
    env = gym.make(ID).unwrapped
    env.reset(seed=2)
    sensor, episode, lib = env.sim.sensor, env.sim.episode, env.sim.sensor.library
    everyone = np.ones(4, bool)
    k = 60
    mixed = sensor.sense(episode, k, ScanPlan(np.array([0, 6]), everyone))
    alone = {w: sensor.sense(episode, k, ScanPlan(np.array([w, w]), everyone)) for w in (0, 6)}
    assert [(d.tx, d.rx) for d in mixed] == [(0, 0), (0, 1), (1, 2), (1, 3)]
    for i, d in enumerate(mixed):
        w = (0, 6)[d.tx]
        ref = alone[w][i]
        assert d.waveform == w
        assert d.range_rate_period_mps == lib.range_rate_periods[w]
        for field in ("z", "snr", "origin", "clutter_intensity"):
            np.testing.assert_array_equal(getattr(d, field), getattr(ref, field))
        # R: the waveform's covariance at the row's SNR (the mixed plan's per-waveform path; the single-waveform one
        # scales R(SNR = 1) / SNR: the last bit may differ)
        np.testing.assert_allclose(d.R, ref.R, rtol=1e-14, atol=0)
        assert d.expected_false_alarms == ref.expected_false_alarms
    # and the waveforms do differ there: the 160 MHz chirp makes ~4x the 40 MHz false alarms at tx-nw's pairs,
    # and its range-rate period is the 10 ms PRI's (same as waveform 0's)
    for i in (2, 3):
        ratio = alone[6][i].expected_false_alarms / alone[0][i].expected_false_alarms
        np.testing.assert_allclose(ratio, 4.0, rtol=1e-12)


def test_joint_plan_cost_equals_hand_applied_pair_updates(tracked):
    """lookahead_costs()[a] of a mixed plan = each pair's expected update applied in turn with its tx's waveform."""
    env = tracked
    costs = env.lookahead_costs()
    sensor, tracker, _, t, k = env._next_scan()
    x, P, _, _ = scored_prediction(tracker, t, k)
    cfg = tracker.cfg
    for w_se, w_nw in ((6, 2), (0, 7), (3, 3)):
        Pa = P[None].copy()
        for tx, rx in sensor.pairs.tolist():
            w = (w_se, w_nw)[tx]
            pd, R = sensor.expected_measurements(
                tx, rx, x[:, 0:3:2], np.array([w]), cfg.assumed_rcs_m2, cfg.assumed_swerling, velocities=x[:, 1:4:2]
            )
            pd = np.minimum(pd, cfg.max_detection_probability)
            R = R.copy()
            R[..., 1, 1] += cfg.range_rate_noise_floor_mps**2  # the filter's range-rate floor
            period = np.array([sensor.library.range_rate_periods[w]])
            Pa = tracker.expected_update(
                Pa, x, P, sensor.measurement_names(rx), sensor.layout.tx_pos[tx], sensor.layout.rx_pos[rx], R, pd,
                reduction_model(1.0, 2, cfg.gate_probability), np.zeros((1, x.shape[0])), period,
            )  # fmt: skip
        by_hand = position_trace(Pa[0]).mean()
        np.testing.assert_allclose(costs[8 * w_se + w_nw], by_hand, rtol=1e-12)
    # the expected posterior is below the prediction for every plan (information only adds)
    assert np.all(costs < position_trace(P).mean())
    assert np.ptp(costs) > 0.0  # the joint plans differ


def test_myopic_and_lookahead_pick_the_argmin(tracked):
    env = tracked
    costs = env.lookahead_costs()
    a = Myopic().act(None, env)
    assert env.action_space.contains(a)
    assert env.plan_index(a) == int(np.argmin(costs))  # the costs are distinct here: no tie-break
    np.testing.assert_array_equal(a, np.unravel_index(int(np.argmin(costs)), (W, W)))
    look = MultiStepLookahead(depth=3, beam=4)
    seq = look.costs(env)
    assert env.plan_index(look.act(None, env)) == int(np.argmin(seq))
    # depth 3's cost of a first plan is at least its one-scan cost (the later scans only add)
    finite = np.isfinite(seq)
    assert finite.sum() >= 1 and np.all(seq[finite] >= costs[finite])


def test_common_waveform_myopic_is_the_argmin_over_the_diagonal(tracked):
    env = tracked
    costs = env.lookahead_costs()
    a = make_scheduler("myopic-common").act(None, env)
    diagonal = np.arange(W) * (W + 1)  # plans (w, w)
    assert a[0] == a[1] and env.plan_index(a) == diagonal[np.argmin(costs[diagonal])]
    assert costs[env.plan_index(a)] >= costs.min()  # never below the joint optimum
    urban = gym.make("uwb_env/UrbanWaveform-v3").unwrapped  # one transmitter: every plan is common, = myopic
    urban.reset(seed=5)
    for k in range(30):
        urban.step(k % 6)
    assert make_scheduler("myopic-common").act(None, urban) == Myopic().act(None, urban)


@pytest.mark.parametrize(
    "name", ["round-robin", "random", "fixed-9", "myopic", "myopic-pd", "myopic-common", "lookahead-2"]
)
def test_every_scheduler_plays_the_multidiscrete_space(name):
    env = gym.make(ID, unavailable_waveforms={"tx-nw": (6, 7)}, **MULTI)
    agent = make_scheduler(name)
    obs, _ = env.reset(seed=4)
    agent.reset(4)
    actions = []
    for _ in range(6):
        a = agent.act(obs, env)
        assert env.action_space.contains(np.asarray(a, dtype=np.int64))
        assert a[1] not in (6, 7)  # tx-nw's masked waveforms are never chosen
        actions.append(tuple(int(v) for v in a))
        obs, reward, *_ = env.step(a)
        assert np.isfinite(reward)
    if name == "round-robin":  # the valid plans in order: tx-se slowest, tx-nw skipping 6 and 7
        assert actions == [(0, 0), (0, 1), (0, 2), (0, 3), (0, 4), (0, 5)]
    if name == "fixed-9":
        assert actions == [(1, 1)] * 6


def test_rewards_are_the_hand_assembled_ones():
    """Every scan's reward = -(mean trace of the confirmed tracks) - 100 x (alive targets no confirmed track covers)."""
    env = gym.make(ID).unwrapped
    env.reset(seed=0)
    agent = Myopic()
    total = 0.0
    for _ in range(env.cfg.n_scans):
        _, reward, terminated, truncated, info = env.step(agent.act(None, env))
        tracks = env.sim.tracker.tracks
        x, P = tracks.combined()
        conf = tracks.confirmed
        trace = position_trace(P[conf]).mean() if conf.any() else 0.0
        k = env.sim.k
        truth = env.sim.truth.states[k][env.sim.truth.alive[k]][:, 0:3:2]
        dist = np.linalg.norm(truth[:, None] - x[conf][:, 0:3:2][None], axis=-1)  # (targets, confirmed)
        missed = int((~(dist <= env.cover_gate_m).any(axis=1)).sum()) if conf.any() else truth.shape[0]
        np.testing.assert_allclose(reward, -trace - 100.0 * missed, rtol=1e-12, atol=0)
        assert info["missed_targets"] == missed
        if k == 1:  # one vehicle alive (the second is born at 10 s), no track yet
            assert reward == -100.0
        total += reward
        assert not terminated and truncated == (k == env.cfg.n_scans)
    assert np.isfinite(total)
    # both vehicles end up tracked: far fewer than the 140 + 100 target-scans are missed
    assert -total < 100.0 * 120


def test_vector_env_equals_single_envs():
    """The batched env's (N, T) actions play the single envs' plans: observations and rewards to the bit.

    Its lookahead costs agree to 1e-13: numpy's vectorised functions over all environments' tracks at once can
    round the last bit differently from one environment's (as on UrbanWideband-v2: up to 4e-16 relative).
    """
    vec = UWBVectorEnv(2, scenario="urban-distributed", action_kind="per-tx", track_frame="relative")  # the id's
    singles = [gym.make(ID, **MULTI).unwrapped for _ in range(2)]
    obs, _ = vec.reset(seed=11)
    np.testing.assert_array_equal(obs, np.stack([e.reset(seed=11 + i)[0] for i, e in enumerate(singles)]))
    for _ in range(15):
        costs = vec.lookahead_costs()
        for e, c in zip(singles, costs, strict=True):
            np.testing.assert_allclose(c, e.lookahead_costs(), rtol=1e-13, atol=0)
        acts = np.stack([e.action_of_plan(int(np.argmin(c))) for e, c in zip(singles, costs, strict=True)])
        obs, rewards, *_ = vec.step(acts)
        outs = [e.step(a) for e, a in zip(singles, acts, strict=True)]
        np.testing.assert_array_equal(obs, np.stack([o[0] for o in outs]))
        np.testing.assert_array_equal(rewards, [o[1] for o in outs])


def test_signal_fidelity_runs_mixed_plans():
    """The chirp chain forms each pair's image with its own transmitter's waveform (pairs grouped by waveform)."""
    env = gym.make(ID, fidelity="signal", **MULTI).unwrapped
    env.reset(seed=0)
    for _ in range(2):
        env.step(np.array([6, 1]))
    dets = env._last.detections
    assert [(d.tx, d.rx, d.waveform) for d in dets] == [(0, 0, 6), (0, 1, 6), (1, 2, 1), (1, 3, 1)]
    lib = env.sim.sensor.library
    for d in dets:
        assert d.range_rate_period_mps == pytest.approx(float(lib.range_rate_periods[d.waveform]), rel=1e-12)


def test_deepcopied_env_costs_are_pure(tracked):
    env = copy.deepcopy(tracked)
    before = env.lookahead_costs()
    env.sequence_costs(2, 4)
    np.testing.assert_array_equal(env.lookahead_costs(), before)


def test_maskable_ppo_takes_the_multidiscrete_masks():
    """sb3-contrib's MaskablePPO on MultiDiscrete([8, 8]): the concatenated masks keep tx-nw off its lacking chirps."""
    sb3_contrib = pytest.importorskip("sb3_contrib")
    from sb3_contrib.common.maskable.utils import get_action_masks
    from stable_baselines3.common.vec_env import DummyVecEnv

    venv = DummyVecEnv([lambda: gym.make(ID, unavailable_waveforms={"tx-nw": (6, 7)}, **MULTI)])
    obs = venv.reset()
    masks = get_action_masks(venv)
    assert masks.shape == (1, 2 * W) and masks.sum() == W + 6
    model = sb3_contrib.MaskablePPO("MlpPolicy", venv, n_steps=32, batch_size=32, seed=0)
    model.learn(32)  # one rollout through the env with masked sampling: a masked plan would raise in step()
    for _ in range(20):
        action, _ = model.predict(obs, action_masks=get_action_masks(venv), deterministic=False)
        assert action.shape == (1, T) and action[0, 1] not in (6, 7)
        obs, *_ = venv.step(action)


@settings(max_examples=60, deadline=None)
@given(n_waveforms=st.integers(1, 6), n_tx=st.integers(1, 4), n_rx=st.integers(1, 3), data=st.data())
def test_per_tx_plans_are_the_product_in_ravel_order(n_waveforms, n_tx, n_rx, data):
    """enumerate_plans("per-tx"): W^T plans, plan a sends unravel_index(a, (W,) * T), every receiver listens; the
    previous action's one-hot per transmitter marks exactly those digits."""
    plans = enumerate_plans("per-tx", n_waveforms, n_tx, n_rx, 1, 0)
    dims = (n_waveforms,) * n_tx
    assert len(plans) == n_waveforms**n_tx
    a = data.draw(st.integers(0, len(plans) - 1))
    np.testing.assert_array_equal(plans[a].waveform, np.unravel_index(a, dims))
    assert plans[a].active_rx.all() and plans[a].active_rx.shape == (n_rx,)
    assert len({tuple(p.waveform.tolist()) for p in plans}) == len(plans)  # every assignment once
    feats = np.zeros((2, 1, 3))
    obs = observations(feats, np.array([a, -1]), len(plans), {}, "box", 10.0, np.zeros(2, np.int64), dims)
    prev = obs[:, 3:]
    assert prev.shape == (2, n_waveforms * n_tx)
    np.testing.assert_array_equal(np.flatnonzero(prev[0]), np.arange(n_tx) * n_waveforms + plans[a].waveform)
    assert not prev[1].any()  # no previous action (reset)
