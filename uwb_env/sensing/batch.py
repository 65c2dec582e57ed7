"""One scan of several episodes of one parametric sensor at once (the batched vector env, ``uwb_env.envs.vector``).

``sense_many`` gives, episode by episode, what ``ParametricSensor.sense`` gives: each episode's rows of the scan are
selected as ``sense`` selects them, then every episode's rows are sorted (by episode, pair, range), given their
covariances and split per pair in one pass. Plans whose transmitters send different waveforms (or a waveform
without a 1/SNR covariance) go through ``sense`` itself.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from uwb_env.sensing.parametric import _KEY_SPAN, EpisodeSensing, ParametricSensor, _append_block, _columns
from uwb_env.sensing.records import Detections, ScanPlan
from uwb_env.typing import FloatArray, IntArray


def sense_many(
    sensor: ParametricSensor,
    episodes: Sequence[EpisodeSensing],
    scans: IntArray,
    plans: Sequence[ScanPlan],
    times_s: FloatArray,
) -> list[tuple[Detections, ...]]:
    """``[sensor.sense(episodes[j], scans[j], plans[j], times_s[j]) for j]``, batched (module docstring)."""
    m = sensor.library.measurement_dim
    col = _columns(m)
    out: list[tuple[Detections, ...] | None] = [None] * len(episodes)
    parts, sizes, batch, waveform = [], [], [], []
    for j, (ep, k, plan) in enumerate(zip(episodes, scans.tolist(), plans, strict=True)):
        all_active, w0, single, _ = sensor._validate(plan)
        if not single:
            out[j] = sensor.sense(ep, k, plan, float(times_s[j]))
            continue
        active = plan.active_rx
        a, b = ep.clutter_start[k], ep.clutter_start[k + 1]
        hit = ep.target_hit[w0, k]
        if not all_active:
            hit = hit & active[None, :, None]
        target_rows = ep.target_rows[w0, k][hit]
        clutter_rows = ep.clutter_rows[w0, a:b]
        if not all_active:
            clutter_rows = clutter_rows[active[ep.clutter_rx[a:b]]]
        parts += [target_rows, clutter_rows]
        sizes.append(target_rows.shape[0] + clutter_rows.shape[0])
        batch.append(j)
        waveform.append(w0)
    if not batch:
        return out  # type: ignore[return-value]
    rows = np.concatenate(parts)
    env = np.repeat(np.arange(len(batch)), sizes)
    order = np.lexsort((rows[:, 0] * _KEY_SPAN + rows[:, 1], env))  # episode, then pair and range as sense sorts
    rows, env = rows.take(order, axis=0), env[order]
    w = np.asarray(waveform, np.int64)[env]
    snr = rows[:, col["snr"]]
    unit = np.stack([sensor._unit_cov[v] if sensor._unit_cov[v] is not None else np.zeros((m, m))
                     for v in range(len(sensor.library))])  # fmt: skip
    cov = unit[w] / np.minimum(snr, sensor._snr_cap[w])[:, None, None]
    if m == 2 and sensor._migration is not None:  # the range walk's accuracy loss (target rows; 0 means 1)
        d = np.sqrt(np.maximum(rows[:, [col["walk_r"], col["walk_d"]]], 1.0))
        cov = cov * d[:, :, None] * d[:, None, :]
    n_pairs = len(sensor._pair_list)
    keys = env * float(n_pairs) + rows[:, 0]  # small integers: exact
    bounds = np.searchsorted(keys, (np.arange(len(batch))[:, None] * n_pairs + sensor._pair_index[None]).ravel())
    bounds = np.append(bounds, rows.shape[0]).tolist()
    origin = rows[:, col["origin"]].astype(np.int64)
    for i, (j, w0) in enumerate(zip(batch, waveform, strict=True)):
        active = plans[j].active_rx
        dets = []
        for p, (t, r) in enumerate(sensor._pair_list):  # the formed pairs: a small fixed set
            if not active[r]:
                continue
            lo, hi = bounds[i * n_pairs + p], bounds[i * n_pairs + p + 1]
            if sensor._doa_rx[r]:
                z, R = rows[lo:hi, 1 : 2 + m], _append_block(cov[lo:hi], rows[lo:hi, col["az_var"]])
            else:
                z, R = rows[lo:hi, 1 : 1 + m], cov[lo:hi]
            dets.append(
                Detections(
                    tx=t,
                    rx=r,
                    waveform=w0,
                    time_s=float(times_s[j]),
                    z=z,
                    R=R,
                    snr=snr[lo:hi],
                    origin=origin[lo:hi],
                    measurement_names=sensor._names[r],
                    clutter_intensity=rows[lo:hi, col["rho"]],
                    expected_false_alarms=sensor._expected_false[p],
                    range_rate_period_mps=float(sensor.range_rate_period[w0]),
                )
            )
        out[j] = tuple(dets)
    return out  # type: ignore[return-value]
