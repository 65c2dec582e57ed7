"""Bad input to the environment: env keywords, scenario values, YAML files and actions (issue 16).

Every case must raise, never be accepted silently, with a message that names the field (or file), the offending
value and what is allowed. Each case lists those three as substrings of the message. Before issue 16, among others:
``include_lookahead="no"`` was taken as true, ``n_slots="8"`` failed with a bare ``TypeError`` from ``<``, ``1`` passed
for a bool config field and ``True`` for a Swerling case, ``8.0`` became ``8``, stepping before ``reset`` raised
``AttributeError ... 'episode'`` and an empty YAML file ``TypeError: 'NoneType' object is not iterable``.
"""

from __future__ import annotations

import math
import re

import gymnasium as gym
import numpy as np
import pytest

import uwb_env
from uwb_env import scenarios
from uwb_env.config import apply_overrides, load_yaml, save_yaml
from uwb_env.envs import ENV_IDS, UWBSchedulingEnv

gym.register_envs(uwb_env)

SUBSET = "uwb_env/IndoorSensorSubset-v1"  # 6 receivers, 3 waveforms, Discrete(20)


def _make(**kwargs):
    return gym.make(SUBSET, **kwargs)


def _assert_names(exc: BaseException, *parts: str) -> None:
    msg = str(exc)
    for part in parts:
        assert part in msg, f"{part!r} not in {msg!r}"


