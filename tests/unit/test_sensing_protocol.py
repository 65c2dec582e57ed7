"""The sensing seam (sensing.protocol): registry, make_sensor, the Sensor protocol, the lookahead at every fidelity."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import uwb_env
from uwb_env import scenarios
from uwb_env.sensing import ParametricSensor, Sensor, make_sensor, protocol, register_sensor, registered_sensors
from uwb_env.sensing.signal import ChirpSignalSensor, SignalSensor

gym.register_envs(uwb_env)


def test_registry_holds_one_sensor_per_fidelity_and_waveform_family():
    assert registered_sensors() == {
        ("parametric", "chirp"): ParametricSensor,
        ("parametric", "impulse"): ParametricSensor,
        ("signal", "impulse"): SignalSensor,
        ("signal", "chirp"): ChirpSignalSensor,
    }


@pytest.mark.parametrize(
    ("scenario", "fidelity", "cls"),
    [
        ("urban-intersection", "parametric", ParametricSensor),
        ("urban-intersection", "signal", ChirpSignalSensor),
        ("indoor-rsn", "parametric", ParametricSensor),
        ("indoor-rsn", "signal", SignalSensor),
    ],
)
def test_make_sensor_picks_by_fidelity_and_family_and_meets_the_protocol(scenario, fidelity, cls):
    sensor = make_sensor(scenarios.get(scenario, **{"sensing.fidelity": fidelity}))
    assert type(sensor) is cls
    assert isinstance(sensor, Sensor)  # every member of the protocol is there
    assert sensor.pairs.shape == (len(sensor.cfg.radar_pairs), 2)
    assert sensor.n_tx == sensor.layout.n_tx and sensor.n_rx == sensor.layout.n_rx


def test_duplicate_registration_and_unsupported_combinations_raise(monkeypatch):
    with pytest.raises(KeyError, match="already registered"):
        register_sensor("signal", "chirp")(ChirpSignalSensor)
    monkeypatch.setattr(protocol, "_SENSORS", {k: v for k, v in registered_sensors().items() if k[0] != "signal"})
    with pytest.raises(ValueError, match=r"sensing.fidelity = 'signal' with chirp waveforms .*registered"):
        make_sensor(scenarios.get("urban-intersection", **{"sensing.fidelity": "signal"}))


@pytest.mark.parametrize(
    ("env_id", "kwargs"),
    [
        ("uwb_env/UrbanWaveform-v3", {}),
        ("uwb_env/IndoorSensorSubset-v1", {}),
    ],
)
def test_signal_fidelity_runs_the_pda_lookahead_on_the_parametric_sensor_model(env_id, kwargs):
    """fidelity='signal' with lookahead_q2='pda': the clutter map comes from the signal sensor's parametric model."""
    env = gym.make(env_id, fidelity="signal", include_lookahead=True, lookahead_q2="pda", **kwargs).unwrapped
    obs, _ = env.reset(seed=3)
    assert env.observation_space.contains(obs)
    for _ in range(6):
        obs, reward, *_ = env.step(int(np.argmin(env.lookahead_costs())))
        costs = env.lookahead_costs()
        assert np.all(np.isfinite(costs)) and np.isfinite(reward)
    sensor = env.sim.sensor
    model = sensor.model
    z = np.array([[60.0, 1.0]]) if sensor.measurement_names(0) == ("bistatic_range", "range_rate") else None
    if z is not None:  # the chirp sensor's clutter map is its parametric model's
        t, r = (int(v) for v in sensor.pairs[0])
        R = np.stack([w.covariance(np.array([100.0])) for w in sensor.library.waveforms])
        np.testing.assert_array_equal(sensor.clutter_intensity_at(t, r, z, R), model.clutter_intensity_at(t, r, z, R))
