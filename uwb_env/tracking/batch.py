r"""N VS-IMM / LMIPDA trackers stepped together: one compiled call per stage over every environment's tracks.

A batched vector env (``uwb_env.envs.vector``) holds one ``Tracker`` per environment (each keeps its own tracks,
candidates, ids and clock) and steps them with :class:`BatchedTracker`. Each stage of ``Tracker.step`` runs once
for all environments, on their tracks concatenated (environment e owns rows ``start[e]:start[e + 1]``; after each
scan every tracker's track set is a view of its block):

1. prediction: ``compiled.predict_models`` over the rows of every environment that shares a period and a model set
   (in lockstep: all of them), existence and age vectorised; an environment whose model set switches this scan
   (VS-IMM, rare) predicts with the tracker's own switch rule;
2. the sensor model's detection probabilities: one call per pair and waveform over the tracks of every environment
   that sends it (``pd_model(tx, rx, waveform, positions)``);
3. pair by pair, in the sensor's pair order (each environment's own order, since detections come sorted by pair):
   ``compiled.receiver_update_batch``, the LMIPDA + PDA update of each environment's tracks with its own
   detections of the pair (LMIPDA couples tracks within one environment only);
4. initiation from the unused detections: ``initiation.range_only_initiation``, every range-only environment in one
   compiled call (an environment with azimuth or fused-position detections initiates with ``Tracker._initiate``);
5. the new tentative tracks appended, confirmation and deletion (``tracker.confirm_and_keep``) over all rows.

Every environment gets the numbers its own ``Tracker.step`` would give, to the bit (the same compiled kernels on
the same rows, the same operations in the same order; ``tests/test_batched_vector_env.py`` compares the trackers'
whole state).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from uwb_env.sensing.records import Detections
from uwb_env.tracking import compiled
from uwb_env.tracking.initiation import initiate_compiled, offsets
from uwb_env.tracking.lmipda import predict_existence
from uwb_env.tracking.tracker import Tracker, _Candidates, confirm_and_keep
from uwb_env.tracking.trackset import FIELDS as _FIELDS
from uwb_env.tracking.trackset import TrackSet
from uwb_env.typing import FloatArray, IntArray

BatchPdModel = Callable[[int, int, int, FloatArray], FloatArray]
"""``(tx, rx, waveform, positions (n, 2)) -> Pd (n,)``: the sensor model's detection probability (capped)."""


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
        start, fields = self._gather(trs)
        self._predict(trs, start, fields, times_s, scan_indices)
        pd = self._detection_probabilities(trs, fields, start, detections, waveforms, pd_model)
        unused = self._update(trs, fields, start, detections, pd)
        new = self._initiate(trs, unused, times_s, scan_indices)
        self._confirm_and_prune(trs, new, scan_indices)

    def scored_predictions(
        self, which: IntArray, times_s: FloatArray, scan_indices: IntArray
    ) -> tuple[FloatArray, FloatArray, IntArray]:
        """Every environment's ``Tracker.scored_prediction`` at its next scan, in one compiled prediction.

        ``which`` ``(E,)`` the environments, ``times_s``, ``scan_indices`` their next scan. Returns the scored tracks'
        combined x ``(n, 6)``, P ``(n, 6, 6)`` concatenated, and each environment's count ``(E,)`` (0: no track).
        """
        trs = [self.trackers[e] for e in which.tolist()]
        tracks = [tr.tracks for tr in trs]
        sizes = np.array([len(t) for t in tracks], np.int64)
        if not sizes.any():
            return np.zeros((0, 6)), np.zeros((0, 6, 6)), np.zeros(which.size, np.int64)
        confirmed = np.concatenate([t.confirmed for t in tracks])
        owner = np.repeat(np.arange(which.size), sizes)
        any_confirmed = np.zeros(which.size, bool)
        any_confirmed[owner[confirmed]] = True
        keep = np.where(any_confirmed[owner], confirmed, ~confirmed)  # the confirmed ones, else every one
        mu, active, x, P = (np.concatenate([getattr(t, f) for t in tracks])[keep] for f in ("mu", "active", "x", "P"))
        counts = np.bincount(owner[keep], minlength=which.size)
        self._predict_models(trs, offsets(counts), mu, active, x, P, times_s, scan_indices)
        xc, Pc = compiled.combine(mu, x, P)
        return xc, Pc, counts

    # --------------------------------------------------------------------------------------------- stages
    def _initiate(
        self,
        trs: list[Tracker],
        unused: list[list[tuple[Detections, np.ndarray]]],
        times_s: FloatArray,
        scan_indices: IntArray,
    ) -> tuple[FloatArray, FloatArray, IntArray]:
        """Stage 4: initiation from the unused detections, one compiled call for the range-only environments.

        An environment with a free detection that carries an azimuth or is a fused position initiates on its own
        (``Tracker._initiate``, which appends its tracks); the others go through ``initiation.initiate_compiled``
        together. Returns their new tracks' states ``x (n, 6)``, ``P (n, 6, 6)`` in environment order and how many
        each environment gets ``(E,)`` (appended by :meth:`_confirm_and_prune`).
        """
        cfg = self.cfg
        batch, groups = [], []
        for j, (tr, pairs) in enumerate(zip(trs, unused, strict=True)):
            free = [(d, f) for d, f in pairs if f.any()]
            if any(d.measurement_names == ("x", "y") or "azimuth" in d.measurement_names for d, _ in free):
                tr._initiate(pairs, float(times_s[j]), int(scan_indices[j]))
            else:
                batch.append(j)
                groups.append(free)
        if not batch:
            return np.zeros((0, 6)), np.zeros((0, 6, 6)), np.zeros(len(trs), np.int64)
        tr0 = trs[batch[0]]
        x, P, new_start, rest_p, rest_cov, rest_start = initiate_compiled(
            groups,
            [None] * len(batch),
            [trs[j]._previous for j in batch],
            [float(times_s[j]) for j in batch],
            tr0.tx_pos,
            tr0.rx_pos,
            tr0.area,
            tr0._starts,
            tr0._gates[2],
            cfg,
        )
        for i, j in enumerate(batch):
            s = slice(rest_start[i], rest_start[i + 1])
            trs[j]._previous = _Candidates(rest_p[s], rest_cov[s], float(times_s[j]))
        counts = np.zeros(len(trs), np.int64)
        counts[batch] = np.diff(new_start)
        return x, P, counts

    def _predict(
        self, trs: list[Tracker], start: IntArray, f: dict[str, np.ndarray], times_s: FloatArray, scan_indices: IntArray
    ) -> None:
        """Stage 1: IMM mixing and prediction (in place in ``f``), existence and age, of every tracker with tracks."""
        had = [tr._time is not None for tr in trs]
        self._predict_models(trs, start, f["mu"], f["active"], f["x"], f["P"], times_s, scan_indices)
        for tr, t_now in zip(trs, times_s.tolist(), strict=True):
            tr._time = t_now
        rows = np.repeat(np.array(had, bool), np.diff(start))  # every track's tracker had a clock: all of them
        f["existence"][rows] = predict_existence(f["existence"][rows], self.cfg.survival_probability)
        f["age"][rows] += 1

    def _predict_models(
        self,
        trs: list[Tracker],
        start: IntArray,
        mu: FloatArray,
        active: np.ndarray,
        x: FloatArray,
        P: FloatArray,
        times_s: FloatArray,
        scan_indices: IntArray,
    ) -> None:
        """``Tracker._predict_models`` of the rows ``start[j]:start[j + 1]`` of tracker j, to ``times_s[j]``, in place.

        Trackers without a clock (nothing to predict from) are skipped; one whose model set switches at its scan
        (VS-IMM, rare) predicts on its own with the switch rule; the rest in one compiled call per (period, set).
        """
        owner = np.repeat(np.arange(len(trs)), np.diff(start))
        groups: dict[tuple[float, bytes], list[int]] = {}
        for k in np.unique(scan_indices).tolist():  # in lockstep: one scan index
            mask = trs[0]._active_mask(k)  # one configuration: the same model set at a scan
            at_k = scan_indices == k
            switching = np.zeros(len(trs), bool)
            switching[owner[(active != mask).any(axis=1) & at_k[owner]]] = True
            for j in np.flatnonzero(at_k).tolist():
                tr = trs[j]
                if tr._time is None or start[j + 1] == start[j]:
                    continue
                dt = float(times_s[j]) - tr._time
                if switching[j]:
                    s = slice(start[j], start[j + 1])
                    mu[s], active[s], x[s], P[s] = tr._predict_models(
                        mu[s].copy(), active[s].copy(), x[s].copy(), P[s].copy(), dt, k
                    )
                else:
                    groups.setdefault((round(dt, 12), mask.tobytes()), []).append(j)
        for (_, key), members in groups.items():
            tr0 = trs[members[0]]
            mask = np.frombuffer(key, dtype=bool)
            Pi, F, Q = tr0._restricted_matrices(float(times_s[members[0]]) - tr0._time, mask)
            a = tr0._active_index(mask)
            if int(np.diff(start)[members].sum()) == mu.shape[0]:  # every row (lockstep): in place
                compiled.predict_models(mu, Pi, x, P, F, Q, a)
            else:
                rows = np.concatenate([np.arange(start[j], start[j + 1]) for j in members])
                mu_g, x_g, P_g = mu[rows], x[rows], P[rows]  # copies, predicted in place
                compiled.predict_models(mu_g, Pi, x_g, P_g, F, Q, a)
                mu[rows], x[rows], P[rows] = mu_g, x_g, P_g

    def _confirm_and_prune(
        self, trs: list[Tracker], new: tuple[FloatArray, FloatArray, IntArray], scan_indices: IntArray
    ) -> None:
        """Stage 5: the new tentative tracks appended, then confirmation and deletion, over every environment at once.

        The new tracks as ``Tracker._append_tracks`` makes them (fresh ids, existence ``initial_existence``, uniform
        model probabilities over the scan's set, every model at the initiated state); then ``tracker.confirm_and_keep``
        on all rows; each tracker's tracks become views of what is kept.
        """
        x_new, P_new, counts = new
        tracks = [tr.tracks for tr in trs]
        old = np.array([len(t) for t in tracks], np.int64)
        if not (old.sum() + counts.sum()):
            return
        fresh = self._fresh_tracks(trs, x_new, P_new, counts, scan_indices)
        new_at = offsets(counts)
        fields = {}
        for f in _FIELDS:
            pieces = []
            for j, t in enumerate(tracks):
                pieces.append(getattr(t, f))
                if counts[j]:
                    pieces.append(fresh[f][new_at[j] : new_at[j + 1]])
            fields[f] = np.concatenate(pieces)
        x, P = compiled.combine(fields["mu"], fields["x"], fields["P"])
        fields["confirmed"], keep = confirm_and_keep(
            self.cfg, trs[0].area, fields["existence"], fields["confirmed"], fields["age"], x, P
        )
        owner = np.repeat(np.arange(len(trs)), old + counts)
        if not keep.all():
            index = np.flatnonzero(keep)
            fields = {f: v.take(index, axis=0) for f, v in fields.items()}
            owner = owner[index]
        start = offsets(np.bincount(owner, minlength=len(trs)))
        for j, tr in enumerate(trs):
            s = slice(start[j], start[j + 1])
            tr.tracks = TrackSet(*(fields[f][s] for f in _FIELDS))

    def _fresh_tracks(
        self, trs: list[Tracker], x: FloatArray, P: FloatArray, counts: IntArray, scan_indices: IntArray
    ) -> dict[str, np.ndarray]:
        """The fields of the new tentative tracks (``Tracker._append_tracks``), ``counts[j]`` for tracker j in order."""
        n = int(counts.sum())
        r = len(self.cfg.models)
        which = np.flatnonzero(counts)
        first_id = np.array([trs[j]._next_id for j in which.tolist()], np.int64)
        for j, c in zip(which.tolist(), counts[which].tolist(), strict=True):
            trs[j]._next_id += c
        offset = np.arange(n) - np.repeat(offsets(counts[which])[:-1], counts[which])
        masks = np.array([trs[j]._active_mask(int(scan_indices[j])) for j in which.tolist()]).reshape(-1, r)
        mask = np.repeat(masks, counts[which], axis=0)
        return {
            "ids": np.repeat(first_id, counts[which]) + offset,
            "confirmed": np.zeros(n, bool),
            "age": np.zeros(n, np.int64),
            "born": np.repeat(np.asarray(scan_indices, np.int64)[which], counts[which]),
            "existence": np.full(n, self.cfg.initial_existence),
            "mu": mask / mask.sum(axis=1, keepdims=True),
            "active": mask,
            "x": np.repeat(x[:, None], r, axis=1),
            "P": np.repeat(P[:, None], r, axis=1),
        }

    @staticmethod
    def _gather(trs: list[Tracker]) -> tuple[IntArray, dict[str, np.ndarray]]:
        """Every tracker's tracks concatenated (row offsets, fields); each tracker's tracks become views into them."""
        tracks = [tr.tracks for tr in trs]
        start = offsets([len(t) for t in tracks])
        fields = {f: np.concatenate([getattr(t, f) for t in tracks]) for f in _FIELDS}
        for e, tr in enumerate(trs):
            s = slice(start[e], start[e + 1])
            tr.tracks = TrackSet(*(fields[f][s] for f in _FIELDS))
        return start, fields

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
        has_tracks = (start[1:] > start[:-1]).tolist()
        floor2 = cfg.range_rate_noise_floor_mps**2
        # each environment's detections are sorted by pair, so the sorted pairs keep every environment's order
        for key in sorted(by_pair):
            members = by_pair[key]
            upd = [(e, d) for e, d in members if has_tracks[e] and len(d)]
            got, det_start, row = None, None, {}
            if upd:
                envs = np.array([e for e, _ in upd], np.int64)
                dets = [d for _, d in upd]
                names = dets[0].measurement_names
                kinds, wm, wc, sigma_scale, use_ukf = trs[upd[0][0]].compiled_filter_args(names)
                det_start = offsets([len(d) for d in dets])
                R = np.concatenate([d.R for d in dets]).astype(float)  # a copy: the floor is added to it
                if floor2 > 0.0 and "range_rate" in names:  # Tracker._with_floor
                    j = names.index("range_rate")
                    R[:, j, j] += floor2
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
                    R,
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
                free = ~got
                row = {e: j for j, e in enumerate(envs.tolist())}
            for e, d in members:
                j = row.get(e)
                unused[e].append((d, np.ones(len(d), bool) if j is None else free[det_start[j] : det_start[j + 1]]))
        return unused  # the trackers' existence arrays are views of fields["existence"], updated in place
