r"""``UWBVectorEnv``: N scheduling environments stepped in lockstep, each stage batched over the environments.

``gymnasium.make_vec(id, num_envs=N, vectorization_mode="vector_entry_point")`` returns it for every registered id
(``uwb_env.envs.ENV_IDS``); the keyword arguments are the single env's (``UWBSchedulingEnv``) plus
``autoreset_mode`` (``gymnasium.vector.AutoresetMode``: ``NEXT_STEP``, the default, ``SAME_STEP`` or
``DISABLED``). Environment e behaves exactly as ``UWBSchedulingEnv`` would with the same seed and actions: the same
observations, rewards, terminations, truncations and infos (``tests/test_batched_vector_env.py``), in the layout of
Gymnasium's ``SyncVectorEnv`` (stacked observations, infos as arrays with ``_key`` masks, ``final_obs`` /
``final_info`` in ``SAME_STEP`` mode).

What is batched (one call per stage and scan for all N, not N step calls):
    * sensing: one sensor shared by the N episodes (its episode draws stay per environment, so common random
      numbers hold env by env); the scan's rows of every episode sorted, given covariances and split per pair in
      one pass (``uwb_env.sensing.batch.sense_many``);
    * tracking: ``uwb_env.tracking.batch.BatchedTracker``: prediction, the sensor model's Pd, the LMIPDA + PDA
      updates, range-only initiation, new tracks, confirmation and deletion, each one compiled or vectorised call
      over every environment's tracks;
    * lookahead (``lookahead_costs()`` ``(N, A)``, also in the observation with ``include_lookahead``): the scored
      tracks of every environment predicted in one compiled call and their expected updates in one
      ``expected_posterior`` over plans x all tracks, averaged per environment;
    * reward, info and observation: ``uwb_env.envs.outputs`` over every environment's tracks in one compiled pass
      (the single env's own functions, with E = 1 there).
What stays a Python call per environment: choosing its scan's rows, its detections' records, its truth's alive
targets, its resets.

Scope: the parametric fidelity and the ``imm-lmipda`` tracker (every registered id's defaults); another fidelity or
tracker raises ``ValueError`` naming the keyword (use ``vectorization_mode="sync"`` for those). ``render`` is not
batched (``render_mode`` must be None).

Seeds: ``reset(seed=s)`` seeds environment e with ``s + e`` (an int) or ``s[e]`` (a list), as ``SyncVectorEnv``;
``reset(options={"reset_mask": mask})`` resets only the environments where ``mask`` ``(N,)`` is True (the others
keep their episodes), so episodes can end at different steps. ``action_masks()`` ``(N, A)`` (``(N, T * W)`` for the
``MultiDiscrete`` encoding of per-tx plans: the single env's per-transmitter masks, stacked).

Actions: ``(N,)`` plan indices, or ``(N, T)`` waveforms per transmitter for the ``MultiDiscrete`` encoding
(``UWBSchedulingEnv`` docstring), decoded to plan indices as the single env decodes them.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space, create_empty_array

from uwb_env.envs.outputs import observations, one_env, rewards_and_infos, scan_summaries
from uwb_env.envs.relative import relative_track_features_batched
from uwb_env.envs.scheduling import OBS_BOUND, UWBSchedulingEnv, _scaled_cost
from uwb_env.lookahead import expected_posterior, position_trace
from uwb_env.sensing.batch import sense_many
from uwb_env.sensing.records import ScanPlan
from uwb_env.sim import ScanResult
from uwb_env.tracking.batch import BatchedTracker
from uwb_env.tracking.compiled import combine as compiled_combine
from uwb_env.typing import BoolArray, FloatArray, IntArray

AUTORESET_MODES = (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP, AutoresetMode.DISABLED)


class UWBVectorEnv(VectorEnv):
    """``num_envs`` copies of ``UWBSchedulingEnv(**kwargs)`` stepped together (module docstring)."""

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}  # noqa: RUF012 (gymnasium's field)

    def __init__(
        self, num_envs: int, autoreset_mode: AutoresetMode | str = AutoresetMode.NEXT_STEP, **kwargs: Any
    ) -> None:
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"num_envs={num_envs!r}: must be an integer >= 1")
        try:
            mode = AutoresetMode(autoreset_mode)
        except ValueError:
            raise ValueError(
                f"autoreset_mode={autoreset_mode!r}: must be one of {[m.value for m in AUTORESET_MODES]}"
            ) from None
        if kwargs.get("render_mode") is not None:
            raise ValueError(f"render_mode={kwargs['render_mode']!r}: the batched vector env does not render (None)")
        first = UWBSchedulingEnv(**kwargs)
        if first.cfg.sensing.fidelity != "parametric":
            raise ValueError(
                f"fidelity={first.cfg.sensing.fidelity!r}: the batched vector env runs the parametric fidelity only "
                "(use vectorization_mode='sync' for 'signal')"
            )
        if first.cfg.tracker.kind != "imm-lmipda":
            raise ValueError(
                f"tracker={first.cfg.tracker.kind!r}: the batched vector env runs 'imm-lmipda' only "
                "(use vectorization_mode='sync' for the particle trackers)"
            )
        kwargs = {**kwargs, "scenario": first.cfg}  # the overrides are applied: build the rest from the config
        for key in ("fidelity", "tracker"):
            kwargs.pop(key, None)
        self.envs = [first] + [UWBSchedulingEnv(**kwargs, _sensor=first.sim.sensor) for _ in range(num_envs - 1)]
        self.num_envs = int(num_envs)
        self.autoreset_mode = mode
        self.metadata = {**self.metadata, "autoreset_mode": mode}
        self.single_observation_space = first.observation_space
        self.single_action_space = first.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.spec = None
        self.render_mode = None
        self.sensor = first.sim.sensor
        self.plans = first.plans
        self._mask = first.plan_masks()  # (A,) over plans, whatever the encoding
        self._waveforms = np.array([p.waveform for p in self.plans], np.int64)  # (A, T)
        self._tracker = BatchedTracker([env.sim.tracker for env in self.envs])
        self._observations = create_empty_array(self.single_observation_space, self.num_envs)
        self._autoreset = np.zeros(self.num_envs, bool)
        self._started = False

    # ------------------------------------------------------------------------------------------------ gym API
    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Reset every environment (or those of ``options["reset_mask"]``); seeds as ``SyncVectorEnv``."""
        options = dict(options or {})
        mask = options.pop("reset_mask", None)
        if options:
            raise ValueError(f"options={options!r}: the only reset option is 'reset_mask'")
        if mask is None:
            mask = np.ones(self.num_envs, bool)
        elif not isinstance(mask, np.ndarray) or mask.dtype != np.bool_ or mask.shape != (self.num_envs,):
            raise ValueError(f"options['reset_mask']={mask!r}: must be a bool numpy array of shape ({self.num_envs},)")
        elif not self._started and not mask.all():
            raise ValueError("options['reset_mask']: the first reset must reset every environment")
        if seed is None:
            seeds: list[int | None] = [None] * self.num_envs
        elif isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
            seeds = [int(seed) + e for e in range(self.num_envs)]
        elif isinstance(seed, (list, tuple)) and len(seed) == self.num_envs:
            seeds = list(seed)
        else:
            raise ValueError(f"seed={seed!r}: must be None, an int or a list of {self.num_envs} ints / None")
        infos: dict[str, Any] = {}
        for e in np.flatnonzero(mask).tolist():
            obs, info = self.envs[e].reset(seed=seeds[e])
            self._set_rows(e, obs)
            infos = self._add_info(infos, info, e)
        self._autoreset[mask] = False
        self._started = True
        return self._copy(), infos

    def step(self, actions: Any) -> tuple[Any, FloatArray, BoolArray, BoolArray, dict[str, Any]]:
        """One scan of every environment (autoreset per ``autoreset_mode``, as ``SyncVectorEnv``)."""
        if not self._started:
            raise RuntimeError("step() before reset(): call reset() to start the episodes")
        acts = self._check_actions(actions)
        n = self.num_envs
        rewards = np.zeros(n)
        terminated = np.zeros(n, bool)
        truncated = np.zeros(n, bool)
        infos: dict[str, Any] = {}
        resetting = self._autoreset.copy() if self.autoreset_mode == AutoresetMode.NEXT_STEP else np.zeros(n, bool)
        if self.autoreset_mode == AutoresetMode.DISABLED and self._autoreset.any():
            raise RuntimeError(
                f"autoreset_mode=DISABLED: environments {np.flatnonzero(self._autoreset).tolist()} ended; "
                "reset them (options={'reset_mask': ...}) before stepping"
            )
        stepping = np.flatnonzero(~resetting)
        self._scan(stepping, acts[stepping])
        env_infos: list[dict[str, Any] | None] = [None] * n
        for e in np.flatnonzero(resetting).tolist():
            obs, env_infos[e] = self.envs[e].reset()
            self._set_rows(e, obs)
        info_arrays = None
        if stepping.size:
            rewards[stepping], info_arrays, batch_obs = self._outputs(stepping, acts[stepping])
            truncated[stepping] = [self.envs[e].sim.done for e in stepping.tolist()]
            self._set_rows(stepping, batch_obs)
        row = {e: j for j, e in enumerate(stepping.tolist())}
        if self.autoreset_mode == AutoresetMode.SAME_STEP:
            for e in np.flatnonzero(truncated | terminated).tolist():
                final = one_env(info_arrays, row[e])
                infos = self._add_info(infos, {"final_obs": _deep(self._row(e)), "final_info": final}, e)
                obs, env_infos[e] = self.envs[e].reset()
                self._set_rows(e, obs)
        infos.update(_stacked_infos(env_infos, info_arrays, row))
        self._autoreset = terminated | truncated
        return self._copy(), rewards, terminated, truncated, infos

    def action_masks(self) -> BoolArray:
        """``(N, A)`` the valid actions of every environment (``UWBSchedulingEnv.action_masks``)."""
        mask = self.envs[0].action_masks()
        return np.broadcast_to(mask, (self.num_envs, mask.size)).copy()

    def lookahead_costs(self) -> FloatArray:
        """``(N, A)`` every environment's ``UWBSchedulingEnv.lookahead_costs`` for its next scan, in one batch."""
        return self._lookahead(np.arange(self.num_envs))

    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple[Any, ...]:
        """``getattr(env, name)(*args, **kwargs)`` of every environment (its value if not callable)."""
        out = []
        for env in self.envs:
            attr = getattr(env, name)
            out.append(attr(*args, **kwargs) if callable(attr) else attr)
        return tuple(out)

    def get_attr(self, name: str) -> tuple[Any, ...]:
        """An attribute of every environment."""
        return tuple(getattr(env, name) for env in self.envs)

    def close_extras(self, **kwargs: Any) -> None:
        """Close every environment (none if construction failed before they were built)."""
        for env in getattr(self, "envs", ()):
            env.close()

    # ------------------------------------------------------------------------------------------------ internals
    def _check_actions(self, actions: Any) -> IntArray:
        """``(N,)`` plan indices of the actions; raises naming the environment of a bad or masked one."""
        a = np.asarray(actions)
        first = self.envs[0]
        if first.action_encoding == "multi":  # (N, T) waveforms per transmitter -> plan indices
            dims = first.action_dims
            if a.shape != (self.num_envs, len(dims)) or a.dtype.kind not in "iu":
                raise ValueError(
                    f"actions={actions!r}: must be ({self.num_envs}, {len(dims)}) integers (a waveform per "
                    f"transmitter), each in [0, {dims[0] - 1}]"
                )
            bad_digit = ((a < 0) | (a >= dims[0])).any(axis=1)
            if bad_digit.any():
                e = int(np.flatnonzero(bad_digit)[0])
                try:
                    self.envs[e]._check_action(a[e])  # raises with the single env's message
                except ValueError as err:
                    raise ValueError(f"actions[{e}]: {err}") from None
            plans = np.ravel_multi_index(tuple(a.T), dims)
            masked = ~self._mask[plans]
            if masked.any():
                e = int(np.flatnonzero(masked)[0])
                try:
                    self.envs[e]._check_action(a[e])
                except ValueError as err:
                    raise ValueError(f"actions[{e}]: {err}") from None
            return plans.astype(np.int64)
        if a.shape != (self.num_envs,) or a.dtype.kind not in "iu":
            raise ValueError(f"actions={actions!r}: must be {self.num_envs} integers in [0, {len(self.plans) - 1}]")
        bad = (a < 0) | (a >= len(self.plans))
        if not bad.any():
            bad = ~self._mask[a]
        if bad.any():
            e = int(np.flatnonzero(bad)[0])
            try:
                self.envs[e]._check_action(int(a[e]))  # raises with the single env's message
            except ValueError as err:
                raise ValueError(f"actions[{e}]: {err}") from None
        return a.astype(np.int64)

    def _scan(self, envs: IntArray, actions: IntArray) -> None:
        """Sense and track the next scan of the environments ``envs`` with ``actions`` (``Simulator.step``'s flow)."""
        if envs.size == 0:
            return
        times, ks = np.zeros(envs.size), np.zeros(envs.size, np.int64)
        episodes, sensed_plans, delivers = [], [], []
        for j, (e, a) in enumerate(zip(envs.tolist(), actions.tolist(), strict=True)):
            env = self.envs[e]
            sim = env.sim
            if not env._started:
                raise RuntimeError("step() before reset(): call reset() to start the episodes")
            if sim.done:
                raise RuntimeError(f"environment {e}: step() after its episode ended; reset it first")
            plan = self.plans[a]
            ready = env.ready_rx
            sim.k += 1
            times[j] = sim.k * sim.cfg.sensing.scan_period_s
            ks[j] = sim.k
            delivering = plan.active_rx if ready is None else plan.active_rx & ready
            sensed = ScanPlan(plan.waveform, delivering) if ready is not None and delivering.any() else plan
            sim._plan = sensed
            episodes.append(sim.episode)
            sensed_plans.append(sensed)
            delivers.append(bool(delivering.any()))
            if env.receiver_warmup:
                env._ready_rx = plan.active_rx.copy()
        sensed_dets = sense_many(self.sensor, episodes, ks, sensed_plans, times)  # every formed pair draws: CRN
        dets = [d if ok else () for d, ok in zip(sensed_dets, delivers, strict=True)]
        self._tracker.step(dets, times, ks, self._waveforms[actions], self._pd, envs)
        for j, (e, a) in enumerate(zip(envs.tolist(), actions.tolist(), strict=True)):
            env = self.envs[e]
            env._previous = a
            env._last = ScanResult(int(ks[j]), float(times[j]), dets[j], env.sim.tracker.tracks)

    def _pd(self, tx: int, rx: int, waveform: int, positions: FloatArray) -> FloatArray:
        """The tracker's detection probability at pair (tx, rx) with ``waveform`` (``Simulator._pd``)."""
        tc = self.envs[0].sim.tracker_cfg
        pd = self.sensor.detection_probability_at(tx, rx, positions, waveform, tc.assumed_rcs_m2, tc.assumed_swerling)
        return np.minimum(pd, tc.max_detection_probability)

    def _lookahead(self, envs: IntArray, all_ready: bool = False) -> FloatArray:
        """``(E, A)`` the lookahead costs of the environments ``envs`` (``lookahead.lookahead_costs``), batched."""
        A = len(self.plans)
        period = self.envs[0].cfg.sensing.scan_period_s
        ks = np.array([self.envs[e].sim.k + 1 for e in envs.tolist()], np.int64)
        x, P, counts_a = self._tracker.scored_predictions(envs, ks * period, ks)
        costs = np.zeros((envs.size, A))
        if not x.shape[0]:
            return costs
        first = self.envs[0]
        delivering = None
        if first.receiver_warmup and not all_ready:
            listening = np.array([p.active_rx for p in self.plans])  # (A, R)
            ready = np.array([self.envs[e]._ready_rx for e in envs.tolist()])  # (E, R)
            delivering = listening[:, None, :] & np.repeat(ready, counts_a, axis=0)[None]
        traces = position_trace(
            expected_posterior(x, P, self.sensor, first.sim.tracker, self.plans, first.lookahead_q2, delivering)
        )  # (A, N)
        has = counts_a > 0
        start = np.concatenate([[0], np.cumsum(counts_a[has])[:-1]])
        costs[has] = (np.add.reduceat(traces, start, axis=1) / counts_a[has]).T
        return costs

    def _outputs(self, envs: IntArray, actions: IntArray) -> tuple[FloatArray, dict[str, np.ndarray], Any]:
        """Rewards ``(E,)``, info arrays and observations of the environments ``envs`` after their scan, batched.

        ``envs.outputs`` on every environment's tracks at once (the single env's own functions, so env by env the
        same numbers); the lookahead parts of the observation from one batched lookahead.
        """
        first = self.envs[0]
        trs = [self.envs[e].sim.tracker.tracks for e in envs.tolist()]
        sizes = [len(t) for t in trs]
        confirmed, existence, mu, x, P = (
            np.concatenate([getattr(t, f) for t in trs]) for f in ("confirmed", "existence", "mu", "x", "P")
        )
        xc, Pc = compiled_combine(mu, x, P)
        ks = np.array([self.envs[e].sim.k for e in envs.tolist()], np.int64)
        targets = []
        for e, k in zip(envs.tolist(), ks.tolist(), strict=True):
            truth = self.envs[e].sim.truth
            targets.append(truth.states[k][truth.alive[k]][:, 0:3:2])  # (x, y) of the alive ones
        summ = scan_summaries(
            _offsets(sizes), confirmed, existence, mu, xc, Pc, _offsets([t.shape[0] for t in targets]),
            np.ascontiguousarray(np.concatenate(targets)), first.cover_gate_m, first.cover_gate_m * 2,
            first._centre, first._half, first._v_max, first.n_slots, first._n_targets,
        )  # fmt: skip
        rewards, info = rewards_and_infos(
            summ, ks, first.plan_energy_j[actions], first.missed_target_penalty_m2, first.energy_cost_per_j
        )
        extra: dict[str, FloatArray] = {}
        if first.include_lookahead:
            extra["lookahead"] = _scaled_cost(self._lookahead(envs))
            if first.receiver_warmup:
                extra["lookahead_all_ready"] = _scaled_cost(self._lookahead(envs, all_ready=True))
        if first.receiver_warmup:
            extra["ready_receivers"] = np.array([self.envs[e]._ready_rx for e in envs.tolist()], dtype=float)
        feats = summ[-1]
        if first._relative_scene is not None:  # the summaries' slots are the absolute ones
            feats = relative_track_features_batched(
                _offsets(sizes), existence, confirmed, mu, xc, Pc, *first._relative_scene, first._v_max, first.n_slots
            )
        obs = observations(feats, actions, len(self.plans), extra, first.obs_kind, OBS_BOUND, ks, first.action_dims)
        return rewards, info, obs

    def _set_rows(self, rows: int | IntArray, obs: Any) -> None:
        """Write observations into the batched ones: one env's (``rows`` an int) or a batch's (``rows`` ``(E,)``)."""
        if isinstance(self._observations, dict):
            for k, v in obs.items():
                self._observations[k][rows] = v
        else:
            self._observations[rows] = obs

    def _row(self, e: int) -> Any:
        """Environment e's current observation (a view), in the single env's form."""
        if isinstance(self._observations, dict):
            return {k: v[e] for k, v in self._observations.items()}
        return self._observations[e]

    def _copy(self) -> Any:
        return _deep(self._observations)


