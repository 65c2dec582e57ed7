r"""N VS-IMM / LMIPDA trackers stepped together: one compiled call per stage over every environment's tracks.

A batched vector env (``uwb_env.envs.vector``) holds one ``Tracker`` per environment (each keeps its own tracks,
candidates, ids and clock) and steps them with :class:`BatchedTracker`. Each stage of ``Tracker.step`` runs once
for all environments, on their tracks concatenated (environment e owns rows ``start[e]:start[e + 1]``):

1. prediction: ``compiled.predict_models`` over the tracks of every environment that shares a period and a model
   set (in lockstep: all of them), existence and age vectorised; an environment whose model set switches this scan
   (VS-IMM, rare) predicts on its own with the tracker's switch rule;
2. the sensor model's detection probabilities: one call per pair and waveform over the tracks of every environment
   that sends it (``pd_model(tx, rx, waveform, positions)``);
3. pair by pair, in the sensor's pair order (each environment's own order, since detections come sorted by pair):
   ``compiled.receiver_update_batch``, the LMIPDA + PDA update of each environment's tracks with its own
   detections of the pair (LMIPDA couples tracks within one environment only);
4. initiation, confirmation and deletion: each tracker's own code (``Tracker._initiate``,
   ``Tracker._confirm_and_prune``) on its unused detections.

Every environment gets the numbers its own ``Tracker.step`` would give (the same compiled kernels on the same
rows; ``tests/test_batched_vector_env.py``). Stage 4 is still a Python call per environment: what remains of the
per-environment cost (``benchmarks/vector_env_throughput.py``).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from uwb_env.sensing.records import Detections
from uwb_env.tracking import compiled
from uwb_env.tracking.lmipda import predict_existence
from uwb_env.tracking.tracker import Tracker
from uwb_env.tracking.trackset import TrackSet
from uwb_env.typing import FloatArray, IntArray

BatchPdModel = Callable[[int, int, int, FloatArray], FloatArray]
"""``(tx, rx, waveform, positions (n, 2)) -> Pd (n,)``: the sensor model's detection probability (capped)."""


def _starts(sizes: Sequence[int]) -> IntArray:
    """``(E + 1,)`` row offsets of E consecutive blocks of ``sizes`` rows."""
    start = np.zeros(len(sizes) + 1, np.int64)
    np.cumsum(sizes, out=start[1:])
    return start