# ------------------------------------------------------------------------------------------------- env keywords
# (keywords, exception, field, value as written in the message, what is allowed)
ENV_KEYWORDS = [
    ({"include_lookahead": "no"}, TypeError, "include_lookahead", "'no'", "must be True or False"),
    ({"include_lookahead": 1}, TypeError, "include_lookahead", "=1", "must be True or False"),
    ({"include_lookahead": None}, TypeError, "include_lookahead", "None", "must be True or False"),
    ({"receiver_warmup": "yes"}, TypeError, "receiver_warmup", "'yes'", "must be True or False"),
    ({"receiver_warmup": 0}, TypeError, "receiver_warmup", "=0", "must be True or False"),
    ({"n_slots": "8"}, TypeError, "n_slots", "'8'", "an integer in [1, 1024]"),
    ({"n_slots": 8.0}, TypeError, "n_slots", "8.0", "an integer in [1, 1024]"),
    ({"n_slots": 0}, ValueError, "n_slots", "=0", "an integer in [1, 1024]"),
    ({"n_slots": -3}, ValueError, "n_slots", "-3", "an integer in [1, 1024]"),
    ({"n_slots": True}, TypeError, "n_slots", "True", "an integer in [1, 1024]"),
    ({"n_slots": 10**6}, ValueError, "n_slots", "1000000", "an integer in [1, 1024]"),
    ({"subset_size": "3"}, TypeError, "subset_size", "'3'", "an integer >= 1"),
    ({"subset_size": 0}, ValueError, "subset_size", "=0", "an integer >= 1"),
    ({"subset_size": 7}, ValueError, "subset_size", "7", "must be in [1, 6]"),
    ({"subset_size": 2.0}, TypeError, "subset_size", "2.0", "an integer >= 1"),
    ({"fixed_waveform": -1}, ValueError, "fixed_waveform", "-1", "an integer >= 0"),
    ({"fixed_waveform": 3}, ValueError, "fixed_waveform", "3", "must be in [0, 2]"),
    ({"fixed_waveform": "0"}, TypeError, "fixed_waveform", "'0'", "an integer >= 0"),
    ({"action_kind": "subsets"}, ValueError, "action_kind", "'subsets'", "one of ('waveform', 'subset', 'joint')"),
    ({"action_kind": None}, TypeError, "action_kind", "None", "one of ('waveform', 'subset', 'joint')"),
    ({"action_kind": 1}, TypeError, "action_kind", "=1", "one of ('waveform', 'subset', 'joint')"),
    ({"fidelity": "exact"}, ValueError, "fidelity", "'exact'", "one of ('parametric', 'signal')"),
    ({"fidelity": 1}, TypeError, "fidelity", "=1", "one of ('parametric', 'signal')"),
    ({"observation": "flat"}, ValueError, "observation", "'flat'", "one of ('box', 'dict')"),
    ({"observation": None}, TypeError, "observation", "None", "one of ('box', 'dict')"),
    ({"render_mode": "rgb"}, ValueError, "render_mode", "'rgb'", "one of ('rgb_array', 'human')"),
    ({"render_mode": 1}, TypeError, "render_mode", "=1", "one of ('rgb_array', 'human')"),
    ({"missed_target_penalty_m2": -1.0}, ValueError, "missed_target_penalty_m2", "-1.0", "finite number >= 0"),
    ({"missed_target_penalty_m2": math.nan}, ValueError, "missed_target_penalty_m2", "nan", "finite number >= 0"),
    ({"missed_target_penalty_m2": "100"}, TypeError, "missed_target_penalty_m2", "'100'", "finite number >= 0"),
    ({"missed_target_penalty_m2": True}, TypeError, "missed_target_penalty_m2", "True", "finite number >= 0"),
    ({"cover_gate_m": 0.0}, ValueError, "cover_gate_m", "0.0", "a finite number > 0"),
    ({"cover_gate_m": math.inf}, ValueError, "cover_gate_m", "inf", "a finite number > 0"),
    ({"cover_gate_m": "5"}, TypeError, "cover_gate_m", "'5'", "a finite number > 0"),
    ({"energy_cost_per_j": -0.1}, ValueError, "energy_cost_per_j", "-0.1", "finite number >= 0"),
    ({"energy_cost_per_j": None}, TypeError, "energy_cost_per_j", "None", "finite number >= 0"),
    ({"lookahead_q2": 0.0}, ValueError, "q2", "0.0", "a number in (0, 1] or 'pda'"),
    ({"lookahead_q2": 1.5}, ValueError, "q2", "1.5", "a number in (0, 1] or 'pda'"),
    ({"lookahead_q2": "pdaa"}, ValueError, "q2", "'pdaa'", "a number in (0, 1] or 'pda'"),
    ({"lookahead_q2": True}, TypeError, "q2", "True", "a number in (0, 1] or 'pda'"),
    ({"lookahead_q2": None}, TypeError, "q2", "None", "a number in (0, 1] or 'pda'"),
    ({"scenario": "indoor-rsm"}, KeyError, "scenario", "'indoor-rsm'", "did you mean 'indoor-rsn'"),
    ({"scenario": 3}, TypeError, "scenario", "=3", "a scenario name"),
    ({"out_of_service_rx": (6,)}, ValueError, "out_of_service_rx", "(6,)", "indices in [0, 5]"),
    ({"out_of_service_rx": ("rx9",)}, ValueError, "out_of_service_rx", "'rx9'", "indices in [0, 5] or names"),
    ({"out_of_service_rx": "rx1"}, TypeError, "out_of_service_rx", "'rx1'", "a tuple of receiver indices"),
    ({"out_of_service_rx": (0, 0)}, ValueError, "out_of_service_rx", "(0, 0)", "each listed once"),
    ({"out_of_service_rx": (True,)}, ValueError, "out_of_service_rx", "True", "indices in [0, 5]"),
    ({"out_of_service_rx": (0, 1, 2, 3, 4, 5)}, ValueError, "out_of_service_rx", "(0, 1, 2, 3, 4, 5)", "valid plan"),
    ({"out_of_service_rx": (0, 1, 2, 3)}, ValueError, "out_of_service_rx", "(0, 1, 2, 3)", "valid plan"),
    ({"unavailable_waveforms": (0,)}, ValueError, "unavailable_waveforms", "(0,)", "valid plan"),  # subset: fixed 0
    ({"unavailable_waveforms": (5,)}, ValueError, "unavailable_waveforms", "(5,)", "indices in [0, 2]"),
    ({"sensing.scan_perod_s": 0.1}, KeyError, "scan_perod_s", "scan_perod_s", "did you mean 'scan_period_s'"),
    ({"n_slot": 8}, KeyError, "n_slot", "unknown field", "allowed:"),
    ({"n_scans.x": 1}, ValueError, "n_scans", "{'x': 1}", "must be an integer >= 1"),
]


