r"""``UWBSchedulingEnv``: a scheduler picks the next scan's plan; the reward is minus the tracks' uncertainty.

One ``step(action)`` is one scan of the data flow: action -> ``ScanPlan`` -> sensing -> tracking -> reward and
observation. The action indexes an enumerated list of plans (``self.plans``):

    action_kind="waveform"  every transmitter sends waveform w, every receiver listens (seed 003)
    action_kind="subset"    the k receivers of subset s listen, the fixed waveform is sent (seed 000's network)
    action_kind="joint"     waveform x subset
    action_kind="per-tx"    every transmitter its own waveform, every receiver listens (distributed transmitters,
                            seed 003's conclusion): the W^T joint assignments in ``itertools.product`` order, the first
                            transmitter slowest, plan a = sum_t w_t W^(T - 1 - t) (``numpy.ravel_multi_index``)

Action encoding (``action_encoding``): ``"flat"`` is ``Discrete(len(plans))``, the action is the plan's index (the only
encoding of the first three kinds); ``"multi"`` (per-tx's default) is ``MultiDiscrete([W] * T)``, the action is the
waveform of each transmitter, ``(T,)`` integers, and decodes to the plan of the same waveforms (so flat action a and
multi action ``numpy.unravel_index(a, (W,) * T)`` play the same plan). ``plan_index(action)`` decodes either,
``action_of_plan(a)`` encodes; ``lookahead_costs()`` and the other per-plan arrays are indexed by plan in both. The
registered ``UrbanDistributed-v0`` takes ``"flat"`` (``Discrete(64)`` with ``action_masks()``, the space the package's
RL engines and generic tests take); ``gymnasium.make(id, action_encoding="multi")`` gives ``MultiDiscrete([8, 8])``.

Reward: minus the mean over confirmed tracks of trace(P) of the position block [m^2], minus
``missed_target_penalty_m2`` for every alive true target that no confirmed track covers within ``cover_gate_m``
(otherwise a scheduler that loses every track would pay nothing), minus ``energy_cost_per_j`` times the scan's
transmitted energy. The components are in ``info``.

Receiver warm-up (``receiver_warmup=True``): a receiver that did not listen in the previous scan spends its first
listening scan re-acquiring its background (seed 001's exponential average, seed 000's empty-room reference, which
the slowly moving clutter makes stale) and its clock, and delivers no detection; at ``reset`` every receiver is
ready (the network was calibrated listening). The scan's energy is paid all the same. Here one-step lookahead is
short-sighted: a switched-in receiver pays off one scan later, so the myopic scheduler's cost of any other subset is
never below its current one (each delivering pair's expected update only lowers P, and the other subset's ready
receivers are a subset of the current ones), and it keeps its first subset for the whole episode, however the
target moves. The multi-step lookahead (``sequence_costs``) sees the delayed pay-off.

Observation (flat ``Box``, default): ``n_slots`` track slots, confirmed tracks first then by existence, each
    [present, existence, confirmed, (x - cx) / hx, (y - cy) / hy, vx / v_max, vy / v_max,
     log10(var_x) / 4, log10(var_y) / 4, corr_xy, mu_1 .. mu_r]
(cx, cy the area's centre, hx, hy its half-sizes; ``track_frame="absolute"``, the default) or, with
``track_frame="relative"``, each track's range, range-rate, bearing and covariance in each node's radial frame, the
bistatic pairs' half range, rate and variance along the range gradient, and the model probabilities with CT-left /
CT-right as their sum and |difference| (``uwb_env.envs.relative``, its layout table: the same numbers for the scene
rotated, mirrored or translated), then the previous action one-hot (with ``action_kind="per-tx"``
one-hot per transmitter, T x W entries, rather than W^T), then optionally
(log10(lookahead cost + 1e-9 m^2) + 9) / 11 per action (0 at no cost, 0.27 at 1e-6 m^2, 0.82 at 1 m^2:
the costs span sub-millimetre indoor covariances to metres outdoors; with receiver warm-up also the same costs as if
every receiver were ready, the value of each subset once warm), then with receiver warm-up the ready receivers
(0/1 each). ``observation="dict"`` gives the same parts as a ``Dict`` in the same order (not sorted by key), so
``gymnasium.spaces.flatten`` of the ``Dict`` observation is the ``Box`` observation.

Episode end: the scenario's fixed horizon (``n_scans`` scans) ends an episode by truncation: ``truncated=True``,
``terminated=False`` (Gymnasium's convention for a time limit: the time is not in the observation, and nothing in the
scene ends an episode, so an agent must bootstrap through the end). ``step()`` before ``reset()`` or after the end
raises ``RuntimeError``.

Info: the same keys and shapes at every step and at ``reset`` (so vector envs can stack them), every value a
Python scalar or a fixed-shape float array:

    scan_index                   int, the scan just played (0 at reset)
    covariance_trace             mean trace of the confirmed tracks' position covariance [m^2] (0 without any)
    target_covariance_trace      the same over the confirmed tracks that cover a target [m^2] (0 without any)
    missed_targets, missed_penalty   alive targets no confirmed track covers; their reward term [m^2]
    energy_j, energy_cost        the scan's transmitted energy [J]; its reward term
    position_errors_m            ``(K,)`` covered targets' position errors [m], K = the scenario's targets; the first
                                 ``position_errors_count`` entries are the errors, the rest are padding, 0 (so
                                 ``sum(e**2)`` over the whole array is the sum over the covered targets)
    position_errors_count        int, how many entries of ``position_errors_m`` are errors
    ospa_m                       OSPA [m] (cut-off 2 ``cover_gate_m``, order 2)
    confirmed_tracks, false_tracks   ints
    model_probabilities          ``(r,)`` mean IMM mode probabilities over the confirmed tracks (zeros without any)

At ``reset`` no scan has been played: every count, cost and error is 0.

Action masks (``action_masks()``): with ``out_of_service_rx`` (receivers that cannot listen) the subset and joint
plans that need one of them are invalid, and the waveform and per-tx plans listen with the receivers in service only;
with ``unavailable_waveforms`` the plans that send one of them are invalid (a tuple: at every transmitter; a dict
``{transmitter: tuple}``: at those transmitters). Stepping an invalid action raises ``ValueError``; without either
keyword every plan is valid. The ``MultiDiscrete`` encoding's mask is sb3-contrib's: the transmitters' per-waveform
masks concatenated, ``(T * W,)``; the flat mask over plans is ``plan_masks()`` (the joint mask is separable: a plan is
valid iff every transmitter's waveform is).
"""