def _offsets(sizes: list[int]) -> IntArray:
    """``(E + 1,)`` row offsets of E consecutive blocks of ``sizes`` rows."""
    out = np.zeros(len(sizes) + 1, np.int64)
    np.cumsum(sizes, out=out[1:])
    return out


def _stacked_infos(
    reset_infos: list[dict[str, Any] | None], arrays: dict[str, np.ndarray] | None, row: dict[int, int]
) -> dict[str, Any]:
    """The vector info: env e's entries from ``arrays`` row ``row[e]`` (a scan) or from ``reset_infos[e]`` (a reset).

    The single env's keys, shapes and types (``VectorEnv._add_info``'s dtypes: a Python scalar's type, an array's
    dtype), with all-True ``_key`` masks.
    """
    n = len(reset_infos)
    some = arrays if arrays is not None else next(i for i in reset_infos if i is not None)
    out: dict[str, Any] = {}
    for key in some:
        if arrays is not None:
            col = arrays[key]
            full = np.zeros((n, *col.shape[1:]), dtype=col.dtype)
            full[list(row)] = col[list(row.values())]
        else:
            first = reset_infos[0][key]
            full = np.zeros((n, *np.shape(first)), dtype=first.dtype if isinstance(first, np.ndarray) else type(first))
        for e, info in enumerate(reset_infos):
            if info is not None:
                full[e] = info[key]
        out[key] = full
        out[f"_{key}"] = np.ones(n, dtype=np.bool_)
    return out


def _deep(obs: Any) -> Any:
    """A copy of a batched observation (array or dict of arrays)."""
    if isinstance(obs, dict):
        return {k: _deep(v) for k, v in obs.items()}
    return np.copy(obs)
