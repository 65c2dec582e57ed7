"""The PDA information-reduction factor q_2 (tracking.reduction): limits, shape, and the tracker's own PDA update."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from uwb_env import scenarios
from uwb_env.lookahead import check_q2
from uwb_env.rng import RngStreams
from uwb_env.scene import sample_truth
from uwb_env.sensing import ParametricSensor, ScanPlan
from uwb_env.tracking.lmipda import lmipda
from uwb_env.tracking.reduction import (
    LAMBDA_MAX,
    PD_GRID,
    gate_volume_factor,
    information_reduction,
    reduction_table,
    unit_ball_volume,
)

PG = 0.99


@pytest.mark.parametrize("m", [1, 2, 3])
def test_no_clutter_gives_the_gate_probability(m):
    """lambda_G = 0: the target's measurement, when in the gate, is used alone: E[P+] = P - P_D P_G K S K^T."""
    table = reduction_table(m, PG)
    np.testing.assert_allclose(table[:, 0], PG, rtol=1e-12)


@pytest.mark.parametrize("m", [1, 2, 3])
def test_q2_falls_with_the_clutter_in_the_gate(m):
    """Monotone in lambda_G up to Monte Carlo wiggles, and small at the end.

    Common random numbers keep the wiggles below 1e-3 for P_D >= 0.2; at P_D -> 0 the table's q_2 = E[...] / P_D
    divides the Monte Carlo error by P_D (1e-2 at P_D = 0.02).
    """
    table = reduction_table(m, PG)
    assert np.all(np.diff(table[PD_GRID >= 0.2], axis=1) < 1e-3)
    assert np.all(np.diff(table, axis=1) < 1e-2)
    assert np.all(table[:, -1] < 0.12)
    assert np.all(table[:, 10] < table[:, 0] - 0.05)  # lambda_G = e^(10 dlog) - 1 ~ 0.8: a clear loss


def test_unit_ball_volume_and_gate_volume():
    assert unit_ball_volume(1) == pytest.approx(2.0)
    assert unit_ball_volume(2) == pytest.approx(math.pi)
    assert unit_ball_volume(3) == pytest.approx(4.0 * math.pi / 3.0)
    assert gate_volume_factor(2, PG) == pytest.approx(math.pi * stats.chi2.ppf(PG, 2))


@pytest.mark.parametrize(("m", "pd", "lam"), [(1, 0.9, 1.5), (2, 0.7, 4.0)])
def test_q2_matches_the_trackers_pda_update_by_monte_carlo(m, pd, lam):
    """E[P+] of the tracker's own LMIPDA weights (existence fixed) over simulated measurement sets, against the table.

    State = measurement space (H = I, P = I, R = I, so S = 2 I, K = I / 2, K S K^T = I / 2): the trace of E[P+]
    is m (1 - q_2 P_D / 2). Tolerance: 4 standard errors of the simulated mean.
    """
    rng = np.random.default_rng(7)
    n_sets = 6000
    S = 2.0 * np.eye(m)
    gamma = stats.chi2.ppf(PG, m)
    volume = gate_volume_factor(m, PG) * math.sqrt(np.linalg.det(S))
    rho = lam / volume
    traces = np.empty(n_sets)
    for k in range(n_sets):
        target = rng.multivariate_normal(np.zeros(m), S) if rng.uniform() < pd else None
        n_c = rng.poisson(lam)
        d = rng.normal(size=(n_c, m))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        clutter = d * (math.sqrt(gamma) * rng.uniform(size=n_c) ** (1.0 / m))[:, None] * math.sqrt(2.0)
        z = clutter if target is None else np.vstack([clutter, target])
        d2 = np.sum(z**2, axis=1) / 2.0
        z = z[d2 < gamma]
        d2 = d2[d2 < gamma]
        loglik = -0.5 * (d2 + m * math.log(2.0 * math.pi) + math.log(np.linalg.det(S)))
        log_ratio = (loglik - math.log(PG) - math.log(rho))[None, None]
        _, _, beta = lmipda(
            log_ratio,
            np.ones_like(log_ratio, bool),
            np.ones((1, 1)),
            np.ones(1),
            np.array([pd]),
            PG,
            fixed_existence=True,
        )
        b = beta[0, 0]
        # PDA posterior, P = I, K = I / 2: beta_0 P + (1 - beta_0)(P - K S K^T) + K (sum b nu nu^T - nubar nubar^T) K^T
        nubar = b[1:] @ z
        spread = (z.T * b[1:]) @ z - np.outer(nubar, nubar)
        Ppost = np.eye(m) - (1.0 - b[0]) * 0.5 * np.eye(m) + 0.25 * spread
        traces[k] = np.trace(Ppost)
    expected = m * (1.0 - float(information_reduction(m, pd, lam, PG)) * pd / 2.0)
    se = traces.std(ddof=1) / math.sqrt(n_sets)
    assert abs(traces.mean() - expected) < 4.0 * se + 2e-3 * m  # + the table's own Monte Carlo and grid error


def test_clutter_intensity_at_reads_the_detections_map():
    """The sensor model's clutter map at a detection's own measurement is the detection's clutter intensity."""
    cfg = scenarios.get("urban-intersection")
    sensor = ParametricSensor(cfg)
    rngs = RngStreams.from_seed(4)
    ep = sensor.new_episode(sample_truth(cfg, rngs.truth, sensor.layout), rngs)
    checked = 0
    for w in range(len(sensor.library)):
        for det in sensor.sense(ep, 10, ScanPlan.all_listening(w, sensor.n_tx, sensor.n_rx), 1.0):
            if len(det):
                rho = sensor.clutter_intensity_at(det.tx, det.rx, det.z, det.R[None], np.array([det.waveform]))
                np.testing.assert_allclose(rho[0], det.clutter_intensity, rtol=1e-12)
                checked += len(det)
    assert checked > 20
    with pytest.raises(ValueError, match="not a formed radar pair"):
        sensor.clutter_intensity_at(5, 0, np.zeros((1, 3)), np.ones((1, 1, 3, 3)))


@pytest.mark.parametrize("bad", [0.0, 1.5, -1.0, "kershaw"])
def test_invalid_q2_is_rejected(bad):
    with pytest.raises(ValueError, match="q2="):
        check_q2(bad)


def test_table_edges_are_held():
    assert float(information_reduction(2, 0.001, 0.0, PG)) == pytest.approx(PG)
    far = float(information_reduction(2, 1.0, 10 * LAMBDA_MAX, PG))
    assert far == pytest.approx(float(information_reduction(2, 1.0, LAMBDA_MAX, PG)))
