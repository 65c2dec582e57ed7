"""The exact speed-ups of the myopic env on UrbanDistributed-v0 give the numbers of the paths they replace, bit for bit.

- ``ParametricSensor.expected_measurements_pairs`` (the lookahead's sensor model of all pairs in one call) equals
  ``expected_measurements`` pair by pair, and its compiled moving-target link (``_moving_link_kernel``) equals the
  kernels called one by one (``mean_link``, ``bistatic_range_rate``, ``notch_terms``, ``walk_gain``).
- ``tracker._confirm_and_keep`` (compiled) equals the numpy expressions of step 5 it replaced.
- ``outputs._digit_offsets``' digits equal ``numpy.unravel_index``.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import uwb_env  # noqa: F401  (registers the ids)
from uwb_env.channel.doppler_notch import bistatic_range_rate, notch_terms
from uwb_env.envs.outputs import _digit_offsets
from uwb_env.sensing.compiled import mean_link, walk_gain
from uwb_env.tracking.tracker import confirm_and_keep


@pytest.fixture(scope="module")
def sensor():
    """UrbanDistributed-v0's parametric sensor (Doppler notch and range walk both on)."""
    env = gym.make("uwb_env/UrbanDistributed-v0").unwrapped
    env.reset(seed=3)
    s = env.sim.sensor
    assert s._notch is not None and s._migration is not None and s._mti is None
    return s


def _targets(rng: np.random.Generator, sensor, n: int) -> tuple[np.ndarray, np.ndarray]:
    """n positions within 150 m of the nodes' centre (most covered) [m] and velocities [m/s]."""
    centre = sensor.layout.tx_pos.mean(axis=0)
    return centre + rng.uniform(-150.0, 150.0, (n, 2)), rng.normal(0.0, 12.0, (n, 2))


def test_pairs_in_one_call_equal_pair_by_pair(sensor) -> None:
    """40 draws of 1-6 targets, random waveform subsets per pair: Pd and R equal to the bit."""
    rng = np.random.default_rng(5)
    W = len(sensor.library)
    pairs = [tuple(p) for p in sensor.pairs.tolist()]
    detected = 0
    for _ in range(40):
        pos, vel = _targets(rng, sensor, int(rng.integers(1, 7)))
        sents = [np.sort(rng.choice(W, int(rng.integers(1, W + 1)), replace=False)) for _ in pairs]
        batched = sensor.expected_measurements_pairs(pairs, pos, sents, 1.3, 1, velocities=vel)
        for (tx, rx), sent, (pd, R) in zip(pairs, sents, batched, strict=True):
            pd1, R1 = sensor.expected_measurements(tx, rx, pos, sent, 1.3, 1, velocities=vel)
            assert pd.shape == (sent.size, pos.shape[0]) and R.shape == (sent.size, pos.shape[0], 2, 2)
            np.testing.assert_array_equal(pd, pd1)
            np.testing.assert_array_equal(R, R1)
            assert np.all((pd >= 0.0) & (pd <= 1.0)) and np.all(R[..., 0, 0] > 0.0)
            detected += int((pd > 0.5).sum())
    assert detected > 100  # covered targets, not only the zeros of uncovered ones


def test_moving_link_equals_the_kernels_one_by_one(sensor) -> None:
    """The fused link: az, coverage, SNR, range-rate, notch terms and both walk gains equal the separate calls."""
    rng = np.random.default_rng(8)
    for tx, rx in sensor.pairs.tolist():
        pos, vel = _targets(rng, sensor, 7)
        w = np.arange(len(sensor.library), dtype=np.int64)
        link = sensor._link_args(tx, rx, w)
        az, ok, snr, rdot, cnr, arg, g_pd, g_peak = sensor._moving_link(link, pos, vel, w, 1.0, tx, rx)
        pair, k, gain, weights = link
        sens = sensor.cfg.sensing
        az0, ok0, snr0, _ = mean_link(
            *pair[:2], pos, *pair[2:], k, 1.0, gain, weights, sens.false_alarm_probability, 1, sensor._p_noise
        )
        rng0, rdot0 = bistatic_range_rate(pos, vel, sensor.layout.tx_pos[tx], sensor.layout.rx_pos[rx])
        cnr_table, step, pri, sigma_f, lam = sensor._notch
        cnr0, arg0 = notch_terms(cnr_table[:, tx, rx], step, lam, pri, sigma_f, w, rng0, rdot0)
        step_w = sensor._WALK_STEP_MPS
        for got, want in [
            (az, az0), (ok, ok0), (snr, snr0), (rdot, rdot0), (cnr, cnr0), (arg, arg0),
            (g_pd, walk_gain(w, rdot0, sensor._migration_pd, step_w)),
            (g_peak, walk_gain(w, rdot0, sensor._migration[0], step_w)),
        ]:  # fmt: skip
            np.testing.assert_array_equal(got, want)
        assert ok.any() and np.all(cnr >= 0.0) and np.all(arg <= 0.0)