class BatchedTracker:
    """Steps the ``trackers`` (one per environment, all of one configuration) together (module docstring)."""

    def __init__(self, trackers: Sequence[Tracker]) -> None:
        if not trackers:
            raise ValueError("trackers=[]: must hold at least one Tracker")
        kinds = {type(t) for t in trackers}
        if kinds != {Tracker}:
            got = sorted(k.__name__ for k in kinds)
            raise TypeError(f"trackers: must all be {Tracker.__name__} (kind 'imm-lmipda'), got {got}")
        self.trackers = list(trackers)
        self.cfg = trackers[0].cfg

    def step(
        self,
        detections: Sequence[Sequence[Detections]],
        times_s: FloatArray,
        scan_indices: IntArray,
        waveforms: IntArray,
        pd_model: BatchPdModel | None,
        which: IntArray | None = None,
    ) -> None:
        """One scan of the environments ``which`` (default all): ``detections[j]`` of environment ``which[j]``.

        ``times_s``, ``scan_indices`` ``(E,)``: each one's scan time and index; ``waveforms`` ``(E, T)`` the waveform
        each transmitter sent (for the detection probabilities). The trackers' ``tracks`` hold the result.
        """
        trs = self.trackers if which is None else [self.trackers[e] for e in which]
        self._predict(trs, times_s, scan_indices)
        tracks = [tr.tracks for tr in trs]
        start = _starts([len(t) for t in tracks])
        fields = self._gather(trs, tracks, start)
        pd = self._detection_probabilities(trs, fields, start, detections, waveforms, pd_model)
        unused = self._update(trs, fields, start, detections, pd)
        for j, tr in enumerate(trs):  # initiation and track management: per environment (module docstring)
            tr._initiate(unused[j], float(times_s[j]), int(scan_indices[j]))
            tr._confirm_and_prune()

    # --------------------------------------------------------------------------------------------- stages
    def _predict(self, trs: list[Tracker], times_s: FloatArray, scan_indices: IntArray) -> None:
        """Stage 1: IMM mixing and prediction of every tracker that has tracks, grouped by (period, model set)."""
        groups: dict[tuple[float, bytes], list[tuple[Tracker, float]]] = {}
        for j, tr in enumerate(trs):
            t_now = float(times_s[j])
            if tr._time is not None and len(tr.tracks):
                dt = t_now - tr._time
                mask = tr._active_mask(int(scan_indices[j]))
                if (tr.tracks.active != mask).any():  # VS-IMM set switch: the tracker's own rule (rare)
                    tr._predict(dt, int(scan_indices[j]))
                else:
                    groups.setdefault((round(dt, 12), mask.tobytes()), []).append((tr, dt))
            tr._time = t_now
            tr._pd_cache = {}
        ps = self.cfg.survival_probability
        for members in groups.values():
            tr0, dt0 = members[0]
            mask = tr0.tracks.active[0]
            a = tr0._active_index(mask)
            Pi, F, Q = tr0._restricted_matrices(dt0, mask)  # a function of the rounded period (Tracker)
            ts = [tr.tracks for tr, _ in members]
            start = _starts([len(t) for t in ts])
            mu, x, P = (np.concatenate([getattr(t, f) for t in ts]) for f in ("mu", "x", "P"))
            compiled.predict_models(mu, Pi, x, P, F, Q, a)
            for e, t in enumerate(ts):
                s = slice(start[e], start[e + 1])
                t.mu, t.x, t.P = mu[s], x[s], P[s]
                t.existence = predict_existence(t.existence, ps)
                t.age = t.age + 1

    @staticmethod
    def _gather(trs: list[Tracker], tracks: list[TrackSet], start: IntArray) -> dict[str, np.ndarray]:
        """The tracks of every environment concatenated; each tracker's arrays become views into them."""
        fields = {f: np.concatenate([getattr(t, f) for t in tracks]) for f in ("mu", "active", "x", "P", "existence")}
        for e, t in enumerate(tracks):
            s = slice(start[e], start[e + 1])
            t.mu, t.active, t.x, t.P = fields["mu"][s], fields["active"][s], fields["x"][s], fields["P"][s]
        return fields

    def _detection_probabilities(
        self,
        trs: list[Tracker],
        fields: dict[str, np.ndarray],
        start: IntArray,
        detections: Sequence[Sequence[Detections]],
        waveforms: IntArray,
        pd_model: BatchPdModel | None,
    ) -> dict[tuple[int, int], FloatArray]:
        """Stage 2: ``(N,)`` Pd of every track at each pair some environment sensed (at the predicted positions).

        Rows of environments that did not sense the pair are left 0 (unused).
        """
        n = start[-1]
        if pd_model is None:
            return {}
        pos = compiled.combine(fields["mu"], fields["x"], fields["P"])[0][:, [0, 2]]
        owner = np.repeat(np.arange(len(trs)), np.diff(start))
        pairs = sorted({(d.tx, d.rx) for dets in detections for d in dets})
        out = {}
        for tx, rx in pairs:  # the formed pairs: a handful
            pd = np.zeros(n)
            for w in np.unique(waveforms[:, tx]).tolist():  # the waveforms sent: a handful
                rows = np.flatnonzero(waveforms[owner, tx] == w)
                if rows.size:
                    pd[rows] = pd_model(tx, rx, w, pos[rows])
            out[(tx, rx)] = pd
        return out

    def _update(
        self,
        trs: list[Tracker],
        fields: dict[str, np.ndarray],
        start: IntArray,
        detections: Sequence[Sequence[Detections]],
        pd: dict[tuple[int, int], FloatArray],
    ) -> list[list[tuple[Detections, np.ndarray]]]:
        """Stage 3: pair by pair, every environment's LMIPDA + PDA update; returns each one's unused detections."""
        cfg = self.cfg
        unused: list[list[tuple[Detections, np.ndarray]]] = [[] for _ in trs]
        by_pair: dict[tuple[int, int], list[tuple[int, Detections]]] = {}
        for e, dets in enumerate(detections):
            for d in dets:
                by_pair.setdefault((d.tx, d.rx), []).append((e, d))
        # each environment's detections are sorted by pair, so the sorted pairs keep every environment's order
        for key in sorted(by_pair):
            members = by_pair[key]
            upd = [(e, trs[e]._with_floor(d)) for e, d in members if start[e + 1] > start[e] and len(d)]
            taken = {}
            if upd:
                envs = np.array([e for e, _ in upd], np.int64)
                dets = [d for _, d in upd]
                names = dets[0].measurement_names
                kinds, wm, wc, sigma_scale, use_ukf = trs[upd[0][0]].compiled_filter_args(names)
                det_start = _starts([len(d) for d in dets])
                pd_pair = pd[key] if pd else np.full(start[-1], cfg.detection_probability)
                tr0 = trs[upd[0][0]]
                got, ok = compiled.receiver_update_batch(
                    fields["x"],
                    fields["P"],
                    fields["mu"],
                    fields["active"],
                    start,
                    envs,
                    fields["existence"],
                    pd_pair,
                    np.ascontiguousarray(np.concatenate([d.z for d in dets]), dtype=float),
                    np.ascontiguousarray(np.concatenate([d.R for d in dets]), dtype=float),
                    np.maximum(np.concatenate([d.clutter_intensity for d in dets]), cfg.min_clutter_intensity),
                    det_start,
                    kinds,
                    tr0.tx_pos[key[0]],
                    tr0.rx_pos[key[1]],
                    wm,
                    wc,
                    sigma_scale,
                    use_ukf,
                    tr0._gates[len(names)],
                    cfg.gate_probability,
                    cfg.fixed_existence,
                    np.array([d.range_rate_period_mps for d in dets], dtype=float),
                )
                if not ok:
                    raise np.linalg.LinAlgError("tracker update: a covariance is not positive definite")
                taken = {e: got[det_start[j] : det_start[j + 1]] for j, e in enumerate(envs.tolist())}
            for e, d in members:
                used = taken.get(e)
                unused[e].append((d, np.ones(len(d), bool) if used is None else ~used))
        for e, tr in enumerate(trs):
            tr.tracks.existence = fields["existence"][start[e] : start[e + 1]].copy()
        return unused