@pytest.mark.parametrize(("kwargs", "exc", "field", "value", "allowed"), ENV_KEYWORDS, ids=lambda v: repr(v)[:40])
def test_bad_env_keyword_is_refused_with_field_value_and_allowed(kwargs, exc, field, value, allowed):
    # gym.make warns about an unknown render mode before the env refuses it: build that one directly
    make = (lambda **kw: UWBSchedulingEnv(**{**ENV_IDS[SUBSET], **kw})) if "render_mode" in kwargs else _make
    with pytest.raises(exc, match=re.escape(field)) as info:
        make(**kwargs)
    _assert_names(info.value, field, value, allowed)


def test_joint_env_keywords_that_leave_no_plan_are_refused():
    with pytest.raises(ValueError, match="unavailable_waveforms") as info:
        gym.make("uwb_env/IndoorJoint-v1", unavailable_waveforms=(0, 1, 2))
    _assert_names(info.value, "(0, 1, 2)", "at least one valid plan")
    with pytest.raises(ValueError, match="out_of_service_rx") as info:
        gym.make("uwb_env/UrbanWaveform-v3", out_of_service_rx=("rx1", "rx2"))
    _assert_names(info.value, "('rx1', 'rx2')", "at least one receiver in service")


# -------------------------------------------------------------------------------------- scenario values (overrides)
# (override, field as named in the message, value as written, what is allowed); all raise ValueError or KeyError
CONFIG_VALUES = [
    ({"n_scans": "61"}, "n_scans", "'61'", "an integer >= 1"),
    ({"n_scans": 61.0}, "n_scans", "61.0", "an integer >= 1"),
    ({"n_scans": 0}, "n_scans", "= 0", "an integer >= 1"),
    ({"n_scans": True}, "n_scans", "True", "an integer >= 1"),
    ({"transmitters.0.power_dbm": 101.0}, "transmitters.0: TransmitterConfig.power_dbm", "101.0", "[-100.0, 100.0]"),
    ({"transmitters.0.power_dbm": "10"}, "power_dbm", "'10'", "a finite number"),
    ({"transmitters.0.power_dbm": math.nan}, "power_dbm", "nan", "a finite number"),
    ({"transmitters.0.power_dbm": True}, "power_dbm", "True", "a finite number"),
    ({"transmitters.0.antenna_gain_db": 61.0}, "antenna_gain_db", "61.0", "[-30.0, 60.0]"),
    ({"receivers.0.noise_figure_db": -1.0}, "receivers.0: ReceiverConfig.noise_figure_db", "-1.0", "[0.0, 40.0]"),
    ({"receivers.0.antenna_gain_db": 61}, "antenna_gain_db", "61", "[-30.0, 60.0]"),
    ({"receivers.0.position_m": (1.0,)}, "receivers.0.position_m", "(1.0,)", "expected 2 items"),
    ({"receivers.0.position_m": "ab"}, "receivers.0.position_m", "'ab'", "expected a sequence"),
    ({"receivers.0.position_m": (1e6, 0.0)}, "position_m", "(1000000.0, 0.0)", "inside the world"),
    ({"receivers.0.name": ""}, "ReceiverConfig.name", "''", "a non-empty string"),
    ({"receivers.1.name": "rx1"}, "receivers", "'rx1'", "uniquely named"),
    ({"sensing.scan_period_s": 0.0}, "sensing: SensingConfig.scan_period_s", "0.0", "> 0"),
    ({"sensing.scan_period_s": "0.25"}, "scan_period_s", "'0.25'", "a finite number"),
    ({"sensing.false_alarm_probability": 0.5}, "false_alarm_probability", "0.5", "in (0.0, 0.1]"),
    ({"sensing.fidelity": "sig"}, "fidelity", "'sig'", "one of ('parametric', 'signal') (did you mean 'signal'?)"),
    ({"sensing.measure_doa": "no"}, "measure_doa", "'no'", "True or False"),
    ({"sensing.measure_doa": 1}, "measure_doa", "= 1", "True or False"),
    ({"sensing.min_range_std_m": 0.0}, "min_range_std_m", "0.0", "in [1e-05, 1.0]"),
    ({"sensing.min_range_std_m": 1e-6}, "min_range_std_m", "1e-06", "in [1e-05, 1.0]"),
    ({"sensing.min_range_std_m": 2.0}, "min_range_std_m", "2.0", "in [1e-05, 1.0]"),
    ({"sensing.min_range_std_m": "1mm"}, "min_range_std_m", "'1mm'", "a finite number"),
    ({"sensing.clutter.density_per_m2": -1.0}, "sensing.clutter: ClutterConfig.density_per_m2", "-1.0", "[0.0, 1.0]"),
    ({"sensing.clutter.discrete_fraction": 1.5}, "discrete_fraction", "1.5", "[0.0, 1.0]"),
    ({"sensing.detection_gain_db": 11.0}, "detection_gain_db", "11.0", "[-10.0, 10.0]"),
    ({"sensing.noise_window_cells": -1.0}, "noise_window_cells", "-1.0", "[0.0, 10000.0]"),
    ({"sensing.ghost_rate": -0.1}, "ghost_rate", "-0.1", "[0.0, 100.0]"),
    ({"sensing.array_beams": "steer"}, "array_beams", "'steer'", "one of ('dft', 'boresight', 'steered')"),
    ({"sensing.signal.align_scans": 1}, "align_scans", "= 1", "one of (True, False)"),
    ({"sensing.signal.align_scans": "true"}, "align_scans", "'true'", "one of (True, False)"),
    ({"sensing.signal.n_samples": 100.0}, "n_samples", "100.0", "an integer >= 64"),
    ({"sensing.signal.nu": 2}, "nu", "= 2", "an integer >= 3"),
    ({"sensing.signal.cfar": "cfar"}, "cfar", "'cfar'", "one of ('dtb', 'ca', 'g', 'os')"),
    ({"sensing.signal.chirp.max_bounces": 4}, "max_bounces", "4", "an integer in [0, 3]"),
    ({"sensing.signal.chirp.max_bounces": 2.0}, "max_bounces", "2.0", "an integer in [0, 3]"),
    ({"tracker.fixed_existence": "false"}, "fixed_existence", "'false'", "True or False"),
    ({"tracker.fixed_existence": 0}, "fixed_existence", "= 0", "True or False"),
    ({"tracker.filter": "kf"}, "filter", "'kf'", "one of ('ukf', 'ekf')"),
    ({"tracker.gate_probability": 0.0}, "gate_probability", "0.0", "in (0.0, 1.0]"),
    ({"tracker.tentative_max_age": 2.5}, "tentative_max_age", "2.5", "an integer >= 1"),
    ({"tracker.tentative_max_age": "5"}, "tentative_max_age", "'5'", "an integer >= 1"),
    ({"tracker.assumed_swerling": True}, "assumed_swerling", "True", "one of (0, 1, 3)"),
    ({"tracker.assumed_swerling": 2}, "assumed_swerling", "= 2", "one of (0, 1, 3)"),
    ({"tracker.initial_existence": 0.995}, "initial_existence", "0.995", "strictly between"),
    ({"tracker.transition": ((1.0,),)}, "transition", "((1.0,),)", "tuple of tuples (one row per model)"),
    ({"tracker.default_models": ("cv",)}, "default_models", "('cv',)", "subset of the model names"),
    ({"tracker.max_speed_mps": -5.0}, "max_speed_mps", "-5.0", "> 0"),
    ({"tracker.initial_accel_std_mps2": 1e6}, "initial_accel_std_mps2", "1000000.0", "in (0.0, 1000.0]"),
    ({"tracker.models.0.accel_noise_std_mps2": 1e6}, "accel_noise_std_mps2", "1000000.0", "in (0.0, 1000.0]"),
    ({"sensing.clutter_residue_looks": 172.0}, "clutter_residue_looks", "172.0", "in [0.0, 100.0]"),
    ({"targets.0.swerling": 1.0}, "targets.0: TargetConfig.swerling", "1.0", "one of (0, 1, 3)"),
    ({"targets.0.rcs_mean_m2": 0.0}, "rcs_mean_m2", "0.0", "> 0"),
    ({"targets.0.birth_time_s": 1e4}, "birth_time_s", "10000.0", "< episode duration"),
    ({"waveforms.0.n_pulses": 1024.0}, "waveforms.0: ImpulseWaveformConfig.n_pulses", "1024.0", "an integer >= 1"),
    ({"waveforms.0.bandwidth_hz": -1.0}, "bandwidth_hz", "-1.0", "> 0"),
    ({"waveforms.0.toa_error_model": "ed"}, "toa_error_model", "'ed'", "one of ('crlb', 'energy_detector')"),
    ({"waveforms.0.prf_hz": 0.5}, "prf_hz", "0.5", "in [1.0, 1000000000.0]"),
    ({"channel.path_loss_exponent": 7.0}, "channel: ChannelConfig.path_loss_exponent", "7.0", "in [1.0, 6.0]"),
    ({"pairs": ((0, 9),)}, "pairs[0]", "(0, 9)", "0 <= rx < 6"),
    ({"pairs": ((0.0, 1),)}, "pairs[0]", "(0.0, 1)", "(tx, rx) with 0 <= tx < 1"),
    ({"pairs": ((0, 1), (0, 1))}, "pairs[1]", "(0, 1)", "listed once"),
    ({"description": 5}, "description", "= 5", "a string"),
    ({"transmitters.5.power_dbm": 1.0}, "transmitters.5", "'5'", "out of range for a tuple of 1 items"),
    ({"world.x_max_m": -100.0}, "x_max_m", "-100.0", "> x_min_m"),
    ({"surveillance_area.x_max_m": 1e5}, "surveillance_area", "Box(", "inside world"),
    ({"transmitters.0": 5}, "transmitters.0", "= 5", "expected a mapping for TransmitterConfig"),
]