def _confirm_and_keep_numpy(cfg, area, existence, confirmed, age, x, P):
    """Step 5 as numpy expressions (the code the compiled kernel replaced)."""
    confirmed = confirmed | (existence >= cfg.confirm_existence)
    lost = P[:, 0, 0] + P[:, 2, 2] > 2.0 * cfg.max_position_std_m**2
    stale = ~confirmed & (age >= cfg.tentative_max_age)
    x0, x1, y0, y1 = area
    width, height = x1 - x0, y1 - y0
    gone = (np.abs(x[:, 0] - (x0 + x1) / 2) > 1.5 * width) | (np.abs(x[:, 2] - (y0 + y1) / 2) > 1.5 * height)
    gone |= x[:, 1] ** 2 + x[:, 3] ** 2 > (10.0 * cfg.max_speed_mps) ** 2
    return confirmed, (existence >= cfg.terminate_existence) & ~lost & ~stale & ~gone


def test_confirm_and_keep_compiled_equals_numpy() -> None:
    """2000 tracks around every threshold (existence, trace, age, area, speed): the same two masks."""
    env = gym.make("uwb_env/UrbanDistributed-v0").unwrapped
    cfg, area = env.sim.tracker.cfg, env.sim.tracker.area
    rng = np.random.default_rng(2)
    n = 2000
    existence = rng.choice([0.0, cfg.terminate_existence, cfg.confirm_existence, 0.5, 1.0], n)
    existence = existence * rng.choice([1.0, 1.0 + 1e-12, 1.0 - 1e-12], n)
    confirmed = rng.random(n) < 0.3
    age = rng.integers(0, 2 * cfg.tentative_max_age, n)
    x = np.zeros((n, 6))
    w, h = area[1] - area[0], area[3] - area[2]
    x[:, 0] = rng.uniform(area[0] - 2.0 * w, area[1] + 2.0 * w, n)
    x[:, 2] = rng.uniform(area[2] - 2.0 * h, area[3] + 2.0 * h, n)
    x[:, [1, 3]] = rng.normal(0.0, 8.0 * cfg.max_speed_mps, (n, 2))
    P = np.zeros((n, 6, 6))
    P[:, 0, 0] = P[:, 2, 2] = cfg.max_position_std_m**2 * rng.uniform(0.5, 1.5, n)
    got = confirm_and_keep(cfg, area, existence, confirmed, age, x, P)
    want = _confirm_and_keep_numpy(cfg, area, existence, confirmed, age, x, P)
    for g, e in zip(got, want, strict=True):
        np.testing.assert_array_equal(g, e)
    assert 0 < want[1].sum() < n and 0 < want[0].sum() < n  # both outcomes occur


@pytest.mark.parametrize("dims", [(8, 8), (3, 4, 5), (7,), (2, 3, 2, 5)])
def test_digit_offsets_equal_unravel_index(dims: tuple[int, ...]) -> None:
    """Every action's digits a // stride % dims equal numpy.unravel_index; offsets are the cumulated dims."""
    offsets, strides, sizes = _digit_offsets(dims)
    a = np.arange(int(np.prod(dims)))
    np.testing.assert_array_equal(a[:, None] // strides % sizes, np.stack(np.unravel_index(a, dims), axis=1))
    np.testing.assert_array_equal(offsets, np.concatenate([[0], np.cumsum(dims)[:-1]]))
