"""The compiled sensor-model link (``sensing.compiled.mean_link``) against the numpy reference, to rounding error."""

from __future__ import annotations

import numpy as np
import pytest

from uwb_env import scenarios
from uwb_env.sensing import ParametricSensor


def _points(sensor: ParametricSensor, n: int, seed: int) -> np.ndarray:
    """Random points over the area and a margin around it, plus the nodes themselves and points next to them."""
    rng = np.random.default_rng(seed)
    a, lay = sensor.layout.area, sensor.layout
    pos = np.column_stack([rng.uniform(a[0] - 5, a[1] + 5, n), rng.uniform(a[2] - 5, a[3] + 5, n)])
    nodes = np.vstack([lay.tx_pos, lay.rx_pos])
    return np.vstack([pos, nodes, nodes + 0.05, nodes + rng.normal(scale=0.5, size=nodes.shape)])


@pytest.mark.parametrize("scenario", scenarios.names())
@pytest.mark.parametrize("swerling", [0, 1, 3])
def test_mean_link_equals_the_numpy_reference(scenario, swerling):
    """Coverage identical (walls, blind zone, field of view, range limits), SNR and Pd to rounding, every pair."""
    sensor = ParametricSensor(scenarios.get(scenario))
    pos = _points(sensor, 1500, seed=3)
    waveforms = np.arange(len(sensor.library))
    covered = 0
    for t in range(sensor.n_tx):
        for r in range(sensor.n_rx):
            az, ok, snr, pd = sensor._mean_link(t, r, pos, waveforms, 1.7, swerling)
            az0, ok0, snr0, pd0 = sensor._mean_link_reference(t, r, pos, waveforms, 1.7, swerling)
            np.testing.assert_array_equal(ok, ok0)
            np.testing.assert_allclose(az, az0, rtol=1e-14, atol=1e-15)
            np.testing.assert_allclose(snr, snr0, rtol=1e-13, atol=0)
            np.testing.assert_allclose(pd, pd0, rtol=1e-13, atol=1e-300)
            covered += int(ok.sum())
    assert covered > 0.05 * pos.shape[0]  # the comparison saw covered points, not only zeros


def test_the_clutter_residue_is_averaged_in_the_compiled_pd():
    """indoor-rsn has a clutter residue: Pd is E_X[Pd(SCNR)], below the residue-free Pd at high SNR."""
    sensor = ParametricSensor(scenarios.get("indoor-rsn"))
    assert sensor._residue
    pos = _points(sensor, 400, seed=5)
    t, r = (int(v) for v in sensor.pairs[0])
    _, ok, snr, pd = sensor._mean_link(t, r, pos, np.array([0]), 1.0, 1)
    free = np.exp(np.log(sensor.cfg.sensing.false_alarm_probability) / (1.0 + snr))  # Swerling I, no residue
    assert ok.any()
    assert np.all(pd[:, ok] <= free[:, ok] + 1e-15)
    assert np.any(pd[:, ok] < free[:, ok] - 1e-3)


@pytest.mark.parametrize("scenario", scenarios.names())
def test_expected_covariance_equals_the_numpy_reference(scenario):
    """The lookahead's R (W, N, m, m): CRLB / SNR, the array's azimuth CRLB appended, unit SNR where uncovered."""
    sensor = ParametricSensor(scenarios.get(scenario))
    pos = _points(sensor, 500, seed=7)
    waveforms = np.arange(len(sensor.library))[::-1].copy()  # not in library order
    for t, r in sensor.pairs.tolist():
        pd, R = sensor.expected_measurements(t, r, pos, waveforms, 2.3, 1)
        az, ok, snr, pd0 = sensor._mean_link(t, r, pos, waveforms, 2.3, 1)
        R0 = sensor._expected_covariance_reference(r, az, ok, snr, waveforms)
        m = len(sensor.measurement_names(r))
        assert R.shape == (waveforms.size, pos.shape[0], m, m)
        np.testing.assert_array_equal(pd, pd0)
        np.testing.assert_allclose(R, R0, rtol=1e-13, atol=0)


def test_compiled_walk_scaling_equals_the_numpy_walk_factors():
    """``sensing.compiled.walk_gain`` / ``walk_scale`` against ``ParametricSensor.migration_gain`` / ``walk_factors``
    on the wideband urban library, range-rates from 0 to 40 m/s (beyond the 160 MHz peaks' flat regime)."""
    from uwb_env.sensing.compiled import walk_gain, walk_scale

    s = ParametricSensor(scenarios.get("urban-intersection-wideband"))
    w = np.arange(len(s.library))
    rdot = np.array([0.0, -3.3, 7.5, 12.0, -19.5, 40.0])
    gain = s.migration_gain(w[:, None], rdot[None])
    np.testing.assert_allclose(walk_gain(w, rdot, s._migration[0], s._WALK_STEP_MPS), gain, rtol=1e-12)
    rng = np.random.default_rng(0)
    A = rng.standard_normal((len(w), rdot.size, 2, 2))
    R = A @ np.swapaxes(A, -1, -2) + 0.1 * np.eye(2)
    f = s.walk_factors(w[:, None], rdot[None], np.stack([R[..., 0, 0], R[..., 1, 1]], axis=-1))
    d = np.sqrt(f)
    expected = R * d[..., :, None] * d[..., None, :]
    gain_t, c_range, c_rate, half_dwell, period = s._migration
    got = walk_scale(R.copy(), w, rdot, gain_t, c_range, c_rate, half_dwell, period, s._WALK_STEP_MPS)
    np.testing.assert_allclose(got, expected, rtol=1e-12)
    np.testing.assert_allclose(s._walk_scaled(R, w, rdot), expected, rtol=1e-12)  # the sensor's call of it
    assert (f[6:, 4] > 1.0).all()  # the 160 MHz chirps at 19.5 m/s measure worse than their bound