@pytest.mark.parametrize(("override", "field", "value", "allowed"), CONFIG_VALUES, ids=lambda v: repr(v)[:40])
def test_bad_scenario_value_is_refused_with_field_value_and_allowed(override, field, value, allowed):
    with pytest.raises((ValueError, KeyError), match=re.escape(field)) as info:
        gym.make(SUBSET, **override)
    _assert_names(info.value, field, value, allowed)


def test_bad_value_straight_into_apply_overrides_is_refused_the_same_way():
    cfg = scenarios.get("indoor-rsn")
    with pytest.raises(ValueError, match=re.escape("tracker: TrackerConfig.fixed_existence = 'no'")) as info:
        apply_overrides(cfg, {"tracker.fixed_existence": "no"})
    _assert_names(info.value, "True or False")
    with pytest.raises(KeyError, match="override key 3") as info:
        apply_overrides(cfg, {3: 1.0})
    _assert_names(info.value, "a dotted field path")


# ---------------------------------------------------------------------------------------------------- YAML files
YAML_FILES = [
    ("", ValueError, "the file is empty"),
    ("# only a comment\n", ValueError, "the file is empty"),
    ("- 1\n- 2\n", ValueError, "holds a list; it must hold a mapping of ScenarioConfig fields"),
    ("name: [unclosed\n", ValueError, "not valid YAML"),
    ("42\n", ValueError, "holds a int; it must hold a mapping of ScenarioConfig fields"),
]