from __future__ import annotations

import itertools
import math
from collections import OrderedDict
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from uwb_env import scenarios
from uwb_env.config import TRACKER_KINDS, ScenarioConfig, apply_overrides
from uwb_env.envs.features import track_features
from uwb_env.envs.outputs import observations, one_env, rewards_and_infos, scan_summaries
from uwb_env.envs.relative import relative_feature_count, relative_track_features, scene_arguments
from uwb_env.lookahead import check_q2, detection_probabilities, lookahead_costs, search_information, sequence_costs
from uwb_env.sensing.protocol import Sensor
from uwb_env.sensing.records import ScanPlan
from uwb_env.sim import ScanResult, Simulator
from uwb_env.tracking.trackset import TrackSet
from uwb_env.typing import BoolArray, FloatArray
from uwb_env.units import dbm_to_watts

ACTION_KINDS = ("waveform", "subset", "joint", "per-tx")
ACTION_ENCODINGS = ("flat", "multi")
LOOKAHEAD_FLOOR_M2 = 1e-9  # floor of the log-scaled lookahead costs in the observation
FIDELITIES = ("parametric", "signal")
TRACK_FRAMES = ("absolute", "relative")
OBS_BOUND = 10.0
"""Observation bounds: every feature is O(1) on the scenario (the tracker deletes a track beyond 50 m std, one
area-size outside the surveillance area or faster than 10 ``max_speed_mps``: ``uwb_env.tracking.tracker``); a value
outside raises rather than being clipped."""


MAX_SLOTS = 1024
"""Most track slots in the observation (the tracker never holds more than a few hundred tracks)."""


