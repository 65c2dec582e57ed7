"""The compiled initiation and notch kernels against their numpy twins: the same numbers to the bit.

``Tracker._initiate`` runs ``initiation.initiate_compiled`` (the batched trackers' kernel with one environment);
``initiation.range_only_candidates`` stays as the numpy reference (``ReferenceTracker``, a subclass overriding
``_form_tracks``, takes it). The lookahead's notch and bistatic range-rate are compiled
(``channel.doppler_notch``); numpy's expressions are their references.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from scipy.stats import chi2

import uwb_env
from uwb_env.channel.doppler_notch import bistatic_range_rate
from uwb_env.tracking.initiation import _range_only_candidates, range_only_candidates
from uwb_env.tracking.tracker import Tracker
from uwb_env.tracking.trackset import FIELDS

gym.register_envs(uwb_env)

AREA = np.array([-40.0, 60.0, -30.0, 50.0])
STARTS = np.array([[10.0, 10.0], [-15.0, -10.0], [35.0, -10.0], [-15.0, 30.0], [35.0, 30.0]])


def _groups(rng: np.random.Generator, n_rx: int, shared: bool, cap: int) -> list[tuple]:
    """Range-only groups of ``n_rx`` receivers seeing 1-2 targets and clutter (ranges beyond each baseline)."""
    targets = rng.uniform([-30.0, -20.0], [50.0, 40.0], (2, 2))
    groups = []
    for _ in range(n_rx):
        tx = np.zeros(2) if shared else rng.uniform(-20.0, 20.0, 2)
        rx = rng.uniform(-30.0, 50.0, 2)
        r = np.linalg.norm(targets - tx, axis=1) + np.linalg.norm(targets - rx, axis=1)
        r = np.concatenate([r + rng.normal(0.0, 0.1, 2), np.linalg.norm(rx - tx) + rng.uniform(1.0, 80.0, 3)])
        n = int(rng.integers(1, cap + 1))
        groups.append((r[:n].copy(), rng.uniform(0.005, 0.05, n), tx, rx))
    return groups


@pytest.mark.parametrize(("n_rx", "shared"), [(2, True), (2, False), (3, True), (3, False), (4, False)])
def test_compiled_range_only_candidates_equal_numpy(n_rx: int, shared: bool) -> None:
    rng = np.random.default_rng(100 * n_rx + shared)
    residual_max = float(chi2.ppf(0.99, 1))
    nu = min(3, n_rx)
    for _ in range(25):
        groups = _groups(rng, n_rx, shared, 5)
        p_ref, c_ref = range_only_candidates(groups, nu, AREA, STARTS)
        cap = max(g[0].size for g in groups)
        rs, vs = np.zeros((n_rx, cap)), np.zeros((n_rx, cap))
        for g, (r, v, _, _) in enumerate(groups):
            rs[g, : r.size], vs[g, : r.size] = r, v
        counts = np.array([g[0].size for g in groups], np.int64)
        gtx, grx = np.array([g[2] for g in groups]), np.array([g[3] for g in groups])
        p, c = _range_only_candidates(rs, vs, counts, gtx, grx, nu, AREA, STARTS, residual_max)
        assert np.array_equal(p, p_ref) and np.array_equal(c, c_ref)


class _NumpyInitiation(Tracker):
    """A Tracker on the numpy initiation path (``_initiate_numpy``), compiled everywhere else."""

    def __init__(self, *args: object, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)
        self._fused_initiation = False


def _record_scans(env_id: str, seed: int, steps: int, **kwargs: object) -> tuple[object, list]:
    """A seeded episode's scans as its tracker saw them: ``(env, [(detections, time_s, scan_index), ...])``."""
    env = gym.make(env_id, **kwargs)
    sim = env.unwrapped.sim
    scans = []
    step = sim.tracker.step

    def recording(dets, time_s, scan_index):
        scans.append((list(dets), time_s, scan_index))
        return step(dets, time_s, scan_index)

    sim.tracker.step = recording
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    for _ in range(steps):
        env.step(int(rng.integers(env.action_space.n)))
    return env, scans


@pytest.mark.parametrize(
    ("env_id", "kwargs"),
    [
        ("uwb_env/UrbanWaveform-v3", {}),
        ("uwb_env/UrbanWideband-v2", {}),
        ("uwb_env/UrbanWaveform-v3", {"sensing.measure_doa": True}),  # array receivers: mixed candidates
    ],
)
def test_fused_initiation_equals_numpy_initiation(env_id: str, kwargs: dict) -> None:
    """Replayed scans: the compiled ``Tracker._initiate`` and the numpy path give the same tracker state."""
    env, scans = _record_scans(env_id, 3, 60, **kwargs)
    tr = env.unwrapped.sim.tracker
    fused = Tracker(tr.cfg, tr.tx_pos, tr.rx_pos, tr.area)
    reference = _NumpyInitiation(tr.cfg, tr.tx_pos, tr.rx_pos, tr.area)
    assert fused._fused_initiation and not reference._fused_initiation
    born = 0
    for dets, time_s, k in scans:
        a, b = fused.step(dets, time_s, k), reference.step(dets, time_s, k)
        for f in FIELDS:
            assert np.array_equal(getattr(a, f), getattr(b, f)), (k, f)
        assert np.array_equal(fused._previous.p, reference._previous.p)
        assert np.array_equal(fused._previous.cov, reference._previous.cov)
        assert fused._previous.time_s == reference._previous.time_s and fused._next_id == reference._next_id
        born = fused._next_id
    assert born > 0  # tracks were initiated


def test_compiled_notch_equals_numpy() -> None:
    """``notch_gain``'s compiled path (one pair, waveforms x targets) equals its broadcasting numpy path."""
    sensor = gym.make("uwb_env/UrbanWaveform-v3").unwrapped.sim.sensor
    assert sensor._notch is not None
    rng = np.random.default_rng(5)
    W = len(sensor.library.waveforms)
    for tx in range(sensor.layout.tx_pos.shape[0]):
        for rx in range(sensor.layout.rx_pos.shape[0]):
            w = rng.integers(0, W, (W + 2, 1))
            r = rng.uniform(-5.0, 400.0, (1, 40))
            v = rng.uniform(-30.0, 30.0, (1, 40))
            v[0, :4] = [0.0, -0.0, 1e-300, 15.0]
            fast = sensor.notch_gain(w, tx, rx, r, v)
            slow = sensor.notch_gain(w, np.array(tx), np.array(rx), r, v)  # 0-d indices: the numpy path
            assert fast.shape == slow.shape == (W + 2, 40)
            assert np.array_equal(fast, slow)


def test_compiled_bistatic_range_rate_equals_numpy() -> None:
    rng = np.random.default_rng(8)
    tx, rx = np.array([1.5, -2.0]), np.array([30.0, 4.0])
    pos = rng.uniform(-50.0, 50.0, (200, 2))
    pos[:2] = [tx, rx]  # on a node: the 1e-9 floor
    vel = rng.normal(0.0, 5.0, (200, 2))
    vel[2] = 0.0
    dt, dr = pos - tx, pos - rx
    lt, lr = np.linalg.norm(dt, axis=1), np.linalg.norm(dr, axis=1)
    rdot = np.einsum("nd,nd->n", dt / np.maximum(lt, 1e-9)[:, None] + dr / np.maximum(lr, 1e-9)[:, None], vel)
    rng_c, rdot_c = bistatic_range_rate(pos, vel, tx, rx)
    assert np.array_equal(rng_c, lt + lr) and np.array_equal(rdot_c, rdot)
    assert np.array_equal(np.signbit(rdot_c), np.signbit(rdot))
