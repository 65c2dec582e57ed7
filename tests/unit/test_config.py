"""Configuration: validation errors name field, value and what is allowed; YAML round trip; overrides."""

from __future__ import annotations

import dataclasses
import math

import pytest

from tests.conftest import tiny_config
from uwb_env import scenarios
from uwb_env.config import (
    Box,
    ChirpWaveformConfig,
    ClutterConfig,
    ImpulseWaveformConfig,
    MaterialConfig,
    MotionSegmentConfig,
    ReceiverConfig,
    SensingConfig,
    TargetConfig,
    TrackerConfig,
    TransmitterConfig,
    UniformLinearArrayConfig,
    WallConfig,
    apply_overrides,
    from_dict,
    load_yaml,
    save_yaml,
    to_dict,
)


@pytest.mark.parametrize("name", scenarios.names())
def test_yaml_round_trip_compares_equal(name, tmp_path):
    cfg = scenarios.get(name)
    path = tmp_path / f"{name}.yaml"
    save_yaml(cfg, path)
    assert load_yaml(path) == cfg
    assert from_dict(type(cfg), to_dict(cfg)) == cfg


def test_opaque_material_round_trips_infinity(tmp_path):
    cfg = scenarios.get("urban-intersection")
    assert math.isinf(cfg.walls[0].material.loss_db)
    save_yaml(cfg, tmp_path / "u.yaml")
    assert math.isinf(load_yaml(tmp_path / "u.yaml").walls[0].material.loss_db)


def test_registry_names_and_unknown_name_suggests():
    assert {"urban-intersection", "indoor-rsn", "indoor-monostatic"} <= set(scenarios.names())
    with pytest.raises(KeyError, match="did you mean 'urban-intersection'"):
        scenarios.get("urban-intersectoin")


def test_dotted_and_nested_overrides_are_applied_and_revalidated():
    cfg = scenarios.get(
        "urban-intersection", **{"sensing.false_alarm_probability": 1e-5, "receivers.1.noise_figure_db": 7.0}
    )
    assert cfg.sensing.false_alarm_probability == 1e-5
    assert cfg.receivers[1].noise_figure_db == 7.0
    assert cfg.receivers[0].noise_figure_db == 5.0
    cfg2 = scenarios.get("urban-intersection", sensing={"max_range_m": 250.0, "clutter": {"density_per_m2": 0.0}})
    assert cfg2.sensing.max_range_m == 250.0 and cfg2.sensing.clutter.density_per_m2 == 0.0
    assert cfg2.sensing.false_alarm_probability == 7e-4  # untouched fields keep their (the scenario's) value
    with pytest.raises(ValueError, match=r"SensingConfig.max_range_m = -1.0: must be > 0"):
        scenarios.get("urban-intersection", **{"sensing.max_range_m": -1.0})


def test_unknown_override_key_raises_with_hint():
    with pytest.raises(KeyError, match="did you mean 'false_alarm_probability'"):
        scenarios.get("urban-intersection", **{"sensing.false_alarm_probabilty": 1e-3})
    with pytest.raises(KeyError, match="out of range"):
        apply_overrides(scenarios.get("urban-intersection"), {"receivers.5.noise_figure_db": 3.0})


def test_unknown_yaml_field_raises():
    data = to_dict(scenarios.get("indoor-rsn"))
    data["sensing"]["scan_periode_s"] = 0.1
    with pytest.raises(KeyError, match="did you mean 'scan_period_s'"):
        from_dict(type(scenarios.get("indoor-rsn")), data)


def test_configs_are_frozen_and_hashable():
    cfg = scenarios.get("indoor-rsn")
    with pytest.raises(dataclasses.FrozenInstanceError):
        cfg.n_scans = 3  # type: ignore[misc]
    assert hash(cfg) == hash(scenarios.get("indoor-rsn"))


# --------------------------------------------------------------------------------------- invalid configurations
CHIRP = {"name": "c", "pulse_duration_s": 1e-6, "bandwidth_hz": 40e6, "carrier_hz": 4e9}