@pytest.mark.parametrize(("text", "exc", "allowed"), YAML_FILES, ids=["empty", "comment", "list", "syntax", "int"])
def test_damaged_scenario_yaml_names_the_file(tmp_path, text, exc, allowed):
    path = tmp_path / "scenario.yaml"
    path.write_text(text)
    with pytest.raises(exc, match=re.escape(str(path))) as info:
        load_yaml(path)
    _assert_names(info.value, str(path), allowed)


def test_binary_scenario_file_names_the_file(tmp_path):
    path = tmp_path / "scenario.yaml"
    path.write_bytes(b"\xff\xfe\x00garbage\x80")
    with pytest.raises(ValueError, match=re.escape(str(path))) as info:
        load_yaml(path)
    _assert_names(info.value, "not a text file")


@pytest.mark.parametrize(
    ("edit", "exc", "parts"),
    [
        (lambda t: t.replace("n_scans: 61", "n_scanz: 61"), KeyError, ["unknown field 'n_scanz'", "did you mean"]),
        (lambda t: t.replace("n_scans: 61\n", ""), KeyError, ["missing field 'n_scans'", "requires"]),
        (lambda t: t.replace("n_scans: 61", "n_scans: sixty"), ValueError, ["n_scans", "'sixty'", "an integer"]),
        (lambda t: t.replace("n_scans: 61", "n_scans: 61.0"), ValueError, ["n_scans", "61.0", "an integer"]),
        (
            lambda t: t.replace("measure_doa: false", "measure_doa: 0"),
            ValueError,
            ["measure_doa", "0", "True or False"],
        ),
    ],
    ids=["unknown-field", "missing-field", "string-for-int", "float-for-int", "int-for-bool"],
)
def test_bad_scenario_yaml_field_names_the_file_field_value(tmp_path, edit, exc, parts):
    path = tmp_path / "scenario.yaml"
    save_yaml(scenarios.get("indoor-rsn"), path)
    text = path.read_text()
    changed = edit(text)
    assert changed != text
    path.write_text(changed)
    with pytest.raises(exc, match=re.escape(str(path))) as info:
        load_yaml(path)
    _assert_names(info.value, *parts)