# ------------------------------------------------------------------------------------------- keyword checks
# Every keyword is checked for its type as well as its value, with no coercion: a bool is a ``bool`` (or numpy
# bool), never the string "no" or the int 1; an int is an ``int`` (or numpy integer), never "8" or 8.0; a number is
# an int or float (numpy's too), never a bool or a string. Errors name the keyword, the value and what is allowed.
def _is_int(value: object) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def check_bool(name: str, value: object) -> None:
    """Raise ``TypeError`` unless ``value`` is True or False."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name}={value!r}: must be True or False (a bool, got {type(value).__name__})")


def check_int(name: str, value: object, lo: int, hi: int | None) -> None:
    """Raise unless ``value`` is an integer in ``[lo, hi]`` (``hi`` None: no upper bound)."""
    allowed = f"an integer in [{lo}, {hi}]" if hi is not None else f"an integer >= {lo}"
    if not _is_int(value):
        raise TypeError(f"{name}={value!r}: must be {allowed} (got {type(value).__name__})")
    if value < lo or (hi is not None and value > hi):  # type: ignore[operator]
        raise ValueError(f"{name}={value!r}: must be {allowed}")


def check_real(name: str, value: object, lo: float, *, closed: bool) -> None:
    """Raise unless ``value`` is a finite number ``>= lo`` (``closed``) or ``> lo``."""
    allowed = f"a finite number {'>=' if closed else '>'} {lo}"
    if not (_is_int(value) or isinstance(value, (float, np.floating))):
        raise TypeError(f"{name}={value!r}: must be {allowed} (got {type(value).__name__})")
    v = float(value)  # type: ignore[arg-type]
    if not math.isfinite(v) or v < lo or (not closed and v == lo):
        raise ValueError(f"{name}={value!r}: must be {allowed}")


def check_choice(name: str, value: object, allowed: tuple[str, ...]) -> None:
    """Raise unless ``value`` is one of the strings ``allowed``."""
    if not isinstance(value, str) or value not in allowed:
        raise (ValueError if isinstance(value, str) else TypeError)(f"{name}={value!r}: must be one of {allowed}")


def _node_mask(name: str, value: object, names: list[str], what: str) -> BoolArray:
    """``(len(names),)`` the nodes listed in ``value`` (a tuple or list of indices or names), checked."""
    allowed = f"a tuple of {what} indices in [0, {len(names) - 1}] or names {names}, each listed once"
    if not isinstance(value, (tuple, list)):
        raise TypeError(f"{name}={value!r}: must be {allowed}")
    mask = np.zeros(len(names), dtype=bool)
    for item in value:
        if isinstance(item, str) and item in names:
            i = names.index(item)
        elif _is_int(item) and 0 <= item < len(names):  # type: ignore[operator]
            i = int(item)  # type: ignore[call-overload]
        else:
            raise ValueError(f"{name}={value!r}: {item!r} is not allowed; must be {allowed}")
        if mask[i]:
            raise ValueError(f"{name}={value!r}: {item!r} listed twice; must be {allowed}")
        mask[i] = True
    return mask


def _waveform_mask(value: object, waveforms: list[str], transmitters: list[str]) -> BoolArray:
    """``(T, W)`` the waveforms each transmitter cannot send (``unavailable_waveforms``), checked.

    A tuple or list of waveforms (indices or names) applies to every transmitter; a dict maps transmitters (indices
    or names, each once) to such tuples, the others sending every waveform.
    """
    T, W = len(transmitters), len(waveforms)
    if not isinstance(value, dict):
        return np.repeat(_node_mask("unavailable_waveforms", value, waveforms, "waveform")[None], T, axis=0)
    dead = np.zeros((T, W), dtype=bool)
    seen = np.zeros(T, dtype=bool)
    for key, item in value.items():
        if isinstance(key, str) and key in transmitters:
            t = transmitters.index(key)
        elif _is_int(key) and 0 <= key < T:  # type: ignore[operator]
            t = int(key)  # type: ignore[call-overload]
        else:
            raise ValueError(
                f"unavailable_waveforms={value!r}: key {key!r} is not a transmitter; must be an index in [0, {T - 1}] "
                f"or a name {transmitters}"
            )
        if seen[t]:
            raise ValueError(f"unavailable_waveforms={value!r}: transmitter {transmitters[t]!r} listed twice")
        seen[t] = True
        dead[t] = _node_mask(f"unavailable_waveforms[{key!r}]", item, waveforms, "waveform")
    return dead


def episode_seed(env: gym.Env, seed: int | None, options: dict[str, Any] | None) -> int:
    """The episode seed of ``env.reset(seed=seed, options=options)``, after checking both and seeding ``np_random``.

    ``seed`` None draws it from the env's own generator (seeded by an earlier reset). The env takes no reset
    ``options``: anything but None or an empty dict raises rather than being ignored.
    """
    if options:
        raise ValueError(f"options={options!r}: must be None or {{}} (this env takes no reset options)")
    if seed is not None:
        check_int("seed", seed, 0, None)
        seed = int(seed)
    gym.Env.reset(env, seed=seed)
    if seed is None:
        seed = int(env.np_random.integers(2**63 - 1))
    return seed


def enumerate_plans(
    kind: str, n_waveforms: int, n_tx: int, n_rx: int, subset_size: int, fixed_waveform: int
) -> list[ScanPlan]:
    """The plans an action indexes (module docstring), in a fixed order."""
    if kind not in ACTION_KINDS:
        raise ValueError(f"action_kind={kind!r}: must be one of {ACTION_KINDS}")
    if kind != "waveform" and not 1 <= subset_size <= n_rx:
        raise ValueError(f"subset_size={subset_size}: must be in [1, {n_rx}] (the receivers of the scenario)")
    if not 0 <= fixed_waveform < n_waveforms:
        raise ValueError(f"fixed_waveform={fixed_waveform}: must be in [0, {n_waveforms - 1}]")
    if kind == "per-tx":  # first transmitter slowest: plan a = ravel_multi_index(w, (W,) * T)
        listening = np.ones(n_rx, dtype=bool)
        return [
            ScanPlan(np.array(w, dtype=np.int64), listening) for w in itertools.product(range(n_waveforms), repeat=n_tx)
        ]
    subsets = [np.isin(np.arange(n_rx), c) for c in itertools.combinations(range(n_rx), subset_size)]
    if kind == "waveform":
        return [ScanPlan.all_listening(w, n_tx, n_rx) for w in range(n_waveforms)]
    waveforms = [fixed_waveform] if kind == "subset" else list(range(n_waveforms))
    return [ScanPlan(np.full(n_tx, w, dtype=np.int64), s) for w in waveforms for s in subsets]


def _scaled_cost(costs: FloatArray) -> FloatArray:
    """Lookahead costs [m^2] as observation features: (log10(c + 1e-9) + 9) / 11 (module docstring)."""
    return (np.log10(costs + LOOKAHEAD_FLOOR_M2) + 9.0) / 11.0


class UWBSchedulingEnv(gym.Env):
    """Closed-loop sensor scheduling on one scenario (see the module docstring).

    Args:
        scenario: a registered scenario name or a ``ScenarioConfig``; overrides: dotted config overrides.
        action_kind, subset_size, fixed_waveform: the plans (``enumerate_plans``).
        action_encoding: ``"flat"`` (``Discrete``) or ``"multi"`` (``MultiDiscrete([W] * T)``, per-tx only); None:
            ``"multi"`` for per-tx, ``"flat"`` otherwise (module docstring).
        fidelity: ``"parametric"`` or ``"signal"`` (synthesised signals through the seeds' chains: seed 000's for
            impulse radios, seed 003's delay-Doppler chain for chirp trains; ``uwb_env.sensing.protocol``); None keeps
            the scenario's ``sensing.fidelity``. With ``"signal"`` the lookahead still uses the parametric sensor
            model (per-pair Pd, R and clutter map).
        tracker: ``"imm-lmipda"`` (seed 003's VS-IMM / LMIPDA), ``"phd"`` (seed 000's particle PHD) or ``"pf"``
            (seed 002's particle filter) (``uwb_env.tracking.registry``); None keeps the scenario's ``tracker.kind``.
            Same as the override ``**{"tracker.kind": ...}``.
        n_slots: track slots in the observation; observation: ``"box"`` or ``"dict"``;
        track_frame: ``"absolute"`` (the slots in the scene's frame, ``uwb_env.envs.features``) or ``"relative"`` (the
            slots relative to the nodes, invariant under rotating, mirroring and translating the scene:
            ``uwb_env.envs.relative``, its layout table);
        include_lookahead: append the lookahead cost of every action to the observation.
        missed_target_penalty_m2, cover_gate_m, energy_cost_per_j: reward terms (module docstring).
        receiver_warmup: a receiver delivers only if it listened in the previous scan (module docstring); the
            observation then ends with the ready receivers (0/1 per receiver).
        lookahead_q2: the lookahead's information-reduction factor: 1 (seed 003's clutter-free update, the
            default), another constant in (0, 1], or ``"pda"`` for q_2(P_D, clutter in the gate) of PDA
            (``uwb_env.tracking.reduction``).
        out_of_service_rx, unavailable_waveforms: receivers and waveforms (indices or names) that the scheduler
            cannot use; they mask actions (module docstring). ``unavailable_waveforms`` may be a dict
            ``{transmitter: waveforms}`` (indices or names) for waveforms that only some transmitters lack.
        render_mode: ``None``, ``"rgb_array"`` (``render()`` returns the frame) or ``"human"`` (shown after every
            ``reset`` and ``step``; ``render()`` returns None).

    Every keyword is checked for its type and value, without coercion (``"no"`` is not a bool, ``"8"`` and ``8.0``
    are not ints); a bad one raises ``TypeError`` / ``ValueError`` naming the keyword, the value and what is allowed.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array", "human"], "render_fps": 4}

    def __init__(
        self,
        scenario: str | ScenarioConfig = "urban-intersection",
        action_kind: str = "waveform",
        action_encoding: str | None = None,
        subset_size: int = 3,
        fixed_waveform: int = 0,
        fidelity: str | None = None,
        tracker: str | None = None,
        n_slots: int = 8,
        observation: str = "box",
        track_frame: str = "absolute",
        include_lookahead: bool = False,
        missed_target_penalty_m2: float = 100.0,
        cover_gate_m: float = 5.0,
        energy_cost_per_j: float = 0.0,
        receiver_warmup: bool = False,
        lookahead_q2: float | str = 1.0,
        out_of_service_rx: tuple[int | str, ...] = (),
        unavailable_waveforms: tuple[int | str, ...] | dict[int | str, tuple[int | str, ...]] = (),
        render_mode: str | None = None,
        _sensor: Sensor | None = None,
        **overrides: Any,
    ) -> None:
        if not isinstance(scenario, (str, ScenarioConfig)):
            raise TypeError(
                f"scenario={scenario!r}: must be a scenario name (one of {scenarios.names()}) or a ScenarioConfig"
            )
        if not isinstance(action_kind, str) or action_kind not in ACTION_KINDS:
            raise (ValueError if isinstance(action_kind, str) else TypeError)(
                f"action_kind={action_kind!r}: must be one of {ACTION_KINDS[:3]} (one waveform for every transmitter) "
                "or 'per-tx' (each transmitter its own waveform)"
            )
        if action_encoding is None:
            action_encoding = "multi" if action_kind == "per-tx" else "flat"
        check_choice("action_encoding", action_encoding, ACTION_ENCODINGS)
        if action_encoding == "multi" and action_kind != "per-tx":
            raise ValueError(
                f"action_encoding='multi' with action_kind={action_kind!r}: MultiDiscrete is per-tx's encoding; "
                "must be 'flat' (or None) for this kind"
            )
        if fidelity is not None:
            check_choice("fidelity", fidelity, FIDELITIES)
        if tracker is not None:
            check_choice("tracker", tracker, TRACKER_KINDS)
        check_choice("observation", observation, ("box", "dict"))
        check_choice("track_frame", track_frame, TRACK_FRAMES)
        if render_mode is not None:
            check_choice("render_mode", render_mode, tuple(self.metadata["render_modes"]))
        check_int("n_slots", n_slots, 1, MAX_SLOTS)
        check_int("subset_size", subset_size, 1, None)
        check_int("fixed_waveform", fixed_waveform, 0, None)
        check_bool("include_lookahead", include_lookahead)
        check_bool("receiver_warmup", receiver_warmup)
        check_real("missed_target_penalty_m2", missed_target_penalty_m2, 0.0, closed=True)
        check_real("cover_gate_m", cover_gate_m, 0.0, closed=False)
        check_real("energy_cost_per_j", energy_cost_per_j, 0.0, closed=True)
        check_q2(lookahead_q2)
        cfg = scenarios.get(scenario) if isinstance(scenario, str) else scenario
        if fidelity is not None:
            overrides = {"sensing.fidelity": fidelity, **overrides}
        if tracker is not None:
            overrides = {"tracker.kind": tracker, **overrides}
        self.cfg = apply_overrides(cfg, overrides) if overrides else cfg
        self._dead_rx = _node_mask(
            "out_of_service_rx", out_of_service_rx, [r.name for r in self.cfg.receivers], "receiver"
        )
        self._dead_tw = _waveform_mask(  # (T, W) the waveforms each transmitter cannot send
            unavailable_waveforms, [w.name for w in self.cfg.waveforms], [t.name for t in self.cfg.transmitters]
        )
        self.sim = Simulator(self.cfg, sensor=_sensor)  # _sensor: one shared by a batched vector env (envs.vector)
        sensor = self.sim.sensor
        plans = enumerate_plans(action_kind, len(sensor.library), sensor.n_tx, sensor.n_rx, subset_size, fixed_waveform)
        if action_kind in ("waveform", "per-tx"):  # every in-service receiver listens; one out of service cannot
            plans = [ScanPlan(p.waveform, p.active_rx & ~self._dead_rx) for p in plans]
            if self._dead_rx.all():
                raise ValueError(
                    f"out_of_service_rx={out_of_service_rx!r}: must leave at least one receiver in service"
                )
        self.plans = plans
        tx_index = np.arange(sensor.n_tx)
        self._mask = np.array(
            [not (p.active_rx & self._dead_rx).any() and not self._dead_tw[tx_index, p.waveform].any() for p in plans]
        )
        if not self._mask.any():
            raise ValueError(
                f"out_of_service_rx={out_of_service_rx!r}, unavailable_waveforms={unavailable_waveforms!r}: "
                f"must leave at least one valid plan of action_kind={action_kind!r}"
            )
        self.action_kind, self.action_encoding = action_kind, action_encoding
        # per-tx: the plan's per-transmitter waveforms are the MultiDiscrete action (module docstring)
        self.action_dims = (len(sensor.library),) * sensor.n_tx if action_kind == "per-tx" else None
        self.n_slots, self.obs_kind, self.include_lookahead = n_slots, observation, include_lookahead
        self.missed_target_penalty_m2 = float(missed_target_penalty_m2)
        self.cover_gate_m = float(cover_gate_m)
        self.energy_cost_per_j = float(energy_cost_per_j)
        self.receiver_warmup = bool(receiver_warmup)
        self.lookahead_q2 = lookahead_q2
        self.render_mode = render_mode
        self.action_space = (
            spaces.MultiDiscrete(list(self.action_dims))
            if action_encoding == "multi" and self.action_dims is not None
            else spaces.Discrete(len(self.plans))
        )
        self.n_models = len(self.sim.tracker.model_names)
        self._n_targets = len(self.cfg.targets)  # the width of info["position_errors_m"]
        lay = sensor.layout
        x0, x1, y0, y1 = lay.area
        self._centre = np.array([(x0 + x1) / 2, (y0 + y1) / 2])
        self._half = np.array([(x1 - x0) / 2, (y1 - y0) / 2])
        self._v_max = self.cfg.tracker.max_speed_mps
        self.track_frame = track_frame
        self._relative_scene = None
        self.slot_features = 10 + self.n_models
        if track_frame == "relative":
            self._relative_scene = scene_arguments(self.cfg, lay, sensor.pairs, tuple(self.sim.tracker.model_names))
            single, turns = self._relative_scene[4], self._relative_scene[5]
            self.slot_features = relative_feature_count(
                sensor.n_tx, sensor.n_rx, sensor.pairs.shape[0], single.size, turns.shape[0]
            )
        self.plan_energy_j = np.array(
            [
                sum(
                    sensor.library[int(w)].scan_energy_j(dbm_to_watts(tx.power_dbm))
                    for w, tx in zip(p.waveform, self.cfg.transmitters, strict=True)
                )
                for p in self.plans
            ]
        )
        parts = {
            "tracks": spaces.Box(-OBS_BOUND, OBS_BOUND, (n_slots, self.slot_features), np.float32),
            "previous_action": spaces.Box(0.0, 1.0, (self._previous_size,), np.float32),
        }
        if include_lookahead:
            parts["lookahead"] = spaces.Box(0.0, OBS_BOUND, (len(self.plans),), np.float32)
            if receiver_warmup:
                parts["lookahead_all_ready"] = spaces.Box(0.0, OBS_BOUND, (len(self.plans),), np.float32)
        if receiver_warmup:
            parts["ready_receivers"] = spaces.Box(0.0, 1.0, (sensor.n_rx,), np.float32)
        self._parts = parts
        if observation == "dict":  # in the Box's order (a plain dict would be sorted by key): flatten() == the Box
            self.observation_space = spaces.Dict(OrderedDict(parts))
        else:
            size = sum(int(np.prod(s.shape)) for s in parts.values())
            self.observation_space = spaces.Box(-OBS_BOUND, OBS_BOUND, (size,), np.float32)
        self._previous: int | None = None
        self._last: ScanResult | None = None
        self._started = False
        self._ready_rx = np.ones(sensor.n_rx, dtype=bool)

    # ------------------------------------------------------------------------------------------------- gym API
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        """Draw an episode; ``seed`` seeds every stream of it (the randomness contract of ``uwb_env.rng``).

        The env takes no reset ``options``: anything but None or an empty dict raises rather than being ignored.
        """
        seed = episode_seed(self, seed, options)
        self.sim.reset(seed)
        self._ready_rx = np.ones(self.sim.sensor.n_rx, dtype=bool)
        self._previous = None
        self._last = None
        self._started = True
        if self.render_mode == "human":
            self.render()
        return self._observation(), self._reset_info()

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        """Sense and track the next scan with plan ``action``.

        Returns ``terminated=False`` always (no state of the scene ends an episode) and ``truncated=True`` at the
        scenario's fixed horizon (``n_scans``): time is not in the observation, so the end is a time limit
        (Gymnasium's convention; value bootstrapping continues through it).
        """
        if not self._started:
            raise RuntimeError("step() before reset(): call reset() to start an episode")
        a = self._check_action(action)
        if self.sim.done:
            raise RuntimeError("step() after the episode ended: call reset()")
        plan = self.plans[a]
        res = self.sim.step(plan, self.ready_rx)
        if self.receiver_warmup:
            self._ready_rx = plan.active_rx.copy()
        self._previous, self._last = a, res
        reward, info = self._reward_and_info(res, a)
        if self.render_mode == "human":
            self.render()
        return self._observation(), reward, False, self.sim.done, info

    def action_masks(self) -> BoolArray:
        """Which actions are valid (for masked policies: sb3-contrib's MaskablePPO, RLlib).

        ``Discrete``: ``(n_actions,)``, False for a plan that needs a receiver out of service (``out_of_service_rx``)
        or sends a waveform that is not available (``unavailable_waveforms``); all True without either.
        ``MultiDiscrete`` (per-tx): sb3-contrib's convention, the transmitters' masks over the library concatenated,
        ``(T * W,)`` (entry t W + w: transmitter t may send waveform w). Stepping a masked action raises
        ``ValueError``.
        """
        if self.action_encoding == "multi":
            return (~self._dead_tw).ravel()
        return self._mask.copy()

    def plan_masks(self) -> BoolArray:
        """``(len(plans),)`` which plans are valid, whatever the encoding (``action_masks()`` of the flat one)."""
        return self._mask.copy()

    def plan_index(self, action: Any) -> int:
        """The index into ``plans`` of ``action`` (either encoding; checked, masked actions allowed)."""
        return self._check_action(action, masked_ok=True)

    def action_of_plan(self, plan: int) -> Any:
        """The action that plays ``plans[plan]``: the index itself (``Discrete``) or its waveforms ``(T,)`` (multi)."""
        check_int("plan", plan, 0, len(self.plans) - 1)
        if self.action_encoding == "multi":
            return np.array(np.unravel_index(int(plan), self.action_dims), dtype=np.int64)
        return int(plan)

    def describe_action(self, action: Any) -> str:
        """The plan of ``action`` in words: the waveform(s) sent (per transmitter for per-tx), the receivers."""
        a = self._check_action(action, masked_ok=True)
        plan = self.plans[a]
        rx = [self.cfg.receivers[i].name for i in np.flatnonzero(plan.active_rx)]
        if self.action_kind == "per-tx":
            sent = [
                f"{t.name} {self.cfg.waveforms[int(w)].name}"
                for t, w in zip(self.cfg.transmitters, plan.waveform, strict=True)
            ]
            return f"action {a}: waveforms {', '.join(sent)}; receivers {', '.join(rx)}"
        names = sorted({self.cfg.waveforms[int(w)].name for w in plan.waveform})
        return f"action {a}: waveform {', '.join(names)}; receivers {', '.join(rx)}"

    @property
    def ready_rx(self) -> BoolArray | None:
        """``(R,)`` the receivers able to deliver in the next scan under receiver warm-up; None without it."""
        return self._ready_rx.copy() if self.receiver_warmup else None

    def lookahead_costs(self) -> FloatArray:
        """Expected mean position-covariance trace [m^2] after the next scan for every action (pure)."""
        return lookahead_costs(*self._next_scan(), q2=self.lookahead_q2, ready_rx=self.ready_rx)

    def detection_probabilities(self) -> FloatArray | None:
        """``(A, N, Q)`` expected Pd of the confirmed tracks at each formed pair under each action (pure).

        None without a confirmed track; ``uwb_env.lookahead.detection_probabilities``.
        """
        return detection_probabilities(*self._next_scan())

    def search_information(self) -> FloatArray:
        """``(A,)`` range information a new target's detections would bring under each action (pure; search scans).

        ``uwb_env.lookahead.search_information`` with the tracker's initiation range-rate prior (+-2 v_max).
        """
        sensor, _, plans, _, _ = self._next_scan()
        return search_information(sensor, plans, 2.0 * self.cfg.tracker.max_speed_mps)

    def sequence_costs(self, depth: int, beam: int | None = None, discount: float = 1.0) -> FloatArray:
        """``(A,)`` the cheapest expected d-scan cost of the plan sequences starting with each action (pure).

        ``uwb_env.lookahead.sequence_costs`` on this env's tracker, sensor model and warm-up state.
        """
        period = self.cfg.sensing.scan_period_s
        return sequence_costs(
            *self._next_scan(), period, depth, beam, discount, q2=self.lookahead_q2, ready_rx=self.ready_rx
        )

    def _next_scan(self) -> tuple[Any, Any, list[ScanPlan], float, int]:
        """The lookahead's arguments for the next scan: sensor, tracker, plans, its time [s] and index."""
        k = self.sim.k + 1
        return self.sim.sensor, self.sim.tracker, self.plans, k * self.cfg.sensing.scan_period_s, k

    # ----------------------------------------------------------------------------------------------- internals
    @property
    def _previous_size(self) -> int:
        """Entries of the previous action's one-hot: one per plan, or per transmitter and waveform (per-tx)."""
        return len(self.plans) if self.action_dims is None else int(sum(self.action_dims))

    def _check_action(self, action: Any, *, masked_ok: bool = False) -> int:
        """The plan index of ``action``; raises unless it is an action of the space and (unless ``masked_ok``) valid.

        ``Discrete``: an integer scalar in range. ``MultiDiscrete``: ``(T,)`` integers, each in [0, W).
        """
        a = np.asarray(action)
        if self.action_encoding == "multi":
            dims = self.action_dims
            if a.shape != (len(dims),) or a.dtype.kind not in "iu" or not ((a >= 0) & (a < dims[0])).all():
                raise ValueError(
                    f"action={action!r}: must be {len(dims)} integers (a waveform per transmitter), each in "
                    f"[0, {dims[0] - 1}]"
                )
            a = np.ravel_multi_index(tuple(a.tolist()), dims)
        elif a.shape != () or a.dtype.kind not in "iu" or not 0 <= int(a) < len(self.plans):
            raise ValueError(f"action={action!r}: must be an integer in [0, {len(self.plans) - 1}]")
        a_int = int(a)
        if not masked_ok and not self._mask[a_int]:
            plan = self.plans[a_int]
            dead = [self.cfg.receivers[i].name for i in np.flatnonzero(plan.active_rx & self._dead_rx)]
            gone = sorted(
                {self.cfg.waveforms[int(w)].name for t, w in enumerate(plan.waveform) if self._dead_tw[t, int(w)]}
            )
            why = "; ".join(
                [f"receiver(s) {dead} out of service"] * bool(dead) + [f"waveform(s) {gone} unavailable"] * bool(gone)
            )
            if self.action_encoding == "multi":
                allowed = {
                    t.name: np.flatnonzero(~self._dead_tw[i]).tolist() for i, t in enumerate(self.cfg.transmitters)
                }
                raise ValueError(
                    f"action={action!r} (plan {a_int}): masked ({why}); each transmitter must send one of its valid "
                    f"waveforms {allowed} (action_masks())"
                )
            raise ValueError(
                f"action={a_int}: masked ({why}); must be one of the valid actions "
                f"{np.flatnonzero(self._mask).tolist()} (action_masks())"
            )
        return a_int

    def _reward_and_info(self, res: ScanResult, action: int) -> tuple[float, dict[str, Any]]:
        """The reward and info of the scan ``res`` played with ``action`` (``envs.outputs``, one environment)."""
        reward, info = rewards_and_infos(
            self._summaries(res.tracks, res.scan_index),
            np.array([res.scan_index]),
            self.plan_energy_j[[action]],
            self.missed_target_penalty_m2,
            self.energy_cost_per_j,
        )
        return float(reward[0]), one_env(info)

    def _summaries(self, tracks: TrackSet, scan_index: int) -> tuple[np.ndarray, ...]:
        """``envs.outputs.scan_summaries`` of ``tracks`` against the targets alive at ``scan_index``."""
        x, P = tracks.combined()
        truth = self.sim.truth
        targets = truth.states[scan_index][truth.alive[scan_index]][:, 0:3:2]  # (x, y) of the alive ones
        return scan_summaries(
            np.array([0, len(tracks)]), tracks.confirmed, tracks.existence, tracks.mu, x, P,
            np.array([0, targets.shape[0]]), np.ascontiguousarray(targets), self.cover_gate_m, self.cover_gate_m * 2,
            self._centre, self._half, self._v_max, self.n_slots, self._n_targets,
        )  # fmt: skip

    def _reset_info(self) -> dict[str, Any]:
        """The info of ``reset``: the step's keys and shapes (vector envs stack them), no scan played yet.

        Every count, cost and error is 0 and the model probabilities are zeros (no confirmed track), as in a
        step's info without tracks; ``scan_index`` is 0.
        """
        return {
            "scan_index": 0,
            "covariance_trace": 0.0,
            "target_covariance_trace": 0.0,
            "missed_targets": 0,
            "missed_penalty": 0.0,
            "energy_j": 0.0,
            "energy_cost": 0.0,
            "position_errors_m": np.zeros(self._n_targets),
            "position_errors_count": 0,
            "ospa_m": 0.0,
            "confirmed_tracks": 0,
            "false_tracks": 0,
            "model_probabilities": np.zeros(self.n_models),
        }

    def track_slots(
        self, existence: FloatArray, confirmed: BoolArray, mu: FloatArray, x: FloatArray, P: FloatArray
    ) -> FloatArray:
        """``(n_slots, slot_features)`` the observation's track slots of N tracks in the env's ``track_frame``.

        existence, confirmed ``(N,)``, mu ``(N, r)``, IMM-combined x ``(N, 6)``, P ``(N, 6, 6)``.
        """
        if self._relative_scene is None:
            return track_features(existence, confirmed, mu, x, P, self._centre, self._half, self._v_max, self.n_slots)
        return relative_track_features(existence, confirmed, mu, x, P, *self._relative_scene, self._v_max, self.n_slots)

    def _observation(self, lookahead: dict[str, FloatArray] | None = None) -> Any:
        """The observation (module docstring); ``lookahead``: its lookahead parts if already computed (scaled)."""
        tracks = self.sim.tracker.tracks
        x, P = tracks.combined()
        feats = self.track_slots(tracks.existence, tracks.confirmed, tracks.mu, x, P)
        extra = {} if lookahead is None else dict(lookahead)
        if self.include_lookahead and lookahead is None:
            extra["lookahead"] = _scaled_cost(self.lookahead_costs())
            if self.receiver_warmup:
                extra["lookahead_all_ready"] = _scaled_cost(lookahead_costs(*self._next_scan(), q2=self.lookahead_q2))
        if self.receiver_warmup:
            extra["ready_receivers"] = self._ready_rx.astype(float)
        obs = observations(
            feats[None],
            np.array([-1 if self._previous is None else self._previous]),
            len(self.plans),
            {k: v[None] for k, v in extra.items()},
            self.obs_kind,
            OBS_BOUND,
            np.array([self.sim.k]),
            self.action_dims,
        )
        return {k: v[0] for k, v in obs.items()} if self.obs_kind == "dict" else obs[0]

    # ---------------------------------------------------------------------------------------------- rendering
    def render(self) -> np.ndarray | None:
        """The scene, truth, the scan's detections, confirmed tracks with 2-sigma ellipses and ids, the chosen plan.

        ``rgb_array``: returns the frame ``(H, W, 3)`` uint8. ``human``: shows it (also after every ``reset`` and
        ``step``, Gymnasium's convention) and returns None. The title names the plan (``describe_action``).
        """
        if self.render_mode is None:
            return None
        import matplotlib

        if self.render_mode == "rgb_array":
            matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        from uwb_env.show import draw_detections, draw_scene

        fig, ax = plt.subplots(figsize=(6, 6), dpi=80)
        draw_scene(ax, self.cfg, self.sim.sensor.layout)
        k = self.sim.k
        truth = self.sim.truth
        if k > 0:
            alive = truth.alive[k]
            ax.plot(truth.states[k][alive, 0], truth.states[k][alive, 2], "k*", ms=10, label="truth")
        if self._last is not None:
            lay = self.sim.sensor.layout
            draw_detections(ax, self._last.detections, lay.tx_pos, lay.rx_pos)
        tracks = self.sim.tracker.tracks
        if len(tracks):
            x, P = tracks.combined()
            angle = np.linspace(0, 2 * np.pi, 60)
            for i in np.flatnonzero(tracks.confirmed):
                C = P[i][np.ix_([0, 2], [0, 2])]
                w, V = np.linalg.eigh(C)
                ell = (V * (2.0 * np.sqrt(np.maximum(w, 0.0)))) @ np.stack([np.cos(angle), np.sin(angle)])
                ax.plot(x[i, 0] + ell[0], x[i, 2] + ell[1], "b-", lw=1)
                ax.text(x[i, 0], x[i, 2], f" {tracks.ids[i]}", color="b", fontsize=8)
        plan = "no scan yet" if self._previous is None else self.describe_action(self._previous)
        ax.set_title(f"scan {k}: {plan}", fontsize=9, wrap=True)
        if self.render_mode == "human":  # Gymnasium: drawn on screen, nothing returned
            plt.show(block=False)
            plt.pause(1.0 / self.metadata["render_fps"])
            plt.close(fig)
            return None
        fig.canvas.draw()
        img = np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()
        plt.close(fig)
        return img