@pytest.mark.parametrize(
    ("build", "match"),
    [
        (
            lambda: ChirpWaveformConfig(**{**CHIRP, "bandwidth_hz": -40e6}),
            r"ChirpWaveformConfig.bandwidth_hz = -40000000.0: must be > 0",
        ),
        (
            lambda: ChirpWaveformConfig(**{**CHIRP, "sweep": "upward"}),
            r"ChirpWaveformConfig.sweep = 'upward': must be one of \('up', 'down'\)",
        ),
        (lambda: ChirpWaveformConfig(**{**CHIRP, "bandwidth_hz": 5e9}), r"bandwidth_hz = 5000000000.0: must be <"),
        (lambda: ChirpWaveformConfig(**{**CHIRP, "pri_s": 2e-6}), r"ChirpWaveformConfig.pri_s = 2e-06: must be >"),
        (lambda: ImpulseWaveformConfig("i", 4.3e9, 9e9), r"ImpulseWaveformConfig.bandwidth_hz = 9000000000.0"),
        (lambda: ImpulseWaveformConfig("i", 4.3e9, 2e9, n_pulses=0), r"n_pulses = 0: must be an integer >= 1"),
        (lambda: ReceiverConfig("rx", (0.0, math.nan)), r"ReceiverConfig.position_m = \(0.0, nan\)"),
        (lambda: ReceiverConfig("rx", (0.0, 0.0), noise_figure_db=-3.0), r"noise_figure_db = -3.0: must be in"),
        (lambda: TransmitterConfig("", (0.0, 0.0), 10.0), r"TransmitterConfig.name = '': must be a non-empty string"),
        (lambda: UniformLinearArrayConfig(n_elements=1), r"n_elements = 1: must be an integer >= 2"),
        (lambda: MaterialConfig("m", loss_db=-1.0), r"MaterialConfig.loss_db = -1.0: must be >= 0"),
        (lambda: WallConfig((1.0, 1.0), (1.0, 1.0), MaterialConfig("m", 3.0)), r"WallConfig.end_m = \(1.0, 1.0\)"),
        (lambda: MotionSegmentConfig("ct", 1.0), r"turn_rate_rps = 0.0: must be non-zero"),
        (lambda: MotionSegmentConfig("turn", 1.0), r"kind = 'turn': must be one of"),
        (lambda: TargetConfig("t", None, swerling=2), r"TargetConfig.trajectory = None"),  # type: ignore[arg-type]
        (lambda: SensingConfig(false_alarm_probability=0.5), r"false_alarm_probability = 0.5: must be in \(0.0, 0.1\]"),
        (lambda: SensingConfig(fidelity="exact"), r"fidelity = 'exact': must be one of"),
        (lambda: ClutterConfig(density_per_m2=-1e-4), r"density_per_m2 = -0.0001"),
        (lambda: TrackerConfig(initial_existence=0.995), r"initial_existence = 0.995: must be strictly between"),
        (lambda: Box(0.0, -1.0, 0.0, 1.0), r"Box.x_max_m = -1.0: must be > x_min_m = 0.0"),
    ],
)
def test_invalid_component_config_raises_named_error(build, match):
    with pytest.raises(ValueError, match=match):
        build()


def test_receiver_outside_world_is_rejected():
    cfg = tiny_config()
    with pytest.raises(ValueError, match=r"receivers\[1\] \('rx2'\).position_m = \(0.0, 500.0\): must be inside"):
        apply_overrides(cfg, {"receivers.1.position_m": (0.0, 500.0)})


def test_empty_waveform_library_is_rejected():
    with pytest.raises(ValueError, match=r"ScenarioConfig.waveforms = \(\): must be a non-empty tuple"):
        dataclasses.replace(tiny_config(), waveforms=())


def test_mixed_waveform_kinds_and_duplicate_names_are_rejected():
    cfg = tiny_config()
    imp = ImpulseWaveformConfig("imp", 4.3e9, 2e9)
    with pytest.raises(ValueError, match="all of one kind"):
        dataclasses.replace(cfg, waveforms=(cfg.waveforms[0], imp))
    with pytest.raises(ValueError, match=r"uniquely named \(duplicates: \['short-up'\]\)"):
        dataclasses.replace(cfg, waveforms=(cfg.waveforms[0], cfg.waveforms[0]))


def test_birth_after_episode_end_and_bad_pairs_are_rejected():
    cfg = tiny_config(n_scans=10)
    with pytest.raises(ValueError, match=r"targets\[0\] \('t'\).birth_time_s = 5.0: must be < episode duration"):
        apply_overrides(cfg, {"targets.0.birth_time_s": 5.0})
    with pytest.raises(ValueError, match=r"pairs\[0\] = \(0, 2\)"):
        dataclasses.replace(cfg, pairs=((0, 2),))


def test_surveillance_area_outside_world_is_rejected():
    with pytest.raises(ValueError, match="surveillance_area"):
        apply_overrides(tiny_config(), {"surveillance_area": {"x_max_m": 300.0}})