# --------------------------------------------------------------------------------------------------------- actions
BAD_ACTIONS = [1.0, "1", -1, 20, np.array([1]), True, None, 1.5, np.float32(2.0), [0], np.int64(20)]


@pytest.mark.parametrize("action", BAD_ACTIONS, ids=repr)
def test_bad_action_is_refused_with_value_and_range(action):
    env = gym.make(SUBSET)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=re.escape("action=")) as info:
        env.step(action)
    _assert_names(info.value, repr(action), "must be an integer in [0, 19]")


@pytest.mark.parametrize(
    ("kwargs", "exc", "parts"),
    [
        ({"options": {"out_of_service_rx": (1,)}}, ValueError, ["options=", "out_of_service_rx", "must be None or {}"]),
        ({"options": {"n_scans": 5}}, ValueError, ["options=", "'n_scans': 5", "must be None or {}"]),
        ({"seed": "1"}, TypeError, ["seed='1'", "must be an integer >= 0"]),
        ({"seed": -1}, ValueError, ["seed=-1", "must be an integer >= 0"]),
        ({"seed": 1.5}, TypeError, ["seed=1.5", "must be an integer >= 0"]),
    ],
    ids=["options-kwarg", "options-override", "seed-str", "seed-negative", "seed-float"],
)
def test_bad_reset_arguments_are_refused(kwargs, exc, parts):
    env = UWBSchedulingEnv("indoor-rsn", action_kind="subset")
    with pytest.raises(exc, match=re.escape(parts[0])) as info:
        env.reset(**kwargs)
    _assert_names(info.value, *parts)


def test_step_before_reset_is_refused_clearly():
    """Before: ``AttributeError: 'Simulator' object has no attribute 'episode'`` (gym.make's OrderEnforcing wrapper
    refuses it first with ``ResetNeeded``; the env itself, e.g. built directly or unwrapped, did not)."""
    env = UWBSchedulingEnv("indoor-rsn", action_kind="subset")
    with pytest.raises(RuntimeError, match=re.escape("step() before reset(): call reset() to start an episode")):
        env.step(0)
    with pytest.raises(gym.error.ResetNeeded):
        gym.make(SUBSET).step(0)
    env.reset(seed=0)
    env.step(0)  # then it works


def test_step_after_the_horizon_is_refused_clearly():
    env = gym.make(SUBSET).unwrapped
    env.reset(seed=0)
    for _ in range(env.cfg.n_scans):
        env.step(0)
    with pytest.raises(RuntimeError, match=re.escape("step() after the episode ended: call reset()")):
        env.step(0)


def test_masked_action_is_refused_naming_the_receiver_and_the_valid_actions():
    env = gym.make(SUBSET, out_of_service_rx=("rx2",))
    env.reset(seed=0)
    mask = env.unwrapped.action_masks()
    bad = int(np.flatnonzero(~mask)[0])
    with pytest.raises(ValueError, match=re.escape(f"action={bad}: masked")) as info:
        env.step(bad)
    _assert_names(info.value, "receiver(s) ['rx2'] out of service", str(np.flatnonzero(mask).tolist()))


def test_describe_action_refuses_an_action_outside_the_space():
    env = gym.make(SUBSET).unwrapped
    with pytest.raises(ValueError, match=re.escape("action=99: must be an integer in [0, 19]")):
        env.describe_action(99)


def test_the_set_holds_at_least_95_cases():
    n = len(ENV_KEYWORDS) + 1 + len(CONFIG_VALUES) + 2 + len(YAML_FILES) + 1 + 5 + len(BAD_ACTIONS) + 5 + 4
    assert n >= 95
